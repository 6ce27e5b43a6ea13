//! The fragment stage of one pass ([`FragmentProgram`]): runs the steps per
//! fragment in the mode's arithmetic, samples the texture units (or, in
//! `exact`, evaluates what a lookup table tabulates, [`exact_lookup`]),
//! reads framebuffers and, in `fixed9` with a generated setup, loads the
//! combiner registers and runs the emulator.

use std::cell::RefCell;
use std::collections::{BTreeMap, HashMap};
use std::sync::atomic::{AtomicU64, Ordering};

use crate::backends::combiners::{PixelEmulator, PixelRegisters};
use crate::ir::{self, eval::Value, Expr, FbChannel, Frequency, Handle, Module, TextureId, Ty};
use crate::pipeline::{Geometry, PassInterface, RenderTarget};
use crate::renderer::raster::Vary;
use crate::renderer::{Fragment, FragmentResult, FragmentStage, Framebuffer, RenderError};
use crate::scene::bind::{self, BoundObject, BoundTexture, ExactFunction};
use crate::textures::{generators, unit, Filter, Texture, Texture2D, Wrap};

use crate::numerics::{fixed9_folded_with, fixed9_quotient, fixed9_with, Precision};

use super::lanes;
use super::program::{Leaf, RegisterOp, Step, StepBuilder};
use super::targets::{fat_texel_layers, Rendered};
use super::{CombinerSetup, PlanRenderer, RoundingBias};

/// What a texture unit reads in this pass.
pub(super) enum Source<'r> {
    Bound {
        texture: &'r BoundTexture,
        exact: Option<ExactFunction>,
    },
    Rendered(&'r Rendered),
    /// `exact`: a texture shaded over its texels (`bake(f)`, Pipeline Grammar
    /// (13)) is not sampled; the texel pass's function is evaluated at the
    /// lookup's coordinates (no lookup tables in the reference).
    Baked {
        program: Box<FragmentProgram<'r>>,
        wrap: Wrap,
    },
    Missing,
}

/// The fragment stage of one pass: the reachable nodes of the output (and
/// condition) in topological order, each with a slot.
pub(super) struct FragmentProgram<'a> {
    pub(super) module: &'a Module,
    pub(super) mode: Precision,
    pub(super) steps: Vec<Step<'a>>,
    pub(super) constants: Vec<(u32, Value)>,
    pub(super) n_slots: usize,
    pub(super) output: u32,
    pub(super) output_ty: Ty,
    pub(super) condition: Option<u32>,
    /// The slot of the depth the fragment takes, when the pass replaces it.
    pub(super) depth: Option<u32>,
    pub(super) sources: Vec<Source<'a>>,
    /// Per texture: the layers of its fat texels, rendered by a bundle pass.
    pub(super) fat: Vec<Vec<&'a Rendered>>,
    pub(super) reads: HashMap<u32, Framebuffer>,
    pub(super) own: Option<Framebuffer>,
    pub(super) filters: Vec<Filter>,
    /// fixed9 with a generated setup: the machine, and the slots of the
    /// values that load texture 0-3, primary and secondary.
    pub(super) combiners: Option<(PixelEmulator, [Option<u32>; 6])>,
    /// fixed9 with a generated setup whose pass has an alpha test: it
    /// decides on the machine's 8-bit alpha, and the IR condition is not
    /// evaluated (`condition` is `None`).
    pub(super) alpha_test: Option<crate::pipeline::AlphaTest>,
    /// Fragments whose value was not finite ([`Frame::nonfinite`]).
    pub(super) nonfinite: AtomicU64,
    /// [`PlanRenderer::set_rounding_bias`] (zero: the model).
    pub(super) tie: RoundingBias,
    /// [`PlanRenderer::set_sampling_latitude`].
    pub(super) latitude: unit::Latitude,
    /// [`PlanRenderer::set_batched`].
    pub(super) batched: bool,
    /// The `f32` mode's program compiled into lane code (batched only).
    pub(super) lanes: Option<lanes::LaneProgram>,
}

thread_local! {
    static SLOTS: RefCell<Vec<Value>> = const { RefCell::new(Vec::new()) };
    /// Slots and varyings of a quad neighbour ([`FragmentProgram::quad_coords`]).
    static QUAD_SCRATCH: RefCell<(Vec<Value>, Vec<f32>)> = const { RefCell::new((Vec::new(), Vec::new())) };
}

