//! Before selection: the per-sample `⊕` (Pipeline Grammar, Section 3.6)
//! rewritten into the products, sums and lerps it stands for, divisions by
//! a constant into products, and the
//! reassociation of long sums into register-sized groups.
//!
//! It lives apart because it works on a copy of the IR module, before any
//! register exists: the selector after it only sees arithmetic.

use super::*;

/// Rewrites the per-sample `⊕` nodes below `value` into the arithmetic they
/// stand for (`crate::ir::eval::combine`, the OpenGL 1.2.1 texture
/// environment of Pipeline Grammar, Section 3.6), so that the selector sees
/// products, sums, lerps and dot products; a division by a constant
/// becomes the product by its reciprocal. `None` when there is neither.
/// The rewritten nodes are appended to a copy of the module: every handle
/// of the original (lookups, interpolants, uniforms) keeps its meaning.
pub(super) fn desugar(module: &Module, value: Handle<Expr>) -> R<Option<(Module, Handle<Expr>)>> {
    let reach = module.reachable(&[value]);
    let is_combine = |h: &Handle<Expr>| {
        matches!(module.exprs[*h], Expr::Combine { .. }) && module.info(*h).freq.is_sample()
    };
    let floats_a_scale = |h: &Handle<Expr>| {
        module.info(*h).freq.is_sample() && scale_to_float(module, &module.exprs[*h]).is_some()
    };
    let by_constant = |h: &Handle<Expr>| {
        module.info(*h).freq.is_sample() && crate::lowering::reciprocal_of_divisor(module, *h).is_some()
    };
    let banded = |h: &Handle<Expr>| module.info(*h).freq.is_sample() && band(module, *h).is_some();
    let gathers = |h: &Handle<Expr>| constants_gathered(module, &module.exprs[*h]).is_some();
    if !reach.iter().any(|h| is_combine(h) || floats_a_scale(h) || by_constant(h) || banded(h) || gathers(h))
    {
        return Ok(None);
    }
    let mut m = module.clone();
    let mut map: HashMap<Handle<Expr>, Handle<Expr>> = HashMap::new();
    for h in reach {
        let e = module.exprs[h].clone();
        // Leaves for the combiners: texture units, interpolants, per-object values.
        if !module.info(h).freq.is_sample()
            || matches!(e, Expr::Lookup { .. } | Expr::FramebufferRead { .. } | Expr::Interpolate { .. })
        {
            continue;
        }
        let span = module.span(h);
        let e = e.map_operands(|o| map.get(&o).copied().unwrap_or(o));
        let new = match e {
            Expr::Combine { mode, lhs, rhs } => match scaled_modulate(&m, mode, lhs, rhs) {
                // `(k·y) ⊕ z`: the scale is the stage's output mapping, applied
                // after the product and clamped there, as the hardware does
                // (seeds/003 Section 4.2.2) — not `saturate(k·y)·z`.
                Some((k, y, z)) => {
                    let (y, z) = (gl_colour(&mut m, y, span)?, gl_colour(&mut m, z, span)?);
                    let inner = intern(&mut m, Expr::Binary { op: BinaryOp::Mul, lhs: y, rhs: z }, span)?;
                    intern(&mut m, Expr::Binary { op: BinaryOp::Mul, lhs: k, rhs: inner }, span)?
                }
                None => {
                    let Expr::Combine { lhs: t, rhs: f, .. } = module.exprs[h] else { unreachable!("a ⊕") };
                    let clamped = [t, f].map(|o| !written_arithmetic(module, o));
                    let result = combine_expr(&mut m, mode, [lhs, rhs], clamped, module.info(h).ty, span)?;
                    // GL clamps a texture-environment result to [0, 1]
                    // (§3.8.9): where arithmetic reads it (`T + (T ⊕[dot3] I)`),
                    // the combiners read it clamped too. The pass's own
                    // value is clamped by the output.
                    if h == value {
                        result
                    } else {
                        gl_colour(&mut m, result, span)?
                    }
                }
            },
            // x / k = x · (1/k): the constant in a register, or an output scale.
            Expr::Binary { op: BinaryOp::Div, lhs, .. } if by_constant(&h) => {
                let inverse = crate::lowering::reciprocal_of_divisor(module, h).unwrap_or(1.0);
                let k = intern(&mut m, Expr::Constant(Constant::scalar(inverse)), span)?;
                intern(&mut m, Expr::Binary { op: BinaryOp::Mul, lhs, rhs: k }, span)?
            }
            // clamp(x, lo, hi) = min(max(x, lo), hi), each by a clamp
            // (`ops.rs::max_by_clamp`, `min_by_clamp`).
            Expr::Math { fun: MathFunction::Clamp, ref args } if banded(&h) => {
                let floor = Expr::Math { fun: MathFunction::Max, args: vec![args[0], args[1]] };
                let floor = intern(&mut m, floor, span)?;
                intern(&mut m, Expr::Math { fun: MathFunction::Min, args: vec![floor, args[2]] }, span)?
            }
            e => match (constants_gathered(&m, &e), scale_to_float(&m, &e)) {
                // `(k + x) − c` = `x + (k − c)`: one constant register.
                (Some((x, k)), _) => {
                    let k = intern(&mut m, Expr::Constant(k), span)?;
                    intern(&mut m, Expr::Binary { op: BinaryOp::Add, lhs: x, rhs: k }, span)?
                }
                (None, Some((k, y, z))) => {
                    let inner = intern(&mut m, Expr::Binary { op: BinaryOp::Mul, lhs: y, rhs: z }, span)?;
                    intern(&mut m, Expr::Binary { op: BinaryOp::Mul, lhs: k, rhs: inner }, span)?
                }
                (None, None) => intern(&mut m, e, span)?,
            },
        };
        if new != h {
            map.insert(h, new);
        }
    }
    let v = map.get(&value).copied().unwrap_or(value);
    Ok(Some((m, v)))
}

