//! Affine decomposition: writing a value `e` as `X·m + s` where neither `m`
//! nor `s` depends on the sub-value `X`. This is what framebuffer blending
//! can do with a value already in the framebuffer (Pipeline Grammar, eq. (9):
//! `C ← C ⊕ …`): if `X` is rendered first, `e` is reached by modulating by
//! `m` (GL_DST_COLOR, GL_ZERO) and adding `s` (GL_ONE, GL_ONE) — or by one
//! pass when `s = 0`, `m = 1`, or `(m, s) = (1 − a, c·a)` (alpha blending).
//!
//! The ⊕ modes follow the OpenGL 1.2.1 texture environment with the left
//! operand the texture (Ct, At) applied over the right one (Cf, Af), as in
//! chained multitexturing (Pipeline Grammar, eq. (12)):
//! - decal: rgb = Cf·(1 − At) + Ct·At, alpha = Af (At = 1 for an rgb texture);
//! - blend: rgb = Cf·(1 − Ct) + Cc·Ct with the default environment colour
//!   Cc = 0, alpha = Af·At.
//!
//! Both are affine in the incoming colour Cf, not in the texture.

use rustc_hash::FxHashMap as HashMap;

use crate::ir::{BinaryOp, Constant, Expr, Handle, Module, Ty, UnaryOp};
use crate::parser::ast::CombineMode;
use crate::span::Span;

/// Builds IR nodes for the planner; every builder returns `None` when the
/// node would be ill-typed (the caller then gives up that decomposition).
pub struct Builder<'m> {
    pub module: &'m mut Module,
}

impl Builder<'_> {
    /// The node `e`, interned (an equal node is the same node); `None` when the module is full.
    pub fn node(&mut self, e: Expr) -> Option<Handle<Expr>> {
        self.module.intern(e, Span::DETACHED).ok()
    }
    /// The constant `v` of type `ty`, splatted.
    pub fn constant(&mut self, ty: Ty, v: f64) -> Option<Handle<Expr>> {
        let w = ty.width().min(4);
        self.node(Expr::Constant(Constant::new(ty, &vec![v; w])))
    }
    /// The type of `h`.
    pub fn ty(&self, h: Handle<Expr>) -> Ty {
        self.module.info(h).ty
    }
    /// `lhs op rhs`, with the algebraic identities (x + 0, x − 0, x·1, x·0) applied, so that split
    /// passes do no dead work.
    pub fn binary(&mut self, op: BinaryOp, lhs: Handle<Expr>, rhs: Handle<Expr>) -> Option<Handle<Expr>> {
        // Algebraic identities keep split passes free of dead work.
        let m = &*self.module;
        // (A scalar stands for itself broadcast: `0 + s` may stay the scalar `s`.)
        let keeps = |x: Handle<Expr>| self.ty(x) == Ty::Scalar || Some(self.ty(x)) == self.join_ty(lhs, rhs);
        match op {
            BinaryOp::Add if m.is_constant(lhs, 0.0) && keeps(rhs) => return Some(rhs),
            BinaryOp::Add | BinaryOp::Sub if m.is_constant(rhs, 0.0) && keeps(lhs) => return Some(lhs),
            BinaryOp::Mul if m.is_constant(lhs, 1.0) && self.ty(rhs) == self.join_ty(lhs, rhs)? => {
                return Some(rhs)
            }
            BinaryOp::Mul if m.is_constant(rhs, 1.0) && self.ty(lhs) == self.join_ty(lhs, rhs)? => {
                return Some(lhs)
            }
            BinaryOp::Mul if m.is_constant(lhs, 0.0) || m.is_constant(rhs, 0.0) => {
                let ty = self.join_ty(lhs, rhs)?;
                return self.constant(ty, 0.0);
            }
            _ => {}
        }
        self.node(Expr::Binary { op, lhs, rhs })
    }
    fn join_ty(&self, a: Handle<Expr>, b: Handle<Expr>) -> Option<Ty> {
        crate::ir::valid::unify(self.ty(a), self.ty(b))
    }
    /// `a + b` (see [`Builder::binary`]).
    pub fn add(&mut self, a: Handle<Expr>, b: Handle<Expr>) -> Option<Handle<Expr>> {
        self.binary(BinaryOp::Add, a, b)
    }
    /// `a · b` (see [`Builder::binary`]).
    pub fn mul(&mut self, a: Handle<Expr>, b: Handle<Expr>) -> Option<Handle<Expr>> {
        self.binary(BinaryOp::Mul, a, b)
    }
    /// `−a`.
    pub fn neg(&mut self, a: Handle<Expr>) -> Option<Handle<Expr>> {
        if self.module.is_constant(a, 0.0) {
            return Some(a);
        }
        self.node(Expr::Unary { op: UnaryOp::Neg, value: a })
    }
    /// `1 − a`: the inverted mapping of the combiners and the blend factors.
    pub fn one_minus(&mut self, a: Handle<Expr>) -> Option<Handle<Expr>> {
        let one = self.constant(Ty::Scalar, 1.0)?;
        self.binary(BinaryOp::Sub, one, a)
    }
    /// Component `i` of `h` as a scalar.
    pub fn component(&mut self, h: Handle<Expr>, i: u8) -> Option<Handle<Expr>> {
        if self.ty(h) == Ty::Scalar {
            return Some(h);
        }
        self.node(Expr::Swizzle { value: h, pattern: [i, 0, 0, 0], len: 1, ty: Ty::Scalar })
    }
    /// The alpha of a colour (1 for an rgb value).
    pub fn alpha(&mut self, h: Handle<Expr>) -> Option<Handle<Expr>> {
        match self.ty(h) {
            Ty::Rgba => self.component(h, 3),
            Ty::Scalar => Some(h),
            _ => self.constant(Ty::Scalar, 1.0),
        }
    }
    /// The RGB of `h` (`h` itself when it has no alpha).
    pub fn rgb(&mut self, h: Handle<Expr>) -> Option<Handle<Expr>> {
        match (self.ty(h), &self.module.exprs[h]) {
            (Ty::Rgba, Expr::Constant(c)) => {
                let c = Constant::new(Ty::Rgb, &c.values()[..3]);
                self.node(Expr::Constant(c))
            }
            (Ty::Rgba, _) => {
                self.node(Expr::Swizzle { value: h, pattern: [0, 1, 2, 0], len: 3, ty: Ty::Rgb })
            }
            _ => Some(h),
        }
    }
    /// A value of type `ty` (rgb or rgba) whose colour channels are `c` and
    /// whose alpha is `a`.
    pub fn color(&mut self, ty: Ty, c: Handle<Expr>, a: Handle<Expr>) -> Option<Handle<Expr>> {
        let c3 =
            if self.ty(c) == Ty::Scalar { self.node(Expr::Convert { value: c, to: Ty::Rgb })? } else { c };
        match ty {
            Ty::Rgba => self.node(Expr::Compose { ty: Ty::Rgba, components: vec![c3, a] }),
            Ty::Rgb => Some(c3),
            _ => Some(c),
        }
    }
}

