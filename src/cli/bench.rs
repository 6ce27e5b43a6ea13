//! `shadec bench [-o DIR] [--size WxH] [--runs N] [--quick]
//! [--only PATTERN]`: the speed-against-error report; `--program FILE`: one
//! program's front; `--gpu-check`: the CPU against wgpu
//! (`shadec::bench::gpu_check`). The work is `shadec::bench`'s.

use std::path::PathBuf;
use std::process::ExitCode;

use shadec::bench::{BenchError, BenchOptions};

use super::render::{parse_size, Progress};
use super::{EXIT_SOURCE_ERRORS, EXIT_USAGE_OR_IO};

#[derive(Debug, clap::Args)]
#[command(group(clap::ArgGroup::new("gpu_check_or_scenes").args(["gpu_check", "adaptive_scenes"]).multiple(true)))]
pub struct BenchArgs {
    /// The folder to write report.md, the plots and diff/ into (created if
    /// needed; each file written atomically). `--out-dir` is an older name.
    #[arg(short, long, alias = "out-dir", value_name = "DIR", default_value = "bench")]
    pub output: PathBuf,
    /// Image size of every variant [default: 512x512; 128x128 with --quick].
    #[arg(long, value_name = "WxH")]
    pub size: Option<String>,
    /// Timed runs per variant, after a warm-up; the median is reported
    /// [default: 5; 1 with --quick].
    #[arg(long, value_name = "N")]
    pub runs: Option<usize>,
    /// A quick look: small images, one run, three thresholds.
    #[arg(long)]
    pub quick: bool,
    /// Only the variants and adaptive scenes whose name contains PATTERN.
    #[arg(long, value_name = "PATTERN")]
    pub only: Option<String>,
    /// What renders the variants: the CPU plan renderer, or the plan's WGSL
    /// on the adapter wgpu finds (a GPU, or lavapipe), timed by GPU
    /// timestamp queries where the adapter has them.
    #[arg(long, value_enum, default_value = "cpu")]
    pub backend: super::render::Backend,
    /// A variant the compiler lowers takes the fastest lowering whose
    /// render is within E of its program's meaning on the group's scene
    /// (largest channel difference, in [0, 1]); one with none is refused
    /// and listed.
    #[arg(long, value_name = "E")]
    pub max_error: Option<f64>,
    /// Instead of the papers' variants: the Pareto front of this program —
    /// every plan the compiler has for it on each `--target` (as written,
    /// then each choice of lowering rules), its predicted frame against
    /// its error on `--scene`; writes front.md and front.png.
    #[arg(long, value_name = "FILE")]
    pub program: Option<PathBuf>,
    /// With --program: a target to plan for (repeatable)
    /// [default: geforce256, geforce3, wgsl].
    #[arg(long = "target", value_name = "PROFILE", requires = "program")]
    pub targets: Vec<String>,
    /// With --program: the scene the plans are measured on [default: the
    /// built-in Kilgard torus].
    #[arg(long, value_name = "FILE", requires = "program")]
    pub scene: Option<PathBuf>,
    /// Instead of the papers' variants: the GPU check — every example and
    /// generated programs rendered on wgpu and on the CPU, compared under
    /// the texture unit's model and its stated latitude, and both timed;
    /// writes gpu-check.md and gpu-check.png (docs/gpu-check.md). Exits 1
    /// when a case lies beyond the model. With --quick: three examples,
    /// small images (what CI runs).
    #[arg(long, conflicts_with = "program")]
    pub gpu_check: bool,
    /// With --gpu-check: the folder of the examples [default: examples].
    #[arg(long, value_name = "DIR", requires = "gpu_check")]
    pub examples: Option<PathBuf>,
    /// With --gpu-check: how many generated programs to compare
    /// [default: 12; 2 with --quick].
    #[arg(long, value_name = "N", requires = "gpu_check")]
    pub generated: Option<usize>,
    /// With --gpu-check: a square size to time at (repeatable)
    /// [default: 1024 and 2048; 128 with --quick].
    #[arg(long = "timing-size", value_name = "N", requires = "gpu_check")]
    pub timing_sizes: Vec<u32>,
    /// With --gpu-check: the adaptive crossover's programs, as Phong lobes
    /// per fragment, comma-separated (0: the diffuse term alone)
    /// [default: 0,1,2,4,8,16,32; 0,8 with --quick]. With
    /// --adaptive-scenes: the Phong programs besides the fragment lighting
    /// example [default: 4,8,16].
    #[arg(long, value_name = "K,K,…", requires = "gpu_check_or_scenes", value_delimiter = ',')]
    pub crossover_lobes: Vec<usize>,
    /// With --gpu-check: the square size the crossover is timed at
    /// [default: 1024; 128 with --quick].
    #[arg(long, value_name = "N", requires = "gpu_check")]
    pub crossover_size: Option<u32>,
    /// Instead of the papers' variants: `--adaptive auto` on every scene of
    /// scenes/ — full and adaptive shading of the same plan interleaved
    /// `--runs` times (default 5), medians, with auto's choice — on the CPU
    /// or, with `--backend wgpu`, on wgpu (GPU timestamps where the adapter
    /// has them), at each scene's resolution or `--size`; prints a markdown
    /// table.
    #[arg(long, conflicts_with_all = ["program", "gpu_check"])]
    pub adaptive_scenes: bool,
}

