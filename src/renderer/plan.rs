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
//!   fixed point), f32 framebuffers, except that a framebuffer declared
//!   `rgba8` (the default `C`) and a texture declared 8-bit that a pass
//!   renders into store 8 bits, clamped and rounded to k/255 at every
//!   write (`ColorFormat::Rgba8`), as GL's fixed-point buffers and wgpu's
//!   `Rgba8Unorm` store them (§2.13.9, §4.1.8: clamped, then converted
//!   with round-to-nearest), so that a later pass reads what the GPU's
//!   reads (`exact` keeps them unrounded: it is the program in ideal
//!   arithmetic, the reference a plan's losses are measured against, and
//!   an 8-bit store between passes is such a loss;
//!   [`PlanRenderer::set_unrounded_targets`] keeps them so in `f32` too);
//!   textures declared 16-bit or float are
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
//!   ([`fixed9_folded_with`](crate::numerics::fixed9_folded_with)). Values that only address textures (lookup
//!   coordinates, framebuffer positions) are not quantized: the texture
//!   units iterate them in float.

use glam::Vec3;
use std::collections::BTreeMap;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use super::{ColorFormat, CullMode, DrawStats, Framebuffer, Pass as RasterPass, RenderError};
use crate::backends::combiners::{self, PixelEmulator};
use crate::ir::{self, eval::Value, Expr, Handle};
use crate::pipeline::{Geometry, Pass, PassInterface, Planned, RenderTarget};
use crate::scene::bind::{self, BoundObject, BoundTexture, TextureDecl, TextureQuality};
use crate::scene::{Scene, SceneAssets};
use crate::textures::unit;

use crate::numerics::Precision;

mod batch;
mod lanes;
mod program;
mod report;
mod shade;
mod targets;
mod vertex;
pub use lanes::{set_dispatch as set_lane_dispatch, Dispatch as LaneDispatch};
use program::{Kernel, Leaf, RegisterOp, Step};
pub use report::{compare, ErrorReport};
pub use shade::exact_lookup;
use shade::{uv_derivatives, FragmentProgram, Source};
use targets::{framebuffer_reads, new_target, reads_own_target, Rendered};
use vertex::{MeshVertices, Quad};

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
    /// In steps of 2⁻²⁴ of normalized device depth: how far a shadow volume
    /// is drawn behind (positive) or before the surfaces it shadows. Its caps
    /// and walls are other primitives than the surface, and GL guarantees
    /// depth invariance only for the same primitive (GL 1.x, Appendix A), so
    /// where a volume grazes a surface at the terminator the depth tests of
    /// two implementations may tie either way.
    pub volume_depth_steps: f32,
    /// In 1/256 pixel, along x and y: how far a shadow volume's vertices
    /// are moved on the screen. Vulkan lets an implementation snap them to
    /// 1/16 pixel (`subPixelPrecisionBits` ≥ 4), so which volume triangle
    /// covers a pixel centre near its edge may differ between two of them.
    pub volume_subpixels: [f32; 2],
}

impl RoundingBias {
    /// The shadow volumes' offset in normalized device coordinates at
    /// `width`×`height` (a pixel is 2/width of them).
    fn volume_offset(&self, width: u32, height: u32) -> Vec3 {
        let [x, y] = self.volume_subpixels.map(|p| p / 256.0);
        Vec3::new(2.0 * x / width as f32, 2.0 * y / height as f32, self.volume_depth_steps * 2f32.powi(-24))
    }
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
    /// See [`PlanRenderer::set_unrounded_targets`].
    unrounded: bool,
    /// What stand-ins were used, for the user.
    pub notes: Vec<String>,
    /// Images of earlier frames to render into ([`PlanRenderer::recycle`]).
    pool: std::sync::Mutex<Vec<Framebuffer>>,
}

/// The most images [`PlanRenderer::recycle`] keeps.
const POOL: usize = 8;

impl<'a> PlanRenderer<'a> {
    /// Binds `planned` to a scene and its assets; its module carries the
    /// program's texture declarations ([`crate::ir::declared`]), so
    /// `_program` is no longer read (kept so that callers stay unchanged
    /// until they drop it).
    pub fn new(
        planned: &'a Planned,
        _program: &crate::parser::ast::Program,
        scene: &'a Scene,
        assets: &'a SceneAssets,
    ) -> Result<PlanRenderer<'a>, RenderError> {
        // A plan that breaks the contract (`pipeline::validate`) is refused, not run.
        planned.validate().map_err(|d| {
            RenderError::Unsupported(d.iter().map(|d| d.message.clone()).collect::<Vec<_>>().join("; "))
        })?;
        let mut decls = bind::texture_decls(&planned.module, &scene.constants);
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
            unrounded: false,
            notes,
            pool: Default::default(),
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

