//! Statements: the target table a statement writes, its index and the
//! frequency its value must have, and the fit of the value to the target
//! (the δ rules of Pipeline Grammar, Section 3.5).

use super::*;

impl<'a> Lowerer<'a> {
    pub(super) fn statement(&mut self, st: &'a ast::Statement) {
        self.let_cache.clear();
        self.inlined.clear();
        let _ = self.statement_inner(st);
        if let Some(Global::Framebuffer(id)) = self.globals.get(&st.target.table.key()).copied() {
            self.written.insert(id);
        }
        self.surface = None;
        self.texel_volume = false;
        self.statement_freq = None;
        self.sample = None;
    }

    /// Whether a statement target's index starts with a framebuffer's name
    /// (`C δπx` in `s C δπx ← …`).
    pub(super) fn index_names_framebuffer(&self, index: &ast::Expr) -> bool {
        index.head_name().is_some_and(|h| matches!(self.globals.get(&h.key()), Some(Global::Framebuffer(_))))
    }

    pub(super) fn statement_inner(&mut self, st: &'a ast::Statement) -> Res<()> {
        let t = &st.target;
        let key = t.table.key();
        let span = t.span.join(st.value.span);
        let (table, sample) = self.target_table(t, &key)?;
        // Texture shading `T δu ← …`: `s δu` may be taken on the surface.
        if let (Table::Texture(_), Frequency::Texel, ExprKind::Apply { func, arg }) =
            (&table, sample, &t.index.kind)
        {
            if let (FuncKind::Delta, ExprKind::Name(u)) = (&func.kind, &arg.kind) {
                if resolve::family(u) == Some(Entity::TexCoords) && !self.globals.contains_key(&u.key()) {
                    self.surface = Some((self.texcoord_id(u), None));
                }
            }
        }
        self.texel_volume = matches!(table, Table::Texture(id)
            if self.module.textures[id as usize].kind == ast::TextureKind::Tex3d);
        // The index.
        self.statement_freq = Some(sample);
        self.sample = if sample.is_sample() { Some(sample) } else { None };
        let index_value = self.lower_expr(&t.index)?;
        let mut index = self.expect_expr(index_value, t.index.span)?;
        self.check_index(&key, &table, sample, index, t.index.span)?;
        // The value.
        let value = self.lower_expr(&st.value)?;
        let value = match value {
            Value::Bundle(b) if matches!(table, Table::Texture(_)) => {
                let members = self.bundle_members(&b, st.value.span)?;
                self.append(Expr::Bundle(members), st.value.span)?
            }
            v => self.expect_expr(v, st.value.span)?,
        };
        // `s δu` was taken on the surface: the statement rasterizes the mesh
        // in texture space, indexed by `δu x` (as (15) writes it).
        if let Some((_, Some((_, surface_index)))) = self.surface {
            index = surface_index;
        }
        let vi = *self.module.info(value);
        // Frequencies: the value must be computable where the statement runs.
        self.check_value_freq(vi.freq, sample, st.value.span)?;
        // Types: what the table holds.
        let value = self.fit_value(&table, index, value, vi.ty, st.value.span)?;
        self.module.statements.push(Statement {
            table,
            index,
            freq: sample,
            value,
            span,
            target_span: t.span,
        });
        Ok(())
    }

