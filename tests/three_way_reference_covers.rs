//! What users write that the independent reference refused, or wgpu could
//! not run, before the sixteenth session (issue 33: every program that
//! plans and renders is evaluated by the reference and run by wgpu): shadow
//! volumes compared other than by z-fail's `>`, stencil counts above one,
//! a program written for light 0 on a scene of several lights with
//! stencil, light-view or rendered-texture statements, the language's
//! "For each light" rule where a product's factors are both lit or the
//! framebuffer is scaled, and 3-D textures rendered over their texels or
//! baked. Each test names what it failed with.

use std::path::Path;

use shadec::numerics::Precision;
use shadec::scene::Scene;

use crate::three_way::{render_three, scene, verdict, Pictures};
use crate::three_way_generated::fixed9_verdict;

/// A scene of `tests/data/heldout_sixteenth_ref/`.
fn own_scene(name: &str) -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/heldout_sixteenth_ref").join(name);
    Scene::parse(&std::fs::read_to_string(&path).unwrap(), &path).unwrap()
}

/// Renders `source` three ways on each of `targets` (f32; fixed9 too on a
/// combiner target), each within its verdict; wgpu must run every plan
/// where a GPU runs the tests. The f32 pictures, by target.
fn agrees(source: &str, targets: &[&str], sc: &Scene) -> Vec<Pictures> {
    let g = crate::common::gpu::gpu();
    let mut out = Vec::new();
    for &target in targets {
        let mut runs = vec![Precision::F32];
        if target != "wgsl" {
            runs.push(Precision::Fixed9);
        }
        for precision in runs {
            let p = render_three(source, target, sc, precision, g.as_ref())
                .unwrap_or_else(|e| panic!("{target} {precision:?}: {e}"));
            assert!(p.gpu_refused.is_none(), "{target}: wgpu refused: {:?}", p.gpu_refused);
            let v = if precision == Precision::Fixed9 { fixed9_verdict(&p, &mut 0) } else { verdict(&p) };
            v.unwrap_or_else(|e| panic!("{target} {precision:?}: {e}"));
            if precision == Precision::F32 {
                out.push(p);
            }
        }
    }
    out
}

/// Compared pixels whose red channel in the reference is within a step of `value`.
fn at(p: &Pictures, value: u8) -> usize {
    let mask = p.compared_mask();
    (0..mask.len()).filter(|&i| mask[i] && p.oracle[4 * i].abs_diff(value) <= 1).count()
}

const SHADOW_HEAD: &str = "vector N : normal;\nvector L : light(0);\nconst ka : rgb = (0.1, 0.1, 0.1);\nconst kd : rgb = (0.7, 0.7, 0.7);\nshader amb : s → c = ka;\nshader lit : s → c = ka + kd * max(0, N·L);\nC δπx ← δ amb s x;\n";

/// Shadow volumes counted in front of the visible surface (Heidmann 1991's
/// z-pass: `z δπx′ < z C δπx′`, and `≤`) and behind it inclusively (`≥`):
/// the executors count the volume's faces the comparison passes, +1 on
/// back faces and −1 on front ones (the plan's counting by facing); the
/// reference takes the volumes' winding numbers at the ends of the ray's
/// stretch they lie on. With the camera outside every volume both mark
/// the floor's shadow. The reference refused every comparison but `>`.
#[test]
fn shadow_volumes_compared_by_every_comparison_agree_three_ways() {
    let sc = scene("shadow_occluder_floor.ron");
    for cmp in
        ["(z δπx′) < (z C δπx′)", "(z δπx′) <= (z C δπx′)", "(z δπx′) >= (z C δπx′)", "(z C δπx′) > (z δπx′)"]
    {
        let source =
            format!("{SHADOW_HEAD}σ C δπx ← (σ C δπx) OR ({cmp});\nC δπx ← (¬σ C δπx) ? (δ lit s x);\n");
        for p in agrees(&source, &["wgsl", "geforce3"], &sc) {
            let shadowed = at(&p, 26);
            assert!(shadowed >= 20, "{cmp}: {shadowed} pixels in shadow");
        }
    }
}

