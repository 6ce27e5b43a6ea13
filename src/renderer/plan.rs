//! Executes a pass plan ([`crate::pipeline::Planned`]) on the CPU for a
//! [`Scene`]: the renderer behind `shadec render`.
//!
//! Per pass, following [`PassInterface`] (the contract every executor
//! binds): the vertex stage evaluates the per-vertex IR (the interpolants
//! and the clip position) at every mesh vertex with [`ir::eval::Evaluator`]
//! over the scene binder's leaves ([`crate::scene::bind`]); the rasterizer
//! interpolates them perspective-correctly; the fragment stage evaluates the
//! pass's output with [`ir::eval::apply`] — the one semantics of the IR —
//! reading interpolated varyings, texture lookups
//! ([`crate::textures`] sampling, mipmap level from the analytic
//! derivatives of the coordinate varying), uniforms, the pixel, and other
//! framebuffers; the pass's [`RenderState`](crate::pipeline::RenderState) does depth, stencil and blending.
//! Passes that render into a texture (`RenderTarget::Texture`, texture
//! shading) or into a planner temporary (`RenderTarget::Temporary`) keep
//! their image, which later passes look up (by screen position: the pixel
//! itself; by coordinates: a filtered texture).
//!
//! # Three modes ([`Precision`])
//!
//! - `exact` — the reference: every node in f64, interpolants as the
//!   program says (`δ v` of a unit vector is not renormalized: the
//!   denormalization of GeForce3 Phong, Figure 9 is the program's meaning, which
//!   `normalize(δ v)` asks to undo); true `pow` (the IR's `^`); **no lookup
//!   tables**: a texture whose *generator* tabulates a function —
//!   `normalize_cube` (normalize, range-compressed unless the format is
//!   signed), `exponent_table(n)` (xⁿ), `brdf_fd`, `brdf_g` — is not
//!   sampled; the function is evaluated at the lookup's coordinates
//!   ([`bind::ExactFunction`], detected from the declaration's source); a
//!   texture shaded over its texels (`bake(f)`) is not sampled either: the
//!   texel pass's function is evaluated at the lookup's coordinates.
//!   Generated data textures (normal maps) are built unquantized, with the
//!   same mipmap filter. f32 framebuffers; what a later pass reads of one
//!   declared `rgba8` (and of a texture declared 8-bit that a pass renders
//!   into) is clamped to [0, 1], as GL's fixed-point buffers store it
//!   (§2.13.9, §4.1.8), without rounding (`ColorFormat::Unorm`; the last
//!   value written is kept as computed); float ones and the planner's
//!   temporaries do not clamp.
//! - `f32` — the same plan with every node rounded to f32, textures as
//!   stored (8-bit where declared so) and sampled as the WGSL target's
//!   texture unit samples them in exact fidelity (`textures::unit`: λ per
//!   2×2 quad — for a dependent lookup from its coordinates computed at the
//!   quad's pixels, `FragmentProgram::quad_coords` — float filtering,
//!   seamless cube maps; fixed9 too, but with 8-bit textures filtered in 8.8
//!   fixed point), f32 framebuffers (clamped where declared `rgba8`, as in
//!   `exact`); textures declared 16-bit or float are
//!   rendered into in half floats, as the WGSL target's `Rgba16Float`.
//! - `fixed9` — what the old hardware showed: 8-bit textures, an RGBA8
//!   framebuffer (blending clamps and rounds) and 8-bit temporaries, and the
//!   fragment maths on the register combiners. For each pass the combiner
//!   code generator ([`crate::backends::combiners::codegen`]) makes the
//!   setup for the plan's target (a GeForce 3 when the target has no
//!   combiners); every fragment loads its texels and interpolated colours
//!   into the texture, primary and secondary registers (clamped to [0, 1],
//!   rounded to 8 bits) and the emulator runs the setup on them
//!   ([`PixelEmulator`], bit-exact with `shadec emulate`;
//!   tests/render_combiners.rs). A pass the generator refuses (a division,
//!   a framebuffer read, too many stages — [`Frame::shading`] says which and
//!   why) falls back to a per-operation model: every per-fragment IR
//!   operation's result is clamped to [−1, 1] and rounded to a multiple of
//!   1/255 with the emulator's rule (nearest, ties toward +∞). Constant and
//!   uniform subexpressions are folded by the compiler into a constant
//!   register and an output scale, so they are rounded but not clamped
//!   ([`fixed9_folded_with`]). Values that only address textures (lookup
//!   coordinates, framebuffer positions) are not quantized: the texture
//!   units iterate them in float.

use std::cell::RefCell;
use std::collections::{BTreeMap, HashMap};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use rayon::prelude::*;

use super::{
    ColorFormat, CullMode, DrawStats, Fragment, FragmentResult, FragmentStage, Framebuffer,
    Pass as RasterPass, RenderError, VertexStage,
};
use crate::backends::combiners::{self, PixelEmulator, PixelRegisters};
use crate::ir::{self, eval::Value, Expr, FbChannel, Frequency, Handle, Module, TextureId, Ty};
use crate::pipeline::{Geometry, Pass, PassInterface, Planned, RenderTarget, TargetFormat, TargetImage};
use crate::scene::bind::{self, BoundObject, BoundTexture, ExactFunction, TextureDecl, TextureQuality};
use crate::scene::{Scene, SceneAssets};
use crate::textures::{generators, unit, Filter, Level, TexelFormat, Texture, Texture2D, Wrap};

use crate::numerics::{fixed9_folded_with, fixed9_quotient, fixed9_with, Precision};

mod batch;
mod lanes;
pub use lanes::{set_dispatch as set_lane_dispatch, Dispatch as LaneDispatch};

/// One rendered frame.
pub struct Frame {
    /// The framebuffer the last framebuffer pass wrote (the picture).
    pub image: Framebuffer,
    pub name: String,
    /// Summed over every pass and object.
    pub stats: DrawStats,
    /// Wall time of the passes (textures and binding excluded).
    pub time: Duration,
    /// Fragments whose computed value had a NaN or ±∞ component before it
    /// was written (a NaN is written as 0, see `FragmentStage::shade` below):
    /// the hard-case suite (`tests/hard_cases.rs`, `docs/numerics.md`)
    /// asserts this is 0, so a fallback cannot hide a NaN.
    pub nonfinite: u64,
    /// Adaptive sample shading's counters, summed over the mesh passes
    /// ([`PlanRenderer::render_adaptive`]); `None` for a full render.
    pub adaptive: Option<super::AdaptiveStats>,
    /// How each pass's fragments were computed, in plan order.
    pub shading: Vec<PassShading>,
}

/// How a pass's fragments were computed.
#[derive(Clone, Debug, PartialEq)]
pub enum PassShading {
    /// `exact` or `f32`: the IR evaluated node by node.
    Float,
    /// `fixed9`: the register-combiner configuration the code generator
    /// made for the pass ([`combiners::codegen`]), run on each fragment's
    /// registers by the emulator ([`PixelEmulator`]): what the old
    /// hardware computed, bit for bit, from the same texels and colours.
    Combiners { stages: usize },
    /// `fixed9` for a pass the generator refuses (`why`): every
    /// per-fragment IR operation clamped and rounded like a register write
    /// ([`fixed9`](crate::numerics::fixed9)) — an approximation of what a hand-made setup would do.
    PerOperation { why: String },
}

impl PassShading {
    /// One line for `shadec render`.
    pub fn describe(&self) -> String {
        match self {
            PassShading::Float => "IR in float".into(),
            PassShading::Combiners { stages } => format!(
                "register combiners ({stages} general stage{}), emulated",
                if *stages == 1 { "" } else { "s" }
            ),
            PassShading::PerOperation { why } => format!("per-operation 8-bit+sign model ({why})"),
        }
    }
}

