//! The reference's level-of-detail hull (`oracle/hull/`): every
//! minified lookup chooses its λ on its own (GL §3.8.8), for any number of
//! lookups, and the hull holds every such choice — where the range over
//! renders of the lookups' extremes (`oracle::render_enumerated`, the
//! reference's range before) did not beyond two lookups — while a render
//! off by a level still falls outside it.

use shadec::numerics::Precision;
use shadec::oracle::{self, LodChoices, Picture};
use shadec::profile::Profile;

use crate::three_way::{render_three, scene, verdict, Pictures, H, PIXEL_TOLERANCE, W};

pub(crate) const HEAD: &str = "texture A : 2d rgb8 mipmap trilinear repeat = image(\"missing-a.png\");\n\
    texture B : 2d rgb8 mipmap trilinear repeat = image(\"missing-b.png\");\n\
    texture D : 2d rgb8 mipmap trilinear repeat = image(\"missing-d.png\");\n\
    framebuffer C : rgba8, depth;\n";

/// Four minified lookups at four scales, a product and a sum, one of them
/// dependent (`D` read at coordinates `B` offsets, Pipeline Grammar,
/// eq. (8)).
const FOUR: &str = "C δπx ← (A δu x) * (B δ(3 * (u x))) + 0.5 * (D δ((u x) + 0.05 * (B δ(5 * (u x))).rg));\n";

pub(crate) struct Compiled {
    pub(crate) module: shadec::ir::Module,
    pub(crate) program: shadec::parser::ast::Program,
    pub(crate) scene: shadec::scene::Scene,
    pub(crate) assets: shadec::scene::SceneAssets,
}

pub(crate) fn compiled(body: &str) -> Compiled {
    compiled_in(body, scene("kilgard_torus.ron"))
}

pub(crate) fn compiled_in(body: &str, scene: shadec::scene::Scene) -> Compiled {
    let assets = scene.build().unwrap();
    let profile = Profile::resolve("wgsl").unwrap();
    let c = shadec::driver::compile(&format!("{HEAD}{body}"), &profile, &Default::default()).unwrap();
    Compiled { module: c.module, program: c.program, scene, assets }
}

impl Compiled {
    pub(crate) fn hull(&self) -> Picture {
        let p = oracle::render_with(
            &self.module,
            &self.program,
            &self.scene,
            &self.assets,
            (W, H),
            Default::default(),
        )
        .unwrap();
        assert!(p.hull_refused.is_none(), "{:?}", p.hull_refused);
        p
    }

    /// The hull on intervals alone, every read of a lookup and each of its
    /// channels as if apart (`oracle::Options::interval_hull`): the
    /// reference's hull before its affine forms.
    pub(crate) fn interval_hull(&self) -> Picture {
        let options = oracle::Options { interval_hull: true, ..Default::default() };
        oracle::render_with(&self.module, &self.program, &self.scene, &self.assets, (W, H), options).unwrap()
    }

    pub(crate) fn enumerated(&self) -> Picture {
        oracle::render_enumerated(
            &self.module,
            &self.program,
            &self.scene,
            &self.assets,
            (W, H),
            Default::default(),
        )
        .unwrap()
    }

    pub(crate) fn chosen(&self, choices: &LodChoices) -> Picture {
        let size = (W, H);
        oracle::render_chosen(
            &self.module,
            &self.program,
            &self.scene,
            &self.assets,
            size,
            Default::default(),
            choices,
        )
        .unwrap()
    }

    fn lookups(&self) -> Vec<oracle::LookupKey> {
        oracle::minified_lookups(&self.module, &self.program, &self.scene, &self.assets, (W, H)).unwrap()
    }
}

/// How many of the pixels `compared` marks have a channel of `p` more than
/// `by` outside `low..=high` (in [0, 1]).
pub(crate) fn outside(
    p: &[[f64; 4]],
    low: &[[f64; 4]],
    high: &[[f64; 4]],
    compared: &[bool],
    by: f64,
) -> usize {
    (0..p.len())
        .filter(|&i| compared[i] && (0..4).any(|c| p[i][c] < low[i][c] - by || p[i][c] > high[i][c] + by))
        .count()
}

