//! Expressions: operators, construction, swizzles, names (locals,
//! declarations, `let`s) and shading-parameter bundles, each lowered to
//! interned IR nodes with their types checked.

use super::*;

impl<'a> Lowerer<'a> {
    pub(super) fn lower_expr(&mut self, e: &'a ast::Expr) -> Res<Value> {
        if self.expr_depth > MAX_EXPR_RECURSION {
            self.error(
                "too-deep",
                format!(
                    "the expression nests more than {MAX_EXPR_RECURSION} levels deep, counting the `let`s, vectors and shaders it inlines"
                ),
                e.span,
                "here",
                "this is shadec's limit on nesting: a sum or product of many terms is flat, not nested; shorten the chain of definitions that build on each other",
            );
            return Err(());
        }
        self.expr_depth += 1;
        let r = self.lower_expr_inner(e);
        self.expr_depth -= 1;
        r
    }

    /// Runs `f` inside the definition `name`. A definition met again while
    /// it is being inlined uses itself: that is the cycle, found by name, so
    /// a long chain of `let`s that each use the one before is not mistaken
    /// for one (only `MAX_EXPR_RECURSION` bounds how deep inlining goes).
    pub(super) fn nested<T>(
        &mut self,
        name: &str,
        span: Span,
        f: impl FnOnce(&mut Self) -> Res<T>,
    ) -> Res<T> {
        if !self.defining.insert(name.to_string()) {
            self.error(
                "cycle",
                format!("`{name}` is defined in terms of itself"),
                span,
                "used here",
                "a `let`, computed vector or shader must not use itself, directly or through others",
            );
            return Err(());
        }
        let r = f(self);
        self.defining.remove(name);
        r
    }

    pub(super) fn lower_expr_inner(&mut self, e: &'a ast::Expr) -> Res<Value> {
        let span = e.span;
        match &e.kind {
            ExprKind::Number(n) => Ok(Value::Expr(self.constant(Constant::scalar(*n), span))),
            ExprKind::String(_) => {
                self.error(
                    "type-mismatch",
                    "a string is not a value",
                    span,
                    "a string",
                    "strings name files, in texture sources (`image(\"brick.png\")`)",
                );
                Err(())
            }
            ExprKind::Name(n) => self.name(n),
            ExprKind::Tuple(items) => {
                let mut hs = Vec::new();
                for i in items {
                    let v = self.lower_expr(i)?;
                    hs.push(self.expect_expr(v, i.span)?);
                }
                let h = self.compose(hs, None, span)?;
                if let Expr::Constant(c) = &self.module.exprs[h] {
                    if c.ty == Ty::Vec3 {
                        let [r, g, b, _] = c.components;
                        self.vec3_tuples.push((span, [r, g, b]));
                    }
                }
                Ok(Value::Expr(h))
            }
            ExprKind::Apply { func, arg } => self.apply(func, arg, span),
            ExprKind::Swizzle { base, components } => self.lower_swizzle(base, components, span),
            ExprKind::Unary { op, operand } => {
                let v = self.lower_expr(operand)?;
                let h = self.expect_expr(v, operand.span)?;
                let op = match op {
                    ast::UnaryOp::Neg => UnaryOp::Neg,
                    ast::UnaryOp::Not => UnaryOp::Not,
                };
                self.append(Expr::Unary { op, value: h }, span).map(Value::Expr)
            }
            ExprKind::Binary { op, lhs, rhs } => {
                let a = self.lower_expr(lhs)?;
                let a = self.expect_expr(a, lhs.span)?;
                let b = self.lower_expr(rhs)?;
                let b = self.expect_expr(b, rhs.span)?;
                self.binary(binary_op(*op), a, b, span).map(Value::Expr)
            }
            ExprKind::Combine { mode, lhs, rhs } => {
                let a = self.lower_expr(lhs)?;
                let a = self.expect_expr(a, lhs.span)?;
                let b = self.lower_expr(rhs)?;
                let b = self.expect_expr(b, rhs.span)?;
                let (a, b) = self.widen_pair(a, b, span)?;
                if mode.is_none() {
                    self.warn_modulating_cleared(a, lhs.span, span);
                }
                let mode = mode.as_ref().map_or(ast::CombineMode::Modulate, |m| m.value);
                self.append(Expr::Combine { mode, lhs: a, rhs: b }, span).map(Value::Expr)
            }
            ExprKind::Select { cond, then, otherwise } => {
                let c = self.lower_expr(cond)?;
                let c = self.expect_expr(c, cond.span)?;
                let a = self.lower_expr(then)?;
                let mut a = self.expect_expr(a, then.span)?;
                let reject = match otherwise {
                    Some(o) => {
                        let b = self.lower_expr(o)?;
                        let b = self.expect_expr(b, o.span)?;
                        let (a2, b2) = self.widen_pair(a, b, span)?;
                        a = a2;
                        Some(b2)
                    }
                    None => None,
                };
                self.append(Expr::Select { cond: c, accept: a, reject }, span).map(Value::Expr)
            }
        }
    }

