//! A compiled plan rendered for a [`Scene`] on wgpu, bound exactly as the
//! CPU renderer ([`crate::renderer::plan::PlanRenderer`]) binds it: the same
//! [`crate::scene::bind`] data — vertex leaves evaluated per mesh vertex by
//! [`bind::VertexEnv`], projection matrices from [`BoundObject::clip_matrix`],
//! uniforms from [`bind::uniforms`] (else the declared default), textures
//! from [`bind::load_textures`] at [`TextureQuality::Stored`] — so the two
//! images differ only by what the executors do, not by their inputs.
//!
//! # Conventions at the seam (codegen ↔ binder ↔ CPU framebuffer)
//!
//! - **Rows.** Both images have row 0 at the top (clip y = +1): the CPU
//!   framebuffer by construction (`renderer::plan`), wgpu because its
//!   framebuffer y points down while NDC y points up. No flip is needed.
//! - **Texture rows.** The binder's `Level` row 0 is t = 0 and codegen's
//!   v = 0 is texture row 0: uploaded as is. Cube faces are in the binder's
//!   order (+X, −X, +Y, −Y, +Z, −Z) with `cube_face_uv`'s GL face table,
//!   which is Vulkan's/wgpu's: uploaded as is.
//! - **Depth.** The binder's matrices are GL's (z in −w..w); codegen maps z
//!   to wgpu's 0..w in the shader. The target is cleared to depth 1 and
//!   transparent black, as the CPU framebuffer.
//! - **Texels.** Exact precision uploads every texture as 16-bit unorm
//!   (`TexelUpload::Rgba16`): 8-bit formats exactly (k/255 → k·257),
//!   16-bit formats exactly, float formats rounded to 16 bits; hardware
//!   precision uploads an 8-bit texture as RGBA8 (filtered in 8.8 fixed
//!   point, as the CPU's `fixed9` models it) and the others as 16-bit
//!   unorm (filtered in float, as the CPU does). Signed formats are range-compressed
//!   `(v + 1)/2` (the codegen contract; the shader expands them). Mip
//!   chains are the binder's own levels (box filtered), uploaded level by
//!   level; `trilinear` uses linear mip filtering, `bilinear` the nearest
//!   level, `nearest` level 0 only when the texture has no chain.
//!
//! # Agreement with the CPU renderer (measured, `tests/wgsl_agreement.rs`)
//!
//! The CPU renderer samples textures as the WGSL target's texture unit does
//! (`textures::unit`: λ per 2×2 quad from coarse derivatives, seamless
//! cube maps — the specs' rules, with lavapipe's choices where they leave
//! freedom). lavapipe filters an `Rgba8Unorm` texture in 8.8 fixed point
//! with 8-bit results and a 16-bit unorm one in float; the CPU's `fixed9`
//! mode models the first (`unit::Arithmetic::Fixed8`), its `f32` mode the
//! second (`Float`). On controlled coordinates the 8-bit model is bit for
//! bit lavapipe's result and the float model within 1/255 on 3 of 65 536
//! pixels (`texture_unit_*` tests; seamless cubes within 1/255 on 20 of
//! 16 384 pixels).
//!
//! Every example on Kilgard's torus (`scenes/kilgard_torus.ron`, 640×480,
//! lavapipe / Mesa 22.3.6) against `renderer::plan`, off a 3×3
//! triangle-ID edge mask (~231 000 pixels compared, ~51 000 of them on the
//! torus; at 256×192 the mask left only ~1 200 torus pixels), the CPU
//! interpolating attributes from the float planes of the unsnapped
//! vertices (`raster::Tri::weights`; coverage keeps the snapped fill
//! rule), multipass plans rendered into a float target (`Target::float`,
//! as the CPU's f32 framebuffer) — `every_example_agrees_on_the_torus`:
//!
//! - exact precision against `f32`: all 28 examples within the issue's
//!   2/255 (all but shadow mask's one pixel within 1/255);
//! - hardware precision against `fixed9`: all 28 within 1/255.
//!
//! Both executors round where the model says (every operation to 8 bits in
//! hardware precision; or the same generated combiner setup), but their
//! interpolated attributes, dot products and derivatives are not
//! bit-identical (they differ by ~10⁻⁴ of an 8-bit step). So on a few
//! pixels of the 231 000 (at most 10 for an example: Kilgard's, Taylor's)
//! a rounding whose input lies that near its tie goes the other way and
//! squarings multiply the 1/255 (up to 8/255). The test accepts such a
//! pixel when the CPU renders it as the GPU did with the model's ties moved
//! by float noise (`PlanRenderer::set_rounding_bias`: register roundings
//! 10⁻³ step, texture-unit coordinates and λ up to 0.2/256, comparisons up
//! to 256 ulps), and fails an example where more than 0.1% of its lit pixels
//! need that. Shadow mask's pixel is such a comparison: near-equal depths
//! at the shadow's edge.
//!
//! On other scenes (`SHADEC_AGREEMENT_SCENE=scenes/bump_torus.ron`,
//! `scenes/bench_sphere.ron`) exact precision holds for every example too,
//! and hardware precision for all but one pixel each of deferred shading
//! (bump torus, 3/255) and EMBM (sphere, 2/255), which no moved tie
//! explains. Cook-Torrance on the sphere took two fixes: a NaN (0/0) is 0
//! on both (below), and a quotient is rounded from the registers'
//! integers, k₁·255/k₂, on both (`divide_*`, `fixed9_quotient`) — a
//! quotient of 8-bit values lands *exactly* on rounding ties, where each
//! executor's float noise decided 205 of its 109 839 lit pixels.
//!
//! Two biases of lavapipe the sweep found are now taken out in the WGSL,
//! not tolerated: its `Rgba16Float` colour writes round toward zero (Vulkan
//! allows it), one half-float step low on every G-buffer value (deferred
//! shading was 3/255 off under `^24`, solid mapping's rings 85/255 on 899
//! pixels), so a pass into a half-float texture rounds to nearest even
//! itself (`round_to_half`, codegen); and hardware precision's `^n` is
//! taken by rounded squarings on both executors (`ir::power_by_squaring`),
//! constants rounded as registers on both; and a NaN (0/0, √ of a
//! negative) is 0 in hardware precision on both (the WGSL tests the bits:
//! lavapipe's `clamp` of NaN gave −1, black highlights on the sphere).
//!
//! Exact precision used to upload RGBA8 as well, filtered in 8 bits on both
//! sides: the same rounding-boundary lookups made 3 pixels of Kilgard's
//! f32 comparison 6/255 off. Filtering exact precision's textures in float
//! removed that, and is what "exact" promises. The sweep also found, and
//! this session fixed: `signed16` textures uploaded clamped (negative
//! components lost), 16-bit textures rounded to 8 bits in hardware
//! precision, dependent lookups sampled at level 0 on the CPU (EMBM),
//! fixed9 rendering a `rgba16f` G-buffer into 8 bits, hardware WGSL not
//! rounding conversions like the CPU's per-operation model, and
//! Pipeline Grammar, eq. (10) drawing nothing.

