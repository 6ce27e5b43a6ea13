//! The program evaluated at a sample: the IR's nodes (the lowered program —
//! its meaning, before any plan) with every leaf supplied from the scene by
//! this module's own means, and its statements run in order into
//! framebuffers that hold what their declared format stores.

use std::collections::HashMap;

use super::geometry::{Coverage, Fragment, View, World};
use super::ops::{self, V};
use super::sampling::{Cube, Image, Paraboloid, Volume};
use super::{vectors, Unsupported};
use crate::ir::{Expr, FbChannel, Handle, Module, Projection, TexCoordId, Ty};
use crate::parser::ast::{FramebufferChannel, Space, VectorKind};
use crate::scene::{Light, Scene};

/// A texture as the evaluator holds it.
pub enum Tex {
    Flat(Image),
    /// A fat texture (Pipeline Grammar, Section 3.3, eq. (5) and (14)):
    /// one image per member of the shading-parameter vector written into
    /// it, each sampled as a flat texture by `T … .member`.
    Fat(Vec<Image>),
    Cube(Cube),
    /// A 3-D texture its statements rendered (GL 1.2's `TEXTURE_3D`).
    Volume(Volume),
    /// A scene's dual-paraboloid environment map, looked up by direction.
    Paraboloid(Box<Paraboloid>),
    /// `bake(f)`: its texel statement's value, evaluated at the lookup's
    /// coordinates (the table's ideal, Pipeline Grammar's texture shading, eq. (13)).
    Baked(Handle<Expr>),
    Missing(String),
}

/// Where a node is evaluated.
#[derive(Clone, Copy)]
pub enum At {
    Vertex {
        object: usize,
        vertex: usize,
    },
    Fragment(Fragment),
    /// A texel of texture shading at (u, v).
    Texel([f64; 2]),
    /// A pixel of a screen pass.
    Pixel(u32, u32),
}

/// One framebuffer's contents.
pub struct Store {
    pub color: Vec<V>,
    pub depth: Vec<f64>,
    /// The stencil, 8 bits wrapping as GL's `INCR_WRAP`/`DECR_WRAP` count
    /// (GL 1.x §4.1.5 with EXT_stencil_wrap); 0 is clear.
    pub stencil: Vec<u8>,
    /// The least and greatest value each pixel's colour may take over the
    /// level-of-detail choices GL §3.8.8 leaves to an implementation (the
    /// hull, `hull/`), stored as `color` is; kept while
    /// [`Evaluator::hull`] is on.
    pub low: Vec<V>,
    pub high: Vec<V>,
    /// Declared 8-bit: written values are clamped to [0, 1] and rounded to
    /// k/255, as GL's fixed-point framebuffer stores them (§4.1.8 dithering
    /// off, §2.13.9 colour clamping).
    pub fixed: bool,
}

pub struct Evaluator<'a> {
    pub m: &'a Module,
    pub world: World<'a>,
    pub lights: &'a [Light],
    pub scene: &'a Scene,
    pub coverage: Coverage,
    pub textures: Vec<Tex>,
    pub framebuffers: Vec<Store>,
    pub texgen: HashMap<TexCoordId, Handle<Expr>>,
    /// Set when the sample just evaluated depends on a choice the
    /// specifications leave open (a cube-map filter at a face edge).
    pub latitude: std::cell::Cell<bool>,
    /// Which value each mipmapped lookup takes (GL §3.8.8's latitude in
    /// λ), by lookup ([`LookupKey`]; `LodChoices::default` for the rest):
    /// 0 the value at eq. 3.17's λ, k ≥ 1 the k-th of the lookup's
    /// extremes over the λ an implementation may use (its own value
    /// where it has fewer). An implementation computes each lookup's λ on
    /// its own, so a render per combination of choices bounds the pixel.
    pub lod_choices: LodChoices,
    /// Set when some lookup's value moves with λ within that latitude.
    pub lod_open: std::cell::Cell<bool>,
    /// The lookups whose λ interval was computed (minified at some fragment).
    pub lod_seen: std::cell::RefCell<std::collections::BTreeSet<LookupKey>>,
    /// Whether each sample also carries its hull over the level-of-detail
    /// choices (`hull/`); turned off, with the reason in
    /// [`Evaluator::hull_refused`], where it cannot be computed.
    pub hull: bool,
    pub hull_refused: Option<Unsupported>,
    /// `⊕` results clamped to [0, 1], as GL's texture environment clamps
    /// them ([`super::Options::clamp_texture_env`]).
    pub clamp_texture_env: bool,
    /// The hull on intervals alone ([`super::Options::interval_hull`]).
    pub interval_hull: bool,
    /// The framebuffer the statement being run writes: whose stored depth
    /// a pixel `xs` of a screen pass carries (`π⁻¹ xs` undoes the camera
    /// at that depth; docs/shadow-maps.md).
    pub target: usize,
}