impl<'a> FragmentProgram<'a> {
    // Each argument is one of the pass's inputs, owned or borrowed differently.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn new(
        r: &'a PlanRenderer<'a>,
        mode: Precision,
        pi: &PassInterface,
        rendered: &'a BTreeMap<String, Rendered>,
        reads: HashMap<u32, Framebuffer>,
        own: Option<Framebuffer>,
        setup: Option<CombinerSetup>,
        first_object: Option<&BoundObject>,
    ) -> Result<FragmentProgram<'a>, RenderError> {
        let m = &r.planned.module;
        // With combiners the IR computes only what loads the registers.
        let mut roots = match &setup {
            Some(c) => c.registers.iter().flatten().copied().collect(),
            None => vec![pi.output],
        };
        let alpha_test = setup.as_ref().and_then(|c| c.alpha_test);
        let condition = pi.condition.filter(|_| alpha_test.is_none());
        roots.extend(condition.into_iter().chain(pi.depth));
        let n = m.exprs.len();
        let reach = ir::fragment_reach(m, &roots);
        let (sources, filters) = FragmentProgram::texture_sources(r, mode, rendered, &reach)?;
        let fat = fat_texel_layers(m, rendered);
        let steps_of = StepBuilder {
            r,
            mode,
            combiners: setup.is_some(),
            // Nodes that only address textures or framebuffers (not quantized in fixed9).
            address: ir::address_only(m, &reach),
            register_reads: ir::register_reads(m, &reach),
            varying_of: pi.interpolants.iter().enumerate().map(|(k, h)| (*h, k)).collect(),
            sources: &sources,
            fat: &fat,
            first_object,
        };
        let mut slot_of = vec![u32::MAX; n];
        let mut steps = Vec::new();
        let mut constants = Vec::new();
        let mut n_slots = 0u32;
        for i in (0..n).filter(|&i| reach[i]) {
            let h = Handle::new(i);
            let expr = &m.exprs[h];
            let slot = n_slots;
            n_slots += 1;
            slot_of[i] = slot;
            if let Expr::Constant(c) = expr {
                constants.push((slot, steps_of.constant(i, c)));
                continue;
            }
            let (leaf, ops, n_ops) = steps_of.leaf_and_operands(h, expr, &slot_of)?;
            steps.push(steps_of.step(h, expr, slot, ops, n_ops, leaf));
        }
        let combiners = setup.map(|c| (c.machine, c.registers.map(|h| h.map(|h| slot_of[h.index()]))));
        let mut program = FragmentProgram {
            module: m,
            mode,
            steps,
            constants,
            n_slots: n_slots as usize,
            output: slot_of[pi.output.index()],
            output_ty: m.info(pi.output).ty,
            condition: condition.map(|c| slot_of[c.index()]),
            depth: pi.depth.map(|d| slot_of[d.index()]),
            sources,
            fat,
            reads,
            own,
            filters,
            combiners,
            alpha_test,
            nonfinite: AtomicU64::new(0),
            tie: r.rounding_bias,
            // The tie pictures move a nearest lookup's coordinates too.
            latitude: unit::Latitude { nearest_shift: r.rounding_bias.texel_quanta / 256.0, ..r.latitude },
            batched: r.batched,
            lanes: None,
        };
        if mode == Precision::F32 && program.combiners.is_none() && lanes::enabled() {
            program.lanes = Some(lanes::LaneProgram::compile(&program));
        }
        Ok(program)
    }

    /// Per texture of the module, what its unit reads in this pass and
    /// with which filter (`reach`: the pass's reachable nodes).
    pub(super) fn texture_sources(
        r: &'a PlanRenderer<'a>,
        mode: Precision,
        rendered: &'a BTreeMap<String, Rendered>,
        reach: &[bool],
    ) -> Result<(Vec<Source<'a>>, Vec<Filter>), RenderError> {
        let m = &r.planned.module;
        let textures = if mode == Precision::Exact { &r.exact } else { &r.stored };
        let mut sources = Vec::with_capacity(m.textures.len());
        let mut filters = Vec::with_capacity(m.textures.len());
        let looked_up: std::collections::HashSet<TextureId> = (0..m.exprs.len())
            .filter(|&i| reach[i])
            .filter_map(|i| match &m.exprs[Handle::new(i)] {
                Expr::Lookup { texture, .. } => Some(*texture),
                _ => None,
            })
            .collect();
        for (id, t) in m.textures.iter().enumerate() {
            let decl = r.decls.iter().find(|d| d.name == t.name);
            // A texture the planner made (an alpha ramp, a normalization
            // cube map) has no declaration: its own sampling (the ramp's
            // nearest — sampled bilinearly, its 8-bit steps blended, a
            // stored step then compared against a blend of two).
            filters.push(decl.map_or(t.sampling.filter, |d| d.filter));
            let baked = match FragmentProgram::baked_by(r, &t.name) {
                Some(index)
                    if mode == Precision::Exact
                        && looked_up.contains(&(id as TextureId))
                        && t.kind != crate::parser::ast::TextureKind::Tex3d =>
                {
                    FragmentProgram::baked(r, mode, rendered, index)?
                }
                _ => None,
            };
            sources.push(if let Some(b) = textures.get(&t.name) {
                Source::Bound { texture: b, exact: if mode == Precision::Exact { b.exact } else { None } }
            } else if let Some(program) = baked {
                Source::Baked { program: Box::new(program), wrap: decl.map_or(Wrap::ClampToEdge, |d| d.wrap) }
            } else if let Some(rt) = rendered.get(&t.name) {
                Source::Rendered(rt)
            } else {
                Source::Missing
            });
        }
        Ok((sources, filters))
    }

    /// The texel pass that shades texture `name` over its texels, if any.
    pub(super) fn baked_by(r: &PlanRenderer, name: &str) -> Option<usize> {
        r.planned.plan.passes.iter().position(|p| {
            matches!(p.geometry, Geometry::Texels)
                && matches!(&p.target, RenderTarget::Texture { name: target } if *target == name)
        })
    }

    /// `exact`: texel pass `index` as a program to evaluate at a lookup's
    /// coordinates ([`Source::Baked`]). Only a function of the texel
    /// coordinate and uniforms can be evaluated anywhere (not solid
    /// mapping's (16), which reads the texture itself): `None` otherwise.
    pub(super) fn baked(
        r: &'a PlanRenderer<'a>,
        mode: Precision,
        rendered: &'a BTreeMap<String, Rendered>,
        index: usize,
    ) -> Result<Option<FragmentProgram<'a>>, RenderError> {
        let m = &r.planned.module;
        let texel_pass = PassInterface::of(r.planned, index);
        let reads = m
            .reachable(&[texel_pass.output])
            .into_iter()
            .any(|h| matches!(m.exprs[h], Expr::Lookup { .. } | Expr::FramebufferRead { .. }));
        if texel_pass.interpolants.is_empty() && !reads {
            Ok(Some(FragmentProgram::new(r, mode, &texel_pass, rendered, HashMap::new(), None, None, None)?))
        } else {
            Ok(None)
        }
    }

    #[inline]
    pub(super) fn leaf(
        &self,
        leaf: &Leaf,
        operand: Value,
        fragment: &Fragment,
        varyings: &[f32],
        texel_at: Option<[f64; 2]>,
    ) -> Value {
        match *leaf {
            Leaf::Uniform(v) => v,
            Leaf::Varying { k } => {
                let v = &varyings[4 * k..4 * k + 4];
                [v[0] as f64, v[1] as f64, v[2] as f64, v[3] as f64]
            }
            Leaf::Lookup { texture, coords_ty, lod_from } => {
                self.lookup(texture, operand, coords_ty, lod_from, None, fragment, varyings)
            }
            // A layer declared `mipmap`: minified through its chain, as a
            // rendered texture's lookup is (`lookup`).
            Leaf::FatMember { texture, member, coords_ty, lod_from } => {
                let (layer, filter) =
                    (self.fat[texture as usize][member as usize], self.filters[texture as usize]);
                if coords_ty != Ty::Position && layer.texture.levels.len() > 1 {
                    let at = (operand, coords_ty, lod_from, None);
                    self.sample_flat(&layer.texture, filter, at, fragment, varyings, false).map(|x| x as f64)
                } else {
                    layer.sample(operand, coords_ty, filter)
                }
            }
            Leaf::Framebuffer { framebuffer, channel } => {
                let Some(fb) = self.reads.get(&framebuffer) else { return [0.0; 4] };
                // Outside the framebuffer: its cleared values (depth 1: far, not an occluder).
                let Some((x, y)) =
                    to_pixel(operand, fb.width(), fb.height(), self.tie.texel_quanta as f64 / 256.0)
                else {
                    return if channel == FbChannel::Depth { [1.0; 4] } else { [0.0; 4] };
                };
                match channel {
                    FbChannel::Color => fb.read_back(x, y).unwrap_or([0.0; 4]).map(|c| c as f64),
                    FbChannel::Alpha => [fb.read_back(x, y).map_or(0.0, |c| c[3]) as f64; 4],
                    FbChannel::Depth => [fb.depth(x, y).unwrap_or(1.0) as f64; 4],
                    FbChannel::Stencil => [fb.stencil(x, y).unwrap_or(0) as f64; 4],
                }
            }
            Leaf::Project { matrix, inverse, ty } => bind::project_by(matrix, inverse, operand, ty),
            Leaf::Depth => {
                let [_, _, z, w] = operand;
                if w == 0.0 {
                    [1.0; 4]
                } else {
                    [(z / w) * 0.5 + 0.5; 4]
                }
            }
            Leaf::Pixel(freq) => {
                let (w, h) = match &self.own {
                    Some(fb) => (fb.width(), fb.height()),
                    None => (1, 1),
                };
                let x = (fragment.x as f64 + 0.5) / w as f64 * 2.0 - 1.0;
                let y = 1.0 - (fragment.y as f64 + 0.5) / h as f64 * 2.0;
                let depth = if freq == Frequency::Screen {
                    self.own.as_ref().and_then(|fb| fb.depth(fragment.x, fragment.y)).unwrap_or(1.0) as f64
                } else {
                    fragment.depth as f64
                };
                [x, y, depth * 2.0 - 1.0, 1.0]
            }
            Leaf::TexelCoord if texel_at.is_some() => {
                let [u, v] = texel_at.unwrap_or_default(); // `Some`: the guard
                [u, v, 0.0, 0.0]
            }
            Leaf::TexelCoord => {
                let (w, h) = match &self.own {
                    Some(fb) => (fb.width(), fb.height()),
                    None => (1, 1),
                };
                [(fragment.x as f64 + 0.5) / w as f64, (fragment.y as f64 + 0.5) / h as f64, 0.0, 0.0]
            }
            Leaf::Unknown => ir::eval::NAN,
        }
    }

    /// A lookup at `c`. The level of detail comes from the quad
    /// derivatives of the varying `lod_from` when the coordinates are one,
    /// else from `quad`, the coordinates at the quad's top-left, top-right
    /// and bottom-left pixels (a dependent lookup, [`FragmentProgram::quad_coords`]).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn lookup(
        &self,
        texture: TextureId,
        c: Value,
        coords_ty: Ty,
        lod_from: Option<usize>,
        quad: Option<[[f64; 2]; 3]>,
        fragment: &Fragment,
        varyings: &[f32],
    ) -> Value {
        let filter = self.filters[texture as usize];
        match &self.sources[texture as usize] {
            Source::Bound { exact: Some(f), .. } => exact_lookup(*f, c),
            Source::Bound { texture: b, .. } => {
                let out = match &b.texture {
                    Texture::Flat(t) => {
                        let at = (c, coords_ty, lod_from, quad);
                        self.sample_flat(t, filter, at, fragment, varyings, self.mode == Precision::Fixed9)
                    }
                    Texture::Cube(t) if self.mode != Precision::Exact => {
                        let d = [c[0] as f32, c[1] as f32, c[2] as f32];
                        unit::sample_cube_with(t, d, filter, self.latitude.weights)
                    }
                    Texture::Cube(t) => t.sample([c[0] as f32, c[1] as f32, c[2] as f32], filter, 0.0),
                    Texture::DualParaboloid(t) => {
                        t.sample([c[0] as f32, c[1] as f32, c[2] as f32], filter, 0.0)
                    }
                };
                out.map(|x| x as f64)
            }
            // A cube map a pass rendered: by direction, as a bound one.
            Source::Rendered(rt) if rt.cube.is_some() => {
                let d = [c[0] as f32, c[1] as f32, c[2] as f32];
                let out = match &rt.cube {
                    Some(t) if self.mode != Precision::Exact => {
                        unit::sample_cube_with(t, d, filter, self.latitude.weights)
                    }
                    Some(t) => t.sample(d, filter, 0.0),
                    None => [f32::NAN; 4],
                };
                out.map(|x| x as f64)
            }
            Source::Rendered(rt) if coords_ty == Ty::Vec3 => {
                let wrap = self.module.textures[texture as usize].sampling.wrap;
                crate::textures::solid::sample(&rt.pixels, [c[0], c[1], c[2]], filter, wrap)
            }
            // A rendered texture declared `mipmap`: its chain, at the level
            // of detail a bound texture's lookup gets (the rendered texels
            // are floats: filtered in float).
            Source::Rendered(rt) if coords_ty != Ty::Position && rt.texture.levels.len() > 1 => {
                let at = (c, coords_ty, lod_from, quad);
                self.sample_flat(&rt.texture, filter, at, fragment, varyings, false).map(|x| x as f64)
            }
            Source::Rendered(rt) => rt.sample(c, coords_ty, filter),
            // A cube map's function at the face's (s, t) (GL 1.3 Table 3.19).
            Source::Baked { program, .. }
                if self.module.textures[texture as usize].kind == crate::parser::ast::TextureKind::Cube =>
            {
                let (_, s, t) = crate::textures::cube_face_uv([c[0] as f32, c[1] as f32, c[2] as f32]);
                baked_lookup(program, Wrap::ClampToEdge, [s as f64, t as f64, 0.0, 0.0], Ty::Vec2)
            }
            Source::Baked { program, wrap } => baked_lookup(program, *wrap, c, coords_ty),
            Source::Missing => ir::eval::NAN,
        }
    }

    /// A 2-D (or 1-D) texture sampled at `at` (coordinates, their type, and
    /// where the level of detail comes from, as [`Self::lookup`] takes
    /// them). f32 and fixed9 sample as the WGSL target's texture unit does
    /// (`textures::unit`: a level of detail per 2×2 quad; with `fixed8`, an
    /// 8-bit texture filtered in 8.8 fixed point, as hardware fidelity
    /// uploads it, else in float, as exact fidelity does), so the wgpu
    /// image agrees with them; exact samples ideal GL.
    pub(super) fn sample_flat(
        &self,
        t: &Texture2D,
        filter: Filter,
        (c, coords_ty, lod_from, quad): (Value, Ty, Option<usize>, Option<[[f64; 2]; 3]>),
        fragment: &Fragment,
        varyings: &[f32],
        fixed8: bool,
    ) -> [f32; 4] {
        let (u, v) = texture_uv(c, coords_ty);
        if self.mode == Precision::Exact {
            let lod = exact_lod(t, coords_ty, lod_from, quad, fragment, varyings);
            return t.sample(u as f32, v as f32, filter, lod);
        }
        let lod = unit_lod(t, coords_ty, lod_from, quad, fragment, varyings);
        let arithmetic = if fixed8 {
            unit::Arithmetic::Fixed8 { tie_bias: self.tie.texel_quanta }
        } else {
            unit::Arithmetic::Float
        };
        unit::sample_2d_with(t, u as f32, v as f32, filter, lod, arithmetic, self.latitude)
    }

    /// Runs the IR steps; returns whether the fragment is discarded.
    /// `texel_at`: the texel coordinate when a baked texture's function is
    /// evaluated at a lookup ([`Source::Baked`]) instead of at a pixel.
    pub(super) fn run(
        &self,
        slots: &mut [Value],
        fragment: &Fragment,
        varyings: &[f32],
        texel_at: Option<[f64; 2]>,
    ) -> bool {
        self.run_steps(slots, fragment, varyings, texel_at, self.steps.len(), true)
    }

    /// [`FragmentProgram::run`] of the first `upto` steps; `quad`: whether a
    /// dependent lookup takes its level of detail from its quad
    /// ([`FragmentProgram::quad_coords`]; not inside that evaluation).
    pub(super) fn run_steps(
        &self,
        slots: &mut [Value],
        fragment: &Fragment,
        varyings: &[f32],
        texel_at: Option<[f64; 2]>,
        upto: usize,
        quad: bool,
    ) -> bool {
        for &(s, v) in &self.constants {
            slots[s as usize] = v;
        }
        let mut discard = false;
        let mut buf = [[0.0; 4]; 4];
        for (i, s) in self.steps[..upto].iter().enumerate() {
            let ops = &s.ops[..s.n_ops as usize];
            for (b, &o) in buf.iter_mut().zip(ops) {
                *b = slots[o as usize];
            }
            let v = self.step_value(i, &buf, fragment, varyings, texel_at, quad, &mut discard);
            slots[s.slot as usize] = self.stored(s, v);
        }
        if let Some(c) = self.condition {
            if slots[c as usize][0] == 0.0 {
                discard = true;
            }
        }
        discard
    }

    /// Step `i`'s value from its operands `buf`, before [`FragmentProgram::stored`]
    /// rounds it; sets `discard` where a `select` without a reject drops the
    /// fragment (parameters as [`FragmentProgram::run_steps`]).
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub(super) fn step_value(
        &self,
        i: usize,
        buf: &[Value; 4],
        fragment: &Fragment,
        varyings: &[f32],
        texel_at: Option<[f64; 2]>,
        quad: bool,
        discard: &mut bool,
    ) -> Value {
        let s = &self.steps[i];
        match &s.leaf {
            Some(Leaf::Lookup { texture, coords_ty, lod_from: None })
                if quad && texel_at.is_none() && self.mipmapped(*texture) =>
            {
                let q = self.quad_coords(i, buf[0], *coords_ty, fragment, varyings);
                self.lookup(*texture, buf[0], *coords_ty, None, Some(q), fragment, varyings)
            }
            Some(leaf) => self.leaf(leaf, buf[0], fragment, varyings, texel_at),
            None if let RegisterOp::Squarings(k) = s.register => ir::power_by_squaring(buf[0], k, |a, c| {
                [0, 1, 2, 3].map(|i| fixed9_with(a[i] * c[i], self.tie.register_steps))
            }),
            None if s.register == RegisterOp::Quotient => {
                let steps = |v: f64| (v * 255.0).round_ties_even();
                [0, 1, 2, 3]
                    .map(|i| fixed9_quotient(steps(buf[0][i]), steps(buf[1][i]), self.tie.register_steps))
            }
            None if self.tie.comparison_ulps != 0.0
                && matches!(
                    s.expr,
                    Expr::Binary {
                        op: ir::BinaryOp::Lt | ir::BinaryOp::Le | ir::BinaryOp::Gt | ir::BinaryOp::Ge,
                        ..
                    }
                ) =>
            {
                let toward = if matches!(s.expr, Expr::Binary { op: ir::BinaryOp::Lt | ir::BinaryOp::Le, .. })
                {
                    1.0
                } else {
                    -1.0
                };
                let ulp = |a: f64, b: f64| a.abs().max(b.abs()) * f32::EPSILON as f64;
                let moved = [0, 1, 2, 3]
                    .map(|i| buf[1][i] + toward * self.tie.comparison_ulps * ulp(buf[0][i], buf[1][i]));
                ir::eval::apply(self.module, s.expr, s.ty, &[buf[0], moved])
            }
            None => {
                if let Expr::Select { reject: None, .. } = s.expr {
                    if buf[0][0] == 0.0 {
                        *discard = true;
                    }
                }
                s.kernel.apply(self.module, s.expr, s.ty, &buf[..s.n_ops as usize])
            }
        }
    }

    /// Step `s`'s value `v` as its slot keeps it: canonical for its type
    /// (unless a raw texel), rounded as the mode rounds it.
    #[inline]
    pub(super) fn stored(&self, s: &Step, v: Value) -> Value {
        let v = if s.raw { v } else { ir::eval::canonical(s.ty, v) };
        match self.mode {
            Precision::Exact => v,
            Precision::F32 => v.map(|x| x as f32 as f64),
            Precision::Fixed9 if s.quantize => v.map(|x| fixed9_with(x, self.tie.register_steps)),
            Precision::Fixed9 if s.folded => v.map(|x| fixed9_folded_with(x, self.tie.register_steps)),
            Precision::Fixed9 => v.map(|x| x as f32 as f64),
        }
    }

    /// Whether `texture` is a bound 2D texture with a mip chain: a lookup
    /// of it at computed coordinates needs their quad derivatives.
    pub(super) fn mipmapped(&self, texture: TextureId) -> bool {
        match &self.sources[texture as usize] {
            Source::Bound { exact: None, texture: b } => {
                matches!(&b.texture, Texture::Flat(t) if t.levels.len() > 1)
            }
            Source::Rendered(rt) => rt.texture.levels.len() > 1,
            _ => false,
        }
    }

    /// The coordinates of the dependent lookup of step `step` (`c` at this
    /// pixel) at the top-left, top-right and bottom-left pixels of this
    /// pixel's 2×2 quad, whose differences are the coarse derivatives a GPU
    /// takes for its level of detail (WGSL `textureSample`: implicit
    /// derivatives of whatever the coordinates are). The other pixels run
    /// the steps before the lookup on their own varyings (extrapolated
    /// outside the triangle: helper pixels); lookups among those steps
    /// that are themselves dependent sample level 0 there.
    pub(super) fn quad_coords(
        &self,
        step: usize,
        c: Value,
        coords_ty: Ty,
        fragment: &Fragment,
        varyings: &[f32],
    ) -> [[f64; 2]; 3] {
        let coords = self.steps[step].ops[0] as usize;
        // A 1D lookup's v is fixed (as in `lookup`).
        let uv = |v: Value| if coords_ty == Ty::Scalar { [v[0], 0.5] } else { [v[0], v[1]] };
        let (tx, ty) = (-((fragment.x & 1) as f32), -((fragment.y & 1) as f32));
        // Not re-entrant: the neighbours' runs evaluate no quads.
        QUAD_SCRATCH.with(|cell| {
            let (slots, vary) = &mut *cell.borrow_mut();
            slots.resize(self.n_slots, [0.0; 4]);
            vary.resize(varyings.len(), 0.0);
            [(tx, ty), (tx + 1.0, ty), (tx, ty + 1.0)].map(|(ox, oy)| {
                if ox == 0.0 && oy == 0.0 {
                    return uv(c);
                }
                let Some(inv_w) = fragment.varyings_at(varyings, ox, oy, vary) else { return uv(c) };
                let at = |p: u32, o: f32| (p as i64 + o as i64).max(0) as u32;
                let neighbour = Fragment { x: at(fragment.x, ox), y: at(fragment.y, oy), inv_w, ..*fragment };
                self.run_steps(slots, &neighbour, vary, None, step, false);
                uv(slots[coords])
            })
        })
    }

    /// The fragment colour: the output node, or what the combiners compute
    /// from the registers the steps loaded (rounded to 8 bits, as texels and
    /// colours reach the machine: colours clamped to [0, 1], texels to
    /// [−1, 1] — a signed texel keeps its sign, an unsigned one has none).
    pub(super) fn colour(&self, slot: impl Fn(u32) -> Value) -> Value {
        match &self.combiners {
            Some((machine, registers)) => {
                machine.run(&self.registers(registers, slot)).map(|c| c as f64 / 255.0)
            }
            None => slot(self.output),
        }
    }

    /// The fragment colour as [`FragmentProgram::colour`], or `None` where
    /// the pass's alpha test drops the fragment: tested on the machine's
    /// 8-bit alpha against the 8-bit reference (OpenGL 1.2.1, Section 4.1.4).
    pub(super) fn tested_colour(&self, slot: impl Fn(u32) -> Value) -> Option<Value> {
        let c = self.colour(slot);
        match self.alpha_test {
            Some(t) if !t.passes_steps((c[3] * 255.0).round() as u8) => None,
            _ => Some(c),
        }
    }

    /// The combiners' per-pixel registers loaded from the slots `registers`
    /// names (texture 0-3, primary, secondary), rounded as [`FragmentProgram::colour`] says.
    pub(super) fn registers(
        &self,
        registers: &[Option<u32>; 6],
        slot: impl Fn(u32) -> Value,
    ) -> PixelRegisters {
        let load = |k: usize, lo: f64| -> [i16; 4] {
            match registers[k] {
                Some(s) => slot(s).map(|x| {
                    if x.is_nan() {
                        0
                    } else {
                        (x.clamp(lo, 1.0) * 255.0 + 0.5 + self.tie.register_steps)
                            .floor()
                            .clamp(-255.0, 255.0) as i16
                    }
                }),
                None => [0; 4],
            }
        };
        let colour = |k: usize| load(k, 0.0).map(|v| v as u8);
        PixelRegisters {
            textures: [load(0, -1.0), load(1, -1.0), load(2, -1.0), load(3, -1.0)],
            primary: colour(4),
            secondary: colour(5),
        }
    }

    /// The fragment's colour `v` as the framebuffer receives it: widened to
    /// RGBA ([`PassInterface`]: a scalar splatted, rgb gets alpha 1, as the
    /// generated combiners widen), NaN as 0; a non-finite value is counted
    /// ([`Frame::nonfinite`]).
    pub(super) fn output(&self, v: Value) -> [f32; 4] {
        let v = match self.output_ty.width() {
            1 => [v[0]; 4],
            2 => [v[0], v[1], 0.0, 1.0],
            3 => [v[0], v[1], v[2], 1.0],
            _ => v,
        };
        if v.iter().any(|x| !x.is_finite()) {
            self.nonfinite.fetch_add(1, Ordering::Relaxed);
        }
        v.map(|x| if x.is_nan() { 0.0 } else { x as f32 })
    }
}

