//! An independent per-pixel reference: the program evaluated at every pixel
//! from the papers and the OpenGL 1.x specification alone, sharing no code
//! with the executors it checks (DESIGN.md, "Reference, speed and error").
//!
//! `meaning` says what a program computes, but it runs through the CPU
//! renderer's rasterizer, interpolation, scene binder and texture sampling,
//! so a bug there is in both and invisible (a projective lookup sampled at
//! raw clip coordinates rendered "∞ dB"). This module shares none of it:
//!
//! - [`geometry`]: its own matrices (f64), and for each pixel centre the
//!   nearest front-facing triangle that contains it, found by window-space
//!   barycentrics — no tiles, no edge functions, no rasterizer;
//! - `program`: each IR node evaluated at the fragment in f64; `δ e` is
//!   `e` at the triangle's three vertices weighted perspective-correctly
//!   (GL §3.5.1), shading vectors and light intensities from their
//!   definitions (`vectors`), projective coordinates `(½x/w + ½, ½ − ½y/w)`;
//! - [`sampling`]: GL §3.8 — wrap, λ from exact per-pixel derivatives,
//!   NEAREST/LINEAR and the mipmap modes, cube-map faces by Table 3.19;
//!   the λ an implementation may use instead (§3.8.8's interval for ρ,
//!   per-quad derivatives) bounds each pixel by its hull
//!   ([`Picture::low`], [`Picture::high`]) over every lookup's λ, each
//!   lookup's on its own, for any number of lookups: the sample evaluated
//!   again in affine arithmetic (Comba and Stolfi 1993), intersected with
//!   intervals (`hull`), a dependent lookup bounded by the texels its
//!   coordinates' box reaches, a cube-map lookup at a moving direction by
//!   every face its box may select; where that cannot be computed, the
//!   range over renders of the lookups' extremes ([`render_enumerated`]);
//! - `ops`: the arithmetic and the ⊕ modes, written again from the
//!   language's definition and GL's texture environment (Table 3.22);
//! - framebuffers store what their declared format stores: an `rgba8`
//!   framebuffer clamps to [0, 1] and rounds to k/255 at every write;
//! - a statement indexed by `δπl x` is rasterized from light 0 as a camera
//!   (a depth-only framebuffer keeps its depth), and a screen pass's `xs`
//!   carries the depth its framebuffer stores, so `πl π⁻¹ xs` takes the
//!   pixel back through the camera and into the light (Williams's shadow
//!   map, docs/shadow-maps.md);
//! - `stencil`: stencil writes from what they say — a constant, a
//!   condition set, cleared or written at the visible fragments; the
//!   depth comparison of Pipeline Grammar, Section 3.5, over the scene's
//!   vertices an OR of every fragment's comparison, over the shadow
//!   volumes `x′` a count: the volumes' winding number at a point is how
//!   many faces of the closed occluders turned from light 0 its segment to
//!   the light crosses (Crow 1977), so the faces z-fail counts behind the
//!   visible point (`>`, `≥`) add up to its winding number, and those
//!   z-pass counts in front of it (`<`, `≤`, Heidmann 1991) to the
//!   winding number on the near plane less its own — building no volume
//!   and rasterizing nothing; the 8-bit stencil keeps the count
//!   (wrapping), `σ C` then reads it;
//! - `rendered`: a statement into a texture (texture shading `T δu x ←`,
//!   `T δu ←` over its texels, `T δπx ←`, `T xs ←`) evaluated into its
//!   own grid — 256² over texels ([`rendered::TEXEL_GRID`]), the
//!   frame's size otherwise — stored in the declared format, mipmaps
//!   box-filtered here, and sampled by later lookups as images are; a
//!   3-D texture is the volume of 64 × 64 × 16 texels whose slices its
//!   statements render tiled 4 × 4 over the grid (docs/solid-textures.md;
//!   a baked one too), sampled as GL 1.2's `TEXTURE_3D` (trilinear within
//!   its one level, wrapped as declared); a cube map filled over its
//!   texels is six faces, each the grid at the face's (s, t) (GL 1.3
//!   §3.8.6);
//! - `lights`: a program written for light 0 on a scene of several
//!   lights: its colour statements at the fragments add each other
//!   light's terms (the language's "For each light"); stencil, alpha,
//!   light-view, texture and screen statements run for light 0 as
//!   written.
//!
//! What it shares: the IR (the lowered program *is* the program's meaning
//! as the language defines it; a lowering bug is in every executor and
//! this reference alike — the snapshot and planner tests guard it), the
//! scene's meshes (data), and the texel data of images and of the
//! procedural stand-in for a missing image. Normalization cube maps and
//! exponent tables are built here from their definitions (Kilgard 2000,
//! Appendix D; GeForce3 Phong's exponent table). It does not use the
//! scene's shadow-volume geometry (`scene::shadow_volume`): it decides
//! shadow without volumes, so it checks them too.
//!
//! Fat textures (Pipeline Grammar, eq. (5) and (14)-(15): a bundle of
//! shading parameters written into a texture, deferred shading's fat
//! framebuffer) hold one image per member, each read back as a flat
//! texture by the member the shader names. A scene's dual-paraboloid map
//! is built here from Heidrich & Seidel 1999, Section 4.1 (each texel the
//! environment in the direction its centre reflects, the front map's
//! alpha 1 inside the unit circle) and looked up by direction at level 0
//! (`sampling::Paraboloid`); the environment's radiance (the procedural
//! sky) is the scene's data, as an image's texels are, and so are a
//! program's own `dual_paraboloid(…)` faces.
//!
//! It is slow (every pixel tests every triangle's bounds, every δ evaluates
//! three vertices) and meant for small images. What it does not evaluate it
//! refuses with [`Unsupported`], never guesses: writes to the depth
//! channel (which the planner refuses too: depth is written by drawing),
//! stencil writes of forms the language does not define (the planner
//! refuses them too), a stencil update comparing a position other than
//! `δπ` of vertices, a frame rendered into a cube map (`E δπx ←`: the
//! frame is no square face) or into a 3-D texture other than over its
//! texels, fat cube or 3-D textures, and a 3-D texture looked up before
//! any statement fills it. Shadow-volume counts assume the volumes end
//! past every surface, as the executors' do. Normal maps are built here
//! from Kilgard 2000's Appendices E-F ([`normal_map`]); triangles crossing
//! the eye plane are clipped to the near plane in clip space (GL §2.12,
//! [`geometry`]). Samples where the specifications leave the
//! result open are marked [`Picture::latitude`]: a cube-map filter at a
//! face edge, a light-space read at a pixel edge, a shadow-volume count
//! decided by a depth tie at the near cap (an occluder's face turned from
//! the light) or a shadow ray grazing an edge.

