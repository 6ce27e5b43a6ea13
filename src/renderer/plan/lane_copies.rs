//! Which components of the lane program's results are read ([`demanded`]),
//! and its copies forwarded to their readers ([`forward_copies`]).

use super::{Op, K};
use crate::renderer::plan::FragmentProgram;

/// Removes the ops of `ops` that only copy components — a swizzle, a
/// conversion that keeps the value, a composition — where only lane ops
/// read their result: each reader reads the copied rows instead
/// (`rows` of [`Op::Lanes`]). A scalar result that only lane ops read is
/// not splatted either: its readers read its first row in every
/// component. No arithmetic changes, so the values are the same bit for
/// bit; a copy over all 32 lanes was a loop over up to four rows, with
/// its dispatch (eight of the 31 lane ops of Kilgard's pass, and six
/// splats).
pub(super) fn forward_copies(p: &FragmentProgram, ops: &mut Vec<Op>) {
    // The slots that code other than the lane ops reads through their own rows.
    let mut direct = vec![false; p.n_slots];
    let mut mark = |s: u32| {
        if let Some(d) = direct.get_mut(s as usize) {
            *d = true;
        }
    };
    for op in ops.iter() {
        if let Op::Scalar(i) | Op::Sample(i) = *op {
            let s = &p.steps[i as usize];
            s.ops[..s.n_ops as usize].iter().for_each(|&o| mark(o));
        }
    }
    [Some(p.output), p.condition, p.depth].into_iter().flatten().for_each(mark);
    // Per slot, the row each component is read from.
    let mut alias: Vec<[u32; 4]> = (0..p.n_slots as u32).map(|s| [0, 1, 2, 3].map(|c| 4 * s + c)).collect();
    ops.retain_mut(|op| {
        let Op::Lanes { k, dst, ops, width, keep, rows } = op else { return true };
        for (row, &o) in rows.iter_mut().zip(ops.iter()) {
            if let Some(a) = alias.get(o as usize) {
                *row = *a;
            }
        }
        let d = *dst as usize;
        if direct.get(d).copied().unwrap_or(true) || !(1..=4).contains(width) {
            return true;
        }
        let w = *width as usize;
        let copied = match *k {
            K::Swizzle(pattern, len) if len as usize == w => Some(pattern.map(|c| rows[0][c as usize & 3])),
            K::Same => Some(rows[0]),
            K::Compose(ws) => {
                let mut a = [0u32; 4];
                let mut at = 0;
                for (row, &wj) in rows.iter().zip(&ws) {
                    for &from in &row[..wj.min(4) as usize] {
                        if let Some(x) = a.get_mut(at) {
                            *x = from;
                        }
                        at += 1;
                    }
                }
                (at == w).then_some(a)
            }
            _ => None,
        };
        // Components above the width that some op reads: zeros to write.
        let zeros_read = w < 4 && w > 1 && *keep >> w != 0;
        match copied {
            Some(a) if w == 1 => alias[d] = [a[0]; 4],
            Some(a) if !zeros_read => alias[d] = a,
            Some(_) => return true,
            None => {
                if w == 1 {
                    alias[d] = [4 * d as u32; 4];
                    *keep = 1;
                }
                return true;
            }
        }
        false
    });
}

/// Per slot, the components that some op of `ops` or the program's
/// outputs read (a bit each). A scalar result is splatted to four
/// components and a narrow one zeroed above its width (the canonical form
/// every kernel may read), but most scalars feed scalar ops, which read
/// only the first: the copies to components no one reads are skipped. The
/// components read are the same values either way, so the results are
/// bit for bit the same (the test of this module renders both).
pub(super) fn demanded(p: &FragmentProgram, ops: &[Op]) -> Vec<u8> {
    let mut demand = vec![0u8; p.n_slots];
    let mut read = |slot: u32, mask: u8| {
        if let Some(d) = demand.get_mut(slot as usize) {
            *d |= mask;
        }
    };
    let below = |w: u8| ((1u16 << w.min(4)) - 1) as u8;
    for op in ops {
        let i = match *op {
            Op::Lanes { k, ops, width, .. } => {
                let comps = below(width.clamp(1, 4));
                match k {
                    K::Dot(w) | K::Length(w) => ops[..2].iter().for_each(|&o| read(o, below(w))),
                    K::Cmp(_) | K::Not => ops[..2].iter().for_each(|&o| read(o, 1)),
                    K::Swizzle(pattern, len) => {
                        pattern[..len as usize].iter().for_each(|&c| read(ops[0], 1 << (c & 3)))
                    }
                    K::Select(_) => {
                        read(ops[0], 1);
                        ops[1..].iter().for_each(|&o| read(o, comps));
                    }
                    K::Compose(ws) => ops.iter().zip(ws).for_each(|(&o, w)| read(o, below(w))),
                    K::Varying(_) => {}
                    K::Add | K::Sub | K::Mul | K::Div | K::Neg | K::Max | K::Min | K::Clamp | K::Saturate => {
                        ops.iter().for_each(|&o| read(o, comps))
                    }
                    K::Expand | K::Compress | K::HalfBias | K::AddSigned | K::Abs | K::Sqrt | K::Rsqrt => {
                        ops.iter().for_each(|&o| read(o, comps))
                    }
                    K::Floor
                    | K::Fract
                    | K::Step
                    | K::Mix
                    | K::Same
                    | K::RgbToRgba
                    | K::PowInt(_)
                    | K::Pow => ops.iter().for_each(|&o| read(o, comps)),
                    K::Normalize(_) => ops.iter().for_each(|&o| read(o, 0b1111)),
                }
                continue;
            }
            Op::Scalar(i) | Op::Sample(i) => i,
        };
        let s = &p.steps[i as usize];
        s.ops[..s.n_ops as usize].iter().for_each(|&o| read(o, 0b1111));
    }
    for slot in [Some(p.output), p.condition, p.depth].into_iter().flatten() {
        read(slot, 0b1111);
    }
    demand
}