/// How far [`PlanRenderer::set_rounding_bias`] moves the ties of `fixed9`'s
/// roundings (the default, zero, is the model).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RoundingBias {
    /// In 1/255 steps: register writes, folded constants, register loads.
    pub register_steps: f64,
    /// In 1/256 quanta: the 8-bit texture units' texel coordinates and λ
    /// (`textures::unit::Arithmetic::Fixed8`), and the pixel a framebuffer
    /// read at a computed position (`πl π⁻¹ xs`) falls in, in every mode.
    pub texel_quanta: f32,
    /// In units in the last place (f32) of the larger operand: the
    /// comparisons `<`, `≤`, `>`, `≥` of the program (a shadow test's
    /// depths), in every mode — positive lets more comparisons hold.
    pub comparison_ulps: f64,
}

/// A program bound to a scene: textures loaded, objects bound. Build once,
/// render in any mode and size.
pub struct PlanRenderer<'a> {
    planned: &'a Planned,
    scene: &'a Scene,
    assets: &'a SceneAssets,
    decls: Vec<TextureDecl>,
    stored: BTreeMap<String, BoundTexture>,
    exact: BTreeMap<String, BoundTexture>,
    uniforms: Vec<Option<Value>>,
    /// See [`PlanRenderer::set_rounding_bias`]; zero renders the model.
    rounding_bias: RoundingBias,
    /// See [`PlanRenderer::set_sampling_latitude`].
    latitude: unit::Latitude,
    /// See [`PlanRenderer::set_batched`].
    batched: bool,
    /// What stand-ins were used, for the user.
    pub notes: Vec<String>,
}

