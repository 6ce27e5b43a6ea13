//! The hull of a sample over the level-of-detail choices GL §3.8.8
//! leaves to an implementation, for any number of minified lookups.
//!
//! An implementation computes each mipmapped lookup's λ on its own,
//! anywhere in the interval §3.8.8 allows (`program.rs`, `minified`), so a
//! program reading n minified lookups may take any of their values'
//! combinations. Rendering every combination of every lookup's extremes
//! grows as 5ⁿ renders, and it is a hull only where the program is
//! monotone in each lookup (`x·(1 − x)` is largest between a lookup's
//! extremes). Here each sample is evaluated once more in affine
//! arithmetic (Comba and Stolfi 1993; Stolfi and de Figueiredo 1997,
//! `affine.rs`): every quantity is a form `x₀ + Σ xᵢ·εᵢ` in noise symbols
//! `εᵢ ∈ [−1, 1]`.
//!
//! A minified lookup at one point of texture coordinates moves only with
//! its λ. Split at the λ where the filter changes how it depends on λ —
//! every integer λ for `LINEAR_MIPMAP_LINEAR`, which blends two levels
//! linearly in λ (eq. 3.20), every level change for `*_MIPMAP_NEAREST` —
//! the texel is `v₀ + Σⱼ (vⱼ₊₁ − vⱼ)·tⱼ` with `tⱼ ∈ [0, 1]` how far λ has
//! run through piece j: one noise symbol per piece, shared by the
//! lookup's four channels and by every read of it (the same texture at
//! the same coordinates takes the same λ). Sums and scalings are exact on
//! forms, products add one fresh symbol (`forms.rs`); `sqrt`, `rsqrt`, a
//! power by a constant, `length`, `normalize`, `exp`, `log`, `sin`, `cos`,
//! `smoothstep` between constant edges, and a clamp, `min`, `max` or
//! `abs` the ranges leave open — of two moving values too, as one plus a
//! clamp of their difference — become their Chebyshev line over the
//! argument's range plus one fresh symbol for its error
//! (`functions.rs`; a moving exponent `exp(y·ln x)`); every other
//! operation is taken on the intervals of its operands' forms
//! (`interval.rs`: monotone functions at their ends, products at their
//! corners, clamps, comparisons decided or left open) and its result
//! given a fresh symbol per lane. A lookup whose coordinates move (a
//! dependent lookup reading a minified lookup, Pipeline Grammar, eq. (8))
//! is bounded by the texels its coordinates' box may reach on the levels
//! its λ interval — from the intervals of its coordinates' derivatives —
//! selects; a cube-map lookup at a moving direction by the texels of
//! every face the direction's box may select, over the box of (s, t) it
//! spans there (`sampling::Cube::box_hull`); a 3-D or dual-paraboloid
//! lookup at moving coordinates by the texels of their box
//! (`Volume::box_hull`, `Paraboloid::box_hull`); a baked lookup at moving
//! coordinates by its table's function evaluated on their forms
//! (`Evaluator::baked_form`). What cannot be bounded so (a
//! framebuffer read at a moving position, a condition that moves and
//! keeps the destination) is [`Unsupported`], and the caller falls back
//! to rendering the combinations.
//!
//! The hull is sound, not exact: a product's rest, the pieces of one λ
//! (taken as if each ran on its own), and whatever passes through
//! intervals widen it.

mod affine;
mod forms;
mod functions;
mod interval;
#[cfg(test)]
mod soundness;

use std::collections::HashMap;

use super::geometry::View;
use super::ops::{self, V};
use super::program::{At, Evaluator, LookupKey, Memo, Tex};
use super::sampling::{Cube, Image};
use super::Unsupported;
use crate::ir::{Expr, FbChannel, Handle, Ty};
use affine::{Affine, Form, Symbols};
use forms::is_point;
pub use interval::R;
use interval::{hull_of, lane, lanes, point, sub, uv_box, I};