fn rgba8(p: &[[f64; 4]]) -> Vec<u8> {
    p.iter().flat_map(|p| p.map(|c| (c.clamp(0.0, 1.0) * 255.0).round() as u8)).collect()
}

/// Every lookup at its own extreme: the k-th assignment of choices 1 (λ's
/// low end) and 2 (its high end) to the lookups, by the bits of `k`.
fn mixed(lookups: &[oracle::LookupKey], k: usize) -> LodChoices {
    let of = lookups.iter().enumerate().map(|(i, &l)| (l, 1 + ((k >> i) & 1))).collect();
    LodChoices { default: 0, of, bias: 0.0 }
}

/// Four minified lookups, one dependent: an implementation taking one
/// lookup's λ at the low end of its interval and another's at the high end
/// (GL §3.8.8 gives each its own) draws pixels the enumerated range — all
/// lookups sharing a choice, the dependent one apart — misses by more than
/// the three-way tolerance; the hull holds every such render on every
/// pixel, exactly (no tolerance), and the CPU and wgpu lie within it.
#[test]
fn the_hull_holds_every_lookups_own_choice_where_the_enumerated_range_did_not() {
    let c = compiled(FOUR);
    let lookups = c.lookups();
    assert_eq!(lookups.len(), 4, "{lookups:?}");
    let (hull, enumerated) = (c.hull(), c.enumerated());
    let seen: Vec<bool> =
        (0..hull.pixels.len()).map(|i| hull.covered[i] && !enumerated.latitude[i]).collect();
    let (mut missed, mut worst) = (0, 0);
    for k in 0..1 << lookups.len() {
        let p = c.chosen(&mixed(&lookups, k));
        let inside = outside(&p.pixels, &hull.low, &hull.high, &hull.covered, 1e-9);
        assert_eq!(inside, 0, "choices {k:b}: {inside} pixels outside the hull");
        let off =
            outside(&p.pixels, &enumerated.low, &enumerated.high, &seen, f64::from(PIXEL_TOLERANCE) / 255.0);
        eprintln!(
            "choices {k:04b}: {off} pixels outside the enumerated range by more than {PIXEL_TOLERANCE}/255"
        );
        (missed, worst) = (missed + usize::from(off > 0), worst.max(off));
    }
    assert!(
        missed > 0 && worst >= 5,
        "the enumerated range held every choice: {missed} renders, {worst} pixels"
    );
    let g = crate::common::gpu::gpu();
    let p = render_three(&format!("{HEAD}{FOUR}"), "wgsl", &c.scene, Precision::F32, g.as_ref()).unwrap();
    verdict(&p).unwrap();
    let mask = p.compared_mask();
    for (who, e) in [("CPU", Some(&p.cpu)), ("wgpu", p.gpu.as_ref())] {
        let Some(e) = e else { continue };
        let off = crate::three_way::largest(e, &p.reference_near(e), &mask);
        assert!(off <= PIXEL_TOLERANCE, "{who} {off}/255 outside the hull");
    }
}

/// Where the combinations can be rendered (up to two minified lookups),
/// the hull holds every one: its least at most the enumerated range's
/// least, its greatest at least the greatest, on every pixel — for a
/// product, a non-monotone `x·(1 − x)` and a power. It is not much wider
/// where the program is monotone in each lookup.
#[test]
fn the_hull_holds_every_enumerated_combination() {
    for body in [
        "C δπx ← (A δu x) * (B δ(3 * (u x)));\n",
        "C δπx ← 4 * (A δu x) * ((1, 1, 1) - (A δu x));\n",
        "C δπx ← (A δ(2 * (u x)))^4 + 0.5 * (B δu x);\n",
    ] {
        let c = compiled(body);
        let (hull, enumerated) = (c.hull(), c.enumerated());
        let seen: Vec<bool> =
            (0..hull.pixels.len()).map(|i| hull.covered[i] && !enumerated.latitude[i]).collect();
        let ranged = (0..seen.len()).filter(|&i| seen[i] && enumerated.low[i] != enumerated.high[i]).count();
        assert!(ranged >= 50, "{body}: {ranged} pixels ranged");
        for (name, p) in [("least", &enumerated.low), ("greatest", &enumerated.high)] {
            let off = outside(p, &hull.low, &hull.high, &seen, 1e-9);
            assert_eq!(off, 0, "{body}: the enumerated {name} outside the hull on {off} pixels");
        }
        let width = |p: &Picture, i: usize| (0..3).map(|k| p.high[i][k] - p.low[i][k]).fold(0.0, f64::max);
        let wider = (0..seen.len())
            .filter(|&i| seen[i] && width(&hull, i) > width(&enumerated, i) + 2.0 / 255.0)
            .count();
        eprintln!("{body}: {ranged} ranged, the hull wider by more than 2/255 on {wider}");
        if !body.contains("- (A") {
            assert!(wider * 10 <= ranged, "{body}: the hull wider on {wider} of {ranged}");
        }
    }
}