impl<'a> PlanRenderer<'a> {
    /// Binds `planned` (compiled from `program`) to a scene and its assets.
    pub fn new(
        planned: &'a Planned,
        program: &crate::parser::ast::Program,
        scene: &'a Scene,
        assets: &'a SceneAssets,
    ) -> Result<PlanRenderer<'a>, RenderError> {
        let mut decls = bind::texture_decls(program, &scene.constants);
        let lowered = bind::lowered_decls(&planned.module, &decls);
        decls.extend(lowered);
        let mut notes = bind::absent_light_notes(&planned.module, scene);
        let err = |e: bind::BindError| RenderError::Unsupported(e.to_string());
        let stored = bind::load_textures(&decls, scene, TextureQuality::Stored, &mut notes).map_err(err)?;
        let mut ignore = Vec::new();
        let exact = bind::load_textures(&decls, scene, TextureQuality::Exact, &mut ignore).map_err(err)?;
        let uniforms = bind::uniforms(&planned.module, scene);
        let m = &planned.module;
        let roots: Vec<_> = m.statements.iter().map(|st| st.value).collect();
        let read: Vec<u32> = (m.reachable(&roots).into_iter())
            .filter_map(|h| match m.exprs[h] {
                Expr::Uniform(id) => Some(id),
                _ => None,
            })
            .collect();
        for (id, (u, value)) in m.uniforms.iter().zip(&uniforms).enumerate() {
            if value.is_none() && u.default.is_none() && read.contains(&(id as u32)) {
                notes.push(format!(
                    "uniform `{}` has no default and the scene does not set it: it is NaN, and a colour it reaches is written as 0 (set it in the scene's `constants: {{ \"{}\": [..] }}`)",
                    u.name, u.name
                ));
            }
        }
        // What the CPU renderer cannot do yet: say so before drawing.
        for (i, _) in planned.plan.passes.iter().enumerate() {
            let pi = PassInterface::of(planned, i);
            let mut roots = vec![pi.output];
            roots.extend(pi.condition);
            roots.extend(pi.interpolants.iter().copied());
            for h in planned.module.reachable(&roots) {
                if let Expr::Vector { site: ir::Site::Texel, .. } = &planned.module.exprs[h] {
                    return Err(RenderError::Unsupported("it uses shading vectors as a function of the texel coordinate, with no mesh to take them on".into()).in_pass(i));
                }
            }
        }
        Ok(PlanRenderer {
            planned,
            scene,
            assets,
            decls,
            stored,
            exact,
            uniforms,
            rounding_bias: RoundingBias::default(),
            latitude: unit::Latitude::MODEL,
            batched: true,
            notes,
        })
    }

    /// A sensitivity probe of `fixed9`, not a model: moves the tie of
    /// every rounding the model takes ([`RoundingBias`]). Where a pixel's
    /// colour changes, some rounding there decides on an input within that
    /// distance of its tie — an input another float evaluation (a GPU's
    /// interpolation, `dot` and derivatives) can put on the other side. The
    /// WGSL agreement tests accept a GPU pixel that agrees with such a
    /// picture, as they skip the pixels where coverage is decided at a
    /// triangle edge.
    pub fn set_rounding_bias(&mut self, bias: RoundingBias) {
        self.rounding_bias = bias;
    }

    /// Renders `f32` and `fixed9` with the texture unit taking `latitude`'s
    /// choice where the specifications leave one (`textures::unit`, "What
    /// the specifications leave open"): the renders of
    /// `unit::Latitude::ENVELOPE` bound what another conforming GPU may
    /// compute. The default, `Latitude::MODEL`, is the model.
    pub fn set_sampling_latitude(&mut self, latitude: unit::Latitude) {
        self.latitude = latitude;
    }

    /// Whether fragments are shaded in batches (the default) or
    /// one at a time, the executor before it: the images are the same bit
    /// for bit (`tests/render_batch.rs`); benches compare the two speeds.
    pub fn set_batched(&mut self, batched: bool) {
        self.batched = batched;
    }

    /// Renders every pass at `width`×`height`; `progress(done, total)` is
    /// called after each pass of each object.
    pub fn render(
        &self,
        mode: Precision,
        width: u32,
        height: u32,
        progress: &mut dyn FnMut(usize, usize),
    ) -> Result<Frame, RenderError> {
        self.render_with(mode, width, height, None, progress)
    }

    /// Renders with Adaptive Sample Shading (Adaptive Sample Shading, Section 2.1): each
    /// mesh pass shades exactly at regular samples, at edges and where
    /// neighbouring samples differ by more than the threshold, and
    /// interpolates the rest ([`super::draw_adaptive`]); blending, depth and
    /// culling follow the pass. Passes with a stencil test, and screen or
    /// texel passes, are shaded in full.
    pub fn render_adaptive(
        &self,
        mode: Precision,
        width: u32,
        height: u32,
        settings: &super::AdaptiveSettings,
        progress: &mut dyn FnMut(usize, usize),
    ) -> Result<Frame, RenderError> {
        self.render_with(mode, width, height, Some(settings), progress)
    }

    fn render_with(
        &self,
        mode: Precision,
        width: u32,
        height: u32,
        adaptive: Option<&super::AdaptiveSettings>,
        progress: &mut dyn FnMut(usize, usize),
    ) -> Result<Frame, RenderError> {
        let m = &self.planned.module;
        let plan = &self.planned.plan;
        let start = Instant::now();
        let format = if mode == Precision::Fixed9 { ColorFormat::Rgba8 } else { ColorFormat::F32 };
        let objects = self.bound_objects(width as f32 / height as f32)?;
        let mut targets: BTreeMap<String, Framebuffer> = BTreeMap::new();
        let mut rendered: BTreeMap<String, Rendered> = BTreeMap::new();
        let mut last_fb: Option<String> = None;
        let mut nonfinite = 0;
        let mut shading = Vec::with_capacity(plan.passes.len());
        let mut draws = Draws {
            stats: DrawStats::default(),
            settings: adaptive,
            adaptive: adaptive.map(|_| super::AdaptiveStats::default()),
            done: 0,
            total: self.n_draws(objects.len()),
            progress,
        };
        for (index, pass) in plan.passes.iter().enumerate() {
            let whole = PassInterface::of(self.planned, index);
            // A fat texel (seeds/001 (5), (15)): one draw per member, member i
            // into layer i of the texture (`T`, then `T#1`, `T#2`, …).
            let outputs = match &m.exprs[whole.output] {
                Expr::Bundle(members) => members.clone(),
                _ => vec![whole.output],
            };
            for (layer, output) in outputs.iter().enumerate() {
                let pi = PassInterface { output: *output, ..whole.clone() };
                let target = &self.planned.setup(index).target;
                let name = if layer == 0 { target.name.clone() } else { format!("{}#{layer}", target.name) };
                if !targets.contains_key(&name) {
                    targets.insert(name.clone(), new_target(target, mode, format, (width, height))?);
                }
                let reads = framebuffer_reads(m, &pi, &targets);
                // A copy of the target only for the passes that read it (its
                // size or depth at the pixel): a copy per pass is megabytes.
                let own_depth = reads_own_target(m, &pi).then(|| targets.get(&name).cloned()).flatten();
                // A `bake` table is the compiler's work, in float, whatever
                // the target's arithmetic (issue 18).
                let mode = if pass.baked && mode == Precision::Fixed9 { Precision::F32 } else { mode };
                let (machine, how) = self.shading_of(mode, index);
                if layer == 0 {
                    shading.push(how);
                }
                let stage = FragmentProgram::new(
                    self,
                    mode,
                    &pi,
                    &rendered,
                    reads,
                    own_depth,
                    machine,
                    objects.first(),
                )
                .map_err(|e| e.in_pass(index))?;
                let target = targets.get_mut(&name).ok_or_else(|| lost(&name))?;
                // A stencil update over `x′`: the scene's shadow volumes.
                let volume = crate::planner::shadow_volumes::for_pass(self.scene, self.assets, m, pass)
                    .map_err(RenderError::Unsupported)?;
                let volumes: Vec<BoundObject> = volume
                    .iter()
                    .map(|v| {
                        crate::scene::shadow_volume::bind_volume(
                            self.scene,
                            self.assets,
                            v,
                            width as f32 / height as f32,
                        )
                    })
                    .collect();
                let drawn = if volume.is_some() { &volumes[..] } else { &objects[..] };
                self.draw_layer(pass, &pi, drawn, &stage, target, &mut draws)?;
                nonfinite += stage.nonfinite.load(Ordering::Relaxed);
                match &pass.target {
                    RenderTarget::Framebuffer { .. } => last_fb = Some(name.clone()),
                    RenderTarget::Texture { .. } | RenderTarget::Temporary { .. } => {
                        let fb = &targets[&name];
                        let mipmap = self.decls.iter().any(|d| d.name == name && d.mipmap);
                        rendered.insert(name.clone(), Rendered::from_framebuffer(fb, mipmap));
                    }
                }
            }
        }
        let time = start.elapsed();
        let name = last_fb.ok_or_else(|| {
            RenderError::Unsupported("the plan writes no framebuffer: nothing to show".into())
        })?;
        let image = targets.remove(&name).ok_or_else(|| lost(&name))?;
        let Draws { stats, adaptive: adaptive_stats, .. } = draws;
        Ok(Frame { image, name, stats, time, nonfinite, adaptive: adaptive_stats, shading })
    }

    /// The scene's objects bound for a frame of this aspect ratio, their
    /// texture coordinates generated; light 0's projection looks at the
    /// centre of the objects.
    fn bound_objects(&self, aspect: f32) -> Result<Vec<BoundObject<'a>>, RenderError> {
        bind::bound_objects(self.scene, self.assets, &self.planned.module, aspect)
            .map_err(|e| RenderError::Unsupported(e.to_string()))
    }

    /// How many draws the plan makes (the `total` of `progress`): one per
    /// layer of each pass, times the objects for a mesh pass.
    fn n_draws(&self, n_objects: usize) -> usize {
        let m = &self.planned.module;
        let plan = &self.planned.plan;
        let layers = |index: usize| match &m.exprs[self.planned.handle(plan.passes[index].fragment.output)] {
            Expr::Bundle(members) => members.len(),
            _ => 1,
        };
        plan.passes
            .iter()
            .enumerate()
            .map(|(i, p)| layers(i) * if matches!(p.geometry, Geometry::Mesh { .. }) { n_objects } else { 1 })
            .sum::<usize>()
    }

    /// How pass `index` is shaded in `mode`: in `fixed9` by its combiner
    /// setup, or per operation where the generator refuses.
    fn shading_of(&self, mode: Precision, index: usize) -> (Option<CombinerSetup>, PassShading) {
        match mode {
            Precision::Fixed9 => match self.combiner_setup(index) {
                Ok((setup, stages)) => (Some(setup), PassShading::Combiners { stages }),
                Err(why) => (None, PassShading::PerOperation { why }),
            },
            _ => (None, PassShading::Float),
        }
    }

    /// Draws one layer of `pass` into `target` with `stage`: each object's
    /// mesh (one adaptive draw over them all when adaptive), or the
    /// screen-filling quad; counted in `draws`.
    fn draw_layer(
        &self,
        pass: &Pass,
        pi: &PassInterface,
        objects: &[BoundObject],
        stage: &FragmentProgram,
        target: &mut Framebuffer,
        draws: &mut Draws,
    ) -> Result<(), RenderError> {
        let m = &self.planned.module;
        let state = pass.state;
        match &pass.geometry {
            Geometry::Mesh { .. } if draws.settings.is_some() && !state.stencil.enabled => {
                let Some(settings) = draws.settings else { unreachable!("matched") };
                // One adaptive draw over every object of the pass, so that
                // silhouettes between objects are edges (Section 2.1.3).
                let drawn: Vec<&BoundObject> = objects
                    .iter()
                    .enumerate()
                    .filter(|(oi, _)| pass.objects.as_ref().is_none_or(|keep| keep.contains(oi)))
                    .map(|(_, o)| o)
                    .collect();
                let vertices: Vec<MeshVertices> =
                    drawn.iter().map(|o| MeshVertices::new(m, o, pi, &self.uniforms)).collect();
                let passes: Vec<RasterPass> = drawn
                    .iter()
                    .zip(&vertices)
                    .map(|(o, vs)| RasterPass {
                        triangles: &o.mesh.triangles,
                        vertex: vs,
                        fragment: stage,
                        state,
                    })
                    .collect();
                let s = super::draw_adaptive(target, &passes, settings)?;
                draws.adaptive = draws.adaptive.map(|a| a + s);
                draws.advance(objects.len());
            }
            Geometry::Mesh { .. } => {
                for (oi, object) in objects.iter().enumerate() {
                    // Light culling drew this light's pass only for some objects.
                    if pass.objects.as_ref().is_some_and(|keep| !keep.contains(&oi)) {
                        draws.done += 1;
                        continue;
                    }
                    let vs = MeshVertices::new(m, object, pi, &self.uniforms);
                    let s = super::draw(
                        target,
                        &RasterPass {
                            triangles: &object.mesh.triangles,
                            vertex: &vs,
                            fragment: stage,
                            state,
                        },
                    )?;
                    add(&mut draws.stats, &s);
                    draws.advance(1);
                }
            }
            Geometry::Screen | Geometry::Texels => {
                let quad = Quad;
                let state = super::RenderState { cull: CullMode::None, ..state };
                let s = super::draw(
                    target,
                    &RasterPass { triangles: &[[0, 1, 2], [0, 2, 3]], vertex: &quad, fragment: stage, state },
                )?;
                add(&mut draws.stats, &s);
                draws.advance(1);
            }
        }
        Ok(())
    }

    /// The register-combiner setup of pass `index` for `fixed9`: generated
    /// for the plan's target (a combiner profile), or for a GeForce 3 when
    /// the plan is for another target; with the values of the constant
    /// colours the scene sets. `Err` says why the generator refused.
    fn combiner_setup(&self, index: usize) -> Result<(CombinerSetup, usize), String> {
        let m = &self.planned.module;
        let g = combiners::setup::of(self.planned, index).map_err(|e| format!("not generated: {e}"))?;
        // A constant colour the config leaves unset is a uniform: the scene's value.
        let constant = |k: usize| -> [f32; 4] {
            let Some(h) = g.constants[k] else { return [0.0; 4] };
            let v = match &m.exprs[h] {
                Expr::Uniform(id) => self
                    .uniforms
                    .get(*id as usize)
                    .copied()
                    .flatten()
                    .or_else(|| m.uniforms[*id as usize].default.as_ref().map(ir::eval::value)),
                Expr::Constant(c) => Some(ir::eval::value(c)),
                _ => None,
            };
            let v = ir::eval::canonical(m.info(h).ty, v.unwrap_or([0.0; 4]));
            v.map(|x| if x.is_nan() { 0.0 } else { x as f32 })
        };
        let machine = PixelEmulator::new(&g.config, constant(0), constant(1), [0.0; 4], Precision::Fixed9)
            .map_err(|e| e.to_string())?;
        let mut registers = [None; 6];
        let output = Handle::new(self.planned.plan.passes[index].fragment.output as usize);
        for (r, u) in registers.iter_mut().zip(&self.planned.setup(index).units) {
            // A depth texture's unit returns its comparison (ARB_shadow), not the depth.
            *r = Some(crate::planner::shadow_map::compare_node(m, output, u.lookup).unwrap_or(u.lookup));
        }
        registers[4] = g.primary;
        registers[5] = g.secondary;
        Ok((CombinerSetup { machine, registers }, g.stages))
    }
}