/// `(k + x) ± c` or `(x + k) ± c` with constants `k` and `c` of one width
/// (or a scalar, splat): `(x, k ± c)`, both constants in one register — a
/// GameCube TEV stage's konst colour and bias, `2·(konst + lerp(…) − ¼)`,
/// in the two general combiners of a GeForce 256 (Kilgard 2000, Section
/// 4.2: a sum of a register and a constant is one portion's `AB + CD`).
fn constants_gathered(m: &Module, e: &Expr) -> Option<(Handle<Expr>, Constant)> {
    let Expr::Binary { op: op @ (BinaryOp::Add | BinaryOp::Sub), lhs, rhs } = *e else { return None };
    let Expr::Constant(c) = &m.exprs[rhs] else { return None };
    let Expr::Binary { op: BinaryOp::Add, lhs: a, rhs: b } = m.exprs[lhs] else { return None };
    let (x, k) = match (&m.exprs[a], &m.exprs[b]) {
        (Expr::Constant(k), _) => (b, k),
        (_, Expr::Constant(k)) => (a, k),
        _ => return None,
    };
    let (kv, cv) = (k.values(), c.values());
    if kv.len() != cv.len() && kv.len() != 1 && cv.len() != 1 {
        return None;
    }
    let ty = if kv.len() >= cv.len() { k.ty } else { c.ty };
    let at = |v: &[f64], i: usize| if v.len() == 1 { v[0] } else { v[i] };
    let sign = if op == BinaryOp::Sub { -1.0 } else { 1.0 };
    let sum: Vec<f64> = (0..kv.len().max(cv.len())).map(|i| at(kv, i) + sign * at(cv, i)).collect();
    Some((x, Constant::new(ty, &sum)))
}

/// `clamp(x, lo, hi)` at `h` with constant bounds other than 0 and 1 (those
/// are an unsigned mapping, `select.rs`): `(lo, hi)`.
fn band(m: &Module, h: Handle<Expr>) -> Option<(Handle<Expr>, Handle<Expr>)> {
    let Expr::Math { fun: MathFunction::Clamp, args } = &m.exprs[h] else { return None };
    let constant = |a: Handle<Expr>| matches!(m.exprs[a], Expr::Constant(_));
    let unit = m.is_constant(args[1], 0.0) && m.is_constant(args[2], 1.0);
    (constant(args[1]) && constant(args[2]) && !unit).then_some((args[1], args[2]))
}

