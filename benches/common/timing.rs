//! The plain timer of the non-criterion benches: the median wall time of
//! `SHADEC_BENCH_RUNS` runs (default `default_runs`) after `warmups` runs.

use std::time::{Duration, Instant};

pub fn median(default_runs: usize, warmups: usize, mut f: impl FnMut()) -> Duration {
    let runs: usize =
        std::env::var("SHADEC_BENCH_RUNS").ok().and_then(|v| v.parse().ok()).unwrap_or(default_runs).max(1);
    for _ in 0..warmups {
        f();
    }
    let mut t: Vec<Duration> = (0..runs)
        .map(|_| {
            let s = Instant::now();
            f();
            s.elapsed()
        })
        .collect();
    t.sort();
    t[runs / 2]
}