pub(super) type Memo = HashMap<Handle<Expr>, Option<V>>;

/// A lookup, for its choice of λ: the texture and the coordinates' node.
pub type LookupKey = (u32, Handle<Expr>);

/// The value each mipmapped lookup takes (`Evaluator::lod_choices`).
#[derive(Clone, Debug, Default)]
pub struct LodChoices {
    /// The choice of a lookup not in `of`.
    pub default: usize,
    pub of: HashMap<LookupKey, usize>,
    /// Levels added to eq. 3.17's λ of every lookup at choice 0: a render
    /// as an implementation off by that much would draw it (a check that
    /// the reference's range is tight enough to tell it).
    pub bias: f64,
}

impl LodChoices {
    fn of(&self, key: LookupKey) -> usize {
        self.of.get(&key).copied().unwrap_or(self.default)
    }
}

impl<'a> Evaluator<'a> {
    pub fn new_store(&self, id: usize) -> Store {
        let n = (self.coverage.width * self.coverage.height) as usize;
        let channels = &self.m.framebuffers[id].channels;
        let float =
            channels.iter().any(|c| matches!(c, FramebufferChannel::Rgba16f | FramebufferChannel::Rgba32f));
        let clear = vec![[0.0; 4]; n];
        Store {
            color: clear.clone(),
            depth: vec![1.0; n],
            stencil: vec![0; n],
            low: clear.clone(),
            high: clear,
            fixed: !float,
        }
    }

    /// The value of `h` at `at`; `None` where a `c ? a` keeps the destination.
    pub fn value(
        &self,
        h: Handle<Expr>,
        at: At,
        lod_depth: u8,
        memo: &mut Memo,
    ) -> Result<Option<V>, Unsupported> {
        if let Some(v) = memo.get(&h) {
            return Ok(*v);
        }
        let ty = self.m.info(h).ty;
        let e = &self.m.exprs[h];
        let v = match e {
            Expr::Constant(c) => Some(ops::shape(c.ty, pad(c.values()))),
            Expr::Interpolate { value, .. } => Some(self.interpolate(*value, at)?),
            Expr::Lookup { texture, coords } => Some(self.lookup(*texture, *coords, at, lod_depth, memo)?),
            Expr::FramebufferRead { framebuffer, channel, position } => {
                let p = self.operand(*position, at, lod_depth, memo)?;
                let light = self.through_light(*position);
                let own = match at {
                    At::Fragment(f) => f.view != View::Texels && (f.view == View::Light) == light,
                    _ => !light,
                };
                Some(self.read(*framebuffer as usize, *channel, p, at, own))
            }
            Expr::Depth(p) => {
                let [_, _, z, w] = self.operand(*p, at, lod_depth, memo)?;
                Some([if w == 0.0 { 1.0 } else { 0.5 * z / w + 0.5 }; 4])
            }
            Expr::Pixel { .. } => Some(self.pixel(at)),
            Expr::TexelCoord => match at {
                At::Texel([u, v]) => Some([u, v, 0.0, 0.0]),
                _ => return Err(Unsupported::new("`δu` outside texture shading")),
            },
            Expr::Uniform(id) => Some(self.uniform(*id as usize)),
            Expr::Project { projection, value } => {
                let v = self.operand(*value, at, lod_depth, memo)?;
                Some(self.project(projection, v, self.m.info(*value).ty, at)?)
            }
            e if matches!(e, Expr::VertexPosition(_) | Expr::TexCoord { .. } | Expr::Vector { .. }) => {
                let At::Vertex { object, vertex } = at else {
                    return Err(Unsupported::new("a per-vertex leaf outside the vertex stage"));
                };
                Some(self.vertex_leaf(e, object, vertex)?)
            }
            Expr::FatMember { texel, member } => Some(self.fat_member(*texel, *member, at, lod_depth, memo)?),
            Expr::Bundle(_) => return Err(Unsupported::new("a bundle other than a fat texture's texel")),
            _ => {
                let mut operands = Vec::new();
                for o in e.operands() {
                    match self.value(o, at, lod_depth, memo)? {
                        Some(v) => operands.push(v),
                        None => {
                            memo.insert(h, None);
                            return Ok(None);
                        }
                    }
                }
                let v = ops::compute(self.m, e, ty, &operands);
                match e {
                    // GL clamps a texture-environment result (§3.8.9).
                    Expr::Combine { .. } if self.clamp_texture_env => v.map(|v| v.map(|x| x.clamp(0.0, 1.0))),
                    _ => v,
                }
            }
        };
        let v = v.map(|v| ops::shape(ty, v));
        memo.insert(h, v);
        Ok(v)
    }