/// The forms of the nodes already evaluated at one sample, and the noise
/// symbols handed out there.
#[derive(Default)]
pub struct Ranges {
    forms: HashMap<Handle<Expr>, Option<Hull>>,
    symbols: Symbols,
    /// The symbol of each piece of a lookup's λ interval, by the lookup,
    /// the interval (its bits) and the piece: the same texture read at the
    /// same coordinates takes one λ.
    pieces: HashMap<(LookupKey, [u64; 2], usize), u32>,
    /// `δu`'s form where a baked table's texel statement is evaluated at
    /// coordinates that move (`Evaluator::baked_form`).
    texel: Option<Form>,
}

impl Ranges {
    pub fn new() -> Self {
        Ranges::default()
    }

    /// Hull `r` for type `ty` as a form: each lane a symbol of its own (a
    /// scalar's lanes one).
    fn fresh(&mut self, r: &R, ty: Ty) -> Hull {
        let f = std::array::from_fn(|c| Affine::interval(lane(r, c), self.symbols.fresh()));
        Hull { form: forms::shape(ty, f), bounds: *r }
    }

    /// Node `h`'s hull clamped to [0, 1] (GL clamps a blend's source:
    /// `oracle::blend_source`).
    pub fn clamp_unit(&mut self, h: Handle<Expr>) {
        if let Some(Some(hull)) = self.forms.get(&h) {
            let hull = hull.clone().clamp_unit(&mut self.symbols);
            self.forms.insert(h, Some(hull));
        }
    }
}

/// What is known of a node at one sample: its affine form, and the
/// interval its operands' intervals give it (Moore 1966) — both hold
/// every value, so their intersection does: a product of two lookups
/// that share nothing is exact on intervals and wider on forms, a value
/// read twice the other way round.
#[derive(Clone, Debug)]
struct Hull {
    form: Form,
    bounds: R,
}

impl Hull {
    fn point(v: V) -> Hull {
        Hull { form: v.map(Affine::constant), bounds: point(v) }
    }

    fn of_form(form: Form) -> Hull {
        Hull { bounds: range_of(&form), form }
    }

    /// The intersection of the form's range and the bounds, lane by lane.
    fn range(&self) -> R {
        let f = range_of(&self.form);
        lanes(|c| {
            let (a, b) = (lane(&f, c), lane(&self.bounds, c));
            let i = (a.0.max(b.0), a.1.min(b.1));
            if i.0 <= i.1 {
                i
            } else {
                b
            }
        })
    }

    fn shaped(self, ty: Ty) -> Hull {
        let (lo, hi) = self.bounds;
        Hull { form: forms::shape(ty, self.form), bounds: (ops::shape(ty, lo), ops::shape(ty, hi)) }
    }

    fn clamp_unit(self, s: &mut Symbols) -> Hull {
        let unit = |v: V| v.map(|x| x.clamp(0.0, 1.0));
        Hull { form: clamp_unit(self.form, s), bounds: (unit(self.bounds.0), unit(self.bounds.1)) }
    }
}

/// Each lane of `f` clamped to [0, 1]: kept where its range lies within,
/// else its range clamped, on a fresh symbol.
fn clamp_unit(f: Form, s: &mut Symbols) -> Form {
    f.map(|a| {
        let (lo, hi) = a.range();
        if lo >= 0.0 && hi <= 1.0 {
            a
        } else {
            Affine::interval((lo.clamp(0.0, 1.0), hi.clamp(0.0, 1.0)), s.fresh())
        }
    })
}

/// The hull of a form: each lane's range.
fn range_of(f: &Form) -> R {
    lanes(|c| f[c].range())
}