/// Whether `h` depends on `x`.
pub fn contains(
    module: &Module,
    h: Handle<Expr>,
    x: Handle<Expr>,
    memo: &mut HashMap<Handle<Expr>, bool>,
) -> bool {
    if h == x {
        return true;
    }
    if h < x {
        return false; // operands precede users
    }
    if let Some(&c) = memo.get(&h) {
        return c;
    }
    let mut c = false;
    module.exprs[h].visit_operands(|o| c = c || contains(module, o, x, memo));
    memo.insert(h, c);
    c
}

/// `e = X·m + s`, with `m` and `s` free of `x`; `None` when `e` is not affine
/// in `x` (a product of two terms with `x`, a function of `x`, `x` used as a
/// texture over something else, …).
pub fn affine(b: &mut Builder, e: Handle<Expr>, x: Handle<Expr>) -> Option<(Handle<Expr>, Handle<Expr>)> {
    let mut memo = HashMap::default();
    let mut cache = HashMap::default();
    decompose(b, e, x, &mut memo, &mut cache)
}

type Pair = (Handle<Expr>, Handle<Expr>);

fn decompose(
    b: &mut Builder,
    e: Handle<Expr>,
    x: Handle<Expr>,
    memo: &mut HashMap<Handle<Expr>, bool>,
    cache: &mut HashMap<Handle<Expr>, Option<Pair>>,
) -> Option<Pair> {
    if let Some(r) = cache.get(&e) {
        return *r;
    }
    let ty = b.ty(e);
    let r = if e == x {
        Some((b.constant(Ty::Scalar, 1.0)?, b.constant(ty, 0.0)?))
    } else if !contains(b.module, e, x, memo) {
        Some((b.constant(Ty::Scalar, 0.0)?, e))
    } else {
        let node = b.module.exprs[e].clone();
        match node {
            Expr::Binary { op: op @ (BinaryOp::Add | BinaryOp::Sub), lhs, rhs } => {
                let (ml, sl) = decompose(b, lhs, x, memo, cache)?;
                let (mr, sr) = decompose(b, rhs, x, memo, cache)?;
                Some((b.binary(op, ml, mr)?, b.binary(op, sl, sr)?))
            }
            Expr::Combine { mode: mode @ (CombineMode::Add | CombineMode::Subtract), lhs, rhs } => {
                let op = if mode == CombineMode::Add { BinaryOp::Add } else { BinaryOp::Sub };
                let (ml, sl) = decompose(b, lhs, x, memo, cache)?;
                let (mr, sr) = decompose(b, rhs, x, memo, cache)?;
                Some((b.binary(op, ml, mr)?, b.binary(op, sl, sr)?))
            }
            Expr::Binary { op: BinaryOp::Mul, lhs, rhs }
            | Expr::Combine { mode: CombineMode::Modulate, lhs, rhs } => {
                let (inner, k) = match (contains(b.module, lhs, x, memo), contains(b.module, rhs, x, memo)) {
                    (true, false) => (lhs, rhs),
                    (false, true) => (rhs, lhs),
                    _ => return None,
                };
                let (m, s) = decompose(b, inner, x, memo, cache)?;
                Some((b.mul(m, k)?, b.mul(s, k)?))
            }
            Expr::Binary { op: BinaryOp::Div, lhs, rhs } if !contains(b.module, rhs, x, memo) => {
                // `(C + T)/2`: the SNES's halved colour math.
                let (m, s) = decompose(b, lhs, x, memo, cache)?;
                Some((b.binary(BinaryOp::Div, m, rhs)?, b.binary(BinaryOp::Div, s, rhs)?))
            }
            Expr::Unary { op: UnaryOp::Neg, value } => {
                let (m, s) = decompose(b, value, x, memo, cache)?;
                Some((b.neg(m)?, b.neg(s)?))
            }
            Expr::Convert { value, to } if b.ty(value) == Ty::Scalar || to == Ty::Rgb => {
                // A splat keeps affinity; the coefficient stays a scalar.
                let (m, s) = decompose(b, value, x, memo, cache)?;
                Some((m, b.node(Expr::Convert { value: s, to })?))
            }
            Expr::Swizzle { value, pattern: [0, 1, 2, _], len: 3, ty: Ty::Rgb }
                if b.ty(value) == Ty::Rgba =>
            {
                // `(X·m + s).rgb` is `X.rgb·m.rgb + s.rgb`: the colour of a
                // framebuffer read (`C δπx.rgb`), as alpha blending's
                // `(Cs − Cd)·As + Cd` writes it.
                let (m, s) = decompose(b, value, x, memo, cache)?;
                Some((b.rgb(m)?, b.rgb(s)?))
            }
            Expr::Convert { value, to: Ty::Rgba } if matches!(b.ty(value), Ty::Rgb | Ty::Vec3) => {
                // `rgba(X·m + s, 1)`: X written with alpha 1, modulated by
                // `(m, 1)`, `(s, 0)` added — `(diffuse + specular) ⊕ decal`
                // distributed over its terms, each in [0, 1] between passes.
                let (m, s) = decompose(b, value, x, memo, cache)?;
                let (one, zero) = (b.constant(Ty::Scalar, 1.0)?, b.constant(Ty::Scalar, 0.0)?);
                Some((b.color(Ty::Rgba, m, one)?, b.color(Ty::Rgba, s, zero)?))
            }
            Expr::Combine {
                mode: mode @ (CombineMode::Decal | CombineMode::Blend),
                lhs: tex,
                rhs: incoming,
            } if !contains(b.module, tex, x, memo) => {
                let (m, s) = decompose(b, incoming, x, memo, cache)?;
                over_incoming(b, ty, mode, tex, (m, s))
            }
            _ => None,
        }
    };
    cache.insert(e, r);
    r
}

