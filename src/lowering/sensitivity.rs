//! How far an error at one value can move the program's output: a rule
//! states its bound at the value it replaces (an 8-bit normal is within
//! 1/255 per component), but `max(0, N·H)¹⁶` multiplies an error of `H`
//! by up to 16·3 at the pixel. The output bound of an approximation is its
//! site bound times the output's sensitivity to the site, `L`, found here
//! by first-order interval arithmetic over the lowered IR: `L` of a sum is
//! the sum of `L`s, of a product `L_a·max|b| + max|a|·L_b`, of `xⁿ`
//! `n·max|x|ⁿ⁻¹·L_x`, of `expand` `2L`, of a clamp `L` (the ranges are the
//! IR's intervals, Kilgard 2000, Section 4.2's register ranges where known).
//! Errors stored by one statement (a texture, a framebuffer) are read by
//! the next through their lookups (filtering is a convex combination).
//!
//! What has no such bound — a site inside a texture coordinate (the slope
//! of the texture is unknown), a condition, a division, `normalize` —
//! gives `None`: only a scene can measure it (`--max-error` on a scene).

use std::collections::HashMap;

use crate::ir::{BinaryOp, Expr, FbChannel, Handle, MathFunction, Module, Table, UnaryOp};
use crate::parser::ast::CombineMode;

/// Where an error is held between statements.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum Store {
    Texture(u32),
    Framebuffer(u32, FbChannel),
}

/// The largest change of any framebuffer's value, per component, per unit
/// of change at `site` (`None`: unbounded or unknown).
pub fn output_sensitivity(m: &Module, site: Handle<Expr>) -> Option<f64> {
    let mut stored: HashMap<Store, f64> = HashMap::new();
    let mut out: f64 = 0.0;
    for st in &m.statements {
        let mut walk = Walk { m, site, stored: &stored, memo: HashMap::new() };
        if walk.of(st.index)? != 0.0 {
            return None; // the site moves where the statement writes
        }
        let l = walk.of(st.value)?;
        if l == 0.0 {
            continue;
        }
        let store = match st.table {
            Table::Framebuffer { id, channel } => Store::Framebuffer(id, channel),
            Table::Texture(id) => Store::Texture(id),
            Table::TexCoords(_) => return None, // a coordinate: unknown slope
        };
        let held = stored.entry(store).or_insert(0.0);
        *held = held.max(l);
        if matches!(store, Store::Framebuffer(..)) {
            out = out.max(l);
        }
    }
    out.is_finite().then_some(out)
}

struct Walk<'a> {
    m: &'a Module,
    site: Handle<Expr>,
    stored: &'a HashMap<Store, f64>,
    memo: HashMap<Handle<Expr>, Option<f64>>,
}