    /// Whether `f32` keeps the 8-bit (`rgba8`) targets unrounded, as
    /// `exact` does (values clamped to [0, 1] where read back, not rounded
    /// to k/255): off by default, where `f32` stores 8 bits as wgpu and GL
    /// do. On, a plan's render differs from its meaning's only by the
    /// plan's structure (its split into passes, each pass's arithmetic),
    /// not by the 8-bit stores between its passes that a single pass does
    /// not make: the checks of a split against the program's meaning
    /// (`tests/differential.rs`, `tests/render_plan.rs`) take it.
    pub fn set_unrounded_targets(&mut self, unrounded: bool) {
        self.unrounded = unrounded;
    }

    /// Gives a rendered frame's image back for later frames to render
    /// into (as a swap chain does): a frame of the same size then clears
    /// it instead of allocating and faulting in fresh buffers. The images
    /// a frame renders into and does not return are kept the same way.
    pub fn recycle(&self, frame: Frame) {
        self.keep_images(std::iter::once(frame.image));
    }

    /// A cleared image for a pass ([`targets::new_target`]), from the pool where one fits.
    fn new_target(
        &self,
        target: &crate::pipeline::TargetImage,
        mode: Precision,
        format: ColorFormat,
        frame: (u32, u32),
    ) -> Result<Framebuffer, RenderError> {
        let mut pool = self.pool.lock().unwrap_or_else(|e| e.into_inner());
        // Unrounded 8-bit targets are what `exact` keeps.
        let mode = if self.unrounded && mode == Precision::F32 { Precision::Exact } else { mode };
        new_target(target, mode, format, frame, &mut pool)
    }