    fn operand(&self, h: Handle<Expr>, at: At, lod_depth: u8, memo: &mut Memo) -> Result<V, Unsupported> {
        Ok(self.value(h, at, lod_depth, memo)?.unwrap_or([f64::NAN; 4]))
    }

    /// `δ e`: `e` at the triangle's three vertices, weighted perspective-
    /// correctly (GL §3.5.1 eq. 3.6).
    fn interpolate(&self, value: Handle<Expr>, at: At) -> Result<V, Unsupported> {
        let At::Fragment(f) = at else {
            return Err(Unsupported::new("δ of a per-vertex value outside a mesh pass"));
        };
        let tri = self.world.objects[f.object].mesh.triangles[f.triangle];
        let mut out = [0.0; 4];
        for (k, &vtx) in tri.iter().enumerate() {
            let mut memo = Memo::new();
            let v =
                self.operand(value, At::Vertex { object: f.object, vertex: vtx as usize }, 0, &mut memo)?;
            for c in 0..4 {
                out[c] += f.weights[k] * v[c];
            }
        }
        Ok(out)
    }

    fn vertex_leaf(&self, e: &Expr, object: usize, vertex: usize) -> Result<V, Unsupported> {
        let o = &self.world.objects[object];
        Ok(match e {
            Expr::VertexPosition(_) => {
                let p = o.mesh.positions[vertex].as_dvec3();
                [p.x, p.y, p.z, 1.0]
            }
            Expr::TexCoord { set, .. } => match self.texgen.get(set) {
                Some(h) => self.operand(*h, At::Vertex { object, vertex }, 0, &mut Memo::new())?,
                None => {
                    let uv = o.mesh.uvs.get(vertex).copied().unwrap_or_default();
                    [uv.x.into(), uv.y.into(), 0.0, 0.0]
                }
            },
            Expr::Vector { vector, .. } => {
                let d = &self.m.vectors[*vector as usize];
                vectors::at_vertex(
                    &self.world,
                    self.lights,
                    o,
                    vertex,
                    d.kind.unwrap_or(VectorKind::Normal),
                    d.index.unwrap_or(0),
                    d.space.unwrap_or(Space::Eye),
                )
            }
            _ => unreachable!("called for vertex leaves only"),
        })
    }

