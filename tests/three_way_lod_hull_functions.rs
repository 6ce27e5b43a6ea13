//! The reference's level-of-detail hull (`oracle/hull/`) on the functions
//! realistic programs take of minified lookups beyond those of
//! `three_way_lod_hull`: `max` and `min` of two moving values (Blinn's
//! `max(n·L, n·H)`), `clamp` between moving ends, `smoothstep`, `exp`,
//! `log`, `sin`, `cos`, a power to a moving exponent (a gloss map), and a
//! baked table read at moving coordinates (a lighting table indexed by a
//! perturbed normal). Each is an affine form with one fresh symbol per
//! function (Stolfi and de Figueiredo 1997's Chebyshev line over the
//! argument's range), so its argument's λ stays shared: every render of
//! the lookups' extremes lies inside the hull, the hull inside the
//! interval hull, and the CPU and wgpu agree with it.

use shadec::numerics::Precision;
use shadec::oracle::{LodChoices, Picture};

use crate::three_way::{render_three, verdict};
use crate::three_way_lod_hull::{as_cpu, compiled, outside, widths, Compiled, HEAD};

/// Blinn 1977's diffuse and highlight terms on a perturbed normal, the
/// larger taken (`max` of two dot products that share the normal's λ).
const LARGER: &str = "let n = normalize(vec3(0.5 * expand((A δu x).rgb)) + (0, 0, 1));\n\
    C δπx ← rgb(1, 1, 1) * max(n · (0.36, 0.48, 0.8), n · (0, 0.6, 0.8));\n";
/// A detail texture held between two moving ends (a lookup at another
/// scale and a share of itself).
const BETWEEN: &str = "let a = A δu x;\nlet b = B δ(3 * (u x));\n\
    C δπx ← clamp(a, 0.5 * b, 0.5 * b + (0.3, 0.3, 0.3));\n";
/// A cel-like ramp: `smoothstep` of a lookup less a share of it.
const SMOOTH: &str = "C δπx ← 2 * (smoothstep(0.2, 0.8, A δu x) - 0.5 * (A δu x));\n";
/// Exponential fog whose density is a lookup, blended towards a fog
/// colour by its own factor (read twice).
const FOG: &str = "let f = exp(-2 * (B δ(3 * (u x))));\n\
    C δπx ← (A δu x) * f + ((1, 1, 1) - f) * rgb(0.6, 0.6, 0.7);\n";
/// A logarithmic tone curve less a share of its argument.
const LOGGED: &str = "C δπx ← 2 * (log((1, 1, 1) + 4 * (A δu x)) - 0.8 * (A δu x));\n";
/// Ripples: `sin` and `cos` of a lookup's scaled value.
const WAVES: &str = "C δπx ← 0.5 + 0.25 * sin(6 * (A δu x)) + 0.25 * cos(4 * (A δu x));\n";
/// A gloss map: a lookup raised to a power read from another.
const GLOSS: &str = "C δπx ← (0.2 * (1, 1, 1) + 0.8 * (A δu x))^(1 + 4 * (B δ(3 * (u x))).g);\n";

/// The sum over the covered pixels of the hull's width (the widest
/// colour channel, in 255ths).
fn total(p: &Picture) -> f64 {
    (0..p.pixels.len())
        .filter(|&i| p.covered[i])
        .map(|i| (0..3).map(|k| p.high[i][k] - p.low[i][k]).fold(0.0, f64::max) * 255.0)
        .sum()
}

/// Every render of the lookups' extremes (choices 1-4) inside `hull` on
/// every covered pixel, exactly.
fn holds_every_extreme(body: &str, c: &Compiled, hull: &Picture) {
    for k in 1..=4 {
        let p = c.chosen(&LodChoices { default: k, ..Default::default() });
        let off = outside(&p.pixels, &hull.low, &hull.high, &hull.covered, 1e-9);
        assert_eq!(off, 0, "{body}: choice {k}: {off} pixels outside the hull");
    }
}

