//! What the 8-bit clamps between passes do to a split (Kilgard 2000,
//! Section 5; OpenGL 1.2.1 §2.13.9, §4.1.8): which splits are exact
//! through them, and the pieces as the blender runs them (a term below 0
//! taken off by a reverse subtraction, a factor past 1 halved and doubled).

use rustc_hash::{FxHashMap as HashMap, FxHashSet};

use super::affine::Builder;
use super::split::{Dest, FitCheck, Overflow, Piece, Storage};
use crate::ir::{BinaryOp, Expr, Handle, Interval, Module, Ty};
use crate::parser::ast::CombineMode;
use crate::pipeline::BlendMode;

/// Whether a split gives what the unsplit value gives on a framebuffer
/// that stores [0, 1] (8-bit, Kilgard 2000, Section 5: every pass's result is
/// clamped when written, and GL clamps a blend's source there too, OpenGL
/// 1.2.1 §4.1.8). The meaning clamps once, at the end; a split clamps after
/// every pass. Tracking the range `h` of what the target would hold
/// unclamped (the framebuffer's [0, 1] before its first piece), a piece is
/// exact when:
/// - `replace v`: always (the stored value's clamp is carried on in `h`);
/// - `add v`, `v ≥ 0`: `h ≥ 0` (min(1, min(1, h) + v) = min(1, h + v));
/// - `add v`, `v` of either sign: `h ⊆ [0, 1]` and the blender subtracts —
///   [`signed_terms`] writes it as `add v` then `reverse_subtract −v`, each
///   source clamped to its non-negative part, so one of them adds nothing;
///   `v ≤ 0`: `h ≤ 1` (only the subtraction);
/// - `reverse_subtract s`, `s ≥ 0`: `h ≤ 1`;
/// - `modulate m`, `m ≤ 1`, `h ≤ 1`, and `m ≥ 0` or `h ≥ 0` (a negative
///   factor is clamped to 0, the product is ≤ 0 and clamped to 0 as well);
///   `m ≤ 2` as `modulate_2x` of `m/2` ([`signed_terms`]; GL 1.1's
///   GL_DST_COLOR, GL_SRC_COLOR, which every target has);
/// - `modulate m`, `1 ≤ m ≤ 2`: whatever `h` is — scaling up what the
///   framebuffer clamped is scaling before the clamp (`4·T0·T1·T2` on a
///   2-unit target: `T0·T1`, then 2× modulate by `T2`, then by 1);
/// - `max v`, `min v` (GL_MAX, GL_MIN): always — the clamp is monotone, so
///   `max(min(1, h), min(1, v))` is `min(1, max(h, v))` (and alike at 0).
///
/// Otherwise — `(diffuse + specular) · decal` with the sum above 1, a sum
/// whose first pass may be negative — the later pass reads a clamped value:
/// the split is refused here and another one (the decal distributed over
/// the terms, the terms reordered) is taken, or the statement is refused.
/// A temporary on an 8-bit texture is clamped when stored, so what it ends
/// with must be in [0, 1] too, unless it is one of `clamped_temps`, which
/// hold `saturate(x)` as `x` clamped by the store. A float target clamps
/// nothing.
///
/// Every blend equation works channel by channel (OpenGL 1.2.1 §4.1.6),
/// and so do the clamps, so `h` is tracked per channel from each value's
/// channel ranges ([`crate::ir::ExprInfo::channels`]): coloured terms added
/// one pass each — `0.4·δl₀ + 0.4·δl₁` with light 0 red and light 1
/// green, `0.36 + 0.12` in red, `0.16 + 0.36` in green — are bounded by
/// their sum in each channel, where the hulls (0.36 + 0.36 in every
/// channel) may pass 1 when the terms never do. A channel a value does not
/// have (an rgb value's alpha) is left as it was: which pass writes alpha
/// is the split's (the first, with the value's alpha 1), and an rgb
/// temporary is read back as rgb. The planner's first search of a
/// statement keeps one range for all channels, their hull, as before the
/// channels were followed; a statement it refuses at the clamps is
/// searched again channel by channel (`Storage::by_channel`).
pub fn exact_through_clamps(
    module: &Module,
    pieces: &[Piece],
    storage: Storage,
    clamped_temps: &FxHashSet<u32>,
) -> bool {
    if !storage.by_channel {
        return exact_through_hulls(module, pieces, storage, clamped_temps);
    }
    let mut held: HashMap<Dest, Lanes> = HashMap::default();
    for p in pieces {
        if !storage.clamps(p.dest) {
            continue;
        }
        let info = module.info(p.value);
        let own = info.channels.map(|c| meet(c, info.interval));
        let read = read_range(module, p.value, &held, storage);
        let b = held.get(&p.dest).copied().unwrap_or([Interval::UNSIGNED; 4]);
        let mut after = b;
        for i in 0..lanes(info.ty) {
            let v = read.map_or(own[i], |r| meet(own[i], r[i]));
            let Some(a) = exact_blend(p.blend, b[i], v, storage.subtract) else { return false };
            after[i] = p.holds.map_or(a, |h| meet(a, h));
        }
        held.insert(p.dest, after);
    }
    held.iter().all(|(d, l)| match d {
        Dest::Main => true,
        Dest::Temp(t) => clamped_temps.contains(t) || l.iter().all(|i| i.lo >= 0.0 && i.hi <= 1.0),
    })
}