impl Walk<'_> {
    /// `L` of `h` with respect to the site.
    fn of(&mut self, h: Handle<Expr>) -> Option<f64> {
        if h == self.site {
            return Some(1.0);
        }
        if let Some(&l) = self.memo.get(&h) {
            return l;
        }
        let l = self.node(h).filter(|l| l.is_finite());
        self.memo.insert(h, l);
        l
    }

    /// max |x| over `h`'s interval.
    fn mag(&self, h: Handle<Expr>) -> f64 {
        let iv = self.m.info(h).interval;
        iv.lo.abs().max(iv.hi.abs())
    }

    fn width(&self, h: Handle<Expr>) -> f64 {
        self.m.info(h).ty.width() as f64
    }

    fn product(&mut self, a: Handle<Expr>, b: Handle<Expr>) -> Option<f64> {
        let (la, lb) = (self.of(a)?, self.of(b)?);
        Some(nonzero(la, self.mag(b)) + nonzero(lb, self.mag(a)))
    }

    fn max_of(&mut self, hs: &[Handle<Expr>]) -> Option<f64> {
        hs.iter().try_fold(0.0f64, |acc, &h| Some(acc.max(self.of(h)?)))
    }

    fn node(&mut self, h: Handle<Expr>) -> Option<f64> {
        let e = self.m.exprs[h].clone();
        // A leaf other than the site (a constant, a vector, the pixel) is exact.
        if e.operands().is_empty() {
            return Some(0.0);
        }
        match e {
            Expr::Lookup { texture, coords } => {
                (self.of(coords)? == 0.0).then(|| self.stored_at(Store::Texture(texture)))
            }
            Expr::FramebufferRead { framebuffer, channel, position } => {
                (self.of(position)? == 0.0).then(|| self.stored_at(Store::Framebuffer(framebuffer, channel)))
            }
            Expr::Interpolate { value, .. } | Expr::Swizzle { value, .. } | Expr::Convert { value, .. } => {
                self.of(value)
            }
            Expr::Unary { op: UnaryOp::Neg, value } => self.of(value),
            Expr::FatMember { texel, .. } => self.of(texel),
            Expr::Compose { components: v, .. } | Expr::Bundle(v) => self.max_of(&v),
            Expr::Binary { op, lhs, rhs } => self.binary(op, lhs, rhs),
            Expr::Combine { mode, lhs, rhs } => match mode {
                CombineMode::Modulate => self.product(lhs, rhs),
                CombineMode::Add | CombineMode::AddSigned | CombineMode::Subtract => {
                    Some(self.of(lhs)? + self.of(rhs)?)
                }
                CombineMode::Replace => self.of(lhs),
                _ => self.unless_depends(h),
            },
            Expr::Math { fun, args } => self.math(fun, &args, h),
            Expr::Select { cond, accept, reject } => {
                if self.of(cond)? != 0.0 {
                    return None; // a step: no first-order bound
                }
                let mut ops = vec![accept];
                ops.extend(reject);
                self.max_of(&ops)
            }
            _ => self.unless_depends(h),
        }
    }

    fn binary(&mut self, op: BinaryOp, a: Handle<Expr>, b: Handle<Expr>) -> Option<f64> {
        match op {
            BinaryOp::Add | BinaryOp::Sub => Some(self.of(a)? + self.of(b)?),
            BinaryOp::Mul => self.product(a, b),
            BinaryOp::Dot => Some(self.width(a).max(self.width(b)) * self.product(a, b)?),
            BinaryOp::Pow => {
                let n = match &self.m.exprs[b] {
                    Expr::Constant(c) if c.components[0] >= 1.0 => c.components[0],
                    _ => return self.unless_depends_on(&[a, b]),
                };
                Some(nonzero(self.of(a)?, n * self.mag(a).powf(n - 1.0)))
            }
            _ => self.unless_depends_on(&[a, b]),
        }
    }

    fn math(&mut self, fun: MathFunction, args: &[Handle<Expr>], h: Handle<Expr>) -> Option<f64> {
        use MathFunction::*;
        match fun {
            // 1-Lipschitz in each argument.
            Max | Min | Clamp | Saturate | Abs => self.max_of(args),
            Expand => Some(2.0 * self.of(args[0])?),
            Compress => Some(0.5 * self.of(args[0])?),
            HalfBias => self.of(args[0]),
            Length => Some(self.width(args[0]).sqrt() * self.of(args[0])?),
            Exp => Some(nonzero(self.of(args[0])?, self.m.info(args[0]).interval.hi.exp())),
            Mix => {
                // a + (b − a)·t
                let (la, lb, lt) = (self.of(args[0])?, self.of(args[1])?, self.of(args[2])?);
                let t = self.mag(args[2]);
                let spread = self.mag(args[0]) + self.mag(args[1]);
                Some(nonzero(la, 1.0 + t) + nonzero(lb, t) + nonzero(lt, spread))
            }
            _ => self.unless_depends(h),
        }
    }

    /// 0 when `h` neither reaches the site nor reads a stored error, else
    /// unknown.
    fn unless_depends(&mut self, h: Handle<Expr>) -> Option<f64> {
        let ops = self.m.operands(h);
        self.unless_depends_on(&ops)
    }

    fn unless_depends_on(&mut self, ops: &[Handle<Expr>]) -> Option<f64> {
        for &o in ops {
            if self.of(o)? != 0.0 {
                return None;
            }
        }
        Some(0.0)
    }

    fn stored_at(&self, s: Store) -> f64 {
        self.stored.get(&s).copied().unwrap_or(0.0)
    }
}

