//! The readable dump of `shadec compile --emit ir`: resources, then every
//! value a statement reaches in arena (topological) order with its type,
//! frequency, range and source position, then the statements with the
//! resources each needs.

use std::fmt::{self, Write as _};

use super::{BinaryOp, Expr, FbChannel, Frequency, Handle, Module, Range, Site, Table, UnaryOp, Usage};
use crate::span::{LineIndex, Span};

/// Dumps `module`; with `source`, spans print as `line:col`.
pub fn dump(module: &Module, source: Option<&str>) -> String {
    let index = source.map(|s| (LineIndex::new(s), s));
    let at = |span: Span| -> String {
        if span == Span::DETACHED {
            return "-".into();
        }
        match &index {
            Some((ix, text)) => {
                let lc = ix.line_col(text, span.start as usize);
                format!("{}:{}", lc.line, lc.col)
            }
            None => format!("{}..{}", span.start, span.end),
        }
    };
    let mut out = String::new();
    // Writing to a `String` cannot fail: the `fmt::Result`s are all `Ok`.
    let _ = resources(&mut out, module);
    let _ = values(&mut out, module, &at);
    let _ = statements(&mut out, module, &at);
    out
}

/// The module's header and its declared resources, one line each.
fn resources(w: &mut String, module: &Module) -> fmt::Result {
    match &module.target {
        Some(t) => writeln!(w, "module (target {})", t.value)?,
        None => writeln!(w, "module")?,
    }
    for (i, t) in module.textures.iter().enumerate() {
        let src = if t.rendered { "rendered" } else { "source" };
        writeln!(w, "  texture t{i} {} : {} {} ({src})", t.name, t.kind.as_str(), t.format.as_str())?;
    }
    for (i, f) in module.framebuffers.iter().enumerate() {
        let ch: Vec<&str> = f.channels.iter().map(|c| c.as_str()).collect();
        let ch = if ch.is_empty() { "rgba8, depth, stencil".to_string() } else { ch.join(", ") };
        writeln!(w, "  framebuffer f{i} {} : {ch}", f.name)?;
    }
    for (i, v) in module.vectors.iter().enumerate() {
        let role = match (v.kind, v.index) {
            (Some(k), Some(n)) => format!("{}({n})", k.as_str()),
            (Some(k), None) => k.as_str().to_string(),
            (None, _) => "computed".to_string(),
        };
        let space = v.space.map(|s| format!(" in {}", s.as_str())).unwrap_or_default();
        writeln!(w, "  vector v{i} {} : {role}{space}", v.name)?;
    }
    for (i, u) in module.uniforms.iter().enumerate() {
        let d = u.default.map(|c| format!(" = {}", constant(&c))).unwrap_or_default();
        writeln!(w, "  uniform u{i} {} : {}{d}", u.name, u.ty.name())?;
    }
    for (i, v) in module.vertices.iter().enumerate() {
        writeln!(w, "  vertices x{i} {v}")?;
    }
    for (i, t) in module.texcoord_sets.iter().enumerate() {
        let g = if t.generated { " (generated)" } else { "" };
        writeln!(w, "  texcoords c{i} {} : {}{g}", t.name, t.ty.name())?;
    }
    Ok(())
}

/// Every node a statement reaches, in arena order, with its type,
/// frequency, range and position.
fn values(w: &mut String, module: &Module, at: &dyn Fn(Span) -> String) -> fmt::Result {
    let mut live = vec![false; module.exprs.len()];
    for st in &module.statements {
        let mut stack = vec![st.value, st.index];
        while let Some(h) = stack.pop() {
            if !live[h.index()] {
                live[h.index()] = true;
                stack.extend(module.operands(h));
            }
        }
    }
    writeln!(w, "values:")?;
    for (h, e) in module.exprs.arena().iter() {
        if !live[h.index()] {
            continue;
        }
        let info = module.info(h);
        let text = format!("  {h} = {}", node(module, e));
        let range = match info.range() {
            Range::Unsigned => "[0,1]",
            Range::Signed => "[-1,1]",
            Range::Unbounded => "unbounded",
        };
        writeln!(
            w,
            "{text:<44} : {:<8} {:<12} {:<9} @{}",
            info.ty.name(),
            freq(info.freq),
            range,
            at(module.span(h))
        )?;
    }
    Ok(())
}

/// The statements, each with the table it writes and the resources it needs.
fn statements(w: &mut String, module: &Module, at: &dyn Fn(Span) -> String) -> fmt::Result {
    writeln!(w, "statements:")?;
    for (i, st) in module.statements.iter().enumerate() {
        let table = match &st.table {
            Table::Framebuffer { id, channel } => {
                let name = &module.framebuffers[*id as usize].name;
                match channel {
                    FbChannel::Color => name.clone(),
                    c => format!("{name}.{}", channel_name(*c)),
                }
            }
            Table::Texture(id) => module.textures[*id as usize].name.clone(),
            Table::TexCoords(id) => module.texcoord_sets[*id as usize].name.clone(),
        };
        let u = Usage::of(module, st);
        writeln!(
            w,
            "  s{i} @{}: {table}[{}] <- {}   ({}; texture units {}, interpolants {}, constants {})",
            at(st.span),
            st.index,
            st.value,
            freq(st.freq),
            u.texture_units(),
            u.interpolants.len(),
            u.constants.len()
        )?;
    }
    Ok(())
}

