//! Every pass resolved once: the typed setup each executor, emitter, the
//! cost model and the language server read instead of working it out again
//! from the plan's text (the review of 2026-12, §5; after naga's
//! `valid::ModuleInfo`, computed once and handed to every writer, and
//! xemu's `ShaderState`, one derivation of the fixed-function state that
//! every renderer consumes).
//!
//! [`PassSetup`] holds, for pass `i` of a plan: its source span (a
//! [`Span`], never `line:col` text), the image it renders into with its
//! extent and format ([`TargetImage`], decided here and nowhere else), its
//! texture units by id ([`UnitBinding`]), and its fragment stage: the
//! register-combiner setup the code generator made when the plan was
//! assembled (Kilgard 2000, Section 4.2) — on a combiner target a pass
//! without one is refused by the planner, never planned —, or the
//! programmable stage. The [`crate::pipeline::PassPlan`] document is
//! written from the same decisions and never read back.
//!
//! **Invariants.** `setups[i]` is the setup of `plan.passes[i]`;
//! `units[u]` is texture unit `u`, as `plan.passes[i].textures[u]`;
//! on a combiner target every pass that is not a `bake` table has
//! [`FragmentSetup::Combiners`].

use rustc_hash::FxHashMap as HashMap;
use std::any::Any;
use std::cell::Cell;
use std::fmt;
use std::sync::{Arc, OnceLock};

use super::plan::{Geometry, Pass, PassPlan, RenderTarget};
use crate::ir::{Expr, Handle, Module, Ty};
use crate::parser::ast::{FramebufferChannel, TextureFormat};
use crate::span::Span;

/// The side of the square texel grid a texture rendered over its texels
/// (`T δu ←`, or the mesh in texture space, `T δu x ←`) is rendered at
/// (Pipeline Grammar, eq. (13)): one size for every executor, the cost
/// model and the lowering.
pub const RENDERED_TEXTURE_SIZE: u32 = 256;

/// Everything an executor needs to run one pass, decided once.
#[derive(Clone, Debug)]
pub struct PassSetup {
    /// The pass's first statement in the source.
    pub span: Span,
    /// The image the pass renders into.
    pub target: TargetImage,
    /// Texture unit `u` holds `units[u]`.
    pub units: Vec<UnitBinding>,
    /// What the fragment stage runs.
    pub fragment: FragmentSetup,
    /// The combiner setup the `fixed9` model runs (CPU renderer, WGSL
    /// `--fidelity hardware`, the hover): the target's own on a combiner
    /// target, else generated for a GeForce 3 on first use, once
    /// (`backends::combiners::setup`).
    pub fixed9: OnceLock<Result<CombinerProgram, SetupRefusal>>,
    /// The pass's `!!VP1.0` vertex program on a target that has vertex
    /// programs (NV_vertex_program, NVIDIA 2001), or why the host computes
    /// its vertices: emitted on first use and kept, so that `--emit
    /// combiners` and `render` read one program. Held opaque, as the
    /// combiner setup is, and read back by its type in
    /// `backends::vertex_program::emit::of`.
    pub vertex_program: OnceLock<Arc<dyn Any + Send + Sync>>,
    /// Whether the pass rasterizes the scene's shadow volumes rather than
    /// its objects ([`VolumeStreams::drawn_by`]),
    /// decided once per plan.
    pub draws_volumes: bool,
}

/// The image a pass renders into, with its size and format.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TargetImage {
    /// A framebuffer, a texture or a temporary, by id.
    pub kind: TargetKind,
    /// The name executors key images by (the declared name, or `tempN`).
    pub name: String,
    /// Its size: the frame's, or a square of texels.
    pub extent: Extent,
    /// How it stores a colour.
    pub format: TargetFormat,
}

/// Which image, by id.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TargetKind {
    /// `module.framebuffers[id]`.
    Framebuffer(u32),
    /// `module.textures[id]`, rendered into (texture shading, deferred shading).
    Texture(u32),
    /// A screen-sized temporary the planner introduced (a render-to-texture split).
    Temporary,
}

/// How large a target is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Extent {
    /// The frame's size.
    Frame,
    /// A square texel grid of this side ([`RENDERED_TEXTURE_SIZE`]).
    Texels(u32),
}

impl Extent {
    /// The size in pixels for a frame of `width` × `height`.
    pub fn size(self, width: u32, height: u32) -> (u32, u32) {
        match self {
            Extent::Frame => (width, height),
            Extent::Texels(s) => (s, s),
        }
    }
}

/// What a target stores.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TargetFormat {
    /// A texture declared 16-bit or float: half floats (`Rgba16Float` on
    /// wgpu), keeping signs (deferred shading's vectors).
    Half,
    /// Fixed-point colour: a framebuffer declared without a float format,
    /// or a texture declared unsigned 8-bit. GL clamps what it stores to
    /// [0, 1] (§2.13.9, §4.1.8).
    Unorm8,
    /// The executor's own frame format (a planner temporary keeps its
    /// intermediate value unclamped; a float framebuffer).
    Frame,
}

