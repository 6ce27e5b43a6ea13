//! The meaning of every IR operation, and an interpreter of IR nodes for one
//! sample (a pixel, texel or vertex) at a time.
//!
//! # One semantics
//!
//! [`apply`] is *the* definition of what a computation node does to its
//! operands' values. Everything that needs numbers from the IR goes through
//! it: the constant folder (`valid::fold`, which keeps only finite results),
//! the [`Evaluator`] (the CPU renderer's `exact` and `f32` shading modes, the
//! pass planner's split-correctness checks, GPU agreement tests). A backend
//! that computes a node differently from `apply` is wrong by definition.
//!
//! # Values
//!
//! A [`Value`] is four `f64` lanes holding `ty.width()` components. A scalar
//! is *splatted* into all four lanes, so componentwise operations broadcast a
//! scalar operand without looking at its type (`kd * max(0, N·L)`: an `rgb`
//! times a scalar); lanes past a vector's width are zero. Every value `apply`
//! and the evaluator produce is in this canonical layout ([`canonical`]),
//! and operands given to `apply` must be too ([`value`] converts a
//! [`Constant`]). Bundles (three components per member, Pipeline Grammar, eq. (5)) do not
//! fit in a value: a [`Expr::Bundle`] evaluates to NaN — evaluate its members.
//!
//! # Leaves
//!
//! What the IR cannot compute by itself for the current sample (uniforms,
//! interpolated values, texels, framebuffer pixels, the vertex attributes of
//! the vertex stage) comes from an [`Env`]. `δ e` ([`Expr::Interpolate`]) is
//! a leaf too: the rasterizer interpolates; the per-vertex `e` is evaluated
//! by a second evaluator over the vertices (roots: [`Evaluator::interpolants`]).
//! An unanswered leaf is NaN ([`NAN`]) so that a missing input shows instead
//! of passing for a plausible number.

use super::{
    BinaryOp, Constant, Expr, FbChannel, FramebufferId, Frequency, Handle, MathFunction, Module, Projection,
    Site, TexCoordId, TextureId, Ty, UnaryOp, UniformId, VectorId, VertexId,
};
use crate::parser::ast::CombineMode;

mod evaluator;

pub use evaluator::{Env, EvalResult, Evaluator};

/// The value of a node for one sample: see the module doc for the layout.
pub type Value = [f64; 4];

/// What an unknown leaf, a bundle, a failed `c ? a` or a leaf given to
/// [`apply`] evaluates to.
pub const NAN: Value = [f64::NAN; 4];

/// OpenGL's `GL_TEXTURE_ENV_COLOR`, the constant colour `Cc` of the blend
/// texture environment: (0, 0, 0, 0) by default (OpenGL 1.2.1 §3.8.9), and
/// the notation has no way to set it, so `⊕[blend]` always sees this.
pub const TEXTURE_ENV_COLOR: Value = [0.0; 4];

/// A constant's value in the canonical layout (a scalar splatted).
pub fn value(c: &Constant) -> Value {
    canonical(c.ty, c.components)
}

/// `v` in the canonical layout for `ty`: a scalar's lane 0 splatted, lanes
/// past a vector's width zeroed.
#[inline]
pub fn canonical(ty: Ty, mut v: Value) -> Value {
    match ty.width() {
        1 => [v[0]; 4],
        w @ 2..=4 => {
            for x in &mut v[w..] {
                *x = 0.0;
            }
            v
        }
        _ => NAN,
    }
}

/// Whether `apply` computes `e` from its operands (rather than `e` being a
/// leaf that an [`Env`] supplies).
pub fn is_computation(e: &Expr) -> bool {
    matches!(
        e,
        Expr::Unary { .. }
            | Expr::Binary { .. }
            | Expr::Combine { .. }
            | Expr::Math { .. }
            | Expr::Swizzle { .. }
            | Expr::Compose { .. }
            | Expr::Convert { .. }
            | Expr::Select { .. }
    )
}

/// A constant, or a computation other than the texture environment's `⊕`
/// (whose clamp depends on the target): what the compiler may evaluate
/// ahead of time over a grid (the texel and solid-texture bakes).
pub fn is_pure_arithmetic(e: &Expr) -> bool {
    matches!(e, Expr::Constant(_)) || (is_computation(e) && !matches!(e, Expr::Combine { .. }))
}

#[inline]
fn lanes(f: impl Fn(usize) -> f64) -> Value {
    [f(0), f(1), f(2), f(3)]
}