/// `exact`'s lookup of a texture shaded over its texels: the texel pass's
/// function evaluated at the lookup's coordinates, wrapped as the texture,
/// its value held as a texel (and every image of the CPU renderer) holds
/// it, in f32. A value a pass wrote into a framebuffer from such a lookup
/// is then the same number as the lookup again: the alpha-ramp shadow map
/// (`lowering::alpha_ramp`) compares exactly those two, `½·(a + 1 − c) <
/// ½` at `a = c`, and with `a` in f64 against `c` stored in f32 its
/// surfaces shadowed themselves in bands of the ramp's steps (216.8/255
/// from the meaning in `exact`, the f32 render 2/255).
fn baked_lookup(program: &FragmentProgram, wrap: Wrap, c: Value, coords_ty: Ty) -> Value {
    let (u, v) = texture_uv(c, coords_ty);
    let at = |x: f64| match wrap {
        Wrap::Repeat => x - x.floor(),
        _ => x.clamp(0.0, 1.0),
    };
    let fragment = Fragment { x: 0, y: 0, depth: 0.0, front_facing: true, inv_w: 1.0, gradients: &[] };
    // The outer fragment's slots are borrowed: the nested program has its own.
    let mut slots = vec![[0.0; 4]; program.n_slots];
    program.run(&mut slots, &fragment, &[], Some([at(u), at(v)]));
    slots[program.output as usize].map(|x| f64::from(x as f32))
}

