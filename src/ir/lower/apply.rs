//! Application: function calls, `δ` (distributed or not), inlined shaders
//! and `let` functions, framebuffer reads, per-vertex parameters, and the
//! built-in functions.
//!
//! Apart from `expr` because inlining is where the lowering recurses into
//! other declarations, with its own depth limit.

use super::*;

impl<'a> Lowerer<'a> {
    pub(super) fn apply(&mut self, func: &'a ast::Func, arg: &'a ast::Expr, span: Span) -> Res<Value> {
        match &func.kind {
            FuncKind::Delta => {
                let saved = std::mem::replace(&mut self.distributed, false);
                self.under_delta += 1;
                let v = self.lower_expr(arg);
                self.under_delta -= 1;
                let distributed = std::mem::replace(&mut self.distributed, saved);
                self.delta(v?, distributed, func.span, span)
            }
            FuncKind::Projection(p) => {
                let v = self.lower_expr(arg)?;
                let h = self.expect_expr(v, arg.span)?;
                let projection =
                    Projection { subscript: p.subscript.clone(), star: p.star, inverse: p.inverse };
                self.append(Expr::Project { projection, value: h }, span).map(Value::Expr)
            }
            FuncKind::Channel(ch) => {
                let v = self.lower_expr(arg)?;
                let h = self.expect_expr(v, arg.span)?;
                let channel = match ch {
                    ast::Channel::Alpha => FbChannel::Alpha,
                    ast::Channel::Depth => FbChannel::Depth,
                    ast::Channel::Stencil => FbChannel::Stencil,
                };
                match self.module.exprs[h].clone() {
                    Expr::FramebufferRead { framebuffer, channel: FbChannel::Color, position } => self
                        .append(Expr::FramebufferRead { framebuffer, channel, position }, span)
                        .map(Value::Expr),
                    _ if channel == FbChannel::Depth => self.append(Expr::Depth(h), span).map(Value::Expr),
                    _ if channel == FbChannel::Alpha && self.module.info(h).ty == Ty::Rgba => {
                        self.swizzle(h, "a", span).map(Value::Expr)
                    }
                    _ => {
                        self.error(
                            "type-mismatch",
                            "a channel selector needs a framebuffer",
                            func.span,
                            "selects a framebuffer channel",
                            "write `α C δπx`, `z C xs`, `σ C δπx`",
                        );
                        Err(())
                    }
                }
            }
            FuncKind::Name(n) => self.apply_name(n, arg, span),
        }
    }