/// `(k · y) · z` or `z · (k · y)` with `k` an output scale (½, 2, 4, 8):
/// `(k, y, z)`, to be rewritten `k · (y · z)` so that the scale lands on the
/// stage's output mapping whatever the order written (Kilgard 2000, Section
/// 4.2.2: scale_by_two() applies to a stage's output, so
/// `2 * L * B` maps as `L * B * 2` does).
pub(super) fn scale_to_float(m: &Module, e: &Expr) -> Option<(Handle<Expr>, Handle<Expr>, Handle<Expr>)> {
    let Expr::Binary { op: BinaryOp::Mul, lhs, rhs } = *e else { return None };
    let scale = |h: Handle<Expr>| matches!(&m.exprs[h], Expr::Constant(c) if { let v = c.values(); !v.is_empty() && v.iter().all(|x| *x == v[0]) && [0.5, 2.0, 4.0, 8.0].contains(&v[0]) });
    let scaled = |h: Handle<Expr>| match m.exprs[h] {
        Expr::Binary { op: BinaryOp::Mul, lhs: a, rhs: b } if scale(a) && !scale(b) => Some((a, b)),
        Expr::Binary { op: BinaryOp::Mul, lhs: a, rhs: b } if scale(b) && !scale(a) => Some((b, a)),
        _ => None,
    };
    if scale(lhs) || scale(rhs) {
        return None;
    }
    scaled(lhs).map(|(k, y)| (k, y, rhs)).or_else(|| scaled(rhs).map(|(k, y)| (k, y, lhs)))
}

/// `(k · y) ⊕ z` or `z ⊕ (k · y)` in modulate mode, `k` an output scale and
/// `y` a colour in [0, 1]: `(k, y, z)`.
pub(super) fn scaled_modulate(
    m: &Module,
    mode: CombineMode,
    lhs: Handle<Expr>,
    rhs: Handle<Expr>,
) -> Option<(Handle<Expr>, Handle<Expr>, Handle<Expr>)> {
    if mode != CombineMode::Modulate {
        return None;
    }
    let (k, y, z) = scale_to_float(m, &Expr::Binary { op: BinaryOp::Mul, lhs, rhs })?;
    let i = m.info(y).interval;
    (i.lo >= 0.0 && i.hi <= 1.0).then_some((k, y, z))
}

/// Whether the `⊕` operand `o` is arithmetic the program writes (`T + T`,
/// `k · x`), not a colour GL hands the texture environment (a texel, an
/// interpolated colour, the framebuffer, another `⊕`'s result): the
/// program means its value unclamped, and the combiners compute it so
/// (registers hold [−1, 1], the sums reordered to stay there).
pub(super) fn written_arithmetic(m: &Module, o: Handle<Expr>) -> bool {
    m.info(o).freq.is_sample() && matches!(m.exprs[o], Expr::Binary { .. } | Expr::Unary { .. })
}

/// `h` clamped to [0, 1] where its range leaves it (see [`combine_expr`]).
pub(super) fn gl_colour(m: &mut Module, h: Handle<Expr>, span: Span) -> R<Handle<Expr>> {
    let i = m.info(h).interval;
    if i.lo >= 0.0 && i.hi <= 1.0 {
        return Ok(h);
    }
    intern(m, Expr::Math { fun: MathFunction::Saturate, args: vec![h] }, span)
}

pub(super) fn intern(m: &mut Module, e: Expr, span: Span) -> R<Handle<Expr>> {
    m.intern(e, span).map_err(|t| {
        unsupported(
            span,
            format!("this value ({})", t.message),
            "please report this: rewriting ⊕ for the combiners failed",
        )
    })
}