/// The level of detail the WGSL target's texture unit samples `t` at
/// (`textures::unit`, per 2×2 quad): from the quad derivatives of varying
/// `lod_from`, else from the coordinates at the quad's pixels (`quad`),
/// else the base level.
fn unit_lod(
    t: &Texture2D,
    coords_ty: Ty,
    lod_from: Option<usize>,
    quad: Option<[[f64; 2]; 3]>,
    fragment: &Fragment,
    varyings: &[f32],
) -> f32 {
    match (lod_from, quad) {
        (Some(k), _) if t.levels.len() > 1 => {
            let d = |i| fragment.quad_derivatives(4 * k + i, varyings[4 * k + i]);
            let (du, dv) = uv_derivatives(coords_ty, &varyings[4 * k..4 * k + 4], d);
            unit::quad_lod(t.width(), t.height(), [du[0], dv[0]], [du[1], dv[1]])
        }
        (None, Some([tl, tr, bl])) => {
            let d = |a: [f64; 2]| [(a[0] - tl[0]) as f32, (a[1] - tl[1]) as f32];
            unit::quad_lod(t.width(), t.height(), d(tr), d(bl))
        }
        _ => f32::NEG_INFINITY,
    }
}

/// `exact`'s level of detail (ideal GL, `textures::sampling`): from the
/// analytic derivatives of varying `lod_from`, else from the coordinates
/// at the quad's pixels (`quad`), else level 0.
fn exact_lod(
    t: &Texture2D,
    coords_ty: Ty,
    lod_from: Option<usize>,
    quad: Option<[[f64; 2]; 3]>,
    fragment: &Fragment,
    varyings: &[f32],
) -> f32 {
    match (lod_from, quad) {
        (Some(k), _) if t.levels.len() > 1 => {
            let d = |i| fragment.derivatives(4 * k + i, varyings[4 * k + i]);
            let (du, dv) = uv_derivatives(coords_ty, &varyings[4 * k..4 * k + 4], d);
            t.lod(du, dv)
        }
        (None, Some([tl, tr, bl])) => {
            let (du, dv) = (
                [(tr[0] - tl[0]) as f32, (bl[0] - tl[0]) as f32],
                [(tr[1] - tl[1]) as f32, (bl[1] - tl[1]) as f32],
            );
            t.lod(du, dv)
        }
        _ => 0.0,
    }
}

