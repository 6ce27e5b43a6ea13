//! Declarations: textures (with their sources and generators), framebuffers,
//! vertices, texture-coordinate sets, constants and uniforms, each given its
//! id in the module before any statement is lowered.
//!
//! The rest of the lowering only reads what is declared here.

use super::*;

impl<'a> Lowerer<'a> {
    pub(super) fn declare(&mut self, item: &'a ast::Item) {
        match &item.kind {
            ItemKind::Target(t) => self.module.target = Some(t.profile.clone()),
            ItemKind::Texture(t) => self.declare_textures(t),
            ItemKind::Framebuffer(f) => {
                for n in &f.names {
                    self.framebuffer_id(n, f.channels.iter().map(|c| c.value).collect());
                }
            }
            ItemKind::Vector(v) => self.declare_vectors(v),
            ItemKind::Params(p) => self.declare_params(p),
            ItemKind::Const(c) => self.declare_const(c),
            ItemKind::Uniform(u) => self.declare_uniform(u),
            ItemKind::Let(l) => {
                self.globals.insert(l.name.key(), Global::Let(l));
            }
            ItemKind::Shader(s) => {
                self.globals.insert(s.name.key(), Global::Shader(s));
            }
            ItemKind::Statement(_) => {}
        }
    }

    /// Each name of a `texture` declaration, with its source, generator and sampling.
    fn declare_textures(&mut self, t: &'a ast::TextureDecl) {
        for n in &t.names {
            let id = self.module.textures.len() as u32;
            self.module.textures.push(Texture {
                name: n.key(),
                kind: t.kind.value,
                format: t.format.as_ref().map_or(ast::TextureFormat::Rgba8, |f| f.value),
                rendered: t.source.is_none(),
                baked: t.source.as_ref().is_some_and(is_bake),
                declaration: None,
                copy_of: None,
                tabulates: t.source.as_ref().and_then(tabulated),
                sampling: super::super::Sampling::of(
                    t.kind.value,
                    &t.attrs.iter().map(|a| a.value).collect::<Vec<_>>(),
                ),
                span: n.span,
            });
            self.globals.insert(n.key(), Global::Texture(id));
        }
    }

    /// Each name of a `vector` declaration: a shading vector, with its role.
    fn declare_vectors(&mut self, v: &'a ast::VectorDecl) {
        for n in &v.names {
            let id = self.module.vectors.len() as u32;
            self.module.vectors.push(Vector {
                name: n.key(),
                kind: v.role.as_ref().map(|r| r.kind.value),
                index: v.role.as_ref().and_then(|r| r.index.as_ref().map(|i| i.value)),
                space: v.role.as_ref().and_then(|r| r.space.as_ref().map(|s| s.value)),
                span: n.span,
            });
            self.vector_decls.push(v.value.as_ref());
            self.globals.insert(n.key(), Global::Vector(id));
        }
    }

    /// A shading-parameter bundle: the vectors it lists.
    fn declare_params(&mut self, p: &'a ast::ParamsDecl) {
        let mut members = Vec::new();
        for m in &p.members {
            match self.globals.get(&m.key()) {
                Some(Global::Vector(id)) => members.push(*id),
                _ => self.error(
                    "bad-params",
                    format!("`{}` is not a shading vector", m.key()),
                    m.span,
                    "not a vector",
                    "list vectors declared with `vector`",
                ),
            }
        }
        self.params.push(members);
        self.globals.insert(p.name.key(), Global::Params(self.params.len() - 1));
    }

    /// A `const`: its value, which must fold to a constant.
    fn declare_const(&mut self, c: &'a ast::ConstDecl) {
        self.sample = None;
        let Ok(h) = self.lower_expr(&c.value).and_then(|v| self.expect_expr(v, c.value.span)) else {
            return;
        };
        let Ok(h) = self.annotate(h, c.ty.as_ref(), c.value.span) else { return };
        if !matches!(self.module.exprs[h], Expr::Constant(_)) {
            self.error(
                "not-constant",
                format!("the constant `{}` is not computable at compile time", c.name.key()),
                c.value.span,
                "not a constant",
                "use `uniform` for a value the scene sets",
            );
            return;
        }
        self.globals.insert(c.name.key(), Global::Const(h));
    }