/// `p` with `pixels` (one render of the reference's, as an implementation
/// would draw it) in the CPU's place and no wgpu, compared against the
/// range of `range` (the reference's own, as `render_three` made it, where
/// `None`).
pub(crate) fn as_cpu(p: &Pictures, pixels: &[[f64; 4]], range: Option<&Picture>) -> Pictures {
    let (oracle_low, oracle_high) = match range {
        Some(r) => (rgba8(&r.low), rgba8(&r.high)),
        None => (p.oracle_low.clone(), p.oracle_high.clone()),
    };
    Pictures {
        cpu: rgba8(pixels),
        gpu: None,
        oracle: p.oracle.clone(),
        covered: p.covered.clone(),
        wide: p.wide.clone(),
        oracle_low,
        oracle_high,
        oracle_unclamped: None,
        oracle_unclamped_range: None,
        gpu_refused: None,
        rules: p.rules.clone(),
        ..*p
    }
}

/// The hull is tight enough to tell a render whose λ is a level off
/// (every lookup's eq. 3.17 λ plus one, `LodChoices::bias`): put in the
/// CPU's place, it fails the three-way verdict, where the render at eq.
/// 3.17's λ passes.
#[test]
fn a_render_a_level_off_falls_outside_the_hull() {
    let c = compiled(FOUR);
    let g = crate::common::gpu::gpu();
    let p = render_three(&format!("{HEAD}{FOUR}"), "wgsl", &c.scene, Precision::F32, g.as_ref()).unwrap();
    let biased = |bias: f64| c.chosen(&LodChoices { bias, ..Default::default() }).pixels;
    verdict(&as_cpu(&p, &biased(0.0), None)).unwrap();
    let off = verdict(&as_cpu(&p, &biased(1.0), None));
    assert!(off.is_err(), "a render a level off passed");
}

/// A minified lookup read twice (`4·x·(1 − x)`, non-monotone in x) and a
/// value taken away from itself (`x − x + y`).
const TWICE: &str = "C δπx ← 4 * (A δu x) * ((1, 1, 1) - (A δu x));\n";
const MINUS: &str = "C δπx ← (A δu x) - (A δu x) + (B δu x);\n";

/// The average and the greatest width of a hull (the widest colour
/// channel, in 255ths) over the covered pixels where it is not one value.
pub(crate) fn widths(p: &Picture) -> (f64, f64) {
    let w: Vec<f64> = (0..p.pixels.len())
        .filter(|&i| p.covered[i])
        .map(|i| (0..3).map(|k| p.high[i][k] - p.low[i][k]).fold(0.0, f64::max) * 255.0)
        .filter(|&w| w > 1e-9)
        .collect();
    (w.iter().sum::<f64>() / w.len().max(1) as f64, w.iter().copied().fold(0.0, f64::max))
}