    /// `base.components`: a swizzle of a value, or of the texel coordinate
    /// where `base` is a texel-site shading-parameter bundle.
    fn lower_swizzle(&mut self, base: &'a ast::Expr, components: &str, span: Span) -> Res<Value> {
        let v = self.lower_expr(base)?;
        if let Value::Bundle(b) = &v {
            if b.site == BundleSite::Texel {
                let tc = match self.surface {
                    // On the surface: the texel coordinate there, `δu x`.
                    Some((_, Some((_, index)))) => index,
                    _ => self.texel_coordinate(base.span)?,
                };
                return self.swizzle(tc, components, span).map(Value::Expr);
            }
            self.unsupported(
                "components of a shading-parameter vector outside texture shading; use its vectors by name",
                span,
            );
            return Err(());
        }
        let h = self.expect_expr(v, base.span)?;
        self.swizzle(h, components, span).map(Value::Expr)
    }

    /// A bare `⊕` is modulate: Pipeline Grammar's multipass forms (9)-(11),
    /// `C δπx ← (C δπx) ⊕ (…)`, written literally as a program's first
    /// write of `C` multiply the cleared framebuffer (0) and render black.
    /// Warns when the left operand reads the colour of a framebuffer no
    /// earlier statement writes.
    pub(super) fn warn_modulating_cleared(&mut self, lhs: Handle<Expr>, lhs_span: Span, span: Span) {
        let Expr::FramebufferRead { framebuffer, channel: FbChannel::Color, .. } = self.module.exprs[lhs]
        else {
            return;
        };
        // Once per place: a `let` is lowered again in every statement using it.
        if self.written.contains(&framebuffer)
            || self.diagnostics.iter().any(|d| d.code == "modulate-cleared" && d.primary.span == lhs_span)
        {
            return;
        }
        let name = self.module.framebuffers[framebuffer as usize].name.clone();
        self.diagnostics.push(
            Diagnostic::warning(
                "modulate-cleared",
                format!("`⊕` modulates the framebuffer `{name}`, which no earlier statement writes: it is still cleared to 0, so the result is black"),
                lhs_span,
                format!("`{name}` is not written yet"),
            )
            .with_label(span, "a bare `⊕` is `⊕[modulate]`")
            .with_help(format!(
                "to accumulate into `{name}`, write `⊕[add]`; to modulate what an earlier pass drew, write `{name}` first (e.g. `{name} δπx ← …;` before this statement)"
            )),
        );
    }

    /// A framebuffer's colour read where no statement of the program writes
    /// the framebuffer at all: it holds its clear value, 0, wherever it is
    /// read (a screen pass `C xs ← F xs` of a forgotten `F δπx ← …`).
    /// Warned once per framebuffer, at its first read. Reads of `C` that
    /// accumulate into it (`(C δπx) ⊕[add] …`) write it, so are not warned;
    /// nor are reads of a framebuffer a statement writes that failed to
    /// lower (its own error is the one to read, not a cascade).
    pub(super) fn warn_never_written(&mut self) {
        let lowered = self.module.statements.iter().filter_map(|st| match st.table {
            Table::Framebuffer { id, .. } => Some(id),
            _ => None,
        });
        let written: HashSet<u32> = lowered.chain(self.written.iter().copied()).collect();
        let mut warned = HashSet::new();
        for (h, e) in self.module.exprs.arena().iter() {
            let Expr::FramebufferRead { framebuffer, channel: FbChannel::Color | FbChannel::Alpha, .. } = *e
            else {
                continue;
            };
            if written.contains(&framebuffer) || !warned.insert(framebuffer) {
                continue;
            }
            let name = self.module.framebuffers[framebuffer as usize].name.clone();
            self.diagnostics.push(
                Diagnostic::warning(
                    "read-cleared",
                    format!("the framebuffer `{name}` is read, but no statement writes it: it holds its clear value, 0 (black)"),
                    self.module.span(h),
                    format!("`{name}` is never written"),
                )
                .with_help(format!("write `{name}` in a statement before this read (e.g. `{name} δπx ← …;`), or read the framebuffer that holds the picture")),
            );
        }
    }