    /// The image `name` pass `index` renders into, made (cleared) the
    /// first time a pass renders into it.
    fn target_named<'t>(
        &self,
        targets: &'t mut BTreeMap<String, Framebuffer>,
        name: &str,
        index: usize,
        mode: Precision,
        format: ColorFormat,
        frame: (u32, u32),
    ) -> Result<&'t mut Framebuffer, RenderError> {
        if !targets.contains_key(name) {
            let fb = self.new_target(&self.planned.setup(index).target, mode, format, frame)?;
            targets.insert(name.to_string(), fb);
        }
        targets.get_mut(name).ok_or_else(|| lost(name))
    }

    fn keep_images(&self, images: impl Iterator<Item = Framebuffer>) {
        let mut pool = self.pool.lock().unwrap_or_else(|e| e.into_inner());
        for fb in images {
            if pool.len() < POOL {
                pool.push(fb);
            }
        }
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
        let mut draws = Draws::new(adaptive, self.n_draws(objects.len()), progress);
        let mut fused_until = 0;
        // In the plan's draw order: a group split in texture space object by object.
        for draw in plan.draws(objects.len()) {
            let (index, pass): (usize, &Pass) = (draw.pass, &drawn(plan, &draw));
            if index < fused_until {
                continue;
            }
            if let Some(run) = adaptive.filter(|_| draw.first).and_then(|_| self.fused_run(index)) {
                let name = self.planned.setup(index).target.name.clone();
                let target = self.target_named(&mut targets, &name, index, mode, format, (width, height))?;
                target.settle();
                let (passes, drawn) = (index..index + run, (&rendered, &objects[..]));
                nonfinite += self.draw_fused(passes, mode, drawn, target, &mut draws, &mut shading)?;
                (last_fb, fused_until) = (Some(name), index + run);
                continue;
            }
            let whole = PassInterface::of(self.planned, index);
            draws.vertex_program = super::vertex_program::PassProgram::of(self.planned, index);
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
                self.target_named(&mut targets, &name, index, mode, format, (width, height))?;
                let reads = settled_reads(m, &pi, &mut targets, &name, plain_draw(pass, &draws));
                // A copy of the target only for the passes that read it (its
                // size or depth at the pixel): a copy per pass is megabytes.
                let own_depth = reads_own_target(m, &pi).then(|| targets.get(&name).cloned()).flatten();
                // A `bake` table is the compiler's work, in float, whatever
                // the target's arithmetic (issue 18).
                let mode = if pass.baked && mode == Precision::Fixed9 { Precision::F32 } else { mode };
                let (machine, how) = self.shading_of(mode, index);
                if layer == 0 && draw.first {
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
                // A stencil update over `x′`: the scene's shadow volume.
                let volume =
                    crate::planner::shadow_volumes::for_pass(self.scene, self.assets, self.planned, index)
                        .map_err(RenderError::Unsupported)?;
                let volume = volume.as_ref().map(|v| self.bound_volume(v, width, height));
                let drawn = volume.as_ref().map_or(&objects[..], std::slice::from_ref);
                self.draw_layer(pass, &pi, drawn, &stage, target, &mut draws)?;
                // A target no draw wrote (no object drawn) still holds its deferred clear.
                target.settle();
                nonfinite += stage.nonfinite.load(Ordering::Relaxed);
                match &pass.target {
                    RenderTarget::Framebuffer { .. } => last_fb = Some(name.clone()),
                    RenderTarget::Texture { .. } | RenderTarget::Temporary { .. } => {
                        rendered.insert(name.clone(), self.keep_rendered(&targets[&name], &name));
                    }
                }
            }
        }
        let time = start.elapsed();
        let name = last_fb.ok_or_else(|| {
            RenderError::Unsupported("the plan writes no framebuffer: nothing to show".into())
        })?;
        let image = targets.remove(&name).ok_or_else(|| lost(&name))?;
        self.keep_images(targets.into_values());
        let Draws { stats, adaptive: adaptive_stats, .. } = draws;
        Ok(Frame { image, name, stats, time, nonfinite, adaptive: adaptive_stats, shading })
    }

    /// The scene's shadow volume `volume` bound like an object for a frame
    /// of `width`×`height`, moved by the rounding bias's volume offset.
    fn bound_volume<'v>(&self, volume: &'v crate::scene::Mesh, width: u32, height: u32) -> BoundObject<'v> {
        let aspect = width as f32 / height as f32;
        let bound = crate::scene::shadow_volume::bind_volume(self.scene, self.assets, volume, aspect);
        crate::scene::shadow_volume::offset_clip(bound, self.rounding_bias.volume_offset(width, height))
    }

    /// What a pass rendered into texture or temporary `name` leaves for
    /// later passes to look up (mipmapped where the texture is declared so;
    /// six faces where it is declared `cube`; wrapped as declared; a fat
    /// texel's layer `T#k` as its texture `T`; a table the lowering made,
    /// which has no declaration, as its own sampling says — a periodic
    /// table repeats).
    fn keep_rendered(&self, fb: &Framebuffer, name: &str) -> Rendered {
        let texture = name.split('#').next().unwrap_or(name);
        let decl = self.decls.iter().find(|d| d.name == texture);
        let mipmap = decl.is_some_and(|d| d.mipmap);
        let cube = decl.is_some_and(|d| d.kind == crate::parser::ast::TextureKind::Cube);
        let added =
            || self.planned.module.textures.iter().find(|t| t.name == texture).map(|t| t.sampling.wrap);
        let wrap = decl.map(|d| d.wrap).or_else(added).unwrap_or(crate::textures::Wrap::ClampToEdge);
        Rendered::from_framebuffer(fb, mipmap, cube, wrap)
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
                let vertices: Vec<MeshVertices> = drawn
                    .iter()
                    .map(|o| MeshVertices::new(m, o, pi, &self.uniforms, draws.vertex_program.as_ref()))
                    .collect();
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
                    let vs = MeshVertices::new(m, object, pi, &self.uniforms, draws.vertex_program.as_ref());
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

    /// How many passes from `index` on the adaptive frame draws as one
    /// adaptive draw of their sum ([`super::adaptive::draw_adaptive_sum`]),
    /// at least 2, or `None`: a mesh pass into the picture that replaces
    /// the colour and writes depth, followed by mesh passes into the same
    /// image over the same objects that add (`ADD`) and test `Equal`
    /// without depth writes (a plan's passes per light, Kilgard 2000,
    /// Section 5). None of them may read a framebuffer or its own target's
    /// depth or size (it would see the sum half done), draw a shadow
    /// volume, use the stencil or render the layers of a fat texel. The
    /// draw checks the rest (same triangles, no ties, no discard of the
    /// first pass) and says when it cannot fuse them.
    fn fused_run(&self, index: usize) -> Option<usize> {
        let (m, plan) = (&self.planned.module, &self.planned.plan);
        let name = &self.planned.setup(index).target.name;
        let fusable = |i: usize, first: bool| {
            let pass = &plan.passes[i];
            let pi = PassInterface::of(self.planned, i);
            let (state, blend) = (pass.state, pass.state.blend);
            let roots: Vec<Handle<Expr>> = std::iter::once(pi.output).chain(pi.condition).collect();
            let reads_framebuffer =
                m.reachable(&roots).into_iter().any(|h| matches!(m.exprs[h], Expr::FramebufferRead { .. }));
            matches!(pass.geometry, Geometry::Mesh { .. })
                && matches!(pass.target, RenderTarget::Framebuffer { .. })
                && self.planned.setup(i).target.name == *name
                && pass.objects == plan.passes[index].objects
                && !matches!(m.exprs[pi.output], Expr::Bundle(_))
                && !state.stencil.enabled
                && !self.planned.setup(i).draws_volumes
                && !reads_framebuffer
                && !reads_own_target(m, &pi)
                && pi.depth.is_none()
                && if first {
                    blend == super::BlendState::REPLACE && state.depth.write
                } else {
                    blend == super::BlendState::ADD && state.depth == super::DepthState::EQUAL_NO_WRITE
                }
        };
        if !fusable(index, true) {
            return None;
        }
        let run = 1 + (index + 1..plan.passes.len()).take_while(|&i| fusable(i, false)).count();
        (run >= 2).then_some(run)
    }

    /// Draws passes `run` ([`PlanRenderer::fused_run`]) adaptively as one
    /// draw of their sum, or one by one where the draw cannot fuse them;
    /// returns the fragments whose value was not finite.
    fn draw_fused(
        &self,
        run: std::ops::Range<usize>,
        mode: Precision,
        (rendered, objects): (&BTreeMap<String, Rendered>, &[BoundObject]),
        target: &mut Framebuffer,
        draws: &mut Draws,
        shading: &mut Vec<PassShading>,
    ) -> Result<u64, RenderError> {
        let (m, plan) = (&self.planned.module, &self.planned.plan);
        let settings = draws
            .settings
            .ok_or_else(|| RenderError::Unsupported("internal: a fused draw of a full frame".into()))?;
        let mut stages = Vec::with_capacity(run.len());
        for i in run.clone() {
            let pass = &plan.passes[i];
            let mode = if pass.baked && mode == Precision::Fixed9 { Precision::F32 } else { mode };
            let (machine, how) = self.shading_of(mode, i);
            shading.push(how);
            let pi = PassInterface::of(self.planned, i);
            let stage = FragmentProgram::new(
                self,
                mode,
                &pi,
                rendered,
                Default::default(),
                None,
                machine,
                objects.first(),
            )
            .map_err(|e| e.in_pass(i))?;
            stages.push((pi, super::vertex_program::PassProgram::of(self.planned, i), stage));
        }
        let keep = &plan.passes[run.start].objects;
        let drawn: Vec<&BoundObject> = (objects.iter().enumerate())
            .filter(|(oi, _)| keep.as_ref().is_none_or(|keep| keep.contains(oi)))
            .map(|(_, o)| o)
            .collect();
        let vertices: Vec<Vec<MeshVertices>> = (stages.iter())
            .map(|(pi, program, _)| {
                drawn.iter().map(|o| MeshVertices::new(m, o, pi, &self.uniforms, program.as_ref())).collect()
            })
            .collect();
        let passes: Vec<Vec<RasterPass>> = (run.clone().zip(&stages).zip(&vertices))
            .map(|((i, (_, _, stage)), vs)| {
                let state = plan.passes[i].state;
                (drawn.iter().zip(vs))
                    .map(|(o, vertex)| RasterPass {
                        triangles: &o.mesh.triangles,
                        vertex,
                        fragment: stage,
                        state,
                    })
                    .collect()
            })
            .collect();
        let members: Vec<&[RasterPass]> = passes.iter().map(Vec::as_slice).collect();
        let fused = super::adaptive::draw_adaptive_sum(target, &members, settings)?;
        let each = match fused {
            Some(s) => vec![s],
            None => {
                members.iter().map(|p| super::draw_adaptive(target, p, settings)).collect::<Result<_, _>>()?
            }
        };
        draws.adaptive = draws.adaptive.map(|a| each.into_iter().fold(a, |a, s| a + s));
        draws.advance(run.len() * objects.len());
        Ok(stages.iter().map(|(_, _, s)| s.nonfinite.load(Ordering::Relaxed)).sum())
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
        let units: Vec<Handle<Expr>> = self.planned.setup(index).units.iter().map(|u| u.lookup).collect();
        // A HILO map's dot-product stages take units of their own (planner::hilo).
        let hardware = crate::planner::hilo::hardware_units(m, &units);
        for (r, u) in registers.iter_mut().zip(hardware) {
            // A depth texture's unit returns its comparison (ARB_shadow), not the depth.
            *r = u.map(|u| crate::planner::shadow_map::compare_node(m, output, u).unwrap_or(u));
        }
        registers[4] = g.primary;
        registers[5] = g.secondary;
        // The pass drops a fragment by the alpha test on what the machine
        // computes, as the card does (planner::alpha_test).
        let alpha_test = Some(self.planned.plan.passes[index].state.alpha_test).filter(|t| !t.is_disabled());
        Ok((CombinerSetup { machine, registers, alpha_test }, g.stages))
    }
}

