//! The shader interface: global resources (uniforms, textures, samplers,
//! render-to-texture targets), the vertex and fragment entry points and the
//! varyings between them, and the output of a fat-texel pass.
//!
//! What the runner binds is decided here; `gpu::runner` reads it back through
//! `PassShader`.

use super::*;

impl Gen<'_> {
    pub(super) fn globals(&mut self) -> R<()> {
        self.uniform_globals();
        self.texture_globals()
    }

    /// The `Uniforms` block at binding 0: the projections (`mat4`), then
    /// the uniforms (`vec4`), if the pass reads any.
    fn uniform_globals(&mut self) {
        let mat4 = self.ty(TypeInner::Matrix {
            columns: VectorSize::Quad,
            rows: VectorSize::Quad,
            scalar: Scalar::F32,
        });
        let vec4 = self.vec_ty(4);
        let mut members = Vec::new();
        let mut offset = 0;
        for p in self.iface.projections.clone() {
            let name = if p.inverse {
                "pi_inv".to_string()
            } else {
                format!(
                    "pi{}{}",
                    p.subscript.as_deref().map(|s| format!("_{}", sanitize(s))).unwrap_or_default(),
                    if p.star { "_star" } else { "" }
                )
            };
            members.push(StructMember { name: Some(name), ty: mat4, binding: None, offset });
            offset += 64;
        }
        for u in self.iface.uniforms.clone() {
            let name = sanitize(&self.m.uniforms[u as usize].name);
            members.push(StructMember { name: Some(name), ty: vec4, binding: None, offset });
            offset += 16;
        }
        if !members.is_empty() {
            let ty = self.module.types.insert(
                Type { name: Some("Uniforms".into()), inner: TypeInner::Struct { members, span: offset } },
                naga::Span::UNDEFINED,
            );
            self.uniforms_var = Some(self.module.global_variables.append(
                GlobalVariable {
                    name: Some("uniforms".into()),
                    space: AddressSpace::Uniform,
                    binding: Some(ResourceBinding { group: 0, binding: 0 }),
                    ty,
                    init: None,
                    memory_decorations: Default::default(),
                },
                naga::Span::UNDEFINED,
            ));
        }
    }

    /// Each texture unit of the pass: its image at binding `1 + 2·unit`,
    /// its sampler at `2 + 2·unit`.
    fn texture_globals(&mut self) -> R<()> {
        let pass = &self.planned.plan.passes[self.pass_index];
        for t in &pass.textures {
            let node = self.planned.handle(t.lookup);
            let read = self.unit_read(node);
            let (kind, format, arrayed) = match self.m.exprs.arena().get(node) {
                // A scene's dual-paraboloid map: its two faces as layers.
                Some(Expr::Lookup { texture, .. }) if matches!(read, UnitRead::DualParaboloid(_)) => {
                    (TextureKind::Tex2d, Some(self.m.textures[*texture as usize].format), true)
                }
                Some(Expr::Lookup { texture, .. }) => {
                    let tex = &self.m.textures[*texture as usize];
                    let fat = self.fat[*texture as usize] > 0;
                    if fat && tex.kind != TextureKind::Tex2d {
                        return self.unsupported(
                            format!(
                                "a fat {} texture (fat texels are stored as the layers of a 2-D array)",
                                tex.kind.as_str()
                            ),
                            Some(node),
                        );
                    }
                    // A rendered 3-D texture is its slices tiled in 2-D (`codegen::solid`).
                    let tiled = tex.kind == TextureKind::Tex3d && (tex.rendered || tex.baked);
                    (if tiled { TextureKind::Tex2d } else { tex.kind }, Some(tex.format), fat)
                }
                Some(Expr::FramebufferRead { .. }) => (TextureKind::Tex2d, None, false),
                _ => return Err(GenError::Internal(format!("texture unit {} is not a lookup", t.unit))),
            };
            let dim = match kind {
                TextureKind::Tex1d | TextureKind::Tex2d => ImageDimension::D2,
                TextureKind::Tex3d => ImageDimension::D3,
                TextureKind::Cube => ImageDimension::Cube,
            };
            let ity = self.ty(TypeInner::Image {
                dim,
                arrayed,
                class: ImageClass::Sampled { kind: ScalarKind::Float, multi: false },
            });
            let sty = self.ty(TypeInner::Sampler { comparison: false });
            let name = sanitize(&t.texture);
            let tv = self.module.global_variables.append(
                GlobalVariable {
                    name: Some(name.clone()),
                    space: AddressSpace::Handle,
                    binding: Some(ResourceBinding { group: 0, binding: 1 + 2 * t.unit }),
                    ty: ity,
                    init: None,
                    memory_decorations: Default::default(),
                },
                naga::Span::UNDEFINED,
            );
            let sv = self.module.global_variables.append(
                GlobalVariable {
                    name: Some(format!("{name}_sampler")),
                    space: AddressSpace::Handle,
                    binding: Some(ResourceBinding { group: 0, binding: 2 + 2 * t.unit }),
                    ty: sty,
                    init: None,
                    memory_decorations: Default::default(),
                },
                naga::Span::UNDEFINED,
            );
            self.units.push((tv, sv, kind, format));
            self.unit_reads.push(read);
        }
        Ok(())
    }

    pub(super) fn vertex(&mut self, vout: naga::Handle<Type>) -> R<Function> {
        let mut b = Body::new(VERTEX_ENTRY, Stage::Vertex);
        let vec4 = self.vec_ty(4);
        let leaves = self.iface.vertex_leaves.clone();
        for (i, leaf) in leaves.iter().enumerate() {
            let name = self.value_name(*leaf).unwrap_or_else(|| format!("in{i}"));
            b.f.arguments.push(FunctionArgument {
                name: Some(name),
                ty: vec4,
                binding: Some(location(i as u32)),
            });
            let arg = b.plain(Expression::FunctionArgument(i as u32));
            b.args.push(arg);
        }
        let quad = if self.quad {
            let i = leaves.len() as u32;
            b.f.arguments.push(FunctionArgument {
                name: Some("quad".into()),
                ty: vec4,
                binding: Some(location(i)),
            });
            Some(b.plain(Expression::FunctionArgument(i)))
        } else {
            None
        };
        // Per-vertex nodes, in topological order.
        let mut roots: Vec<ir::Handle<Expr>> = vec![];
        for h in &self.iface.interpolants {
            if let Expr::Interpolate { value, .. } = self.m.exprs[*h] {
                roots.push(value);
            }
        }
        roots.extend(self.iface.position);
        for n in self.m.reachable(&roots) {
            self.node(&mut b, n)?;
        }
        // The clip position.
        let clip = match (self.iface.position, quad) {
            (Some(p), _) if !self.quad => {
                let v = b.vals[&p];
                match self.m.info(p).ty {
                    Ty::Position => v,
                    Ty::Vec2 => texture_space_clip(&mut b, v, vec4),
                    t => {
                        return self
                            .unsupported(format!("a pass positioned by a {} value", t.name()), Some(p))
                    }
                }
            }
            (_, Some(q)) => q,
            _ => return Err(GenError::Internal("no clip position".into())),
        };
        let position = wgpu_clip(&mut b, clip, vec4);
        b.name(position, "clip_position");
        let mut comps = vec![position];
        for h in self.iface.interpolants.clone() {
            let Expr::Interpolate { value, .. } = self.m.exprs[h] else { unreachable!() };
            let v = b.vals[&value];
            let wv = self.widen_zero(&mut b, v, width(self.m.info(value).ty));
            comps.push(wv);
        }
        if let Some(q) = quad {
            comps.push(texel_uv(&mut b, q, vec4));
        }
        let out = b.emit(Expression::Compose { ty: vout, components: comps });
        b.f.body.push(Statement::Return { value: Some(out) }, naga::Span::UNDEFINED);
        b.f.result = Some(FunctionResult { ty: vout, binding: None });
        Ok(b.f)
    }

    /// Whether this pass renders into a texture held in half floats (a
    /// 16-bit or float format: `Rgba16Float` on wgpu, `ColorFormat::F16`
    /// on the CPU).
    pub(super) fn renders_half_floats(&self) -> bool {
        self.planned.setup(self.pass_index).target.format == crate::pipeline::TargetFormat::Half
    }

    pub(super) fn fragment(&mut self, vout: naga::Handle<Type>) -> R<Function> {
        let mut b = Body::new(FRAGMENT_ENTRY, Stage::Fragment);
        b.f.arguments.push(FunctionArgument { name: Some("input".into()), ty: vout, binding: None });
        let input = b.plain(Expression::FunctionArgument(0));
        let fc = b.emit(Expression::AccessIndex { base: input, index: 0 });
        b.frag_coord = Some(fc);
        for (k, h) in self.iface.interpolants.clone().into_iter().enumerate() {
            let v = b.emit(Expression::AccessIndex { base: input, index: k as u32 + 1 });
            let w = width(self.m.info(h).ty);
            let v = self.narrow(&mut b, v, 4, w);
            if let Some(n) = self.value_name(h) {
                b.name(v, &n);
            }
            b.vals.insert(h, v);
        }
        if self.quad {
            let uv4 = b.emit(Expression::AccessIndex {
                base: input,
                index: self.iface.interpolants.len() as u32 + 1,
            });
            let uv = self.narrow(&mut b, uv4, 4, 2);
            b.texel_uv = Some(uv);
        }
        let pass = &self.planned.plan.passes[self.pass_index];
        let stencil_only =
            matches!(&pass.target, RenderTarget::Framebuffer { channels, .. } if channels == "stencil");
        let vec4 = self.vec_ty(4);
        if stencil_only && pass.state.alpha_test.is_disabled() {
            // No colour is written: the depth and stencil state do the work,
            // after the discard of a conditional stencil write (with an
            // alpha test, the combiners compute the alpha it tests).
            self.combiners = None;
        }
        let out = if stencil_only && self.iface.condition.is_none() {
            b.plain(Expression::ZeroValue(vec4))
        } else if let Some(g) = self.combiners.clone() {
            self.fragment_combiners(&mut b, &g)?
        } else {
            let mut roots = vec![self.iface.output];
            roots.extend(self.iface.condition.into_iter().chain(self.iface.depth));
            let reach = ir::fragment_reach(self.m, &roots);
            self.address = ir::address_only(self.m, &reach);
            self.register_reads = ir::register_reads(self.m, &reach);
            self.pass_nodes = self.fragment_nodes(&roots);
            for n in self.pass_nodes.clone() {
                self.node(&mut b, n)?;
            }
            if let Some(c) = self.iface.condition {
                let cv = b.vals[&c];
                self.discard_unless(&mut b, cv);
            }
            let o = self.iface.output;
            let ty = self.m.info(o).ty;
            let v = if matches!(ty, Ty::Bundle(_)) { b.lit(0.0) } else { b.vals[&o] };
            match ty {
                Ty::Scalar => b.emit(Expression::Splat { size: VectorSize::Quad, value: v }),
                Ty::Vec2 => {
                    let zero = b.lit(0.0);
                    let one = b.lit(1.0);
                    b.emit(Expression::Compose { ty: vec4, components: vec![v, zero, one] })
                }
                Ty::Vec3 | Ty::Rgb => {
                    let one = b.lit(1.0);
                    b.emit(Expression::Compose { ty: vec4, components: vec![v, one] })
                }
                Ty::Rgba | Ty::Position => v,
                Ty::Bundle(_) => return self.fat_texel_output(b, o, vec4),
            }
        };
        let out = if self.renders_half_floats() { self.round_to_half(&mut b, out) } else { out };
        if let Some(d) = self.iface.depth {
            return self.depth_replaced_output(b, out, d);
        }
        b.f.body.push(Statement::Return { value: Some(out) }, naga::Span::UNDEFINED);
        b.f.result = Some(FunctionResult { ty: vec4, binding: Some(location(0)) });
        Ok(b.f)
    }

    /// A fat texel (Pipeline Grammar, eq. (5), (15)): member i to colour attachment i
    /// — layer i of the fat texture — as rgb, alpha 1; the function's
    /// result is a struct of the members.
    pub(super) fn fat_texel_output(
        &mut self,
        mut b: Body,
        o: ir::Handle<Expr>,
        vec4: naga::Handle<Type>,
    ) -> R<Function> {
        let Expr::Bundle(members) = self.m.exprs[o].clone() else {
            return Err(GenError::Internal("a bundle-typed value that is not a bundle".into()));
        };
        let mut comps = Vec::new();
        let mut fields = Vec::new();
        for (i, h) in members.iter().enumerate() {
            let v = b
                .vals
                .get(h)
                .copied()
                .ok_or_else(|| GenError::Internal(format!("member %{} not computed", h.index())))?;
            let one = b.lit(1.0);
            let c = match width(self.m.info(*h).ty) {
                3 => b.emit(Expression::Compose { ty: vec4, components: vec![v, one] }),
                w => self.widen_zero(&mut b, v, w),
            };
            let c = if self.renders_half_floats() { self.round_to_half(&mut b, c) } else { c };
            comps.push(c);
            let name = match &self.m.exprs[*h] {
                Expr::Interpolate { value, .. } => self.value_name(*value),
                _ => self.value_name(*h),
            }
            .unwrap_or_else(|| format!("member{i}"));
            fields.push(StructMember {
                name: Some(name),
                ty: vec4,
                binding: Some(location(i as u32)),
                offset: 16 * i as u32,
            });
        }
        let n = fields.len() as u32;
        let ty = self.module.types.insert(
            Type {
                name: Some("FatTexel".into()),
                inner: TypeInner::Struct { members: fields, span: 16 * n },
            },
            naga::Span::UNDEFINED,
        );
        let out = b.emit(Expression::Compose { ty, components: comps });
        b.f.body.push(Statement::Return { value: Some(out) }, naga::Span::UNDEFINED);
        b.f.result = Some(FunctionResult { ty, binding: None });
        self.outputs = n;
        Ok(b.f)
    }
}

