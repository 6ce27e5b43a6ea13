//! The texture unit of a modern (Vulkan/WebGPU) implementation, as the CPU
//! renderer's `f32` and `fixed9` modes model it so that they compute what
//! the WGSL backend's shaders compute on wgpu. The ideal
//! GL sampling of [`super::sampling`] stays the `exact` mode's.
//!
//! Everything here is what the specifications require, and where they leave
//! an implementation freedom, the choice is **Mesa's llvmpipe/lavapipe**
//! (22.3, the driver CI runs on; `gallivm/lp_bld_sample*.c`), measured on
//! it by `tests/wgsl_agreement.rs` (`texture_unit_*`):
//!
//! - **Level of detail per 2×2 quad** (Vulkan §16 "Scale factor": ∂u/∂x
//!   etc. may be the coarse derivatives of the quad; WGSL `textureSample`
//!   uses implicit derivatives): the derivatives are the differences of the
//!   coordinates between the quad's top-left pixel and its right and lower
//!   neighbours ([`crate::renderer::Fragment::quad_derivatives`]), one LOD
//!   for the four pixels. ρ² = max((∂u/∂x·w)² + (∂v/∂x·h)², (∂u/∂y·w)² +
//!   (∂v/∂y·h)²) is the spec's ρ, squared; λ = ½·log2(ρ²) with log2 taken
//!   *piecewise linearly* between powers of two — exact at powers of two,
//!   (e − 1) + m for ρ² = m·2ᵉ, m ∈ [1, 2) — the approximation of λ the spec
//!   allows (Vulkan §16.5.6: λ_base "may be approximated"). Linear mipmap
//!   filtering truncates the fraction of λ to 8 bits (the spec's
//!   `mipmapPrecisionBits`); nearest mipmap filtering rounds λ exactly
//!   (half up).
//! - **8-bit textures filter in 8.8 fixed point** in `fixed9` mode
//!   ([`Arithmetic::Fixed8`]; Vulkan §16.8:
//!   `subTexelPrecisionBits` = 8 on lavapipe; the precision of the filter
//!   arithmetic is the implementation's): the unnormalized coordinate
//!   u·size·256 is rounded to an integer (ties to even), ½ texel (128)
//!   subtracted, the top bits select the texel and the low 8 bits are the
//!   weight w ∈ 0..=255; each linear step is `a + ⌊(w·(b − a) + 128)/256⌋`
//!   on the 8-bit texel values, the result again 8-bit — horizontally on both
//!   rows, then vertically, then (trilinear) between the two levels with the
//!   8-bit λ fraction. Other formats filter in f32 with the same weights
//!   unquantized — and so do 8-bit textures in `f32` mode
//!   ([`Arithmetic::Float`]): exact fidelity uploads them to wgpu as 16-bit
//!   unorm (k·257, the same values), which lavapipe filters in float, so a
//!   filtered texel is not rounded to 8 bits before the shader's math (a
//!   1/255 step there became up to 6/255 under Kilgard's `^8`).
//! - **Cube maps are seamless** (WebGPU and Vulkan always filter cube maps
//!   seamlessly; GL 4.6 §8.13.1): a bilinear footprint that leaves a face
//!   takes the adjacent face's texels (GL's rule: the texel whose centre the
//!   out-of-face texel centre's direction hits), and a texel outside both
//!   edges at a corner is the average of the three that meet there. Seamless
//!   filtering is float filtering in lavapipe, so cube maps filter in f32 at
//!   any format. Face selection is GL's (Kilgard 2000, Appendix A Table 1,
//!   [`cube_face_uv`]).
//!
//! # What the specifications leave open: [`Latitude`]
//!
//! Another implementation (an NVIDIA GPU) makes other choices where the
//! specifications allow them. [`Latitude`] names one such choice per
//! freedom; rendering a plan once per choice of [`Latitude::ENVELOPE`]
//! (`renderer::plan::PlanRenderer::set_sampling_latitude`) gives, per
//! pixel, the interval an image comparison accepts (`bench::gpu_check`):
//!
//! - **λ** may lie anywhere in [λ − [`LOD_BELOW`], λ + [`LOD_ABOVE`]] of
//!   this model's λ (the derivation is at the constants: the scale
//!   factor's max-norm bounds, log₂'s approximation, the mipmap blend
//!   weight's precision). The sample is a piecewise-linear function of λ
//!   whose breakpoints are the integers (trilinear: a pure level; nearest
//!   mipmap: where the level changes), so over that interval it takes its
//!   extremes at the two ends or at the at most two integers inside
//!   ([`LodChoice`]): five renders bound every λ a conforming unit takes.
//!   The independent reference (`oracle::program`'s lookups) takes the
//!   exact per-pixel λ and marks as latitude the pixels where λ per quad
//!   or λ ± 0.1 (log₂'s approximation) moves a texel by more than half a
//!   step; those choices lie inside this interval, which adds the scale
//!   factor's own approximation the specifications allow.
//! - **Sub-texel weights** may be quantized to [`SUB_TEXEL_BITS`] bits,
//!   by truncation or by rounding ([`WeightChoice`]); a bilinear sample
//!   is bilinear in the two weights, so its extremes over the two
//!   quantization intervals are at their four corners.
//! - **Cube-map face selection** at a face edge: filtering is seamless on
//!   both sides (above), so the face an implementation picks where two
//!   major-axis magnitudes are equal to float precision samples the same
//!   footprint, weighted from the other face's side; the difference is
//!   that of [`WeightChoice`] at the edge and is not modelled further.
//! - **Dependent lookups** (EMBM, `offset_2d`): a choice is applied to
//!   every lookup of a render at once, and the second lookup's coordinates
//!   are computed from the first's result in that render (and its λ from
//!   those coordinates across the quad), so the latitude of the first
//!   propagates through the renderer's own arithmetic. The per-pixel hull
//!   of the renders is then exactly the set of values for one lookup, and
//!   for a composition a bound where the result is monotone in each
//!   lookup's choice; where it is not (a nearest lookup whose texel a
//!   perturbed coordinate changes), a GPU pixel outside the hull is
//!   reported by the comparison, not hidden.