    fn uniform(&self, id: usize) -> V {
        let u = &self.m.uniforms[id];
        match self.scene.constants.get(&u.name) {
            Some(v) if !v.is_empty() => {
                ops::shape(u.ty, pad(&v.iter().map(|&x| f64::from(x)).collect::<Vec<_>>()))
            }
            _ => u.default.as_ref().map_or([f64::NAN; 4], |c| ops::shape(c.ty, pad(c.values()))),
        }
    }

    /// `π v`: a point to clip space by the camera's (`π`, `π*`: no jitter)
    /// or light 0's (`πl`, any other subscript) matrix; `π⁻¹` back, divided
    /// by w; `πR d` of a direction: sphere-map coordinates (Pipeline Grammar
    /// (7); GL §2.10.4's `SPHERE_MAP` with m = 2·sqrt(x² + y² + (z + 1)²)).
    fn project(&self, p: &Projection, v: V, ty: Ty, at: At) -> Result<V, Unsupported> {
        if ty == Ty::Vec3 {
            let [x, y, z, _] = v;
            let m = 2.0 * (x * x + y * y + (z + 1.0) * (z + 1.0)).sqrt();
            return Ok(if m > 0.0 { [x / m + 0.5, y / m + 0.5, 0.0, 0.0] } else { [0.5, 0.5, 0.0, 0.0] });
        }
        let light = !matches!(p.subscript.as_deref(), None | Some(""));
        let base = match at {
            At::Vertex { object, .. } | At::Fragment(Fragment { object, .. }) => {
                let o = &self.world.objects[object];
                if light {
                    o.light_clip
                } else {
                    o.camera_clip
                }
            }
            // A pixel belongs to no object: `π⁻¹` takes it to the world and
            // `πl` from there (the model matrices cancel in `πl π⁻¹`).
            At::Pixel(..) if light => self.world.light_vp,
            At::Pixel(..) => self.world.camera_vp,
            At::Texel(_) => return Err(Unsupported::new("a projection at a texel")),
        };
        let w = if v[3] == 0.0 && !p.inverse { 1.0 } else { v[3] };
        let point = glam::DVec4::new(v[0], v[1], v[2], w);
        if p.inverse {
            let r = base.inverse() * point;
            return Ok(if r.w != 0.0 { [r.x / r.w, r.y / r.w, r.z / r.w, 1.0] } else { r.to_array() });
        }
        Ok((base * point).to_array())
    }

    /// `xs` (or `δ xs`): the pixel centre in normalized device coordinates,
    /// with the depth there mapped to −1..1, w = 1.
    fn pixel(&self, at: At) -> V {
        let (w, h) = (self.coverage.width, self.coverage.height);
        let (px, py, depth) = match at {
            At::Fragment(f) => (f.pixel.0, f.pixel.1, f.depth),
            At::Pixel(x, y) => (x, y, self.framebuffers[self.target].depth[(y * w + x) as usize]),
            _ => (0, 0, 1.0),
        };
        let (x, y) = super::geometry::pixel_ndc(f64::from(px) + 0.5, f64::from(py) + 0.5, w, h);
        [x, y, 2.0 * depth - 1.0, 1.0]
    }

    /// Whether a position is projected by a light (`πl …`): read from
    /// another view, never the sample's own pixel.
    pub(super) fn through_light(&self, position: Handle<Expr>) -> bool {
        self.m.reachable(&[position]).into_iter().any(|h| {
            matches!(&self.m.exprs[h], Expr::Project { projection, .. }
                if !matches!(projection.subscript.as_deref(), None | Some("")))
        })
    }

    /// A framebuffer channel at a clip-space position, the nearest pixel
    /// (a framebuffer read as a texture is sampled NEAREST); outside it,
    /// the cleared values (colour 0, depth 1). `own`: the position is the
    /// sample's own (a read at the fragment's pixel).
    fn read(&self, fb: usize, channel: FbChannel, p: V, at: At, own_view: bool) -> V {
        let Some(i) = self.read_pixel(p, at, own_view) else {
            return if channel == FbChannel::Depth { [1.0; 4] } else { [0.0; 4] };
        };
        let store = &self.framebuffers[fb];
        match channel {
            FbChannel::Color => store.color[i],
            FbChannel::Alpha => [store.color[i][3]; 4],
            FbChannel::Depth => [store.depth[i]; 4],
            FbChannel::Stencil => [f64::from(store.stencil[i]); 4],
        }
    }