/// `t ⊕[mode] f` of type `ty` as IR arithmetic: `crate::ir::eval::combine`
/// node for node (TEXTURE_ENV_COLOR is 0, so `blend` is f·(1 − t)).
///
/// Each operand enters as GL gives it to the texture environment or the
/// blender: a colour in [0, 1] (OpenGL 1.2.1 Sections 2.13.6 and 4.1.7:
/// fragment colours are clamped, texels and fixed-point framebuffer values
/// are in range). Such an operand (`clamped`) whose range leaves [0, 1] is
/// therefore `saturate`d here — what the as-written plan does on the
/// hardware, where the operand is the fragment colour a blend clamps
/// (Kilgard's `C ⊕ rgba(diffuse, s_self)`, `diffuse` in [0.1, 1.1], fused
/// into one pass). Arithmetic written as an operand (`(T + T) ⊕ T`) is
/// not a colour GL clamps: it keeps its value ([`written_arithmetic`]).
/// The IR itself keeps ⊕ unclamped (docs/language.md).
pub(super) fn combine_expr(
    m: &mut Module,
    mode: CombineMode,
    [t, f]: [Handle<Expr>; 2],
    clamped: [bool; 2],
    ty: Ty,
    span: Span,
) -> R<Handle<Expr>> {
    let bin = |m: &mut Module, op: BinaryOp, lhs: Handle<Expr>, rhs: Handle<Expr>| {
        intern(m, Expr::Binary { op, lhs, rhs }, span)
    };
    let konst = |m: &mut Module, v: f64| intern(m, Expr::Constant(Constant::scalar(v)), span);
    let lhs_rgb = matches!(m.exprs[t], Expr::Convert { value, to: Ty::Rgba } if m.info(value).ty == Ty::Rgb);
    let colour = |m: &mut Module, h, clamped| if clamped { gl_colour(m, h, span) } else { Ok(h) };
    let (t, f) = (colour(m, t, clamped[0])?, colour(m, f, clamped[1])?);
    let rgba = ty == Ty::Rgba;
    let rgb_of = |m: &mut Module, h: Handle<Expr>| rgb_part(m, h, span);
    let alpha_of = |m: &mut Module, h: Handle<Expr>| alpha_part(m, h, span);
    let compose = |m: &mut Module, c: Handle<Expr>, a: Handle<Expr>| {
        intern(m, Expr::Compose { ty: Ty::Rgba, components: vec![c, a] }, span)
    };
    Ok(match mode {
        CombineMode::Modulate => bin(m, BinaryOp::Mul, t, f)?,
        CombineMode::Add => bin(m, BinaryOp::Add, t, f)?,
        CombineMode::Subtract => bin(m, BinaryOp::Sub, t, f)?,
        CombineMode::AddSigned => {
            let sum = bin(m, BinaryOp::Add, t, f)?;
            intern(m, Expr::Math { fun: MathFunction::HalfBias, args: vec![sum] }, span)?
        }
        // Without alpha, At = 1: decal, replace and interpolate give t.
        CombineMode::Decal | CombineMode::Replace | CombineMode::Interpolate if !rgba => t,
        // rgb = f·(1 − At) + t·At, alpha = Af.
        CombineMode::Decal => {
            let (tc, fc, fa) = (rgb_of(m, t)?, rgb_of(m, f)?, alpha_of(m, f)?);
            let c = if lhs_rgb {
                tc
            } else {
                let at = alpha_of(m, t)?;
                intern(m, Expr::Math { fun: MathFunction::Mix, args: vec![fc, tc, at] }, span)?
            };
            compose(m, c, fa)?
        }
        CombineMode::Replace => {
            let tc = rgb_of(m, t)?;
            let a = if lhs_rgb { alpha_of(m, f)? } else { alpha_of(m, t)? };
            compose(m, tc, a)?
        }
        CombineMode::Interpolate => {
            let at = alpha_of(m, t)?;
            intern(m, Expr::Math { fun: MathFunction::Mix, args: vec![f, t, at] }, span)?
        }
        // rgb = f·(1 − t) (+ Cc·t, Cc = 0), alpha = At·Af.
        CombineMode::Blend => {
            let one = konst(m, 1.0)?;
            let (tc, fc) = (rgb_of(m, t)?, rgb_of(m, f)?);
            let inv = bin(m, BinaryOp::Sub, one, tc)?;
            let c = bin(m, BinaryOp::Mul, fc, inv)?;
            if rgba {
                let (ta, fa) = (alpha_of(m, t)?, alpha_of(m, f)?);
                let a = bin(m, BinaryOp::Mul, ta, fa)?;
                compose(m, c, a)?
            } else {
                c
            }
        }
        // 4·Σ(t − ½)(f − ½) = expand(t)·expand(f), on every channel (dot3_rgba)
        // or rgb with alpha At·Af (dot3_rgb).
        CombineMode::Dot3Rgb | CombineMode::Dot3Rgba => {
            let (tc, fc) = (rgb_of(m, t)?, rgb_of(m, f)?);
            let et = intern(m, Expr::Math { fun: MathFunction::Expand, args: vec![tc] }, span)?;
            let ef = intern(m, Expr::Math { fun: MathFunction::Expand, args: vec![fc] }, span)?;
            let op = if m.info(tc).ty == Ty::Scalar { BinaryOp::Mul } else { BinaryOp::Dot };
            let d = bin(m, op, et, ef)?;
            match (mode, ty) {
                (_, Ty::Scalar) => d,
                (CombineMode::Dot3Rgb, Ty::Rgba) => {
                    let c = intern(m, Expr::Convert { value: d, to: Ty::Rgb }, span)?;
                    let (ta, fa) = (alpha_of(m, t)?, alpha_of(m, f)?);
                    let a = bin(m, BinaryOp::Mul, ta, fa)?;
                    compose(m, c, a)?
                }
                (_, ty) => intern(m, Expr::Convert { value: d, to: ty }, span)?,
            }
        }
    })
}