use super::sampling::{
    cube_direction, cube_face_uv, floor_finite, CubeFace, Filter, Level, TexelFormat, Texture2D, TextureCube,
    Wrap,
};

/// λ of a lookup from the coarse derivatives of (u, v) in a 2×2 quad,
/// `ddx = [∂u/∂x, ∂v/∂x]`, `ddy = [∂u/∂y, ∂v/∂y]`, for a level-0 size of
/// `width`×`height` (module docs). Non-finite or zero derivatives give
/// −∞ (magnification: level 0).
pub fn quad_lod(width: u32, height: u32, ddx: [f32; 2], ddy: [f32; 2]) -> f32 {
    let (w, h) = (width as f32, height as f32);
    let (ux, vx, uy, vy) = (ddx[0] * w, ddx[1] * h, ddy[0] * w, ddy[1] * h);
    let rho2 = (ux * ux + vx * vx).max(uy * uy + vy * vy);
    if !rho2.is_finite() || rho2 <= 0.0 {
        return f32::NEG_INFINITY;
    }
    0.5 * piecewise_log2(rho2)
}

/// log2 linear between powers of two: (e − 1) + m for x = m·2ᵉ, m ∈ [1, 2).
pub(crate) fn piecewise_log2(x: f32) -> f32 {
    let bits = x.to_bits();
    let e = ((bits >> 23) & 0xff) as i32 - 127;
    let m = f32::from_bits((bits & 0x007f_ffff) | 0x3f80_0000);
    (e - 1) as f32 + m
}

/// How a texture unit computes with the texels of an 8-bit texture (module
/// docs); other formats always filter in float.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Arithmetic {
    /// 8.8 fixed point, 8-bit results: the hardware (`fixed9`) model, and
    /// lavapipe on `Rgba8Unorm`. `tie_bias` is 0 in the model; otherwise
    /// every rounding or truncation of the coordinates' 1/256 texels and
    /// of λ's 1/256 moves by that many quanta — a sensitivity probe
    /// (`renderer::plan::PlanRenderer::set_rounding_bias`).
    Fixed8 { tie_bias: f32 },
    /// f32 weights and results: the `f32` model, and lavapipe on the
    /// `Rgba16Unorm` upload of exact fidelity.
    Float,
}

impl Arithmetic {
    /// The hardware model: [`Arithmetic::Fixed8`] with no bias.
    pub const FIXED8: Arithmetic = Arithmetic::Fixed8 { tie_bias: 0.0 };
}

/// How far below this model's λ another conforming implementation's λ
/// may lie. The specifications let ρ be approximated by a function f
/// bounded by the max-norm and the sum of the scaled derivatives (GL 1.4
/// §3.8.8: max{m_u, m_v} ≤ f ≤ m_u + m_v; Vulkan, "Scale Factor
/// Operation": max(|m_ux|, |m_vx|) ≤ f_x ≤ √2(|m_ux| + |m_vx|)). The
/// lower bound is at least ρ/√2 (the larger of two components of a vector
/// is at least its length over √2): −½ in log₂. This model's own λ is the
/// larger end of its ρ ([`quad_lod`] takes the exact length), so nothing
/// else lowers it, save the blend weight's precision: Vulkan's
/// `mipmapPrecisionBits` is 8 on lavapipe and on NVIDIA's drivers (the
/// minimum the spec allows is 4), the fraction of λ within 2⁻⁸ of itself.
pub const LOD_BELOW: f32 = 0.5 + 1.0 / 256.0;