fn bool(x: bool) -> f64 {
    if x {
        1.0
    } else {
        0.0
    }
}

/// The value of computation node `expr` of type `ty` (its inferred type,
/// `module.info`) given its operands' values, in `expr.operands()` order and
/// in the canonical layout. `module` gives the operands' types where an
/// operation depends on them (a dot product's width, `rgb` → `rgba`).
///
/// Semantics, in f64 (the [`Evaluator`] rounds afterwards for `f32`):
///
/// - Arithmetic, `^` and the built-in functions componentwise, scalars
///   broadcast; `a · b` sums over the operands' width (of two scalars: their
///   product). `expand(x) = 2x − 1`, `half_bias(x) = x − ½` and
///   `compress(x) = (x + 1)/2` are the register-combiner range mappings of
///   Kilgard 2000, Table 3 (`GL_EXPAND_NORMAL`, `GL_HALF_BIAS_NORMAL`) and their
///   inverse, the range compression of Kilgard 2000, Section 5.3.
///   `step(e, x) = x < e ? 0 : 1`, `smoothstep(e0, e1, x)` and
///   `mix(a, b, t) = a(1 − t) + bt` as in GLSL; `cross(a, b)` the cross
///   product and `reflect(I, N) = I − 2(N·I)N` as GLSL's (N unit).
/// - Comparisons and `∧ ∨ not` give 0 or 1; any nonzero value is true.
/// - `c ? a : b` is `a` where `c ≠ 0`, else `b`. `c ? a` (no `b`) keeps the
///   destination where `c = 0` (the shadow-volume pass, Pipeline Grammar, Section
///   3.5): that is not a value, so `apply` gives [`NAN`] and the
///   [`Evaluator`] reports the sample as discarded.
/// - Swizzles select lanes, `(a, b, …)` concatenates, `rgb` → `rgba` sets
///   alpha 1, a scalar converted to a vector is splatted.
/// - `⊕` modes: see [`combine`].
///
/// Leaves (`Constant`, `Uniform`, lookups, `δ`, …) and bundles give
/// [`NAN`]: their values come from an [`Env`].
pub fn apply(module: &Module, expr: &Expr, ty: Ty, operands: &[Value]) -> Value {
    let o = operands;
    let v = match expr {
        Expr::Unary { op, .. } => match op {
            UnaryOp::Neg => lanes(|i| -o[0][i]),
            UnaryOp::Not => [bool(o[0][0] == 0.0); 4],
        },
        Expr::Binary { op, lhs, .. } => {
            let (a, b) = (o[0], o[1]);
            use BinaryOp::*;
            match op {
                Dot => [dot(&a, &b, module.info(*lhs).ty.width()); 4],
                Add => lanes(|i| a[i] + b[i]),
                Sub => lanes(|i| a[i] - b[i]),
                Mul => lanes(|i| a[i] * b[i]),
                Div => lanes(|i| a[i] / b[i]),
                Pow => lanes(|i| a[i].powf(b[i])),
                Lt => [bool(a[0] < b[0]); 4],
                Le => [bool(a[0] <= b[0]); 4],
                Gt => [bool(a[0] > b[0]); 4],
                Ge => [bool(a[0] >= b[0]); 4],
                Eq => [bool(a[0] == b[0]); 4],
                Ne => [bool(a[0] != b[0]); 4],
                And => [bool(a[0] != 0.0 && b[0] != 0.0); 4],
                Or => [bool(a[0] != 0.0 || b[0] != 0.0); 4],
            }
        }
        Expr::Combine { mode, lhs, .. } => {
            // An rgb texture widened to rgba (alpha 1) by lowering has no alpha of its own.
            let lhs_rgb = matches!(&module.exprs[*lhs], Expr::Convert { value, to: Ty::Rgba } if module.info(*value).ty == Ty::Rgb);
            combine(*mode, ty.width(), &o[0], &o[1], lhs_rgb)
        }
        Expr::Math { fun, args } => math(module, *fun, args, ty, o),
        Expr::Swizzle { pattern, len, .. } => {
            let mut v = [0.0; 4];
            for (k, &i) in pattern[..*len as usize].iter().enumerate() {
                v[k] = o[0][i as usize & 3];
            }
            v
        }
        Expr::Compose { components, .. } => {
            let mut v = [0.0; 4];
            let mut k = 0;
            for (h, c) in components.iter().zip(o) {
                for &x in &c[..module.info(*h).ty.width().min(4)] {
                    if k < 4 {
                        v[k] = x;
                    }
                    k += 1;
                }
            }
            v
        }
        Expr::Convert { value, to } => {
            if module.info(*value).ty == Ty::Rgb && *to == Ty::Rgba {
                [o[0][0], o[0][1], o[0][2], 1.0]
            } else {
                o[0]
            }
        }
        Expr::Select { reject, .. } => {
            if o[0][0] != 0.0 {
                o[1]
            } else if reject.is_some() {
                o[2]
            } else {
                NAN
            }
        }
        _ => NAN,
    };
    canonical(ty, v)
}

