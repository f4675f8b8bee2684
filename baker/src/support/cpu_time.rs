//! This process's CPU time, for stage timings (`prt-bake bake --verbose`): on a shared
//! machine wall time also counts other tenants, CPU time only this process's work.

/// CPU seconds (user + system) of all of this process's threads so far, from
/// `/proc/self/stat` in clock ticks of 1/100 s (Linux's USER_HZ); `None` where there is no
/// such file (not Linux).
pub fn process_cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the parenthesised command name; utime and stime are fields 14 and 15.
    let fields: Vec<&str> = stat.rsplit_once(')')?.1.split_whitespace().collect();
    let ticks = |i: usize| fields.get(i - 3)?.parse::<f64>().ok();
    Some((ticks(14)? + ticks(15)?) / 100.0)
}

/// CPU seconds (user + system) of the calling thread so far (`CLOCK_THREAD_CPUTIME_ID`), for
/// a stage that runs beside others; `None` where the clock cannot be read.
pub fn thread_cpu_seconds() -> Option<f64> {
    let mut now = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime only writes the timespec it is given.
    let ok = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut now) } == 0;
    ok.then_some(now.tv_sec as f64 + now.tv_nsec as f64 * 1e-9)
}