/// How far above this model's λ another conforming implementation's λ may
/// lie: the upper bound of [`LOD_BELOW`]'s f is m_u + m_v ≤ 2ρ (for
/// derivatives (a, 0) and (0, a), ρ = a and the sum is 2a; Vulkan's √2
/// times the sum of one axis's two components is at most 2ρ_x): +1 in
/// log₂; plus this model's approximation of log₂ (linear between powers of
/// two, below log₂ by at most max over m ∈ [0, 1) of log₂(1 + m) − m =
/// 0.0861 at m = 1/ln 2 − 1, halved since λ = ½·log₂ρ²: 0.0431), plus the
/// blend weight's 2⁻⁸.
pub const LOD_ABOVE: f32 = 1.0 + 0.0431 + 1.0 / 256.0;

/// Bits of sub-texel precision of another implementation's filter
/// weights: Vulkan's `subTexelPrecisionBits` (at least 4), 8 on NVIDIA's
/// drivers and on lavapipe, whose 8-bit-texture path this model's
/// [`Arithmetic::Fixed8`] follows; its float path (and this model's
/// [`Arithmetic::Float`]) keeps full f32 weights.
pub const SUB_TEXEL_BITS: u32 = 8;

/// One choice, among those the specifications allow, for the level of
/// detail of a lookup (module docs, "What the specifications leave open").
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum LodChoice {
    /// This model's λ ([`quad_lod`]).
    #[default]
    Model,
    /// λ + Δ (Δ = −[`LOD_BELOW`] or [`LOD_ABOVE`]: the interval's ends).
    Shift(f32),
    /// The lowest integer in [λ − [`LOD_BELOW`], λ + [`LOD_ABOVE`]]
    /// (a breakpoint of the sample as a function of λ); λ where none is.
    LowestInteger,
    /// The highest integer in that interval; λ where none is.
    HighestInteger,
}

impl LodChoice {
    /// λ as this choice takes it.
    pub fn apply(self, lod: f32) -> f32 {
        let (low, high) = (lod - LOD_BELOW, lod + LOD_ABOVE);
        match self {
            LodChoice::Model => lod,
            LodChoice::Shift(d) => lod + d,
            LodChoice::LowestInteger if low.ceil() <= high => low.ceil(),
            LodChoice::HighestInteger if high.floor() >= low => high.floor(),
            LodChoice::LowestInteger | LodChoice::HighestInteger => lod,
        }
    }
}

/// One choice for the sub-texel weights of bilinear filtering.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum WeightChoice {
    /// This model's weights (f32, or 8 bits rounded ties to even in
    /// [`Arithmetic::Fixed8`]).
    #[default]
    Model,
    /// Each axis's weight quantized to [`SUB_TEXEL_BITS`] bits, down
    /// (truncated) or up: a corner of the two quantization intervals. In
    /// [`Arithmetic::Fixed8`] the 1/256-texel coordinate is taken ⌊·⌋ or
    /// ⌈·⌉ instead of rounded (to within 10⁻³ of a quantum).
    Quantized { x_up: bool, y_up: bool },
}

impl WeightChoice {
    /// A float weight as this choice quantizes it on the axis whose
    /// choice is `up`.
    fn weight(self, w: f32, up: bool) -> f32 {
        let scale = (1u32 << SUB_TEXEL_BITS) as f32;
        match (self, up) {
            (WeightChoice::Model, _) => w,
            (WeightChoice::Quantized { .. }, false) => (w * scale).floor() / scale,
            (WeightChoice::Quantized { .. }, true) => (w * scale).ceil() / scale,
        }
    }

    /// The two axes' float weights.
    fn weights(self, ax: f32, ay: f32) -> (f32, f32) {
        match self {
            WeightChoice::Model => (ax, ay),
            WeightChoice::Quantized { x_up, y_up } => (self.weight(ax, x_up), self.weight(ay, y_up)),
        }
    }

    /// The offsets, in 1/256 quanta, that turn [`Arithmetic::Fixed8`]'s
    /// rounding of the coordinate into ⌊·⌋ or ⌈·⌉, per axis.
    fn fixed_offsets(self) -> (f32, f32) {
        let offset = |up: bool| if up { 0.499 } else { -0.499 };
        match self {
            WeightChoice::Model => (0.0, 0.0),
            WeightChoice::Quantized { x_up, y_up } => (offset(x_up), offset(y_up)),
        }
    }
}