//! # Rendered textures
//!
//! A pass that renders into a texture draws into a
//! [`runner::RenderedTexture`] later passes sample (`TextureData::Rendered`):
//! 256² (`pipeline::RENDERED_TEXTURE_SIZE`, as the CPU) when it is rendered over
//! its texels or in texture space, else the frame's size; one array layer
//! per member of a fat texel; `Rgba16Float` for 16-bit and float formats,
//! else RGBA8. Screen and texel passes draw one rectangle. A texture
//! declared `mipmap` gets its whole chain, box filtered from level 0 after
//! the passes into it (`runner::RenderedTexture::mip_levels`), and is
//! sampled through it, as on the CPU.
//!
//! The picture is the framebuffer the plan writes last (as the CPU's); the
//! others (shadow mask's C′, Cl) are frame-sized rendered textures in the
//! target's colour format. A framebuffer read in a shader binds that
//! texture's colour, or its depth as of the pass (`TextureData::RenderedDepth`,
//! an R32Float copy); a pass's reads of its own target
//! (`PassShader::target_copies`) bind the same copies.
//!
//! A shader that reads the colour (or alpha) of the framebuffer read back
//! (`C xs ← ((α C xs) > ½) ? …`, Pipeline Grammar, Section 3.5) gets it as
//! the other framebuffers: that framebuffer is rendered as a frame-sized
//! texture (its own depth and stencil) and copied texel for texel to the
//! picture after the last pass (`present`). A stencil read in a shader
//! (`(σ C xs) · …`) binds an `R32Float` snapshot of the stencil aspect as
//! of the pass (`TextureData::RenderedStencil`, s/255, as the depth's).
//! The planner's temporaries (render-to-texture splits) render into
//! frame-sized textures and are read back at the pixel, as on the CPU.
//!
//! # Texels the shader filters (`codegen::texel`)
//!
//! Where the CPU's sampler is not the texture unit's model, the shader
//! loads the texels and filters them in f32 as the CPU does
//! (`Texture2D::sample` at level 0, clamped to the edge):
//!
//! - a scene's dual-paraboloid map (`DualParaboloid`, Heidrich & Seidel
//!   1999, Section 4.1) bound to a program's texture: level 0 of its front
//!   and back faces are the two layers of a 2-D array (16-bit texels, in
//!   every precision, as the CPU filters them in float), the direction
//!   picks the layer and the coordinates as `textures::paraboloid_uv`
//!   does. On the torus at 640×480 (reflection vector, a 64² sky): f32
//!   within 1/255 (bilinear) and bit for bit (nearest), fixed9 on
//!   geforce3/geforce256 within 1/255 (`tests/wgpu_dual_paraboloid.rs`).
//!   A program's own `dual_paraboloid(…)` faces are 2-D textures and are
//!   sampled by the unit.
//! - in hardware precision, a texture the plan renders (a `bake` table,
//!   a fat texel's member, a texture shaded over its texels) without a
//!   mip chain: the CPU's `fixed9` filters those in float, where the
//!   unit filters 8-bit texels in 8.8 fixed point, and a power after the
//!   lookup magnified the difference (the fat texture map's members under
//!   `(N·H)^16`: 13/255 on 246 of 3 890 lit pixels at 320×240; now 0/255).
//!
//! # What is not supported (an [`SceneRunError::Unsupported`])
//!
//! What the binder cannot bind (a missing texture, a scene error); a plan
//! that writes no framebuffer; a full-screen pass with per-vertex inputs;
//! a cube map or dual-paraboloid map whose faces differ in size; a cube
//! map the plan renders other than over its square texel grid (one over
//! its texels is six layers, its passes drawing layer 0, copied into the
//! other five after the last of them, read as a cube view); and, in code
//! generation, a dual-paraboloid map looked up at the pixel (`T xs`).
//! Every example on `wgsl`, `geforce3` and `geforce256` that plans and
//! that the CPU renders runs, as do the constructs no example shows
//! (`tests/wgpu_runs_what_the_cpu_runs.rs`).