/// The range of each channel (red, green, blue, alpha) of what a target
/// holds or a value is.
type Lanes = [Interval; 4];

/// The channels a value of type `ty` writes: a scalar splats into all four.
fn lanes(ty: Ty) -> usize {
    match ty.width() {
        1 => 4,
        w => w.min(4),
    }
}

/// The intersection of two ranges of one value (each a bound of it).
fn meet(a: Interval, b: Interval) -> Interval {
    Interval { lo: a.lo.max(b.lo), hi: a.hi.min(b.hi) }
}

/// The range of a temporary's read-back (`temp{id}` looked up, its rgb
/// or a channel, scaled by a constant, widened, saturated) from what the
/// split's earlier pieces left in it, channel by channel, where that is
/// tighter than a texture's [0, 1]: a product halved into a temporary
/// (`½·E·F·G`) holds at most ½, so what it is added to may hold ½ more
/// and stay in [0, 1] (`C ← C·(A·B·D + E·F·G)` on a 2-unit target: the sum
/// halved into one temporary, its second product through another). `None`
/// for any other value.
fn read_range(
    module: &Module,
    v: Handle<Expr>,
    held: &HashMap<Dest, Lanes>,
    storage: Storage,
) -> Option<Lanes> {
    match &module.exprs[v] {
        Expr::Lookup { texture, .. } => {
            let name = &module.textures.get(*texture as usize)?.name;
            let id: u32 = name.strip_prefix("temp")?.parse().ok()?;
            let dest = Dest::Temp(id);
            let h = *held.get(&dest)?;
            Some(if storage.clamps(dest) { h.map(|i| meet(i, Interval::UNSIGNED)) } else { h })
        }
        Expr::Swizzle { value, pattern, len, .. } => {
            let r = read_range(module, *value, held, storage)?;
            let lane = |i: usize| r[usize::from(pattern[i]).min(3)];
            // One channel read splats into all four, as a scalar does.
            Some(std::array::from_fn(|i| if *len == 1 { lane(0) } else { lane(i) }))
        }
        Expr::Convert { value, to: Ty::Rgba } => {
            let r = read_range(module, *value, held, storage)?;
            // An rgb value widened: alpha 1. Otherwise each channel may be 1.
            Some(match module.info(*value).ty {
                Ty::Rgb | Ty::Vec3 => [r[0], r[1], r[2], Interval::point(1.0)],
                _ => r.map(|i| Interval { lo: i.lo.min(1.0), hi: i.hi.max(1.0) }),
            })
        }
        Expr::Math { fun: crate::ir::MathFunction::Saturate, args } => {
            let r = read_range(module, args[0], held, storage)?;
            Some(r.map(|i| Interval { lo: i.lo.clamp(0.0, 1.0), hi: i.hi.clamp(0.0, 1.0) }))
        }
        Expr::Binary { op: BinaryOp::Mul, lhs, rhs } => {
            let constant = |h: Handle<Expr>| matches!(module.exprs[h], Expr::Constant(_));
            let (k, x) = if constant(*lhs) { (*lhs, *rhs) } else { (*rhs, *lhs) };
            if !constant(k) {
                return None;
            }
            let r = read_range(module, x, held, storage)?;
            let kc = module.info(k).channels;
            Some(std::array::from_fn(|i| crate::ir::valid::mul(kc[i], r[i])))
        }
        _ => None,
    }
}

