//! Front-end speed: parse+check of every example, and throughput on a
//! generated ~1 MB program, with baselines measured in the same run (the item
//! splitter alone, which touches every byte once, and pest alone, without
//! building the AST). Results: BENCHMARKS.md.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};

/// A program of about `bytes` bytes: varied statements over declared names.
pub fn generated_program(bytes: usize) -> String {
    let mut s = String::from(
        "vector N : normal;\nvector L : light(0) in tangent;\nvector H : half(0);\nconst kd : rgb = (0.8, 0.6, 0.4);\n\
         texture T, T′ : 2d rgba8 mipmap = image(\"brick.png\");\nshader p(n: scalar = 32) : s → c = kd * max(0, N·L) + (N·H)^n;\n",
    );
    let mut i = 0;
    while s.len() < bytes {
        s.push_str(&format!(
            "let v{i} = max(0, N·L) * kd + (N·H)^{} ⊕ T δu x;\nC δπx ← (C δπx) ⊕[add] (p δ s x * T′ δu′ x.a + v{i});\n",
            i % 64
        ));
        i += 1;
    }
    s
}

fn bench(c: &mut Criterion) {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/examples");
    let mut examples: Vec<(String, String)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "shd"))
        .map(|p| {
            (p.file_stem().unwrap().to_string_lossy().into_owned(), std::fs::read_to_string(&p).unwrap())
        })
        .collect();
    examples.sort();
    let total: usize = examples.iter().map(|(_, t)| t.len()).sum();

    let mut group = c.benchmark_group("examples");
    group.throughput(Throughput::Bytes(total as u64));
    group.bench_function("check_all", |b| {
        b.iter(|| {
            for (_, text) in &examples {
                let (_, d) = shadec::parser::check(text);
                assert!(d.is_empty());
            }
        })
    });
    group.finish();

    let program = generated_program(1 << 20);
    let mut group = c.benchmark_group("generated_1MB");
    group.throughput(Throughput::Bytes(program.len() as u64));
    group.sample_size(10);
    group.bench_function("baseline_split_items", |b| {
        b.iter(|| shadec::parser::bench_support::split_only(&program))
    });
    group.bench_function("baseline_pest_only", |b| {
        b.iter(|| shadec::parser::bench_support::pest_only(&program))
    });
    group.bench_function("parse", |b| b.iter(|| shadec::parser::parse(&program)));
    group.bench_function("check", |b| b.iter(|| shadec::parser::check(&program)));
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