use std::collections::BTreeMap;

use image::RgbaImage;

use super::runner::{
    self, AddressMode, ColorTarget, Gpu, GpuError, LoadedTexture, PassTarget, RunPass, RunShader, RunTexture,
    SamplerSettings, ShaderSource, Target, TexelUpload, TextureData, VertexData,
};
use crate::backends::wgsl::codegen::{self, uniform_bytes, PassShader};
use crate::ir::{self, Expr, Handle, Module};
use crate::numerics::Precision;
use crate::parser::ast::Program;
use crate::pipeline::{Geometry, Pass, Planned, RenderTarget, TargetFormat, TargetKind};
use crate::scene::bind::{self, BoundObject, BoundTexture, TextureQuality};
use crate::scene::{Scene, SceneAssets};
use crate::textures::{Filter, Level, TexelFormat, Texture, Texture2D, Wrap};

/// One draw of a pass: for an object (its projections), its vertices and
/// triangles.
type Draw<'d> = dyn Fn(Option<&BoundObject>, VertexData, Vec<u32>) -> RunPass + 'd;

/// Why a plan could not run on wgpu for a scene.
#[derive(Debug, thiserror::Error)]
pub enum SceneRunError {
    #[error("the wgpu scene runner cannot run this plan: {0}")]
    Unsupported(String),
    #[error("code generation failed: {0}")]
    Codegen(String),
    #[error(transparent)]
    Gpu(#[from] GpuError),
}

/// The contract's refusals of a plan, one line each.
fn invalid_plan(errors: &[crate::diag::Diagnostic]) -> String {
    errors
        .iter()
        .map(|d| format!("{} (at bytes {}..{})", d.message, d.primary.span.start, d.primary.span.end))
        .collect::<Vec<_>>()
        .join("; ")
}

/// A plan compiled and bound to a scene, ready to render on a device at
/// any size. Build once (code generation, texture upload data), render many.
pub struct ScenePlan<'a> {
    planned: &'a Planned,
    scene: &'a Scene,
    assets: &'a SceneAssets,
    shaders: Vec<PassShader>,
    textures: BTreeMap<String, BoundTexture>,
    decls: Vec<bind::TextureDecl>,
    /// The framebuffer read back (written last); the others are rendered textures.
    main: String,
    /// A shader reads `main`'s colour or alpha: it is rendered as a texture
    /// too, and copied to the picture after the last pass ([`present`]).
    main_read: bool,
    uniforms: Vec<[f32; 4]>,
    /// Stand-ins the binder used (missing images), for the user.
    pub notes: Vec<String>,
    /// Which executor model the textures follow (see [`upload_of`]).
    precision: Precision,
}