pub mod geometry;
mod hull;
mod lights;
pub mod normal_map;
mod ops;
mod program;
pub mod rendered;
pub mod sampling;
mod stencil;
mod textures;
mod vectors;

use std::collections::HashMap;

use crate::ir::{FbChannel, Frequency, Module, Table};
use crate::parser::ast::{self, TextureKind};
use crate::scene::{Scene, SceneAssets};
use geometry::View;
use program::{At, Evaluator, Tex};
pub use program::{LodChoices, LookupKey};

/// Why the reference cannot evaluate a program (it refuses rather than guess).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Unsupported {
    pub what: String,
}

impl Unsupported {
    fn new(what: impl Into<String>) -> Unsupported {
        Unsupported { what: what.into() }
    }
}

impl std::fmt::Display for Unsupported {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "the independent reference does not evaluate {}", self.what)
    }
}

/// The picture: the framebuffer the last framebuffer statement wrote.
#[derive(Clone, Debug)]
pub struct Picture {
    pub width: u32,
    pub height: u32,
    /// Row-major, row 0 at the top; what the framebuffer holds.
    pub pixels: Vec<[f64; 4]>,
    /// Whether a triangle of the scene covers the pixel.
    pub covered: Vec<bool>,
    /// Whether the pixel's value depends on a choice the specifications
    /// leave to the implementation (a cube-map lookup whose filter reaches
    /// a face edge: GL 1.x clamps each face, Vulkan filters seamlessly), so
    /// that a comparison can leave it out and say so.
    pub latitude: Vec<bool>,
    /// The least value of each pixel's channels over the level-of-detail
    /// choices GL §3.8.8 leaves to an implementation (`pixels` where no
    /// lookup's choice matters); an implementation's pixel lies in
    /// `low..=high`.
    pub low: Vec<[f64; 4]>,
    /// The greatest, as [`Picture::low`].
    pub high: Vec<[f64; 4]>,
    /// Why `low..=high` is not the hull of every sample over every
    /// lookup's λ (`hull/`) but the range over renders of the lookups'
    /// extreme choices ([`render_enumerated`]); `None` where it is the hull.
    pub hull_refused: Option<Unsupported>,
}

