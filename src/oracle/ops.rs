//! The arithmetic of the language, written again from its definition
//! (docs/language.md; the ⊕ modes from OpenGL 1.2.1 §3.8.9 Table 3.22 and
//! ARB_texture_env_combine / _dot3) — not from `ir::eval`, so that a slip in
//! the one semantics the executors share shows as a disagreement.
//!
//! Values are four f64 lanes: a scalar is splatted, lanes past a vector's
//! width are zero, an `rgba` keeps alpha in lane 3.

use crate::ir::{BinaryOp, Expr, MathFunction, Module, Ty, UnaryOp};
use crate::parser::ast::CombineMode;

pub type V = [f64; 4];

/// `v` laid out for `ty`: a scalar splatted, unused lanes zeroed.
pub fn shape(ty: Ty, v: V) -> V {
    match ty.width() {
        1 => [v[0]; 4],
        w @ 2..=4 => {
            let mut out = [0.0; 4];
            out[..w].copy_from_slice(&v[..w]);
            out
        }
        _ => [f64::NAN; 4],
    }
}

fn each(f: impl Fn(usize) -> f64) -> V {
    [f(0), f(1), f(2), f(3)]
}

fn truth(b: bool) -> f64 {
    f64::from(u8::from(b))
}

fn dot(a: V, b: V, width: usize) -> f64 {
    a.iter().zip(b).take(width).map(|(x, y)| x * y).sum()
}

/// The value of a computing node from its operands' values (in
/// `Expr::operands` order). `None` for `c ? a` where `c` is false: the
/// destination is kept (Pipeline Grammar, Section 3.5: shadow volumes).
pub fn compute(m: &Module, e: &Expr, ty: Ty, o: &[V]) -> Option<V> {
    let v = match e {
        Expr::Unary { op: UnaryOp::Neg, .. } => each(|i| -o[0][i]),
        Expr::Unary { op: UnaryOp::Not, .. } => [truth(o[0][0] == 0.0); 4],
        Expr::Binary { op, lhs, .. } => binary(*op, o[0], o[1], m.info(*lhs).ty.width()),
        Expr::Combine { mode, lhs, .. } => {
            let widened = matches!(&m.exprs[*lhs], Expr::Convert { value, to: Ty::Rgba } if m.info(*value).ty == Ty::Rgb);
            texture_env(*mode, ty.width(), o[0], o[1], widened)
        }
        Expr::Math { fun, args } => math(*fun, o, m.info(args[0]).ty.width()),
        Expr::Swizzle { pattern, len, .. } => {
            let mut v = [0.0; 4];
            for (k, &i) in pattern[..*len as usize].iter().enumerate() {
                v[k] = o[0][usize::from(i) & 3];
            }
            v
        }
        Expr::Compose { components, .. } => {
            let lanes: Vec<f64> = components
                .iter()
                .zip(o)
                .flat_map(|(h, v)| v[..m.info(*h).ty.width().min(4)].to_vec())
                .collect();
            each(|i| lanes.get(i).copied().unwrap_or(0.0))
        }
        Expr::Convert { value, to } => {
            if m.info(*value).ty == Ty::Rgb && *to == Ty::Rgba {
                [o[0][0], o[0][1], o[0][2], 1.0]
            } else {
                o[0]
            }
        }
        Expr::Select { reject, .. } => match (o[0][0] != 0.0, reject) {
            (true, _) => o[1],
            (false, Some(_)) => o[2],
            (false, None) => return None,
        },
        _ => [f64::NAN; 4],
    };
    Some(shape(ty, v))
}

fn binary(op: BinaryOp, a: V, b: V, width: usize) -> V {
    use BinaryOp::*;
    match op {
        Dot => [dot(a, b, width); 4],
        Add => each(|i| a[i] + b[i]),
        Sub => each(|i| a[i] - b[i]),
        Mul => each(|i| a[i] * b[i]),
        Div => each(|i| a[i] / b[i]),
        Pow => each(|i| a[i].powf(b[i])),
        Lt => [truth(a[0] < b[0]); 4],
        Le => [truth(a[0] <= b[0]); 4],
        Gt => [truth(a[0] > b[0]); 4],
        Ge => [truth(a[0] >= b[0]); 4],
        Eq => [truth(a[0] == b[0]); 4],
        Ne => [truth(a[0] != b[0]); 4],
        And => [truth(a[0] != 0.0 && b[0] != 0.0); 4],
        Or => [truth(a[0] != 0.0 || b[0] != 0.0); 4],
    }
}

