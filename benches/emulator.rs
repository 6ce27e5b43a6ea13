//! Emulator throughput for seeds/003 Appendix G and H at 1024×1024, fixed9
//! and f32, one thread and all threads. Results: BENCHMARKS-combiners.md.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use shadec::backends::combiners::emulator::{emulate_into, Inputs};
use shadec::backends::combiners::rc1::parse_and_validate;
use shadec::backends::combiners::CombinerLimits;
use shadec::numerics::Precision;

fn bench(c: &mut Criterion) {
    const W: usize = 1024;
    const H: usize = 1024;
    let t0: Vec<u8> = (0..W * H * 4).map(|i| (i.wrapping_mul(2654435761) >> 13) as u8).collect();
    let t1: Vec<u8> = (0..W * H * 4).map(|i| (i.wrapping_mul(40503) >> 7) as u8).collect();
    let mut out = vec![0u8; W * H * 4];
    let inputs =
        Inputs { width: W, height: H, textures: [Some(&t0), Some(&t1), None, None], ..Inputs::default() };
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let all = rayon::ThreadPoolBuilder::new().build().unwrap();
    let mut group = c.benchmark_group("emulator_1024x1024");
    group.throughput(Throughput::Elements((W * H) as u64));
    group.sample_size(20);
    for name in ["appendix_g", "appendix_h"] {
        let path = format!("{}/tests/data/combiners/{name}.rc", env!("CARGO_MANIFEST_DIR"));
        let text = std::fs::read_to_string(path).unwrap();
        let config = parse_and_validate(&text, &CombinerLimits::GEFORCE256).unwrap();
        for (pname, precision) in [("fixed9", Precision::Fixed9), ("f32", Precision::F32)] {
            for (tname, pool) in [("1thread", &one), ("allthreads", &all)] {
                group.bench_function(format!("{name}/{pname}/{tname}"), |b| {
                    b.iter(|| pool.install(|| emulate_into(&config, &inputs, precision, &mut out).unwrap()))
                });
            }
        }
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