/// How the reference reads the program where GL and the language differ.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Options {
    /// Clamp every `⊕` result to [0, 1], as GL's texture environment does
    /// (GL 1.2.1 §3.8.9; ARB_texture_env_combine, ARB_texture_env_dot3).
    /// The language keeps ⊕ unclamped (docs/language.md, "⊕ modes"); the
    /// hardware the fixed9 renders model clamps it.
    pub clamp_texture_env: bool,
    /// Take the level-of-detail hull on intervals alone — every read of a
    /// lookup and each of its channels as if apart, as the reference did
    /// before its affine forms (`hull/`): a baseline to measure the forms
    /// against, never tighter.
    pub interval_hull: bool,
}

/// Renders `module` (the lowered `program`) for `scene` at `width × height`.
pub fn render(
    module: &Module,
    program: &ast::Program,
    scene: &Scene,
    assets: &SceneAssets,
    width: u32,
    height: u32,
) -> Result<Picture, Unsupported> {
    render_with(module, program, scene, assets, (width, height), Options::default())
}

/// [`render`] read with `options`.
///
/// Where a mipmapped lookup's value moves with λ inside the latitude GL
/// §3.8.8 gives an implementation, [`Picture::low`] and [`Picture::high`]
/// bound each pixel by its hull over every lookup's λ, each lookup's on
/// its own, for any number of lookups (`hull/`: the sample evaluated in affine arithmetic and on
/// intervals, in the same render). Where the hull cannot be computed
/// ([`Picture::hull_refused`]), the range over renders of the lookups'
/// extreme choices ([`render_enumerated`]).
pub fn render_with(
    module: &Module,
    program: &ast::Program,
    scene: &Scene,
    assets: &SceneAssets,
    size: (u32, u32),
    options: Options,
) -> Result<Picture, Unsupported> {
    let choices = LodChoices::default();
    let (picture, open) = render_choice(module, program, scene, assets, size, options, &choices, true)?;
    match (&picture.hull_refused, open) {
        (Some(why), Some(_)) => {
            let mut enumerated = render_enumerated(module, program, scene, assets, size, options)?;
            enumerated.hull_refused = Some(why.clone());
            Ok(enumerated)
        }
        _ => Ok(picture),
    }
}

/// [`render_with`] with the range over renders of the λ choices, as the
/// reference bounded a pixel before its hull: the program rendered once
/// more per combination of the lookups' choices among
/// `program::LOD_CHOICES` extremes (`lod_combinations`: every combination
/// for up to [`LOD_INDEPENDENT`] lookups, at most 24 renders more), each
/// pixel's range over the renders. Not a hull beyond two lookups, nor
/// where the program is not monotone in a lookup.
pub fn render_enumerated(
    module: &Module,
    program: &ast::Program,
    scene: &Scene,
    assets: &SceneAssets,
    size: (u32, u32),
    options: Options,
) -> Result<Picture, Unsupported> {
    let choices = LodChoices::default();
    let (mut picture, open) = render_choice(module, program, scene, assets, size, options, &choices, false)?;
    if let Some(lookups) = open {
        for choices in lod_combinations(module, &lookups) {
            let (other, _) = render_choice(module, program, scene, assets, size, options, &choices, false)?;
            for i in 0..picture.pixels.len() {
                for c in 0..4 {
                    picture.low[i][c] = picture.low[i][c].min(other.pixels[i][c]);
                    picture.high[i][c] = picture.high[i][c].max(other.pixels[i][c]);
                }
                picture.latitude[i] |= other.latitude[i];
            }
        }
    }
    Ok(picture)
}

/// One render with each minified lookup at its choice in `choices`
/// (0: eq. 3.17's λ, k ≥ 1 its k-th extreme; `LodChoices::bias` added to
/// every λ at choice 0): what one implementation may draw (or, biased, one
/// off by that much). `low` and `high` are its pixels.
pub fn render_chosen(
    module: &Module,
    program: &ast::Program,
    scene: &Scene,
    assets: &SceneAssets,
    size: (u32, u32),
    options: Options,
    choices: &LodChoices,
) -> Result<Picture, Unsupported> {
    Ok(render_choice(module, program, scene, assets, size, options, choices, false)?.0)
}