impl<'a> ScenePlan<'a> {
    /// Generates the plan's WGSL passes and binds the scene (textures,
    /// uniforms) once, for `precision`'s texture model; `source` gives the
    /// passes their source positions. The module carries the program's
    /// texture declarations ([`crate::ir::declared`]): `_program` is no
    /// longer read (kept so that callers stay unchanged until they drop it).
    pub fn new(
        planned: &'a Planned,
        _program: &Program,
        source: Option<&str>,
        precision: Precision,
        scene: &'a Scene,
        assets: &'a SceneAssets,
    ) -> Result<ScenePlan<'a>, SceneRunError> {
        // A plan that breaks the contract is refused, located, before any
        // shader is generated for it.
        planned.validate().map_err(|d| SceneRunError::Unsupported(invalid_plan(&d)))?;
        let mut main = None;
        for pass in &planned.plan.passes {
            match &pass.target {
                // The picture is the framebuffer written last, as the CPU's.
                RenderTarget::Framebuffer { name, .. } => main = Some(name.clone()),
                RenderTarget::Texture { .. } | RenderTarget::Temporary { .. } => {}
            }
        }
        let main = main.ok_or_else(|| {
            SceneRunError::Unsupported("the plan writes no framebuffer: nothing to show".into())
        })?;
        let mut decls = bind::texture_decls(&planned.module, &scene.constants);
        let lowered = bind::lowered_decls(&planned.module, &decls);
        decls.extend(lowered);
        let mut notes = bind::absent_light_notes(&planned.module, scene);
        let textures = bind::load_textures(&decls, scene, TextureQuality::Stored, &mut notes)
            .map_err(|e| SceneRunError::Unsupported(e.to_string()))?;
        // A scene's dual-paraboloid map is read by direction (`codegen::texel`).
        let bindings = codegen::SceneBindings {
            dual_paraboloid: textures
                .values()
                .filter(|t| matches!(t.texture, Texture::DualParaboloid(_)))
                .map(|t| t.name.clone())
                .collect(),
        };
        let shaders = codegen::generate_bound(planned, source, precision, &bindings).map_err(|d| {
            SceneRunError::Codegen(d.iter().map(|d| d.message.clone()).collect::<Vec<_>>().join("; "))
        })?;
        let m = &planned.module;
        let uniforms = bind::uniforms(m, scene)
            .into_iter()
            .enumerate()
            .map(|(i, v)| {
                v.or_else(|| m.uniforms[i].default.as_ref().map(ir::eval::value))
                    .unwrap_or([0.0; 4])
                    .map(|c| c as f32)
            })
            .collect();
        let main_read = shaders.iter().any(|s| reads_colour_of(planned, s, &main));
        Ok(ScenePlan {
            planned,
            scene,
            assets,
            shaders,
            textures,
            decls,
            uniforms,
            main,
            main_read,
            notes,
            precision,
        })
    }

    /// The [`RunPass`]es of a `width`×`height` frame: per pass, one draw per
    /// scene object (one rectangle for screen and texel passes).
    pub fn passes(&self, width: u32, height: u32) -> Result<Vec<RunPass>, SceneRunError> {
        self.passes_in(&Target::new(width, height))
    }

    /// The same for `target`: the framebuffers other than the one read back
    /// have its colour format.
    /// Where a pass renders: the frame's main target, or a rendered texture
    /// (a texture, or a framebuffer other than the one shown).
    fn pass_target(&self, pass: &Pass, rendered: &BTreeMap<String, runner::RenderedTexture>) -> PassTarget {
        match &pass.target {
            RenderTarget::Texture { name } | RenderTarget::Temporary { name } => {
                PassTarget::Texture(rendered[name].clone())
            }
            RenderTarget::Framebuffer { name, .. } if *name != self.main || self.main_read => {
                PassTarget::Texture(rendered[name].clone())
            }
            _ => PassTarget::Main,
        }
    }

    /// The runner's passes for one frame of `frame`'s size: every pass's
    /// shader, vertices (its vertex leaves evaluated at every vertex of every
    /// object, or a screen rectangle), textures, uniforms and state.
    pub fn passes_in(&self, frame: &Target) -> Result<Vec<RunPass>, SceneRunError> {
        let (width, height) = (frame.width, frame.height);
        let m = &self.planned.module;
        let aspect = width as f32 / height as f32;
        let objects = bind::bound_objects(self.scene, self.assets, m, aspect)
            .map_err(|e| SceneRunError::Unsupported(e.to_string()))?;
        let uniforms64: Vec<Option<[f64; 4]>> =
            self.uniforms.iter().map(|u| Some(u.map(|c| c as f64))).collect();
        let fat = codegen::fat_layers(m);
        let fat_textures: Vec<&str> =
            m.textures.iter().zip(&fat).filter(|(_, l)| **l > 0).map(|(t, _)| t.name.as_str()).collect();
        let rendered = self.rendered_textures(frame, &fat)?;
        let mut out = Vec::new();
        // In the plan's draw order: a group split in texture space object by object.
        for step in self.planned.plan.draws(objects.len()) {
            let Some(s) = self.shaders.iter().find(|s| s.pass == step.pass) else { continue };
            let pass = &self.planned.plan.passes[s.pass];
            let textures = self.pass_textures(s, &rendered, &fat_textures)?;
            let target = self.pass_target(pass, &rendered);
            let loaded = self.own_target_reads(s)?;
            let leaves = &s.interface.vertex_leaves;
            let unis: Vec<[f32; 4]> =
                s.interface.uniforms.iter().map(|u| self.uniforms[*u as usize]).collect();
            // One draw: the pass's projections taken from `object`'s matrices.
            let draw = |object: Option<&BoundObject>, vertices: VertexData, indices: Vec<u32>| {
                let projections: Vec<[f32; 16]> = object.map_or_else(Vec::new, |o| {
                    s.interface.projections.iter().map(|p| o.clip_matrix(p).to_cols_array()).collect()
                });
                let has_block = !projections.is_empty() || !unis.is_empty();
                RunPass {
                    label: s.label.clone(),
                    shader: RunShader {
                        source: ShaderSource::Naga(s.module.clone()),
                        vertex_entry: codegen::VERTEX_ENTRY.into(),
                        fragment_entry: codegen::FRAGMENT_ENTRY.into(),
                    },
                    vertices,
                    indices,
                    textures: textures.clone(),
                    uniforms: has_block.then(|| uniform_bytes(&projections, &unis)),
                    state: pass.state,
                    target: target.clone(),
                    loaded: loaded.clone(),
                    outputs: s.outputs,
                }
            };
            if !matches!(pass.geometry, Geometry::Mesh { .. }) {
                // One full-screen (full-texture) rectangle: the `quad` input.
                if !leaves.is_empty() {
                    return Err(SceneRunError::Unsupported(format!(
                        "pass {} draws a rectangle with per-vertex inputs",
                        s.pass + 1
                    )));
                }
                let floats =
                    vec![-1.0, -1.0, 0.0, 1.0, 1.0, -1.0, 0.0, 1.0, 1.0, 1.0, 0.0, 1.0, -1.0, 1.0, 0.0, 1.0];
                out.push(draw(
                    objects.first(),
                    VertexData { floats, components: vec![4] },
                    vec![0, 1, 2, 0, 2, 3],
                ));
                continue;
            }
            self.mesh_draws(s, (&objects, step.objects.as_deref()), aspect, &uniforms64, &draw, &mut out)?;
        }
        if self.main_read {
            out.push(present(&self.main));
        }
        Ok(out)
    }

    /// Pass `s`'s draws of meshes: one per object (or shadow volume) the
    /// pass draws (of `keep`, the draw's objects: `None`, all), through the
    /// pass's vertex program where the target has them, else through the
    /// WGSL backend's vertex stage on the leaves.
    fn mesh_draws(
        &self,
        s: &PassShader,
        (objects, keep): (&[BoundObject], Option<&[usize]>),
        aspect: f32,
        uniforms64: &[Option<[f64; 4]>],
        draw: &Draw,
        out: &mut Vec<RunPass>,
    ) -> Result<(), SceneRunError> {
        let m = &self.planned.module;
        let leaves = &s.interface.vertex_leaves;
        // A stencil update over `x′`: the scene's shadow volumes.
        let volume = crate::planner::shadow_volumes::for_pass(self.scene, self.assets, self.planned, s.pass)
            .map_err(SceneRunError::Unsupported)?;
        let volumes: Vec<BoundObject> = volume
            .iter()
            .map(|v| crate::scene::shadow_volume::bind_volume(self.scene, self.assets, v, aspect))
            .collect();
        // On a target with vertex programs, the pass's own program (as the CPU).
        let program = super::vertex_stage::VertexStage::of(self.planned, s);
        let drawn = if volume.is_some() { &volumes[..] } else { objects };
        for (oi, object) in drawn.iter().enumerate() {
            // Light culling (Adaptive Sample Shading, Section 2.2): a
            // light's pass draws only the objects it can reach, as on the CPU.
            if keep.is_some_and(|keep| !keep.contains(&oi)) {
                continue;
            }
            let indices = object.mesh.triangles.iter().flatten().copied().collect();
            if let Some(program) = &program {
                let empty = VertexData { floats: Vec::new(), components: vec![4] };
                out.push(program.draw(draw(Some(object), empty, indices), m, object, uniforms64));
                continue;
            }
            let floats = vertex_floats(m, leaves, object, uniforms64);
            out.push(draw(Some(object), VertexData { floats, components: vec![4; leaves.len()] }, indices));
        }
        Ok(())
    }

    /// The textures the plan renders, and how (Pipeline Grammar, eq. (5), (13), (15)):
    /// declared ones over their texels or the frame, the other framebuffers
    /// (shadow mask's C′, Cl) as frame-sized textures.
    fn rendered_textures(
        &self,
        frame: &Target,
        fat: &[u8],
    ) -> Result<BTreeMap<String, runner::RenderedTexture>, SceneRunError> {
        let (width, height) = (frame.width, frame.height);
        let mut rendered: BTreeMap<String, runner::RenderedTexture> = BTreeMap::new();
        for s in &self.shaders {
            // What the pass renders into, and its size and format: its setup's.
            let target = &self.planned.setup(s.pass).target;
            if let TargetKind::Texture(id) = target.kind {
                let (w, h) = target.extent.size(width, height);
                let format = if target.format == TargetFormat::Half {
                    ColorTarget::Rgba16Float
                } else {
                    ColorTarget::Rgba8
                };
                // Mipmapped where the texture is declared so, as on the CPU;
                // a cube map six faces (sampled at level 0, docs/language.md).
                let mipmap = self.decls.iter().any(|d| d.name == target.name && d.mipmap);
                let cube =
                    self.planned.module.textures[id as usize].kind == crate::parser::ast::TextureKind::Cube;
                if cube && (w != h || fat[id as usize] > 1) {
                    return Err(unsupported_in(
                        s,
                        format!(
                            "renders the cube map `{}` other than over its square texel grid",
                            target.name
                        ),
                    ));
                }
                rendered.insert(
                    target.name.clone(),
                    runner::RenderedTexture {
                        name: target.name.clone(),
                        width: w,
                        height: h,
                        layers: if cube { 6 } else { u32::from(fat[id as usize]).max(1) },
                        format,
                        mip_levels: if mipmap && !cube { runner::full_chain(w, h) } else { 1 },
                        cube,
                    },
                );
            }
        }
        // The other framebuffers (shadow mask's C′, Cl) and the planner's
        // temporaries (a render-to-texture split, read back at the pixel):
        // frame-sized textures in the frame's colour format, as the CPU's.
        for pass in &self.planned.plan.passes {
            if let RenderTarget::Framebuffer { name, .. } | RenderTarget::Temporary { name } = &pass.target {
                if *name != self.main || self.main_read {
                    rendered.insert(
                        name.clone(),
                        runner::RenderedTexture {
                            name: name.clone(),
                            width,
                            height,
                            layers: 1,
                            format: frame.color_format,
                            mip_levels: 1,
                            cube: false,
                        },
                    );
                }
            }
        }
        Ok(rendered)
    }

    /// The texture units of pass `s`: other framebuffers read in the shader,
    /// textures the plan renders, and bound textures uploaded.
    fn pass_textures(
        &self,
        s: &PassShader,
        rendered: &BTreeMap<String, runner::RenderedTexture>,
        fat_textures: &[&str],
    ) -> Result<Vec<RunTexture>, SceneRunError> {
        let m = &self.planned.module;
        let pass = &self.planned.plan.passes[s.pass];
        let main = if self.main_read { "" } else { self.main.as_str() };
        let depth_of = |name: &str| self.depth_of(name);
        let unsupported = |what: String| unsupported_in(s, what);
        let mut textures = Vec::new();
        for t in &pass.textures {
            if t.unit as usize != textures.len() {
                return Err(SceneRunError::Unsupported(format!(
                    "texture units of pass {} are not 0..n",
                    s.pass + 1
                )));
            }
            if let Expr::FramebufferRead { framebuffer, channel, .. } = m.exprs[self.planned.handle(t.lookup)]
            {
                // Another framebuffer, read in the shader: its colour, or its depth as of now.
                let name = m.framebuffers[framebuffer as usize].name.as_str();
                let data = match channel {
                    ir::FbChannel::Depth => depth_of(name),
                    ir::FbChannel::Stencil => self.stencil_of(name),
                    ir::FbChannel::Color | ir::FbChannel::Alpha if name != main => {
                        TextureData::Rendered { name: name.to_string(), array: false }
                    }
                    _ => return Err(unsupported(format!("reads the {channel:?} of `{name}` in its shader"))),
                };
                textures.push(RunTexture {
                    data,
                    sampler: runner::SamplerSettings::NEAREST_CLAMP,
                    texels: TexelUpload::Rgba8,
                });
                continue;
            }
            if let Some(r) = rendered.get(&t.texture) {
                let (filter, wrap) = self.rendered_sampling(&t.texture)?;
                // A cube map: its six faces, looked up by direction (level 0).
                if r.cube {
                    textures.push(RunTexture {
                        data: TextureData::RenderedCube { name: t.texture.clone() },
                        sampler: sampler(filter, Wrap::ClampToEdge, false),
                        texels: TexelUpload::Rgba8,
                    });
                    continue;
                }
                // Its mip chain, where it has one (`runner::RenderedTexture::mip_levels`).
                textures.push(RunTexture {
                    data: TextureData::Rendered {
                        name: t.texture.clone(),
                        array: fat_textures.contains(&r.name.as_str()),
                    },
                    sampler: sampler(filter, wrap, r.mip_levels > 1),
                    texels: TexelUpload::Rgba8,
                });
                continue;
            }
            let bound = self
                .textures
                .get(&t.texture)
                .ok_or_else(|| SceneRunError::Unsupported(format!("texture `{}` is not bound", t.texture)))?;
            let signed =
                self.decls.iter().find(|d| d.name == t.texture).is_some_and(|d| bind::is_signed(d.format));
            textures.push(run_texture(bound, self.precision, signed)?);
        }
        Ok(textures)
    }

    /// How a rendered texture is sampled: as declared, or — a temporary the
    /// planner added — as the compiler's own textures are (`Sampling::ADDED`).
    fn rendered_sampling(&self, name: &str) -> Result<(Filter, Wrap), SceneRunError> {
        if let Some(decl) = self.decls.iter().find(|d| d.name == name) {
            return Ok((decl.filter, decl.wrap));
        }
        let added = self.planned.module.textures.iter().find(|t| t.name == name && t.declaration.is_none());
        added
            .map(|t| (t.sampling.filter, t.sampling.wrap))
            .ok_or_else(|| SceneRunError::Unsupported(format!("texture `{name}` has no declaration")))
    }

    /// A depth buffer read as a texture: the main one, or a rendered target's.
    fn depth_of(&self, name: &str) -> TextureData {
        TextureData::RenderedDepth { name: (name != self.main || self.main_read).then(|| name.to_string()) }
    }

    /// A stencil buffer read as a texture (s/255), as [`Self::depth_of`].
    fn stencil_of(&self, name: &str) -> TextureData {
        TextureData::RenderedStencil { name: (name != self.main || self.main_read).then(|| name.to_string()) }
    }

    /// Reads of pass `s`'s own target, as it was before the pass.
    fn own_target_reads(&self, s: &PassShader) -> Result<Vec<LoadedTexture>, SceneRunError> {
        let main = if self.main_read { "" } else { self.main.as_str() };
        let depth_of = |name: &str| self.depth_of(name);
        let unsupported = |what: String| unsupported_in(s, what);
        let mut loaded = Vec::new();
        for c in &s.target_copies {
            let data = if c.depth {
                depth_of(&c.framebuffer)
            } else if c.stencil {
                self.stencil_of(&c.framebuffer)
            } else if c.framebuffer != main {
                TextureData::Rendered { name: c.framebuffer.clone(), array: false }
            } else {
                return Err(unsupported(format!(
                    "reads the colour of `{}`, the framebuffer read back, in its shader",
                    c.framebuffer
                )));
            };
            loaded.push(LoadedTexture { binding: c.binding, data });
        }
        Ok(loaded)
    }

    /// Renders a frame and reads it back (row 0 at the top).
    pub fn render(&self, gpu: &Gpu, width: u32, height: u32) -> Result<RgbaImage, SceneRunError> {
        self.render_into(gpu, &Target::new(width, height))
    }

    /// Renders into `target` (e.g. [`Target::float`], to compare a
    /// multipass plan with the CPU renderer's `f32` mode).
    pub fn render_into(&self, gpu: &Gpu, target: &Target) -> Result<RgbaImage, SceneRunError> {
        let passes = self.passes_in(target)?;
        Ok(runner::run_passes(gpu, target, &passes)?)
    }
}