/// One choice per freedom the specifications leave a texture unit (module
/// docs); the default is this model.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Latitude {
    pub lod: LodChoice,
    pub weights: WeightChoice,
    /// Texels added to the unnormalized coordinates before a `nearest`
    /// lookup picks its texel; 0 in the model. Not a freedom of the
    /// texture unit but of the coordinates it is handed: another
    /// implementation interpolates them in its own float arithmetic
    /// (Vulkan §3.7 leaves interpolation's precision to it), so a
    /// coordinate that lies within float noise of a texel edge — a
    /// constant 0.5 interpolated across a triangle, on a texture of even
    /// size — may fall on either side. `bench::gpu_check`'s tie pictures
    /// set it from `RoundingBias::texel_quanta`.
    pub nearest_shift: f32,
}

impl Latitude {
    /// This model: lavapipe's choices.
    pub const MODEL: Latitude =
        Latitude { lod: LodChoice::Model, weights: WeightChoice::Model, nearest_shift: 0.0 };

    /// The choices whose renders bound every conforming implementation
    /// (module docs): the model, the four λ breakpoints, the four weight
    /// corners.
    pub const ENVELOPE: [Latitude; 9] = [
        Latitude::MODEL,
        Latitude::lod(LodChoice::Shift(-LOD_BELOW)),
        Latitude::lod(LodChoice::Shift(LOD_ABOVE)),
        Latitude::lod(LodChoice::LowestInteger),
        Latitude::lod(LodChoice::HighestInteger),
        Latitude::weights(false, false),
        Latitude::weights(false, true),
        Latitude::weights(true, false),
        Latitude::weights(true, true),
    ];

    const fn lod(lod: LodChoice) -> Latitude {
        Latitude { lod, weights: WeightChoice::Model, nearest_shift: 0.0 }
    }

    const fn weights(x_up: bool, y_up: bool) -> Latitude {
        Latitude {
            lod: LodChoice::Model,
            weights: WeightChoice::Quantized { x_up, y_up },
            nearest_shift: 0.0,
        }
    }
}

/// Samples a 2D texture at (u, v) with level of detail `lod` ([`quad_lod`]).
pub fn sample_2d(
    t: &Texture2D,
    u: f32,
    v: f32,
    filter: Filter,
    lod: f32,
    arithmetic: Arithmetic,
) -> [f32; 4] {
    sample_2d_with(t, u, v, filter, lod, arithmetic, Latitude::MODEL)
}

/// [`sample_2d`] as another implementation would take it: λ and the
/// weights as `latitude` chooses (module docs).
pub fn sample_2d_with(
    t: &Texture2D,
    u: f32,
    v: f32,
    filter: Filter,
    lod: f32,
    arithmetic: Arithmetic,
    latitude: Latitude,
) -> [f32; 4] {
    let (fixed, bias) = match arithmetic {
        Arithmetic::Fixed8 { tie_bias } if t.format == TexelFormat::Rgba8 => (true, tie_bias),
        _ => (false, 0.0),
    };
    let last = t.levels.len() - 1;
    let lod = if lod.is_nan() { f32::NEG_INFINITY } else { latitude.lod.apply(lod + bias / 256.0) };
    let filter_in = |level: usize| {
        let l = &t.levels[level];
        match fixed {
            true => bilinear(l, bias, latitude.weights, u, v, t.wrap),
            false => float_bilinear(l, latitude.weights, u, v, t.wrap),
        }
    };
    match filter {
        // Nearest and bilinear take the level nearest to λ (GL's
        // *_MIPMAP_NEAREST); without a chain, level 0.
        Filter::Nearest | Filter::Bilinear => {
            let level = if lod <= 0.0 { 0 } else { ((lod + 0.5).floor() as usize).min(last) };
            if filter == Filter::Nearest {
                let l = &t.levels[level];
                let shift = latitude.nearest_shift;
                l.sample_nearest(u + shift / l.width as f32, v + shift / l.height as f32, t.wrap)
            } else {
                filter_in(level)
            }
        }
        Filter::Trilinear => {
            let floor = lod.floor();
            if lod.is_infinite() || floor < 0.0 || last == 0 {
                return filter_in(0);
            }
            let l0 = floor as usize;
            if l0 >= last {
                return filter_in(last);
            }
            let fraction = lod - floor;
            let a = filter_in(l0);
            if fixed {
                // mipmapPrecisionBits = 8, truncated.
                let w = (fraction * 256.0) as i32;
                if w <= 0 {
                    return a;
                }
                let b = filter_in(l0 + 1);
                [0, 1, 2, 3].map(|c| lerp8(w, to_byte(a[c]), to_byte(b[c])) as f32 / 255.0)
            } else {
                let b = filter_in(l0 + 1);
                [0, 1, 2, 3].map(|c| a[c] + fraction * (b[c] - a[c]))
            }
        }
    }
}