/// An image the frame loop made and then could not find: a bug, said as
/// an error rather than a panic.
fn lost(name: &str) -> RenderError {
    RenderError::Unsupported(format!("internal: the image `{name}` a pass renders into is missing"))
}

/// A cleared image for a pass to render into, as its setup says
/// (`pipeline::TargetImage`): a texture declared 16-bit or float keeps what
/// is rendered into it (deferred shading's signed vectors) in half floats,
/// as the WGSL target's `Rgba16Float` (fixed9 and f32; exact keeps f32); a
/// fixed-point target (`rgba8`) is clamped to [0, 1] as GL stores it,
/// which `exact` and `f32` keep in float ([`ColorFormat::Unorm`]) and
/// `fixed9` in RGBA8; a planner temporary keeps its value unclamped.
fn new_target(
    target: &TargetImage,
    mode: Precision,
    format: ColorFormat,
    frame: (u32, u32),
) -> Result<Framebuffer, RenderError> {
    let format = match (mode, target.format) {
        (Precision::Exact, TargetFormat::Half) => ColorFormat::F32,
        (_, TargetFormat::Half) => ColorFormat::F16,
        (Precision::Exact | Precision::F32, TargetFormat::Unorm8) => ColorFormat::Unorm,
        _ => format,
    };
    let (width, height) = target.extent.size(frame.0, frame.1);
    let mut fb = Framebuffer::new(width, height, format)?;
    fb.clear_color([0.0, 0.0, 0.0, 0.0]);
    Ok(fb)
}

/// Snapshots of the framebuffers a pass reads (another's, or its own in a
/// screen pass), by framebuffer id.
/// Whether the pass reads its own target's size or depth (`xs`, `δu`).
fn reads_own_target(m: &Module, pi: &PassInterface) -> bool {
    let mut roots = vec![pi.output];
    roots.extend(pi.condition);
    m.reachable(&roots).into_iter().any(|h| matches!(m.exprs[h], Expr::Pixel { .. } | Expr::TexelCoord))
}

fn framebuffer_reads(
    m: &Module,
    pi: &PassInterface,
    targets: &BTreeMap<String, Framebuffer>,
) -> HashMap<u32, Framebuffer> {
    let mut reads: HashMap<u32, Framebuffer> = HashMap::new();
    let mut roots = vec![pi.output];
    roots.extend(pi.condition);
    for h in m.reachable(&roots) {
        if let Expr::FramebufferRead { framebuffer, .. } = m.exprs[h] {
            let fname = &m.framebuffers[framebuffer as usize].name;
            if let Some(fb) = targets.get(fname) {
                reads.entry(framebuffer).or_insert_with(|| fb.clone());
            }
        }
    }
    reads
}

/// The draws of a frame so far ([`PlanRenderer::render_with`]): their
/// counters, and the caller's progress report.
struct Draws<'p, 's> {
    stats: DrawStats,
    /// Adaptive sample shading's settings, `None` for a full render.
    settings: Option<&'s super::AdaptiveSettings>,
    adaptive: Option<super::AdaptiveStats>,
    done: usize,
    total: usize,
    progress: &'p mut dyn FnMut(usize, usize),
}

impl Draws<'_, '_> {
    /// Counts `n` draws done and reports progress.
    fn advance(&mut self, n: usize) {
        self.done += n;
        (self.progress)(self.done, self.total);
    }
}

/// A pass's register-combiner configuration ready to run, and the IR nodes
/// whose values load texture registers 0-3, primary and secondary.
struct CombinerSetup {
    machine: PixelEmulator,
    registers: [Option<Handle<Expr>>; 6],
}

fn add(total: &mut DrawStats, s: &DrawStats) {
    total.triangles_in += s.triangles_in;
    total.triangles_setup += s.triangles_setup;
    total.culled += s.culled;
    total.degenerate += s.degenerate;
    total.fragments += s.fragments;
    total.shaded += s.shaded;
    total.written += s.written;
}

/// A texture or temporary a pass rendered: its pixels (for lookups by
/// screen position) and a filtered texture (for lookups by coordinates).
struct Rendered {
    width: u32,
    height: u32,
    pixels: Vec<[f32; 4]>,
    texture: Texture2D,
}

impl Rendered {
    /// The texel at a pixel position (`T xs`, `T δπx`), or sampled at
    /// texture coordinates (level 0).
    fn sample(&self, c: Value, coords_ty: Ty, filter: Filter) -> Value {
        if coords_ty == Ty::Position {
            match to_pixel(c, self.width, self.height, 0.0) {
                Some((x, y)) => self.pixels[(y * self.width + x) as usize].map(|v| v as f64),
                None => [0.0; 4],
            }
        } else {
            self.texture.sample(c[0] as f32, c[1] as f32, filter, 0.0).map(|v| v as f64)
        }
    }

    fn from_framebuffer(fb: &Framebuffer, mipmap: bool) -> Rendered {
        let pixels = fb.read_back_rgba_f32();
        let t = Texture2D::new(
            TexelFormat::F32,
            Wrap::ClampToEdge,
            Level::new(fb.width(), fb.height(), pixels.clone()),
        );
        let texture = if mipmap { t.with_box_mipmaps() } else { t };
        Rendered { width: fb.width(), height: fb.height(), pixels, texture }
    }
}

/// The screen-filling rectangle of screen and texel passes.
struct Quad;

impl VertexStage for Quad {
    fn n_vertices(&self) -> usize {
        4
    }
    fn n_varyings(&self) -> usize {
        0
    }
    fn shade_vertex(&self, index: u32, _varyings: &mut [f32]) -> [f32; 4] {
        // Counter-clockwise in NDC.
        match index {
            0 => [-1.0, -1.0, 0.0, 1.0],
            1 => [1.0, -1.0, 0.0, 1.0],
            2 => [1.0, 1.0, 0.0, 1.0],
            _ => [-1.0, 1.0, 0.0, 1.0],
        }
    }
}