    /// The table a statement's target writes into, and the frequency the
    /// statement runs at: per fragment or per pixel for a framebuffer, per
    /// texel or fragment for a texture, per vertex for texgen.
    pub(super) fn target_table(&mut self, t: &'a ast::Target, key: &str) -> Res<(Table, Frequency)> {
        let has_delta = contains(
            &t.index,
            &|e| matches!(&e.kind, ExprKind::Apply { func, .. } if func.kind == FuncKind::Delta),
        );
        let has_pi = contains(
            &t.index,
            &|e| matches!(&e.kind, ExprKind::Apply { func, .. } if matches!(func.kind, FuncKind::Projection(_))),
        );
        let channel = match t.channel.as_ref().map(|c| c.value) {
            None => FbChannel::Color,
            Some(ast::Channel::Alpha) => FbChannel::Alpha,
            Some(ast::Channel::Depth) => FbChannel::Depth,
            Some(ast::Channel::Stencil) => FbChannel::Stencil,
        };
        let (table, sample) = match (self.globals.get(key).copied(), resolve::family(&t.table)) {
            (Some(Global::Framebuffer(id)), _) => (
                Table::Framebuffer { id, channel },
                if has_delta { Frequency::Fragment } else { Frequency::Screen },
            ),
            (None, Some(Entity::Framebuffer)) => {
                let id = self.framebuffer_id(&t.table, Vec::new());
                (
                    Table::Framebuffer { id, channel },
                    if has_delta { Frequency::Fragment } else { Frequency::Screen },
                )
            }
            (Some(Global::Texture(id)), _) => {
                if !has_delta {
                    self.unsupported("rendering into a texture without δ (write `T δu` or `T δπx`)", t.span);
                    return Err(());
                }
                (Table::Texture(id), if has_pi { Frequency::Fragment } else { Frequency::Texel })
            }
            (None, Some(Entity::TexCoords)) => {
                (Table::TexCoords(self.texcoord_id(&t.table)), Frequency::Vertex)
            }
            _ if matches!(key, "a" | "s") && self.index_names_framebuffer(&t.index) => {
                // seeds/001 as printed: `s C δπx ← …` is σ, `a C xs ← …` α.
                let (sym, word) = if key == "s" { ("σ", "stencil") } else { ("α", "alpha") };
                self.diagnostics.push(
                    Diagnostic::error("unknown-name", format!("`{key}` is not a table"), t.table.span, "assigned into here").with_help(format!(
                        "did you mean `{sym}` (ASCII `{word}`), the framebuffer's {word} channel: `{sym} C δπx ← …`? Pipeline Grammar as printed (the Symbol font) shows `{sym}` as `{key}`"
                    )),
                );
                return Err(());
            }
            _ => {
                self.unsupported(format!("assigning into `{key}`"), t.table.span);
                return Err(());
            }
        };
        Ok((table, sample))
    }

    /// Refuses an index the table cannot be indexed by at `sample`.
    pub(super) fn check_index(
        &mut self,
        key: &str,
        table: &Table,
        sample: Frequency,
        index: Handle<Expr>,
        span: Span,
    ) -> Res<()> {
        let ii = *self.module.info(index);
        let index_ok = match table {
            Table::Framebuffer { .. } => ii.ty == Ty::Position && ii.freq == sample,
            Table::Texture(_) if sample == Frequency::Fragment => ii.ty == Ty::Position && ii.freq == sample,
            Table::Texture(_) => ii.ty == Ty::Vec2 && ii.freq == Frequency::Texel,
            Table::TexCoords(_) => ii.ty == Ty::Position && ii.freq == Frequency::Vertex,
        };
        if !index_ok {
            self.error(
                "bad-target",
                format!("`{key}` cannot be indexed by a {} {}", ii.freq.name(), ii.ty.name()),
                span,
                "unexpected index",
                "write `C δπx` (fragments), `C xs` (a screen pass), `T δu` (texture shading), `T δπx` (render to texture) or `u x` (texgen)",
            );
            return Err(());
        }
        Ok(())
    }

    /// Refuses a value not computable where the statement runs (`sample`).
    pub(super) fn check_value_freq(&mut self, freq: Frequency, sample: Frequency, span: Span) -> Res<()> {
        if freq.join(sample).is_none() || (freq == Frequency::Vertex && sample.is_sample()) {
            let help = if freq == Frequency::Vertex {
                "interpolate it: right of δ is per vertex, left of δ per fragment (e.g. `δ p s x`)"
                    .to_string()
            } else {
                format!(
                    "this target is written {}; compute the value there, or write it in another statement",
                    sample.name()
                )
            };
            self.error(
                "frequency",
                format!("a {} value is assigned to a {} target", freq.name(), sample.name()),
                span,
                format!("{} value", freq.name()),
                help,
            );
            return Err(());
        }
        Ok(())
    }

    /// A vec3 written as a colour is most often a constant tuple scaled by
    /// scalars (`(0.8, 0.7, 0.6) * shadow * max(0, N·L)`): a tuple is a
    /// vec3, and only `rgb(…)` or a colour operand makes it a colour. The
    /// last diagnostic gets a label at the first tuple written inside
    /// `span`, naming its `rgb(…)`.
    fn label_vec3_tuple(&mut self, span: Span) {
        let inside = |t: &Span| t.start >= span.start && t.end <= span.end;
        let Some(&(at, [r, g, b])) = self.vec3_tuples.iter().find(|(t, _)| inside(t)) else { return };
        if let Some(d) = self.diagnostics.last_mut() {
            *d =
                d.clone().with_label(at, format!("this tuple is a vec3: `rgb({r}, {g}, {b})` is the colour"));
        }
    }