/// Float bilinear filtering of one level (GL's, [`Level::sample_bilinear`])
/// with the weights as `weights` quantizes them.
fn float_bilinear(level: &Level, weights: WeightChoice, u: f32, v: f32, wrap: Wrap) -> [f32; 4] {
    if weights == WeightChoice::Model {
        return level.sample_bilinear(u, v, wrap);
    }
    let fx = finite(u * level.width as f32 - 0.5);
    let fy = finite(v * level.height as f32 - 0.5);
    let (x0, y0) = (floor_finite(fx), floor_finite(fy));
    let (ax, ay) = weights.weights(fx - x0, fy - y0);
    let (x0, y0) = (x0 as i64, y0 as i64);
    let t = |dx: i64, dy: i64| level.fetch(x0 + dx, y0 + dy, wrap);
    let (t00, t10, t01, t11) = (t(0, 0), t(1, 0), t(0, 1), t(1, 1));
    [0, 1, 2, 3].map(|c| {
        let top = t00[c] + ax * (t10[c] - t00[c]);
        let bottom = t01[c] + ax * (t11[c] - t01[c]);
        top + ay * (bottom - top)
    })
}

/// Samples a cube map along `direction`, seamlessly (level 0: the renderer's
/// cube maps have no chains).
pub fn sample_cube(c: &TextureCube, direction: [f32; 3], filter: Filter) -> [f32; 4] {
    sample_cube_with(c, direction, filter, WeightChoice::Model)
}

/// [`sample_cube`] with the filter weights as `weights` quantizes them.
pub fn sample_cube_with(
    c: &TextureCube,
    direction: [f32; 3],
    filter: Filter,
    weights: WeightChoice,
) -> [f32; 4] {
    let (face, s, t) = cube_face_uv(direction);
    let f = &c.faces[face as usize];
    let level = &f.levels[0];
    if filter == Filter::Nearest {
        return level.sample_nearest(s, t, Wrap::ClampToEdge);
    }
    let n = level.width as i64;
    let fx = finite(s * level.width as f32 - 0.5);
    let fy = finite(t * level.height as f32 - 0.5);
    let (x0, y0) = (floor_finite(fx), floor_finite(fy));
    let (ax, ay) = weights.weights(fx - x0, fy - y0);
    let (x0, y0) = (x0 as i64, y0 as i64);
    let inside = |i: i64| (0..n).contains(&i);
    let mut texel = [[[0.0f32; 4]; 2]; 2];
    let mut corner = None;
    for (dy, row) in texel.iter_mut().enumerate() {
        for (dx, out) in row.iter_mut().enumerate() {
            let (i, j) = (x0 + dx as i64, y0 + dy as i64);
            if inside(i) || inside(j) {
                *out = cube_texel(c, face, i, j);
            } else {
                corner = Some((dx, dy));
            }
        }
    }
    if let Some((dx, dy)) = corner {
        texel[dy][dx] = cube_corner(&texel, (dx, dy));
    }
    [0, 1, 2, 3].map(|k| {
        let top = texel[0][0][k] + ax * (texel[0][1][k] - texel[0][0][k]);
        let bottom = texel[1][0][k] + ax * (texel[1][1][k] - texel[1][0][k]);
        top + ay * (bottom - top)
    })
}

/// The texel of a seamless footprint `texel` (`[dy][dx]`) at its corner
/// (`dx`, `dy`) beyond two edges of the face: the three texels that meet
/// at the corner are the other three of the footprint (GL 4.6 §8.13.1),
/// averaged.
fn cube_corner(texel: &[[[f32; 4]; 2]; 2], (dx, dy): (usize, usize)) -> [f32; 4] {
    let others = [(dx ^ 1, dy), (dx, dy ^ 1), (dx ^ 1, dy ^ 1)];
    [0, 1, 2, 3].map(|k| others.iter().map(|&(x, y)| texel[y][x][k]).sum::<f32>() / 3.0)
}

/// Level 0 of each face of `c` with a border of one texel, `(n + 2)²`
/// texels row-major (texel (i, j) of the face, i and j in −1..=n, at
/// `(j + 1)·(n + 2) + i + 1`): what [`sample_cube_with`]'s bilinear
/// footprints read there — the face's texels, one texel beyond an edge the
/// adjacent face's, and at a corner beyond two edges the average of the
/// other three texels of the one footprint that reaches it. A footprint
/// whose top-left texel is (x, y) with −1 ≤ x, y < n reads the four texels
/// at (x, y)…(x + 1, y + 1) of this grid, the same values the one-lane
/// code finds. Faces of one size `n` (a cube map's).
pub(crate) fn cube_bordered_faces(c: &TextureCube) -> [Vec<[f32; 4]>; 6] {
    let n = c.faces[0].levels[0].width as i64;
    CubeFace::ALL.map(|face| {
        let texel = |i: i64, j: i64| cube_texel(c, face, i, j);
        let mut grid = Vec::with_capacity(((n + 2) * (n + 2)) as usize);
        for j in -1..=n {
            for i in -1..=n {
                let outside = |v: i64| !(0..n).contains(&v);
                grid.push(if outside(i) && outside(j) {
                    // The one footprint with this corner: its top-left
                    // texel and the corner's place in it.
                    let (x0, dx) = if i < 0 { (i, 0) } else { (i - 1, 1) };
                    let (y0, dy) = if j < 0 { (j, 0) } else { (j - 1, 1) };
                    let mut fp = [[[0.0f32; 4]; 2]; 2];
                    for (ry, row) in fp.iter_mut().enumerate() {
                        for (rx, t) in row.iter_mut().enumerate() {
                            if (rx, ry) != (dx, dy) {
                                *t = texel(x0 + rx as i64, y0 + ry as i64);
                            }
                        }
                    }
                    cube_corner(&fp, (dx, dy))
                } else {
                    texel(i, j)
                });
            }
        }
        grid
    })
}