    pub(super) fn delta(&mut self, v: Value, distributed: bool, delta_span: Span, span: Span) -> Res<Value> {
        let Some(to) = self.sample else {
            let (message, label) = match self.statement_freq {
                Some(Frequency::Vertex) => (
                    "δ makes a per-fragment value, but this is a per-vertex target",
                    "per-fragment value in a per-vertex statement",
                ),
                Some(Frequency::Screen) => (
                    "δ in a screen pass: `C xs ←` draws no primitives to interpolate over",
                    "nothing to rasterize",
                ),
                _ => (
                    "δ outside a statement: constants and uniforms are not rasterized",
                    "δ rasterizes primitives",
                ),
            };
            self.error("frequency", message, delta_span, label, "δ belongs in statements that draw: `C δπx ← …`, `T δu ← …`; a texgen `u x ←` runs per vertex and a screen pass `C xs ←` per pixel");
            return Err(());
        };
        // In texture shading `T δu ← …`, δ of a per-vertex value interpolates
        // over the mesh: the statement rasterizes it in texture space (its
        // index becomes `δu x`, Pipeline Grammar, eq. (15)), as `s δu` taken
        // on the surface does; a quad over the texels has no vertices.
        if to == Frequency::Texel && !matches!(v, Value::TexCoordSet) {
            self.surface_vertex(delta_span)?;
        }
        match v {
            Value::Bundle(Bundle { members, site: BundleSite::Vertex(x) }) => {
                Ok(Value::Bundle(Bundle { members, site: BundleSite::Interpolated(x, to) }))
            }
            Value::Bundle(_) => {
                self.error(
                    "delta-twice",
                    "δ applied to a shading-parameter vector that is not per vertex",
                    delta_span,
                    "δ applied twice",
                    "δ interpolates per-vertex values; remove one δ",
                );
                Err(())
            }
            Value::Vertex(x) => {
                let p = self.append(Expr::VertexPosition(x), span)?;
                self.interpolate(p, to, span).map(Value::Expr)
            }
            Value::TexCoordSet => {
                if to != Frequency::Texel {
                    self.error("bad-index", "`δu` without a vertex is the coordinate of the texel being rendered", span, "only in texture shading", "write `δu x` for interpolated texture coordinates; `T δu ← …` renders a texture in its own coordinates");
                    return Err(());
                }
                self.append(Expr::TexelCoord, span).map(Value::Expr)
            }
            Value::ParamsName(_) => {
                self.error(
                    "type-mismatch",
                    "δ of an unapplied parameter vector",
                    span,
                    "no vertex",
                    "write `δ s x`",
                );
                Err(())
            }
            Value::Expr(h) => {
                if let Expr::Pixel { freq: Frequency::Screen } = self.module.exprs[h] {
                    // `δ xs`: the fragment at pixel xs (seeds/001 (10)).
                    return self.append(Expr::Pixel { freq: to }, span).map(Value::Expr);
                }
                let info = *self.module.info(h);
                match info.freq {
                    Frequency::Constant | Frequency::Uniform => Ok(Value::Expr(h)),
                    Frequency::Vertex => self.interpolate(h, to, span).map(Value::Expr),
                    // EMBM (seeds/001 (8)): δ distributed over the operators while
                    // its argument was lowered, interpolating the per-vertex operands.
                    _ if distributed => Ok(Value::Expr(h)),
                    _ => {
                        let freq = info.freq.name();
                        self.error(
                            "delta-twice",
                            format!("δ applied to a value that is already {freq}"),
                            delta_span,
                            "δ applied twice",
                            format!("δ interpolates per-vertex values, and this δ's argument is computed {freq} already (from δs, texels or framebuffer reads inside it); remove this δ: a texture is looked up at a {freq} coordinate as it is, `T (…)`"),
                        );
                        Err(())
                    }
                }
            }
        }
    }

    pub(super) fn apply_name(&mut self, n: &'a ast::Name, arg: &'a ast::Expr, span: Span) -> Res<Value> {
        let key = n.key();
        let local = self.lookup_local(&key);
        let global = self.globals.get(&key).copied();
        if local.is_none() && global.is_none() && FUNCTIONS.contains(&key.as_str()) {
            return self.builtin(&key, arg, span).map(Value::Expr);
        }
        if let Some(v) = local {
            if let Value::ParamsName(members) = v {
                let a = self.lower_expr(arg)?;
                return self.params_at(members, a, arg.span);
            }
            self.unsupported(format!("applying the local `{key}`"), n.span);
            return Err(());
        }
        match global {
            Some(Global::Texture(id)) => {
                let a = self.lower_expr(arg)?;
                let coords = self.expect_expr(a, arg.span)?;
                self.append(Expr::Lookup { texture: id, coords }, span).map(Value::Expr)
            }
            Some(Global::Framebuffer(id)) => self.framebuffer_read(id, arg, span),
            Some(Global::Shader(s)) => {
                let a = self.lower_expr(arg)?;
                self.inline(s, a, arg.span, span).map(Value::Expr)
            }
            Some(Global::Vector(id)) => {
                let a = self.lower_expr(arg)?;
                let b = match a {
                    Value::Bundle(b) => b,
                    _ => {
                        self.error(
                            "type-mismatch",
                            format!("the vector `{key}` selects from a shading-parameter vector"),
                            arg.span,
                            "not a parameter vector",
                            format!("write `{key} s x` or `{key} δ s x`"),
                        );
                        return Err(());
                    }
                };
                self.member(&b, id, n.span.join(arg.span)).map(Value::Expr)
            }
            Some(Global::Params(i)) => {
                let a = self.lower_expr(arg)?;
                let members = self.params[i].clone();
                self.params_at(members, a, arg.span)
            }
            Some(Global::Let(_) | Global::Const(_) | Global::Uniform(_)) => {
                self.unsupported(format!("applying `{key}` to a value"), n.span);
                Err(())
            }
            None => self.apply_undeclared(n, arg, span),
        }
    }