/// Built-in functions, componentwise as in GLSL; `normalize(0) = 0` (the
/// language's definition, docs/numerics.md); `expand`, `half_bias` and
/// `compress` are Kilgard 2000's Table 3 input mappings and their inverse.
fn math(fun: MathFunction, o: &[V], width: usize) -> V {
    use MathFunction::*;
    let a = o[0];
    let one = |f: fn(f64) -> f64| each(|i| f(a[i]));
    match fun {
        Normalize => {
            let n = dot(a, a, width).sqrt();
            if n == 0.0 {
                [0.0; 4]
            } else {
                each(|i| a[i] / n)
            }
        }
        Length => [dot(a, a, width).sqrt(); 4],
        Cross => {
            let b = o[1];
            [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0], 0.0]
        }
        Reflect => {
            let d = dot(o[1], a, 3);
            each(|i| a[i] - 2.0 * d * o[1][i])
        }
        Max => each(|i| a[i].max(o[1][i])),
        Min => each(|i| a[i].min(o[1][i])),
        Clamp => each(|i| a[i].max(o[1][i]).min(o[2][i])),
        Saturate => one(|x| x.clamp(0.0, 1.0)),
        Abs => one(f64::abs),
        Sign => one(f64::signum),
        Sqrt => one(f64::sqrt),
        Rsqrt => one(|x| x.sqrt().recip()),
        Exp => one(f64::exp),
        Log => one(f64::ln),
        Sin => one(f64::sin),
        Cos => one(f64::cos),
        Floor => one(f64::floor),
        Fract => one(|x| x - x.floor()),
        Expand => one(|x| 2.0 * x - 1.0),
        HalfBias => one(|x| x - 0.5),
        Compress => one(|x| 0.5 * (x + 1.0)),
        Step => each(|i| truth(o[1][i] >= a[i])),
        Mix => each(|i| a[i] + (o[1][i] - a[i]) * o[2][i]),
        Smoothstep => each(|i| {
            let t = ((o[2][i] - a[i]) / (o[1][i] - a[i])).clamp(0.0, 1.0);
            t * t * (3.0 - 2.0 * t)
        }),
    }
}

/// `t ⊕[mode] f`, the left operand the texture (Ct, At), the right the
/// incoming colour (Cf, Af) — the chained multitexturing of Pipeline Grammar,
/// eq. (12). GL 1.2.1 Table 3.22 and the combine extension, unclamped; the
/// texture environment colour Cc is GL's default 0.
fn texture_env(mode: CombineMode, width: usize, t: V, f: V, widened: bool) -> V {
    let alpha = width == 4;
    let at = if alpha { t[3] } else { 1.0 };
    let set_alpha = |mut c: V, a: f64| {
        if alpha {
            c[3] = a;
        }
        c
    };
    let dot3 = || {
        let n = if width == 1 { 1 } else { 3 };
        4.0 * (0..n).map(|i| (t[i] - 0.5) * (f[i] - 0.5)).sum::<f64>()
    };
    match mode {
        CombineMode::Modulate => each(|i| t[i] * f[i]),
        CombineMode::Add => each(|i| t[i] + f[i]),
        CombineMode::AddSigned => each(|i| t[i] + f[i] - 0.5),
        CombineMode::Subtract => each(|i| t[i] - f[i]),
        CombineMode::Decal => set_alpha(each(|i| t[i] * at + f[i] * (1.0 - at)), f[3]),
        CombineMode::Blend => set_alpha(each(|i| f[i] * (1.0 - t[i])), t[3] * f[3]),
        CombineMode::Replace => set_alpha(t, if widened { f[3] } else { t[3] }),
        CombineMode::Interpolate => each(|i| t[i] * at + f[i] * (1.0 - at)),
        CombineMode::Dot3Rgb => set_alpha([dot3(); 4], t[3] * f[3]),
        CombineMode::Dot3Rgba => [dot3(); 4],
    }
}