/// `bench --gpu-check`.
#[cfg(feature = "gpu")]
fn gpu_check(args: &BenchArgs) -> ExitCode {
    use shadec::bench::gpu_check::{self, GpuCheckOptions};
    let examples = args.examples.clone().unwrap_or_else(|| PathBuf::from("examples"));
    let mut options =
        if args.quick { GpuCheckOptions::quick(examples) } else { GpuCheckOptions::full(examples) };
    if let Some(s) = &args.size {
        match parse_size(s) {
            Some(v) => options.size = v,
            None => {
                return usage(format!(
                    "--size {s}: expected WxH with 1..=16384 pixels per side, such as 640x480"
                ))
            }
        }
    }
    if let Some(n) = args.runs {
        if !(1..=1000).contains(&n) {
            return usage(format!("--runs {n}: expected 1 to 1000 timed runs"));
        }
        options.runs = n;
    }
    if let Some(n) = args.generated {
        options.generated = n;
    }
    if !args.timing_sizes.is_empty() {
        if let Some(bad) = args.timing_sizes.iter().find(|s| !(1..=16384).contains(*s)) {
            return usage(format!("--timing-size {bad}: expected 1 to 16384 pixels per side"));
        }
        options.timing_sizes = args.timing_sizes.clone();
    }
    if let Some(only) = &args.only {
        options.only_examples = Some(vec![only.clone()]);
    }
    if !args.crossover_lobes.is_empty() {
        if let Some(bad) = args.crossover_lobes.iter().find(|k| **k > 64) {
            return usage(format!("--crossover-lobes {bad}: expected 0 to 64 lobes"));
        }
        options.crossover_lobes = args.crossover_lobes.clone();
    }
    if let Some(n) = args.crossover_size {
        if !(1..=16384).contains(&n) {
            return usage(format!("--crossover-size {n}: expected 1 to 16384 pixels per side"));
        }
        options.crossover_size = n;
    }
    let progress = Progress::counting("programs");
    let result =
        gpu_check::run(&options, &args.output, &mut |done, total, name| progress.tick(name, done, total));
    progress.finish();
    match result {
        Ok(check) => {
            println!("adapter: {}", check.adapter);
            for c in &check.cases {
                if let gpu_check::Outcome::Compared(k) = &c.outcome {
                    println!(
                        "{:<44} {:<10} {:<6} max {:>3}/255  beyond {:>5}  {}",
                        c.program,
                        c.target,
                        c.mode.name(),
                        k.max_diff,
                        k.beyond,
                        k.verdict()
                    );
                }
            }
            println!("wrote {}", args.output.join("gpu-check.md").display());
            if check.failures() > 0 {
                eprintln!("error: {} case(s) beyond the model (gpu-check.md names them)", check.failures());
                return ExitCode::from(EXIT_SOURCE_ERRORS);
            }
            ExitCode::SUCCESS
        }
        Err(e) => usage(e),
    }
}