    /// A `uniform`, with its type and constant default.
    fn declare_uniform(&mut self, u: &'a ast::UniformDecl) {
        self.sample = None;
        let mut default = None;
        let mut ty = u.ty.as_ref().map(|t| Ty::from_ast(t.value));
        if let Some(d) = &u.default {
            if let Ok(h) = self
                .lower_expr(d)
                .and_then(|v| self.expect_expr(v, d.span))
                .and_then(|h| self.annotate(h, u.ty.as_ref(), d.span))
            {
                if let Expr::Constant(c) = self.module.exprs[h] {
                    ty = Some(c.ty);
                    default = Some(c);
                } else {
                    self.error(
                        "not-constant",
                        "a uniform's default must be a constant",
                        d.span,
                        "not a constant",
                        "write numbers or constants here",
                    );
                }
            }
        }
        let id = self.module.uniforms.len() as u32;
        self.module.uniforms.push(Uniform {
            name: u.name.key(),
            ty: ty.unwrap_or(Ty::Scalar),
            default,
            span: u.name.span,
        });
        self.globals.insert(u.name.key(), Global::Uniform(id));
    }
    /// A `3d` texture's `image(…)`: an image file has two axes and the
    /// language gives no layout of slices in it, so what the executors
    /// would sample is undefined (the CPU read it as 2-D, wgpu could not
    /// bind it); refused where it is declared. Solid textures are rendered
    /// (solid mapping, Pipeline Grammar eq. (15)-(16)), which the lowering
    /// makes a 3-D texture where the target has them.
    fn image_3d(&mut self, t: &'a ast::TextureDecl, at: crate::span::Span) {
        let names = t.names.iter().map(ast::Name::key).collect::<Vec<_>>().join(", ");
        self.diagnostics.push(
            Diagnostic::error(
                "bad-generator",
                "a 3-D texture cannot be read from an image: an image file has two axes, and shadec defines no layout of slices in one",
                at,
                "an image for a 3d texture",
            )
            .with_label(t.kind.span, "declared 3d here")
            .with_help(format!("a solid texture is rendered, not read: declare `{names}` as `2d rgba16f` without a source and write `{names} δu x ← δ P s x;` then `{names} δu ← p {names} δu;` (solid mapping, with `vector P : position in object;`), which on geforce3, planned for a scene, becomes a 3-D texture (docs/solid-textures.md); or declare it `2d` to read the image as one")),
        );
    }