/// `l · k`, with 0 · ∞ = 0 (an exact operand of an unbounded factor).
fn nonzero(l: f64, k: f64) -> f64 {
    if l == 0.0 {
        0.0
    } else {
        l * k
    }
}

#[cfg(test)]
mod tests {
    use super::output_sensitivity;
    use crate::ir::{Expr, Handle, Module};

    fn module(source: &str) -> Module {
        let (program, diags) = crate::parser::check(source);
        assert!(diags.iter().all(|d| !d.is_error()), "{diags:?}");
        let (m, diags) = crate::ir::lower(&program);
        assert!(diags.iter().all(|d| !d.is_error()), "{diags:?}");
        m
    }

    /// The node of `m` written `text` in `source` (outer parentheses aside).
    fn at(m: &Module, source: &str, text: &str) -> Handle<Expr> {
        (0..m.exprs.len())
            .map(Handle::new)
            .find(|&h| {
                let span = m.span(h);
                let written = source.get(span.start as usize..span.end as usize).unwrap_or("");
                written == text || written.strip_prefix('(').and_then(|w| w.strip_suffix(')')) == Some(text)
            })
            .unwrap_or_else(|| panic!("no node at `{text}`"))
    }

    #[test]
    fn a_power_multiplies_an_error_of_its_base() {
        let source = "vector N : normal;\nvector H : half(0);\ntexture A : 2d rgb8 = image(\"a.png\");\n\
            C δπx ← (A δu x) * saturate((δ N s x)·(δ H s x))^16;\n";
        let m = module(source);
        // saturate(N·H) ∈ [0, 1]: d(x¹⁶)/dx ≤ 16, times the texel's ≤ 1.
        let l = output_sensitivity(&m, at(&m, source, "saturate((δ N s x)·(δ H s x))")).unwrap();
        assert!((l - 16.0).abs() < 1e-9, "{l}");
        // The texel scales a power ≤ 1.
        assert_eq!(output_sensitivity(&m, at(&m, source, "(A δu x)")), Some(1.0));
    }

    #[test]
    fn an_error_in_a_coordinate_or_a_condition_has_no_bound() {
        let source = "vector N : normal;\nvector L : light(0);\ntexture T : 1d r8 = image(\"t.png\");\n\
            C δπx ← rgb(T ((δ N s x)·(δ L s x)));\n";
        let m = module(source);
        assert_eq!(output_sensitivity(&m, at(&m, source, "(δ N s x)·(δ L s x)")), None);
        let source =
            "vector N : normal;\nvector L : light(0);\nC δπx ← rgb(((δ N s x)·(δ L s x)) > 0 ? 1 : 0);\n";
        let m = module(source);
        assert_eq!(output_sensitivity(&m, at(&m, source, "(δ N s x)·(δ L s x)")), None);
    }

    #[test]
    fn an_error_stored_in_a_texture_reaches_the_statement_reading_it() {
        let source = "texture A : 2d rgb8 = image(\"a.png\");\ntexture T : 2d rgba8;\n\
            T δu x ← rgba(0.5 * (A δu x), 1);\nC δπx ← expand((T δu x).rgb);\n";
        let m = module(source);
        // ½ stored, doubled by expand.
        assert_eq!(output_sensitivity(&m, at(&m, source, "(A δu x)")), Some(1.0));
    }
}
