//! Reading resources: vertex inputs, pixel values, texture lookups (by unit,
//! projective, sphere-mapped, at the pixel), framebuffer reads and the copy of
//! a pass's own target, depth, and members of a fat texel.
//!
//! Everything that turns an IR node into a texture or buffer access lives
//! here, so the binding rules sit next to the reads that need them.

use super::*;

impl Gen<'_> {
    /// A per-vertex leaf (vertex position, texture coordinate, vector): its
    /// vertex input.
    pub(super) fn vertex_input(&mut self, b: &mut Body, n: ir::Handle<Expr>) -> R<NH> {
        let info = *self.m.info(n);
        if info.freq == Frequency::Texel {
            return self.unsupported("a shading vector as a function of the texel coordinate (texture shading, `s δu`): PassInterface binds per-vertex inputs only", Some(n));
        }
        if b.per_sample() {
            return Err(GenError::Internal(format!(
                "per-vertex value %{} read per sample without δ",
                n.index()
            )));
        }
        let i = self.iface.vertex_leaves.iter().position(|x| *x == n);
        let Some(i) = i else {
            return self.unsupported(
                format!("a {} shading value here (only per-vertex inputs are bound)", info.freq.name()),
                Some(n),
            );
        };
        let a = b.args[i];
        Ok(self.narrow(b, a, 4, width(info.ty)))
    }

    /// The pixel `xs` as a value (`π⁻¹ xs`, `xs.x`), built only if a node
    /// other than a read at the pixel uses it (those use the fragment's own
    /// coordinates).
    pub(super) fn pixel_value(&mut self, b: &mut Body, n: ir::Handle<Expr>) -> R<Option<NH>> {
        if !b.per_sample() {
            return self.unsupported("a pixel position per vertex", Some(n));
        }
        let m = self.m;
        let at_pixel = |e: &Expr| match e {
            Expr::FramebufferRead { position, .. } => *position == n,
            Expr::Lookup { coords, .. } => *coords == n,
            Expr::Depth(p) => *p == n && self.depth_is_fragments(n),
            _ => false,
        };
        if !self.pass_nodes.iter().any(|h| m.exprs[*h].operands().contains(&n) && !at_pixel(&m.exprs[*h])) {
            return Ok(None);
        }
        self.pixel_position(b, n).map(Some)
    }

    /// `π x`: a projection matrix times a position, or sphere-map texgen of
    /// a direction.
    pub(super) fn project(
        &mut self,
        b: &mut Body,
        n: ir::Handle<Expr>,
        projection: &ir::Projection,
        value: ir::Handle<Expr>,
    ) -> R<NH> {
        use naga::BinaryOperator as B;
        let x = b.val(value)?;
        match self.m.info(value).ty {
            Ty::Position => {
                let idx = self
                    .iface
                    .projections
                    .iter()
                    .position(|p| p == projection)
                    .ok_or_else(|| GenError::Internal("projection not in the interface".into()))?;
                let var = self
                    .uniforms_var
                    .ok_or_else(|| GenError::Internal("projection without a block".into()))?;
                let mat = b.load_member(var, idx as u32);
                Ok(self.binop(b, B::Multiply, mat, x))
            }
            Ty::Vec3 => Ok(self.sphere_map(b, x)),
            t => self.unsupported(format!("π of a {}", t.name()), Some(n)),
        }
    }

    /// Sphere-map texgen (Pipeline Grammar, eq. (7)): m = 2·sqrt(Rx² + Ry² + (Rz + 1)²),
    /// (s, t) = (Rx/m + ½, Ry/m + ½).
    pub(super) fn sphere_map(&mut self, b: &mut Body, x: NH) -> NH {
        use naga::BinaryOperator as B;
        let one = b.lit(1.0);
        let zero = b.lit(0.0);
        let vec3 = self.vec_ty(3);
        let off = b.emit(Expression::Compose { ty: vec3, components: vec![zero, zero, one] });
        let r1 = self.binop(b, B::Add, x, off);
        let len = self.math(b, naga::MathFunction::Length, &[r1]);
        let two = b.lit(2.0);
        let mm = self.binop(b, B::Multiply, len, two);
        let xy = self.narrow(b, x, 3, 2);
        let d = self.binop(b, B::Divide, xy, mm);
        let half = b.lit(0.5);
        let h2 = b.emit(Expression::Splat { size: VectorSize::Bi, value: half });
        self.binop(b, B::Add, d, h2)
    }

    /// `z p`: the fragment's own depth, or the GL window depth `½ z/w + ½`
    /// of clip position `p`.
    pub(super) fn depth(&mut self, b: &mut Body, p: ir::Handle<Expr>) -> R<NH> {
        use naga::BinaryOperator as B;
        if self.depth_is_fragments(p) {
            let fc = b.frag_coord.ok_or_else(|| GenError::Internal("no fragment position".into()))?;
            return Ok(b.emit(Expression::AccessIndex { base: fc, index: 2 }));
        }
        let pv = b.val(p)?;
        let z = b.emit(Expression::AccessIndex { base: pv, index: 2 });
        let ww = b.emit(Expression::AccessIndex { base: pv, index: 3 });
        let d = self.binop(b, B::Divide, z, ww);
        let half = b.lit(0.5);
        let d = self.binop(b, B::Multiply, d, half);
        Ok(self.binop(b, B::Add, d, half))
    }

    /// `T x`: the texture's unit sampled at `coords` (projectively for a 2D
    /// texture at a position). A fat texture whose members only are read is
    /// recorded in `b.fat` instead (`None`).
    pub(super) fn lookup(
        &mut self,
        b: &mut Body,
        n: ir::Handle<Expr>,
        texture: ir::TextureId,
        coords: ir::Handle<Expr>,
    ) -> R<Option<Computed>> {
        let m = self.m;
        let w = self.width_of(n);
        let sample = b.per_sample();
        let unit = self.unit_of(n)?;
        let (_, _, kind, format) = self.units[unit];
        let ct = m.info(coords).ty;
        let fat = self.fat[texture as usize] > 0;
        let dual_paraboloid = matches!(self.unit_reads[unit], UnitRead::DualParaboloid(_));
        if matches!(m.exprs[coords], Expr::Pixel { .. }) {
            if dual_paraboloid {
                return self.unsupported("a dual-paraboloid map looked up at the pixel", Some(n));
            }
            return self.lookup_at_pixel(b, n, unit, fat);
        }
        let c = b.val(coords)?;
        if dual_paraboloid {
            let s = self.dual_paraboloid_sample(b, unit, c, width(ct))?;
            let t = self.narrow(b, s, 4, w);
            if matches!(format, Some(TextureFormat::Signed8 | TextureFormat::Signed16)) {
                return Ok(Some(Computed::plain(self.expand(b, t, w))));
            }
            return Ok(Some(Computed::plain(t)));
        }
        if m.textures[texture as usize].kind == TextureKind::Tex3d
            && (m.textures[texture as usize].rendered || m.textures[texture as usize].baked)
        {
            let sampling = m.textures[texture as usize].sampling;
            let s = self.solid_sample(b, (unit, sampling), c, naga::SampleLevel::Zero);
            return Ok(Some(Computed::plain(self.narrow(b, s, 4, w))));
        }
        let coord = match (kind, ct) {
            (TextureKind::Tex1d, _) => {
                let half = b.lit(0.5);
                let vec2 = self.vec_ty(2);
                b.emit(Expression::Compose { ty: vec2, components: vec![c, half] })
            }
            (TextureKind::Tex2d, Ty::Position) => self.projective_uv(b, c),
            _ => c,
        };
        let level = if sample { naga::SampleLevel::Auto } else { naga::SampleLevel::Zero };
        let shader_filter = self.shader_filter(unit, ct);
        if fat && !self.plain_use(n) {
            // Only its members are read (`Expr::FatMember`).
            b.fat.insert(n, (unit, coord, level, shader_filter.is_some()));
            return Ok(None);
        }
        // A fat texture read as a colour: its first layer.
        let s = match shader_filter {
            Some(filter) => {
                let layer = fat.then(|| b.plain(Expression::Literal(Literal::I32(0))));
                self.float_filtered(b, unit, coord, layer, filter)
            }
            None => self.sample_unit(b, unit, coord, fat.then_some(0), level),
        };
        let t = self.narrow(b, s, 4, w);
        if matches!(format, Some(TextureFormat::Signed8 | TextureFormat::Signed16)) {
            return Ok(Some(Computed::plain(self.expand(b, t, w))));
        }
        // A 2D 8-bit texture filters to 8-bit results in
        // hardware precision (`scene_run` uploads it as RGBA8).
        if self.precision == Precision::Fixed9
            && sample
            && shader_filter.is_none()
            && kind != TextureKind::Cube
            && matches!(format, None | Some(TextureFormat::Rgba8 | TextureFormat::Rgb8 | TextureFormat::R8))
        {
            self.on_grid.insert(n);
        }
        Ok(Some(Computed::plain(t)))
    }

    /// `T xs` (Pipeline Grammar, eq. (6)): the texel under the pixel of a screen pass, at
    /// level 0 (a fat framebuffer is one texel per pixel).
    pub(super) fn lookup_at_pixel(
        &mut self,
        b: &mut Body,
        n: ir::Handle<Expr>,
        unit: usize,
        fat: bool,
    ) -> R<Option<Computed>> {
        let Some(uv) = b.texel_uv else {
            return self.unsupported("a lookup at the pixel outside a screen pass", Some(n));
        };
        if fat && !self.plain_use(n) {
            b.fat.insert(n, (unit, uv, naga::SampleLevel::Zero, false));
            return Ok(None);
        }
        let s = self.sample_unit(b, unit, uv, fat.then_some(0), naga::SampleLevel::Zero);
        let w = self.width_of(n);
        Ok(Some(Computed::plain(self.narrow(b, s, 4, w))))
    }

    /// Samples texture unit `unit` at `coordinate`, in array `layer` of a fat
    /// texture.
    pub(super) fn sample_unit(
        &mut self,
        b: &mut Body,
        unit: usize,
        coordinate: NH,
        layer: Option<i32>,
        level: naga::SampleLevel,
    ) -> NH {
        let (tv, sv, _, _) = self.units[unit];
        let image = b.plain(Expression::GlobalVariable(tv));
        let sampler = b.plain(Expression::GlobalVariable(sv));
        let array_index = layer.map(|l| b.plain(Expression::Literal(Literal::I32(l))));
        b.sample(image, sampler, coordinate, array_index, level)
    }

    /// A framebuffer channel (`C`, `α C`, `z C`, stencil): loaded at the
    /// fragment's own pixel, else sampled at the projective coordinate.
    pub(super) fn framebuffer_read(
        &mut self,
        b: &mut Body,
        n: ir::Handle<Expr>,
        framebuffer: ir::FramebufferId,
        channel: FbChannel,
        position: ir::Handle<Expr>,
    ) -> R<NH> {
        let at_pixel =
            matches!(self.m.exprs[position], Expr::Pixel { .. }) || Some(position) == self.own_position;
        let (var, sv) = match self.unit_of(n) {
            Ok(unit) => {
                let (tv, sv, _, _) = self.units[unit];
                (tv, Some(sv))
            }
            Err(_) => (self.own_target_copy(n, framebuffer, channel, at_pixel)?, None),
        };
        let texel = if at_pixel {
            self.load_at_pixel(b, var)?
        } else {
            self.sample_framebuffer(b, var, sv, position, channel)?
        };
        Ok(self.framebuffer_channel(b, texel, channel))
    }

    /// The pass's own target, which blending did not absorb: a copy taken
    /// before the pass, read at the pixel.
    pub(super) fn own_target_copy(
        &mut self,
        n: ir::Handle<Expr>,
        framebuffer: ir::FramebufferId,
        channel: FbChannel,
        at_pixel: bool,
    ) -> R<naga::Handle<GlobalVariable>> {
        let name = self.m.framebuffers[framebuffer as usize].name.clone();
        if !at_pixel {
            return self.unsupported(
                format!("reading the target framebuffer `{name}` away from the fragment's own pixel"),
                Some(n),
            );
        }
        Ok(self.target_copy(&name, channel == FbChannel::Depth, channel == FbChannel::Stencil))
    }

    /// A framebuffer sampled at projective `position`; outside it, its
    /// cleared values (colour 0, depth 1), as the CPU.
    pub(super) fn sample_framebuffer(
        &mut self,
        b: &mut Body,
        var: naga::Handle<GlobalVariable>,
        sv: Option<naga::Handle<GlobalVariable>>,
        position: ir::Handle<Expr>,
        channel: FbChannel,
    ) -> R<NH> {
        let image = b.plain(Expression::GlobalVariable(var));
        let sv = sv.ok_or_else(|| GenError::Internal("a framebuffer read without a sampler".into()))?;
        let p = b.val(position)?;
        let uv = self.projective_uv(b, p);
        let sampler = b.plain(Expression::GlobalVariable(sv));
        let level = if b.per_sample() { naga::SampleLevel::Auto } else { naga::SampleLevel::Zero };
        let texel = b.sample(image, sampler, uv, None, level);
        let inside = self.inside_unit_square(b, uv);
        let clear = b.lit(if channel == FbChannel::Depth { 1.0 } else { 0.0 });
        let clear = b.emit(Expression::Splat { size: VectorSize::Quad, value: clear });
        Ok(b.emit(Expression::Select { condition: inside, accept: texel, reject: clear }))
    }

    /// Whether texture coordinate `uv` lies in the framebuffer (0..1 both).
    pub(super) fn inside_unit_square(&mut self, b: &mut Body, uv: NH) -> NH {
        use naga::BinaryOperator as B;
        let (zero, one) = (b.lit(0.0), b.lit(1.0));
        let (zero2, one2) = (
            b.emit(Expression::Splat { size: VectorSize::Bi, value: zero }),
            b.emit(Expression::Splat { size: VectorSize::Bi, value: one }),
        );
        let above = self.binop(b, B::GreaterEqual, uv, zero2);
        let below = self.binop(b, B::LessEqual, uv, one2);
        let above = b.emit(Expression::Relational { fun: naga::RelationalFunction::All, argument: above });
        let below = b.emit(Expression::Relational { fun: naga::RelationalFunction::All, argument: below });
        self.binop(b, B::LogicalAnd, above, below)
    }

    /// The channel of a framebuffer texel: colour, alpha, depth (in `.x`),
    /// or the stencil value (`.x` as 0..255).
    pub(super) fn framebuffer_channel(&mut self, b: &mut Body, texel: NH, channel: FbChannel) -> NH {
        match channel {
            FbChannel::Color => texel,
            FbChannel::Alpha => b.emit(Expression::AccessIndex { base: texel, index: 3 }),
            FbChannel::Depth => b.emit(Expression::AccessIndex { base: texel, index: 0 }),
            FbChannel::Stencil => {
                let r = b.emit(Expression::AccessIndex { base: texel, index: 0 });
                let k = b.lit(255.0);
                let s = self.binop(b, naga::BinaryOperator::Multiply, r, k);
                self.math(b, naga::MathFunction::Round, &[s])
            }
        }
    }

    /// Member `member` of the fat texel `texel`: layer `member`'s rgb, sampled
    /// where the fat lookup is.
    pub(super) fn fat_member(
        &mut self,
        b: &mut Body,
        n: ir::Handle<Expr>,
        texel: ir::Handle<Expr>,
        member: u8,
    ) -> R<NH> {
        let Some(&(unit, coordinate, level, filtered)) = b.fat.get(&texel) else {
            return Err(GenError::Internal(format!(
                "fat member %{} of %{}, which is not a fat lookup here",
                n.index(),
                texel.index()
            )));
        };
        let s = match self.unit_reads[unit] {
            UnitRead::Float(filter) if filtered => {
                let layer = b.plain(Expression::Literal(Literal::I32(member as i32)));
                self.float_filtered(b, unit, coordinate, Some(layer), filter)
            }
            _ => self.sample_unit(b, unit, coordinate, Some(member as i32), level),
        };
        let w = self.width_of(n);
        Ok(self.narrow(b, s, 4, w))
    }
}