impl Evaluator<'_> {
    /// The hull of node `h` at `at` over the level-of-detail choices
    /// (`value`'s twin on forms, `Evaluator::form`, read as intervals).
    pub(super) fn range(
        &self,
        h: Handle<Expr>,
        at: At,
        lod_depth: u8,
        ranges: &mut Ranges,
        values: &mut Memo,
    ) -> Result<Option<R>, Unsupported> {
        Ok(self.form(h, at, lod_depth, ranges, values)?.map(|h| h.range()))
    }

    /// The affine form of node `h` at `at` over the level-of-detail
    /// choices; `values` holds the sample's nominal values, which a node
    /// that cannot move takes as its form.
    fn form(
        &self,
        h: Handle<Expr>,
        at: At,
        lod_depth: u8,
        ranges: &mut Ranges,
        values: &mut Memo,
    ) -> Result<Option<Hull>, Unsupported> {
        if let Some(r) = ranges.forms.get(&h) {
            return Ok(r.clone());
        }
        let ty = self.m.info(h).ty;
        let e = &self.m.exprs[h];
        let nan = Hull::point([f64::NAN; 4]);
        let r = match e {
            Expr::Lookup { texture, coords } => {
                let c = self.form(*coords, at, lod_depth, ranges, values)?.unwrap_or(nan);
                let key = (*texture, *coords);
                Some(match &self.textures[*texture as usize] {
                    Tex::Cube(cube) if !is_point(&c.form) => self.cube_hull(cube, &c, ty, ranges),
                    Tex::Volume(volume) if !is_point(&c.form) => {
                        ranges.fresh(&volume.box_hull(direction_box(&c)), ty)
                    }
                    Tex::Paraboloid(map) if !is_point(&c.form) => {
                        ranges.fresh(&map.box_hull(direction_box(&c)), ty)
                    }
                    Tex::Baked(value) if !is_point(&c.form) => {
                        self.baked_form(*texture, *value, &c, self.m.info(*coords).ty, ranges)?
                    }
                    Tex::Flat(image) => {
                        self.lookup_form(h, Some(image), key, &c, at, lod_depth, ranges, values)?
                    }
                    _ => self.lookup_form(h, None, key, &c, at, lod_depth, ranges, values)?,
                })
            }
            Expr::FatMember { texel, member } => {
                let Expr::Lookup { texture, coords } = self.m.exprs[*texel] else {
                    return Err(Unsupported::new("a fat member of a value other than a texture lookup"));
                };
                let c = self.form(coords, at, lod_depth, ranges, values)?.unwrap_or(nan);
                let image = match &self.textures[texture as usize] {
                    Tex::Fat(members) => members.get(usize::from(*member)),
                    _ => None,
                };
                Some(self.lookup_form(h, image, (texture, coords), &c, at, lod_depth, ranges, values)?)
            }
            Expr::FramebufferRead { framebuffer, channel, position } => {
                let p = self.form(*position, at, lod_depth, ranges, values)?.unwrap_or(nan);
                if !is_point(&p.form) {
                    return Err(Unsupported::new(
                        "a framebuffer read at a position that moves with a level of detail",
                    ));
                }
                let p = p.form.map(|a| a.center);
                match self.read_range(*framebuffer as usize, *channel, *position, p, at) {
                    Some(r) => Some(ranges.fresh(&r, ty)),
                    None => self.value(h, at, lod_depth, values)?.map(Hull::point),
                }
            }
            Expr::Project { value, .. } | Expr::Depth(value) => {
                let v = self.form(*value, at, lod_depth, ranges, values)?.unwrap_or(nan);
                if !is_point(&v.form) {
                    return Err(Unsupported::new(
                        "a projection of a value that moves with a level of detail",
                    ));
                }
                self.value(h, at, lod_depth, values)?.map(Hull::point)
            }
            Expr::TexelCoord if ranges.texel.is_some() => ranges.texel.clone().map(Hull::of_form),
            Expr::Constant(_)
            | Expr::Interpolate { .. }
            | Expr::Pixel { .. }
            | Expr::TexelCoord
            | Expr::Uniform(_)
            | Expr::VertexPosition(_)
            | Expr::TexCoord { .. }
            | Expr::Vector { .. }
            | Expr::Bundle(_) => self.value(h, at, lod_depth, values)?.map(Hull::point),
            _ => self.computed_form(h, at, lod_depth, ranges, values)?,
        };
        let r = r.map(|h| h.shaped(ty));
        ranges.forms.insert(h, r.clone());
        Ok(r)
    }

    /// The form of a computing node `h` from its operands' forms: on forms
    /// where it is affine or a product (`forms::compute`), else on their
    /// intervals (`interval::compute`) with a fresh symbol per lane.
    /// `None` where a `c ? a` keeps the destination.
    fn computed_form(
        &self,
        h: Handle<Expr>,
        at: At,
        lod_depth: u8,
        ranges: &mut Ranges,
        values: &mut Memo,
    ) -> Result<Option<Hull>, Unsupported> {
        let (e, ty) = (&self.m.exprs[h], self.m.info(h).ty);
        let mut operands = Vec::new();
        for o in e.operands() {
            match self.form(o, at, lod_depth, ranges, values)? {
                Some(f) => operands.push(f),
                None => return Ok(None),
            }
        }
        let clamp = matches!(e, Expr::Combine { .. }) && self.clamp_texture_env;
        if operands.iter().all(|o| is_point(&o.form)) {
            let v: Vec<V> = operands.iter().map(|o| o.form.clone().map(|a| a.center)).collect();
            let r = ops::compute(self.m, e, ty, &v);
            // GL clamps a texture-environment result (§3.8.9).
            let r = if clamp { r.map(|v| v.map(|x| x.clamp(0.0, 1.0))) } else { r };
            return Ok(r.map(Hull::point));
        }
        let bounds: Vec<R> = operands.iter().map(Hull::range).collect();
        let forms: Vec<Form> = operands.into_iter().map(|o| o.form).collect();
        let affine = (!self.interval_hull)
            .then(|| forms::compute(self.m, e, ty, &forms, &bounds, &mut ranges.symbols));
        let r = match affine.flatten() {
            Some(Some(form)) => {
                let bounds = interval::compute(self.m, e, ty, &bounds).ok().flatten();
                Some(match bounds {
                    Some(bounds) => Hull { form, bounds },
                    None => Hull::of_form(form),
                })
            }
            Some(None) => None,
            None => interval::compute(self.m, e, ty, &bounds)?.map(|r| ranges.fresh(&r, ty)),
        };
        Ok(if clamp { r.map(|h| h.clamp_unit(&mut ranges.symbols)) } else { r })
    }

    /// A cube-map lookup at a direction of hull `c` that moves: the texels
    /// of every face its box may select (`Cube::box_hull`), the sample
    /// marked latitude where the box nears a face edge.
    fn cube_hull(&self, cube: &Cube, c: &Hull, ty: Ty, ranges: &mut Ranges) -> Hull {
        let (lo, hi, edge) = cube.box_hull(direction_box(c));
        if edge {
            self.latitude.set(true);
        }
        ranges.fresh(&(lo, hi), ty)
    }

    /// A baked lookup (`bake(f)`, the table's ideal: Pipeline Grammar's
    /// texture shading, eq. (13)) at coordinates of hull `c` (of type
    /// `cty`) that move: its texel statement `value` evaluated on forms,
    /// `δu` the coordinates' form taken where the table's wrap takes it
    /// (`texel_coordinates`) — so the table's function of its coordinates
    /// keeps what they share with the rest of the program, as if it were
    /// written in place.
    fn baked_form(
        &self,
        texture: u32,
        value: Handle<Expr>,
        c: &Hull,
        cty: Ty,
        ranges: &mut Ranges,
    ) -> Result<Hull, Unsupported> {
        let repeat = self.m.textures[texture as usize].sampling.wrap == crate::textures::Wrap::Repeat;
        let uv = texel_coordinates(c, cty, repeat, &mut ranges.symbols);
        let centre = |a: &Affine| a.center.clamp(0.0, 1.0);
        let at = At::Texel([centre(&uv[0]), centre(&uv[1])]);
        let mut inner =
            Ranges { symbols: std::mem::take(&mut ranges.symbols), texel: Some(uv), ..Ranges::new() };
        let r = self.form(value, at, 0, &mut inner, &mut Memo::new());
        ranges.symbols = inner.symbols;
        Ok(r?.unwrap_or(Hull::point([f64::NAN; 4])))
    }

    /// The hull a colour or alpha read of framebuffer `fb` at `p` (the
    /// value of `position`) holds there (`Store::low`, `Store::high`);
    /// `None` for another channel or outside the framebuffer.
    fn read_range(&self, fb: usize, channel: FbChannel, position: Handle<Expr>, p: V, at: At) -> Option<R> {
        let light = self.through_light(position);
        let own = match at {
            At::Fragment(f) => f.view != View::Texels && (f.view == View::Light) == light,
            _ => !light,
        };
        let i = self.read_pixel(p, at, own)?;
        let fb = &self.framebuffers[fb];
        match channel {
            FbChannel::Color => Some((fb.low[i], fb.high[i])),
            FbChannel::Alpha => Some(([fb.low[i][3]; 4], [fb.high[i][3]; 4])),
            _ => None,
        }
    }

    /// The form of lookup `h` of a flat image (`image`; `None` for any
    /// other texture) at coordinates of form `c`: a minified lookup at one
    /// point in its λ's pieces (`lod_form`), else the hull of what its
    /// coordinates' box reaches, on fresh symbols.
    #[allow(clippy::too_many_arguments)]
    fn lookup_form(
        &self,
        h: Handle<Expr>,
        image: Option<&Image>,
        key: LookupKey,
        c: &Hull,
        at: At,
        lod_depth: u8,
        ranges: &mut Ranges,
        values: &mut Memo,
    ) -> Result<Hull, Unsupported> {
        let mut nominal = || -> Result<V, Unsupported> {
            Ok(self.value(h, at, lod_depth, values)?.unwrap_or([f64::NAN; 4]))
        };
        let ty = self.m.info(h).ty;
        let cty = self.m.info(key.1).ty;
        let here = uv_box(&c.range(), cty);
        match (image, at) {
            (Some(image), At::Fragment(f)) if lod_depth < 2 && image.levels.len() > 1 => {
                let nominal = nominal()?;
                let (lo, hi) = self.lambda_interval(image, key, cty, here, &f, lod_depth)?;
                if is_point(&c.form) {
                    let path = image.lod_path(here[0].0, here[1].0, lo, hi);
                    let bounds = lanes(|k| hull_of(path.iter().map(|t| t[k]).chain([nominal[k]])));
                    if self.interval_hull {
                        return Ok(ranges.fresh(&bounds, ty));
                    }
                    let form = with_nominal(lod_form(&path, (lo, hi), key, ranges), nominal, ranges);
                    return Ok(Hull { form, bounds });
                }
                let r = image.footprint_hull(here[0], here[1], lo, hi);
                Ok(ranges.fresh(&lanes(|k| hull_of([r.0[k], r.1[k], nominal[k]])), ty))
            }
            _ if is_point(&c.form) => Ok(Hull::point(nominal()?)),
            (Some(image), _) => Ok(ranges.fresh(&image.footprint_hull(here[0], here[1], 0.0, 0.0), ty)),
            (None, _) => {
                Err(Unsupported::new("a baked lookup at coordinates that move with a level of detail"))
            }
        }
    }

    /// The interval of λ a minified lookup at fragment `f` may take
    /// (`minified`'s, from the intervals of the coordinates' differences
    /// where they move): GL §3.8.8's interval for ρ over the pixel's
    /// forward differences and the quad's coarse and fine ones, widened by
    /// `LOG2_SLACK`, within the levels.
    fn lambda_interval(
        &self,
        image: &Image,
        key: LookupKey,
        cty: Ty,
        here: [I; 2],
        f: &super::geometry::Fragment,
        lod_depth: u8,
    ) -> Result<I, Unsupported> {
        let at_offset = |dx: f64, dy: f64| -> Result<[I; 2], Unsupported> {
            if dx == 0.0 && dy == 0.0 {
                return Ok(here);
            }
            let g = At::Fragment(self.shifted(f, dx, dy));
            let r = self.range(key.1, g, lod_depth + 1, &mut Ranges::new(), &mut Memo::new())?;
            Ok(uv_box(&r.unwrap_or(point([f64::NAN; 4])), cty))
        };
        let d = |a: [I; 2], b: [I; 2]| [sub(b[0], a[0]), sub(b[1], a[1])];
        let sets = super::program::quad_derivative_sets(f.pixel, at_offset, d)?;
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for (dx, dy) in sets {
            let (a, b) = image.lod_bounds_within(dx, dy);
            (lo, hi) = (lo.min(a), hi.max(b));
        }
        let slack = super::program::LOG2_SLACK;
        let lo = if lo.is_nan() { 0.0 } else { (lo - slack).max(0.0) };
        let hi = if hi.is_nan() { f64::INFINITY } else { hi + slack };
        Ok((lo, hi.min(image.levels.len() as f64)))
    }
}