/// [`exact_through_clamps`] with one range for all four channels of
/// each value, their hull: the planner's first search, which every plan
/// before the channels were followed came from.
fn exact_through_hulls(
    module: &Module,
    pieces: &[Piece],
    storage: Storage,
    clamped_temps: &FxHashSet<u32>,
) -> bool {
    let mut held: HashMap<Dest, Interval> = HashMap::default();
    for p in pieces {
        if !storage.clamps(p.dest) {
            continue;
        }
        let v = read_hull(module, p.value, &held, storage).map_or(module.info(p.value).interval, |r| {
            let own = module.info(p.value).interval;
            Interval { lo: own.lo.max(r.lo), hi: own.hi.min(r.hi) }
        });
        let b = held.get(&p.dest).copied().unwrap_or(Interval::UNSIGNED);
        let Some(after) = exact_blend(p.blend, b, v, storage.subtract) else { return false };
        let after = match p.holds {
            Some(h) => Interval { lo: after.lo.max(h.lo), hi: after.hi.min(h.hi) },
            None => after,
        };
        held.insert(p.dest, after);
    }
    held.iter().all(|(d, i)| match d {
        Dest::Main => true,
        Dest::Temp(t) => clamped_temps.contains(t) || (i.lo >= 0.0 && i.hi <= 1.0),
    })
}

/// The range of a temporary's read-back (`temp{id}` looked up, its rgb
/// or a channel, scaled by a constant, widened, saturated) from what the
/// split's earlier pieces left in it, where that is tighter than a
/// texture's [0, 1]: a product halved into a temporary (`½·E·F·G`) holds
/// at most ½, so what it is added to may hold ½ more and stay in [0, 1]
/// (`C ← C·(A·B·D + E·F·G)` on a 2-unit target: the sum halved into one
/// temporary, its second product through another). `None` for any other
/// value.
fn read_hull(
    module: &Module,
    v: Handle<Expr>,
    held: &HashMap<Dest, Interval>,
    storage: Storage,
) -> Option<Interval> {
    match &module.exprs[v] {
        Expr::Lookup { texture, .. } => {
            let name = &module.textures.get(*texture as usize)?.name;
            let id: u32 = name.strip_prefix("temp")?.parse().ok()?;
            let dest = Dest::Temp(id);
            let h = *held.get(&dest)?;
            Some(if storage.clamps(dest) { Interval { lo: h.lo.max(0.0), hi: h.hi.min(1.0) } } else { h })
        }
        Expr::Swizzle { value, .. } => read_hull(module, *value, held, storage),
        Expr::Convert { value, to: Ty::Rgba } => {
            let r = read_hull(module, *value, held, storage)?;
            Some(Interval { lo: r.lo.min(1.0), hi: r.hi.max(1.0) })
        }
        Expr::Math { fun: crate::ir::MathFunction::Saturate, args } => {
            let r = read_hull(module, args[0], held, storage)?;
            Some(Interval { lo: r.lo.clamp(0.0, 1.0), hi: r.hi.clamp(0.0, 1.0) })
        }
        Expr::Binary { op: BinaryOp::Mul, lhs, rhs } => {
            let constant = |h: Handle<Expr>| matches!(module.exprs[h], Expr::Constant(_));
            let (k, x) = if constant(*lhs) { (*lhs, *rhs) } else { (*rhs, *lhs) };
            if !constant(k) {
                return None;
            }
            let r = read_hull(module, x, held, storage)?;
            Some(crate::ir::valid::mul(module.info(k).interval, r))
        }
        _ => None,
    }
}