/// `tex ⊕[mode] (X·m + s)` for a decal or blend `mode` as `X·(m·k) +
/// (s·k + c)`: the environment is `Cf·k + c` per channel in the incoming
/// colour (the module's doc).
fn over_incoming(
    b: &mut Builder,
    ty: Ty,
    mode: CombineMode,
    tex: Handle<Expr>,
    (m, s): Pair,
) -> Option<Pair> {
    let at = b.alpha(tex)?;
    let one = b.constant(Ty::Scalar, 1.0)?;
    // Result = Cf·k + c, per channel.
    let (k, c) = if mode == CombineMode::Decal {
        let k_rgb = b.one_minus(at)?;
        let k = b.color(ty, k_rgb, one)?;
        let ct = b.rgb(tex)?;
        let c_rgb = b.mul(ct, at)?;
        let zero = b.constant(Ty::Scalar, 0.0)?;
        (k, b.color(ty, c_rgb, zero)?)
    } else {
        let ct = b.rgb(tex)?;
        let k_rgb = b.one_minus(ct)?;
        (b.color(ty, k_rgb, at)?, b.constant(ty, 0.0)?)
    };
    let mk = b.mul(m, k)?;
    let sk = b.mul(s, k)?;
    Some((mk, b.add(sk, c)?))
}