/// `δu`'s form for a baked lookup at coordinates of hull `c` (type
/// `cty`, `program::uv`): each of (u, v) its coordinate's form, less the
/// whole turns where the table repeats and its range lies within one turn
/// (GL §3.8.7: REPEAT keeps the fraction), clamped to [0, 1] where it
/// clamps; a fresh symbol over [0, 1] where a repeated range crosses a
/// turn, and over the box where the coordinates are a projected position.
fn texel_coordinates(c: &Hull, cty: Ty, repeat: bool, s: &mut Symbols) -> Form {
    let range = c.range();
    let boxed = uv_box(&range, cty);
    let coordinate = |k: usize, s: &mut Symbols| -> Affine {
        let (form, (lo, hi)) = match (cty, k) {
            (Ty::Position, _) => (Affine::interval(boxed[k], s.fresh()), boxed[k]),
            (Ty::Scalar, 1) => (Affine::constant(0.5), (0.5, 0.5)),
            _ => (c.form[k].clone(), lane(&range, k)),
        };
        if repeat && lo.floor() == hi.floor() {
            form.scale(1.0, -lo.floor())
        } else if repeat {
            Affine::interval((0.0, 1.0), s.fresh())
        } else if lo >= 0.0 && hi <= 1.0 {
            form
        } else {
            functions::clamped(&form, (lo, hi), (0.0, 1.0), s)
                .unwrap_or_else(|| Affine::interval((lo.clamp(0.0, 1.0), hi.clamp(0.0, 1.0)), s.fresh()))
        }
    };
    let u = coordinate(0, s);
    let v = coordinate(1, s);
    [u, v, Affine::constant(0.0), Affine::constant(0.0)]
}