/// What a clamped target holds (unclamped) after `blend` of a value in `v`
/// onto one holding `b`, when the clamps leave the result exact
/// ([`exact_through_clamps`]).
fn exact_blend(blend: BlendMode, b: Interval, v: Interval, subtract: bool) -> Option<Interval> {
    let unit = |i: Interval| i.lo >= 0.0 && i.hi <= 1.0;
    let sum = crate::ir::valid::add(b, v);
    match blend {
        BlendMode::Replace => Some(v),
        BlendMode::Add if v.lo >= 0.0 => (b.lo >= 0.0).then_some(sum),
        BlendMode::Add if v.hi <= 0.0 => (subtract && b.hi <= 1.0).then_some(sum),
        BlendMode::Add => (subtract && unit(b)).then_some(sum),
        BlendMode::ReverseSubtract => {
            (v.lo >= 0.0 && b.hi <= 1.0).then(|| crate::ir::valid::add(b, Interval { lo: -v.hi, hi: -v.lo }))
        }
        // Past 1 (up to 2) as `modulate_2x` of `m/2` ([`signed_terms`]).
        // A factor of at least 1 scales what was clamped exactly, whatever
        // the target held: min(1, m·min(1, h)) = min(1, m·h) for m ≥ 1
        // (both 1 where h ≥ 1), and both 0 where h ≤ 0.
        BlendMode::Modulate => (v.hi <= 2.0
            && (v.lo >= 1.0 || (b.hi <= 1.0 && (v.lo >= 0.0 || b.lo >= 0.0))))
            .then(|| crate::ir::valid::mul(b, v)),
        // GL clamps the source to [0, 1] as the store clamps what is held,
        // and max (min) of the clamped values is the clamp of their max
        // (min): exact whatever either holds.
        BlendMode::Max => Some(Interval { lo: b.lo.max(v.lo), hi: b.hi.max(v.hi) }),
        BlendMode::Min => Some(Interval { lo: b.lo.min(v.lo), hi: b.hi.min(v.hi) }),
        // The alpha blends: both in [0, 1], the result too.
        _ => (unit(b) && unit(v)).then_some(Interval::UNSIGNED),
    }
}

/// The range of `x·(1 − f) + y·f` with `f` in [0, 1] (a `lerp` written
/// out, `algebra::canonical`): the hull of what `x` and `y` range over,
/// each bounded so in turn, where the sum's own range adds them. `None`
/// for any other value, or where that is no tighter.
pub fn lerp_bound(module: &Module, h: Handle<Expr>) -> Option<Interval> {
    let bound = |x| lerp_bound(module, x).unwrap_or(module.info(x).interval);
    let (a, b) = match module.exprs[h] {
        Expr::Binary { op: BinaryOp::Add, lhs, rhs } | Expr::Combine { mode: CombineMode::Add, lhs, rhs } => {
            (lhs, rhs)
        }
        _ => return None,
    };
    let factors = |p: Handle<Expr>| match module.exprs[p] {
        Expr::Binary { op: BinaryOp::Mul, lhs, rhs }
        | Expr::Combine { mode: CombineMode::Modulate, lhs, rhs } => Some([(lhs, rhs), (rhs, lhs)]),
        _ => None,
    };
    let weight = |w: Handle<Expr>| match module.exprs[w] {
        Expr::Binary { op: BinaryOp::Sub, lhs, rhs } if module.is_constant(lhs, 1.0) => Some(rhs),
        _ => None,
    };
    for (p, q) in [(a, b), (b, a)] {
        for (x, w) in factors(p)? {
            let Some(f) = weight(w) else { continue };
            let fi = module.info(f).interval;
            if fi.lo < 0.0 || fi.hi > 1.0 {
                continue;
            }
            for (y, g) in factors(q)? {
                if g == f {
                    let (bx, by) = (bound(x), bound(y));
                    let hull = Interval { lo: bx.lo.min(by.lo), hi: bx.hi.max(by.hi) };
                    let own = module.info(h).interval;
                    return (hull.lo > own.lo || hull.hi < own.hi).then_some(hull);
                }
            }
        }
    }
    None
}

