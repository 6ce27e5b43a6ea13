//! GL's texture environment as the machine it is (OpenGL 1.2.1, Section
//! 3.8.9; ARB_multitexture): texture unit i combines its own texel `Ct`
//! with the colour `Cf` the unit before it left (unit 0: the primary
//! colour, clamped to [0, 1] at the vertex, Section 2.13.9), by one of the
//! profile's modes, and clamps the result. Chained multitexturing is
//! Pipeline Grammar's equation (12), `T‴ δu‴ x ⊕ (T″ δu″ x ⊕ (…))`.
//!
//! A fragment value is one pass of the environment only when it is such a
//! chain: each stage one texture and the chain so far, the start a colour
//! in [0, 1]. Counting operations instead accepted `2·T0`, `T0 − T1` and
//! `T0 − ½` as one stage each on a target whose modes compute none of them.

use crate::ir::{BinaryOp, Expr, Handle, MathFunction, Module};
use crate::parser::ast::CombineMode;

/// Why a value is no chain of texture-environment stages, at its node.
pub(super) struct NotAChain {
    pub at: Handle<Expr>,
    pub what: String,
}

/// The texture units (stages) `value` takes as a chain of the environment
/// whose modes are `modes` (GL's names, `modulate`, `add`, …).
pub(super) fn stages(module: &Module, value: Handle<Expr>, modes: &[String]) -> Result<usize, NotAChain> {
    Env { m: module, modes }.chain(value)
}

struct Env<'a> {
    m: &'a Module,
    modes: &'a [String],
}

impl Env<'_> {
    fn chain(&self, h: Handle<Expr>) -> Result<usize, NotAChain> {
        if !self.m.info(h).freq.is_sample() {
            return self.primary(h);
        }
        match &self.m.exprs[h] {
            Expr::Lookup { .. } | Expr::FramebufferRead { .. } => Ok(1),
            Expr::Convert { value, .. } => self.chain(*value),
            // The stage's own clamp: free.
            Expr::Math { fun: MathFunction::Saturate, args } => self.chain(args[0]),
            Expr::Combine { mode, lhs, rhs } => {
                self.mode(h, mode.as_str())?;
                // `Ct·Cf` and `Ct + Cf` read either way round.
                let commutes = matches!(mode, CombineMode::Modulate | CombineMode::Add);
                let before = match (self.texel(*lhs), self.texel(*rhs)) {
                    (true, _) => *rhs,
                    (false, true) if commutes => *lhs,
                    _ => return Err(self.not_one_texture(h)),
                };
                Ok(self.chain(before)? + 1)
            }
            Expr::Binary { op: BinaryOp::Mul, .. } => self.fold(h, BinaryOp::Mul, "modulate"),
            Expr::Binary { op: BinaryOp::Add, .. } => self.fold(h, BinaryOp::Add, "add"),
            Expr::Binary { op: BinaryOp::Sub, lhs, rhs } if self.texel(*lhs) => {
                self.mode(h, "subtract")?;
                Ok(self.chain(*rhs)? + 1)
            }
            Expr::Binary { op: BinaryOp::Sub, .. } | Expr::Unary { .. } => Err(NotAChain {
                at: h,
                what: "a difference or negation, which no texture-environment mode computes from the unit before and one texture"
                    .into(),
            }),
            // Selections, swizzles and compositions keep the count they had
            // (one stage per ⊕ or operation); the rest is refused before.
            _ => Ok(self.operations(h)),
        }
    }

    /// A sum or product written out, `T0·T1·δc`: every term a texture but
    /// at most one, which is the chain the textures are applied over.
    fn fold(&self, h: Handle<Expr>, op: BinaryOp, mode: &str) -> Result<usize, NotAChain> {
        self.mode(h, mode)?;
        let mut terms = Vec::new();
        self.flatten(h, op, &mut terms);
        let (texels, rest): (Vec<_>, Vec<_>) = terms.into_iter().partition(|t| self.texel(*t));
        match rest.as_slice() {
            [] => Ok(texels.len()),
            [chain] => Ok(texels.len() + self.chain(*chain)?),
            _ => Err(self.not_one_texture(h)),
        }
    }

    fn flatten(&self, h: Handle<Expr>, op: BinaryOp, out: &mut Vec<Handle<Expr>>) {
        match self.m.exprs[h] {
            Expr::Binary { op: o, lhs, rhs } if o == op && self.m.info(h).freq.is_sample() => {
                self.flatten(lhs, op, out);
                self.flatten(rhs, op, out);
            }
            _ => out.push(h),
        }
    }

    /// A texel one unit samples (through a widening to rgba).
    fn texel(&self, h: Handle<Expr>) -> bool {
        match &self.m.exprs[h] {
            Expr::Convert { value, .. } => self.texel(*value),
            Expr::Lookup { .. } | Expr::FramebufferRead { .. } => self.m.info(h).freq.is_sample(),
            _ => false,
        }
    }

    /// The chain's start, the primary colour: GL clamps it to [0, 1] at
    /// the vertex (an interpolated one is checked where it is interpolated).
    fn primary(&self, h: Handle<Expr>) -> Result<usize, NotAChain> {
        let i = self.m.info(h).interval;
        if matches!(self.m.exprs[h], Expr::Interpolate { .. }) || (i.lo >= 0.0 && i.hi <= 1.0) {
            return Ok(0);
        }
        Err(NotAChain {
            at: h,
            what: format!(
                "a colour in [{}, {}] applied as the primary colour, which GL clamps to [0, 1] (the texture environment has no scale)",
                round(i.lo),
                round(i.hi)
            ),
        })
    }

    fn mode(&self, h: Handle<Expr>, mode: &str) -> Result<(), NotAChain> {
        if self.modes.iter().any(|m| m == mode) {
            return Ok(());
        }
        Err(NotAChain {
            at: h,
            what: format!(
                "{} (the texture-environment mode `{mode}`, which the target lacks: it has {})",
                operation(mode),
                self.modes.join(", ")
            ),
        })
    }

    fn not_one_texture(&self, h: Handle<Expr>) -> NotAChain {
        NotAChain {
            at: h,
            what: "a combination of two computed colours, where each texture-environment stage combines the unit before it with one texture".into(),
        }
    }

    /// The old measure, one stage per ⊕ or operation per sample.
    fn operations(&self, h: Handle<Expr>) -> usize {
        self.m
            .reachable(&[h])
            .into_iter()
            .filter(|n| {
                self.m.info(*n).freq.is_sample()
                    && matches!(self.m.exprs[*n], Expr::Combine { .. } | Expr::Binary { .. })
            })
            .count()
    }
}

/// What a mode computes, in a message.
fn operation(mode: &str) -> &'static str {
    match mode {
        "modulate" => "a product",
        "add" => "a sum",
        "subtract" => "a difference",
        _ => "a ⊕",
    }
}

fn round(x: f64) -> String {
    if x.is_finite() {
        format!("{}", (x * 100.0).round() / 100.0)
    } else {
        "∞".into()
    }
}