/// `max`, `min` and `clamp` of moving values, `smoothstep`, `exp`, `log`,
/// `sin`, `cos` and a moving exponent on affine forms: every render of
/// the lookups' extremes inside the hull, the hull inside the interval
/// hull on every pixel, its total width over the covered pixels no
/// greater — and under 0.85 of it where a lookup is read twice or
/// through two functions (the normal of `max(n·L, n·H)`, the argument
/// beside `smoothstep`, `log` and the fog's factor) — and the CPU and
/// wgpu inside it. `sin` and `cos` were [−1, 1] on intervals, whatever
/// their argument.
#[test]
fn functions_of_moving_values_keep_what_their_arguments_share() {
    let shared = [LARGER, SMOOTH, FOG, LOGGED];
    for body in [LARGER, BETWEEN, SMOOTH, FOG, LOGGED, WAVES, GLOSS] {
        let c = compiled(body);
        let (hull, intervals) = (c.hull(), c.interval_hull());
        for (name, p) in [("least", &hull.low), ("greatest", &hull.high)] {
            let off = outside(p, &intervals.low, &intervals.high, &hull.covered, 1e-9);
            assert_eq!(off, 0, "{body}: the {name} outside the interval hull on {off} pixels");
        }
        holds_every_extreme(body, &c, &hull);
        let ((avg, max), (iavg, imax)) = (widths(&hull), widths(&intervals));
        let (sum, isum) = (total(&hull), total(&intervals));
        eprintln!(
            "{body}: width {avg:.2}/255 on average, {max:.0} at most, {sum:.0} in all; \
             intervals {iavg:.2}, {imax:.0}, {isum:.0}"
        );
        assert!(sum > 0.0, "{body}: nothing ranged");
        let ratio = if shared.contains(&body) { 0.85 } else { 1.0 };
        assert!(sum <= ratio * isum, "{body}: {sum:.0} against {isum:.0} on intervals");
        let g = crate::common::gpu::gpu();
        let p = render_three(&format!("{HEAD}{body}"), "wgsl", &c.scene, Precision::F32, g.as_ref()).unwrap();
        verdict(&p).unwrap();
    }
}

/// A render whose every λ is off by a part of a level, put in the CPU's
/// place, fails the three-way verdict against the hull of `smoothstep`
/// (half a level too coarse), of the fog and of the tone curve (a quarter
/// too fine), where against the interval hull it passed; the render at
/// eq. 3.17's λ passes both. (The hull before these functions took forms
/// passed the `smoothstep` and tone-curve renders too; it told the fog's,
/// its factor's one symbol shared by both reads.)
#[test]
fn a_render_off_in_lambda_falls_outside_the_hull_of_a_function_of_a_lookup_not_the_interval_hull() {
    for (body, bias) in [(SMOOTH, 0.5), (FOG, -0.25), (LOGGED, -0.25)] {
        let c = compiled(body);
        let g = crate::common::gpu::gpu();
        let p = render_three(&format!("{HEAD}{body}"), "wgsl", &c.scene, Precision::F32, g.as_ref()).unwrap();
        let intervals = c.interval_hull();
        let biased = |bias: f64| c.chosen(&LodChoices { bias, ..Default::default() }).pixels;
        verdict(&as_cpu(&p, &biased(0.0), None)).unwrap();
        verdict(&as_cpu(&p, &biased(0.0), Some(&intervals))).unwrap();
        let told = verdict(&as_cpu(&p, &biased(bias), None));
        assert!(told.is_err(), "{body}: a render {bias} level off passed");
        let before = verdict(&as_cpu(&p, &biased(bias), Some(&intervals)));
        assert!(before.is_ok(), "{body}: the interval hull told a render {bias} level off: {before:?}");
    }
}

/// Kilgard's illumination table baked over (n·L, n·H) and read at a
/// minified normal map's dot products (`examples/hilo_bump.shd`'s form,
/// on an rgb normal map), clamped and repeated: the table's function is
/// evaluated on the coordinates' forms, where the reference fell back to
/// the renders of the lookups' extremes (`hull_refused`, which
/// `Compiled::hull` asserts is not set). Every such render lies inside
/// the hull, and the CPU and wgpu agree with it.
#[test]
fn a_baked_table_at_moving_coordinates_is_bounded_by_the_hull() {
    for wrap in ["clamp", "repeat"] {
        let body = format!(
            "shader illumination : s → c = rgb(0.75, 0.55, 0.35) * s.x + rgb(0.6, 0.6, 0.6) * s.y^16;\n\
             texture Tlit : 2d rgb8 bilinear {wrap} = bake(illumination);\n\
             let n = normalize(vec3(0.5 * expand((A δu x).rgb)) + (0, 0, 1));\n\
             C δπx ← Tlit vec2(n · (0.36, 0.48, 0.8), n · (0, 0.6, 0.8));\n"
        );
        let c = compiled(&body);
        let hull = c.hull();
        let ranged =
            (0..hull.pixels.len()).filter(|&i| hull.covered[i] && hull.low[i] != hull.high[i]).count();
        let enumerated = c.enumerated();
        eprintln!(
            "{wrap}: {ranged} pixels ranged, width {:?}; the renders of the extremes {:?}",
            widths(&hull),
            widths(&enumerated)
        );
        assert!(ranged >= 50, "{wrap}: {ranged} pixels ranged");
        holds_every_extreme(&body, &c, &hull);
        let g = crate::common::gpu::gpu();
        let p = render_three(&format!("{HEAD}{body}"), "wgsl", &c.scene, Precision::F32, g.as_ref()).unwrap();
        verdict(&p).unwrap();
    }
}