/// `pieces` as the blender runs them on a clamped target: an `add` of a
/// term that may be negative becomes `add v` then `reverse_subtract −v`
/// (`−v` alone when `v ≤ 0`); a `modulate` by a factor past 1 becomes
/// `modulate_2x` of half of it. GL clamps each source to [0, 1] on a
/// fixed-point target (§4.1.8), so at every fragment one of the two is 0
/// and the other adds or takes off what `v` means there; exact where
/// [`exact_through_clamps`] accepted the add. `None` when `−v` (or `m/2`)
/// does not fit a pass of the target.
pub fn signed_terms(
    module: &mut Module,
    fit: &dyn FitCheck,
    pieces: &[Piece],
    storage: Storage,
) -> Option<Vec<Piece>> {
    let mut out = Vec::with_capacity(pieces.len());
    for p in pieces {
        let v = module.info(p.value).interval;
        if p.blend == BlendMode::Modulate && v.hi > 1.0 && storage.clamps(p.dest) {
            let half = halved(module, p.value)
                .filter(|&h| fit.fits(module, h).is_ok())
                .or_else(|| halved_terms(module, p.value).filter(|&h| fit.fits(module, h).is_ok()))?;
            out.push(Piece {
                blend: BlendMode::Modulate2x,
                value: half,
                why: format!(
                    "{}{}a factor up to {}, halved into [0, 1] and doubled by the blender (2× modulate)",
                    p.why,
                    if p.why.is_empty() { "" } else { "; " },
                    v.hi
                ),
                ..p.clone()
            });
            continue;
        }
        if p.blend != BlendMode::Add || v.lo >= 0.0 || !storage.clamps(p.dest) {
            out.push(p.clone());
            continue;
        }
        let negated = negation(module, p.value).filter(|&n| fit.fits(module, n).is_ok())?;
        if v.hi > 0.0 {
            out.push(Piece {
                why: format!("{}; its part above 0 (the blend clamps the rest)", p.why),
                ..p.clone()
            });
        }
        out.push(Piece {
            blend: BlendMode::ReverseSubtract,
            value: negated,
            why: format!(
                "{}{}its part below 0, taken off by the blender (reverse subtract), which an add would clamp to 0",
                p.why,
                if p.why.is_empty() { "" } else { "; " }
            ),
            ..p.clone()
        });
    }
    Some(out)
}