/// The (u, v) a 2-D or 1-D texture is sampled at: a scalar indexes a 1-D
/// table at its centre row; a clip-space position (`T δπl x`, Olano &
/// Lastra's projective texturing) projectively, `(½x/w + ½, ½ − ½y/w)` —
/// v = 0 is the top row, as the WGSL target's convention.
pub(super) fn texture_uv(c: Value, coords_ty: Ty) -> (f64, f64) {
    match coords_ty {
        Ty::Scalar => (c[0], 0.5),
        Ty::Position if c[3] != 0.0 => (0.5 * c[0] / c[3] + 0.5, 0.5 - 0.5 * c[1] / c[3]),
        _ => (c[0], c[1]),
    }
}

/// The screen derivatives `([du/dx, du/dy], [dv/dx, dv/dy])` of
/// [`texture_uv`] from those of the coordinate varying's lanes (`d(i)` of
/// lane i, values `lanes`): by the quotient rule for a projective position.
pub(super) fn uv_derivatives(
    coords_ty: Ty,
    lanes: &[f32],
    d: impl Fn(usize) -> [f32; 2],
) -> ([f32; 2], [f32; 2]) {
    if coords_ty != Ty::Position || lanes[3] == 0.0 {
        return (d(0), d(1));
    }
    let (x, y, w) = (lanes[0], lanes[1], lanes[3]);
    let (dx, dy, dw) = (d(0), d(1), d(3));
    let q = |a: f32, da: [f32; 2], sign: f32| [0, 1].map(|k| sign * 0.5 * (da[k] * w - a * dw[k]) / (w * w));
    (q(x, dx, 1.0), q(y, dy, -1.0))
}

