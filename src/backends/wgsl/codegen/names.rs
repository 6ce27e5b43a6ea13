//! Names in the generated WGSL: the source's own names for the values it
//! binds (so that a reader of `--emit wgsl` finds `N`, `L`, `diffuse`),
//! made valid WGSL identifiers.
//!
//! Apart from the emitter because naming is cosmetic: nothing here changes
//! what a shader computes.

use super::*;

/// Names of IR values from the source: the `let` whose value a node is.
pub(super) fn source_names(planned: &Planned, source: Option<&str>) -> HashMap<ir::Handle<Expr>, String> {
    let mut by_span: HashMap<Span, String> = HashMap::new();
    if let Some(text) = source {
        let (program, _) = crate::parser::parse(text);
        for item in &program.items {
            match &item.kind {
                crate::parser::ast::ItemKind::Let(l) => {
                    by_span.insert(l.value.span, l.name.key());
                }
                // A computed vector (`vector H = normalize(L + V)`).
                crate::parser::ast::ItemKind::Vector(v) if v.names.len() == 1 => {
                    if let Some(value) = &v.value {
                        by_span.insert(value.span, v.names[0].key());
                    }
                }
                crate::parser::ast::ItemKind::Shader(s) => {
                    for l in &s.lets {
                        by_span.insert(l.value.span, l.name.key());
                    }
                }
                _ => {}
            }
        }
    }
    let m = &planned.module;
    let mut names = HashMap::new();
    let mut last: HashMap<Span, ir::Handle<Expr>> = HashMap::new();
    for (h, _) in m.exprs.arena().iter() {
        let s = m.span(h);
        if by_span.contains_key(&s) {
            last.insert(s, h); // the outermost node with the let's span
        }
    }
    for (s, h) in last {
        names.insert(h, sanitize(&by_span[&s]));
    }
    names
}

impl Gen<'_> {
    /// The name a value gets in the shader: its `let`, or a descriptive one.
    pub(super) fn value_name(&self, h: ir::Handle<Expr>) -> Option<String> {
        if let Some(n) = self.names.get(&h) {
            return Some(n.clone());
        }
        let m = self.m;
        let n = match &m.exprs[h] {
            Expr::VertexPosition(v) => sanitize(m.vertices.get(*v as usize)?),
            Expr::TexCoord { set, .. } => sanitize(&m.texcoord_sets.get(*set as usize)?.name),
            Expr::Vector { vector, .. } => sanitize(&m.vectors.get(*vector as usize)?.name),
            Expr::Uniform(u) => sanitize(&m.uniforms.get(*u as usize)?.name),
            Expr::Interpolate { value, .. } => format!("{}_frag", self.value_name(*value)?),
            Expr::Project { projection, value } => {
                let p = if projection.inverse {
                    "pi_inv".to_string()
                } else {
                    format!(
                        "pi{}{}",
                        projection.subscript.as_deref().map(sanitize).unwrap_or_default(),
                        if projection.star { "_star" } else { "" }
                    )
                };
                format!("{p}_{}", self.value_name(*value)?)
            }
            Expr::Lookup { texture, .. } => {
                format!("{}_texel", sanitize(&m.textures.get(*texture as usize)?.name))
            }
            Expr::FramebufferRead { framebuffer, channel, .. } => {
                let c = match channel {
                    FbChannel::Color => "color",
                    FbChannel::Alpha => "alpha",
                    FbChannel::Depth => "depth",
                    FbChannel::Stencil => "stencil",
                };
                format!("{}_{c}", sanitize(&m.framebuffers.get(*framebuffer as usize)?.name))
            }
            Expr::Binary { op: BinaryOp::Dot, lhs, rhs } => {
                let (a, b) = (self.value_name(*lhs)?, self.value_name(*rhs)?);
                short(&a)?;
                short(&b)?;
                format!("{}_dot_{}", a.to_lowercase(), b.to_lowercase())
            }
            Expr::Math { fun: MathFunction::Normalize, args } => {
                format!("{}_unit", short(&self.value_name(args[0])?)?)
            }
            Expr::Math { fun: MathFunction::Expand, args } => {
                format!("{}_expanded", short(&self.value_name(args[0])?)?)
            }
            Expr::Binary { op: BinaryOp::Pow, lhs, .. } => format!("{}_pow", short(&self.value_name(*lhs)?)?),
            _ => return None,
        };
        Some(n)
    }
}