/// The vertex stage of one object in one pass: every vertex evaluated up
/// front (in f64), in parallel.
struct MeshVertices {
    n_varyings: usize,
    varyings: Vec<f32>,
    clip: Vec<[f32; 4]>,
}

impl MeshVertices {
    fn new(m: &Module, object: &BoundObject, pi: &PassInterface, uniforms: &[Option<Value>]) -> MeshVertices {
        let values: Vec<Handle<Expr>> = pi
            .interpolants
            .iter()
            .map(|h| match m.exprs[*h] {
                Expr::Interpolate { value, .. } => value,
                _ => *h,
            })
            .collect();
        let mut roots = values.clone();
        roots.extend(pi.position);
        let n = object.n_vertices();
        let nv = 4 * values.len();
        let chunk = 256;
        let results: Vec<(Vec<f32>, Vec<[f32; 4]>)> = (0..n.div_ceil(chunk))
            .into_par_iter()
            .map(|c| {
                let mut ev = ir::eval::Evaluator::new(m, &roots, crate::numerics::Precision::Exact);
                let mut vary = Vec::with_capacity(chunk * nv);
                let mut clip = Vec::with_capacity(chunk);
                for v in c * chunk..((c + 1) * chunk).min(n) {
                    let mut env = bind::VertexEnv { object, module: m, vertex: v, uniforms };
                    let r = ev.eval(&mut env);
                    for (k, &value) in values.iter().enumerate() {
                        let ty = m.info(value).ty;
                        let x = widen_vertex(r.values[k], ty);
                        vary.extend(x.map(|c| c as f32));
                    }
                    let p = match pi.position {
                        // Into a texture by its coordinates (seeds/001 (15)): clip (2u − 1, 1 − 2v), row 0 at v = 0.
                        Some(p) if m.info(p).ty == Ty::Vec2 => {
                            let [u, v, ..] = r.values[values.len()];
                            [2.0 * u - 1.0, 1.0 - 2.0 * v, 0.0, 1.0]
                        }
                        Some(_) => r.values[values.len()],
                        None => [0.0, 0.0, 0.0, 1.0],
                    };
                    clip.push(p.map(|c| c as f32));
                }
                (vary, clip)
            })
            .collect();
        let mut varyings = Vec::with_capacity(n * nv);
        let mut clip = Vec::with_capacity(n);
        for (v, c) in results {
            varyings.extend(v);
            clip.extend(c);
        }
        MeshVertices { n_varyings: nv, varyings, clip }
    }
}

/// A per-vertex value as a varying: a scalar as itself in lane 0 (then
/// splatted again when read), others as they are.
fn widen_vertex(v: Value, _ty: Ty) -> Value {
    v
}

impl VertexStage for MeshVertices {
    fn n_vertices(&self) -> usize {
        self.clip.len()
    }
    fn n_varyings(&self) -> usize {
        self.n_varyings
    }
    fn shade_vertex(&self, index: u32, varyings: &mut [f32]) -> [f32; 4] {
        let i = index as usize;
        varyings.copy_from_slice(&self.varyings[i * self.n_varyings..(i + 1) * self.n_varyings]);
        self.clip[i]
    }
}

/// What a texture unit reads in this pass.
enum Source<'r> {
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

#[derive(Clone, Copy, Debug, PartialEq)]
enum Leaf {
    Uniform(Value),
    /// Interpolant k (varyings 4k..4k+4).
    Varying {
        k: usize,
    },
    Lookup {
        texture: TextureId,
        coords_ty: Ty,
        lod_from: Option<usize>,
    },
    /// Member `member` of a fat texel of `texture` (Pipeline Grammar, eq. (6), (14),
    /// (16)): layer `member` sampled at the lookup's coordinates.
    FatMember {
        texture: TextureId,
        member: u8,
        coords_ty: Ty,
    },
    Framebuffer {
        framebuffer: u32,
        channel: FbChannel,
    },
    Pixel(Frequency),
    TexelCoord,
    Depth,
    /// `π p` of a per-pixel point (`πl π⁻¹ xs`, Pipeline Grammar, Section 3.5):
    /// by the projection's model → clip matrix of the scene's first object
    /// (in `πl π⁻¹` the model matrix cancels), as the WGSL target does.
    Project {
        matrix: glam::Mat4,
        inverse: bool,
        ty: Ty,
    },
    /// A value the fragment stage cannot know (NaN).
    Unknown,
}

#[derive(Clone, Debug)]
struct Step<'m> {
    expr: &'m Expr,
    ty: Ty,
    slot: u32,
    ops: [u32; 4],
    n_ops: u8,
    leaf: Option<Leaf>,
    /// fixed9: a per-fragment result, clamped and rounded ([`fixed9`]).
    quantize: bool,
    /// fixed9: a constant or uniform result, which the compiler folds into
    /// a constant register and an output scale: rounded, not clamped.
    folded: bool,
    /// A colour texel loaded into a combiner register: kept as the texture
    /// unit delivers it (all four channels: the register has the texture's
    /// alpha even where the program reads only rgb), not narrowed to the
    /// node's type. A scalar texel is an intensity (v, v, v, v), as the
    /// program's type says.
    raw: bool,
    /// fixed9: how a register write of a power or a quotient is rounded.
    register: RegisterOp,
    /// The step's arithmetic, decided once.
    kernel: Kernel,
}

/// A step's arithmetic when it is one of the common operations, decided
/// when the program is built, so that a fragment does not walk the IR's
/// expression kinds again for it; each computes exactly what
/// [`ir::eval::apply`] computes, which [`Kernel::General`] calls.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Kernel {
    Add,
    Sub,
    Mul,
    Neg,
    /// A dot product of vectors of this width.
    Dot(usize),
    Swizzle([u8; 4], u8),
    /// rgb widened to rgba: alpha 1.
    RgbToRgba,
    /// A conversion that keeps the value.
    Same,
    Max,
    Min,
    Clamp,
    Saturate,
    Expand,
    Compress,
    Mix,
    /// `normalize` of a vector of this width.
    Normalize(usize),
    General,
}

impl Kernel {
    fn of(m: &Module, expr: &Expr, ty: Ty) -> Kernel {
        use ir::{BinaryOp, UnaryOp};
        match expr {
            Expr::Binary { op: BinaryOp::Add, .. } => Kernel::Add,
            Expr::Binary { op: BinaryOp::Sub, .. } => Kernel::Sub,
            Expr::Binary { op: BinaryOp::Mul, .. } => Kernel::Mul,
            Expr::Unary { op: UnaryOp::Neg, .. } => Kernel::Neg,
            Expr::Binary { op: BinaryOp::Dot, lhs, .. } => Kernel::Dot(m.info(*lhs).ty.width()),
            Expr::Swizzle { pattern, len, .. } => Kernel::Swizzle(*pattern, *len),
            Expr::Convert { value, to } if m.info(*value).ty == Ty::Rgb && *to == Ty::Rgba => {
                Kernel::RgbToRgba
            }
            Expr::Convert { .. } => Kernel::Same,
            Expr::Math { fun, .. } => match fun {
                ir::MathFunction::Max => Kernel::Max,
                ir::MathFunction::Min => Kernel::Min,
                ir::MathFunction::Clamp => Kernel::Clamp,
                ir::MathFunction::Saturate => Kernel::Saturate,
                ir::MathFunction::Expand => Kernel::Expand,
                ir::MathFunction::Compress => Kernel::Compress,
                ir::MathFunction::Mix => Kernel::Mix,
                ir::MathFunction::Normalize => Kernel::Normalize(ty.width()),
                _ => Kernel::General,
            },
            _ => Kernel::General,
        }
    }