/// The colour part of a value, for `combine_expr` (a scalar or rgb is its own).
fn rgb_part(m: &mut Module, h: Handle<Expr>, span: Span) -> R<Handle<Expr>> {
    match m.info(h).ty {
        Ty::Rgba => intern(m, Expr::Swizzle { value: h, pattern: [0, 1, 2, 0], len: 3, ty: Ty::Rgb }, span),
        _ => Ok(h),
    }
}

/// The alpha of a value, for `combine_expr`: a scalar splats, an rgb has alpha 1.
fn alpha_part(m: &mut Module, h: Handle<Expr>, span: Span) -> R<Handle<Expr>> {
    match m.info(h).ty {
        Ty::Rgba => {
            intern(m, Expr::Swizzle { value: h, pattern: [3, 0, 0, 0], len: 1, ty: Ty::Scalar }, span)
        }
        Ty::Scalar => Ok(h),
        _ => intern(m, Expr::Constant(Constant::scalar(1.0)), span),
    }
}

/// At most this many addends are reordered ([`Gen::reassociated_sum`]).
pub(super) const MAX_ADDENDS: usize = 6;

/// An order of addends (their ranges) whose partial sums, from the first
/// two to all but the last, stay in a register's [−1, 1]; depth-first, the
/// order written first. `None` when none does (or fewer than three).
pub(super) fn order_within_a_register(ranges: &[(f64, f64)]) -> Option<Vec<usize>> {
    fn extend(ranges: &[(f64, f64)], order: &mut Vec<usize>, lo: f64, hi: f64) -> bool {
        if order.len() + 1 >= ranges.len() {
            return true;
        }
        for i in 0..ranges.len() {
            if order.contains(&i) {
                continue;
            }
            let (l, h) = (lo + ranges[i].0, hi + ranges[i].1);
            if !order.is_empty() && (l < -1.0 || h > 1.0) {
                continue;
            }
            order.push(i);
            if extend(ranges, order, l, h) {
                return true;
            }
            order.pop();
        }
        false
    }
    if ranges.len() < 3 || ranges.len() > MAX_ADDENDS {
        return None;
    }
    let mut order = Vec::new();
    extend(ranges, &mut order, 0.0, 0.0).then(|| {
        let rest = (0..ranges.len()).filter(|i| !order.contains(i));
        order.extend(rest.collect::<Vec<_>>());
        order
    })
}
