//! Agreement of the two executors of a plan (issue 5, part 4): the wgpu
//! image (`gpu::scene_run`, Mesa's lavapipe in CI) against the CPU
//! renderer's f32 mode (`renderer::plan`), bound to the same scene data,
//! within 2/255 per channel on every pixel not on a triangle edge; and
//! `--fidelity hardware` against the fixed9 mode within 1/255. Every
//! example is compared at 640×480 (at 256×192 the mask below left only
//! ~1 200 of the torus's pixels).
//!
//! # Rounding ties
//!
//! The executors' interpolated values, dot products and derivatives differ
//! by float noise, so a rounding (or comparison) whose input lies within
//! that noise of its tie can go either way, and squarings multiply the
//! 1/255. Where pixels differ beyond the tolerance, the CPU renders the
//! plan again with every tie moved ± [`TIES`]
//! (`PlanRenderer::set_rounding_bias`); a pixel within the tolerance of
//! one of those pictures agrees. More than 0.1% of an example's lit
//! pixels needing that fails it: noise explains a rare pixel, not a
//! pattern (the `^n` rounded once on one executor and by squarings on the
//! other showed on 254 of kajiya_kay_hair's 51 840).
//!
//! # The edge mask
//!
//! A triangle-ID image is rendered on the GPU with the binder's camera clip
//! matrices and depth test (each triangle its own flat 24-bit colour; 0 is
//! background). A pixel is masked when its 3×3 neighbourhood holds more
//! than one ID — coverage changes there (silhouettes, self-occlusion, and
//! the shared edges inside a mesh, where the two rasterizers may pick
//! different triangles and the GPU's 2×2 derivative quads straddle two
//! triangles). Everything else is compared.
//!
//! With no adapter these fail with the fix, unless `SHADEC_ALLOW_NO_GPU=1`
//! (outside CI), as `tests/gpu_runner.rs` documents.
#![cfg(feature = "gpu")]

use crate::common;

use std::path::Path;

use shadec::gpu::runner::{
    run_passes, Gpu, PassTarget, RunPass, RunShader, ShaderSource, Target, VertexData,
};
use shadec::gpu::scene_run::ScenePlan;
use shadec::numerics::Precision;
use shadec::profile::Profile;
use shadec::renderer::plan::{PlanRenderer, RoundingBias};
use shadec::renderer::{BlendState, CullMode, DepthState, RenderState, StencilState};
use shadec::scene::Scene;

const W: u32 = 640;
const H: u32 = 480;

/// How near its tie a rounding's input may come and the rounding still
/// count as float noise, which may go either way
/// ([`PlanRenderer::set_rounding_bias`]): (1/255 register steps, 1/256
/// texture-unit quanta), tried in turn. Register inputs (interpolated
/// values, dot products) differ between the executors by up to about
/// 1.2·10⁻⁴ steps (measured by rendering `fract(25500 · T·L)` on both), so
/// 10⁻³ steps. Texture coordinates scaled to 1/256 texels differ by up to
/// about 4·10⁻³ quanta, λ by more: it comes from differences of
/// neighbouring coordinates (a relative error of ~5·10⁻⁴ in ρ is 0.2
/// quanta of λ); one picture per distance, since a larger move also
/// flips roundings that were not near their ties.
/// Comparisons (a shadow test of depths that went through a 24-bit depth
/// buffer and a reprojection) get 8, 64 and 256 ulps.
const TIES: [(f64, f32, f64); 3] = [(1e-3, 1e-2, 8.0), (1e-3, 5e-2, 64.0), (1e-3, 0.2, 256.0)];

use common::gpu::gpu;

fn kilgard_scene() -> Scene {
    let text =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/kilgard_torus.ron")).unwrap();
    // Anchored where decal.png / bumps.png do not exist: the binder's
    // procedural stand-ins are used by both executors.
    Scene::parse(&text, Path::new("/nonexistent-shadec-scene/kilgard_torus.ron")).unwrap()
}

pub(crate) struct Agreement {
    pub(crate) max_diff: u8,
    masked: f64,
    covered: usize,
    pub(crate) over: usize,
    /// Hardware fidelity: pixels that differ from the fixed9 picture but
    /// agree with it when an 8-bit rounding whose input lies within
    /// [`TIES`] of its tie goes the other way; and the agreement
    /// without that allowance.
    pub(crate) ties: usize,
    over_with_ties: usize,
    pub(crate) max_with_ties: u8,
    /// Pixels compared (off the mask).
    pub(crate) compared: usize,
    /// Compared pixels the CPU image does not leave black.
    pub(crate) lit: usize,
}

impl Agreement {
    /// At least a tenth of the compared pixels are lit: agreement on a
    /// mostly black image would prove nothing.
    pub(crate) fn says_something(&self) -> bool {
        self.lit * 10 >= self.compared
    }
}

