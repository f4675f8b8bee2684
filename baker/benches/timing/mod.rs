//! CPU-time measurement shared by the benchmarks (`bake.rs`, `lightmap.rs`): CPU time (user +
//! system, all threads) divided by the thread count, best of [`REPEATS`]. On a shared machine
//! wall time also counts other tenants; CPU time counts only this process's work.

/// How many times a measurement is repeated; the best run counts (noise from other tenants
/// only slows runs down).
pub const REPEATS: usize = 3;

/// The least of [`REPEATS`] runs of `run`.
pub fn best_of(mut run: impl FnMut() -> f64) -> f64 {
    (0..REPEATS).map(|_| run()).fold(f64::INFINITY, f64::min)
}

/// CPU seconds (user + system) of all of this process's threads so far, from `/proc/self/stat`
/// in clock ticks of 1/100 s (Linux's USER_HZ on every architecture we build for).
pub fn cpu_seconds() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").expect("read /proc/self/stat");
    // Fields after the parenthesised command name; utime and stime are fields 14 and 15.
    let fields: Vec<&str> = stat
        .rsplit_once(')')
        .expect("a stat line")
        .1
        .split_whitespace()
        .collect();
    let ticks = |i: usize| fields[i - 3].parse::<f64>().expect("a tick count");
    (ticks(14) + ticks(15)) / 100.0
}

/// CPU seconds of `work` divided by the thread count.
pub fn cpu_time(work: impl FnOnce()) -> f64 {
    let before = cpu_seconds();
    work();
    (cpu_seconds() - before) / rayon::current_num_threads() as f64
}