/// One call: compile, bind and render.
#[allow(clippy::too_many_arguments)]
pub fn render_scene(
    gpu: &Gpu,
    planned: &Planned,
    program: &Program,
    source: Option<&str>,
    precision: Precision,
    scene: &Scene,
    assets: &SceneAssets,
    width: u32,
    height: u32,
) -> Result<RgbaImage, SceneRunError> {
    ScenePlan::new(planned, program, source, precision, scene, assets)?.render(gpu, width, height)
}

/// A level's texels as `texels` bytes: a signed texture's (`signed8`,
/// `signed16`: values in [−1, 1]) range-compressed, `(v + 1)/2` (the
/// codegen contract), everything rounded to the upload's unorm steps
/// (8-bit texels exactly at either width).
fn level_rgba(level: &Level, signed: bool, texels: TexelUpload) -> Vec<u8> {
    let values =
        level.texels.iter().flatten().map(|&c| (if signed { 0.5 * (c + 1.0) } else { c }).clamp(0.0, 1.0));
    match texels {
        TexelUpload::Rgba8 => values.map(|c| (c * 255.0).round() as u8).collect(),
        TexelUpload::Rgba16 => values.flat_map(|c| ((c * 65535.0).round() as u16).to_ne_bytes()).collect(),
    }
}