/// The stencil holds the count, not a mark: where two balls' shadow
/// volumes overlap on the floor z-fail counts 2, and a screen pass that
/// reads the stencil's value (`σ C xs`) darkens those pixels twice. The
/// reference set the stencil to 1 wherever a volume counted, so it was
/// the odd one out on the overlap.
#[test]
fn stencil_counts_two_where_two_shadow_volumes_overlap() {
    let source = format!(
        "{SHADOW_HEAD}const count : rgba = (0, 0, 0.3, 0);\nσ C δπx ← (σ C δπx) OR ((z δπx′) > (z C δπx′));\nC δπx ← (¬σ C δπx) ? (δ lit s x);\nC xs ← (C xs) + count * (σ C xs);\n"
    );
    let p = agrees(&source, &["wgsl"], &own_scene("two_balls_floor.ron")).remove(0);
    // In shadow red is the ambient 0.1 (26/255) and blue has 0.3 per
    // count added: 102 at a count of 1, 179 at 2 (lit pixels are grey).
    let mask = p.compared_mask();
    let blue = |b: u8| {
        (0..mask.len())
            .filter(|&i| mask[i] && p.oracle[4 * i].abs_diff(26) <= 1 && p.oracle[4 * i + 2].abs_diff(b) <= 1)
            .count()
    };
    let (once, twice) = (blue(102), blue(179));
    eprintln!("{once} pixels counted once, {twice} twice");
    assert!(once >= 20 && twice >= 20, "{once} pixels counted once, {twice} twice");
}

/// Shadow volumes, a shadow map and a stencil decal written for light 0
/// on scenes of three and four lights: the stencil, light-view and
/// rendered-texture statements run for light 0 as written, the colour
/// statements at the fragments add every other light's terms (the
/// language's "For each light"). The reference refused such programs.
#[test]
fn light_0_programs_with_stencil_and_light_views_on_several_lights_agree() {
    let lamps = own_scene("two_lamps_floor.ron");
    assert_eq!(lamps.lights.len(), 3);
    let volumes = format!(
        "{SHADOW_HEAD}σ C δπx ← (σ C δπx) OR ((z δπx′) > (z C δπx′));\nC δπx ← (¬σ C δπx) ? (C δπx) ⊕[add] (δ lit s x);\n"
    );
    agrees(&volumes, &["wgsl", "geforce3"], &lamps);
    let map = "vector N : normal;\nvector L : light(0);\nconst ka : rgb = (0.12, 0.12, 0.14);\nconst kd : rgb = (0.55, 0.5, 0.45);\nframebuffer Lit : rgba8, depth;\nframebuffer Cl : depth;\nshader p : s → c = ka + kd * max(0, N·L);\nC δπx ← ka;\nLit δπx ← δ p s x;\nCl δπl x ← δ x;\nα C xs ← (z πl π⁻¹ xs) > (z Cl πl π⁻¹ xs) + 0.003;\nC xs ← (α C xs)*(C xs) + (1 – α C xs)*(Lit xs);\n";
    agrees(map, &["wgsl", "geforce3"], &lamps);
    let rendered = "vector N : normal;\nvector L : light(0);\ntexture Look : 2d rgba8 nearest clamp;\nshader m : s → c = (0.2, 0.2, 0.2) + (0.7, 0.6, 0.5) * max(0, N·L);\nLook δπx ← δ m s x;\nC δπx ← δ m s x;\nC xs ← 0.5 * (C xs) + 0.5 * (Look xs);\n";
    agrees(rendered, &["wgsl"], &lamps);
}

/// "For each light" distributes a product over a sum only where one factor
/// depends on the light: `(ka + d(L))·(kb + g(L))` is one light term,
/// added whole for every light (`ka·kb` included), and a statement that
/// scales the framebuffer (`0.5·C + d(L)`) is no replacement or addition:
/// light 0 only. The reference multiplied every product out (`ka·kb`
/// once) and added light terms under a scaled framebuffer; the planner,
/// the CPU and wgpu follow the rule.
#[test]
fn for_each_light_splits_products_and_blends_as_the_language_says() {
    let sc = scene("adaptive_sphere_4lights.ron");
    let head = "vector N : normal;\nvector L : light(0);\nvector H : half(0);\nconst ka : rgb = (0.3, 0.3, 0.3);\nconst kd : rgb = (0.6, 0.5, 0.4);\nshader d : s → scalar = max(0, N·L);\nshader g : s → scalar = max(0, N·H)^8;\n";
    let both_lit = format!("{head}C δπx ← kd * ((0.2 + δ d s x) * (0.5 + δ g s x));\n");
    agrees(&both_lit, &["wgsl"], &sc);
    let scaled = format!("{head}C δπx ← ka;\nC δπx ← 0.5 * (C δπx) + kd * (δ d s x);\n");
    agrees(&scaled, &["wgsl"], &sc);
}