fn freq(f: Frequency) -> &'static str {
    match f {
        Frequency::Constant => "constant",
        Frequency::Uniform => "per-object",
        Frequency::Vertex => "per-vertex",
        Frequency::Fragment => "per-fragment",
        Frequency::Texel => "per-texel",
        Frequency::Screen => "per-pixel",
    }
}

fn channel_name(c: FbChannel) -> &'static str {
    match c {
        FbChannel::Color => "color",
        FbChannel::Alpha => "alpha",
        FbChannel::Depth => "depth",
        FbChannel::Stencil => "stencil",
    }
}

fn number(v: f64) -> String {
    let s = format!("{v:.6}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".into()
    } else {
        s.to_string()
    }
}

fn constant(c: &super::Constant) -> String {
    let v: Vec<String> = c.values().iter().map(|v| number(*v)).collect();
    if v.len() == 1 {
        v[0].clone()
    } else {
        format!("({})", v.join(", "))
    }
}

fn list(hs: &[Handle<Expr>]) -> String {
    hs.iter().map(|h| h.to_string()).collect::<Vec<_>>().join(", ")
}

/// How the dump writes a binary operator.
fn binary_symbol(op: BinaryOp) -> &'static str {
    match op {
        BinaryOp::Add => "+",
        BinaryOp::Sub => "-",
        BinaryOp::Mul => "*",
        BinaryOp::Div => "/",
        BinaryOp::Pow => "^",
        BinaryOp::Dot => "·",
        BinaryOp::Lt => "<",
        BinaryOp::Le => "≤",
        BinaryOp::Gt => ">",
        BinaryOp::Ge => "≥",
        BinaryOp::Eq => "=",
        BinaryOp::Ne => "≠",
        BinaryOp::And => "and",
        BinaryOp::Or => "or",
    }
}

/// One node as the dump writes it: its operation and operands.
pub(crate) fn node(m: &Module, e: &Expr) -> String {
    match e {
        Expr::Constant(c) => format!("const {}", constant(c)),
        Expr::Uniform(id) => format!("uniform {}", m.uniforms[*id as usize].name),
        Expr::VertexPosition(x) => format!("vertex {}", m.vertices[*x as usize]),
        Expr::TexCoord { set, vertex } => {
            format!("texcoord {} {}", m.texcoord_sets[*set as usize].name, m.vertices[*vertex as usize])
        }
        Expr::Vector { vector, site } => {
            let site = match site {
                Site::Vertex(x) => m.vertices[*x as usize].clone(),
                Site::Texel => "texel".into(),
            };
            format!("vector {} {site}", m.vectors[*vector as usize].name)
        }
        Expr::TexelCoord => "texel-coord".into(),
        Expr::Pixel { freq: f } => format!("pixel ({})", freq(*f)),
        Expr::Project { projection, value } => {
            let mut p = "π".to_string();
            if let Some(s) = &projection.subscript {
                p.push_str(s);
            }
            if projection.star {
                p.push('*');
            }
            if projection.inverse {
                p.push_str("⁻¹");
            }
            format!("project {p} {value}")
        }
        Expr::Interpolate { value, to } => format!("δ {value} -> {}", freq(*to)),
        Expr::Lookup { texture, coords } => format!("lookup {} {coords}", m.textures[*texture as usize].name),
        Expr::FramebufferRead { framebuffer, channel, position } => {
            format!(
                "read {}.{} {position}",
                m.framebuffers[*framebuffer as usize].name,
                channel_name(*channel)
            )
        }
        Expr::Depth(h) => format!("depth {h}"),
        Expr::FatMember { texel, member } => format!("fat-member {member} of {texel}"),
        Expr::Bundle(hs) => format!("bundle ({})", list(hs)),
        Expr::Unary { op, value } => match op {
            UnaryOp::Neg => format!("neg {value}"),
            UnaryOp::Not => format!("not {value}"),
        },
        Expr::Binary { op, lhs, rhs } => format!("{lhs} {} {rhs}", binary_symbol(*op)),
        Expr::Combine { mode, lhs, rhs } => format!("{lhs} ⊕[{}] {rhs}", mode.as_str()),
        Expr::Math { fun, args } => format!("{}({})", fun.name(), list(args)),
        Expr::Swizzle { value, pattern, len, ty } => {
            let letters = if ty.is_color() || m.info(*value).ty.is_color() { "rgba" } else { "xyzw" };
            let s: String =
                pattern[..*len as usize].iter().map(|&i| letters.as_bytes()[i as usize] as char).collect();
            format!("{value}.{s}")
        }
        Expr::Compose { ty, components } => format!("{}({})", ty.name(), list(components)),
        Expr::Convert { value, to } => format!("convert {value} to {}", to.name()),
        Expr::Select { cond, accept, reject } => match reject {
            Some(r) => format!("{cond} ? {accept} : {r}"),
            None => format!("{cond} ? {accept} : keep"),
        },
    }
}
