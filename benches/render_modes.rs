//! The CPU renderer's speed (issue 6 part 7): the default scene of `shadec
//! render` (Kilgard's bump-mapped torus, the 3-pass geforce256 plan) at
//! 1024×1024 in each mode with one thread and with all threads; how the time
//! grows with resolution and with the triangle count; and the peer a user
//! would pick instead, the same plan's WGSL run by wgpu (lavapipe where there
//! is no GPU), measured in the same run. A plain timer: median of
//! `SHADEC_BENCH_RUNS` (default 7) after one warm-up frame, printed as the
//! tables of BENCHMARKS.md. `cargo bench --bench render_modes`.

#[path = "common/timing.rs"]
mod timing;

use std::path::Path;
use std::time::Duration;

use shadec::renderer::plan::{Mode, PlanRenderer};
use shadec::scene::Scene;

/// Median of 7 runs (`SHADEC_BENCH_RUNS`) after one warm-up.
fn median(f: impl FnMut()) -> Duration {
    timing::median(7, 1, f)
}

const SOURCE: &str = include_str!("../examples/kilgard_bump_mapping.shd");
const SCENE: &str = include_str!("../scenes/kilgard_torus.ron");

struct Setup {
    planned: shadec::pipeline::Planned,
    program: shadec::parser::ast::Program,
    scene: Scene,
    assets: shadec::scene::SceneAssets,
}

fn setup(scene_text: &str) -> Setup {
    let scene = Scene::parse(scene_text, Path::new("/nonexistent-shadec-scene/kilgard_torus.ron")).unwrap();
    let assets = scene.build().unwrap();
    let profile = shadec::profile::Profile::resolve("geforce256").unwrap();
    let planned = shadec::driver::compile(SOURCE, &profile, &Default::default()).map(|c| c.planned).unwrap();
    let (program, _) = shadec::parser::check(SOURCE);
    Setup { planned, program, scene, assets }
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

fn main() {
    let s = setup(SCENE);
    let cpu = PlanRenderer::new(&s.planned, &s.program, &s.scene, &s.assets).unwrap();
    let all = rayon::current_num_threads();
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let (w, h) = (1024u32, 1024u32);
    let mpix = |d: Duration| (w as f64 * h as f64) / d.as_secs_f64() / 1e6;

    println!(
        "Kilgard torus, geforce256 plan ({} passes), {w}×{h}, median frame time",
        s.planned.plan.passes.len()
    );
    println!("| mode | 1 thread: ms | Mpixel/s | {all} threads: ms | Mpixel/s | speed-up |");
    println!("|---|---|---|---|---|---|");
    let mut fixed9_all = Duration::ZERO;
    for mode in [Mode::Fixed9, Mode::F32, Mode::Exact] {
        let t1 = one.install(|| median(|| drop(cpu.render(mode, w, h, &mut |_, _| {}).unwrap())));
        let tn = median(|| drop(cpu.render(mode, w, h, &mut |_, _| {}).unwrap()));
        if mode == Mode::Fixed9 {
            fixed9_all = tn;
        }
        println!(
            "| {} | {:.1} | {:.2} | {:.1} | {:.2} | {:.2}× |",
            mode.name(),
            ms(t1),
            mpix(t1),
            ms(tn),
            mpix(tn),
            t1.as_secs_f64() / tn.as_secs_f64()
        );
    }

    println!("\nGrowth with resolution (fixed9, {all} threads)");
    println!("| size | ms | ratio to the size before | pixels ratio |");
    println!("|---|---|---|---|");
    let mut before: Option<Duration> = None;
    for side in [256u32, 512, 1024, 2048] {
        let t = median(|| drop(cpu.render(Mode::Fixed9, side, side, &mut |_, _| {}).unwrap()));
        println!(
            "| {side}×{side} | {:.1} | {} | {} |",
            ms(t),
            before.map_or(String::new(), |b| format!("{:.2}×", t.as_secs_f64() / b.as_secs_f64())),
            if before.is_some() { "4×" } else { "" }
        );
        before = Some(t);
    }

    println!("\nGrowth with triangle count (fixed9, 512×512, {all} threads)");
    println!("| torus rings × sides | triangles | ms | ratio to the row before |");
    println!("|---|---|---|---|");
    let mut before: Option<Duration> = None;
    for (rings, sides) in [(16, 8), (64, 32), (256, 128), (1024, 512)] {
        let text = SCENE.replace("rings: 64, sides: 32", &format!("rings: {rings}, sides: {sides}"));
        let g = setup(&text);
        let r = PlanRenderer::new(&g.planned, &g.program, &g.scene, &g.assets).unwrap();
        let t = median(|| drop(r.render(Mode::Fixed9, 512, 512, &mut |_, _| {}).unwrap()));
        println!(
            "| {rings} × {sides} | {} | {:.1} | {} |",
            2 * rings * sides,
            ms(t),
            before.map_or(String::new(), |b| format!("{:.2}×", t.as_secs_f64() / b.as_secs_f64()))
        );
        before = Some(t);
    }

    peer(&s, fixed9_all, w, h);
}

/// The same plan's WGSL on wgpu, in the same run.
#[cfg(feature = "gpu")]
fn peer(s: &Setup, fixed9: Duration, w: u32, h: u32) {
    use shadec::backends::wgsl::codegen::Fidelity;
    use shadec::gpu::runner::Gpu;
    use shadec::gpu::scene_run::ScenePlan;
    let gpu = match Gpu::new() {
        Ok(g) => g,
        Err(e) => {
            println!("\nno GPU adapter ({e}): no peer to compare with");
            return;
        }
    };
    let plan = ScenePlan::new(&s.planned, &s.program, Some(SOURCE), Fidelity::Hardware, &s.scene, &s.assets)
        .unwrap();
    let t = median(|| drop(plan.render(&gpu, w, h).unwrap()));
    println!("\nThe peer: the same plan's WGSL (--fidelity hardware) on wgpu, adapter {gpu}, {w}×{h}, whole frame incl. upload and readback");
    println!("| path | ms/frame | ratio to wgpu |");
    println!("|---|---|---|");
    println!("| wgpu | {:.1} | 1.00× |", ms(t));
    println!(
        "| CPU renderer, fixed9, all threads | {:.1} | {:.2}× |",
        ms(fixed9),
        fixed9.as_secs_f64() / t.as_secs_f64()
    );
}

#[cfg(not(feature = "gpu"))]
fn peer(_: &Setup, _: Duration, _: u32, _: u32) {
    println!("\nbuilt without the `gpu` feature: no peer to compare with");
}