impl Gen<'_> {
    /// `textureLoad(var, pixel, 0)` at the fragment's pixel, once per texture.
    pub(super) fn load_at_pixel(&mut self, b: &mut Body, var: naga::Handle<GlobalVariable>) -> R<NH> {
        if let Some(texel) = b.loads.get(&var) {
            return Ok(*texel);
        }
        let fc = b.frag_coord.ok_or_else(|| GenError::Internal("no fragment position".into()))?;
        let image = b.plain(Expression::GlobalVariable(var));
        let xy = self.narrow(b, fc, 4, 2);
        let ixy = b.emit(Expression::As { expr: xy, kind: ScalarKind::Sint, convert: Some(4) });
        let zero = b.plain(Expression::Literal(Literal::I32(0)));
        let texel = b.emit(Expression::ImageLoad {
            image,
            coordinate: ixy,
            array_index: None,
            sample: None,
            level: Some(zero),
        });
        b.loads.insert(var, texel);
        Ok(texel)
    }

    /// Whether `z p` is the fragment's own depth (`@builtin(position).z`):
    /// `p` is the pass's position or `δ xs`. The depth at a screen pass's
    /// pixel `xs` is the target's, from [`Self::pixel_position`].
    pub(super) fn depth_is_fragments(&self, p: ir::Handle<Expr>) -> bool {
        matches!(self.m.exprs[p], Expr::Pixel { freq: Frequency::Fragment }) || Some(p) == self.own_position
    }

    /// Whether `lookup` (of a fat texture) is used as a colour, not only
    /// through its members.
    pub(super) fn plain_use(&self, lookup: ir::Handle<Expr>) -> bool {
        self.iface.output == lookup
            || self.iface.condition == Some(lookup)
            || self.pass_nodes.iter().any(|h| {
                !matches!(self.m.exprs[*h], Expr::FatMember { .. })
                    && self.m.exprs[*h].operands().contains(&lookup)
            })
    }

    /// The global of the copy of the target framebuffer `name` (its depth,
    /// or colour) taken before the pass: `texture_2d<f32>` bound after the
    /// units' textures and samplers, read with `textureLoad`.
    pub(super) fn target_copy(
        &mut self,
        name: &str,
        depth: bool,
        stencil: bool,
    ) -> naga::Handle<GlobalVariable> {
        if let Some((_, var)) = self
            .target_copies
            .iter()
            .find(|(c, _)| c.framebuffer == name && c.depth == depth && c.stencil == stencil)
        {
            return *var;
        }
        let binding = 1 + 2 * self.units.len() as u32 + self.target_copies.len() as u32;
        let ty = self.ty(TypeInner::Image {
            dim: ImageDimension::D2,
            arrayed: false,
            class: ImageClass::Sampled { kind: ScalarKind::Float, multi: false },
        });
        let aspect = if depth {
            "depth_"
        } else if stencil {
            "stencil_"
        } else {
            ""
        };
        let var_name = format!("{}_{aspect}before", sanitize(name));
        let var = self.module.global_variables.append(
            GlobalVariable {
                name: Some(var_name),
                space: AddressSpace::Handle,
                binding: Some(ResourceBinding { group: 0, binding }),
                ty,
                init: None,
                memory_decorations: Default::default(),
            },
            naga::Span::UNDEFINED,
        );
        self.target_copies.push((TargetCopy { binding, framebuffer: name.to_string(), depth, stencil }, var));
        var
    }

    /// A pixel `xs` (`δ xs`) as a position, as the CPU renderer defines it:
    /// GL normalized device coordinates of the pixel's centre, the depth
    /// there — the target's (a copy taken before the pass) for `xs`, the
    /// fragment's for `δ xs` — mapped to −1..1, and w = 1; what `π⁻¹`
    /// takes back to model space (Pipeline Grammar, Section 3.5, shadow mask).
    pub(super) fn pixel_position(&mut self, b: &mut Body, n: ir::Handle<Expr>) -> R<NH> {
        let Expr::Pixel { freq } = self.m.exprs[n] else {
            return Err(GenError::Internal(format!("%{} is not a pixel", n.index())));
        };
        let (Some(uv), Some(fc)) = (b.texel_uv, b.frag_coord) else {
            return self.unsupported("the position of a pixel outside a screen pass", Some(n));
        };
        use naga::BinaryOperator as B;
        let (one, two) = (b.lit(1.0), b.lit(2.0));
        let u = b.emit(Expression::AccessIndex { base: uv, index: 0 });
        let v = b.emit(Expression::AccessIndex { base: uv, index: 1 });
        let u2 = self.binop(b, B::Multiply, u, two);
        let x = self.binop(b, B::Subtract, u2, one);
        let v2 = self.binop(b, B::Multiply, v, two);
        let y = self.binop(b, B::Subtract, one, v2);
        let depth = if freq == Frequency::Screen {
            let target = match &self.planned.plan.passes[self.pass_index].target {
                RenderTarget::Framebuffer { name, .. } => Some(name.clone()),
                _ => None,
            };
            let with_depth = target
                .as_ref()
                .and_then(|t| self.m.framebuffers.iter().find(|f| f.name == *t))
                .is_some_and(|f| {
                    f.channels.is_empty()
                        || f.channels
                            .iter()
                            .any(|c| matches!(c, crate::parser::ast::FramebufferChannel::Depth))
                });
            match target {
                Some(t) if with_depth => {
                    let var = self.target_copy(&t, true, false);
                    let texel = self.load_at_pixel(b, var)?;
                    b.emit(Expression::AccessIndex { base: texel, index: 0 })
                }
                // No depth buffer: the far plane, as the CPU's cleared depth.
                _ => b.lit(1.0),
            }
        } else {
            b.emit(Expression::AccessIndex { base: fc, index: 2 })
        };
        let d2 = self.binop(b, B::Multiply, depth, two);
        let z = self.binop(b, B::Subtract, d2, one);
        let vec4 = self.vec_ty(4);
        let p = b.emit(Expression::Compose { ty: vec4, components: vec![x, y, z, one] });
        b.name(p, "pixel_position");
        Ok(p)
    }

    pub(super) fn unit_of(&self, lookup: ir::Handle<Expr>) -> R<usize> {
        let pass = &self.planned.plan.passes[self.pass_index];
        pass.textures
            .iter()
            .position(|t| t.lookup as usize == lookup.index())
            .ok_or_else(|| GenError::Internal(format!("lookup %{} has no texture unit", lookup.index())))
    }
}
