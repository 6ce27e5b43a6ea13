//! One pass of a split and what it costs: the pieces the splitter
//! produces ([`Piece`], written to a [`Dest`] through the target's
//! [`Storage`]), the check that a value fits one pass ([`FitCheck`], and
//! why not: [`Overflow`]) and the order plans are compared in ([`Cost`]).

use std::rc::Rc;

#[cfg(doc)]
use super::clamps::{lerp_bound, signed_terms};
use crate::ir::{Expr, Handle, Interval, Module, Usage};
use crate::pipeline::BlendMode;

/// Why a value does not fit one pass.
#[derive(Clone, Debug, PartialEq)]
pub struct Overflow {
    /// What ran out, or (with `need` 1 and `have` 0) what the target lacks,
    /// or (with both 0) the whole reason, as a sentence.
    pub resource: String,
    pub need: usize,
    pub have: usize,
    /// The node most responsible (for diagnostics), if one stands out.
    pub at: Option<Handle<Expr>>,
    /// The fragment stage's own help for a refusal it explained (the
    /// combiner code generator's), for the planner's diagnostic.
    pub help: Option<String>,
}

impl std::fmt::Display for Overflow {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        if self.have == 0 && self.need == 0 {
            // A refusal that says itself (the combiner code generator's).
            write!(f, "{}", self.resource)
        } else if self.have == 0 && self.need == 1 {
            write!(f, "needs {}, which the target cannot compute in a pass", self.resource)
        } else {
            write!(f, "needs {} {}; the target has {}", self.need, self.resource, self.have)
        }
    }
}

/// Does a value fit one pass? (A profile's limits; tests may plug in others.)
pub trait FitCheck {
    fn fits(&self, module: &Module, value: Handle<Expr>) -> Result<(), Overflow>;

    /// The predicted time (ns) of `piece` as one pass on the target's cost
    /// model, on its nominal workload; 0 on a target without
    /// one, where passes and fetches decide.
    fn piece_ns(&self, _module: &Module, _piece: &Piece) -> u64 {
        0
    }

    /// The texture units computing `value` takes (a fit may remember it:
    /// the splitter costs the same pieces many times).
    fn texture_units(&self, module: &Module, value: Handle<Expr>) -> usize {
        Usage::texture_units_of(module, value)
    }
}

/// Where a piece is written.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Dest {
    /// The statement's own target.
    Main,
    /// A temporary texture (render-to-texture).
    Temp(u32),
}

/// What the target's storage does to a value between passes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Storage {
    /// Temporaries are float textures, which clamp nothing.
    pub float_temps: bool,
    /// The statement's own target is float (an `rgba16f` framebuffer on a
    /// target that has one), which clamps nothing.
    pub float_main: bool,
    /// The blender subtracts (`C ← C − s`, EXT_blend_subtract): a term
    /// below zero is taken off there ([`signed_terms`]).
    pub subtract: bool,
    /// The blender takes the larger or smaller of the framebuffer and the
    /// source (`C ← max(C, s)`, `C ← min(C, s)`: GL_MAX and GL_MIN,
    /// EXT_blend_minmax): a `max` or `min` chain splits across passes.
    pub min_max: bool,
    /// The clamps between passes are followed channel by channel
    /// ([`super::split::exact_through_clamps`]): the planner's second
    /// search of a statement whose splits its first, on the channels'
    /// hull, refused at the clamps.
    pub by_channel: bool,
}

impl Storage {
    pub(super) fn clamps(self, dest: Dest) -> bool {
        match dest {
            Dest::Main => !self.float_main,
            Dest::Temp(_) => !self.float_temps,
        }
    }
}

/// One pass of a split: `dest ← dest <blend> value`.
#[derive(Clone, Debug, PartialEq)]
pub struct Piece {
    pub blend: BlendMode,
    pub value: Handle<Expr>,
    pub dest: Dest,
    /// Whether the pass writes alpha: an rgb value split into passes writes
    /// alpha 1 once, in its first pass, and keeps it after.
    pub alpha: bool,
    /// How the split produced this piece.
    pub why: String,
    /// What the destination holds after this piece, where that is known
    /// tighter than the sum of the ranges blended into it: a `lerp`
    /// written out as `x·(1 − f) + y·f` holds what `x` and `y` hold
    /// ([`lerp_bound`]), so a factor after it is modulated exactly.
    pub holds: Option<Interval>,
}

pub type Pieces = Rc<Vec<Piece>>;

/// (predicted time in ns, passes, texture fetches): what the planner
/// minimizes, in that order — the target's cost model first,
/// ties broken by pass count. Without a cost model the time is 0 and
/// passes, then fetches, decide.
pub type Cost = (u64, usize, usize);

pub fn cost(module: &Module, fit: &dyn FitCheck, pieces: &[Piece]) -> Cost {
    pieces
        .iter()
        .fold((0, 0, 0), |c, p| add(c, (fit.piece_ns(module, p), 1, fit.texture_units(module, p.value))))
}

/// The cheapest of the splits that fit (the first on a tie). When the
/// target's cost model decided between splits it predicts differently, the
/// first pass's reason says so.
pub(super) fn fastest(fitting: Vec<(Cost, Vec<Piece>)>) -> Option<Vec<Piece>> {
    let mut best: Option<usize> = None;
    for (i, (c, _)) in fitting.iter().enumerate() {
        if best.is_none_or(|b| *c < fitting[b].0) {
            best = Some(i);
        }
    }
    let b = best?;
    let runner_up = fitting.iter().enumerate().filter(|(i, _)| *i != b).map(|(_, (c, _))| c.0).min();
    let (cost, mut pieces) = fitting.into_iter().nth(b)?;
    if let Some(next) = runner_up.filter(|&n| cost.0 > 0 && n > cost.0) {
        let why = &mut pieces[0].why;
        if why.is_empty() {
            *why = "the part rendered first".into();
        }
        *why += &format!(
            "; the cost model predicts this split the fastest of those that fit ({:.3} ms against {:.3} ms)",
            cost.0 as f64 / 1e6,
            next as f64 / 1e6
        );
    }
    Some(pieces)
}

/// Costs add componentwise.
pub fn add(a: Cost, b: Cost) -> Cost {
    (a.0 + b.0, a.1 + b.1, a.2 + b.2)
}