#[inline]
fn dot(a: &Value, b: &Value, width: usize) -> f64 {
    (0..width.min(4)).map(|i| a[i] * b[i]).sum()
}

fn math(module: &Module, fun: MathFunction, args: &[Handle<Expr>], ty: Ty, o: &[Value]) -> Value {
    use MathFunction::*;
    let a = o[0];
    let f1 = |f: fn(f64) -> f64| lanes(|i| f(a[i]));
    match fun {
        Normalize => {
            // normalize(0) has no direction. GLSL leaves it undefined (NaN on
            // most GPUs); we define it as the zero vector, as glam's
            // `normalize_or_zero` in the scene binder does: every dot product
            // with it is 0, so a zero-length interpolated normal and the half
            // vector of L = −V (seeds/003 Eq. 16, H = (L + V)/|L + V|) light
            // nothing — what GL's lighting gives there, since its specular
            // term is 0 wherever N·L ≤ 0. docs/numerics.md lists the cases.
            let n = dot(&a, &a, ty.width()).sqrt();
            if n == 0.0 {
                return [0.0; 4];
            }
            lanes(|i| a[i] / n)
        }
        Length => [dot(&a, &a, module.info(args[0]).ty.width()).sqrt(); 4],
        Cross => {
            let b = o[1];
            [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0], 0.0]
        }
        Reflect => {
            // GLSL reflect(I, N) = I − 2·dot(N, I)·N.
            let n = o[1];
            let d = dot(&n, &a, 3);
            lanes(|i| a[i] - 2.0 * d * n[i])
        }
        Max => lanes(|i| a[i].max(o[1][i])),
        Min => lanes(|i| a[i].min(o[1][i])),
        Clamp => lanes(|i| a[i].max(o[1][i]).min(o[2][i])),
        Saturate => f1(|x| x.clamp(0.0, 1.0)),
        Abs => f1(f64::abs),
        Sign => f1(f64::signum),
        Sqrt => f1(f64::sqrt),
        Rsqrt => f1(|x| 1.0 / x.sqrt()),
        Exp => f1(f64::exp),
        Log => f1(f64::ln),
        Sin => f1(f64::sin),
        Cos => f1(f64::cos),
        Floor => f1(f64::floor),
        Fract => f1(|x| x - x.floor()),
        Expand => f1(|x| 2.0 * x - 1.0),
        HalfBias => f1(|x| x - 0.5),
        Compress => f1(|x| (x + 1.0) / 2.0),
        Step => lanes(|i| if o[1][i] < a[i] { 0.0 } else { 1.0 }),
        Mix => lanes(|i| a[i] * (1.0 - o[2][i]) + o[1][i] * o[2][i]),
        Smoothstep => lanes(|i| {
            let t = ((o[2][i] - a[i]) / (o[1][i] - a[i])).clamp(0.0, 1.0);
            t * t * (3.0 - 2.0 * t)
        }),
    }
}