fn sampler(filter: Filter, wrap: Wrap, mipmapped: bool) -> SamplerSettings {
    let address = match wrap {
        Wrap::ClampToEdge => AddressMode::ClampToEdge,
        Wrap::Repeat => AddressMode::Repeat,
    };
    let (texel, mip) = match filter {
        Filter::Nearest => (runner::Filter::Nearest, runner::Filter::Nearest),
        Filter::Bilinear => (runner::Filter::Linear, runner::Filter::Nearest),
        Filter::Trilinear => (runner::Filter::Linear, runner::Filter::Linear),
    };
    SamplerSettings { mag: texel, min: texel, address, mipmap: mipmapped.then_some(mip) }
}

/// How a texture of `format` is uploaded: as RGBA8, filtered in 8.8 fixed
/// point, only where the CPU's model of the precision filters it so
/// (`unit::Arithmetic::Fixed8`: `fixed9` on an 8-bit texture); everything
/// else — all of exact precision, and 16-bit, float and signed textures in
/// hardware precision (the CPU filters them in float) — as 16-bit unorm,
/// filtered in float.
fn upload_of(precision: Precision, format: TexelFormat) -> TexelUpload {
    if precision == Precision::Fixed9 && format == TexelFormat::Rgba8 {
        TexelUpload::Rgba8
    } else {
        TexelUpload::Rgba16
    }
}

