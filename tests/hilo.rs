//! HILO normal maps on geforce3 (docs/hilo.md): a two-channel `signed16`
//! map whose third component is rebuilt as NV_texture_shader's
//! SIGNED_HILO16 format computes it, read by DOT_PRODUCT_TEXTURE_2D stages
//! (NV_texture_shader, Section 3.8.13); refused, located, on geforce256;
//! the CPU's emulated plan against the plan's WGSL on wgpu; `signed16`
//! texels stored at 16 bits.

use std::collections::BTreeMap;
use std::path::Path;

use shadec::backends::combiners::ts1::{DotFamily, Operation};
use shadec::backends::combiners::{self, CombinerLimits};
use shadec::backends::vertex_program::program::Output;
use shadec::diag::SourceFile;
use shadec::pipeline::Planned;
use shadec::profile::Profile;

fn example() -> String {
    std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/hilo_bump.shd")).unwrap()
}

fn plan(source: &str, target: &str) -> Result<Planned, Vec<shadec::diag::Diagnostic>> {
    let profile = Profile::resolve(target).unwrap();
    shadec::driver::compile(source, &profile, &Default::default()).map(|c| c.planned)
}

/// The pass that reads the HILO map (the last: the first renders the `bake` table).
fn hilo_pass(planned: &Planned) -> usize {
    planned.plan.passes.len() - 1
}

/// Refused before this session ("needs `sqrt` per fragment"): now three
/// texture units — `texture_2d` of the HILO map, then `dot_product_2d_1of2`
/// and `_2of2` reading it — and combiners that only pass texture 2 on.
#[test]
fn hilo_normal_map_plans_on_geforce3_through_the_texture_shader() {
    let planned = plan(&example(), "geforce3").unwrap_or_else(|d| panic!("{d:?}"));
    let index = hilo_pass(&planned);
    let g = combiners::setup::of(&planned, index).unwrap();
    let ts = g.config.texture_shader.as_ref().expect("a texture-shader program");
    assert_eq!(ts.stages.len(), 3, "{ts:?}");
    assert_eq!(ts.stages[0], Operation::Texture2d);
    for (step, op) in ts.stages[1..].iter().enumerate() {
        match *op {
            Operation::DotProduct {
                family: DotFamily::Texture2d, step: s, previous: 0, eye: None, ..
            } => {
                assert_eq!(usize::from(s), step)
            }
            other => panic!("unit {}: {other:?}", step + 1),
        }
    }
    // The setup's text reads back as the same program (the `!!TS1.0` and
    // `!!RC1.0` readers), and the combiners read texture 2 only.
    let text = combiners::rc1::print(&g.config);
    let back = combiners::rc1::parse_and_validate(&text, &CombinerLimits::GEFORCE3)
        .unwrap_or_else(|d| panic!("{d:?}\n{text}"));
    assert_eq!(back.texture_shader.as_ref(), Some(ts));
    let rc = &text[text.find("!!RC1.0").unwrap()..];
    assert!(rc.contains("tex2") && !rc.contains("tex0") && !rc.contains("tex1"), "{rc}");
    insta::assert_snapshot!("hilo_bump_geforce3_ts1_rc1", text);
}

/// The vertex program feeds the units as the texture shader reads them:
/// u x to unit 0, L to unit 1 and H to unit 2 (the dot products' (s, t, r)).
#[test]
fn hilo_vertex_program_writes_each_dot_products_vector_to_its_unit() {
    let planned = plan(&example(), "geforce3").unwrap();
    let index = hilo_pass(&planned);
    let pi = shadec::pipeline::PassInterface::of(&planned, index);
    let outputs = shadec::backends::vertex_program::emit::outputs_for(&planned, index, &pi);
    let want: Vec<Output> = (0..3).map(Output::tex).collect();
    assert_eq!(outputs, want);
}