fn agreement(gpu: &Gpu, source: &str, target: &str, scene: &Scene) -> Agreement {
    agreement_in(gpu, source, target, scene, Precision::F32)
}

/// `Exact`: the WGSL against the CPU's f32 mode, in a float target;
/// `Hardware`: against the CPU's fixed9 mode, in an RGBA8 target as the
/// old machine's framebuffer (over-count threshold 1/255 instead of 2/255).
fn agreement_in(gpu: &Gpu, source: &str, target: &str, scene: &Scene, fidelity: Precision) -> Agreement {
    try_agreement_in(gpu, source, target, scene, fidelity).unwrap_or_else(|e| panic!("{target}: {e}"))
}

/// Whether a pass of `planned` blends a source leaving [0, 1]: into the
/// declared `rgba8` framebuffer it relies on GL's clamp of the blend's
/// source (§4.1.8; a blend the program writes means it,
/// `planner::blended_as_gl`), which a float target does not apply, so
/// such a plan draws into RGBA8, as declared (rounded per pass, within
/// the tolerance).
fn clamps_blend_source(planned: &shadec::pipeline::Planned) -> bool {
    planned.plan.passes.iter().any(|p| {
        let r = planned.module.info(planned.handle(p.fragment.output)).interval;
        p.blend != shadec::pipeline::BlendMode::Replace && (r.lo < 0.0 || r.hi > 1.0)
    })
}