    /// The pixel (its index) a framebuffer read at clip-space position `p`
    /// reads ([`Evaluator::read`]); `None` outside the framebuffer.
    pub(super) fn read_pixel(&self, p: V, at: At, own_view: bool) -> Option<usize> {
        let (w, h) = (self.coverage.width, self.coverage.height);
        let own = match at {
            At::Fragment(f) if own_view => Some(f.pixel),
            At::Pixel(x, y) if own_view => Some((x, y)),
            _ => None,
        };
        let pixel = if p[3] == 0.0 {
            None
        } else {
            let (sx, sy) =
                ((p[0] / p[3] + 1.0) * 0.5 * f64::from(w), (1.0 - p[1] / p[3]) * 0.5 * f64::from(h));
            // Another view's position near a pixel edge: which pixel is
            // nearest depends on the last bits of the arithmetic.
            let edge = |v: f64| (v - v.round()).abs() < 1e-4;
            if own.is_none() && (edge(sx) || edge(sy)) {
                self.latitude.set(true);
            }
            let (x, y) = (sx.floor(), sy.floor());
            (x >= 0.0 && y >= 0.0 && x < f64::from(w) && y < f64::from(h)).then_some((x as u32, y as u32))
        };
        // A read at the fragment's own position is its own pixel, whatever
        // the rounding of the divided position.
        let pixel = match (own, pixel) {
            (Some(o), Some(q)) if o.0.abs_diff(q.0) <= 1 && o.1.abs_diff(q.1) <= 1 => Some(o),
            (_, q) => q,
        };
        pixel.map(|(x, y)| (y * w + x) as usize)
    }

    /// `T c`: sampled at the coordinates, λ from their change over one
    /// pixel in x and in y on the same triangle (GL §3.8.8's derivatives,
    /// of any coordinate expression: dependent lookups too).
    fn lookup(
        &self,
        texture: u32,
        coords: Handle<Expr>,
        at: At,
        lod_depth: u8,
        memo: &mut Memo,
    ) -> Result<V, Unsupported> {
        let cty = self.m.info(coords).ty;
        let c = self.operand(coords, at, lod_depth, memo)?;
        match &self.textures[texture as usize] {
            Tex::Missing(why) => Err(Unsupported::new(why.clone())),
            Tex::Cube(cube) => {
                let (v, edge) = cube.sample([c[0], c[1], c[2]]);
                if edge {
                    self.latitude.set(true);
                }
                Ok(v)
            }
            Tex::Baked(value) => {
                // The table's ideal, at the coordinates its declared wrap
                // takes them to (GL §3.8.7: REPEAT keeps the fraction).
                let [u, v] = uv(c, cty);
                let repeat = self.m.textures[texture as usize].sampling.wrap == crate::textures::Wrap::Repeat;
                let wrap = |x: f64| if repeat { x - x.floor() } else { x.clamp(0.0, 1.0) };
                Ok(self.operand(*value, At::Texel([wrap(u), wrap(v)]), 0, &mut Memo::new())?)
            }
            Tex::Flat(image) => self.flat(image, (texture, coords), cty, c, at, lod_depth),
            Tex::Paraboloid(map) => Ok(map.sample([c[0], c[1], c[2]])),
            Tex::Volume(volume) => Ok(volume.sample(c[0], c[1], c[2])),
            Tex::Fat(_) => Err(Unsupported::new("a fat texel read other than by its members")),
        }
    }