    /// rgb meets rgba: the rgb side widens (alpha 1).
    pub(super) fn widen_pair(
        &mut self,
        a: Handle<Expr>,
        b: Handle<Expr>,
        span: Span,
    ) -> Res<(Handle<Expr>, Handle<Expr>)> {
        let (ta, tb) = (self.module.info(a).ty, self.module.info(b).ty);
        match (ta, tb) {
            (Ty::Rgb, Ty::Rgba) => Ok((self.append(Expr::Convert { value: a, to: Ty::Rgba }, span)?, b)),
            (Ty::Rgba, Ty::Rgb) => Ok((a, self.append(Expr::Convert { value: b, to: Ty::Rgba }, span)?)),
            _ => Ok((a, b)),
        }
    }

    pub(super) fn binary(
        &mut self,
        op: BinaryOp,
        a: Handle<Expr>,
        b: Handle<Expr>,
        span: Span,
    ) -> Res<Handle<Expr>> {
        let (a, b) = if matches!(op, BinaryOp::Add | BinaryOp::Sub | BinaryOp::Mul | BinaryOp::Div) {
            self.widen_pair(a, b, span)?
        } else {
            (a, b)
        };
        self.append(Expr::Binary { op, lhs: a, rhs: b }, span)
    }

    pub(super) fn compose(&mut self, hs: Vec<Handle<Expr>>, ty: Option<Ty>, span: Span) -> Res<Handle<Expr>> {
        if hs.len() == 1 && ty.is_none() {
            return Ok(hs[0]);
        }
        let width: usize = hs.iter().map(|h| self.module.info(*h).ty.width()).sum();
        let ty = match ty {
            Some(t) => t,
            None => match width {
                2 => Ty::Vec2,
                3 => Ty::Vec3,
                4 => Ty::Rgba,
                n => {
                    self.error(
                        "type-mismatch",
                        format!("a tuple of {n} components is not a value"),
                        span,
                        "2, 3 or 4 components",
                        "write (u, v), (x, y, z) or (r, g, b, a)",
                    );
                    return Err(());
                }
            },
        };
        // `rgb(v)` of a vec3 is a colour, `vec3(c)` of a colour a vector,
        // `rgba(c)` of an rgb the colour with alpha 1, `rgb(s)` a grey.
        if hs.len() == 1 {
            if let Some(h) = self.coerce(hs[0], ty, span)? {
                return Ok(h);
            }
        }
        // `rgb(g, g, g)` is the grey `rgb(g)`: one scalar in every
        // component is a splat, which every target computes (the register
        // combiners cannot assemble a colour from separate channels).
        if ty.is_numeric()
            && hs.len() == ty.width()
            && hs.iter().all(|&h| h == hs[0] && self.module.info(h).ty == Ty::Scalar)
        {
            return self.append(Expr::Convert { value: hs[0], to: ty }, span);
        }
        self.append(Expr::Compose { ty, components: hs }, span)
    }

    pub(super) fn swizzle(&mut self, h: Handle<Expr>, components: &str, span: Span) -> Res<Handle<Expr>> {
        let mut pattern = [0u8; 4];
        let mut xyzw = false;
        let mut rgba = false;
        let chars: Vec<char> = components.chars().collect();
        if chars.is_empty() || chars.len() > 4 {
            self.error(
                "bad-swizzle",
                format!("`.{components}` selects {} components", chars.len()),
                span,
                "1 to 4 components",
                "write `.x`, `.xy`, `.rgb`, `.a`…",
            );
            return Err(());
        }
        for (i, c) in chars.iter().enumerate() {
            pattern[i] = match c {
                'x' | 'r' => 0,
                'y' | 'g' => 1,
                'z' | 'b' => 2,
                'w' | 'a' => 3,
                _ => {
                    self.error(
                        "bad-swizzle",
                        format!("`{c}` is not a component"),
                        span,
                        "unknown component",
                        "components are x y z w, or r g b a",
                    );
                    return Err(());
                }
            };
            if "xyzw".contains(*c) {
                xyzw = true;
            } else {
                rgba = true;
            }
        }
        if xyzw && rgba {
            self.error(
                "bad-swizzle",
                format!("`.{components}` mixes xyzw and rgba"),
                span,
                "mixed component names",
                "use one naming: `.xyz` or `.rgb`",
            );
            return Err(());
        }
        let ty = match chars.len() {
            1 => Ty::Scalar,
            2 => Ty::Vec2,
            3 if rgba => Ty::Rgb,
            3 => Ty::Vec3,
            _ => Ty::Rgba,
        };
        // `.rgb` of an rgb, `.xyz` of a vec3: nothing to do.
        let src = self.module.info(h).ty;
        if src == ty && (0..chars.len()).all(|i| pattern[i] as usize == i) {
            return Ok(h);
        }
        self.append(Expr::Swizzle { value: h, pattern, len: chars.len() as u8, ty }, span)
    }