/// What a texture unit holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct UnitBinding {
    /// The image the unit reads.
    pub source: UnitSource,
    /// The lookup (or framebuffer read) node the unit serves.
    pub lookup: Handle<Expr>,
}

/// The image bound to a texture unit, by id.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum UnitSource {
    /// A declared (or lowered) texture, by its id in the module.
    Texture(u32),
    /// A framebuffer read back, by id.
    Framebuffer(u32),
    /// A temporary an earlier pass of the split rendered.
    Temporary,
}

/// What a pass's fragment stage runs.
#[derive(Clone, Debug)]
pub enum FragmentSetup {
    /// A programmable stage (WGSL): the executor compiles the value.
    Programmable,
    /// A `bake(f)` table, computed by the compiler on the CPU.
    Baked,
    /// The register-combiner setup generated under the target's limits.
    Combiners(CombinerProgram),
}

/// A register-combiner setup made by the code generator. The generator
/// sits above the plan contract (backends), as the planner's `Realizer`
/// does, so the setup is held opaque here and read back by its type in
/// `backends::combiners::setup`; what the contract itself needs of it (its
/// general stages, which the cost model charges) is typed.
#[derive(Clone)]
pub struct CombinerProgram {
    stages: u32,
    setup: Arc<dyn Any + Send + Sync>,
}

impl CombinerProgram {
    /// A generated setup using `stages` general combiners.
    pub fn new<T: Any + Send + Sync>(stages: u32, setup: T) -> CombinerProgram {
        GENERATED.with(|n| n.set(n.get() + 1));
        CombinerProgram { stages, setup: Arc::new(setup) }
    }

    /// General combiner stages used (Kilgard 2000, Section 4.2).
    pub fn stages(&self) -> u32 {
        self.stages
    }

    /// The setup as the generator's own type.
    pub fn get<T: Any>(&self) -> Option<&T> {
        self.setup.downcast_ref()
    }
}

impl fmt::Debug for CombinerProgram {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        write!(f, "CombinerProgram({} general stages)", self.stages)
    }
}

/// Why the code generator made no setup for a pass's `fixed9` model,
/// located at the node it names.
#[derive(Clone, Debug)]
pub struct SetupRefusal {
    /// Where the node the generator refused is written, when it has a place.
    pub span: Option<Span>,
    /// The generator's error.
    pub error: Arc<dyn std::error::Error + Send + Sync>,
}

impl fmt::Display for SetupRefusal {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        write!(f, "{}", self.error)
    }
}

thread_local! {
    static GENERATED: Cell<usize> = const { Cell::new(0) };
}

/// How many combiner setups this thread has kept for passes (every
/// [`CombinerProgram::new`]): what the test that each pass's setup is
/// generated once counts.
pub fn generated_setups() -> usize {
    GENERATED.with(Cell::get)
}

impl PassSetup {
    /// The setup of `pass` of `module`: its target decided here, its units
    /// by id, with the fragment stage the planner realized.
    pub fn resolve(
        module: &Module,
        names: &Names,
        pass: &Pass,
        span: Span,
        fragment: FragmentSetup,
        draws_volumes: bool,
    ) -> PassSetup {
        let fixed9 = OnceLock::new();
        if let FragmentSetup::Combiners(program) = &fragment {
            let _ = fixed9.set(Ok(program.clone()));
        }
        PassSetup {
            span,
            target: target_image(module, names, pass),
            units: pass
                .textures
                .iter()
                .map(|t| UnitBinding {
                    source: names.unit_source(&t.texture),
                    lookup: Handle::new(t.lookup as usize),
                })
                .collect(),
            fragment,
            fixed9,
            vertex_program: OnceLock::new(),
            draws_volumes,
        }
    }

    /// The combiner setup the plan's target runs, if it has one.
    pub fn combiners(&self) -> Option<&CombinerProgram> {
        match &self.fragment {
            FragmentSetup::Combiners(p) => Some(p),
            _ => None,
        }
    }
}

/// Every pass of `plan` resolved with its span and fragment stage.
pub fn resolve_all(
    module: &Module,
    plan: &PassPlan,
    stages: impl IntoIterator<Item = (Span, FragmentSetup)>,
) -> Vec<PassSetup> {
    let names = Names::of(module);
    let volumes = VolumeStreams::of(module);
    plan.passes
        .iter()
        .zip(stages)
        .map(|(p, (span, f))| PassSetup::resolve(module, &names, p, span, f, volumes.drawn_by(module, p)))
        .collect()
}

/// The module's textures and framebuffers by name, looked up once per
/// plan (a plan of many passes over many rendered textures would otherwise
/// scan the names for every unit of every pass).
pub struct Names<'m> {
    textures: HashMap<&'m str, u32>,
    framebuffers: HashMap<&'m str, u32>,
}