/// The minified lookups of `module` ([`LookupKey`]s) whose value moved
/// with λ in a render for `scene` at `size`: what [`LodChoices`] choose
/// for.
pub fn minified_lookups(
    module: &Module,
    program: &ast::Program,
    scene: &Scene,
    assets: &SceneAssets,
    size: (u32, u32),
) -> Result<Vec<LookupKey>, Unsupported> {
    let choices = LodChoices::default();
    let open = render_choice(module, program, scene, assets, size, Options::default(), &choices, false)?.1;
    Ok(open.unwrap_or_default())
}

/// At most this many lookups choose their λ each on its own
/// (`lod_combinations`): (`LOD_CHOICES` + 1)² − 1 = 24 renders more.
pub const LOD_INDEPENDENT: usize = 2;

/// The renders after the first that bound a pixel over the λ choices
/// (the first rendered every lookup at choice 0): each of the minified
/// `lookups` choosing on its own — every combination of choices — where
/// they are at most [`LOD_INDEPENDENT`]; more, and the lookups that read
/// another lookup (dependent, Pipeline Grammar eq. (8)) choose apart from
/// the rest, which share one choice (every pair), or all share one where
/// none is dependent.
fn lod_combinations(module: &Module, lookups: &[program::LookupKey]) -> Vec<LodChoices> {
    let n = program::LOD_CHOICES;
    if lookups.len() <= LOD_INDEPENDENT {
        let mut all = vec![Vec::new()];
        for _ in lookups {
            all = all
                .into_iter()
                .flat_map(|v: Vec<usize>| (0..=n).map(move |k| [v.clone(), vec![k]].concat()))
                .collect();
        }
        return all
            .into_iter()
            .filter(|v| v.iter().any(|&k| k != 0))
            .map(|v| LodChoices { default: 0, of: lookups.iter().copied().zip(v).collect(), bias: 0.0 })
            .collect();
    }
    let dependent = dependent_lookups(module);
    let pairs: Vec<(usize, usize)> = if lookups.iter().all(|l| !dependent.contains(&l.1)) {
        (1..=n).map(|k| (k, k)).collect()
    } else {
        (0..=n).flat_map(|a| (0..=n).map(move |b| (a, b))).filter(|&p| p != (0, 0)).collect()
    };
    pairs
        .into_iter()
        .map(|(a, b)| LodChoices {
            default: a,
            of: lookups.iter().filter(|l| dependent.contains(&l.1)).map(|&l| (l, b)).collect(),
            bias: 0.0,
        })
        .collect()
}

/// The coordinates of the lookups that read another lookup (dependent
/// lookups, Pipeline Grammar, eq. (8)).
fn dependent_lookups(m: &Module) -> std::collections::HashSet<crate::ir::Handle<crate::ir::Expr>> {
    let roots: Vec<_> = m.statements.iter().flat_map(|s| [s.value, s.index]).collect();
    m.reachable(&roots)
        .into_iter()
        .filter_map(|h| match m.exprs[h] {
            crate::ir::Expr::Lookup { coords, .. } => Some(coords),
            _ => None,
        })
        .filter(|&c| {
            m.reachable(&[c]).into_iter().any(|h| matches!(m.exprs[h], crate::ir::Expr::Lookup { .. }))
        })
        .collect()
}