    pub(super) fn lookup_local(&self, key: &str) -> Option<Value> {
        self.locals.iter().rev().find(|(k, _)| k == key).map(|(_, v)| v.clone())
    }

    pub(super) fn name(&mut self, n: &'a ast::Name) -> Res<Value> {
        let key = n.key();
        if let Some(v) = self.lookup_local(&key) {
            return Ok(v);
        }
        match self.globals.get(&key).copied() {
            Some(Global::Const(h)) => Ok(Value::Expr(h)),
            Some(Global::Uniform(id)) => self.append(Expr::Uniform(id), n.span).map(Value::Expr),
            Some(Global::Let(l)) => self.let_value(l),
            Some(Global::Vector(id)) => match self.bundles.last().cloned() {
                Some(b) => self.member(&b, id, n.span).map(Value::Expr),
                None => {
                    self.error("no-site", format!("the shading vector `{key}` needs a site"), n.span, "where is it evaluated?", format!("select it from a parameter vector: `{key} s x` (at a vertex) or `{key} δ s x` (interpolated), or use it inside a shader"));
                    Err(())
                }
            },
            Some(Global::Params(i)) => Ok(Value::ParamsName(self.params[i].clone())),
            Some(Global::Texture(_) | Global::Framebuffer(_) | Global::Shader(_)) => {
                self.error(
                    "type-mismatch",
                    format!("`{key}` is a table or shader, not a value"),
                    n.span,
                    "apply it",
                    match self.globals.get(&key) {
                        Some(Global::Framebuffer(_)) => {
                            format!("read a framebuffer at an index: `{key} δπx` (the fragment's pixel) or `{key} xs` (in a screen pass)")
                        }
                        Some(Global::Shader(_)) => format!(
                            "apply the shader to the shading parameters: `{key} δ s x` (per fragment) or `δ {key} s x` (per vertex, interpolated)"
                        ),
                        _ => format!("apply it to an index, such as `{key} δu x`"),
                    },
                );
                Err(())
            }
            None => match resolve::family(n) {
                Some(Entity::Vertex) => Ok(Value::Vertex(self.vertex_id(n))),
                Some(Entity::Pixel) => {
                    self.append(Expr::Pixel { freq: Frequency::Screen }, n.span).map(Value::Expr)
                }
                Some(Entity::TexCoords) => {
                    self.texcoord_id(n);
                    Ok(Value::TexCoordSet)
                }
                Some(Entity::Params) => Ok(Value::ParamsName(self.all_vectors())),
                Some(Entity::Framebuffer) => {
                    self.error(
                        "type-mismatch",
                        format!("the framebuffer `{key}` is not a value"),
                        n.span,
                        "apply it",
                        format!("read it at a position: `{key} δπx` or `{key} xs`"),
                    );
                    Err(())
                }
                _ => {
                    if FUNCTIONS.contains(&key.as_str()) {
                        self.error(
                            "type-mismatch",
                            format!("the function `{key}` is not a value"),
                            n.span,
                            "apply it",
                            format!("call it: `{key}(…)`"),
                        );
                    } else {
                        self.error(
                            "unknown-name",
                            format!("unknown name `{key}`"),
                            n.span,
                            "not declared",
                            "declare it first",
                        );
                    }
                    Err(())
                }
            },
        }
    }

    pub(super) fn all_vectors(&self) -> Vec<VectorId> {
        (0..self.module.vectors.len() as u32).collect()
    }