/// [`agreement_in`], or why an executor refused the program.
pub(crate) fn try_agreement_in(
    gpu: &Gpu,
    source: &str,
    target: &str,
    scene: &Scene,
    fidelity: Precision,
) -> Result<Agreement, String> {
    let profile = Profile::resolve(target).map_err(|e| format!("{e:?}"))?;
    let planned = shadec::driver::compile(source, &profile, &Default::default())
        .map(|c| c.planned)
        .map_err(|d| format!("does not compile: {d:?}"))?;
    let (program, _) = shadec::parser::check(source);
    let assets = scene.build().unwrap();
    let (mode, tol) =
        if fidelity == Precision::Fixed9 { (Precision::Fixed9, 1) } else { (Precision::F32, 2) };
    let mut renderer =
        PlanRenderer::new(&planned, &program, scene, &assets).map_err(|e| format!("CPU: {e}"))?;
    let mut render = |bias: RoundingBias| {
        renderer.set_rounding_bias(bias);
        renderer
            .render(mode, W, H, &mut |_, _| {})
            .map(|f| f.image.to_rgba8())
            .map_err(|e| format!("CPU: {e}"))
    };
    let cpu = render(RoundingBias::default())?;
    let plan = ScenePlan::new(&planned, &program, Some(source), fidelity, scene, &assets)
        .map_err(|e| format!("wgpu: {e}"))?;
    // f32: a float target — between passes the values stay in float, as in
    // the CPU renderer's f32 mode (the picture is read back in 8 bits, as
    // the CPU's is written). fixed9: RGBA8 between passes, as the CPU's.
    let gpu_target = if fidelity == Precision::Fixed9 || clamps_blend_source(&planned) {
        shadec::gpu::runner::Target::new(W, H)
    } else {
        shadec::gpu::runner::Target::float(W, H)
    };
    let gpu_img = plan.render_into(gpu, &gpu_target).map_err(|e| format!("wgpu: {e}"))?.into_raw();
    let ids = shadec::bench::gpu_check::triangle_ids(gpu, scene, &assets, (W, H)).unwrap();
    let mask = shadec::bench::gpu_check::edge_mask(&ids, (W, H));
    // Per pixel off the edge mask, the difference from the nearest of the CPU `pictures`.
    let differences = |pictures: &[&[u8]]| {
        let (mut max_diff, mut over, mut worst) = (0u8, 0usize, (0usize, [0u8; 4], [0u8; 4]));
        for i in (0..(W * H) as usize).filter(|&i| !mask[i]) {
            let d = pictures
                .iter()
                .map(|cpu| (0..4).map(|c| cpu[4 * i + c].abs_diff(gpu_img[4 * i + c])).max().unwrap())
                .min()
                .unwrap();
            if d > tol {
                over += 1;
            }
            if d > max_diff {
                max_diff = d;
                worst = (
                    i,
                    cpu[4 * i..4 * i + 4].try_into().unwrap(),
                    gpu_img[4 * i..4 * i + 4].try_into().unwrap(),
                );
            }
        }
        (max_diff, over, worst)
    };
    let (max_with_ties, over_with_ties, worst_with_ties) = differences(&[&cpu]);
    // Hardware fidelity, where pixels differ: the fixed9 model also as it
    // decides every 8-bit rounding whose input lies within TIES of its
    // tie the other way (the CPU rendered again with the ties moved ±).
    let (max_diff, over, worst) = if over_with_ties > 0 {
        let mut pictures = vec![cpu.clone()];
        for (register_steps, texel_quanta, comparison_ulps) in TIES {
            for sign in [1.0, -1.0] {
                pictures.push(render(RoundingBias {
                    register_steps: sign * register_steps,
                    texel_quanta: sign as f32 * texel_quanta,
                    comparison_ulps: sign * comparison_ulps,
                    ..RoundingBias::default()
                })?);
            }
        }
        differences(&pictures.iter().map(|p| &p[..]).collect::<Vec<_>>())
    } else {
        (max_with_ties, over_with_ties, worst_with_ties)
    };
    let ties = over_with_ties - over;
    let masked = mask.iter().filter(|m| **m).count() as f64 / mask.len() as f64;
    let covered = ids.iter().filter(|id| **id != 0).count();
    eprintln!(
        "{target}: max |wgpu − cpu {}| = {max_diff}/255 off the edge mask ({over} pixels over {tol}/255; worst at ({}, {}): cpu {:?} wgpu {:?}); masked {:.1}% of {}×{} ({covered} pixels covered); {ties} pixels agree with a rounding tie taken the other way (without: max {max_with_ties}/255, {over_with_ties} pixels over)",
        mode.name(),
        worst.0 % W as usize,
        worst.0 / W as usize,
        worst.1,
        worst.2,
        100.0 * masked,
        W,
        H
    );
    if std::env::var("SHADEC_AGREEMENT_DUMP").is_ok() {
        // Signed differences (wgpu − CPU) per channel over the lit compared pixels: a bias shows as asymmetry.
        for c in 0..3 {
            let mut histogram = std::collections::BTreeMap::new();
            for i in
                (0..(W * H) as usize).filter(|&i| !mask[i] && cpu[4 * i..4 * i + 3].iter().any(|&c| c > 0))
            {
                *histogram.entry(gpu_img[4 * i + c] as i32 - cpu[4 * i + c] as i32).or_insert(0usize) += 1;
            }
            eprintln!("{target} channel {c}: wgpu − cpu → pixels {histogram:?}");
        }
        let dir = std::env::temp_dir();
        image::RgbaImage::from_raw(W, H, cpu.clone())
            .unwrap()
            .save(dir.join(format!("agree_cpu_{target}.png")))
            .unwrap();
        image::RgbaImage::from_raw(W, H, gpu_img.clone())
            .unwrap()
            .save(dir.join(format!("agree_gpu_{target}.png")))
            .unwrap();
        let diff: Vec<u8> = (0..(W * H) as usize)
            .flat_map(|i| {
                let d = (0..3).map(|c| cpu[4 * i + c].abs_diff(gpu_img[4 * i + c])).max().unwrap();
                let v = (d as u32 * 40).min(255) as u8;
                if mask[i] {
                    [0, 0, 80, 255]
                } else {
                    [v, v, v, 255]
                }
            })
            .collect();
        image::RgbaImage::from_raw(W, H, diff)
            .unwrap()
            .save(dir.join(format!("agree_diff_{target}.png")))
            .unwrap();
    }
    let compared = mask.iter().filter(|m| !**m).count();
    let lit =
        (0..(W * H) as usize).filter(|&i| !mask[i] && cpu[4 * i..4 * i + 3].iter().any(|&c| c > 0)).count();
    Ok(Agreement { max_diff, masked, covered, over, ties, over_with_ties, max_with_ties, compared, lit })
}

/// A pass into a half-float texture rounds to nearest, ties to even, on
/// both executors (the CPU's F16; WGSL's `round_to_half`, since lavapipe's
/// `Rgba16Float` writes round toward zero). With u = 2⁻¹², the half-float
/// step at ¼: ¼ + ¾u rounds up (toward zero: down), ¼ + 1.5u and ¼ + 2.5u
/// are ties, to 2u both (toward zero: u and 2u; half away from zero: 2u
/// and 3u). The second pass shows the stored steps ×¼.
#[test]
fn half_float_targets_round_to_nearest_even() {
    let Some(gpu) = gpu() else { return };
    let source = "texture T : 2d rgba16f nearest clamp;\n\
                  T δπx ← rgb(0.25018310546875, 0.2503662109375, 0.2506103515625);\n\
                  C xs ← 1024 * (T xs - 0.25);\n";
    // Exact fidelity: hardware fidelity's 8-bit constants would hide the steps.
    let a = agreement(&gpu, source, "wgsl", &kilgard_scene());
    assert!(a.says_something(), "the torus is drawn ({} of {} compared pixels lit)", a.lit, a.compared);
    assert_eq!((a.max_diff, a.max_with_ties), (0, 0), "the half floats are rounded differently");
}