    /// A 2-D (or 1-D) image sampled at coordinates `c` (the value of
    /// `lookup`'s coordinates, of type `cty`): minified at a fragment, at
    /// level 0 elsewhere.
    pub(super) fn flat(
        &self,
        image: &Image,
        lookup: LookupKey,
        cty: Ty,
        c: V,
        at: At,
        lod_depth: u8,
    ) -> Result<V, Unsupported> {
        let [u, v] = uv(c, cty);
        match at {
            At::Fragment(f) if lod_depth < 2 && image.levels.len() > 1 => {
                self.minified(image, lookup, cty, [u, v], &f, lod_depth)
            }
            _ => Ok(image.sample(u, v, 0.0)),
        }
    }

    /// Member `member` of a fat texel `T c`: that member's image of the
    /// fat texture sampled at `c` as a flat texture is (each member its
    /// own texture of the declared format and filter).
    fn fat_member(
        &self,
        texel: Handle<Expr>,
        member: u8,
        at: At,
        lod_depth: u8,
        memo: &mut Memo,
    ) -> Result<V, Unsupported> {
        let Expr::Lookup { texture, coords } = self.m.exprs[texel] else {
            return Err(Unsupported::new("a fat member of a value other than a texture lookup"));
        };
        let Tex::Fat(members) = &self.textures[texture as usize] else {
            return Err(Unsupported::new("a fat member of a texture no statement filled with a bundle"));
        };
        let image = members
            .get(usize::from(member))
            .ok_or_else(|| Unsupported::new("a fat member beyond the bundle written"))?;
        let c = self.operand(coords, at, lod_depth, memo)?;
        self.flat(image, (texture, coords), self.m.info(coords).ty, c, at, lod_depth)
    }

    /// A mipmapped lookup at fragment `f`: sampled at eq. 3.17's λ from
    /// the coordinates' forward differences over one pixel in x and in y
    /// on the same triangle (GL §3.8.8's derivatives, of any coordinate
    /// expression: dependent lookups too), the value
    /// [`Evaluator::lod_choices`] picks.
    ///
    /// What an implementation may use instead: derivatives taken per 2×2
    /// quad, the quad's corner's (coarse) or the pixel's own row and
    /// column's (fine) — as GPUs and the Vulkan specification's implicit
    /// derivatives do —, any ρ in GL §3.8.8's interval
    /// [`Image::lod_bounds`] for each, and log₂ approximated
    /// by up to [`LOG2_SLACK`]. λ lies in the hull of those intervals.
    fn minified(
        &self,
        image: &Image,
        lookup: LookupKey,
        cty: Ty,
        [u, v]: [f64; 2],
        f: &Fragment,
        lod_depth: u8,
    ) -> Result<V, Unsupported> {
        let coords = lookup.1;
        // The coordinates at a pixel offset (dx, dy) from `f`.
        let at_offset = |dx: f64, dy: f64| -> Result<[f64; 2], Unsupported> {
            if dx == 0.0 && dy == 0.0 {
                return Ok([u, v]);
            }
            let g = self.shifted(f, dx, dy);
            Ok(uv(self.operand(coords, At::Fragment(g), lod_depth + 1, &mut Memo::new())?, cty))
        };
        let sets =
            quad_derivative_sets(f.pixel, at_offset, |a: [f64; 2], b: [f64; 2]| [b[0] - a[0], b[1] - a[1]])?;
        let lambda = image.lod(sets[0].0, sets[0].1) + self.lod_choices.bias;
        let value = image.sample(u, v, lambda);
        let (mut lo, mut hi) = (lambda, lambda);
        for (dx, dy) in sets {
            let (a, b) = image.lod_bounds(dx, dy);
            (lo, hi) = (lo.min(a), hi.max(b));
        }
        let extremes = image.lod_extremes(u, v, lo - LOG2_SLACK, hi + LOG2_SLACK);
        self.lod_seen.borrow_mut().insert(lookup);
        Ok(self.lod_choose(value, &extremes, self.lod_choices.of(lookup)))
    }

