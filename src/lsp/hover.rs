//! Hover: what a name is, and for the value under the cursor its type,
//! computation frequency (Pipeline Grammar, Section 3: where δ stands decides per
//! vertex or per fragment), value range, and where it lands on the
//! document's target — the pass, the texture unit of a lookup, the
//! combiner setup (Kilgard 2000, §4.2) or the WGSL stage.

use std::fmt::Write as _;

use super::documents::Document;
use super::index;
use crate::backends::combiners::codegen::Placement;
use crate::ir::{Expr, Frequency, Handle, Interval, Module};
use crate::parser::ast;
use crate::pipeline::Planned;
use crate::span::Span;

/// The hover text (Markdown) at `offset`, and the span it is about.
pub fn hover(doc: &Document, offset: usize) -> Option<(String, Span)> {
    let a = &doc.analysis;
    let mut text = String::new();
    let mut span = None;
    let occ = index::occurrences(&a.program);
    let mut let_value = None;
    if let Some(o) = index::at(&occ, offset) {
        let_value = o.decl.and_then(|d| let_value_span(&a.program, d));
        let what = o.entity.map_or("unknown name", |e| e.describe());
        let _ = write!(text, "**`{}`** — {what}", o.key);
        if let Some(d) = o.decl.filter(|d| *d != o.span) {
            let lc = a.file.line_index().line_col(&a.file.text, d.start as usize);
            let _ = write!(text, " (declared at line {}:{})", lc.line, lc.col);
        }
        text.push('\n');
        span = Some(o.span);
    }
    let module = a.planned.as_ref().map(|p| &p.module).or(a.module.as_ref());
    let node = |m: &Module| match let_value {
        // A `let` is lowered once, where it is declared: its value's node.
        Some(v) => m.exprs.arena().iter().map(|(h, _)| h).find(|&h| m.span(h) == v),
        None => node_at(m, offset),
    };
    if let Some((h, m)) = module.and_then(|m| node(m).map(|h| (h, m))) {
        let s = m.span(h);
        let source = a.file.text.get(s.range()).unwrap_or("").trim();
        if !text.is_empty() {
            text.push('\n');
        }
        let _ = writeln!(text, "`{}`", short(source));
        let info = m.info(h);
        let _ = writeln!(
            text,
            "\n- type: {}\n- frequency: {}\n- value range: {}",
            info.ty.name(),
            info.freq.name(),
            interval(info.interval)
        );
        match &a.planned {
            Some(p) => {
                text.push_str(&placement(p, h, &a.target));
                let lc = a.file.line_index().line_col(&a.file.text, s.start as usize);
                text.push_str(&approximations(p, &format!("{}:{}", lc.line, lc.col)));
            }
            None => {
                let _ = writeln!(text, "- target {}: not planned (see the diagnostics)", a.target);
            }
        }
        span = span.or(Some(s));
    }
    span.map(|s| (text, s))
}

/// The value span of the `let` (global or in a shader block) declared at `decl`.
fn let_value_span(program: &ast::Program, decl: Span) -> Option<Span> {
    program.items.iter().find_map(|item| match &item.kind {
        ast::ItemKind::Let(l) if l.name.span == decl => Some(l.value.span),
        ast::ItemKind::Shader(s) => s.lets.iter().find(|l| l.name.span == decl).map(|l| l.value.span),
        _ => None,
    })
}

/// The smallest IR node whose source span holds `offset`.
fn node_at(m: &Module, offset: usize) -> Option<Handle<Expr>> {
    let o = offset as u32;
    m.exprs
        .arena()
        .iter()
        .map(|(h, _)| (h, m.span(h)))
        .filter(|(_, s)| *s != Span::DETACHED && s.start <= o && o < s.end)
        .min_by_key(|(h, s)| (s.len(), std::cmp::Reverse(h.index())))
        .map(|(h, _)| h)
}

fn short(source: &str) -> String {
    let one_line: String = source.split_whitespace().collect::<Vec<_>>().join(" ");
    if one_line.chars().count() > 60 {
        format!("{}…", one_line.chars().take(60).collect::<String>())
    } else {
        one_line
    }
}

fn bound(v: f64) -> String {
    if v == f64::INFINITY {
        "∞".into()
    } else if v == f64::NEG_INFINITY {
        "−∞".into()
    } else {
        format!("{}", (v * 1e4).round() / 1e4)
    }
}