/// Affine forms keep what a lookup's reads and its channels share — its
/// λ, one noise symbol per piece of its interval: the hull lies inside
/// the interval hull (the reference's before) on every pixel of every
/// program, and where a lookup is read twice it is under 0.6 of its
/// average width. The four lookups share nothing (a product of two, and a
/// dependent lookup bounded by its coordinates' box): the same width.
#[test]
fn the_affine_hull_lies_inside_the_interval_hull_and_narrows_where_reads_are_shared() {
    for body in [FOUR, TWICE, MINUS] {
        let c = compiled(body);
        let (hull, intervals) = (c.hull(), c.interval_hull());
        for (name, p) in [("least", &hull.low), ("greatest", &hull.high)] {
            let off = outside(p, &intervals.low, &intervals.high, &hull.covered, 1e-9);
            assert_eq!(off, 0, "{body}: the {name} outside the interval hull on {off} pixels");
        }
        let ((avg, max), (iavg, imax)) = (widths(&hull), widths(&intervals));
        eprintln!("{body}: width {avg:.2}/255 on average, {max:.0} at most; intervals {iavg:.2}, {imax:.0}");
        if body != FOUR {
            assert!(avg < 0.6 * iavg, "{body}: {avg:.2} against {iavg:.2} on intervals");
        }
    }
}

/// A render whose every λ is half a level too coarse, or a quarter too
/// fine (`LodChoices::bias`), put in the CPU's place, fails the three-way
/// verdict on a lookup read twice, where the interval hull (the
/// reference's before) held it: an implementation's λ error of half a
/// level or less is told. The render at eq. 3.17's λ passes both.
#[test]
fn a_render_half_a_level_off_falls_outside_the_affine_hull_not_the_interval_hull() {
    let c = compiled(TWICE);
    let g = crate::common::gpu::gpu();
    let p = render_three(&format!("{HEAD}{TWICE}"), "wgsl", &c.scene, Precision::F32, g.as_ref()).unwrap();
    verdict(&p).unwrap();
    let intervals = c.interval_hull();
    let biased = |bias: f64| c.chosen(&LodChoices { bias, ..Default::default() }).pixels;
    verdict(&as_cpu(&p, &biased(0.0), None)).unwrap();
    verdict(&as_cpu(&p, &biased(0.0), Some(&intervals))).unwrap();
    for bias in [0.5, -0.25] {
        let told = verdict(&as_cpu(&p, &biased(bias), None));
        assert!(told.is_err(), "a render {bias} level off passed");
        let before = verdict(&as_cpu(&p, &biased(bias), Some(&intervals)));
        assert!(before.is_ok(), "the interval hull told a render {bias} level off: {before:?}");
    }
}

/// A cube-map lookup at a direction that moves with a minified lookup's λ
/// (a dependent lookup, Pipeline Grammar, eq. (8)).
const CUBE: &str = "texture Env : cube rgb8 bilinear = normalize_cube(16);\n\
    C δπx ← Env (vec3(expand((A δu x).rgb)) + (0.2, 0.5, 1));\n";

/// A cube-map lookup at a moving direction is bounded by the hull (every
/// face the direction's box may select, over the (s, t) it spans there:
/// `sampling::Cube::box_hull`), where the reference fell back to the
/// renders of the lookups' extremes: each such render lies inside it on
/// every pixel not left out, and the CPU and wgpu agree with it.
#[test]
fn a_cube_map_lookup_at_a_moving_direction_is_bounded_by_the_hull() {
    let c = compiled(CUBE);
    let hull = c.hull();
    let seen: Vec<bool> = (0..hull.pixels.len()).map(|i| hull.covered[i] && !hull.latitude[i]).collect();
    let ranged = (0..seen.len()).filter(|&i| seen[i] && hull.low[i] != hull.high[i]).count();
    eprintln!("{ranged} of {} pixels ranged, width {:?}", seen.iter().filter(|&&s| s).count(), widths(&hull));
    assert!(ranged >= 50, "{ranged} pixels ranged");
    // The extremes a render may pick for each lookup (the ends of its λ
    // interval and two levels between).
    for k in 1..=4 {
        let p = c.chosen(&LodChoices { default: k, ..Default::default() });
        let off = outside(&p.pixels, &hull.low, &hull.high, &seen, 1e-9);
        assert_eq!(off, 0, "choice {k}: {off} pixels outside the hull");
    }
    let g = crate::common::gpu::gpu();
    let p = render_three(&format!("{HEAD}{CUBE}"), "wgsl", &c.scene, Precision::F32, g.as_ref()).unwrap();
    verdict(&p).unwrap();
}