    /// The texel `choice` ([`Evaluator::lod_choices`]) asks for among a lookup's
    /// `extremes` (0: the nominal `value`); notes in
    /// [`Evaluator::lod_open`] that the choice matters, and marks the
    /// sample latitude where the extremes are more than the choices.
    fn lod_choose(&self, value: V, extremes: &[V], choice: usize) -> V {
        let moves = extremes.iter().any(|e| e.iter().zip(value).any(|(a, b)| (a - b).abs() > 1e-12));
        if !moves {
            return value;
        }
        self.lod_open.set(true);
        if extremes.len() > LOD_CHOICES && !self.hull {
            self.latitude.set(true);
        }
        match choice {
            0 => value,
            k => extremes.get(k - 1).copied().unwrap_or(value),
        }
    }
}

/// How far an implementation's log₂ of ρ may be from the true one: a
/// piecewise-linear log₂ (`(e − 1) + m` for `m·2ᵉ`, as fixed-function
/// hardware and llvmpipe take it) is low by up to 0.086.
pub const LOG2_SLACK: f64 = 0.1;

/// The derivative pairs GL §3.8.8 lets an implementation take a lookup's λ
/// from at the fragment of `pixel`: the forward differences at the
/// fragment itself, those of its 2×2 quad's first fragment, and the
/// quad's row and column through the fragment. `at_offset` gives the
/// coordinates at a pixel offset (`(0, 0)` the fragment's own), `d` the
/// difference of two.
pub(super) fn quad_derivative_sets<P: Copy, D, E>(
    pixel: (u32, u32),
    at_offset: impl Fn(f64, f64) -> Result<P, E>,
    d: impl Fn(P, P) -> D,
) -> Result<[(D, D); 3], E> {
    let (here, right, below) = (at_offset(0.0, 0.0)?, at_offset(1.0, 0.0)?, at_offset(0.0, 1.0)?);
    let (qx, qy) = (-f64::from(pixel.0 & 1), -f64::from(pixel.1 & 1));
    let q = [
        at_offset(qx, qy)?,
        at_offset(qx + 1.0, qy)?,
        at_offset(qx, qy + 1.0)?,
        at_offset(qx + 1.0, qy + 1.0)?,
    ];
    let row = if qy == 0.0 { (q[0], q[1]) } else { (q[2], q[3]) };
    let column = if qx == 0.0 { (q[0], q[2]) } else { (q[1], q[3]) };
    Ok([
        (d(here, right), d(here, below)),
        (d(q[0], q[1]), d(q[0], q[2])),
        (d(row.0, row.1), d(column.0, column.1)),
    ])
}

/// How many extremes of a lookup's λ interval a render can pick
/// ([`Evaluator::lod_choices`] 1..=LOD_CHOICES): the two ends and two
/// levels between. A wider interval leaves the sample open (latitude).
pub const LOD_CHOICES: usize = 4;

impl Evaluator<'_> {
    /// `f`'s triangle at a pixel offset, in the raster `f` was found in.
    pub(super) fn shifted(&self, f: &Fragment, dx: f64, dy: f64) -> Fragment {
        let size = super::rendered::TEXEL_GRID;
        let raster = match f.view {
            View::Texels => Coverage { width: size, height: size, fragments: Vec::new() },
            _ => Coverage { width: self.coverage.width, height: self.coverage.height, fragments: Vec::new() },
        };
        raster.offset(&self.world, f, dx, dy)
    }
}

/// Texture coordinates of a lookup: a scalar indexes a 1-D table at its
/// centre row; a clip-space position projectively, `(½x/w + ½, ½ − ½y/w)`
/// (v = 0 is the top row: docs/language.md, "Texture coordinates").
pub(super) fn uv(c: V, ty: Ty) -> [f64; 2] {
    match ty {
        Ty::Scalar => [c[0], 0.5],
        Ty::Position => [0.5 * c[0] / c[3] + 0.5, 0.5 - 0.5 * c[1] / c[3]],
        _ => [c[0], c[1]],
    }
}

fn pad(values: &[f64]) -> V {
    std::array::from_fn(|i| values.get(i).copied().unwrap_or(0.0))
}