fn run_texture(
    bound: &BoundTexture,
    precision: Precision,
    signed: bool,
) -> Result<RunTexture, SceneRunError> {
    match &bound.texture {
        Texture::Flat(t) => Ok(flat(t, bound.filter, upload_of(precision, t.format), signed)),
        Texture::Cube(c) => {
            let size = c.faces[0].width();
            let texels = upload_of(precision, c.faces[0].format);
            let mut rgba = Vec::new();
            for f in &c.faces {
                if f.width() != size || f.height() != size {
                    return Err(SceneRunError::Unsupported(format!(
                        "cube map `{}` has faces of different sizes",
                        bound.name
                    )));
                }
                rgba.extend(level_rgba(&f.levels[0], signed, texels));
            }
            Ok(RunTexture {
                data: TextureData::Cube { size, rgba },
                sampler: sampler(bound.filter, c.faces[0].wrap, false),
                texels,
            })
        }
        Texture::DualParaboloid(t) => dual_paraboloid(bound, t, signed),
    }
}

/// A scene's dual-paraboloid map (Heidrich & Seidel 1999, Section 4.1):
/// level 0 of its front and back faces as the two layers of a 2-D array,
/// which the shader reads by direction and filters itself
/// (`codegen::texel`), as the CPU's `DualParaboloid::sample` does in
/// every precision — so 16-bit texels (8-bit ones exactly) whatever the
/// precision, and no sampler filtering.
fn dual_paraboloid(
    bound: &BoundTexture,
    t: &crate::textures::DualParaboloid,
    signed: bool,
) -> Result<RunTexture, SceneRunError> {
    let (width, height) = (t.front.width(), t.front.height());
    if t.back.width() != width || t.back.height() != height {
        return Err(SceneRunError::Unsupported(format!(
            "dual-paraboloid map `{}` has faces of different sizes",
            bound.name
        )));
    }
    let texels = TexelUpload::Rgba16;
    let mut rgba = level_rgba(&t.front.levels[0], signed, texels);
    rgba.extend(level_rgba(&t.back.levels[0], signed, texels));
    Ok(RunTexture {
        data: TextureData::D2Array { width, height, layers: 2, rgba },
        sampler: SamplerSettings::NEAREST_CLAMP,
        texels,
    })
}