/// Whether `pass` draws into its target only through the tiled
/// rasterizer's draws (`super::draw`, which makes a deferred clear tile by
/// tile): a mesh pass drawn in full.
fn plain_draw(pass: &Pass, draws: &Draws) -> bool {
    matches!(pass.geometry, Geometry::Mesh { .. }) && (draws.settings.is_none() || pass.state.stencil.enabled)
}

/// The framebuffers pass `pi` reads ([`framebuffer_reads`]), every
/// target's deferred clear settled first but that of its own target `name`
/// where the pass draws it plainly (`plain`, [`plain_draw`]) and reads
/// neither it nor any framebuffer (a copy read must be settled).
fn settled_reads(
    m: &ir::Module,
    pi: &PassInterface,
    targets: &mut BTreeMap<String, Framebuffer>,
    name: &str,
    plain: bool,
) -> std::collections::HashMap<u32, Framebuffer> {
    settle_targets(targets, name, plain && !reads_own_target(m, pi));
    let reads = framebuffer_reads(m, pi, targets);
    if reads.is_empty() {
        return reads;
    }
    settle_targets(targets, name, false);
    framebuffer_reads(m, pi, targets)
}

/// Settles every target's deferred clear ([`Framebuffer::settle`]) but
/// that of `name` where `keep` (its first draw makes it).
fn settle_targets(targets: &mut BTreeMap<String, Framebuffer>, name: &str, keep: bool) {
    for (n, fb) in targets.iter_mut() {
        if !(keep && n == name) {
            fb.settle();
        }
    }
}