/// A 3-D texture filled over its texels (the grid of its slices, tiled
/// 4 × 4, docs/solid-textures.md) and looked up at the scaled object
/// position: GL 1.2's `TEXTURE_3D`, trilinear within its one level. The
/// reference refused statements rendering into 3-D textures.
#[test]
fn a_3d_texture_rendered_over_its_texels_agrees_three_ways() {
    // The reference's volume is the renderer's (it may not import it).
    use shadec::textures::solid::{SIDE, SLICES, TILES};
    assert_eq!(shadec::oracle::rendered::VOLUME, [SIDE, SIDE, SLICES]);
    assert_eq!(shadec::oracle::rendered::SLICES_PER_ROW, TILES);
    let source = "vector P : position in object;\ntexture V : 3d rgba8 bilinear clamp;\nshader f : s → c = rgb(s.x, 0.3 + 0.6 * s.y, fract(3 * s.x + s.y));\nV δu ← f s δu;\nC δπx ← V δ(0.5 + 0.5 * (P s x));\n";
    agrees(source, &["wgsl"], &scene("bench_sphere.ron"));
}

/// A baked 3-D table (`texture V : 3d … = bake(f)`): the texel pass is the
/// compiler's, and the lookup is the tiled volume's on every executor.
/// wgpu declared the baked volume a 3-D texture while the runner bound the
/// grid its pass rendered (a 2-D texture): a pipeline validation error.
#[test]
fn a_baked_3d_texture_runs_on_wgpu() {
    let source = "vector N : normal;\nvector L : light(0);\nvector P : position in object;\nshader f : s → c = rgb(0.6 + 0.4 * s.x, 0.5 + 0.3 * s.y, 0.7);\ntexture V : 3d rgba8 bilinear clamp = bake(f);\nshader lit : s → scalar = 0.25 + 0.75 * max(0, N·L);\nC δπx ← (V δ(0.5 + 0.5 * (P s x))) * (δ lit s x);\n";
    agrees(source, &["wgsl"], &scene("bench_sphere.ron"));
}

/// A 3-D texture declared `repeat` looked up beyond [0, 1]³ (the object
/// position times 1.5, rendered over its texels and baked): its texel
/// indices wrap (GL 1.2 §3.8.7), on every axis and in the filter. The CPU
/// (`textures::solid`) and wgpu (`codegen::solid`) clamped the tiled
/// volume to its edge whatever the declaration — the same picture as
/// `clamp`, 224/255 off the reference on 97 % of the sphere.
#[test]
fn a_repeated_3d_texture_wraps_on_every_executor() {
    let rendered = "vector P : position in object;\ntexture V : 3d rgba8 bilinear repeat;\nshader rings : s → c = rgb(0.5 + 0.5 * sin(12 * s.x), 0.4 + 0.4 * s.y, 0.3 + 0.5 * fract(4 * s.y));\nV δu ← rings s δu;\nC δπx ← V δ(1.5 * (P s x));\n";
    let baked = "vector P : position in object;\nshader f : s → c = rgb(0.6 + 0.4 * s.x, 0.5 + 0.3 * s.y, 0.3);\ntexture V : 3d rgba8 bilinear repeat = bake(f);\nC δπx ← V δ(1.5 * (P s x));\n";
    let nearest = rendered.replace("bilinear repeat", "nearest repeat");
    let sc = scene("bench_sphere.ron");
    for source in [rendered, baked, nearest.as_str()] {
        let p = agrees(source, &["wgsl"], &sc);
        // Not the clamped picture: the same lookup declared `clamp` differs.
        let clamped = agrees(&source.replace(" repeat", " clamp"), &["wgsl"], &sc);
        let d = crate::three_way::difference(&p[0].cpu, &clamped[0].cpu, &p[0].compared_mask());
        assert!(!d.within(), "{source}: repeat renders as clamp: {d:?}");
    }
}

