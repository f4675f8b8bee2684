//! This process's CPU time, for stage timings (`prt-bake bake --verbose`): on a shared
//! machine wall time also counts other tenants, CPU time only this process's work.

/// CPU seconds (user + system) of all of this process's threads so far, from
/// `/proc/self/stat` in clock ticks of 1/100 s (Linux's USER_HZ); `None` where there is no
/// such file (not Linux).
pub fn process_cpu_seconds() -> Option<f64> {
    stat_cpu_seconds("/proc/self/stat")
}

/// CPU seconds (user + system) of the calling thread so far, from `/proc/thread-self/stat`,
/// for a stage that runs beside others; `None` where there is no such file.
pub fn thread_cpu_seconds() -> Option<f64> {
    stat_cpu_seconds("/proc/thread-self/stat")
}

/// utime + stime of a `stat` file of procfs, in seconds.
fn stat_cpu_seconds(path: &str) -> Option<f64> {
    let stat = std::fs::read_to_string(path).ok()?;
    // Fields after the parenthesised command name; utime and stime are fields 14 and 15.
    let fields: Vec<&str> = stat.rsplit_once(')')?.1.split_whitespace().collect();
    let ticks = |i: usize| fields.get(i - 3)?.parse::<f64>().ok();
    Some((ticks(14)? + ticks(15)?) / 100.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A thread's clock counts its own work and no other thread's (spun by CPU time, not wall
    /// time, so that a loaded machine only makes it slower).
    #[test]
    fn a_threads_cpu_time_is_its_own() {
        // Spins until this thread's clock advanced by `seconds`; false if it did not within a
        // minute of wall time.
        let spin = |seconds: f64| {
            let (started, from) = (std::time::Instant::now(), thread_cpu_seconds());
            let mut x = 0u64;
            while started.elapsed().as_secs() < 60 {
                for _ in 0..100_000 {
                    x = std::hint::black_box(x.wrapping_mul(31).wrapping_add(7));
                }
                if thread_cpu_seconds()
                    .zip(from)
                    .is_some_and(|(t, f)| t - f >= seconds)
                {
                    return true;
                }
            }
            false
        };
        let before = thread_cpu_seconds().expect("procfs");
        let other = std::thread::scope(|s| s.spawn(|| spin(0.3)).join().expect("spun"));
        let idle = thread_cpu_seconds().expect("procfs") - before;
        assert!(other, "the other thread's clock did not advance");
        assert!(idle < 0.1, "{idle} s while another thread worked");
        assert!(spin(0.2), "this thread's clock did not advance");
    }
}