fn flat(t: &Texture2D, filter: Filter, texels: TexelUpload, signed: bool) -> RunTexture {
    let (width, height) = (t.width(), t.height());
    let data = if t.levels.len() > 1 {
        TextureData::D2Mipmapped {
            width,
            height,
            levels: t.levels.iter().map(|l| level_rgba(l, signed, texels)).collect(),
        }
    } else {
        TextureData::D2 { width, height, rgba: level_rgba(&t.levels[0], signed, texels) }
    };
    RunTexture { data, sampler: sampler(filter, t.wrap, t.levels.len() > 1), texels }
}

/// Whether pass `s` reads the colour (or alpha) of framebuffer `name` in
/// its shader: through a texture unit, or a copy of its own target.
fn reads_colour_of(planned: &Planned, s: &PassShader, name: &str) -> bool {
    let m = &planned.module;
    let unit = planned.plan.passes[s.pass].textures.iter().any(|t| {
        matches!(m.exprs[planned.handle(t.lookup)], Expr::FramebufferRead { framebuffer, channel, .. }
            if m.framebuffers[framebuffer as usize].name == name
                && matches!(channel, ir::FbChannel::Color | ir::FbChannel::Alpha))
    });
    unit || s.target_copies.iter().any(|c| !c.depth && c.framebuffer == name)
}

/// The pass that copies framebuffer `main`, rendered as a texture because a
/// shader reads its colour (Pipeline Grammar, Section 3.5: `C xs` read in
/// a screen pass), to the picture read back: each pixel's texel, loaded
/// unfiltered, so the copy is exact in either colour format.
fn present(main: &str) -> RunPass {
    const PRESENT: &str = "@group(0) @binding(1) var picture: texture_2d<f32>;\n\
        @group(0) @binding(2) var picture_sampler: sampler;\n\
        @vertex fn vs_main(@location(0) corner: vec4<f32>) -> @builtin(position) vec4<f32> { return corner; }\n\
        @fragment fn fs_main(@builtin(position) pixel: vec4<f32>) -> @location(0) vec4<f32> {\n\
            return textureLoad(picture, vec2<i32>(pixel.xy), 0);\n\
        }\n";
    let floats = vec![-1.0, -1.0, 0.0, 1.0, 1.0, -1.0, 0.0, 1.0, 1.0, 1.0, 0.0, 1.0, -1.0, 1.0, 0.0, 1.0];
    RunPass {
        label: format!("present `{main}`"),
        shader: RunShader {
            source: ShaderSource::Wgsl(PRESENT.to_string()),
            vertex_entry: "vs_main".into(),
            fragment_entry: "fs_main".into(),
        },
        vertices: VertexData { floats, components: vec![4] },
        indices: vec![0, 1, 2, 0, 2, 3],
        textures: vec![RunTexture {
            data: TextureData::Rendered { name: main.to_string(), array: false },
            sampler: SamplerSettings::NEAREST_CLAMP,
            texels: TexelUpload::Rgba8,
        }],
        uniforms: None,
        state: crate::pipeline::RenderState {
            cull: crate::pipeline::CullMode::None,
            depth: crate::pipeline::DepthState::DISABLED,
            ..Default::default()
        },
        target: PassTarget::Main,
        loaded: vec![],
        outputs: 1,
    }
}

/// What pass `s` does that the GPU runner cannot.
fn unsupported_in(s: &PassShader, what: String) -> SceneRunError {
    SceneRunError::Unsupported(format!("pass {} {what}", s.pass + 1))
}

/// The vertex leaves of a pass evaluated (in f64) at every vertex of
/// `object`, as the f32 attributes `@location(i)` reads.
fn vertex_floats(
    m: &Module,
    leaves: &[Handle<Expr>],
    object: &BoundObject,
    uniforms: &[Option<[f64; 4]>],
) -> Vec<f32> {
    let mut ev = ir::eval::Evaluator::new(m, leaves, crate::numerics::Precision::Exact);
    let mut floats = Vec::with_capacity(object.n_vertices() * 4 * leaves.len());
    for v in 0..object.n_vertices() {
        let mut env = bind::VertexEnv { object, module: m, vertex: v, uniforms };
        let r = ev.eval(&mut env);
        for value in r.values.iter().take(leaves.len()) {
            floats.extend(value.map(|c| c as f32));
        }
    }
    floats
}