/// Texel (i, j) of `face`, or, one texel beyond one of its edges, the texel
/// of the adjacent face whose area the direction through its centre hits.
fn cube_texel(c: &TextureCube, face: CubeFace, i: i64, j: i64) -> [f32; 4] {
    let level = &c.faces[face as usize].levels[0];
    let n = level.width as i64;
    if (0..n).contains(&i) && (0..n).contains(&j) {
        return level.texel(i as u32, j as u32);
    }
    let size = n as f32;
    let d = cube_direction(face, (i as f32 + 0.5) / size, (j as f32 + 0.5) / size);
    let (other, s, t) = cube_face_uv(d);
    let l = &c.faces[other as usize].levels[0];
    let x = ((s * size).floor() as i64).clamp(0, n - 1);
    let y = ((t * size).floor() as i64).clamp(0, n - 1);
    l.texel(x as u32, y as u32)
}

/// Bilinear filtering of one level of an 8-bit texture in 8.8 fixed point
/// ([`Arithmetic::Fixed8`], module docs).
fn bilinear(level: &Level, bias: f32, weights: WeightChoice, u: f32, v: f32, wrap: Wrap) -> [f32; 4] {
    let (ox, oy) = weights.fixed_offsets();
    let (x0, x1, wx) = fixed_coordinate(u, level.width, wrap, bias + ox);
    let (y0, y1, wy) = fixed_coordinate(v, level.height, wrap, bias + oy);
    let t = |x: u32, y: u32| level.texel(x, y).map(to_byte);
    let (t00, t10, t01, t11) = (t(x0, y0), t(x1, y0), t(x0, y1), t(x1, y1));
    [0, 1, 2, 3].map(|c| {
        let top = lerp8(wx, t00[c], t10[c]);
        let bottom = lerp8(wx, t01[c], t11[c]);
        lerp8(wy, top, bottom) as f32 / 255.0
    })
}

/// The two texel indices and the 8-bit weight of the second along one axis.
fn fixed_coordinate(u: f32, size: u32, wrap: Wrap, bias: f32) -> (u32, u32, i32) {
    let n = size as i64;
    let pot = size.is_power_of_two();
    let scaled = |x: f32| -> i64 {
        let x = (x + bias).round_ties_even();
        if x.is_finite() {
            x.clamp(-(1i64 << 40) as f32, (1i64 << 40) as f32) as i64
        } else {
            0
        }
    };
    if wrap == Wrap::Repeat && !pot {
        // Non-power-of-two repeat wraps in float first.
        let f = finite(u - u.floor());
        let s = scaled(f * size as f32 * 256.0) - 128;
        let w = (s & 255) as i32;
        let mut i0 = s >> 8;
        if i0 < 0 {
            i0 = n - 1;
        }
        let i0 = i0.min(n - 1);
        let i1 = if i0 == n - 1 { 0 } else { i0 + 1 };
        return (i0 as u32, i1 as u32, w);
    }
    let s = scaled(finite(u) * (size * 256) as f32) - 128;
    let w = (s & 255) as i32;
    let i0 = s >> 8;
    let (i0, i1) = match wrap {
        Wrap::Repeat => (i0 & (n - 1), (i0 + 1) & (n - 1)),
        Wrap::ClampToEdge => (i0.clamp(0, n - 1), (i0 + 1).clamp(0, n - 1)),
    };
    (i0 as u32, i1 as u32, w)
}

/// One 8-bit linear step with an 8-bit weight, rounded (module docs).
#[inline]
fn lerp8(w: i32, a: i32, b: i32) -> i32 {
    a + ((w * (b - a) + 128) >> 8)
}

#[inline]
fn to_byte(v: f32) -> i32 {
    (v.clamp(0.0, 1.0) * 255.0).round() as i32
}