/// One render with every mipmapped lookup at its choice in `choices`
/// (`Evaluator::lod_choices`); where some lookup's choice mattered, the
/// lookups minified. With `hull`, `low` and `high` are each pixel's hull
/// over the λ choices (`hull/`), or, where it cannot be computed,
/// the pixels, with [`Picture::hull_refused`] saying why.
#[allow(clippy::too_many_arguments)]
fn render_choice(
    module: &Module,
    program: &ast::Program,
    scene: &Scene,
    assets: &SceneAssets,
    (width, height): (u32, u32),
    options: Options,
    choices: &LodChoices,
    hull: bool,
) -> Result<(Picture, Option<Vec<program::LookupKey>>), Unsupported> {
    let world = geometry::World::new(scene, assets, f64::from(width) / f64::from(height));
    let coverage = geometry::Coverage::find(&world, width, height);
    let light_vectors = module.vectors.iter().filter(|v| {
        matches!(v.kind, Some(ast::VectorKind::Light | ast::VectorKind::Half | ast::VectorKind::Intensity))
    });
    // A program written for light 0 means one term per scene light in its
    // colour statements at the fragments (`lights.rs`); every other
    // statement runs for light 0, as written.
    let per_light = scene.lights.len() > 1
        && light_vectors.clone().count() > 0
        && light_vectors.clone().all(|v| v.index.unwrap_or(0) == 0);
    let textures = textures::bind(module, program, scene, assets)?;
    let mut ev = Evaluator {
        m: module,
        world,
        lights: &scene.lights,
        scene,
        coverage,
        textures,
        framebuffers: Vec::new(),
        texgen: HashMap::new(),
        latitude: std::cell::Cell::new(false),
        lod_choices: choices.clone(),
        lod_open: std::cell::Cell::new(false),
        lod_seen: std::cell::RefCell::new(std::collections::BTreeSet::new()),
        hull,
        hull_refused: None,
        clamp_texture_env: options.clamp_texture_env,
        interval_hull: options.interval_hull,
        target: 0,
    };
    let mut latitude = vec![false; (width * height) as usize];
    ev.framebuffers = (0..module.framebuffers.len()).map(|i| ev.new_store(i)).collect();
    let mut rendered = HashMap::new();
    let mut last = None;
    for st in &module.statements {
        match st.table {
            Table::TexCoords(set) => {
                ev.texgen.insert(set, st.value);
            }
            // A baked table is its statement's value at the lookup (the
            // table's ideal); a baked volume or cube map is rendered as any
            // is, its statement seeing the texel's place in the grid.
            Table::Texture(id)
                if module.is_baked(st)
                    && matches!(
                        module.textures[id as usize].kind,
                        TextureKind::Tex1d | TextureKind::Tex2d
                    ) =>
            {
                ev.textures[id as usize] = Tex::Baked(st.value)
            }
            Table::Texture(id) => without_hull(&mut ev, "a rendered texture", |ev| {
                rendered::statement(ev, st, id as usize, &mut rendered)
            })?,
            Table::Framebuffer { id, channel: FbChannel::Stencil } => {
                without_hull(&mut ev, "a stencil update", |ev| {
                    stencil::update(ev, st, id as usize, &mut latitude)
                })?;
            }
            Table::Framebuffer { id, channel } => {
                run(&mut ev, st, id as usize, channel, &mut latitude)?;
                if per_light {
                    without_hull(&mut ev, "another light's terms", |ev| {
                        for_each_other_light(ev, st, id as usize)
                    })?;
                }
                last = Some(id as usize);
            }
        }
    }
    let Some(fb) = last else { return Err(Unsupported::new("a program that writes no framebuffer")) };
    let covered = ev.coverage.fragments.iter().map(Option::is_some).collect();
    let pixels = std::mem::take(&mut ev.framebuffers[fb].color);
    let (low, high) = if ev.hull {
        (std::mem::take(&mut ev.framebuffers[fb].low), std::mem::take(&mut ev.framebuffers[fb].high))
    } else {
        (pixels.clone(), pixels.clone())
    };
    let open = ev.lod_open.get().then(|| ev.lod_seen.take().into_iter().collect());
    let hull_refused = ev.hull_refused.take();
    Ok((Picture { width, height, pixels, covered, latitude, low, high, hull_refused }, open))
}

/// Runs `statement` (of `what`) without a hull: where a lookup's value
/// moved with λ in it, the hull is refused ([`Picture::hull_refused`]).
fn without_hull(
    ev: &mut Evaluator,
    what: &str,
    statement: impl FnOnce(&mut Evaluator) -> Result<(), Unsupported>,
) -> Result<(), Unsupported> {
    let open = ev.lod_open.replace(false);
    statement(ev)?;
    if ev.hull && ev.lod_open.get() {
        ev.hull = false;
        ev.hull_refused = Some(Unsupported::new(format!("{what} whose lookups move with a level of detail")));
    }
    ev.lod_open.set(open || ev.lod_open.get());
    Ok(())
}