#[cfg(not(feature = "gpu"))]
fn gpu_check(_: &BenchArgs) -> ExitCode {
    usage("this shadec was built without the `gpu` feature: rebuild with default features for --gpu-check")
}

/// `bench --program`: the program's front on each target.
fn front(args: &BenchArgs, program: &std::path::Path) -> ExitCode {
    let source = match shadec::io::read_text(program) {
        Ok(s) => s,
        Err(e) => return usage(e),
    };
    // Errors in the program, located, before anything is measured.
    let errors: Vec<shadec::diag::Diagnostic> =
        shadec::driver::front(&source).diagnostics.into_iter().filter(|d| d.is_error()).collect();
    if !errors.is_empty() {
        let file = shadec::diag::SourceFile::new(program.display().to_string(), source);
        eprint!("{}", file.render(&errors, super::check::color_stderr()));
        return ExitCode::from(EXIT_SOURCE_ERRORS);
    }
    let names: Vec<String> = if args.targets.is_empty() {
        ["geforce256", "geforce3", "wgsl"].map(String::from).to_vec()
    } else {
        args.targets.clone()
    };
    let mut profiles = Vec::new();
    for name in &names {
        match shadec::profile::Profile::resolve(name) {
            Ok(p) => profiles.push(p),
            Err(e) => return usage(e),
        }
    }
    let scene = match super::render::scene_from(args.scene.as_deref()) {
        Ok(s) => s,
        Err(code) => return code,
    };
    let name = program.display().to_string();
    match shadec::bench::front::run(&name, &source, &profiles, &scene, &args.output) {
        Ok((rows, refused)) => {
            for r in &rows {
                println!(
                    "{} {:<10} {:>3} passes  {}  max {:>5.1}/255  RMSE {:.5}  {}",
                    if r.on_front { "*" } else { " " },
                    r.target,
                    r.passes,
                    r.predicted_ms
                        .map_or("predicted    —    ".to_string(), |t| format!("predicted {t:>7.3} ms")),
                    r.max_abs * 255.0,
                    r.rmse,
                    r.rules
                );
            }
            let file = shadec::diag::SourceFile::new(name.clone(), source.clone());
            for r in &refused {
                println!("refused on {}:", r.target);
                eprint!("{}", file.render(&r.diagnostics, super::check::color_stderr()));
            }
            println!("wrote {}", args.output.join("front.md").display());
            // Nothing planned on any target: no front to draw.
            if rows.is_empty() {
                ExitCode::from(EXIT_SOURCE_ERRORS)
            } else {
                ExitCode::SUCCESS
            }
        }
        Err(e @ BenchError::Io(_)) => usage(e),
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(EXIT_SOURCE_ERRORS)
        }
    }
}

/// The options of a bench run from its flags, or the usage error's exit code.
fn bench_options(args: &BenchArgs) -> Result<BenchOptions, ExitCode> {
    let mut options = if args.quick { BenchOptions::quick() } else { BenchOptions::full() };
    if let Some(s) = &args.size {
        match parse_size(s) {
            Some(v) => options.size = v,
            None => {
                return Err(usage(format!(
                    "--size {s}: expected WxH with 1..=16384 pixels per side, such as 512x512"
                )))
            }
        }
    }
    if let Some(n) = args.runs {
        if !(1..=1000).contains(&n) {
            return Err(usage(format!("--runs {n}: expected 1 to 1000 timed runs")));
        }
        options.runs = n;
    }
    options.only = args.only.clone();
    if let Some(e) = args.max_error {
        if !(e.is_finite() && e >= 0.0) {
            return Err(usage(format!("--max-error {e}: expected a non-negative error such as 0.05")));
        }
        options.max_error = Some(e);
    }
    options.backend = match args.backend {
        super::render::Backend::Cpu => shadec::bench::Backend::Cpu,
        super::render::Backend::Wgpu => shadec::bench::Backend::Wgpu,
    };
    Ok(options)
}