/// The varying whose derivatives choose the mipmap level of a lookup at
/// `coords`: the coordinates themselves when they are a δ, or a swizzle of
/// one that keeps its components in place (`.xy` of a δ vec3). The level
/// is taken from the varying's first components ([`uv_derivatives`]), so a
/// swizzle that moves them (`(P δ s x).yz`, triplanar mapping) has none:
/// its level comes from the coordinates at the quad's pixels, as a
/// dependent lookup's does.
pub(super) fn lod_varying(m: &Module, coords: Handle<Expr>) -> Option<Handle<Expr>> {
    match &m.exprs[coords] {
        Expr::Interpolate { .. } => Some(coords),
        Expr::Swizzle { value, pattern, len, .. } if (0..*len).all(|i| pattern[i as usize] == i) => {
            lod_varying(m, *value)
        }
        _ => None,
    }
}

/// A clip-space position (x, y, z, w) to a pixel (row 0 at the top).
/// (`shift`: of the pixel boundaries, in pixels — [`RoundingBias`].)
pub(super) fn to_pixel(p: Value, width: u32, height: u32, shift: f64) -> Option<(u32, u32)> {
    let [x, y, _, w] = p;
    if w == 0.0 || !x.is_finite() || !y.is_finite() || !w.is_finite() {
        return None;
    }
    let px = ((x / w) * 0.5 + 0.5) * width as f64 + shift;
    let py = (0.5 - (y / w) * 0.5) * height as f64 + shift;
    if px < 0.0 || py < 0.0 {
        return None;
    }
    let (px, py) = (px.floor() as u64, py.floor() as u64);
    (px < width as u64 && py < height as u64).then_some((px as u32, py as u32))
}