/// `t ⊕[mode] f`: OpenGL 1.2.1's texture environment (§3.8.9, Table 3.22)
/// and ARB_texture_env_combine, on values of `width` 1 (a scalar: one colour
/// channel), 3 (`rgb`) or 4 (`rgba`, alpha in lane 3).
///
/// **Which operand is the texture.** Pipeline Grammar, eq. (12) writes chained
/// multitexturing as `C δπx ← T‴ δu‴ x ⊕ (T″ δu″ x ⊕ (T′ δu′ x ⊕ T δu x))`:
/// each texture unit applies its texture over the colour coming from the
/// units before it, so the **left operand is the texture** (`Ct`, `At`) and
/// the **right operand the incoming fragment colour** (`Cf`, `Af`). For the
/// symmetric modes this does not matter; for `decal`, `blend`, `replace`,
/// `interpolate` and `subtract` it does.
///
/// | mode | colour | alpha (rgba) |
/// |---|---|---|
/// | `modulate` (default) | `Ct·Cf` | `At·Af` |
/// | `add` | `Ct + Cf` | `At + Af` |
/// | `add_signed` | `Ct + Cf − ½` | `At + Af − ½` |
/// | `subtract` | `Ct − Cf` | `At − Af` |
/// | `decal` | `Cf(1 − At) + Ct·At` | `Af` |
/// | `blend` | `Cf(1 − Ct) + Cc·Ct` | `Af·At` |
/// | `replace` | `Ct` | `At` (`Af` for an rgb texture) |
/// | `interpolate` | `Ct·At + Cf(1 − At)` | `At·At + Af(1 − At)` |
/// | `dot3_rgb` | `4((Ct − ½)·(Cf − ½))` in r, g, b | `At·Af` |
/// | `dot3_rgba` | `4((Ct − ½)·(Cf − ½))` in r, g, b, a | |
///
/// - `add`, `add_signed`, `subtract` are the combine extension's functions
///   with the same function for `COMBINE_RGB` and `COMBINE_ALPHA` (so
///   alpha adds; the older `GL_ADD` environment multiplies alphas). That is
///   also what framebuffer blending `C ← C ⊕[add] …` (`glBlendFunc(ONE,
///   ONE)`) does to alpha.
/// - `Cc` is [`TEXTURE_ENV_COLOR`], GL's default (0, 0, 0, 0): `blend`
///   gives `Cf(1 − Ct)`, the texture as an opacity darkening the fragment.
/// - A texture without alpha (an `rgb` operand, or one lowering widened to
///   `rgba` with alpha 1) has `At = 1`, so `decal` and `interpolate` give
///   `Ct`; for `replace`, `lhs_rgb` says the texture was widened and GL's
///   RGB base format keeps `Af`.
/// - `interpolate` is the combine extension's `Arg0·Arg2 + Arg1(1 − Arg2)`
///   with `Arg0 = Ct`, `Arg1 = Cf` and `Arg2 = At` (source texture, operand
///   `SRC_ALPHA`): GL's default third source is the constant colour, whose
///   alpha 0 would make the mode return `Cf` unchanged, and ⊕ has only two
///   operands.
/// - `dot3` (ARB_texture_env_dot3) sums over r, g, b only and splats the
///   result; for `dot3_rgb` the alpha function is the default `MODULATE`.
///   Of two scalars it is `4(t − ½)(f − ½)`.
///
/// Results are **not clamped** to [0, 1] here, although GL clamps every
/// texture-environment result: clamping belongs to the hardware model (the
/// combiner emulator, an 8-bit framebuffer), so that the planner can see the
/// exact value a split would have to store.
pub fn combine(mode: CombineMode, width: usize, t: &Value, f: &Value, lhs_rgb: bool) -> Value {
    let has_alpha = width == 4;
    let at = if has_alpha { t[3] } else { 1.0 };
    let cc = TEXTURE_ENV_COLOR;
    let with_alpha = |rgb: Value, alpha: f64| if has_alpha { [rgb[0], rgb[1], rgb[2], alpha] } else { rgb };
    let dot3 = || {
        if width == 1 {
            4.0 * (t[0] - 0.5) * (f[0] - 0.5)
        } else {
            4.0 * (0..3).map(|i| (t[i] - 0.5) * (f[i] - 0.5)).sum::<f64>()
        }
    };
    match mode {
        CombineMode::Modulate => lanes(|i| t[i] * f[i]),
        CombineMode::Add => lanes(|i| t[i] + f[i]),
        CombineMode::AddSigned => lanes(|i| t[i] + f[i] - 0.5),
        CombineMode::Subtract => lanes(|i| t[i] - f[i]),
        CombineMode::Decal => with_alpha(lanes(|i| f[i] * (1.0 - at) + t[i] * at), f[3]),
        CombineMode::Blend => with_alpha(lanes(|i| f[i] * (1.0 - t[i]) + cc[i] * t[i]), t[3] * f[3]),
        CombineMode::Replace => with_alpha(*t, if lhs_rgb { f[3] } else { t[3] }),
        CombineMode::Interpolate => lanes(|i| t[i] * at + f[i] * (1.0 - at)),
        CombineMode::Dot3Rgb => with_alpha([dot3(); 4], t[3] * f[3]),
        CombineMode::Dot3Rgba => [dot3(); 4],
    }
}

#[cfg(test)]
mod tests;