/// A minified normal map renormalized (`normalize`, then each channel
/// back to [0, 1]), and Blinn 1977's highlight on it beside a diffuse term
/// (`normalize`, dot products and a power of 16 on one normal), and a
/// display gamma (a power of 1/2.2) less a share of the value it raises:
/// one-variable functions of lookups whose channels and reads share λ.
const RENORMALIZED: &str = "C δπx ← compress(normalize(expand((A δu x).rgb)));\n";
const BLINN: &str = "let n = normalize(vec3(0.5 * expand((A δu x).rgb)) + (0, 0, 1));\n\
    C δπx ← rgb(1, 1, 1) * (0.6 * max(0, n · (0.36, 0.48, 0.8)) + max(0, n · (0, 0.6, 0.8))^16);\n";
const GAMMA: &str = "C δπx ← 2 * ((A δu x)^(1 / 2.2) - 0.6 * (A δu x));\n";

/// `normalize`, `length`, `sqrt`, `rsqrt` and powers by a constant stay on
/// affine forms (a Chebyshev line over the argument's range and one error
/// symbol, Stolfi and de Figueiredo 1997): every render of the lookups'
/// extremes lies inside the hull on every pixel, the hull inside the
/// interval hull, and under 0.6 of its average width — under 0.9 for the
/// renormalized map and Blinn's highlight, whose `normalize` on
/// intervals takes the corners of each channel and the other channels'
/// squared length (`interval::normalized`; 24.8/255 and 21.9 on average
/// before, 16.1 and 7.6 now).
#[test]
fn one_variable_functions_keep_what_their_argument_shares() {
    for (body, ratio) in [(RENORMALIZED, 0.9), (BLINN, 0.9), (GAMMA, 0.6)] {
        let c = compiled(body);
        let (hull, intervals) = (c.hull(), c.interval_hull());
        for (name, p) in [("least", &hull.low), ("greatest", &hull.high)] {
            let off = outside(p, &intervals.low, &intervals.high, &hull.covered, 1e-9);
            assert_eq!(off, 0, "{body}: the {name} outside the interval hull on {off} pixels");
        }
        for k in 1..=4 {
            let p = c.chosen(&LodChoices { default: k, ..Default::default() });
            let off = outside(&p.pixels, &hull.low, &hull.high, &hull.covered, 1e-9);
            assert_eq!(off, 0, "{body}: choice {k}: {off} pixels outside the hull");
        }
        for bias in [-1.0, -0.5, -0.25, 0.25, 0.5, 1.0] {
            let p = c.chosen(&LodChoices { bias, ..Default::default() });
            let off = outside(&p.pixels, &hull.low, &hull.high, &hull.covered, 2.0 / 255.0);
            let before = outside(&p.pixels, &intervals.low, &intervals.high, &hull.covered, 2.0 / 255.0);
            eprintln!("{body}: bias {bias}: {off} pixels outside by more than 2/255 ({before} on intervals)");
        }
        let ((avg, max), (iavg, imax)) = (widths(&hull), widths(&intervals));
        eprintln!("{body}: width {avg:.2}/255 on average, {max:.0} at most; intervals {iavg:.2}, {imax:.0}");
        assert!(avg < ratio * iavg, "{body}: {avg:.2} against {iavg:.2} on intervals");
    }
}