    /// `n arg` for a name nothing declares: a name of a family the language
    /// knows by its letter (parameter vectors, texture coordinates,
    /// framebuffers), or an error.
    fn apply_undeclared(&mut self, n: &'a ast::Name, arg: &'a ast::Expr, span: Span) -> Res<Value> {
        let key = n.key();
        match resolve::family(n) {
            Some(Entity::Params) => {
                let a = self.lower_expr(arg)?;
                let members = self.all_vectors();
                self.params_at(members, a, arg.span)
            }
            Some(Entity::TexCoords) => {
                let set = self.texcoord_id(n);
                match self.lower_expr(arg)? {
                    Value::Vertex(x) => self.append(Expr::TexCoord { set, vertex: x }, span).map(Value::Expr),
                    _ => {
                        self.error(
                            "type-mismatch",
                            format!("`{key}` is indexed by a vertex"),
                            arg.span,
                            "not a vertex",
                            format!("write `{key} x`"),
                        );
                        Err(())
                    }
                }
            }
            Some(Entity::Framebuffer) => {
                let id = self.framebuffer_id(n, Vec::new());
                self.framebuffer_read(id, arg, span)
            }
            _ => {
                self.unsupported(format!("applying `{key}`"), n.span);
                Err(())
            }
        }
    }

    /// A member of `s δu` in `T δu ← …`: the vertex stream of the surface
    /// it is taken on, making the statement's index `δu x` the first time
    /// (the mesh rasterized in texture space, as (15) writes it). The mesh
    /// is the program's one vertex stream; with none, `None` (the member is
    /// a function of the texel coordinate); with several, an error.
    pub(super) fn surface_vertex(&mut self, span: Span) -> Res<Option<VertexId>> {
        let Some((set, made)) = self.surface else { return Ok(None) };
        if let Some((x, _)) = made {
            return Ok(Some(x));
        }
        // Every vertex stream the program names (x, x′, …).
        let mut streams: Vec<ast::Name> = Vec::new();
        for item in &self.program.items {
            if let ItemKind::Statement(st) = &item.kind {
                for e in [&st.target.index, &st.value] {
                    e.walk(&mut |x| {
                        if let ExprKind::Name(n) = &x.kind {
                            if resolve::family(n) == Some(Entity::Vertex)
                                && !streams.iter().any(|s| s.key() == n.key())
                            {
                                streams.push(n.clone());
                            }
                        }
                    });
                }
            }
        }
        let x = match streams.as_slice() {
            [] => return Ok(None),
            [x] => self.vertex_id(x),
            _ => {
                self.error(
                    "ambiguous-surface",
                    "texture shading `s δu` on a program with several vertex streams: which surface `u` parameterizes is not said",
                    span,
                    "on which mesh?",
                    "name the stream: `T δu x ← p δ s x` rasterizes the mesh `x` in texture space (Pipeline Grammar, eq. (15))",
                );
                return Err(());
            }
        };
        let tc = self.append(Expr::TexCoord { set, vertex: x }, span)?;
        let index = self.interpolate(tc, Frequency::Texel, span)?;
        self.surface = Some((set, Some((x, index))));
        Ok(Some(x))
    }

    pub(super) fn framebuffer_read(&mut self, id: u32, arg: &'a ast::Expr, span: Span) -> Res<Value> {
        let a = self.lower_expr(arg)?;
        let position = self.expect_expr(a, arg.span)?;
        self.append(Expr::FramebufferRead { framebuffer: id, channel: FbChannel::Color, position }, span)
            .map(Value::Expr)
    }

    /// `s x`, `s δu`: a bundle at a vertex or at the texel being rendered.
    pub(super) fn params_at(&mut self, members: Vec<VectorId>, a: Value, span: Span) -> Res<Value> {
        match a {
            Value::Vertex(x) => Ok(Value::Bundle(Bundle { members, site: BundleSite::Vertex(x) })),
            Value::Expr(h) if matches!(self.module.exprs[h], Expr::TexelCoord) => {
                Ok(Value::Bundle(Bundle { members, site: BundleSite::Texel }))
            }
            _ => {
                self.error(
                    "type-mismatch",
                    "a shading-parameter vector is indexed by a vertex or a texel",
                    span,
                    "not a vertex",
                    "write `s x` (at a vertex) or `s δu` (texture shading)",
                );
                Err(())
            }
        }
    }

