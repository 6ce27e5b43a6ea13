//! A screen pass that reads its own framebuffer other than as a blend —
//! `C xs ← (C xs)^(1/2.2)`, a tone map or a grey conversion in place — is
//! the program's meaning all the same: each pixel's new value is a
//! function of its old one (Pipeline Grammar, eq. (6): a screen pass reads
//! framebuffers as tables). Framebuffer blending computes only `C·m + s`
//! (eq. (9)), so such a pass reads a copy instead: `C° xs ← C xs` first (a
//! screen pass that reads `C` as a texture, the copy-to-texture every
//! target here has), then the statement with its reads of `C` turned into
//! reads of `C°`. A pass that blending can express is left as it is.

use rustc_hash::FxHashMap as HashMap;

use super::form;
use crate::ir::{Expr, FbChannel, Framebuffer, Frequency, Handle, Module, Statement, Table};
use crate::parser::ast::FramebufferChannel;

/// The copy statements inserted, by index (before lights are expanded),
/// with the name of the framebuffer each copies.
#[derive(Default)]
pub(super) struct Copies(Vec<(usize, String)>);

/// Rewrites every screen statement that reads its own target's colour or
/// alpha in a way no blend computes into a copy pass and the statement
/// reading the copy. Run before planning, on the planner's own module;
/// [`renumber`] then names the statements as the source numbers them.
pub(super) fn read_own_colour_through_a_copy(m: &mut Module) -> Copies {
    let mut copies = Copies::default();
    let mut i = 0;
    while i < m.statements.len() {
        let st = m.statements[i].clone();
        match through_a_copy(m, &st) {
            Some((copy, reading)) => {
                if let Table::Framebuffer { id, .. } = st.table {
                    copies.0.push((i, m.framebuffers[id as usize].name.clone()));
                }
                m.statements[i] = reading;
                m.statements.insert(i, copy);
                i += 2;
            }
            None => i += 1,
        }
    }
    copies
}

/// Each statement's source statement and name as the program numbers
/// them: a copy is its reading statement's ("statement 2 (copy of C)"),
/// the statements after a copy keep their own numbers.
pub(super) fn renumber(copies: &Copies, prepared: &mut super::Prepared) {
    if copies.0.is_empty() {
        return;
    }
    let original = |s: usize| s - copies.0.iter().filter(|(c, _)| *c < s).count();
    for (i, source) in prepared.per_light.source.iter_mut().enumerate() {
        let s = *source;
        *source = original(s);
        let Some(name) = prepared.names.get_mut(i) else { continue };
        let rest = name.trim_start_matches(|c: char| c.is_ascii_digit()).to_string();
        *name = match copies.0.iter().find(|(c, _)| *c == s) {
            Some((_, of)) => format!("{} (copy of {of})", original(s) + 1),
            None => format!("{}{rest}", original(s) + 1),
        };
    }
}

/// The copy statement and the statement reading it, when `st` is a screen
/// pass that blending cannot express only because it reads its target.
fn through_a_copy(m: &mut Module, st: &Statement) -> Option<(Statement, Statement)> {
    let Table::Framebuffer { id, channel: FbChannel::Color | FbChannel::Alpha } = st.table else {
        return None;
    };
    if st.freq != Frequency::Screen {
        return None;
    }
    let own: Vec<Handle<Expr>> = m
        .reachable(&[st.value])
        .into_iter()
        .filter(|h| {
            matches!(m.exprs[*h], Expr::FramebufferRead { framebuffer, channel: FbChannel::Color | FbChannel::Alpha, .. } if framebuffer == id)
        })
        .collect();
    // A `max`/`min` of its own colour is a blend only where the blender
    // has the MIN/MAX equations, which this pass does not know: it reads
    // the copy, as before there was that blend, on every target.
    let blended = form::classify(m, st, st.value)
        .is_ok_and(|f| !matches!(f.blend, crate::pipeline::BlendMode::Max | crate::pipeline::BlendMode::Min));
    if own.is_empty() || blended {
        return None;
    }
    let copy_id = add_copy_framebuffer(m, id);
    let mut map = HashMap::default();
    for h in own {
        let Expr::FramebufferRead { channel, position, .. } = m.exprs[h] else { continue };
        let read =
            m.intern(Expr::FramebufferRead { framebuffer: copy_id, channel, position }, m.span(h)).ok()?;
        map.insert(h, read);
    }
    let value = form::substitute(m, st.value, &map)?;
    let reading = Statement { value, ..st.clone() };
    // Still no blend (it reads another framebuffer's channel of its own
    // target, say): refused as written. The copy framebuffer stays
    // declared, unused, as nodes already name it.
    if form::classify(m, &reading, value).is_err() {
        return None;
    }
    let whole = m
        .intern(
            Expr::FramebufferRead { framebuffer: id, channel: FbChannel::Color, position: st.index },
            st.span,
        )
        .ok()?;
    let copy = Statement {
        table: Table::Framebuffer { id: copy_id, channel: FbChannel::Color },
        value: whole,
        ..st.clone()
    };
    Some((copy, reading))
}

/// A framebuffer of `of`'s colour format, named after it (`C°`, a name no
/// program can write), appended to the module.
fn add_copy_framebuffer(m: &mut Module, of: u32) -> u32 {
    let original = &m.framebuffers[of as usize];
    let colour: Vec<FramebufferChannel> = original
        .channels
        .iter()
        .copied()
        .filter(|c| !matches!(c, FramebufferChannel::Depth | FramebufferChannel::Stencil))
        .collect();
    let channels = if colour.is_empty() { vec![FramebufferChannel::Rgba8] } else { colour };
    let mut name = format!("{}°", original.name);
    while m.framebuffers.iter().any(|f| f.name == name) {
        name.push('°');
    }
    let span = original.span;
    m.framebuffers.push(Framebuffer { name, channels, span });
    (m.framebuffers.len() - 1) as u32
}