    #[inline]
    fn apply(self, m: &Module, expr: &Expr, ty: Ty, o: &[Value]) -> Value {
        match self {
            Kernel::Add => [0, 1, 2, 3].map(|i| o[0][i] + o[1][i]),
            Kernel::Sub => [0, 1, 2, 3].map(|i| o[0][i] - o[1][i]),
            Kernel::Mul => [0, 1, 2, 3].map(|i| o[0][i] * o[1][i]),
            Kernel::Neg => [0, 1, 2, 3].map(|i| -o[0][i]),
            Kernel::Dot(width) => [(0..width.min(4)).map(|i| o[0][i] * o[1][i]).sum(); 4],
            Kernel::Swizzle(pattern, len) => {
                let mut v = [0.0; 4];
                for (k, &i) in pattern[..len as usize].iter().enumerate() {
                    v[k] = o[0][i as usize & 3];
                }
                v
            }
            Kernel::RgbToRgba => [o[0][0], o[0][1], o[0][2], 1.0],
            Kernel::Same => o[0],
            Kernel::Max => [0, 1, 2, 3].map(|i| o[0][i].max(o[1][i])),
            Kernel::Min => [0, 1, 2, 3].map(|i| o[0][i].min(o[1][i])),
            Kernel::Clamp => [0, 1, 2, 3].map(|i| o[0][i].max(o[1][i]).min(o[2][i])),
            Kernel::Saturate => o[0].map(|x| x.clamp(0.0, 1.0)),
            Kernel::Expand => o[0].map(|x| 2.0 * x - 1.0),
            Kernel::Compress => o[0].map(|x| (x + 1.0) / 2.0),
            Kernel::Mix => [0, 1, 2, 3].map(|i| o[0][i] * (1.0 - o[2][i]) + o[1][i] * o[2][i]),
            Kernel::Normalize(width) => {
                let a = o[0];
                let n = (0..width.min(4)).map(|i| a[i] * a[i]).sum::<f64>().sqrt();
                if n == 0.0 {
                    [0.0; 4]
                } else {
                    a.map(|x| x / n)
                }
            }
            Kernel::General => ir::eval::apply(m, expr, ty, o),
        }
    }
}

/// A fixed9 register write the WGSL's hardware fidelity computes its own
/// way, so the CPU computes it that way too.
#[derive(Clone, Copy, Debug, PartialEq)]
enum RegisterOp {
    /// Any other: the operation in float, rounded once.
    Rounded,
    /// `x^k` by `k`'s squarings, each product rounded ([`ir::squaring_exponent`]).
    Squarings(u32),
    /// A quotient rounded from the registers' integers ([`fixed9_quotient`]).
    Quotient,
}

/// The fragment stage of one pass: the reachable nodes of the output (and
/// condition) in topological order, each with a slot.
struct FragmentProgram<'a> {
    module: &'a Module,
    mode: Precision,
    steps: Vec<Step<'a>>,
    constants: Vec<(u32, Value)>,
    n_slots: usize,
    output: u32,
    output_ty: Ty,
    condition: Option<u32>,
    sources: Vec<Source<'a>>,
    /// Per texture: the layers of its fat texels, rendered by a bundle pass.
    fat: Vec<Vec<&'a Rendered>>,
    reads: HashMap<u32, Framebuffer>,
    own: Option<Framebuffer>,
    filters: Vec<Filter>,
    /// fixed9 with a generated setup: the machine, and the slots of the
    /// values that load texture 0-3, primary and secondary.
    combiners: Option<(PixelEmulator, [Option<u32>; 6])>,
    /// Fragments whose value was not finite ([`Frame::nonfinite`]).
    nonfinite: AtomicU64,
    /// [`PlanRenderer::set_rounding_bias`] (zero: the model).
    tie: RoundingBias,
    /// [`PlanRenderer::set_sampling_latitude`].
    latitude: unit::Latitude,
    /// [`PlanRenderer::set_batched`].
    batched: bool,
    /// The `f32` mode's program compiled into lane code (batched only).
    lanes: Option<lanes::LaneProgram>,
}

/// Per texture, the layers of its fat texels a bundle pass rendered (`T`,
/// `T#1`, `T#2`, …).
fn fat_texel_layers<'a>(m: &Module, rendered: &'a BTreeMap<String, Rendered>) -> Vec<Vec<&'a Rendered>> {
    m.textures
        .iter()
        .zip(ir::fat_layers(m))
        .map(|(t, n)| {
            (0..n)
                .map_while(|i| rendered.get(&if i == 0 { t.name.clone() } else { format!("{}#{i}", t.name) }))
                .collect()
        })
        .collect()
}

/// What turning a pass's reachable nodes into [`Step`]s reads: the
/// renderer, the mode, the analyses of the fragment reach and the pass's
/// texture sources.
struct StepBuilder<'c, 'a> {
    r: &'a PlanRenderer<'a>,
    mode: Precision,
    /// fixed9 with a generated combiner setup: the IR only loads registers.
    combiners: bool,
    address: Vec<bool>,
    register_reads: Vec<bool>,
    varying_of: HashMap<Handle<Expr>, usize>,
    sources: &'c [Source<'a>],
    fat: &'c [Vec<&'a Rendered>],
    first_object: Option<&'c BoundObject<'c>>,
}