    pub(super) fn inline(
        &mut self,
        s: &'a ast::ShaderDecl,
        arg: Value,
        arg_span: Span,
        span: Span,
    ) -> Res<Handle<Expr>> {
        self.used.insert(s.name.key());
        let input_members = match self.globals.get(&s.input.key()) {
            Some(Global::Params(i)) => self.params[*i].clone(),
            _ => self.all_vectors(),
        };
        let bundle = match arg {
            Value::Bundle(b) => b,
            Value::Expr(h)
                if self.module.info(h).ty.is_color()
                    && matches!(self.module.exprs[h], Expr::Lookup { .. }) =>
            {
                // A fat texel holds the shader's parameters (seeds/001 (6), (14), (16)).
                Bundle { members: input_members, site: BundleSite::Fat(h) }
            }
            _ => {
                self.error(
                    "type-mismatch",
                    format!(
                        "the shader `{}` is applied to something that is not a shading-parameter vector",
                        s.name.key()
                    ),
                    arg_span,
                    "not a parameter vector",
                    "apply a shader to `s x`, `δ s x`, `s δu` or a fat-texture lookup `T δu x`",
                );
                return Err(());
            }
        };
        let key = (std::ptr::from_ref(s) as usize, bundle.members.clone(), bundle.site, self.under_delta);
        if let Some(&(h, distributed)) = self.inlined.get(&key) {
            self.distributed |= distributed;
            return Ok(h);
        }
        let saved = std::mem::take(&mut self.locals);
        let outer_distributed = std::mem::replace(&mut self.distributed, false);
        self.locals.push((s.input.key(), Value::Bundle(bundle.clone())));
        self.bundles.push(bundle);
        let r = self.nested(&s.name.key(), span, |l| l.shader_body(s, span));
        self.bundles.pop();
        self.locals = saved;
        let distributed = std::mem::replace(&mut self.distributed, outer_distributed);
        self.distributed |= distributed;
        if let Ok(h) = r {
            self.inlined.insert(key, (h, distributed));
        }
        r
    }

    pub(super) fn shader_body(&mut self, s: &'a ast::ShaderDecl, span: Span) -> Res<Handle<Expr>> {
        for p in &s.params {
            let Some(d) = &p.default else {
                let (name, ty) = (p.name.key(), p.ty.as_ref().map_or("scalar", |t| t.value.as_str()));
                self.error(
                    "not-supported",
                    format!("the shader parameter `{name}` has no default: a shader's parameters cannot be set where it is used yet, so each takes its default"),
                    p.name.span,
                    "no default",
                    format!("give it one, `{name}: {ty} = …`; for a value the scene sets, declare `uniform {name} : {ty} = …;` and drop the parameter"),
                );
                return Err(());
            };
            let v = self.lower_expr(d)?;
            let h = self.expect_expr(v, d.span)?;
            let h = self.annotate(h, p.ty.as_ref(), d.span)?;
            self.locals.push((p.name.key(), Value::Expr(h)));
        }
        for l in &s.lets {
            let v = self.lower_expr(&l.value)?;
            self.locals.push((l.name.key(), v));
        }
        let v = self.lower_expr(&s.body)?;
        let h = self.expect_expr(v, s.body.span)?;
        let have = self.module.info(h).ty;
        let want = Ty::from_ast(s.output.value);
        // The declared `s → t` is the type of every use: the declaration is
        // checked (`check_unused`) and each use inlined through this one rule,
        // so a shader that checks where it is declared types alike where it is used.
        let coerced = self.coerce(h, want, s.body.span)?;
        let Some(h) = coerced else {
            self.diagnostics.push(
                Diagnostic::error(
                    "type-mismatch",
                    format!(
                        "the shader `{}` returns a {}, not the declared {}",
                        s.name.key(),
                        have.name(),
                        want.name()
                    ),
                    s.body.span,
                    have.a_name(),
                )
                .with_label(s.output.span, "declared here")
                .with_label(span, "inlined here")
                .with_help(format!("declare it `: s → {}`", have.name())),
            );
            return Err(());
        };
        Ok(h)
    }