fn interval(i: Interval) -> String {
    format!("[{}, {}]", bound(i.lo), bound(i.hi))
}

/// Where `h` lands in the plan: each pass that computes it, the texture
/// unit of a lookup, and what the target runs there.
pub fn placement(p: &Planned, h: Handle<Expr>, target: &str) -> String {
    let mut out = String::new();
    let m = &p.module;
    let combiners = p.combiners.is_some();
    for (k, pass) in p.plan.passes.iter().enumerate() {
        let mut roots: Vec<Handle<Expr>> = vec![p.handle(pass.fragment.output)];
        roots.extend(pass.fragment.condition.map(|c| p.handle(c)));
        roots.extend(pass.vertex.interpolants.iter().map(|&i| p.handle(i)));
        if !m.reachable(&roots).contains(&h) {
            continue;
        }
        let _ = write!(out, "- {target}, pass {}", k + 1);
        if let Some(t) = pass.textures.iter().find(|t| p.handle(t.lookup) == h) {
            let _ = write!(out, ": texture unit {} (`{}`)", t.unit, t.texture);
        }
        let stage = m.info(h).freq;
        if pass.baked {
            out.push_str(": baked by the compiler into a table");
        } else if combiners {
            out.push_str(&combiner_note(p, k, h, stage));
        } else if stage <= Frequency::Vertex {
            out.push_str(": WGSL vertex shader");
        } else {
            out.push_str(": WGSL fragment shader");
        }
        let _ = writeln!(out, " — {}", pass.reason);
    }
    if out.is_empty() {
        let _ = writeln!(out, "- {target}: in no pass (folded, or removed by specialization)");
    }
    out
}

/// The approximations the lowering applied at `at` (line:col), with their
/// error against the program's exact meaning.
fn approximations(p: &Planned, at: &str) -> String {
    let mut out = String::new();
    for a in p.plan.approximations.iter().filter(|a| a.at == at) {
        let error = match (a.error_bound, a.output_bound) {
            (Some(e), Some(o)) => format!("error ≤ {} here, ≤ {} at the output", bound(e), bound(o)),
            (Some(e), None) => format!("error ≤ {} here, not bounded at the output", bound(e)),
            _ => "error not bounded".to_string(),
        };
        let _ = writeln!(out, "- approximated by `{}`: {} ({error})", a.rule, a.why);
    }
    out
}

fn combiner_note(p: &Planned, pass: usize, h: Handle<Expr>, freq: Frequency) -> String {
    if freq <= Frequency::Vertex {
        return ": per vertex (interpolated into the combiners)".into();
    }
    match crate::driver::combiners_of(p, pass).map_err(|e| format!("not generated: {e}")) {
        Ok(g) => format!(
            ": register combiners, {} general stage{} and the final combiner; {}",
            g.stages,
            plural(g.stages),
            combiner_stage(&g.placements, p.module.span(h), matches!(p.module.exprs[h], Expr::Lookup { .. }))
        ),
        Err(why) => format!(": register combiners (no setup generated: {why})"),
    }
}

/// Which combiner computes the value spanning `s` (Kilgard 2000, §4.2): the
/// general stage whose operation has exactly that span, else the stage whose
/// operation's span holds it (an input), else an input mapping or the final
/// combiner. Spans do not nest across a `let`: a let's value used inside a
/// product is placed by its own span only.
fn combiner_stage(placements: &[Placement], s: Span, lookup: bool) -> String {
    let portion = |p: &Placement| if p.alpha { "alpha" } else { "RGB" };
    if let Some(p) = placements.iter().find(|p| p.span == s) {
        return format!("computed in general combiner {} ({} portion)", p.stage, portion(p));
    }
    let within = placements
        .iter()
        .filter(|p| p.span.start <= s.start && s.end <= p.span.end)
        .min_by_key(|p| (p.span.len(), p.stage));
    match (within, lookup) {
        (Some(p), true) => format!("read from its texture register by general combiner {}", p.stage),
        (Some(p), false) => format!("an input of general combiner {} ({} portion)", p.stage, portion(p)),
        (None, true) => "read from its texture register by the final combiner".into(),
        (None, false) => "no general combiner computes it: an input mapping or the final combiner".into(),
    }
}

fn plural(n: usize) -> &'static str {
    if n == 1 {
        ""
    } else {
        "s"
    }
}