/// The samples of a statement's index (Pipeline Grammar, Section 3): the
/// visible fragment of each pixel under the index's projection for
/// `C δπx` and `Cl δπl x`, every pixel for `C xs`; each with its position
/// in a raster of `width` columns.
pub(crate) fn samples(ev: &Evaluator, st: &crate::ir::Statement) -> Result<Vec<(usize, At)>, Unsupported> {
    let (w, h) = (ev.coverage.width, ev.coverage.height);
    match st.freq {
        Frequency::Fragment => {
            let found;
            let fragments = match index_view(ev.m, st.index) {
                View::Camera => &ev.coverage.fragments,
                view => {
                    found = geometry::Coverage::find_in(&ev.world, w, h, view).fragments;
                    &found
                }
            };
            Ok(fragments.iter().enumerate().filter_map(|(i, f)| f.map(|f| (i, At::Fragment(f)))).collect())
        }
        Frequency::Screen => {
            Ok((0..h).flat_map(|y| (0..w).map(move |x| ((y * w + x) as usize, At::Pixel(x, y)))).collect())
        }
        _ => Err(Unsupported::new(format!("statements at {} frequency", st.freq.name()))),
    }
}

/// The projection a statement's index rasterizes with: light 0's where
/// it projects by `πl` (any subscript), else the camera's.
fn index_view(m: &Module, index: crate::ir::Handle<crate::ir::Expr>) -> View {
    let light = m.reachable(&[index]).into_iter().any(|h| {
        matches!(&m.exprs[h], crate::ir::Expr::Project { projection, .. }
            if !projection.inverse && !matches!(projection.subscript.as_deref(), None | Some("")))
    });
    if light {
        View::Light
    } else {
        View::Camera
    }
}

/// A colour statement's light terms for every scene light after light 0,
/// each added into framebuffer `fb` and stored, a pass per light
/// (`lights.rs`); nothing where the statement runs for light 0 only.
fn for_each_other_light(ev: &mut Evaluator, st: &crate::ir::Statement, fb: usize) -> Result<(), Unsupported> {
    let Some(terms) = lights::light_terms(ev.m, st)? else { return Ok(()) };
    let all = ev.lights;
    let samples = samples(ev, st)?;
    let widened = ev.m.info(st.value).ty.width() != 4;
    for i in 1..all.len() {
        ev.lights = &all[i..];
        let mut adds = Vec::with_capacity(samples.len());
        for &(p, at) in &samples {
            adds.push((p, lights::value(ev, &terms, at)?));
        }
        let store = &mut ev.framebuffers[fb];
        let stored = |x: f64| if store.fixed { (x.clamp(0.0, 1.0) * 255.0).round() / 255.0 } else { x };
        for (p, v) in adds {
            let v = if widened { [v[0], v[1], v[2], 1.0] } else { v };
            store.color[p] = std::array::from_fn(|c| stored(store.color[p][c] + v[c]));
            store.low[p] = std::array::from_fn(|c| stored(store.low[p][c] + v[c]));
            store.high[p] = std::array::from_fn(|c| stored(store.high[p][c] + v[c]));
        }
    }
    ev.lights = all;
    Ok(())
}

/// One statement into framebuffer `fb`, every sample of its index.
fn run(
    ev: &mut Evaluator,
    st: &crate::ir::Statement,
    fb: usize,
    channel: FbChannel,
    latitude: &mut [bool],
) -> Result<(), Unsupported> {
    ev.target = fb;
    let source = blend_source(ev.m, st, fb, channel, ev.framebuffers[fb].fixed);
    let mut writes = Vec::new();
    for (i, at) in samples(ev, st)? {
        ev.latitude.set(false);
        let mut memo = HashMap::new();
        if let Some(s) = source {
            // GL clamps the blend's source (see `blend_source`).
            if let Some(v) = ev.value(s, at, 0, &mut memo)? {
                memo.insert(s, Some(v.map(|x| x.clamp(0.0, 1.0))));
            }
        }
        if let Some(v) = ev.value(st.value, at, 0, &mut memo)? {
            let range = if ev.hull { sample_hull(ev, st.value, source, at, &mut memo) } else { None };
            writes.push((i, v, range.unwrap_or((v, v)), at));
        }
        // A light's view is another raster: its latitude is not a pixel's.
        if !matches!(at, At::Fragment(f) if f.view != View::Camera) {
            latitude[i] |= ev.latitude.get();
        }
    }
    let width = ev.m.info(st.value).ty.width();
    let store = &mut ev.framebuffers[fb];
    let widen = |v: [f64; 4]| match width {
        1 => [v[0], v[0], v[0], 1.0],
        3 => [v[0], v[1], v[2], 1.0],
        _ => v,
    };
    for (i, v, (lo, hi), at) in writes {
        let (v, lo, hi) = (widen(v), widen(lo), widen(hi));
        let stored = |x: f64| if store.fixed { (x.clamp(0.0, 1.0) * 255.0).round() / 255.0 } else { x };
        match channel {
            FbChannel::Color => {
                store.color[i] = v.map(stored);
                (store.low[i], store.high[i]) = (lo.map(stored), hi.map(stored));
            }
            FbChannel::Alpha => {
                store.color[i][3] = stored(v[0]);
                (store.low[i][3], store.high[i][3]) = (stored(lo[0]), stored(hi[0]));
            }
            FbChannel::Depth | FbChannel::Stencil => {
                return Err(Unsupported::new("a statement that writes the depth channel"));
            }
        }
        if let At::Fragment(f) = at {
            store.depth[i] = f.depth;
        }
    }
    Ok(())
}

