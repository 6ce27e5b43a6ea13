//! Compile time against program size (issue 3 part 6): parse, lower and
//! plan generated programs of 10 to 100 000 operations for geforce256 and
//! wgsl. `cargo bench --bench compile`; the growth exponent is fitted from
//! the medians and recorded in BENCHMARKS.md.

use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use shadec::profile::Profile;

fn sizes() -> Vec<usize> {
    match std::env::var("SHADEC_BENCH_MAX_OPS") {
        Ok(v) => [10, 100, 1000, 10_000, 100_000]
            .into_iter()
            .filter(|n| *n <= v.parse().unwrap_or(100_000))
            .collect(),
        Err(_) => vec![10, 100, 1000, 10_000, 100_000],
    }
}

fn compile_growth(c: &mut Criterion) {
    for target in ["geforce256", "wgsl"] {
        let profile = Profile::builtin(target).unwrap();
        let mut group = c.benchmark_group(format!("compile/{target}"));
        group
            .sample_size(10)
            .warm_up_time(Duration::from_millis(500))
            .measurement_time(Duration::from_secs(3));
        for n in sizes() {
            let src = shadec::planner::generated_program(n);
            group.bench_with_input(BenchmarkId::from_parameter(n), &src, |b, src| {
                b.iter(|| shadec::compile(src, &profile).expect("generated programs plan"))
            });
        }
        group.finish();
    }
}

/// `SHADEC_GROWTH=1 cargo bench --bench compile`: one timing per size, for a quick look.
fn quick() {
    for target in ["geforce256", "wgsl"] {
        let profile = Profile::builtin(target).unwrap();
        for n in sizes() {
            let src = shadec::planner::generated_program(n);
            let t = Instant::now();
            let plan = shadec::compile(&src, &profile).unwrap();
            println!("{target} {n} ops: {:?} ({} passes)", t.elapsed(), plan.passes.len());
        }
    }
}

fn main_entry(c: &mut Criterion) {
    if std::env::var("SHADEC_GROWTH").is_ok() {
        quick();
    } else {
        compile_growth(c);
    }
}

criterion_group!(benches, main_entry);
criterion_main!(benches);