/// A render whose every λ is off by a part of a level
/// (`LodChoices::bias`), put in the CPU's place, fails the three-way
/// verdict against the hull of a renormalized normal map (half a level
/// too coarse) and of a gamma less its argument (half a level too fine,
/// three quarters too coarse), where against the interval hull — which
/// takes powers as the reference did before, on intervals — the gamma's
/// passed. (The renormalized map's is told by the interval hull too since
/// `normalize` on intervals takes the corners of each channel and the
/// others' squared length.) The render at eq. 3.17's λ passes both.
#[test]
fn a_render_off_in_lambda_falls_outside_the_hull_of_a_function_not_the_interval_hull() {
    for (body, biases, apart) in [(RENORMALIZED, &[0.5][..], false), (GAMMA, &[-0.5, 0.75][..], true)] {
        let c = compiled(body);
        let g = crate::common::gpu::gpu();
        let p = render_three(&format!("{HEAD}{body}"), "wgsl", &c.scene, Precision::F32, g.as_ref()).unwrap();
        verdict(&p).unwrap();
        let intervals = c.interval_hull();
        let biased = |bias: f64| c.chosen(&LodChoices { bias, ..Default::default() }).pixels;
        verdict(&as_cpu(&p, &biased(0.0), None)).unwrap();
        verdict(&as_cpu(&p, &biased(0.0), Some(&intervals))).unwrap();
        for &bias in biases {
            let told = verdict(&as_cpu(&p, &biased(bias), None));
            assert!(told.is_err(), "{body}: a render {bias} level off passed");
            let before = verdict(&as_cpu(&p, &biased(bias), Some(&intervals)));
            assert!(
                before.is_ok() || !apart,
                "{body}: the interval hull told a render {bias} level off: {before:?}"
            );
        }
    }
}

/// A 3-D texture rendered by a statement, and a scene's dual-paraboloid
/// map, each looked up at coordinates that move with a minified lookup's
/// λ (a dependent lookup, Pipeline Grammar, eq. (8)).
const VOLUME: &str = "vector P : position in object;\n\
    texture V : 3d rgba8 bilinear clamp;\n\
    shader f : s → c = rgb(s.x, 0.3 + 0.6 * s.y, fract(3 * s.x + s.y));\n\
    V δu ← f s δu;\n\
    C δπx ← V vec3((A δu x).rgb);\n";
const PARABOLOID: &str = "texture Env : cube rgb8 bilinear clamp = image(\"sky.png\");\n\
    C δπx ← Env (vec3(expand((A δu x).rgb)) + (0.2, 0.5, 1));\n";

/// The torus with a scene texture `Env`: a dual-paraboloid map of the
/// procedural sky, 32² per face.
pub(crate) fn paraboloid_scene() -> shadec::scene::Scene {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/kilgard_torus.ron"))
        .unwrap()
        .replace(
            "    objects: [",
            "    textures: { \"Env\": DualParaboloid(size: 32, sun: (0.3, 0.8, 0.5)) },\n    objects: [",
        );
    assert!(text.contains("DualParaboloid"), "the torus scene changed its layout");
    shadec::scene::Scene::parse(&text, std::path::Path::new("/nonexistent-shadec-scene/env.ron")).unwrap()
}

/// A 3-D and an environment lookup at moving coordinates are bounded by
/// the hull (the texels of the coordinates' box: `Volume::box_hull`,
/// `Paraboloid::box_hull`), where the reference fell back to the renders
/// of the lookups' extremes: each such render lies inside it on every
/// covered pixel, and the CPU and wgpu agree with it.
#[test]
fn volume_and_environment_lookups_at_moving_coordinates_are_bounded_by_the_hull() {
    for (body, sc) in [(VOLUME, scene("kilgard_torus.ron")), (PARABOLOID, paraboloid_scene())] {
        let c = compiled_in(body, sc);
        let hull = c.hull();
        let seen: Vec<bool> = (0..hull.pixels.len()).map(|i| hull.covered[i] && !hull.latitude[i]).collect();
        let ranged = (0..seen.len()).filter(|&i| seen[i] && hull.low[i] != hull.high[i]).count();
        let n = seen.iter().filter(|&&s| s).count();
        eprintln!("{body}: {ranged} of {n} pixels ranged, width {:?}", widths(&hull));
        assert!(ranged >= 50, "{body}: {ranged} pixels ranged");
        for k in 1..=4 {
            let p = c.chosen(&LodChoices { default: k, ..Default::default() });
            let off = outside(&p.pixels, &hull.low, &hull.high, &seen, 1e-9);
            assert_eq!(off, 0, "{body}: choice {k}: {off} pixels outside the hull");
        }
        let g = crate::common::gpu::gpu();
        let p = render_three(&format!("{HEAD}{body}"), "wgsl", &c.scene, Precision::F32, g.as_ref()).unwrap();
        verdict(&p).unwrap();
    }
}