/// An image the frame loop made and then could not find: a bug, said as
/// an error rather than a panic.
fn lost(name: &str) -> RenderError {
    RenderError::Unsupported(format!("internal: the image `{name}` a pass renders into is missing"))
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
    /// The current pass's vertex program, where the target runs them.
    vertex_program: Option<super::vertex_program::PassProgram>,
}

impl<'p, 's> Draws<'p, 's> {
    /// No draws yet of `total`, adaptive where `settings` say so.
    fn new(
        settings: Option<&'s super::AdaptiveSettings>,
        total: usize,
        progress: &'p mut dyn FnMut(usize, usize),
    ) -> Self {
        let adaptive = settings.map(|_| super::AdaptiveStats::default());
        Draws {
            stats: DrawStats::default(),
            settings,
            adaptive,
            done: 0,
            total,
            progress,
            vertex_program: None,
        }
    }

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
    /// The pass's alpha test, which replaces its IR condition.
    alpha_test: Option<crate::pipeline::AlphaTest>,
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

/// The pass a draw of the plan makes: `draw.pass` over the draw's objects
/// (one object of a group drawn object by object, `Pass::object_major`).
fn drawn<'p>(
    plan: &'p crate::pipeline::PassPlan,
    draw: &crate::pipeline::Draw,
) -> std::borrow::Cow<'p, Pass> {
    let pass = &plan.passes[draw.pass];
    if draw.objects == pass.objects {
        std::borrow::Cow::Borrowed(pass)
    } else {
        std::borrow::Cow::Owned(Pass { objects: draw.objects.clone(), ..pass.clone() })
    }
}