/// What a lookup table's generator tabulates, evaluated exactly.
pub fn exact_lookup(f: ExactFunction, c: Value) -> Value {
    match f {
        ExactFunction::Normalize { signed } => {
            let l = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
            // The zero vector has no direction: normalize(0) = 0, the IR's
            // fallback (`ir::eval`, docs/numerics.md). The stored cube map
            // cannot hold it and returns +X's centre texel instead.
            let d = if l > 0.0 && l.is_finite() { [c[0] / l, c[1] / l, c[2] / l] } else { [0.0, 0.0, 0.0] };
            if signed {
                [d[0], d[1], d[2], 1.0]
            } else {
                [0.5 * d[0] + 0.5, 0.5 * d[1] + 0.5, 0.5 * d[2] + 0.5, 1.0]
            }
        }
        ExactFunction::Exponent(n) => {
            let v = c[0].clamp(0.0, 1.0).powf(n.max(0.0) as f64);
            [v, v, v, 1.0]
        }
        ExactFunction::FresnelDistribution { roughness, index } => {
            let (u, v) = (c[0].clamp(0.0, 1.0) as f32, c[1].clamp(0.0, 1.0) as f32);
            let fd = (generators::fresnel(u, index) * generators::distribution(v, roughness)) as f64;
            [fd, fd, fd, 1.0]
        }
        ExactFunction::Geometry { roughness, scale } => {
            let (u, v) = (c[0].clamp(0.0, 1.0) as f32, c[1].clamp(1e-6, 1.0) as f32);
            let scale = if scale > 0.0 && scale.is_finite() { scale } else { 1.0 };
            let g = (generators::smith_g1(u, roughness) * generators::smith_g1(v, roughness)
                / (std::f32::consts::PI * v)
                / scale) as f64;
            [g, g, g, 1.0]
        }
    }
}

