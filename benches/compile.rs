//! Compile time against program size: parse, lower and plan
//! programs of 100 to 20 000 statements on geforce256, geforce3 and wgsl,
//! and fit the growth exponent (least squares of log time on log size).
//!
//! The programs are written here, by a small writer of its own, not by the
//! planner's `generated_program`, so that the benchmark does not grow the
//! way the planner was tuned for. Shapes:
//! - `lit`: N accumulation statements `C δπx ← (C δπx) ⊕[add] ((δ pᵢ s x) ⊕
//!   (Tₐ δu x) ⊕ (T_b δu x))`, N lights, eight textures (Pipeline Grammar,
//!   eq. (9), one pass per light);
//! - `wide`: one shader summing N lit terms;
//! - `chain`: one statement, a product of N texture lookups;
//! - `lets`: N `let`s, each added by its own statement;
//! - `lights`: N lights, each a Blinn-Phong highlight added in its own statement;
//! - `shaders`: N shaders of one light, `kᵢ · max(0, N·L)`, each added by its
//!   own statement (each a per-vertex fall-back on the combiner targets, whose
//!   output bound and interpolants were once found anew for every statement).
//!
//! `cargo bench --bench compile`; `SHADEC_BENCH_MAX=N` caps the size,
//! `SHADEC_BENCH_SHAPES=lit,wide` and `SHADEC_BENCH_TARGETS=wgsl` pick.
//! Also times a whole-pipeline compile of a small program (the goal is
//! ≤ 5 ms, so that fuzzing and the language server are fast).

use std::fmt::Write as _;
use std::time::{Duration, Instant};

use shadec::profile::Profile;

const SIZES: [usize; 7] = [100, 300, 1000, 2000, 5000, 10_000, 20_000];
const SHAPES: [&str; 6] = ["lit", "wide", "chain", "lets", "lights", "shaders"];
const TARGETS: [&str; 3] = ["geforce256", "geforce3", "wgsl"];

/// The program of `shape` at size `n`.
fn program(shape: &str, n: usize) -> String {
    let mut s = String::from("vector N : normal;\n");
    let weight = |i: usize| (i % 997 + 1) as f64 / 1000.0;
    let textures = |s: &mut String| {
        for t in 0..8 {
            let _ = writeln!(s, "texture T{t} : 2d rgba8;");
        }
    };
    match shape {
        "lit" => {
            textures(&mut s);
            s += "const kd : rgb = (0.8, 0.6, 0.4);\n";
            for i in 0..n {
                let _ = writeln!(s, "vector L{i} : light({i});");
                let _ = writeln!(s, "shader p{i} : s → c = {:.3} * kd * max(0, N·L{i});", weight(i));
            }
            for i in 0..n {
                let (a, b) = (i % 8, (3 * i + 1) % 8);
                let _ = writeln!(s, "C δπx ← (C δπx) ⊕[add] ((δ p{i} s x) ⊕ (T{a} δu x) ⊕ (T{b} δu x));");
            }
        }
        "wide" => {
            textures(&mut s);
            for l in 0..8 {
                let _ = writeln!(s, "vector L{l} : light({l});");
            }
            let terms: Vec<String> =
                (0..n).map(|i| format!("{:.3} * max(0, N·L{})", weight(i), i % 8)).collect();
            let _ = writeln!(s, "shader p : s → c = {};", terms.join(" + "));
            s += "C δπx ← (δ p s x) ⊕ (T0 δu x);\n";
        }
        "chain" => {
            textures(&mut s);
            let terms: Vec<String> = (0..n).map(|i| format!("(T{} δu x)", i % 8)).collect();
            let _ = writeln!(s, "C δπx ← {};", terms.join(" * "));
        }
        "lets" => {
            textures(&mut s);
            for i in 0..n {
                let _ = writeln!(s, "let a{} = {:.3} * T{} δu x;", name(i), weight(i), i % 8);
            }
            for i in 0..n {
                let _ = writeln!(s, "C δπx ← (C δπx) ⊕[add] a{};", name(i));
            }
        }
        "lights" => {
            s += "vector V : view;\nconst ks : rgb = (1, 1, 1);\n";
            for i in 0..n {
                let _ = writeln!(s, "vector L{i} : light({i});");
                let _ = writeln!(s, "shader p{i} : s → c = ks * max(0, N·normalize(L{i} + V))^16;");
            }
            for i in 0..n {
                let _ = writeln!(s, "C δπx ← (C δπx) ⊕[add] (δ p{i} s x);");
            }
        }
        "shaders" => {
            s += "vector L : light(0);\n";
            for i in 0..n {
                let _ = writeln!(s, "shader g{} : s → c = {:.3} * max(0, N·L);", name(i), weight(i));
            }
            for i in 0..n {
                let _ = writeln!(s, "C δπx ← (C δπx) ⊕[add] (δ g{} s x);", name(i));
            }
        }
        other => panic!("unknown shape {other}"),
    }
    s
}