impl<'a> StepBuilder<'_, 'a> {
    /// The value of constant node `i`: in fixed9 a register value in the
    /// combiners' precision (as WGSL's hardware fidelity writes it; scale
    /// factors beyond ±1 and addresses stay exact), in f32 an f32.
    fn constant(&self, i: usize, c: &ir::Constant) -> Value {
        let v = ir::eval::value(c);
        let register = self.mode == Precision::Fixed9
            && !self.combiners
            && !self.address[i]
            && c.values().iter().all(|x| x.abs() <= 1.0);
        if register {
            v.map(|x| fixed9_with(x, self.r.rounding_bias.register_steps))
        } else if self.mode == Precision::F32 {
            // f32: every node in f32, constants too (as WGSL holds them).
            v.map(|x| x as f32 as f64)
        } else {
            v
        }
    }

    /// The leaf a node reads at the fragment (`None` for an operation the
    /// IR's semantics computes), and the slots of its operands.
    fn leaf_and_operands(
        &self,
        h: Handle<Expr>,
        expr: &Expr,
        slot_of: &[u32],
    ) -> Result<(Option<Leaf>, [u32; 4], u8), RenderError> {
        let m = &self.r.planned.module;
        let mut ops = [u32::MAX; 4];
        let mut n_ops = 0u8;
        let leaf = match expr {
            Expr::Uniform(id) => Some(Leaf::Uniform(
                self.r
                    .uniforms
                    .get(*id as usize)
                    .copied()
                    .flatten()
                    .or_else(|| m.uniforms[*id as usize].default.as_ref().map(ir::eval::value))
                    .unwrap_or(ir::eval::NAN),
            )),
            Expr::Interpolate { .. } => match self.varying_of.get(&h) {
                Some(&k) => Some(Leaf::Varying { k }),
                None => Some(Leaf::Unknown),
            },
            Expr::Lookup { texture, coords } => {
                ops[0] = slot_of[coords.index()];
                n_ops = 1;
                let lod_from = lod_varying(m, *coords).and_then(|c| self.varying_of.get(&c).copied());
                if matches!(self.sources[*texture as usize], Source::Missing) {
                    return Err(RenderError::Unsupported(format!(
                        "texture `{}` is read before any pass renders it",
                        m.textures[*texture as usize].name
                    )));
                }
                Some(Leaf::Lookup { texture: *texture, coords_ty: m.info(*coords).ty, lod_from })
            }
            Expr::FramebufferRead { framebuffer, channel, position } => {
                ops[0] = slot_of[position.index()];
                n_ops = 1;
                Some(Leaf::Framebuffer { framebuffer: *framebuffer, channel: *channel })
            }
            Expr::Depth(p) => {
                ops[0] = slot_of[p.index()];
                n_ops = 1;
                Some(Leaf::Depth)
            }
            Expr::Pixel { freq } => Some(Leaf::Pixel(*freq)),
            Expr::TexelCoord => Some(Leaf::TexelCoord),
            Expr::FatMember { texel, member } => {
                let Expr::Lookup { texture, coords } = m.exprs[*texel] else {
                    return Err(RenderError::Unsupported("a fat member of something not a lookup".into()));
                };
                if self.fat[texture as usize].len() <= *member as usize {
                    return Err(RenderError::Unsupported(format!(
                        "member {} of the fat texels of `{}`, which no pass renders (a fat texture from an image has no layout yet)",
                        member + 1,
                        m.textures[texture as usize].name
                    )));
                }
                ops[0] = slot_of[coords.index()];
                n_ops = 1;
                Some(Leaf::FatMember { texture, member: *member, coords_ty: m.info(coords).ty })
            }
            Expr::Project { projection, value } if m.info(*value).freq.is_sample() => match self.first_object
            {
                Some(object) => {
                    ops[0] = slot_of[value.index()];
                    n_ops = 1;
                    Some(Leaf::Project {
                        matrix: object.clip_matrix(projection),
                        inverse: projection.inverse,
                        ty: m.info(*value).ty,
                    })
                }
                None => Some(Leaf::Unknown),
            },
            Expr::VertexPosition(_)
            | Expr::TexCoord { .. }
            | Expr::Vector { .. }
            | Expr::Project { .. }
            | Expr::Bundle(_) => Some(Leaf::Unknown),
            e => {
                let operands = e.operands();
                if operands.len() > 4 {
                    return Err(RenderError::Unsupported("an operation with more than four operands".into()));
                }
                for (k, o) in operands.iter().enumerate() {
                    ops[k] = slot_of[o.index()];
                }
                n_ops = operands.len() as u8;
                None
            }
        };
        Ok((leaf, ops, n_ops))
    }

    /// Node `h`'s step, with how fixed9 rounds its result.
    fn step(
        &self,
        h: Handle<Expr>,
        expr: &'a Expr,
        slot: u32,
        ops: [u32; 4],
        n_ops: u8,
        leaf: Option<Leaf>,
    ) -> Step<'a> {
        let m = &self.r.planned.module;
        let i = h.index();
        let ty = m.info(h).ty;
        let per_sample = m.info(h).freq.is_sample();
        let per_operation =
            self.mode == Precision::Fixed9 && !self.combiners && !self.address[i] && leaf.is_none();
        // A register write clamps where the hardware's would: a value a
        // product or function reads from a register, and the powers and
        // quotients the generator cannot fold (`ir::register_reads`).
        let own_register = self.register_reads[i]
            || ir::squaring_exponent(m, h).is_some()
            || matches!(expr, Expr::Binary { op: ir::BinaryOp::Div, .. });
        let quantize = per_operation && per_sample && own_register;
        let folded = per_operation && !quantize;
        let raw = self.combiners
            && ty.width() >= 3
            && matches!(leaf, Some(Leaf::Lookup { .. } | Leaf::Framebuffer { .. }));
        let register = match (quantize, ir::squaring_exponent(m, h)) {
            (false, _) => RegisterOp::Rounded,
            (true, Some(k)) => RegisterOp::Squarings(k),
            (true, None) if matches!(expr, Expr::Binary { op: ir::BinaryOp::Div, .. }) => {
                RegisterOp::Quotient
            }
            (true, None) => RegisterOp::Rounded,
        };
        let kernel = Kernel::of(m, expr, ty);
        Step { expr, ty, slot, ops, n_ops, leaf, quantize, folded, raw, register, kernel }
    }
}

thread_local! {
    static SLOTS: RefCell<Vec<Value>> = const { RefCell::new(Vec::new()) };
    /// Slots and varyings of a quad neighbour ([`FragmentProgram::quad_coords`]).
    static QUAD_SCRATCH: RefCell<(Vec<Value>, Vec<f32>)> = const { RefCell::new((Vec::new(), Vec::new())) };
}