    pub(super) fn builtin(&mut self, key: &str, arg: &'a ast::Expr, span: Span) -> Res<Handle<Expr>> {
        let items: Vec<&'a ast::Expr> = match &arg.kind {
            ExprKind::Tuple(items) => items.iter().collect(),
            _ => vec![arg],
        };
        let mut args = Vec::new();
        for i in &items {
            let v = self.lower_expr(i)?;
            args.push(self.expect_expr(v, i.span)?);
        }
        let n_args = |l: &mut Self, n: usize| -> Res<()> {
            if args.len() != n {
                l.error(
                    "arity",
                    format!("`{key}` takes {n} argument(s), got {}", args.len()),
                    span,
                    "wrong number of arguments",
                    format!("write `{key}(…)` with {n} argument(s)"),
                );
                return Err(());
            }
            Ok(())
        };
        use MathFunction::*;
        let fun = match key {
            "dot" => {
                n_args(self, 2)?;
                return self.binary(BinaryOp::Dot, args[0], args[1], span);
            }
            "pow" => {
                n_args(self, 2)?;
                return self.binary(BinaryOp::Pow, args[0], args[1], span);
            }
            "rgb" => return self.compose(args, Some(Ty::Rgb), span),
            "rgba" | "vec4" => return self.compose(args, Some(Ty::Rgba), span),
            "vec2" => return self.compose(args, Some(Ty::Vec2), span),
            "vec3" => return self.compose(args, Some(Ty::Vec3), span),
            "normalize" => Normalize,
            "length" => {
                if let [v] = args[..] {
                    self.warn_unit_length(v, items[0].span);
                }
                Length
            }
            "cross" => Cross,
            "reflect" => Reflect,
            "max" => Max,
            "min" => Min,
            "clamp" => Clamp,
            "saturate" => Saturate,
            "abs" => Abs,
            "sign" => Sign,
            "sqrt" => Sqrt,
            "rsqrt" => Rsqrt,
            "exp" => Exp,
            "log" => Log,
            "sin" => Sin,
            "cos" => Cos,
            "floor" => Floor,
            "fract" => Fract,
            "step" => Step,
            "smoothstep" => Smoothstep,
            "lerp" | "mix" => Mix,
            "expand" => Expand,
            "half_bias" => HalfBias,
            "compress" => Compress,
            other => {
                self.unsupported(format!("the built-in `{other}`"), span);
                return Err(());
            }
        };
        // Componentwise functions take rgb and rgba together by widening.
        if matches!(fun, Max | Min | Clamp | Mix) && args.len() >= 2 {
            let (a, b) = self.widen_pair(args[0], args[1], span)?;
            args[0] = a;
            args[1] = b;
        }
        self.append(Expr::Math { fun, args }, span)
    }

    /// `length(V)` of a direction the scene binder normalizes at each
    /// vertex (every role but `position` and `intensity`): 1 at the
    /// vertices, a little less between them. A user reaching for the
    /// distance to the eye or the light (fog, attenuation) gets a constant;
    /// the help names the `position` vector, whose length in eye space is
    /// that distance.
    fn warn_unit_length(&mut self, v: Handle<Expr>, span: Span) {
        let at = match self.module.exprs[v] {
            Expr::Interpolate { value, .. } => value,
            _ => v,
        };
        let Expr::Vector { vector, .. } = self.module.exprs[at] else { return };
        let decl = &self.module.vectors[vector as usize];
        let Some(kind) =
            decl.kind.filter(|k| !matches!(k, ast::VectorKind::Position | ast::VectorKind::Intensity))
        else {
            return;
        };
        // Once per place: a `let` or shader is lowered again at each use.
        if self.diagnostics.iter().any(|d| d.code == "unit-length" && d.primary.span == span) {
            return;
        }
        let (name, role) = (decl.name.clone(), kind.as_str());
        self.diagnostics.push(
            Diagnostic::warning(
                "unit-length",
                format!("`{name}` is a `{role}` vector, a unit direction: its length is 1 everywhere"),
                span,
                format!("`length({name})` is 1 (a little less where a unit vector is interpolated)"),
            )
            .with_help(
                "for the distance to the eye (fog), declare `vector P : position in eye;` and write \
                 `length(P)`; a light's distance attenuation is in the `intensity` vector",
            ),
        );
    }
}