/// The box of a lookup's first three coordinates (a direction, or a 3-D
/// texture's (s, t, r)) over hull `c`.
fn direction_box(c: &Hull) -> [I; 3] {
    let r = c.range();
    [lane(&r, 0), lane(&r, 1), lane(&r, 2)]
}

/// A minified lookup at one point `(u, v)` whose λ lies in `lambda`: the
/// texels at the ends of λ's pieces (`Image::lod_path`) `v₀ … vₙ`, and the
/// texel `v₀ + Σⱼ (vⱼ₊₁ − vⱼ)·tⱼ` with `tⱼ = ½ + ½εⱼ` how far λ has run
/// through piece j — one symbol per piece, shared by the channels and by
/// every read of the lookup with the same interval.
fn lod_form(path: &[V], lambda: I, key: LookupKey, ranges: &mut Ranges) -> Form {
    let mut form = path[0].map(Affine::constant);
    for (j, ends) in path.windows(2).enumerate() {
        let bits = [lambda.0.to_bits(), lambda.1.to_bits()];
        let symbols = &mut ranges.symbols;
        let sym = *ranges.pieces.entry((key, bits, j)).or_insert_with(|| symbols.fresh());
        for c in 0..4 {
            let half = 0.5 * (ends[1][c] - ends[0][c]);
            if half != 0.0 {
                form[c] = form[c].add(&Affine { center: half, terms: vec![(sym, half)] });
            }
        }
    }
    form
}

/// `form` with any lane that misses the `nominal` value (eq. 3.17's λ,
/// which §3.8.8's interval holds) widened to it on a fresh symbol — a
/// guard, not expected to act.
fn with_nominal(form: Form, nominal: V, ranges: &mut Ranges) -> Form {
    let mut form = form;
    for (a, x) in form.iter_mut().zip(nominal) {
        let (lo, hi) = a.range();
        if x < lo || x > hi {
            let gap = Affine::interval(((x - lo).min(0.0), (x - hi).max(0.0)), ranges.symbols.fresh());
            *a = a.add(&gap);
        }
    }
    form
}