impl FragmentStage for FragmentProgram<'_> {
    fn replaces_depth(&self) -> bool {
        self.depth.is_some()
    }

    /// A fragment is dropped only by the condition, the alpha test or a
    /// `select` without a reject (what [`FragmentProgram::run`] and
    /// [`FragmentProgram::tested_colour`] test).
    fn may_discard(&self) -> bool {
        self.condition.is_some()
            || self.alpha_test.is_some()
            || self.steps.iter().any(|s| matches!(s.expr, Expr::Select { reject: None, .. }))
    }

    /// The replaced depth as the depth buffer holds it: clamped to [0, 1]
    /// (NV_texture_shader leaves a depth outside it undefined).
    fn shade_with_depth(
        &self,
        fragment: &Fragment,
        varyings: &[f32],
        out: &mut [f32; 4],
    ) -> (FragmentResult, f32) {
        let Some(d) = self.depth else { return (self.shade(fragment, varyings, out), fragment.depth) };
        SLOTS.with(|cell| {
            let mut slots = cell.borrow_mut();
            if slots.len() < self.n_slots {
                slots.resize(self.n_slots, [0.0; 4]);
            }
            if self.run(&mut slots[..self.n_slots], fragment, varyings, None) {
                return (FragmentResult::Discard, fragment.depth);
            }
            let depth = (slots[d as usize][0] as f32).clamp(0.0, 1.0);
            let Some(c) = self.tested_colour(|s| slots[s as usize]) else {
                return (FragmentResult::Discard, fragment.depth);
            };
            *out = self.output(c);
            (FragmentResult::Keep, depth)
        })
    }

    fn shade(&self, fragment: &Fragment, varyings: &[f32], out: &mut [f32; 4]) -> FragmentResult {
        SLOTS.with(|cell| {
            let mut slots = cell.borrow_mut();
            if slots.len() < self.n_slots {
                slots.resize(self.n_slots, [0.0; 4]);
            }
            if self.run(&mut slots[..self.n_slots], fragment, varyings, None) {
                return FragmentResult::Discard;
            }
            let Some(c) = self.tested_colour(|s| slots[s as usize]) else { return FragmentResult::Discard };
            *out = self.output(c);
            FragmentResult::Keep
        })
    }

    fn shade_batch(
        &self,
        fragments: &[Fragment],
        varyings: &[f32],
        out: &mut [[f32; 4]],
        results: &mut [FragmentResult],
    ) {
        if let (true, Some(lp)) = (self.batched, &self.lanes) {
            let per = varyings.len().checked_div(fragments.len()).unwrap_or(0);
            self.shade_compiled(lp, fragments, Vary::by_fragment(varyings, per), out, results)
        } else if self.batched {
            self.shade_lanes(fragments, varyings, out, results)
        } else {
            crate::renderer::shade_each(self, fragments, varyings, out, results)
        }
    }

    fn shade_batch_rows(
        &self,
        fragments: &[Fragment],
        (rows, per, row): (&[f32], usize, usize),
        out: &mut [[f32; 4]],
        results: &mut [FragmentResult],
    ) {
        match (self.batched, &self.lanes) {
            (true, Some(lp)) => {
                self.shade_compiled(lp, fragments, Vary::by_component(rows, per, row), out, results)
            }
            _ => crate::renderer::shade_rows_by_fragment(self, fragments, (rows, per, row), out, results),
        }
    }
}
