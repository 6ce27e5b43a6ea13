//! The reference's level-of-detail hull (`oracle/hull.rs`): every
//! minified lookup chooses its λ on its own (GL §3.8.8), for any number of
//! lookups, and the hull holds every such choice — where the range over
//! renders of the lookups' extremes (`oracle::render_enumerated`, the
//! reference's range before) did not beyond two lookups — while a render
//! off by a level still falls outside it.

use shadec::numerics::Precision;
use shadec::oracle::{self, LodChoices, Picture};
use shadec::profile::Profile;

use crate::three_way::{render_three, scene, verdict, Pictures, H, PIXEL_TOLERANCE, W};

const HEAD: &str = "texture A : 2d rgb8 mipmap trilinear repeat = image(\"missing-a.png\");\n\
    texture B : 2d rgb8 mipmap trilinear repeat = image(\"missing-b.png\");\n\
    texture D : 2d rgb8 mipmap trilinear repeat = image(\"missing-d.png\");\n\
    framebuffer C : rgba8, depth;\n";

/// Four minified lookups at four scales, a product and a sum, one of them
/// dependent (`D` read at coordinates `B` offsets, Pipeline Grammar,
/// eq. (8)).
const FOUR: &str = "C δπx ← (A δu x) * (B δ(3 * (u x))) + 0.5 * (D δ((u x) + 0.05 * (B δ(5 * (u x))).rg));\n";

struct Compiled {
    module: shadec::ir::Module,
    program: shadec::parser::ast::Program,
    scene: shadec::scene::Scene,
    assets: shadec::scene::SceneAssets,
}

fn compiled(body: &str) -> Compiled {
    let scene = scene("kilgard_torus.ron");
    let assets = scene.build().unwrap();
    let profile = Profile::resolve("wgsl").unwrap();
    let c = shadec::driver::compile(&format!("{HEAD}{body}"), &profile, &Default::default()).unwrap();
    Compiled { module: c.module, program: c.program, scene, assets }
}

impl Compiled {
    fn hull(&self) -> Picture {
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

    fn enumerated(&self) -> Picture {
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

    fn chosen(&self, choices: &LodChoices) -> Picture {
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
fn outside(p: &[[f64; 4]], low: &[[f64; 4]], high: &[[f64; 4]], compared: &[bool], by: f64) -> usize {
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

/// The hull is tight enough to tell a render whose λ is a level off
/// (every lookup's eq. 3.17 λ plus one, `LodChoices::bias`): put in the
/// CPU's place, it fails the three-way verdict, where the render at eq.
/// 3.17's λ passes.
#[test]
fn a_render_a_level_off_falls_outside_the_hull() {
    let c = compiled(FOUR);
    let g = crate::common::gpu::gpu();
    let p = render_three(&format!("{HEAD}{FOUR}"), "wgsl", &c.scene, Precision::F32, g.as_ref()).unwrap();
    let pr = &p;
    let as_cpu = |bias: f64| {
        let chosen = c.chosen(&LodChoices { bias, ..Default::default() });
        Pictures {
            cpu: rgba8(&chosen.pixels),
            gpu: None,
            oracle: p.oracle.clone(),
            covered: p.covered.clone(),
            wide: p.wide.clone(),
            oracle_low: p.oracle_low.clone(),
            oracle_high: p.oracle_high.clone(),
            oracle_unclamped: None,
            oracle_unclamped_range: None,
            gpu_refused: None,
            rules: p.rules.clone(),
            ..*pr
        }
    };
    verdict(&as_cpu(0.0)).unwrap();
    let off = verdict(&as_cpu(1.0));
    assert!(off.is_err(), "a render a level off passed");
}