/// `v/2`, as the target computes it most simply: `2·x` is `x`, an rgb
/// value written with alpha 1 gets alpha ½.
pub(super) fn halved(module: &mut Module, v: Handle<Expr>) -> Option<Handle<Expr>> {
    if let Expr::Constant(c) = &module.exprs[v] {
        let (ty, half): (Ty, Vec<f64>) = (c.ty, c.values().iter().map(|x| x / 2.0).collect());
        return module.intern(Expr::Constant(crate::ir::Constant::new(ty, &half)), module.span(v)).ok();
    }
    if let Expr::Convert { value, to: Ty::Rgba } = module.exprs[v] {
        if matches!(module.info(value).ty, Ty::Rgb | Ty::Vec3) {
            let colour = halved(module, value)?;
            let mut b = Builder { module };
            let alpha = b.constant(Ty::Scalar, 0.5)?;
            return b.node(Expr::Compose { ty: Ty::Rgba, components: vec![colour, alpha] });
        }
    }
    // `rgba(2·x, 1)`, an affine coefficient of a colour read (`2·C.rgb·T`):
    // each part halved, `rgba(x, ½)`.
    if let Expr::Compose { ty: Ty::Rgba, ref components } = module.exprs[v] {
        if let [colour, alpha] = components[..] {
            let (colour, alpha) = (halved(module, colour)?, halved(module, alpha)?);
            return Builder { module }.node(Expr::Compose { ty: Ty::Rgba, components: vec![colour, alpha] });
        }
    }
    if let Expr::Binary { op: BinaryOp::Mul, lhs, rhs }
    | Expr::Combine { mode: CombineMode::Modulate, lhs, rhs } = module.exprs[v]
    {
        for (k, x) in [(lhs, rhs), (rhs, lhs)] {
            if module.is_constant(k, 2.0) && module.info(x).ty == module.info(v).ty {
                return Some(x);
            }
        }
    }
    if let Some(h) = halved_coefficient(module, v) {
        return Some(h);
    }
    let mut b = Builder { module };
    let half = b.constant(Ty::Scalar, 0.5)?;
    b.mul(v, half).filter(|&h| b.module.info(h).ty == b.module.info(v).ty)
}

impl Piece {
    /// `value` written whole into the target with `blend`, in one pass.
    pub(super) fn whole(blend: BlendMode, value: Handle<Expr>) -> Piece {
        Piece { blend, value, dest: Dest::Main, alpha: true, why: String::new(), holds: None }
    }
}

/// `x·k` — a constant scale `k > 1` written inside a product, moved to its
/// end — where that fits one pass written whole: the last stage's scale
/// (a texture environment's RGB_SCALE, ARB_texture_env_combine, applied to
/// a stage's result before its clamp; a combiner's output scale), which
/// the framebuffer's clamp then clamps as the meaning does:
/// min(1, k·x). `exposure·tint·(2·Det)·δp` on multitexture, where `2·Det`
/// first leaves [0, 1] at its stage. `None` for another blend.
pub(super) fn scaled_in_last_stage(
    module: &mut Module,
    fit: &dyn FitCheck,
    mode: BlendMode,
    x: Handle<Expr>,
    k: f64,
) -> Option<Handle<Expr>> {
    if mode != BlendMode::Replace {
        return None;
    }
    let mut b = Builder { module };
    let scale = b.constant(Ty::Scalar, k)?;
    let last = b.binary(BinaryOp::Mul, x, scale).filter(|&h| b.module.info(h).ty == b.module.info(x).ty)?;
    fit.fits(module, last).is_ok().then_some(last)
}

/// Why a value that fits one pass is split further: the blender cannot
/// apply it exactly ([`signed_terms`]) — a factor past 1 whose half does
/// not fit a pass (`C·(T1·δl + T1·T5²)` on four texture-environment
/// stages), whose halves then go through a temporary.
pub(super) fn not_exact_alone() -> Overflow {
    Overflow {
        resource: "cannot be blended exactly as one pass (its half, or its negation, does not fit one)"
            .into(),
        need: 0,
        have: 0,
        at: None,
        help: None,
    }
}

