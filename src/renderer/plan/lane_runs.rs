//! Straight runs of the lane program's element-wise ops fused into one
//! pass over the lanes ([`fuse_runs`], [`run_links`]).

use super::{canonical, power_lanes, Lanes, Op, K};
use crate::renderer::BATCH;

/// One op of a fused run ([`Run`]): the arithmetic, per operand and
/// component the register row it reads, which operand is the run's value
/// so far (`acc`; [`NO_ACC`] for the run's first op, which reads all its
/// operands from the registers), and whether the result is written to
/// its registers (`store`: some op after the run reads it).
#[derive(Clone, Copy, Debug)]
pub(super) struct Link {
    k: K,
    rows: [[u32; 4]; 4],
    acc: u8,
    dst: u32,
    width: u8,
    keep: u8,
    store: bool,
}

/// `acc` of a run's first op.
const NO_ACC: u8 = 4;

/// Consecutive element-wise ops of one width, each reading the one
/// before it ([`fuse_runs`]).
#[derive(Clone, Debug)]
pub(super) struct Run {
    comps: usize,
    links: Vec<Link>,
}

/// Whether an op of kind `k` can be a link of a run: computed component
/// by component, one formula per lane, without discarding.
fn linkable(k: K) -> bool {
    matches!(
        k,
        K::Add
            | K::Sub
            | K::Mul
            | K::Div
            | K::Neg
            | K::Max
            | K::Min
            | K::Clamp
            | K::Saturate
            | K::Expand
            | K::Compress
            | K::HalfBias
            | K::AddSigned
            | K::Abs
            | K::Sqrt
            | K::Rsqrt
            | K::Floor
            | K::Fract
            | K::Step
            | K::Mix
            | K::PowInt(_)
            | K::Select(true)
    )
}

/// The operands an op of kind `k` reads (of a [`linkable`] kind).
fn arity(k: K) -> usize {
    match k {
        K::Clamp | K::Mix | K::Select(_) => 3,
        K::Add | K::Sub | K::Mul | K::Div | K::Max | K::Min | K::AddSigned | K::Step => 2,
        _ => 1,
    }
}

/// Replaces each straight run of [`linkable`] lane ops in `ops` — at
/// least two, one after the other, of one width, each reading the result
/// of the one before it in one operand and no other result of the run —
/// by one [`Op::Run`]: its ops are computed component by component over
/// the lanes, the value so far kept in a local (vector registers) instead
/// of written to its registers and read back, and a result written only
/// where an op after the run, or other code, reads it (`direct`: the
/// slots read by code other than the lane ops, [`super::forward_copies`]).
/// The same operations in the same order on the same values: the same
/// results bit for bit.
pub(super) fn fuse_runs(ops: &mut Vec<Op>, direct: &[bool]) -> Vec<Run> {
    let slot_of = |row: u32| (row / 4) as usize;
    // Per slot, the operands (op and operand) that read one of its rows.
    let mut reads: Vec<Vec<(usize, usize)>> = vec![Vec::new(); direct.len()];
    for (i, op) in ops.iter().enumerate() {
        if let Op::Lanes { ops: o, rows, .. } = op {
            for (j, row) in rows.iter().enumerate().filter(|&(j, _)| o[j] != u32::MAX) {
                let mut slots: Vec<usize> = row.iter().map(|&r| slot_of(r)).collect();
                slots.dedup();
                for s in slots {
                    if let Some(x) = reads.get_mut(s) {
                        x.push((i, j));
                    }
                }
            }
        }
    }
    let mut runs = Vec::new();
    let mut out = Vec::with_capacity(ops.len());
    let mut i = 0;
    while i < ops.len() {
        let mut end = i + 1;
        if let Op::Lanes { k, width, dst, .. } = ops[i] {
            let mut dsts = vec![dst as usize];
            while let Some(&Op::Lanes { k: kn, width: wn, rows, ops: on, dst: dn, .. }) = ops.get(end) {
                let prev = dsts[dsts.len() - 1] as u32;
                let w = wn as usize;
                let own = |row: &[u32; 4]| (0..w).all(|c| row[c] == 4 * prev + c as u32);
                let acc = (0..arity(kn)).filter(|&j| on[j] != u32::MAX && own(&rows[j])).collect::<Vec<_>>();
                // No other operand reads a result of the run.
                let clean = (0..arity(kn))
                    .filter(|j| !acc.contains(j))
                    .all(|j| rows[j].iter().all(|&r| !dsts.contains(&slot_of(r))));
                if !(linkable(k)
                    && linkable(kn)
                    && wn == width
                    && (1..=4).contains(&wn)
                    && acc.len() == 1
                    && clean)
                {
                    break;
                }
                dsts.push(dn as usize);
                end += 1;
            }
        }
        if end - i < 2 {
            out.push(ops[i]);
            i += 1;
            continue;
        }
        let mut links = Vec::with_capacity(end - i);
        for at in i..end {
            let Op::Lanes { k, dst, width, keep, rows, .. } = ops[at] else { continue };
            let acc = match links.last() {
                Some(&Link { dst: prev, .. }) => {
                    (0..arity(k)).find(|&j| rows[j][0] == 4 * prev).map_or(NO_ACC, |j| j as u8)
                }
                None => NO_ACC,
            };
            // Read by an operand other than the next link's value so far.
            let next_acc = |&(op, j): &(usize, usize)| {
                op == at + 1 && at + 1 < end && {
                    let Op::Lanes { rows, .. } = ops[at + 1] else { return false };
                    rows[j][0] == 4 * dst
                }
            };
            let d = dst as usize;
            let store = direct.get(d).copied().unwrap_or(true)
                || at + 1 == end
                || reads.get(d).is_some_and(|r| r.iter().any(|x| !next_acc(x)));
            links.push(Link { k, rows, acc, dst, width, keep, store });
        }
        let comps = links.first().map_or(1, |l: &Link| l.width.clamp(1, 4) as usize);
        out.push(Op::Run(runs.len() as u32));
        runs.push(Run { comps, links });
        i = end;
    }
    *ops = out;
    runs
}

