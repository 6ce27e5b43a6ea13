//! A long product of lookups (one statement, split into many passes) plans
//! in time linear in its length: the splitter once tried every pass it had
//! opened for every operand, and gathered all the other operands for each
//! one, which made a lookup of a chain of 10 000 cost 6 to 7 times one of a
//! chain of 1 000 (BENCHMARKS.md, compile time against program size).

use shadec::profile::Profile;

/// `C δπx ← (T0 δu x) * (T1 δu x) * …`, `n` lookups of eight textures
/// (the `chain` shape of `benches/compile.rs`).
fn chain(n: usize) -> String {
    let mut s = String::from("vector N : normal;\n");
    for t in 0..8 {
        s += &format!("texture T{t} : 2d rgba8;\n");
    }
    let terms: Vec<String> = (0..n).map(|i| format!("(T{} δu x)", i % 8)).collect();
    s + &format!("C δπx ← {};\n", terms.join(" * "))
}

/// Processor time of this thread so far, in seconds (`/proc/thread-self/stat`,
/// fields 14 and 15, ticks of 1/100 s): the other tests of the suite run
/// beside it, so the process's time would count theirs.
fn thread_cpu() -> f64 {
    let stat = std::fs::read_to_string("/proc/thread-self/stat").unwrap_or_default();
    let fields: Vec<&str> = stat.rsplit(')').next().unwrap_or_default().split_whitespace().collect();
    let field = |i: usize| fields.get(i).and_then(|f| f.parse::<u64>().ok()).unwrap_or(0);
    (field(11) + field(12)) as f64 / 100.0
}

/// Processor time of `runs` compiles of a chain of `n`, and its passes.
fn plan_time(n: usize, runs: usize, profile: &Profile) -> (f64, usize) {
    let src = chain(n);
    let before = thread_cpu();
    let mut passes = 0;
    for _ in 0..runs {
        passes = shadec::compile(&src, profile).unwrap_or_else(|d| panic!("{d:?}")).passes.len();
    }
    (thread_cpu() - before, passes)
}

#[test]
fn a_long_chain_plans_in_linear_time() {
    if !std::path::Path::new("/proc/thread-self/stat").exists() {
        eprintln!("no /proc/thread-self/stat: the processor time cannot be read here");
        return;
    }
    for target in ["geforce256", "geforce3"] {
        let profile = Profile::builtin(target).unwrap();
        // The same number of lookups planned in all: 16 chains of 1 000
        // against 2 of 8 000.
        let (short, short_passes) = plan_time(1_000, 16, &profile);
        let (long, long_passes) = plan_time(8_000, 2, &profile);
        assert!(long_passes >= 7 * short_passes, "{target}: {short_passes} and {long_passes} passes");
        assert!(
            long < 2.5 * short.max(0.05),
            "{target}: 2 chains of 8 000 lookups took {long:.2} s, 16 of 1 000 took {short:.2} s"
        );
    }
}