/// Hardware fidelity: a NaN (here √ of a negative) is 0 on both executors,
/// as `fixed9` makes it — lavapipe's `clamp` of NaN gave −1, which turned
/// Cook-Torrance's 0/0 highlights black on a sphere (44/255).
#[test]
fn hardware_fidelity_makes_nan_zero_on_both() {
    let Some(gpu) = gpu() else { return };
    let source = "vector N : normal;\nvector L : light(0);\n\
                  shader p : s → c = rgb(0.5, 0.5, 0.5) + rgb(0.25, 0.25, 0.25) * sqrt(-0.5 - (N·L)^2);\n\
                  C δπx ← p δ s x;\n";
    let a = agreement_in(&gpu, source, "wgsl", &kilgard_scene(), Precision::Fixed9);
    assert!(a.says_something(), "the torus is drawn ({} of {} compared pixels lit)", a.lit, a.compared);
    assert_eq!(a.max_with_ties, 0, "NaN is not 0 on one of them");
}

/// Hardware fidelity: a uniform is read as given and what is computed
/// from it alone is folded (rounded to 1/255, keeping its magnitude: a
/// constant register and its scale), on both executors — the WGSL used to
/// clamp a uniform to ±1, halving this one.
#[test]
fn hardware_fidelity_keeps_a_uniforms_magnitude() {
    let Some(gpu) = gpu() else { return };
    let source = "vector N : normal;\nvector L : light(0);\nuniform k : scalar = 1.5;\n\
                  shader p : s → c = rgb(0.5, 0.4, 0.3) * (k * k / 2) * max(0, N·L);\n\
                  C δπx ← p δ s x;\n";
    let a = agreement_in(&gpu, source, "wgsl", &kilgard_scene(), Precision::Fixed9);
    assert!(a.says_something(), "the torus is drawn ({} of {} compared pixels lit)", a.lit, a.compared);
    assert!(a.max_diff <= 1, "max {}/255 on {} pixels", a.max_diff, a.over);
}

/// Hardware fidelity: quotients of register values that land exactly on
/// rounding ties — 3/10, 3/34 and 9/90 in 1/255 steps are 76.5, 22.5 and
/// 25.5 — round the same way on both executors (up: `fixed9_quotient`,
/// `divide_*`). Taken as float quotients of k/255 values, f32 rounds the
/// first two down and f64 the third: each executor's noise. Scaled (×3,
/// ×10, ×9) so that one step shows.
#[test]
fn hardware_fidelity_rounds_quotient_ties_alike() {
    let Some(gpu) = gpu() else { return };
    let source = "vector N : normal;\nvector L : light(0);\n\
                  shader p : s → c {\n\
                      let one = max(1, N·L);\n\
                      rgb(3, 10, 9) * rgb(one * (3 / 255) / (one * (10 / 255)), one * (3 / 255) / (one * (34 / 255)), one * (9 / 255) / (one * (90 / 255)))\n\
                  }\n\
                  C δπx ← p δ s x;\n";
    let a = agreement_in(&gpu, source, "wgsl", &kilgard_scene(), Precision::Fixed9);
    assert!(a.says_something(), "the torus is drawn ({} of {} compared pixels lit)", a.lit, a.compared);
    assert_eq!(a.max_with_ties, 0, "the executors round a quotient's tie apart");
}

fn kilgard() -> String {
    std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/kilgard_bump_mapping.shd"))
        .unwrap()
}

/// The criterion: every pixel off the edge mask within 2/255.
fn check(a: &Agreement, what: &str) {
    sane(a, what);
    assert!(
        a.max_diff <= 2,
        "{what}: wgpu and the CPU f32 renderer differ by up to {}/255 on {} pixels off triangle edges",
        a.max_diff,
        a.over
    );
}

fn sane(a: &Agreement, what: &str) {
    assert!(
        a.covered > (W * H) as usize / 10,
        "{what}: the torus covers too little of the image ({} pixels)",
        a.covered
    );
    assert!(a.masked < 0.6, "{what}: the edge mask hides {:.0}% of the image", 100.0 * a.masked);
}

/// Kilgard's bump-mapped torus as the one fused pass of the wgsl target.
#[test]
fn kilgard_wgsl_single_pass_agrees_with_cpu_f32() {
    let Some(gpu) = gpu() else { return };
    let src = kilgard().replace("target geforce256;", "");
    let a = agreement(&gpu, &src, "wgsl", &kilgard_scene());
    check(&a, "kilgard (wgsl, 1 pass)");
}

/// The same program as the paper's three blended passes (geforce256 plan),
/// each pass's WGSL run with its blend and depth state.
#[test]
fn kilgard_geforce256_three_passes_agree_with_cpu_f32() {
    let Some(gpu) = gpu() else { return };
    let a = agreement(&gpu, &kilgard(), "geforce256", &kilgard_scene());
    check(&a, "kilgard (geforce256, 3 passes)");
}