/// GeForce 256 has neither signed textures nor texture shaders: refused at
/// the HILO lookup and at the dependent lookup, each located.
#[test]
fn hilo_on_geforce256_is_refused_located() {
    let source = example().replace("target geforce3;", "target geforce256;");
    let errors = plan(&source, "geforce256").expect_err("geforce256 has no HILO textures");
    let file = SourceFile::new("hilo_bump.shd", source.clone());
    let at = |needle: &str| {
        let start = source.find(needle).unwrap() as u32;
        file.location(start)
    };
    let located: Vec<(String, String)> =
        errors.iter().map(|d| (file.location(d.primary.span.start), d.message.clone())).collect();
    assert!(
        located.iter().any(|(l, m)| *l == at("Nh δu x;") && m.contains("signed textures")),
        "{located:?}"
    );
    assert!(
        located.iter().any(|(l, m)| *l == at("Tlit vec2") && m.contains("dependent lookup")),
        "{located:?}"
    );
    assert!(errors.iter().all(|d| d.help.as_ref().is_some_and(|h| !h.is_empty())), "{errors:?}");
}

/// A HILO texel that the combiners read itself (not through the dot
/// products) has no hardware reading on geforce3: still refused, located
/// at the `sqrt` the combiners would need.
#[test]
fn a_hilo_normal_read_by_the_combiners_is_refused_located() {
    let source =
        example().replace("C δπx ← Tlit vec2(N · δ L s x, N · δ H s x);", "C δπx ← rgb(compress(N));");
    let errors = plan(&source, "geforce3").expect_err("the combiners have no sqrt");
    assert!(errors.iter().any(|d| d.message.contains("sqrt")), "{errors:?}");
    let file = SourceFile::new("hilo_bump.shd", source.clone());
    let want = file.location(source.find("C δπx ← rgb").unwrap() as u32);
    assert!(errors.iter().any(|d| file.location(d.primary.span.start) == want), "{errors:?}");
}

/// A component of `bumps()` that 8 bits cannot hold, stored as `signed16`:
/// it comes back as its nearest k/32767, within half a 16-bit step of the
/// unquantized value, where 8 bits would have moved it by more.
#[test]
fn signed16_holds_what_8_bits_cannot() {
    let stored = bumps("signed16", shadec::scene::bind::TextureQuality::Stored);
    let exact = bumps("signed16", shadec::scene::bind::TextureQuality::Exact);
    assert_eq!(stored.len(), exact.len());
    let mut finer = 0;
    for (s, e) in stored.iter().zip(&exact) {
        assert_eq!(*s, shadec::textures::sampling::signed16(*e), "stored is the nearest k/32767");
        assert!((s - e).abs() <= 0.5 / 32767.0 + 1e-7, "{s} vs {e}");
        let eight = (e * 127.0).round() / 127.0;
        if (eight - e).abs() > 0.25 / 127.0 && (s - e).abs() < 0.01 / 127.0 {
            finer += 1;
        }
    }
    assert!(finer * 4 > stored.len(), "{finer} of {} components held finer than 8 bits", stored.len());
}

fn bumps(format: &str, quality: shadec::scene::bind::TextureQuality) -> Vec<f32> {
    use shadec::scene::bind;
    let source =
        format!("texture B : 2d {format} = bumps(8);\nC δπx ← rgb(vec3((B δu x).x, (B δu x).y, 0));\n");
    let (program, diags) = shadec::parser::check(&source);
    assert!(diags.iter().all(|d| !d.is_error()), "{diags:?}");
    let scene = shadec::scene::Scene::parse(
        "(camera: (eye: (0.0, 0.0, 3.0), target: (0.0, 0.0, 0.0), up: (0.0, 1.0, 0.0)), objects: [])",
        Path::new(""),
    )
    .unwrap();
    let decls = bind::texture_decls(&shadec::ir::lower(&program).0, &BTreeMap::new());
    let textures = bind::load_textures(&decls, &scene, quality, &mut Vec::new()).unwrap();
    let shadec::textures::Texture::Flat(t) = &textures["B"].texture else { panic!("a 2-D texture") };
    t.levels[0].texels.iter().flat_map(|c| c[..3].to_vec()).collect()
}

