//! `--adaptive auto` on every scene of `scenes/`: full against
//! adaptive shading of the same plan, interleaved in the same run, medians,
//! with auto's choice; on the CPU renderer and on wgpu
//! (`SHADEC_BENCH_GPU=1`). `SHADEC_BENCH_RUNS` repetitions (default 5);
//! `SHADEC_BENCH_LOBES` the Phong programs (default `4,8,16`) besides
//! `examples/fragment_lighting.shd`; `SHADEC_BENCH_SCENES` a comma-separated
//! filter on scene names. `shadec bench --adaptive-scenes` runs the same.
//!
//! `cargo bench --bench adaptive_auto` prints the markdown table.

use std::path::Path;

use shadec::bench::adaptive_scenes::{markdown, programs, run_all, Measure};

fn env_list(name: &str, default: &str) -> Vec<String> {
    std::env::var(name)
        .unwrap_or_else(|_| default.into())
        .split(',')
        .map(|s| s.trim().to_string())
        .filter(|s| !s.is_empty())
        .collect()
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let runs = std::env::var("SHADEC_BENCH_RUNS").ok().and_then(|v| v.parse().ok()).unwrap_or(5);
    let gpu = std::env::var("SHADEC_BENCH_GPU").is_ok_and(|v| v == "1");
    let lobes: Vec<usize> = env_list("SHADEC_BENCH_LOBES", "4,8,16")
        .iter()
        .map(|k| k.parse().expect("SHADEC_BENCH_LOBES: numbers"))
        .collect();
    let programs = programs(root, &lobes).expect("the programs");
    let only = env_list("SHADEC_BENCH_SCENES", "");
    let measure = Measure { runs, cpu: true, gpu, size: None };
    let rows = run_all(&root.join("scenes"), &programs, &measure, &only, &mut |line| eprintln!("{line}"))
        .expect("the scenes");
    println!("{}", markdown(&rows));
}