/// Kilgard with the mip chains removed (`bilinear` level 0): isolates the
/// executors' arithmetic from their level-of-detail computations.
#[test]
fn kilgard_without_mipmaps_agrees_with_cpu_f32() {
    let Some(gpu) = gpu() else { return };
    let src = kilgard().replace("target geforce256;", "").replace("mipmap trilinear", "bilinear");
    let a = agreement(&gpu, &src, "wgsl", &kilgard_scene());
    check(&a, "kilgard without mipmaps (wgsl, 1 pass)");
}

/// Every example on Kilgard's torus, planned for its own target (`wgsl`
/// when it names none): exact fidelity against f32 within 2/255, hardware
/// fidelity against fixed9 within 1/255, off the edge mask (allowing for
/// rounding ties, module docs). Shadow volumes are compared by the GPU
/// check's test instead, under its model of the volume's ties.
#[test]
fn every_example_agrees_on_the_torus() {
    let Some(gpu) = gpu() else { return };
    // `SHADEC_AGREEMENT_SCENE=scenes/bump_torus.ron` runs the sweep on another scene.
    let scene = match std::env::var("SHADEC_AGREEMENT_SCENE") {
        Ok(path) => Scene::load(Path::new(&path)).unwrap_or_else(|e| panic!("{path}: {e}")),
        Err(_) => kilgard_scene(),
    };
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/examples");
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter(|n| n.ends_with(".shd"))
        .collect();
    names.sort();
    assert!(names.len() >= 28, "{names:?}");
    // Shadow volumes on the torus shadow the torus itself: along the
    // terminator the volume's walls graze the surface, depth and coverage
    // ties the two rasterizers break differently (GL makes neither
    // invariant across primitives). This sweep has no model of them; the
    // GPU check's has (`gpu_check::shadow_volume_terminator_ties_lie_within_the_model`,
    // all three targets), so the example is compared there.
    names.retain(|n| n != "shadow_volumes.shd");
    // `SHADEC_AGREEMENT_ONLY=embm` narrows the sweep (with `SHADEC_AGREEMENT_DUMP`, its images).
    if let Ok(only) = std::env::var("SHADEC_AGREEMENT_ONLY") {
        names.retain(|n| n.contains(&only));
    }
    let mut failures = Vec::new();
    for name in &names {
        let source = std::fs::read_to_string(format!("{dir}/{name}")).unwrap();
        let target = source
            .lines()
            .find_map(|l| l.trim().strip_prefix("target ")?.strip_suffix(';').map(str::to_string))
            .unwrap_or_else(|| "wgsl".into());
        for (fidelity, tol) in [(Precision::F32, 2), (Precision::Fixed9, 1)] {
            match try_agreement_in(&gpu, &source, &target, &scene, fidelity) {
                Ok(a) => {
                    eprintln!(
                        "{name} ({target}, {fidelity:?}): max {}/255, {} of {} compared pixels over {tol}/255, {} lit; {} agree with a rounding tie taken the other way (without: max {}/255, {} over)",
                        a.max_diff, a.over, a.compared, a.lit, a.ties, a.max_with_ties, a.over_with_ties
                    );
                    // The tie allowance explains a rare pixel, not a pattern (a bias would show on thousands).
                    if a.ties * 1000 > a.lit {
                        failures.push(format!("{name} {fidelity:?}: {} pixels agree only with a rounding tie taken the other way: more than noise", a.ties));
                    }
                    if !a.says_something() {
                        failures.push(format!("{name} {fidelity:?}: only {} of {} compared pixels are lit: the agreement says little", a.lit, a.compared));
                    }
                    if a.max_diff > tol {
                        failures.push(format!(
                            "{name} {fidelity:?}: max {}/255 on {} pixels",
                            a.max_diff, a.over
                        ));
                    }
                }
                Err(e) => failures.push(format!("{name} {fidelity:?}: refused: {e}")),
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Hardware fidelity of the plans the combiner targets make with a lowered
/// table (`table_lowered0`: Kajiya-Kay's and the silhouette's baked
/// function) or a fat texel split into 8-bit members (`T_member0…`:
/// deferred shading, the fat texture map): wgpu against the CPU's fixed9
/// within 1/255 (rounding ties allowed, as above). The GPU check found
/// them unbindable, then 176/255 (the table's last texel: WGSL's `pow`
/// of a negative base) and 13/255 (`(N·H)^16` of members filtered in
/// 8.8 fixed point where the CPU filters rendered textures in float) off.
#[test]
fn lowered_tables_and_fat_members_agree_in_hardware_fidelity() {
    let Some(gpu) = gpu() else { return };
    let scene = kilgard_scene();
    let mut failures = Vec::new();
    for name in ["kajiya_kay_hair", "silhouette", "deferred_shading", "fat_texture_map"] {
        let source =
            std::fs::read_to_string(format!("{}/examples/{name}.shd", env!("CARGO_MANIFEST_DIR"))).unwrap();
        for target in ["geforce3", "geforce256"] {
            let a = try_agreement_in(&gpu, &source, target, &scene, Precision::Fixed9)
                .unwrap_or_else(|e| panic!("{name} on {target}: {e}"));
            eprintln!(
                "{name} ({target}, fixed9): max {}/255, {} of {} compared pixels over 1/255, {} lit; {} agree with a rounding tie taken the other way (without: max {}/255)",
                a.max_diff, a.over, a.compared, a.lit, a.ties, a.max_with_ties
            );
            if a.max_diff > 1 || a.ties * 1000 > a.lit || !a.says_something() {
                failures.push(format!(
                    "{name} on {target}: max {}/255 on {} pixels, {} by ties, {} of {} lit",
                    a.max_diff, a.over, a.ties, a.lit, a.compared
                ));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// An integer power of a negative base: `(N·L)^3` is negative on the
/// torus's dark side, where WGSL's `pow` (exp2 of y·log2 x) is NaN and
/// the IR's `powf` is −|N·L|³; an even power, `(N·L)^4`, is positive.
/// wgpu takes `|x|^k`, negated for an odd k, and agrees with the CPU.
#[test]
fn an_integer_power_of_a_negative_base_agrees_with_the_cpu() {
    let Some(gpu) = gpu() else { return };
    let source = "vector N : normal;\nvector L : light(0);\n\
        shader p : s → c = (0.5 + 0.5 * (N·L)^3, 0.25 + (N·L)^4, 0.5);\n\
        C δπx ← δ p s x;\n";
    let scene = kilgard_scene();
    let a = agreement(&gpu, source, "wgsl", &scene);
    check(&a, "(N·L)^3 and (N·L)^4 (wgsl, f32)");
    let a = agreement_in(&gpu, source, "wgsl", &scene, Precision::Fixed9);
    sane(&a, "(N·L)^3 and (N·L)^4 (wgsl, fixed9)");
    assert!(a.max_diff <= 1 && a.ties * 1000 <= a.lit, "fixed9: max {}/255, {} by ties", a.max_diff, a.ties);
}

// ---------------------------------------------------------------------------
// The texture unit model (`shadec::textures::unit`) against the driver, bit
// for bit, on coordinates both sides compute exactly (dyadic rationals: no
// rounding anywhere before the sampler).

use shadec::gpu::runner::{
    AddressMode, Filter as RunFilter, RunTexture, SamplerSettings, TexelUpload, TextureData,
};
use shadec::textures::{unit, Filter, Level, TexelFormat, Texture2D, TextureCube, Wrap};

/// A deterministic pseudo-random RGBA8 image.
fn noise(n: usize, seed: u64) -> Vec<u8> {
    let mut s = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    (0..n)
        .map(|_| {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (s >> 56) as u8
        })
        .collect()
}

fn level_of(w: u32, h: u32, rgba: &[u8]) -> Level {
    Level::new(w, h, rgba.chunks(4).map(|t| [0, 1, 2, 3].map(|c| t[c] as f32 / 255.0)).collect())
}

/// One full-target rectangle with `fs` as the fragment body.
fn draw_rect(gpu: &Gpu, w: u32, h: u32, decls: &str, body: &str, texture: RunTexture) -> Vec<u8> {
    let wgsl = format!(
        "{decls}\n@group(0) @binding(1) var t: {};\n@group(0) @binding(2) var s: sampler;\nstruct VsOut {{ @builtin(position) pos: vec4<f32> }}\n@vertex fn vs_main(@location(0) p: vec4<f32>) -> VsOut {{ return VsOut(p); }}\n@fragment fn fs_main(i: VsOut) -> @location(0) vec4<f32> {{ let p = i.pos.xy; {body} }}\n",
        if matches!(texture.data, TextureData::Cube { .. }) { "texture_cube<f32>" } else { "texture_2d<f32>" }
    );
    let floats = vec![-1.0, -1.0, 0.0, 1.0, 1.0, -1.0, 0.0, 1.0, 1.0, 1.0, 0.0, 1.0, -1.0, 1.0, 0.0, 1.0];
    let pass = RunPass {
        label: "texture unit".into(),
        shader: RunShader {
            source: ShaderSource::Wgsl(wgsl),
            vertex_entry: "vs_main".into(),
            fragment_entry: "fs_main".into(),
        },
        vertices: VertexData { floats, components: vec![4] },
        indices: vec![0, 1, 2, 0, 2, 3],
        textures: vec![texture],
        uniforms: None,
        state: RenderState {
            cull: CullMode::None,
            depth: DepthState::DISABLED,
            stencil: StencilState::DISABLED,
            blend: BlendState::REPLACE,
            alpha_test: shadec::pipeline::AlphaTest::DISABLED,
        },
        target: PassTarget::Main,
        loaded: vec![],
        outputs: 1,
    };
    run_passes(gpu, &Target::new(w, h), &[pass]).unwrap().into_raw()
}

fn bytes(v: [f32; 4]) -> [u8; 4] {
    v.map(|c| (c * 255.0).round() as u8)
}

/// Bilinear filtering of an 8-bit texture, repeat and clamp, every weight
/// and every rounding tie: identical bytes.
#[test]
fn texture_unit_bilinear_matches_lavapipe_bit_for_bit() {
    let Some(gpu) = gpu() else { return };
    let (tw, th, w, h) = (16u32, 16u32, 256u32, 64u32);
    let rgba = noise((tw * th * 4) as usize, 5);
    for (wrap, address, offset) in
        [(Wrap::Repeat, AddressMode::Repeat, 0.0f32), (Wrap::ClampToEdge, AddressMode::ClampToEdge, -1.5)]
    {
        let sampler =
            SamplerSettings { mag: RunFilter::Linear, min: RunFilter::Linear, address, mipmap: None };
        let body = format!("let uv = vec2<f32>(p.x / 4096.0 + p.y / 16.0 + {offset:?}, p.y * 3.0 / 4096.0 + p.x / 64.0 + {offset:?}); return textureSample(t, s, uv);");
        let got = draw_rect(
            &gpu,
            w,
            h,
            "",
            &body,
            RunTexture {
                data: TextureData::D2 { width: tw, height: th, rgba: rgba.clone() },
                sampler,
                texels: TexelUpload::Rgba8,
            },
        );
        let t = Texture2D::new(TexelFormat::Rgba8, wrap, level_of(tw, th, &rgba));
        let mut differ = 0;
        for y in 0..h {
            for x in 0..w {
                let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
                let (u, v) = (px / 4096.0 + py / 16.0 + offset, py * 3.0 / 4096.0 + px / 64.0 + offset);
                let want = bytes(unit::sample_2d(
                    &t,
                    u,
                    v,
                    Filter::Bilinear,
                    f32::NEG_INFINITY,
                    unit::Arithmetic::FIXED8,
                ));
                let i = 4 * (y * w + x) as usize;
                if got[i..i + 4] != want {
                    differ += 1;
                }
            }
        }
        assert_eq!(differ, 0, "{wrap:?}: {differ} of {} pixels differ from textures::unit", w * h);
    }
}

/// The trilinear pattern of the tests below: a 64² noise texture with its
/// chain, uploaded as `texels`, drawn over 256² with coordinates whose
/// quad derivatives take λ from 0 to 3. Returns lavapipe's image and the
/// model's answer (`textures::unit`) at a pixel.
fn trilinear_pattern(
    gpu: &Gpu,
    texels: TexelUpload,
) -> (Vec<u8>, impl Fn(u32, u32, unit::Arithmetic) -> [u8; 4]) {
    let size = 64u32;
    let (mut levels, mut chain, mut s) = (Vec::new(), Vec::new(), size);
    while s >= 1 {
        let rgba = noise((s * s * 4) as usize, 11 + s as u64);
        chain.push(level_of(s, s, &rgba));
        levels.push(match texels {
            TexelUpload::Rgba8 => rgba,
            TexelUpload::Rgba16 => rgba.iter().flat_map(|&k| (k as u16 * 257).to_ne_bytes()).collect(),
        });
        s /= 2;
    }
    let sampler = SamplerSettings {
        mag: RunFilter::Linear,
        min: RunFilter::Linear,
        address: AddressMode::Repeat,
        mipmap: Some(RunFilter::Linear),
    };
    let body = "let uv = vec2<f32>(p.x * p.x / 4096.0, p.y * p.y / 8192.0); return textureSample(t, s, uv);";
    let got = draw_rect(
        gpu,
        256,
        256,
        "",
        body,
        RunTexture { data: TextureData::D2Mipmapped { width: size, height: size, levels }, sampler, texels },
    );
    let t = Texture2D { format: TexelFormat::Rgba8, wrap: Wrap::Repeat, levels: chain };
    let coord = |x: u32, y: u32| {
        let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
        (px * px / 4096.0, py * py / 8192.0)
    };
    let model = move |x: u32, y: u32, arithmetic| {
        let (x0, y0) = (x & !1, y & !1);
        let (u00, v00) = coord(x0, y0);
        let (u10, v10) = coord(x0 + 1, y0);
        let (u01, v01) = coord(x0, y0 + 1);
        let lod = unit::quad_lod(size, size, [u10 - u00, v10 - v00], [u01 - u00, v01 - v00]);
        let (u, v) = coord(x, y);
        bytes(unit::sample_2d(&t, u, v, Filter::Trilinear, lod, arithmetic))
    };
    (got, model)
}

/// Trilinear filtering with the level of detail from the quad's implicit
/// derivatives (λ from 0 to 3, every 8-bit mip weight): identical bytes.
#[test]
fn texture_unit_trilinear_lod_matches_lavapipe_bit_for_bit() {
    let Some(gpu) = gpu() else { return };
    let (got, model) = trilinear_pattern(&gpu, TexelUpload::Rgba8);
    let differ = (0..256 * 256u32)
        .filter(|&i| {
            got[4 * i as usize..4 * i as usize + 4] != model(i % 256, i / 256, unit::Arithmetic::FIXED8)
        })
        .count();
    assert_eq!(differ, 0, "{differ} of {} pixels differ from textures::unit", 256 * 256);
}

/// Exact fidelity's upload: the same 8-bit texels as 16-bit unorm, which
/// lavapipe filters in float (`unit::Arithmetic::Float`), with the same
/// quad λ: within 1/255 of the model once the result is rounded to the
/// RGBA8 target (float arithmetic orders differ by an ulp, so a few
/// results round the other way), never the 8-bit model's value steps.
#[test]
fn texture_unit_16bit_upload_filters_in_float() {
    let Some(gpu) = gpu() else { return };
    assert!(
        gpu.filters_16bit_norm(),
        "the device has no TEXTURE_FORMAT_16BIT_NORM: exact fidelity falls back to RGBA8"
    );
    let (got, model) = trilinear_pattern(&gpu, TexelUpload::Rgba16);
    let (mut max, mut differ, mut fixed_differ) = (0u8, 0, 0);
    for i in 0..256 * 256u32 {
        let (x, y, k) = (i % 256, i / 256, 4 * i as usize);
        let want = model(x, y, unit::Arithmetic::Float);
        let m = (0..4).map(|c| got[k + c].abs_diff(want[c])).max().unwrap();
        max = max.max(m);
        differ += (m > 0) as usize;
        fixed_differ += (got[k..k + 4] != model(x, y, unit::Arithmetic::FIXED8)) as usize;
    }
    eprintln!("16-bit upload: max {max}/255, {differ} of 65536 pixels differ from the float model, {fixed_differ} from the 8-bit one");
    assert!(max <= 1, "16-bit upload: up to {max}/255 off the float model");
    assert!(differ * 100 < 65536, "16-bit upload: {differ} pixels differ from the float model");
    assert!(fixed_differ > 10 * differ, "16-bit upload looks like 8-bit filtering: {fixed_differ} pixels off the 8-bit model, {differ} off the float one");
}

/// Seamless cube filtering, every face, edge and corner: within 1/255 (the
/// face coordinates are divisions, rounded differently), mostly identical.
#[test]
fn texture_unit_seamless_cube_matches_lavapipe() {
    let Some(gpu) = gpu() else { return };
    let (size, w, h) = (8u32, 256u32, 64u32);
    let rgba = noise((size * size * 4 * 6) as usize, 23);
    let faces: Vec<Texture2D> = (0..6)
        .map(|f| {
            Texture2D::new(
                TexelFormat::Rgba8,
                Wrap::ClampToEdge,
                level_of(
                    size,
                    size,
                    &rgba[(f * size * size * 4) as usize..((f + 1) * size * size * 4) as usize],
                ),
            )
        })
        .collect();
    let cube = TextureCube { faces: faces.try_into().unwrap() };
    let sampler = SamplerSettings {
        mag: RunFilter::Linear,
        min: RunFilter::Linear,
        address: AddressMode::ClampToEdge,
        mipmap: None,
    };
    let body = "let d = vec3<f32>(p.x / 64.0 - 2.0, p.y / 16.0 - 2.0, fract(p.x / 16.0) * 2.0 - 1.0); return textureSample(t, s, d);";
    let got = draw_rect(
        &gpu,
        w,
        h,
        "",
        body,
        RunTexture { data: TextureData::Cube { size, rgba }, sampler, texels: TexelUpload::Rgba8 },
    );
    let (mut max, mut differ) = (0u8, 0);
    for y in 0..h {
        for x in 0..w {
            let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
            let d = [px / 64.0 - 2.0, py / 16.0 - 2.0, (px / 16.0).fract() * 2.0 - 1.0];
            let want = bytes(unit::sample_cube(&cube, d, Filter::Bilinear));
            let i = 4 * (y * w + x) as usize;
            let m = (0..4).map(|c| got[i + c].abs_diff(want[c])).max().unwrap();
            max = max.max(m);
            differ += (m > 0) as usize;
        }
    }
    eprintln!("seamless cube: max {max}/255, {differ} of {} pixels differ", w * h);
    assert!(max <= 1, "seamless cube: up to {max}/255 off textures::unit");
    assert!(differ * 100 < (w * h) as usize, "seamless cube: {differ} pixels differ");
}