/// The hull of `value` at sample `at` (`hull/`; `memo` its nominal
/// values), the blend's `source` clamped as GL clamps it; `None`, with the
/// hull turned off and the reason kept, where it cannot be computed.
fn sample_hull(
    ev: &mut Evaluator,
    value: crate::ir::Handle<crate::ir::Expr>,
    source: Option<crate::ir::Handle<crate::ir::Expr>>,
    at: At,
    memo: &mut program::Memo,
) -> Option<hull::R> {
    let mut ranges = hull::Ranges::new();
    let mut range = || -> Result<Option<hull::R>, Unsupported> {
        if let Some(s) = source {
            ev.range(s, at, 0, &mut ranges, memo)?;
            ranges.clamp_unit(s);
        }
        ev.range(value, at, 0, &mut ranges, memo)
    };
    match range() {
        Ok(Some(r)) => Some(r),
        Ok(None) => {
            ev.hull_refused =
                Some(Unsupported::new("a sample whose hull keeps the destination where its value does not"));
            ev.hull = false;
            None
        }
        Err(why) => {
            ev.hull_refused = Some(why);
            ev.hull = false;
            None
        }
    }
}

/// The source of the framebuffer blend a statement writes into a
/// fixed-point framebuffer, which GL clamps to [0, 1] before blending
/// (OpenGL 1.2.1 §2.13.9, §4.1.8): `v` of `(C δπx) ⊕ v` (GL_DST_COLOR,
/// GL_ZERO) and of `(C δπx) ⊕[add] v` (GL_ONE, GL_ONE), `s` of
/// `(C δπx) ⊕[add] ((α C δπx)·s)` (GL_DST_ALPHA, GL_ONE) — the passes of
/// Pipeline Grammar's eq. (9) and of Kilgard 2000, Sections 5.4-5.5. Not
/// where the source reads the framebuffer otherwise (no one blend), nor
/// for arithmetic (`+`, `*`), which means what it computes.
pub fn blend_source(
    m: &Module,
    st: &crate::ir::Statement,
    fb: usize,
    channel: FbChannel,
    fixed: bool,
) -> Option<crate::ir::Handle<crate::ir::Expr>> {
    use crate::ir::{BinaryOp, Expr};
    use ast::CombineMode;
    let own = |h, ch| {
        matches!(m.exprs[h], Expr::FramebufferRead { framebuffer, channel, position }
            if framebuffer as usize == fb && channel == ch && position == st.index)
    };
    let reads_fb = |h| {
        m.reachable(&[h]).into_iter().any(
            |n| matches!(m.exprs[n], Expr::FramebufferRead { framebuffer, .. } if framebuffer as usize == fb),
        )
    };
    if !fixed || channel != FbChannel::Color {
        return None;
    }
    let Expr::Combine { mode, lhs, rhs } = m.exprs[st.value] else { return None };
    let v = if own(lhs, FbChannel::Color) {
        rhs
    } else if own(rhs, FbChannel::Color) {
        lhs
    } else {
        return None;
    };
    let alpha_scaled = match m.exprs[v] {
        Expr::Binary { op: BinaryOp::Mul, lhs: a, rhs: b }
        | Expr::Combine { mode: CombineMode::Modulate, lhs: a, rhs: b } => {
            if own(a, FbChannel::Alpha) {
                Some(b)
            } else if own(b, FbChannel::Alpha) {
                Some(a)
            } else {
                None
            }
        }
        _ => None,
    };
    match (mode, alpha_scaled) {
        (CombineMode::Add, Some(s)) if !reads_fb(s) => Some(s),
        (CombineMode::Add | CombineMode::Modulate, _) if !reads_fb(v) => Some(v),
        _ => None,
    }
}