/// A normal map renormalized where its expanded texel may reach length 0
/// (`normalize(expand(A.rgb))`, the map's texels near grey): bounded per
/// channel by the corners of the channel and the others' squared length
/// (`interval::normalized`), where it took [−1, 1] or the channel over
/// the length's interval; every render of the extremes inside.
#[test]
fn normalize_where_the_length_may_reach_zero_is_bounded() {
    let body = "let n = normalize(expand((A δu x).rgb));\n\
        C δπx ← rgb(1, 1, 1) * (0.6 * max(0, n · (0.36, 0.48, 0.8)) + max(0, n · (0, 0.6, 0.8))^16);\n";
    let c = compiled(body);
    let (hull, intervals) = (c.hull(), c.interval_hull());
    holds_every_extreme(body, &c, &hull);
    let ((avg, max), (iavg, imax)) = (widths(&hull), widths(&intervals));
    eprintln!("{body}: width {avg:.2}/255 on average, {max:.0} at most; intervals {iavg:.2}, {imax:.0}");
    eprintln!("total {:.0} against {:.0}", total(&hull), total(&intervals));
    for (name, p) in [("least", &hull.low), ("greatest", &hull.high)] {
        let off = outside(p, &intervals.low, &intervals.high, &hull.covered, 1e-9);
        assert_eq!(off, 0, "{body}: the {name} outside the interval hull on {off} pixels");
    }
}

/// A soft threshold at a moving level: `smoothstep` between edges that
/// move with a lookup, a constant distance apart (the quotient affine in
/// `x − e₀`) or a moving one (through the span's reciprocal).
const EDGES: [&str; 2] = [
    "let a = A δu x;\nC δπx ← smoothstep(0.5 * a, 0.5 * a + 0.4, B δ(3 * (u x)));\n",
    "let a = A δu x;\nC δπx ← smoothstep(0.3 * a, 0.5 + 0.4 * a, B δ(3 * (u x)));\n",
];
/// A gloss map's moving exponent over a base that reaches 0 (a clamped
/// channel, as `max(0, n·H)` is), less a share of the base.
const GLOSS_FROM_ZERO: &str = "let h = max(0, 2 * (A δu x).r - 0.6);\n\
    C δπx ← rgb(1, 1, 1) * 2 * (h^(1 + 4 * (B δ(3 * (u x))).g) - 0.5 * h);\n";

/// `smoothstep` between moving edges is bounded by the hull (it refused,
/// falling back to the renders of the lookups' extremes): every such
/// render lies inside it, and the CPU and wgpu agree with it.
#[test]
fn smoothstep_between_moving_edges_is_bounded_by_the_hull() {
    for body in EDGES {
        let c = compiled(body);
        let (hull, intervals) = (c.hull(), c.interval_hull());
        holds_every_extreme(body, &c, &hull);
        let enumerated = c.enumerated();
        eprintln!(
            "{body}: width {:?}, {:.0} in all; intervals {:?}, {:.0}; the renders of the extremes {:?}",
            widths(&hull),
            total(&hull),
            widths(&intervals),
            total(&intervals),
            widths(&enumerated)
        );
        assert!(total(&hull) > 0.0, "{body}: nothing ranged");
        let g = crate::common::gpu::gpu();
        let p = render_three(&format!("{HEAD}{body}"), "wgsl", &c.scene, Precision::F32, g.as_ref()).unwrap();
        verdict(&p).unwrap();
    }
}

/// A power to a moving exponent whose base reaches 0 keeps the base's
/// symbols (`functions::pow_over_exponents`), where it took the corners
/// of intervals: every render of the extremes inside, the hull inside the
/// interval hull and narrower in all.
#[test]
fn a_moving_exponent_over_a_base_reaching_zero_keeps_the_base_s_symbols() {
    let body = GLOSS_FROM_ZERO;
    let c = compiled(body);
    let (hull, intervals) = (c.hull(), c.interval_hull());
    holds_every_extreme(body, &c, &hull);
    for (name, p) in [("least", &hull.low), ("greatest", &hull.high)] {
        let off = outside(p, &intervals.low, &intervals.high, &hull.covered, 1e-9);
        assert_eq!(off, 0, "{body}: the {name} outside the interval hull on {off} pixels");
    }
    let (sum, isum) = (total(&hull), total(&intervals));
    eprintln!(
        "{body}: width {:?}, {sum:.0} in all; intervals {:?}, {isum:.0}",
        widths(&hull),
        widths(&intervals)
    );
    assert!(sum < isum, "{body}: {sum:.0} against {isum:.0} on intervals");
    let g = crate::common::gpu::gpu();
    let p = render_three(&format!("{HEAD}{body}"), "wgsl", &c.scene, Precision::F32, g.as_ref()).unwrap();
    verdict(&p).unwrap();
}