/// A 2-D table declared `repeat`, baked or rendered over its texels, read
/// past [0, 1]² (the texture coordinates times 3): its coordinates wrap
/// (GL §3.8.7) on every executor, in f32 and fixed9. The reference
/// evaluated a baked table at coordinates clamped to [0, 1] whatever the
/// declaration, the CPU renderer kept every rendered texture clamped to
/// its edge, and so did wgpu's fixed9 shader filter; only wgpu's f32
/// sampler wrapped (203/255 off the CPU and the reference on 86 % of the
/// torus, the odd one out; on geforce3 all three showed the clamped
/// picture).
#[test]
fn a_repeated_2d_table_wraps_on_every_executor() {
    let f =
        "shader f : s → c = rgb(0.5 + 0.4 * sin(6.2831853 * s.x), 0.5 + 0.4 * cos(6.2831853 * s.y), 0.3);\n";
    let baked = format!("{f}texture B : 2d rgba8 bilinear repeat = bake(f);\nC δπx ← B δ(3 * (u x));\n");
    let rendered =
        format!("{f}texture B : 2d rgba8 bilinear repeat;\nB δu ← f s δu;\nC δπx ← B δ(3 * (u x));\n");
    let sc = scene("kilgard_torus.ron");
    for source in [baked, rendered] {
        let p = agrees(&source, &["wgsl", "geforce3"], &sc);
        // Not the clamped picture: the same lookup declared `clamp` differs.
        let clamped = agrees(&source.replace(" repeat", " clamp"), &["wgsl"], &sc);
        let d = crate::three_way::difference(&p[0].cpu, &clamped[0].cpu, &p[0].compared_mask());
        assert!(!d.within(), "{source}: repeat renders as clamp: {d:?}");
        let d = crate::three_way::difference(&p[0].oracle, &clamped[0].oracle, &p[0].compared_mask());
        assert!(!d.within(), "{source}: the reference reads repeat as clamp: {d:?}");
    }
}

const CUBE: &str = "vector R : reflection;\ntexture E : cube rgba8 bilinear clamp;\nshader sky : s → c = rgb(s.x, s.y, 0.8);\nE δu ← sky s δu;\nC δπx ← E δ R s x;\n";

/// A cube map filled over its texels (`E δu ← f s δu`): six faces, each
/// the grid the statement rendered at the face's (s, t) (GL 1.3 §3.8.6, six
/// 2-D images), looked up by direction (Table 3.19's faces) on every
/// executor. The reference evaluated it; the CPU sampled the rendered grid
/// as if it were a tiled 3-D texture (its lookups at a vec3 of a rendered
/// texture were all read so: 251/255 off on every pixel of the torus), and
/// the wgpu scene runner refused it by name (before that it bound the 2-D
/// target to the shader's cube view, a pipeline validation error). wgpu
/// renders into layer 0 of a six-layer texture and copies it into the
/// other faces after the last pass into it.
#[test]
fn a_cube_map_rendered_over_its_texels_agrees_three_ways() {
    let p = agrees(CUBE, &["wgsl"], &scene("kilgard_torus.ron")).remove(0);
    // Not one colour: the reflections read several faces and places.
    let mask = p.compared_mask();
    let reds: std::collections::BTreeSet<u8> =
        (0..mask.len()).filter(|&i| mask[i]).map(|i| p.oracle[4 * i]).collect();
    assert!(reds.len() > 20, "{} distinct reds", reds.len());
}

/// The same cube map baked (`= bake(f)`): the texel pass is the compiler's,
/// and the lookup by direction the same on every executor.
#[test]
fn a_baked_cube_map_agrees_three_ways() {
    let source = "vector R : reflection;\nshader sky : s → c = rgb(s.x, s.y, 0.8);\ntexture E : cube rgba8 bilinear clamp = bake(sky);\nC δπx ← E δ R s x;\n";
    agrees(source, &["wgsl"], &scene("kilgard_torus.ron"));
}