impl Gen<'_> {
    /// The nodes the fragment stage computes: reachable from `roots`, not
    /// looking under δ (the varyings), in topological order.
    pub(super) fn fragment_nodes(&self, roots: &[ir::Handle<Expr>]) -> Vec<ir::Handle<Expr>> {
        let mut seen = BTreeSet::new();
        let mut stack = roots.to_vec();
        while let Some(n) = stack.pop() {
            if !seen.insert(n) {
                continue;
            }
            if !matches!(self.m.exprs[n], Expr::Interpolate { .. }) {
                stack.extend(self.m.operands(n));
            }
        }
        seen.into_iter().collect()
    }

    pub(super) fn discard_unless(&mut self, b: &mut Body, cond: NH) {
        let fails = match b.bools.get(&cond) {
            Some(c) => b.emit(Expression::Unary { op: naga::UnaryOperator::LogicalNot, expr: *c }),
            None => {
                let zero = b.lit(0.0);
                b.emit(Expression::Binary { op: naga::BinaryOperator::Equal, left: cond, right: zero })
            }
        };
        let mut accept = naga::Block::new();
        accept.push(Statement::Kill, naga::Span::UNDEFINED);
        b.f.body.push(
            Statement::If { condition: fails, accept, reject: naga::Block::new() },
            naga::Span::UNDEFINED,
        );
    }
}

/// `@location(i)` with the default interpolation.
pub(super) fn location(i: u32) -> Binding {
    Binding::Location {
        location: i,
        interpolation: None,
        sampling: None,
        blend_src: None,
        per_primitive: false,
    }
}