/// `v/2` with the half taken into each term of a sum (and each operand
/// of a `lerp`, whose weights sum to 1): `(a + b)/2` = `a/2 + b/2`, where
/// halving the sum computes it first — past 1 on a texture environment,
/// which clamps each stage's result (OpenGL 1.3, Section 3.8.13), or on
/// the general combiners, which clamp to [−1, 1]. `0.2·T0 + 0.9·T4`
/// halved is `0.1·T0 + 0.45·T4`. `None` where `v` is no sum or lerp, or
/// the halves cannot be built.
pub(super) fn halved_terms(module: &mut Module, v: Handle<Expr>) -> Option<Handle<Expr>> {
    let part = |module: &mut Module, h: Handle<Expr>| halved_terms(module, h).or_else(|| halved(module, h));
    match module.exprs[v].clone() {
        Expr::Convert { value, to: Ty::Rgba } if matches!(module.info(value).ty, Ty::Rgb | Ty::Vec3) => {
            let colour = halved_terms(module, value)?;
            let mut b = Builder { module };
            let alpha = b.constant(Ty::Scalar, 0.5)?;
            b.node(Expr::Compose { ty: Ty::Rgba, components: vec![colour, alpha] })
        }
        Expr::Binary { op: BinaryOp::Add, lhs, rhs } => {
            let (a, c) = (part(module, lhs)?, part(module, rhs)?);
            let mut b = Builder { module };
            b.binary(BinaryOp::Add, a, c).filter(|&h| b.module.info(h).ty == b.module.info(v).ty)
        }
        Expr::Math { fun: crate::ir::MathFunction::Mix, args } if module.info(args[2]).ty == Ty::Scalar => {
            let (x, y) = (part(module, args[0])?, part(module, args[1])?);
            let mut b = Builder { module };
            b.node(Expr::Math { fun: crate::ir::MathFunction::Mix, args: vec![x, y, args[2]] })
                .filter(|&h| b.module.info(h).ty == b.module.info(v).ty)
        }
        _ => None,
    }
}

/// The factors of a product, left to right, and the index of its first
/// positive scalar constant (`None` without one).
fn factors_with_constant(module: &Module, v: Handle<Expr>) -> Option<(Vec<Handle<Expr>>, usize)> {
    let factors = module.chain_operands(v, |e| matches!(e, Expr::Binary { op: BinaryOp::Mul, .. }));
    let k = factors.iter().position(
        |&f| matches!(&module.exprs[f], Expr::Constant(c) if c.ty == Ty::Scalar && c.components[0] > 0.0),
    )?;
    Some((factors, k))
}

/// A product with a scalar constant factor `k` anywhere in it, with `k/2`
/// in its place (none for `k = 2`): `2·T0·T1` halved is `T0·T1`, where
/// `(2·T0·T1)·½` would compute `2·T0` past 1 first, which a fixed-point
/// combiner clamps.
fn halved_coefficient(module: &mut Module, v: Handle<Expr>) -> Option<Handle<Expr>> {
    let (mut factors, k) = factors_with_constant(module, v)?;
    let Expr::Constant(c) = module.exprs[factors[k]].clone() else { return None };
    let mut b = Builder { module };
    if c.components[0] == 2.0 {
        factors.remove(k);
    } else {
        factors[k] = b.constant(Ty::Scalar, c.components[0] / 2.0)?;
    }
    let mut acc = *factors.first()?;
    for &f in &factors[1..] {
        acc = b.mul(acc, f)?;
    }
    (b.module.info(acc).ty == b.module.info(v).ty).then_some(acc)
}

/// A product with a scalar constant factor: the factor, and the product
/// of the others (`None` without one, or when it is the only factor).
pub(super) fn constant_factor(module: &mut Module, v: Handle<Expr>) -> Option<(Handle<Expr>, Handle<Expr>)> {
    let (mut factors, k) = factors_with_constant(module, v)?;
    let constant = factors.remove(k);
    let mut b = Builder { module };
    let mut acc = *factors.first()?;
    for &f in &factors[1..] {
        acc = b.mul(acc, f)?;
    }
    (b.module.info(acc).ty == b.module.info(v).ty).then_some((constant, acc))
}

/// `−v`, as the target computes it most simply: a subtraction's operands
/// swapped, else a negation.
fn negation(module: &mut Module, v: Handle<Expr>) -> Option<Handle<Expr>> {
    let mut b = Builder { module };
    match b.module.exprs[v] {
        Expr::Combine { mode: CombineMode::Subtract, lhs, rhs } => {
            b.node(Expr::Combine { mode: CombineMode::Subtract, lhs: rhs, rhs: lhs })
        }
        Expr::Binary { op: BinaryOp::Sub, lhs, rhs } => b.binary(BinaryOp::Sub, rhs, lhs),
        Expr::Unary { op: crate::ir::UnaryOp::Neg, value } => Some(value),
        _ => b.neg(v),
    }
}
