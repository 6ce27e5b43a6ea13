//! Stencil writes other than the shadow volume's count (`form::stencil_write`):
//! a constant, and a condition set or cleared through GL's per-fragment
//! operations (OpenGL 1.2.1, Section 4.1: the alpha test drops a fragment
//! before the stencil test, so a dropped fragment leaves the stencil as it
//! was; `glStencilOp(…, GL_REPLACE)` writes the reference where it passes).
//!
//! | statement | pass |
//! |---|---|
//! | `σ C δπx ← k` (an integer 0-255) | stencil `REPLACE` with reference k (`ZERO` for 0) |
//! | `σ C δπx ← (σ C δπx) OR c` | fragments where c ≠ 0 kept (the rest dropped), `REPLACE` 1 |
//! | `σ C δπx ← (σ C δπx) AND c` | fragments where c = 0 kept, `ZERO` |
//! | `σ C δπx ← c` | as `σ OR c`, where the stencil is known clear and an earlier statement drew the geometry |
//!
//! Each is one pass with no colour write, depth tested as any statement
//! drawing its geometry (the first writes depth, later ones test `Equal`), so
//! that the visible fragment decides, as it does for the colour channels
//! (Pipeline Grammar, Section 3.5, marks the stencil so).

use crate::diag::Diagnostic;
use crate::ir::{BinaryOp, Expr, FbChannel, Handle, Module, Statement, Table, Ty, UnaryOp};
use crate::pipeline::{CompareFunc, StencilOp, StencilState};

use super::form::{other_operand, self_read};
use super::Form;
use crate::pipeline::BlendMode;

/// The form of a stencil write this module knows (table above); `None` for
/// another value.
pub(super) fn stencil_form(m: &mut Module, st: &Statement, value: Handle<Expr>) -> Option<Form> {
    if let Some(k) = stencil_constant(m, value) {
        let op = if k == 0 { StencilOp::Zero } else { StencilOp::Replace };
        return Some(form(value, None, k, op));
    }
    let own = self_read(m, st, FbChannel::Stencil);
    match m.exprs[value] {
        Expr::Binary { op: BinaryOp::Or, lhs, rhs } => {
            let c = other_operand(lhs, rhs, own?)?;
            condition(m, c, own).then(|| form(value, Some(c), 1, StencilOp::Replace))
        }
        Expr::Binary { op: BinaryOp::And, lhs, rhs } => {
            let c = other_operand(lhs, rhs, own?)?;
            if !condition(m, c, own) {
                return None;
            }
            let not_c = m.intern(Expr::Unary { op: UnaryOp::Not, value: c }, m.span(c)).ok()?;
            Some(form(value, Some(not_c), 0, StencilOp::Zero))
        }
        _ if condition(m, value, own) && clear_and_drawn(m, st) => {
            Some(form(value, Some(value), 1, StencilOp::Replace))
        }
        _ => None,
    }
}

/// The located refusal of a stencil write no form above takes, with the
/// forms that plan.
pub(super) fn unsupported(st: &Statement) -> Diagnostic {
    Diagnostic::error(
        "unsupported-stencil",
        "the stencil cannot be written so: it holds an integer 0-255, which GL writes through the stencil operation (a constant, set or cleared where a condition holds, or a count), not a value computed per fragment",
        st.span,
        "this stencil write",
    )
    .with_help("write a constant (`σ C δπx ← 1;`), set or clear it where a condition holds (`σ C δπx ← (σ C δπx) OR c;`, `… AND c;`), or count a shadow volume (`σ C δπx ← (σ C δπx) OR ((z δπx′) > (z C δπx′));`); to write a condition `σ C δπx ← c`, clear it first (`σ C δπx ← 0;`) and then `σ C δπx ← (σ C δπx) OR c;`")
}

fn form(value: Handle<Expr>, condition: Option<Handle<Expr>>, reference: u8, op: StencilOp) -> Form {
    Form {
        blend: BlendMode::Replace,
        value,
        condition,
        stencil: Some(StencilState {
            enabled: true,
            func: CompareFunc::Always,
            reference,
            pass: op,
            ..StencilState::DISABLED
        }),
        depth: None,
        channels: "stencil",
        then_add: None,
        drawn_at: None,
    }
}

/// An integer constant the 8-bit stencil holds.
fn stencil_constant(m: &Module, h: Handle<Expr>) -> Option<u8> {
    let Expr::Constant(k) = &m.exprs[h] else { return None };
    let [v] = k.values()[..] else { return None };
    (v.fract() == 0.0 && (0.0..=255.0).contains(&v)).then_some(v as u8)
}

/// A computed scalar (not a constant) that does not read the stencil being written: the
/// fragment is kept where it is not zero (what `c ? a` drops elsewhere).
fn condition(m: &Module, c: Handle<Expr>, own: Option<Handle<Expr>>) -> bool {
    !matches!(m.exprs[c], Expr::Constant(_))
        && m.info(c).ty == Ty::Scalar
        && !own.is_some_and(|own| super::split::depends_on(m, c, own))
}

/// Whether, before `st`, no statement writes the stencil of `st`'s
/// framebuffer (it is clear, as the frame starts) and one draws `st`'s
/// geometry into that framebuffer (so `st` tests `Equal` and only the
/// visible fragment writes): then setting where the condition holds is
/// writing the condition.
fn clear_and_drawn(m: &Module, st: &Statement) -> bool {
    let Table::Framebuffer { id, .. } = st.table else { return false };
    let mut drawn = false;
    for s in &m.statements {
        if s.span == st.span {
            return drawn;
        }
        if matches!(s.table, Table::Framebuffer { id: f, channel: FbChannel::Stencil } if f == id) {
            return false;
        }
        drawn |= s.table.depth_target() == st.table.depth_target() && s.index == st.index;
    }
    false
}