impl<'a> FragmentProgram<'a> {
    // Each argument is one of the pass's inputs, owned or borrowed differently.
    #[allow(clippy::too_many_arguments)]
    fn new(
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
        roots.extend(pi.condition);
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
            condition: pi.condition.map(|c| slot_of[c.index()]),
            sources,
            fat,
            reads,
            own,
            filters,
            combiners,
            nonfinite: AtomicU64::new(0),
            tie: r.rounding_bias,
            latitude: r.latitude,
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
    fn texture_sources(
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
            filters.push(decl.map_or(Filter::Bilinear, |d| d.filter));
            let baked = match FragmentProgram::baked_by(r, &t.name) {
                Some(index) if mode == Precision::Exact && looked_up.contains(&(id as TextureId)) => {
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
    fn baked_by(r: &PlanRenderer, name: &str) -> Option<usize> {
        r.planned.plan.passes.iter().position(|p| {
            matches!(p.geometry, Geometry::Texels)
                && matches!(&p.target, RenderTarget::Texture { name: target } if *target == name)
        })
    }

    /// `exact`: texel pass `index` as a program to evaluate at a lookup's
    /// coordinates ([`Source::Baked`]). Only a function of the texel
    /// coordinate and uniforms can be evaluated anywhere (not solid
    /// mapping's (16), which reads the texture itself): `None` otherwise.
    fn baked(
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
    fn leaf(
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
            Leaf::FatMember { texture, member, coords_ty } => self.fat[texture as usize][member as usize]
                .sample(operand, coords_ty, self.filters[texture as usize]),
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
    fn lookup(
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
                    Texture::Flat(t) if self.mode != Precision::Exact => {
                        // f32 and fixed9 sample as the WGSL target's texture
                        // unit does (`textures::unit`: a level of detail per
                        // 2×2 quad; 8-bit textures filtered in 8.8 fixed
                        // point in fixed9, as hardware fidelity uploads them,
                        // in float in f32, as exact fidelity does), so the
                        // wgpu image agrees with them (issue 5).
                        let (u, v) = texture_uv(c, coords_ty);
                        let lod = match (lod_from, quad) {
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
                        };
                        let arithmetic = if self.mode == Precision::Fixed9 {
                            unit::Arithmetic::Fixed8 { tie_bias: self.tie.texel_quanta }
                        } else {
                            unit::Arithmetic::Float
                        };
                        unit::sample_2d_with(t, u as f32, v as f32, filter, lod, arithmetic, self.latitude)
                    }
                    Texture::Cube(t) if self.mode != Precision::Exact => {
                        let d = [c[0] as f32, c[1] as f32, c[2] as f32];
                        unit::sample_cube_with(t, d, filter, self.latitude.weights)
                    }
                    Texture::Flat(t) => {
                        let (u, v) = texture_uv(c, coords_ty);
                        let lod = match (lod_from, quad) {
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
                        };
                        t.sample(u as f32, v as f32, filter, lod)
                    }
                    Texture::Cube(t) => t.sample([c[0] as f32, c[1] as f32, c[2] as f32], filter, 0.0),
                    Texture::DualParaboloid(t) => {
                        t.sample([c[0] as f32, c[1] as f32, c[2] as f32], filter, 0.0)
                    }
                };
                out.map(|x| x as f64)
            }
            Source::Rendered(rt) => rt.sample(c, coords_ty, filter),
            Source::Baked { program, wrap } => {
                let (u, v) = texture_uv(c, coords_ty);
                let at = |x: f64| match wrap {
                    Wrap::Repeat => x - x.floor(),
                    _ => x.clamp(0.0, 1.0),
                };
                let fragment =
                    Fragment { x: 0, y: 0, depth: 0.0, front_facing: true, inv_w: 1.0, gradients: &[] };
                // The outer fragment's slots are borrowed: the nested program has its own.
                let mut slots = vec![[0.0; 4]; program.n_slots];
                program.run(&mut slots, &fragment, &[], Some([at(u), at(v)]));
                slots[program.output as usize]
            }
            Source::Missing => ir::eval::NAN,
        }
    }

    /// Runs the IR steps; returns whether the fragment is discarded.
    /// `texel_at`: the texel coordinate when a baked texture's function is
    /// evaluated at a lookup ([`Source::Baked`]) instead of at a pixel.
    fn run(
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
    fn run_steps(
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
    fn step_value(
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
    fn stored(&self, s: &Step, v: Value) -> Value {
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
    fn mipmapped(&self, texture: TextureId) -> bool {
        matches!(&self.sources[texture as usize], Source::Bound { exact: None, texture: b } if matches!(&b.texture, Texture::Flat(t) if t.levels.len() > 1))
    }

    /// The coordinates of the dependent lookup of step `step` (`c` at this
    /// pixel) at the top-left, top-right and bottom-left pixels of this
    /// pixel's 2×2 quad, whose differences are the coarse derivatives a GPU
    /// takes for its level of detail (WGSL `textureSample`: implicit
    /// derivatives of whatever the coordinates are). The other pixels run
    /// the steps before the lookup on their own varyings (extrapolated
    /// outside the triangle: helper pixels); lookups among those steps
    /// that are themselves dependent sample level 0 there.
    fn quad_coords(
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
    fn colour(&self, slot: impl Fn(u32) -> Value) -> Value {
        match &self.combiners {
            Some((machine, registers)) => {
                machine.run(&self.registers(registers, slot)).map(|c| c as f64 / 255.0)
            }
            None => slot(self.output),
        }
    }

    /// The combiners' per-pixel registers loaded from the slots `registers`
    /// names (texture 0-3, primary, secondary), rounded as [`FragmentProgram::colour`] says.
    fn registers(&self, registers: &[Option<u32>; 6], slot: impl Fn(u32) -> Value) -> PixelRegisters {
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
    fn output(&self, v: Value) -> [f32; 4] {
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

/// The (u, v) a 2-D or 1-D texture is sampled at: a scalar indexes a 1-D
/// table at its centre row; a clip-space position (`T δπl x`, Olano &
/// Lastra's projective texturing) projectively, `(½x/w + ½, ½ − ½y/w)` —
/// v = 0 is the top row, as the WGSL target's convention.
fn texture_uv(c: Value, coords_ty: Ty) -> (f64, f64) {
    match coords_ty {
        Ty::Scalar => (c[0], 0.5),
        Ty::Position if c[3] != 0.0 => (0.5 * c[0] / c[3] + 0.5, 0.5 - 0.5 * c[1] / c[3]),
        _ => (c[0], c[1]),
    }
}

/// The screen derivatives `([du/dx, du/dy], [dv/dx, dv/dy])` of
/// [`texture_uv`] from those of the coordinate varying's lanes (`d(i)` of
/// lane i, values `lanes`): by the quotient rule for a projective position.
fn uv_derivatives(coords_ty: Ty, lanes: &[f32], d: impl Fn(usize) -> [f32; 2]) -> ([f32; 2], [f32; 2]) {
    if coords_ty != Ty::Position || lanes[3] == 0.0 {
        return (d(0), d(1));
    }
    let (x, y, w) = (lanes[0], lanes[1], lanes[3]);
    let (dx, dy, dw) = (d(0), d(1), d(3));
    let q = |a: f32, da: [f32; 2], sign: f32| [0, 1].map(|k| sign * 0.5 * (da[k] * w - a * dw[k]) / (w * w));
    (q(x, dx, 1.0), q(y, dy, -1.0))
}

/// The varying whose derivatives choose the mipmap level of a lookup at
/// `coords`: the coordinates themselves when they are a δ (or a swizzle of one).
fn lod_varying(m: &Module, coords: Handle<Expr>) -> Option<Handle<Expr>> {
    match &m.exprs[coords] {
        Expr::Interpolate { .. } => Some(coords),
        Expr::Swizzle { value, .. } => lod_varying(m, *value),
        _ => None,
    }
}

/// A clip-space position (x, y, z, w) to a pixel (row 0 at the top).
/// (`shift`: of the pixel boundaries, in pixels — [`RoundingBias`].)
fn to_pixel(p: Value, width: u32, height: u32, shift: f64) -> Option<(u32, u32)> {
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
    fn shade(&self, fragment: &Fragment, varyings: &[f32], out: &mut [f32; 4]) -> FragmentResult {
        SLOTS.with(|cell| {
            let mut slots = cell.borrow_mut();
            if slots.len() < self.n_slots {
                slots.resize(self.n_slots, [0.0; 4]);
            }
            if self.run(&mut slots[..self.n_slots], fragment, varyings, None) {
                return FragmentResult::Discard;
            }
            *out = self.output(self.colour(|s| slots[s as usize]));
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
            self.shade_compiled(lp, fragments, varyings, out, results)
        } else if self.batched {
            self.shade_lanes(fragments, varyings, out, results)
        } else {
            super::shade_each(self, fragments, varyings, out, results)
        }
    }
}

/// The error of `test` against `reference` over RGB: max abs, RMSE, PSNR.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ErrorReport {
    pub max_abs: f32,
    pub rmse: f64,
    pub psnr: f64,
}

/// Compares two images of the same size; both are clamped to [0, 1] first
/// (what a display shows).
pub fn compare(reference: &Framebuffer, test: &Framebuffer) -> ErrorReport {
    let clamp = |v: Vec<[f32; 4]>| {
        v.into_iter().map(|p| p.map(|c| if c.is_nan() { 0.0 } else { c.clamp(0.0, 1.0) })).collect::<Vec<_>>()
    };
    let a = clamp(reference.to_rgba_f32());
    let b = clamp(test.to_rgba_f32());
    let e = super::image_error(&a, &b);
    let rmse = if e.psnr.is_infinite() { 0.0 } else { 10f64.powf(-e.psnr / 20.0) };
    ErrorReport { max_abs: e.max_abs, rmse, psnr: e.psnr }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every node of every example whose step gets a specialized
    /// [`Kernel`] computes, on operand values spanning signs, zero and
    /// magnitudes, bit for bit what `ir::eval::apply` computes (after the
    /// canonical form both pass through).
    #[test]
    fn kernels_compute_what_eval_computes() {
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/examples");
        let values = [-2.5, -1.0, -0.25, 0.0, 0.125, 0.5, 1.0, 3.0];
        let mut checked = 0;
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.extension().is_none_or(|e| e != "shd") {
                continue;
            }
            let (program, _) = crate::parser::check(&std::fs::read_to_string(&path).unwrap());
            let (m, _) = ir::lower(&program);
            for (h, expr) in m.exprs.arena().iter() {
                let ty = m.info(h).ty;
                let kernel = Kernel::of(&m, expr, ty);
                if kernel == Kernel::General {
                    continue;
                }
                let n = expr.operands().len();
                for k in 0..values.len() {
                    let o: Vec<Value> = (0..n)
                        .map(|j| [0, 1, 2, 3].map(|c| values[(k + 3 * j + c) % values.len()]))
                        .collect();
                    let fast = ir::eval::canonical(ty, kernel.apply(&m, expr, ty, &o));
                    let slow = ir::eval::apply(&m, expr, ty, &o);
                    assert_eq!(
                        fast.map(f64::to_bits),
                        slow.map(f64::to_bits),
                        "{kernel:?} {expr:?} on {o:?}"
                    );
                    checked += 1;
                }
            }
        }
        assert!(checked > 500, "{checked}");
    }
}