/// One line per measured variant, refusal and adaptive row.
fn print_report(report: &shadec::bench::report::Report) {
    for m in &report.measured {
        println!(
            "{:<24} {:>10} {:>7} {:>8.2} ms {}  {}  RMSE {:.5}  max {:>5.1}/255",
            m.variant.name,
            m.variant.target,
            m.variant.mode.name(),
            m.time.as_secs_f64() * 1e3,
            m.clock.name(),
            m.predicted_ms.map_or("predicted    —    ".to_string(), |p| format!("predicted {p:>7.3} ms")),
            m.error.rmse,
            m.error.max_abs * 255.0
        );
    }
    for r in &report.refused {
        println!("refused: {r}");
    }
    for r in &report.adaptive {
        println!(
            "{:<24} threshold {:>4.1} %: {:>6.2} % shaded, {:.2}× faster, PSNR {:.1} dB",
            r.scene,
            100.0 * r.threshold,
            100.0 * r.fraction_shaded,
            r.speedup(),
            r.psnr
        );
    }
}

/// `shadec bench`: the variants' table, one program's front
/// (`--program`), or the GPU check (`--gpu-check`).
pub fn run(args: &BenchArgs) -> ExitCode {
    if let Some(program) = &args.program {
        return front(args, program);
    }
    if args.gpu_check {
        return gpu_check(args);
    }
    #[cfg(feature = "gpu")]
    if args.adaptive_scenes {
        let gpu = args.backend == super::render::Backend::Wgpu;
        let size = match args.size.as_deref().map(|s| (s, parse_size(s))) {
            None => None,
            Some((_, Some(v))) => Some(v),
            Some((s, None)) => {
                return usage(format!(
                    "--size {s}: expected WxH with 1..=16384 pixels per side, such as 640x480"
                ))
            }
        };
        if let Some(bad) = args.crossover_lobes.iter().find(|k| **k > 64) {
            return usage(format!("--crossover-lobes {bad}: expected 0 to 64 lobes"));
        }
        let lobes =
            if args.crossover_lobes.is_empty() { vec![4, 8, 16] } else { args.crossover_lobes.clone() };
        let measure =
            shadec::bench::adaptive_scenes::Measure { runs: args.runs.unwrap_or(5), cpu: !gpu, gpu, size };
        let root = std::path::Path::new(".");
        return match shadec::bench::adaptive_scenes::report(root, &measure, &lobes, args.only.as_deref()) {
            Ok(md) => {
                println!("{md}");
                ExitCode::SUCCESS
            }
            Err(e) => usage(e),
        };
    }
    let options = match bench_options(args) {
        Ok(options) => options,
        Err(code) => return code,
    };
    println!(
        "shadec bench: {}×{}, median of {} run{}, {} threads → {}",
        options.size.0,
        options.size.1,
        options.runs,
        if options.runs == 1 { "" } else { "s" },
        rayon::current_num_threads(),
        args.output.display()
    );
    let progress = Progress::counting("variants");
    let result =
        shadec::bench::run(&options, &args.output, &mut |done, total, name| progress.tick(name, done, total));
    progress.finish();
    match result {
        Ok(report) => {
            print_report(&report);
            println!("wrote {}", args.output.join("report.md").display());
            ExitCode::SUCCESS
        }
        Err(e @ BenchError::Io(_)) => usage(e),
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(EXIT_SOURCE_ERRORS)
        }
    }
}

fn usage(e: impl std::fmt::Display) -> ExitCode {
    eprintln!("error: {e}");
    ExitCode::from(EXIT_USAGE_OR_IO)
}