    pub(super) fn let_value(&mut self, l: &'a ast::LetDecl) -> Res<Value> {
        let key = l.name.key();
        self.used.insert(key.clone());
        if let Some(v) = self.let_cache.get(&key) {
            return Ok(v.clone());
        }
        // A global `let` sees no shader locals.
        let locals = std::mem::take(&mut self.locals);
        let bundles = std::mem::take(&mut self.bundles);
        let r = self.nested(&key, l.name.span, |this| this.lower_expr(&l.value));
        self.locals = locals;
        self.bundles = bundles;
        let v = r?;
        self.let_cache.insert(key, v.clone());
        Ok(v)
    }

    /// Vector `id` of bundle `b`, as an IR node.
    pub(super) fn member(&mut self, b: &Bundle, id: VectorId, span: Span) -> Res<Handle<Expr>> {
        let Some(pos) = b.members.iter().position(|m| *m == id) else {
            let name = self.module.vectors[id as usize].name.clone();
            self.error(
                "not-a-member",
                format!("`{name}` is not a member of this shading-parameter vector"),
                span,
                "not in the bundle",
                format!("add `{name}` to its `params` declaration"),
            );
            return Err(());
        };
        match b.site {
            BundleSite::Vertex(x) => self.vector_at(id, Site::Vertex(x), b, span),
            BundleSite::Texel => match (self.vector_decls[id as usize], self.surface_vertex(span)?) {
                (None, Some(x)) => {
                    let h = self.vector_at(id, Site::Vertex(x), b, span)?;
                    self.interpolate(h, Frequency::Texel, span)
                }
                _ => self.vector_at(id, Site::Texel, b, span),
            },
            BundleSite::Interpolated(x, to) => {
                let at_vertex = Bundle { members: b.members.clone(), site: BundleSite::Vertex(x) };
                let h = self.vector_at(id, Site::Vertex(x), &at_vertex, span)?;
                self.interpolate(h, to, span)
            }
            BundleSite::Fat(texel) => self.append(Expr::FatMember { texel, member: pos as u8 }, span),
        }
    }

    /// A vector evaluated at a vertex or texel: a leaf for a role, or its
    /// declared expression with the other members of `b` at the same site.
    pub(super) fn vector_at(
        &mut self,
        id: VectorId,
        site: Site,
        b: &Bundle,
        span: Span,
    ) -> Res<Handle<Expr>> {
        match self.vector_decls[id as usize] {
            None => self.append(Expr::Vector { vector: id, site }, span),
            Some(value) => {
                let locals = std::mem::take(&mut self.locals);
                self.bundles.push(Bundle { members: self.all_vectors(), site: b.site });
                let name = self.module.vectors[id as usize].name.clone();
                let r = self
                    .nested(&name, span, |l| l.lower_expr(value).and_then(|v| l.expect_expr(v, value.span)));
                self.bundles.pop();
                self.locals = locals;
                r
            }
        }
    }

    pub(super) fn interpolate(&mut self, h: Handle<Expr>, to: Frequency, span: Span) -> Res<Handle<Expr>> {
        self.append(Expr::Interpolate { value: h, to }, span)
    }

    pub(super) fn bundle_members(&mut self, b: &Bundle, span: Span) -> Res<Vec<Handle<Expr>>> {
        let mut v = Vec::new();
        for &m in &b.members.clone() {
            v.push(self.member(b, m, span)?);
        }
        Ok(v)
    }
}

/// The IR operator of a source binary operator.
fn binary_op(op: ast::BinaryOp) -> BinaryOp {
    match op {
        ast::BinaryOp::Or => BinaryOp::Or,
        ast::BinaryOp::And => BinaryOp::And,
        ast::BinaryOp::Lt => BinaryOp::Lt,
        ast::BinaryOp::Le => BinaryOp::Le,
        ast::BinaryOp::Gt => BinaryOp::Gt,
        ast::BinaryOp::Ge => BinaryOp::Ge,
        ast::BinaryOp::Eq => BinaryOp::Eq,
        ast::BinaryOp::Ne => BinaryOp::Ne,
        ast::BinaryOp::Add => BinaryOp::Add,
        ast::BinaryOp::Sub => BinaryOp::Sub,
        ast::BinaryOp::Mul => BinaryOp::Mul,
        ast::BinaryOp::Div => BinaryOp::Div,
        ast::BinaryOp::Dot => BinaryOp::Dot,
        ast::BinaryOp::Pow => BinaryOp::Pow,
    }
}