#[inline]
fn finite(v: f32) -> f32 {
    if v.is_finite() {
        v.clamp(-1e9, 1e9)
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The tie bias moves the rounding of the 1/256-texel coordinate, and
    /// only near its tie (`Arithmetic::Fixed8 { tie_bias }`).
    #[test]
    fn tie_bias_moves_only_near_ties() {
        // u·256·256 = 192.5: a tie, to even (192), weight 192 − 128 = 64.
        let tie = 192.5 / 65536.0;
        let weight = |u: f32, bias: f32| fixed_coordinate(u, 256, Wrap::ClampToEdge, bias).2;
        assert_eq!((weight(tie, 0.0), weight(tie, 0.01), weight(tie, -0.01)), (64, 65, 64));
        let off = 192.3 / 65536.0;
        assert_eq!((weight(off, 0.0), weight(off, 0.01), weight(off, -0.01)), (64, 64, 64));
    }

    fn two_texels(a: [f32; 4], b: [f32; 4]) -> Texture2D {
        Texture2D::new(TexelFormat::Rgba8, Wrap::ClampToEdge, Level::new(2, 1, vec![a, b]))
    }

    #[test]
    fn fixed_point_weights_round_ties_to_even_and_lerps_round() {
        // Between the texel centres u = 0.25 and 0.75; a = (x + ½)/256.
        let t = two_texels([0.0; 4], [1.0; 4]);
        let at = |x: u32| {
            let u = 0.25 + 0.5 * (x as f32 + 0.5) / 256.0;
            (sample_2d(&t, u, 0.5, Filter::Bilinear, 0.0, Arithmetic::FIXED8)[0] * 255.0).round() as u32
        };
        // u·512 = 128 + x + ½ rounds to the even neighbour: weights 0, 2, 2, 4, 4 …
        // and 255·w/256 rounds: 0, 2, 2, 4, 4, …; 128 → 128; 130 → 129.
        assert_eq!([at(0), at(1), at(2), at(3), at(4)], [0, 2, 2, 4, 4]);
        assert_eq!([at(127), at(128), at(129), at(130), at(131)], [128, 128, 129, 129, 131]);
        // The result is 8-bit: between 10 and 11 there is nothing.
        let t = two_texels([10.0 / 255.0; 4], [11.0 / 255.0; 4]);
        let s = sample_2d(&t, 0.25 + 0.5 * 0.3, 0.5, Filter::Bilinear, 0.0, Arithmetic::FIXED8);
        assert_eq!(s[0], 10.0 / 255.0);
        // In float it is: 30% of the way.
        let s = sample_2d(&t, 0.25 + 0.5 * 0.3, 0.5, Filter::Bilinear, 0.0, Arithmetic::Float);
        assert!((s[0] * 255.0 - 10.3).abs() < 1e-4, "{}", s[0] * 255.0);
    }

    #[test]
    fn piecewise_log2_is_exact_at_powers_of_two_and_linear_between() {
        assert_eq!(piecewise_log2(1.0), 0.0);
        assert_eq!(piecewise_log2(8.0), 3.0);
        assert_eq!(piecewise_log2(0.25), -2.0);
        assert_eq!(piecewise_log2(1.5), 0.5);
        assert_eq!(piecewise_log2(12.0), 3.5);
        // ρ = 2 texels per pixel → λ = 1; ρ² = 2 → ½.
        assert_eq!(quad_lod(256, 256, [2.0 / 256.0, 0.0], [0.0, 1.0 / 256.0]), 1.0);
        assert_eq!(quad_lod(4, 4, [0.0, 0.0], [0.0, 0.0]), f32::NEG_INFINITY);
    }

    #[test]
    fn seamless_cube_filtering_crosses_faces() {
        // Each face a constant: at a face's edge the filter mixes in the
        // neighbour's value; at its centre it does not.
        let faces = CubeFace::ALL.map(|f| {
            let v = f as usize as f32 / 10.0;
            Texture2D::new(
                TexelFormat::F32,
                Wrap::ClampToEdge,
                Level::new(4, 4, vec![[v, 0.0, 0.0, 1.0]; 16]),
            )
        });
        let c = TextureCube { faces };
        assert_eq!(sample_cube(&c, [1.0, 0.0, 0.0], Filter::Bilinear)[0], 0.0);
        // +X at s = 1 (its −Z edge), t = ½: half +X (0.0), half −Z (0.5).
        let s = sample_cube(&c, [1.0, 0.0, -1.0 + 1e-6], Filter::Bilinear)[0];
        assert!((s - 0.25).abs() < 1e-3, "{s}");
        // A corner: the average of the three faces, whichever face is chosen.
        let s = sample_cube(&c, [1.0, 1.0 - 1e-6, 1.0 - 1e-6], Filter::Bilinear)[0];
        let expected = (0.0 + 0.2 + 0.4) / 3.0;
        assert!((s - expected).abs() < 1e-3, "{s} vs {expected}");
    }

    /// A ramp whose mip levels differ: level k holds the value k/8.
    fn levels_ramp() -> Texture2D {
        let base = Level::new(64, 64, vec![[0.0, 0.0, 0.0, 1.0]; 64 * 64]);
        let mut t = Texture2D::new(TexelFormat::F32, Wrap::Repeat, base).with_box_mipmaps();
        for (k, level) in t.levels.iter_mut().enumerate() {
            level.texels.fill([k as f32 / 8.0, 0.0, 0.0, 1.0]);
        }
        t
    }

    /// The hull of the envelope's renders holds the sample of every λ in
    /// [λ − LOD_BELOW, λ + LOD_ABOVE], trilinear and nearest-mipmap alike:
    /// the breakpoints (integers) are among the choices.
    #[test]
    fn envelope_bounds_every_lod_in_the_interval() {
        let t = levels_ramp();
        for filter in [Filter::Trilinear, Filter::Bilinear, Filter::Nearest] {
            for k in 0..400 {
                let lod = -1.0 + k as f32 * 0.0173;
                let hull = Latitude::ENVELOPE
                    .map(|l| sample_2d_with(&t, 0.3, 0.6, filter, lod, Arithmetic::Float, l)[0]);
                let (lo, hi) = hull.iter().fold((f32::MAX, f32::MIN), |(a, b), &x| (a.min(x), b.max(x)));
                for j in 0..=64 {
                    let other = lod - LOD_BELOW + (LOD_BELOW + LOD_ABOVE) * j as f32 / 64.0;
                    let x = sample_2d(&t, 0.3, 0.6, filter, other, Arithmetic::Float)[0];
                    assert!(
                        x >= lo - 1e-6 && x <= hi + 1e-6,
                        "{filter:?} λ {lod} → {other}: {x} ∉ [{lo}, {hi}]"
                    );
                }
            }
        }
    }

    #[test]
    fn lod_choices_take_the_interval_ends_and_its_integers() {
        assert_eq!(LodChoice::Model.apply(1.3), 1.3);
        assert_eq!(LodChoice::Shift(-LOD_BELOW).apply(1.3), 1.3 - LOD_BELOW);
        assert_eq!(LodChoice::LowestInteger.apply(1.3), 1.0);
        assert_eq!(LodChoice::HighestInteger.apply(1.3), 2.0);
        assert_eq!(LodChoice::LowestInteger.apply(0.6), 1.0);
        assert_eq!(LodChoice::HighestInteger.apply(f32::NEG_INFINITY), f32::NEG_INFINITY);
    }

    /// The specifications' worst cases of the scale factor land at the
    /// interval's ends: derivatives (a, 0), (0, a) give ρ = a, the sum
    /// bound 2a (+1); (a, a) in x gives ρ = √2·a, the max-norm a (−½).
    #[test]
    fn scale_factor_bounds_are_the_interval() {
        let a = 4.0 / 256.0;
        let model = quad_lod(256, 256, [a, 0.0], [0.0, a]);
        let sum = (2.0f32 * 4.0).log2();
        assert!(sum - model <= LOD_ABOVE && sum - model >= 1.0 - 1e-6, "{model} {sum}");
        let model = quad_lod(256, 256, [a, a], [0.0, 0.0]);
        let max_norm = 4.0f32.log2();
        assert!(model - max_norm <= LOD_BELOW, "{model} {max_norm}");
        // The piecewise log2's worst error, halved, is within the allowance.
        let m = 1.0 / std::f32::consts::LN_2 - 1.0;
        assert!(0.5 * ((1.0 + m).log2() - m) < 0.0431);
    }

    /// 8-bit weights, down and up, bracket the float weight; in fixed
    /// point they are ⌊·⌋ and ⌈·⌉ of the 1/256-texel coordinate.
    #[test]
    fn quantized_weights_bracket_the_model() {
        let t = two_texels([0.0; 4], [1.0; 4]);
        let u = 0.25 + 0.5 * 0.3001;
        let at = |w| sample_2d_with(&t, u, 0.5, Filter::Bilinear, 0.0, Arithmetic::Float, w)[0];
        let (down, model, up) =
            (at(Latitude::weights(false, false)), at(Latitude::MODEL), at(Latitude::weights(true, true)));
        assert!(down < model && model < up && up - down <= 1.0 / 256.0 + 1e-6, "{down} {model} {up}");
        assert_eq!(down, 76.0 / 256.0);
        let weight = |u: f32, o: f32| fixed_coordinate(u, 256, Wrap::ClampToEdge, o).2;
        let x = 192.3 / 65536.0;
        let (d, _) = (WeightChoice::Quantized { x_up: false, y_up: true }).fixed_offsets();
        assert_eq!((weight(x, d), weight(x, 0.499)), (64, 65));
    }
}