/// The ops of `run` over the [`BATCH`] lanes of the registers `r`:
/// component by component, each op's formula (those of
/// `super::componentwise`, in the same order) with the value so far in a
/// local; results written where [`Link::store`] says, then made canonical.
// Indexed loops over several lane arrays at once are the form that vectorises.
#[allow(clippy::needless_range_loop)]
#[inline(always)]
pub(super) fn run_links(run: &Run, r: &mut [Lanes]) {
    for c in 0..run.comps.min(4) {
        let mut acc = [0.0f32; BATCH];
        for l in &run.links {
            let v = {
                // A selection's condition is its first component in every component.
                let first = matches!(l.k, K::Select(_));
                let x = |j: usize| -> &Lanes {
                    if j == l.acc as usize {
                        &acc
                    } else {
                        &r[l.rows[j][if first && j == 0 { 0 } else { c }] as usize]
                    }
                };
                link_value(l.k, x)
            };
            acc = v;
            if l.store {
                r[l.dst as usize * 4 + c] = acc;
            }
        }
    }
    for l in run.links.iter().filter(|l| l.store) {
        let d = l.dst as usize * 4;
        canonical(&mut r[d..d + 4], l.width, l.keep);
    }
}

/// One link's formula over the lanes; `x(j)`: operand `j`'s component.
#[allow(clippy::needless_range_loop)]
#[inline(always)]
fn link_value<'a>(k: K, x: impl Fn(usize) -> &'a Lanes) -> Lanes {
    let mut o = [0.0f32; BATCH];
    macro_rules! each {
        (|$i:ident| $e:expr) => {
            for $i in 0..BATCH {
                o[$i] = $e;
            }
        };
    }
    macro_rules! un {
        (|$a:ident, $i:ident| $e:expr) => {{
            let $a = x(0);
            each!(|$i| $e)
        }};
    }
    macro_rules! bin {
        (|$a:ident, $b:ident, $i:ident| $e:expr) => {{
            let ($a, $b) = (x(0), x(1));
            each!(|$i| $e)
        }};
    }
    macro_rules! tri {
        (|$a:ident, $b:ident, $c:ident, $i:ident| $e:expr) => {{
            let ($a, $b, $c) = (x(0), x(1), x(2));
            each!(|$i| $e)
        }};
    }
    match k {
        K::Add => bin!(|a, b, i| a[i] + b[i]),
        K::Sub => bin!(|a, b, i| a[i] - b[i]),
        K::Mul => bin!(|a, b, i| a[i] * b[i]),
        K::Div => bin!(|a, b, i| a[i] / b[i]),
        K::Neg => un!(|a, i| -a[i]),
        K::Max => bin!(|a, b, i| a[i].max(b[i])),
        K::Min => bin!(|a, b, i| a[i].min(b[i])),
        K::Clamp => tri!(|a, b, cc, i| a[i].max(b[i]).min(cc[i])),
        K::Saturate => un!(|a, i| a[i].clamp(0.0, 1.0)),
        K::Expand => un!(|a, i| 2.0 * a[i] - 1.0),
        K::Compress => un!(|a, i| (a[i] + 1.0) / 2.0),
        K::HalfBias => un!(|a, i| a[i] - 0.5),
        K::AddSigned => bin!(|a, b, i| a[i] + b[i] - 0.5),
        K::Abs => un!(|a, i| a[i].abs()),
        K::Sqrt => un!(|a, i| a[i].sqrt()),
        K::Rsqrt => un!(|a, i| 1.0 / a[i].sqrt()),
        K::Floor => un!(|a, i| a[i].floor()),
        K::Fract => un!(|a, i| a[i] - a[i].floor()),
        K::Step => bin!(|a, b, i| if b[i] < a[i] { 0.0 } else { 1.0 }),
        K::Mix => tri!(|a, b, cc, i| a[i] * (1.0 - cc[i]) + b[i] * cc[i]),
        K::PowInt(e) => return power_lanes(x(0), e),
        K::Select(_) => tri!(|cond, a, b, i| if cond[i] != 0.0 { a[i] } else { b[i] }),
        _ => {}
    }
    o
}

#[cfg(test)]
impl Run {
    /// The ops fused.
    pub(super) fn len(&self) -> usize {
        self.links.len()
    }
}