/// A name of letters only (`aq`): digits after a name read as a subscript.
fn name(mut i: usize) -> String {
    let mut s = String::new();
    loop {
        s.push((b'a' + (i % 26) as u8) as char);
        i /= 26;
        if i == 0 {
            return s;
        }
    }
}

/// Timings of `runs` compiles of `src`: the median wall-clock time, the
/// mean processor time of the process (all threads; on a machine shared
/// with other builds the wall clock also counts waiting for a core), and
/// the passes planned.
fn time(src: &str, profile: &Profile, runs: usize) -> (Duration, Duration, usize) {
    let mut times = Vec::with_capacity(runs);
    let mut passes = 0;
    let cpu_before = process_cpu();
    for _ in 0..runs {
        let t = Instant::now();
        let plan = shadec::compile(src, profile).unwrap_or_else(|d| panic!("{}: {d:?}", profile.name));
        times.push(t.elapsed());
        passes = plan.passes.len();
    }
    let cpu = process_cpu().saturating_sub(cpu_before) / runs as u32;
    times.sort();
    (times[runs / 2], cpu, passes)
}

/// User and system time of this process so far, from `/proc/self/stat`
/// (fields 14 and 15, in ticks of 1/100 s); zero where there is none.
fn process_cpu() -> Duration {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let after_name = stat.rsplit(')').next().unwrap_or_default();
    // After the name: field 3 (the state) first, so utime (14) is the 12th.
    let fields: Vec<&str> = after_name.split_whitespace().collect();
    let field = |i: usize| fields.get(i).and_then(|f| f.parse::<u64>().ok()).unwrap_or(0);
    let ticks = field(11) + field(12);
    Duration::from_millis(ticks * 10)
}

/// The slope of the least-squares line through `(ln n, ln t)`.
fn growth_exponent(points: &[(usize, Duration)]) -> f64 {
    let xy: Vec<(f64, f64)> = points.iter().map(|(n, t)| ((*n as f64).ln(), t.as_secs_f64().ln())).collect();
    let k = xy.len() as f64;
    let (mx, my) = (xy.iter().map(|p| p.0).sum::<f64>() / k, xy.iter().map(|p| p.1).sum::<f64>() / k);
    let sxy: f64 = xy.iter().map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = xy.iter().map(|(x, _)| (x - mx) * (x - mx)).sum();
    sxy / sxx
}

fn chosen<'a>(var: &str, all: &[&'a str]) -> Vec<&'a str> {
    match std::env::var(var) {
        Ok(v) => all.iter().copied().filter(|a| v.split(',').any(|w| w == *a)).collect(),
        Err(_) => all.to_vec(),
    }
}

fn main() {
    // `cargo bench` passes `--bench`; `cargo test --benches` does not: run small.
    let benching = std::env::args().any(|a| a == "--bench");
    let max: usize = std::env::var("SHADEC_BENCH_MAX")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(if benching { 20_000 } else { 300 });
    small_program();
    for target in chosen("SHADEC_BENCH_TARGETS", &TARGETS) {
        let profile = Profile::builtin(target).unwrap();
        for shape in chosen("SHADEC_BENCH_SHAPES", &SHAPES) {
            let (mut wall, mut cpu) = (Vec::new(), Vec::new());
            for n in SIZES.into_iter().filter(|n| *n <= max) {
                let src = program(shape, n);
                // Enough runs that the processor time's 10 ms ticks average out.
                let runs = (20_000 / n).clamp(3, 40);
                let (median, mean_cpu, passes) = time(&src, &profile, runs);
                println!(
                    "{target:>10} {shape:>6} {n:>6}: {:>10.3} ms wall (median of {runs}), {:>10.3} ms processor  ({passes} passes)",
                    median.as_secs_f64() * 1e3,
                    mean_cpu.as_secs_f64() * 1e3
                );
                wall.push((n, median));
                cpu.push((n, mean_cpu.max(Duration::from_micros(100))));
            }
            if wall.len() >= 2 {
                println!(
                    "{target:>10} {shape:>6} growth exponent {:.3} (wall), {:.3} (processor)",
                    growth_exponent(&wall),
                    growth_exponent(&cpu)
                );
            }
        }
    }
}

/// The whole pipeline (parse, check, lower, plan, generate) on one small
/// example program, per target.
fn small_program() {
    let src = include_str!("../examples/kilgard_bump_mapping.shd");
    for target in TARGETS {
        let profile = Profile::builtin(target).unwrap();
        let (median, cpu, passes) = time(src, &profile, 101);
        println!(
            "small program (kilgard_bump_mapping.shd) on {target}: {:.3} ms wall (median of 101), {:.3} ms processor ({passes} passes)",
            median.as_secs_f64() * 1e3,
            cpu.as_secs_f64() * 1e3
        );
    }
}