impl<'m> Names<'m> {
    pub fn of(m: &'m Module) -> Self {
        // The first of equal names, as a scan would find.
        let index = |names: Vec<&'m str>| {
            let mut map = HashMap::default();
            for (i, n) in names.into_iter().enumerate() {
                map.entry(n).or_insert(i as u32);
            }
            map
        };
        Names {
            textures: index(m.textures.iter().map(|t| t.name.as_str()).collect()),
            framebuffers: index(m.framebuffers.iter().map(|f| f.name.as_str()).collect()),
        }
    }

    fn unit_source(&self, name: &str) -> UnitSource {
        if let Some(&id) = self.textures.get(name) {
            UnitSource::Texture(id)
        } else if let Some(&id) = self.framebuffers.get(name) {
            UnitSource::Framebuffer(id)
        } else {
            UnitSource::Temporary
        }
    }
}

/// The one decision of a pass's target image: which, how large (a
/// texture rendered over its texels, or the mesh rasterized in texture
/// space, `T δu x ←`, is a [`RENDERED_TEXTURE_SIZE`] grid; everything else
/// frame-sized), and in what format.
fn target_image(m: &Module, names: &Names, pass: &Pass) -> TargetImage {
    let (kind, name) = match &pass.target {
        RenderTarget::Framebuffer { name, .. } => {
            let id = names.framebuffers.get(name.as_str());
            (id.map_or(TargetKind::Temporary, |&i| TargetKind::Framebuffer(i)), name)
        }
        RenderTarget::Texture { name } => {
            let id = names.textures.get(name.as_str());
            (id.map_or(TargetKind::Temporary, |&i| TargetKind::Texture(i)), name)
        }
        RenderTarget::Temporary { name } => (TargetKind::Temporary, name),
    };
    // The clip position is the per-vertex value the pass's index interpolates.
    let position = pass.vertex.position.and_then(|p| match &m.exprs[Handle::new(p as usize)] {
        Expr::Interpolate { value, .. } => Some(*value),
        _ => None,
    });
    let by_texel =
        matches!(pass.geometry, Geometry::Texels) || position.is_some_and(|p| m.info(p).ty == Ty::Vec2);
    let extent = match kind {
        TargetKind::Texture(_) if by_texel => Extent::Texels(RENDERED_TEXTURE_SIZE),
        _ => Extent::Frame,
    };
    TargetImage { kind, name: name.clone(), extent, format: target_format(m, kind) }
}

fn target_format(m: &Module, kind: TargetKind) -> TargetFormat {
    match kind {
        TargetKind::Texture(id) => match m.textures[id as usize].format {
            f if f.is_wide() => TargetFormat::Half,
            TextureFormat::Rgba8 | TextureFormat::Rgb8 | TextureFormat::R8 => TargetFormat::Unorm8,
            _ => TargetFormat::Frame,
        },
        TargetKind::Framebuffer(id) => {
            let float = m.framebuffers[id as usize]
                .channels
                .iter()
                .any(|c| matches!(c, FramebufferChannel::Rgba16f | FramebufferChannel::Rgba32f));
            if float {
                TargetFormat::Frame
            } else {
                TargetFormat::Unorm8
            }
        }
        TargetKind::Temporary => TargetFormat::Frame,
    }
}

/// The vertex streams that only a stencil update's compared depth
/// rasterizes (`x′` of `z δπx′ > z C δπx′`): no statement is indexed by
/// them, so the scene's objects are not their geometry — the shadow
/// volumes are.
pub fn volume_streams(m: &Module) -> Vec<u32> {
    let indexed: Vec<u32> = streams_of(m, &m.statements.iter().map(|s| s.index).collect::<Vec<_>>());
    let all: Vec<u32> = (0..m.vertices.len() as u32).collect();
    all.into_iter().filter(|v| !indexed.contains(v)).collect()
}

pub(crate) fn streams_of(m: &Module, roots: &[crate::ir::Handle<Expr>]) -> Vec<u32> {
    let mut out: Vec<u32> = m
        .reachable(roots)
        .into_iter()
        .filter_map(|h| match m.exprs[h] {
            Expr::VertexPosition(v) => Some(v),
            _ => None,
        })
        .collect();
    out.dedup();
    out
}

/// The volume streams of a module ([`volume_streams`]), found once per
/// plan: which passes rasterize the shadow volumes is then a look at each
/// pass's own position ([`PassSetup::draws_volumes`] keeps the answer per
/// pass), not a walk over every statement for each pass.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct VolumeStreams(Vec<u32>);

impl VolumeStreams {
    /// The streams of `m` that only a stencil update's compared depth rasterizes.
    pub fn of(m: &Module) -> VolumeStreams {
        VolumeStreams(volume_streams(m))
    }

    /// Whether `pass` rasterizes the shadow volumes: a mesh pass whose
    /// position is a volume stream.
    pub fn drawn_by(&self, m: &Module, pass: &Pass) -> bool {
        let Some(position) = pass.vertex.position else { return false };
        if self.0.is_empty() || !matches!(pass.geometry, Geometry::Mesh { .. }) {
            return false;
        }
        let drawn = streams_of(m, &[Handle::new(position as usize)]);
        !drawn.is_empty() && drawn.iter().all(|v| self.0.contains(v))
    }
}