#[cfg(feature = "gpu")]
mod gpu {
    use super::*;
    use shadec::gpu::scene_run::ScenePlan;
    use shadec::numerics::Precision;
    use shadec::renderer::plan::PlanRenderer;
    use shadec::scene::Scene;

    const W: u32 = 640;
    const H: u32 = 480;

    fn kilgard_scene() -> Scene {
        let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/kilgard_torus.ron"))
            .unwrap();
        Scene::parse(&text, Path::new("/nonexistent-shadec-scene/kilgard_torus.ron")).unwrap()
    }

    /// (largest channel difference, pixels over 1/255, compared, lit) on
    /// the torus off the triangle-edge mask, CPU against wgpu, both in `precision`.
    fn difference(gpu: &shadec::gpu::runner::Gpu, precision: Precision) -> (u8, usize, usize, usize) {
        let source = example();
        let planned = plan(&source, "geforce3").unwrap();
        let (program, _) = shadec::parser::check(&source);
        let scene = kilgard_scene();
        let assets = scene.build().unwrap();
        let cpu = PlanRenderer::new(&planned, &program, &scene, &assets).unwrap();
        let cpu = cpu.render(precision, W, H, &mut |_, _| {}).unwrap().image.to_rgba8();
        let target = if precision == Precision::Fixed9 {
            shadec::gpu::runner::Target::new(W, H)
        } else {
            shadec::gpu::runner::Target::float(W, H)
        };
        let run = ScenePlan::new(&planned, &program, Some(&source), precision, &scene, &assets).unwrap();
        let wgpu = run.render_into(gpu, &target).unwrap().into_raw();
        let ids = shadec::bench::gpu_check::triangle_ids(gpu, &scene, &assets, (W, H)).unwrap();
        let mask = shadec::bench::gpu_check::edge_mask(&ids, (W, H));
        let (mut max, mut over, mut compared, mut lit) = (0u8, 0, 0, 0);
        for i in (0..(W * H) as usize).filter(|&i| !mask[i] && ids[i] != 0) {
            let d = (0..3).map(|c| cpu[4 * i + c].abs_diff(wgpu[4 * i + c])).max().unwrap();
            max = max.max(d);
            over += usize::from(d > 1);
            compared += 1;
            lit += usize::from(cpu[4 * i..4 * i + 3].iter().any(|&c| c > 8));
        }
        eprintln!(
            "hilo_bump {precision:?}: max {max}/255, {over} of {compared} pixels over 1/255, {lit} lit"
        );
        (max, over, compared, lit)
    }

    /// The bound (docs/hilo.md): both executors compute the coordinates in
    /// f32 from the same 16-bit texels (the CPU filters k/32767, wgpu the
    /// 16-bit unorm upload: ≤ 1.5·10⁻⁵ apart per component, z's root at
    /// most doubling it on the map's normals), so the dot products differ
    /// by ≲ 10⁻⁴ and the illumination table's bilinear value by ≲ 10⁻³
    /// (its steepest slope, 16·ks, times that); the combiners' register
    /// load rounds it to 8 bits (9-bit signed registers, bit-exact on both
    /// sides), so one rounding may go either way: at most 1/255, and on no
    /// more than 1% of the pixels.
    #[test]
    fn hilo_cpu_agrees_with_wgsl_within_one_step() {
        let Some(gpu) = crate::common::gpu::gpu() else { return };
        for precision in [Precision::Fixed9, Precision::F32] {
            let (max, over, compared, lit) = difference(&gpu, precision);
            // Thousands of pixels inside the torus's triangles, a tenth of them lit.
            assert!(compared > 5000 && lit * 10 > compared, "{precision:?}: {lit} of {compared} lit");
            assert!(max <= 1, "{precision:?}: CPU and wgpu differ by {max}/255 ({over} pixels over 1/255)");
        }
    }
}