    /// Bounds a generated texture where it is declared, before anything
    /// builds it: `normalize_cube(size[, bits])` (Kilgard 2000, Appendix D)
    /// needs a `cube` texture, a whole face size from 1 to
    /// [`generators::MAX_CUBE_FACE`] known at compile time (a literal or a
    /// `const`), and 8 or 16 bits. The other generators' sizes are fixed
    /// (`bumps`, `exponent_table`, `brdf_*`: 256 or 64 per side, or the
    /// height image's own size).
    pub(super) fn check_generator(&mut self, t: &'a ast::TextureDecl) {
        use crate::textures::generators::MAX_CUBE_FACE;
        let Some(source) = &t.source else { return };
        let ExprKind::Apply { func, arg } = &source.kind else { return };
        let FuncKind::Name(f) = &func.kind else { return };
        if f.key() == "image" && t.kind.value == ast::TextureKind::Tex3d {
            self.image_3d(t, f.span);
            return;
        }
        if f.key() != "normalize_cube" {
            return;
        }
        if t.kind.value != ast::TextureKind::Cube {
            self.diagnostics.push(
                Diagnostic::error(
                    "bad-generator",
                    format!(
                        "`normalize_cube` makes a cube map, but the texture is declared `{}`",
                        t.kind.value.as_str()
                    ),
                    f.span,
                    "a cube map generator",
                )
                .with_label(t.kind.span, "declared here")
                .with_help(format!(
                    "declare the texture `cube`: `texture {} : cube … = normalize_cube(…);`",
                    t.names.iter().map(ast::Name::key).collect::<Vec<_>>().join(", ")
                )),
            );
            // One mistake, one error: its lookups are read as the cube
            // map the generator makes, not reported again as 2-D lookups.
            for n in &t.names {
                if let Some(Global::Texture(id)) = self.globals.get(&n.key()) {
                    self.module.textures[*id as usize].kind = ast::TextureKind::Cube;
                }
            }
            return;
        }
        let items: Vec<&'a ast::Expr> = match &arg.kind {
            ExprKind::Tuple(items) => items.iter().collect(),
            _ => vec![arg],
        };
        if items.is_empty() || items.len() > 2 {
            self.error("arity", format!("`normalize_cube` takes a face size and optionally the bits (8 or 16), got {} argument(s)", items.len()), arg.span, "normalize_cube(size[, bits])", "write `normalize_cube(32)` or `normalize_cube(256, 16)`");
            return;
        }
        let values: Vec<Option<f64>> = items.iter().map(|e| self.compile_time_number(e)).collect();
        let size = values[0];
        match size {
            None => self.error("bad-generator", "the face size of `normalize_cube` is not a number known at compile time", items[0].span, "not a constant", "write a number or a `const`, such as `normalize_cube(32)`"),
            Some(n) if !(n >= 1.0 && n <= MAX_CUBE_FACE as f64 && n.fract() == 0.0) => self.error(
                if n > MAX_CUBE_FACE as f64 { "too-large" } else { "bad-generator" },
                if n > MAX_CUBE_FACE as f64 {
                    format!("a cube face of {n}×{n} texels is larger than the limit of {MAX_CUBE_FACE}×{MAX_CUBE_FACE}")
                } else {
                    format!("a cube face of {n} texels per side is not a whole number from 1 to {MAX_CUBE_FACE}")
                },
                items[0].span,
                format!("{n} texels per side"),
                format!("write a whole face size from 1 to {MAX_CUBE_FACE}: `normalize_cube(32)` is Kilgard 2000's normalization cube, 256 is smooth under magnification"),
            ),
            Some(_) => {}
        }
        if let Some(bits) = items.get(1) {
            if !matches!(values[1], Some(b) if b == 8.0 || b == 16.0) {
                self.error("bad-generator", "the bits of `normalize_cube` are 8 or 16", bits.span, "not 8 or 16", "write `normalize_cube(size, 8)` (Kilgard's 8-bit encoding) or `normalize_cube(size, 16)` (16 bits per component)");
            }
        }
    }

    /// A generator argument as the scene binder reads it (`scene::bind`): a
    /// number, a `const`, or a negation of one.
    pub(super) fn compile_time_number(&self, e: &ast::Expr) -> Option<f64> {
        match &e.kind {
            ExprKind::Number(v) => Some(*v),
            ExprKind::Unary { op: ast::UnaryOp::Neg, operand } => {
                self.compile_time_number(operand).map(|v| -v)
            }
            ExprKind::Name(n) => match self.globals.get(&n.key()) {
                Some(Global::Const(h)) => match self.module.exprs[*h] {
                    Expr::Constant(c) if c.ty == Ty::Scalar => Some(c.values()[0]),
                    _ => None,
                },
                _ => None,
            },
            _ => None,
        }
    }

    pub(super) fn framebuffer_id(&mut self, n: &ast::Name, channels: Vec<ast::FramebufferChannel>) -> u32 {
        if let Some(Global::Framebuffer(id)) = self.globals.get(&n.key()) {
            return *id;
        }
        let id = self.module.framebuffers.len() as u32;
        self.module.framebuffers.push(super::super::Framebuffer { name: n.key(), channels, span: n.span });
        self.globals.insert(n.key(), Global::Framebuffer(id));
        id
    }

    pub(super) fn vertex_id(&mut self, n: &ast::Name) -> VertexId {
        let key = n.key();
        if let Some(i) = self.module.vertices.iter().position(|v| *v == key) {
            return i as u32;
        }
        self.module.vertices.push(key);
        (self.module.vertices.len() - 1) as u32
    }

    pub(super) fn texcoord_id(&mut self, n: &ast::Name) -> u32 {
        let key = n.key();
        if let Some(i) = self.module.texcoord_sets.iter().position(|v| v.name == key) {
            return i as u32;
        }
        self.module.texcoord_sets.push(TexCoordSet { name: key, ty: Ty::Vec2, generated: false });
        (self.module.texcoord_sets.len() - 1) as u32
    }
}