    /// The value as the table holds it (rgb widened to rgba, a position
    /// into a depth buffer as its depth); records a texgen's type.
    pub(super) fn fit_value(
        &mut self,
        table: &Table,
        index: Handle<Expr>,
        mut value: Handle<Expr>,
        ty: Ty,
        span: Span,
    ) -> Res<Handle<Expr>> {
        match table {
            Table::Framebuffer { channel, .. } => {
                let want = match channel {
                    FbChannel::Color => Ty::Rgba,
                    _ => Ty::Scalar,
                };
                value = match (ty, want) {
                    (a, b) if a == b => value,
                    (Ty::Rgb, Ty::Rgba) | (Ty::Scalar, Ty::Rgba) => {
                        self.append(Expr::Convert { value, to: Ty::Rgba }, span)?
                    }
                    // `Cl δπl x ← δ x` (shadow mask): a position written into a depth
                    // buffer stores the depth of the fragment being written, in the
                    // projection of the index (πl here) — what the depth test compares.
                    (Ty::Position, _) if *channel == FbChannel::Depth || self.is_depth_only(table) => {
                        self.append(Expr::Depth(index), span)?
                    }
                    (have, want) => {
                        self.error("type-mismatch", format!("{} is written into {} channel", have.a_name(), want.a_name()), span, have.a_name(), if have == Ty::Vec3 { "a vec3 is a direction: write a colour into a framebuffer (`rgb(v)` reads a vec3 as one, `rgb(r, g, b)` is a constant colour), a scalar into α, z or σ" } else { "write a colour (rgb or rgba) into a framebuffer, a scalar into α, z or σ" });
                        if have == Ty::Vec3 {
                            self.label_vec3_tuple(span);
                        }
                        return Err(());
                    }
                };
            }
            Table::Texture(id) => {
                let tex = &self.module.textures[*id as usize];
                let (texel, _) = valid::texel_type(tex.kind, tex.format);
                let name = tex.name.clone();
                value = match (ty, texel) {
                    (a, b) if a == b => value,
                    (Ty::Bundle(_), _) => value,
                    (Ty::Rgb, Ty::Rgba) | (Ty::Scalar, Ty::Rgba) => {
                        self.append(Expr::Convert { value, to: Ty::Rgba }, span)?
                    }
                    (Ty::Vec3, Ty::Rgb) | (Ty::Rgb, Ty::Vec3) => value,
                    (have, want) => {
                        self.error(
                            "type-mismatch",
                            format!("{} is written into the texture `{name}` of {} texels", have.a_name(), want.name()),
                            span,
                            have.a_name(),
                            if want == Ty::Scalar {
                                "the texture's one-channel texels hold a scalar: compute one (a shader `s → scalar`, or a channel such as `.r`), or declare the texture `rgb8`"
                            } else {
                                "change the texture's format, or the value"
                            },
                        );
                        return Err(());
                    }
                };
            }
            Table::TexCoords(set) => {
                if !matches!(ty, Ty::Scalar | Ty::Vec2 | Ty::Vec3) {
                    self.error(
                        "type-mismatch",
                        format!("texture coordinates cannot be {}", ty.a_name()),
                        span,
                        ty.a_name(),
                        "generate a scalar, vec2 or vec3 (Pipeline Grammar, eq. (7))",
                    );
                    return Err(());
                }
                let set = &mut self.module.texcoord_sets[*set as usize];
                set.ty = ty;
                set.generated = true;
            }
        }
        Ok(value)
    }

    pub(super) fn is_depth_only(&self, table: &Table) -> bool {
        match table {
            Table::Framebuffer { id, .. } => {
                let ch = &self.module.framebuffers[*id as usize].channels;
                !ch.is_empty()
                    && ch.iter().all(|c| {
                        matches!(c, ast::FramebufferChannel::Depth | ast::FramebufferChannel::Stencil)
                    })
            }
            _ => false,
        }
    }
}
