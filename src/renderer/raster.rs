//! Triangle setup: vertex stage, homogeneous clipping, snapping to a
//! fixed-point grid, culling, and the edge functions of the top-left fill rule.
//!
//! **Fill rule.** Vertices snap to 1/2^`SUBPIXEL_BITS` pixel; edge functions
//! are exact `i64`s, so two triangles sharing an edge compute the same edge
//! function with opposite sign, and the top-left rule (a pixel centre exactly
//! on an edge belongs to the triangle for which that edge is a top or left
//! edge) gives every pixel to exactly one of them: no cracks, no double hits.
//!
//! **Clipping.** Polygons are clipped in homogeneous space against w ≥ ε, the
//! near and far planes, and a guard band (|x|, |y| ≤ g·w) that keeps snapped
//! coordinates inside ±2^15 pixels. An intersection is always computed from
//! the inside vertex towards the outside one, so an edge shared by two
//! triangles is cut at bit-identical points.

use rayon::prelude::*;

use super::{CullMode, Pass, RenderError};

/// Sub-pixel precision of snapped vertex positions.
pub const SUBPIXEL_BITS: u32 = 8;
pub(crate) const SUB: i64 = 1 << SUBPIXEL_BITS;
const HALF: i64 = SUB / 2;

/// One pixel being shaded, as the fragment stage sees it.
pub struct Fragment<'a> {
    /// Pixel column (0 = left).
    pub x: u32,
    /// Pixel row (0 = top).
    pub y: u32,
    /// Window depth in [0, 1].
    pub depth: f32,
    /// Counter-clockwise in normalized device coordinates.
    pub front_facing: bool,
    /// Interpolated 1/w (perspective-correct weights divide by it).
    pub(crate) inv_w: f32,
    /// d(v/w)/dx, d(v/w)/dy for every varying, then d(1/w)/dx, d(1/w)/dy.
    pub(crate) gradients: &'a [f32],
}

impl Fragment<'_> {
    /// Screen-space derivatives [d/dx, d/dy] (per pixel) of varying `index`
    /// whose interpolated value at this pixel is `value` — what a GPU gets
    /// from its 2×2 quads, computed here analytically from the triangle's
    /// planes: v = A/Q with A = v/w and Q = 1/w affine in screen space, so
    /// dv/dx = (dA/dx − v·dQ/dx)/Q. Used to choose a mipmap level.
    pub fn derivatives(&self, index: usize, value: f32) -> [f32; 2] {
        let n = self.gradients.len() / 2 - 1;
        if index >= n || self.inv_w == 0.0 {
            return [0.0, 0.0];
        }
        let (ax, ay) = (self.gradients[2 * index], self.gradients[2 * index + 1]);
        let (qx, qy) = (self.gradients[2 * n], self.gradients[2 * n + 1]);
        [(ax - value * qx) / self.inv_w, (ay - value * qy) / self.inv_w]
    }

    /// The coarse derivatives of varying `index` (value `value` here) in
    /// this pixel's 2×2 quad, as a GPU takes them for a texture's level of
    /// detail (`textures::unit`): [d/dx, d/dy] = the varying at the quad's
    /// top-right and bottom-left pixels minus the one at its top-left, each
    /// interpolated perspective-correctly from this triangle's planes (a
    /// pixel outside the triangle is a helper pixel, extrapolated, as on a
    /// GPU). Falls back to [`Fragment::derivatives`] where 1/w degenerates.
    pub fn quad_derivatives(&self, index: usize, value: f32) -> [f32; 2] {
        let n = self.gradients.len() / 2 - 1;
        if index >= n || self.inv_w == 0.0 {
            return [0.0, 0.0];
        }
        let (ax, ay) = (self.gradients[2 * index], self.gradients[2 * index + 1]);
        let (qx, qy) = (self.gradients[2 * n], self.gradients[2 * n + 1]);
        // Offsets of the quad's top-left pixel from this one.
        let (ox, oy) = (-((self.x & 1) as f32), -((self.y & 1) as f32));
        let a = value * self.inv_w + ax * ox + ay * oy;
        let q = self.inv_w + qx * ox + qy * oy;
        let (qr, qb) = (q + qx, q + qy);
        if q <= 0.0 || qr <= 0.0 || qb <= 0.0 {
            return self.derivatives(index, value);
        }
        let v = a / q;
        [(a + ax) / qr - v, (a + ay) / qb - v]
    }
}

/// A batch's varyings as the lane code reads them: value `c` of fragment
/// (lane) `i` at `data[i * lane + c * comp]` — stored by fragment (`per`
/// values each: `lane = per`, `comp = 1`) or by component (a row of lanes
/// per value: `lane = 1`, `comp` the row's length), so that a row loads
/// as a vector.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Vary<'v> {
    data: &'v [f32],
    lane: usize,
    comp: usize,
    /// Values per fragment.
    pub(crate) per: usize,
}

impl<'v> Vary<'v> {
    /// `per` values of each fragment after each other.
    pub(crate) fn by_fragment(data: &'v [f32], per: usize) -> Vary<'v> {
        Vary { data, lane: per, comp: 1, per }
    }

    /// `per` rows of `row` lanes: value `c` of lane `i` at `c * row + i`.
    pub(crate) fn by_component(data: &'v [f32], per: usize, row: usize) -> Vary<'v> {
        Vary { data, lane: 1, comp: row, per }
    }

    /// Value `c` of lane `i`.
    #[inline(always)]
    pub(crate) fn get(&self, i: usize, c: usize) -> f32 {
        self.data[i * self.lane + c * self.comp]
    }

    /// Value `c` of lanes `0..n` as one slice, where they are stored so.
    #[inline(always)]
    pub(crate) fn row(&self, c: usize, n: usize) -> Option<&'v [f32]> {
        (self.lane == 1).then(|| &self.data[c * self.comp..][..n])
    }

    /// The values of lane `i` into `out` (`per` of them): a fragment's own
    /// slice for the one-lane code.
    #[inline(always)]
    pub(crate) fn lane_into(&self, i: usize, out: &mut [f32]) {
        for (c, o) in out.iter_mut().enumerate().take(self.per) {
            *o = self.get(i, c);
        }
    }
}

/// λ of a 2-D lookup for each of `fragments` (lanes `0..fragments.len()`
/// of `lod`; of one triangle or of several, each lane with its own
/// triangle's gradients) whose coordinates (u, v) are the first two
/// components of varying `k` (`varyings`: stored by fragment or by component), on a texture
/// whose level 0 is `width`×`height`: [`Fragment::quad_derivatives`] of u
/// and v and [`crate::textures::unit::quad_lod`] as fixed-length loops over
/// the lanes (vector code), the same formulas in the same order, so the
/// same values bit for bit. Returns the lanes it leaves to the one-lane
/// code: those whose 1/w degenerates (`quad_derivatives`' fallback), or
/// whose varying has no gradients.
// Indexed loops over several lane arrays at once are the form that vectorises.
#[allow(clippy::needless_range_loop)]
#[inline(always)]
pub(crate) fn quad_lod_lanes<const N: usize>(
    fragments: &[Fragment],
    varyings: Vary,
    k: usize,
    (width, height): (u32, u32),
    lod: &mut [f32; N],
) -> [bool; N] {
    let n = fragments.len().min(N);
    let mut one_lane = [false; N];
    let (mut ox, mut oy, mut inv_w, mut u, mut v) = ([0.0f32; N], [0.0; N], [1.0; N], [0.0; N], [0.0; N]);
    // Each lane's gradients of 1/w, u and v: x and y.
    let (mut gq, mut gu, mut gv) = ([[0.0f32; N]; 2], [[0.0f32; N]; 2], [[0.0f32; N]; 2]);
    // A batch of one triangle's fragments (most, where triangles cover
    // more than a batch's pixels in a tile): its gradients once, as splats.
    let first = fragments.first().map(|f| f.gradients);
    if let Some(g) = first.filter(|&g| fragments[..n].iter().all(|f| std::ptr::eq(f.gradients, g))) {
        let m = (g.len() / 2).saturating_sub(1);
        if 4 * k + 1 >= m {
            one_lane[..n].fill(true);
        } else {
            for (lane, f) in fragments[..n].iter().enumerate() {
                (ox[lane], oy[lane]) = (-((f.x & 1) as f32), -((f.y & 1) as f32));
                inv_w[lane] = f.inv_w;
            }
            // The coordinates' rows copied where the varyings are stored by component.
            for (lanes, c) in [(&mut u, 4 * k), (&mut v, 4 * k + 1)] {
                match varyings.row(c, n) {
                    Some(row) => lanes[..n].copy_from_slice(row),
                    None => (0..n).for_each(|lane| lanes[lane] = varyings.get(lane, c)),
                }
            }
            let [[gqx, gqy], [gux, guy], [gvx, gvy]] = [&mut gq, &mut gu, &mut gv];
            let splats = [
                (gqx, 2 * m),
                (gqy, 2 * m + 1),
                (gux, 8 * k),
                (guy, 8 * k + 1),
                (gvx, 8 * k + 2),
                (gvy, 8 * k + 3),
            ];
            for (lanes, at) in splats {
                lanes[..n].fill(g[at]);
            }
        }
    } else {
        for (lane, f) in fragments[..n].iter().enumerate() {
            let g = f.gradients;
            let m = (g.len() / 2).saturating_sub(1);
            if 4 * k + 1 >= m {
                one_lane[lane] = true;
                continue;
            }
            // Offsets of the quad's top-left pixel from this one.
            (ox[lane], oy[lane]) = (-((f.x & 1) as f32), -((f.y & 1) as f32));
            inv_w[lane] = f.inv_w;
            (u[lane], v[lane]) = (varyings.get(lane, 4 * k), varyings.get(lane, 4 * k + 1));
            (gq[0][lane], gq[1][lane]) = (g[2 * m], g[2 * m + 1]);
            (gu[0][lane], gu[1][lane], gv[0][lane], gv[1][lane]) =
                (g[8 * k], g[8 * k + 1], g[8 * k + 2], g[8 * k + 3]);
        }
    }
    let (mut q, mut qr, mut qb) = ([0.0f32; N], [0.0f32; N], [0.0f32; N]);
    for l in 0..N {
        q[l] = inv_w[l] + gq[0][l] * ox[l] + gq[1][l] * oy[l];
        (qr[l], qb[l]) = (q[l] + gq[0][l], q[l] + gq[1][l]);
    }
    let quad = QuadLanes { ox, oy, inv_w, q, qr, qb };
    let ([ux, uy], [vx, vy]) = (quad.derivatives(&gu, &u), quad.derivatives(&gv, &v));
    let (w, h) = (width as f32, height as f32);
    for l in 0..N {
        let (ux, vx, uy, vy) = (ux[l] * w, vx[l] * h, uy[l] * w, vy[l] * h);
        let rho2 = (ux * ux + vx * vx).max(uy * uy + vy * vy);
        lod[l] = if !rho2.is_finite() || rho2 <= 0.0 {
            f32::NEG_INFINITY
        } else {
            0.5 * crate::textures::unit::piecewise_log2(rho2)
        };
    }
    for l in 0..n {
        one_lane[l] |= quad.inv_w[l] == 0.0 || quad.q[l] <= 0.0 || quad.qr[l] <= 0.0 || quad.qb[l] <= 0.0;
    }
    one_lane
}

/// The lanes of [`quad_lod_lanes`]: each lane's offsets to its quad's
/// top-left pixel, its 1/w, and 1/w at that pixel and its right and lower
/// neighbours.
struct QuadLanes<const N: usize> {
    ox: [f32; N],
    oy: [f32; N],
    inv_w: [f32; N],
    q: [f32; N],
    qr: [f32; N],
    qb: [f32; N],
}

impl<const N: usize> QuadLanes<N> {
    /// [`Fragment::quad_derivatives`] of a varying whose gradients are
    /// `g` (x and y) and values `value`, per lane.
    #[inline(always)]
    fn derivatives(&self, g: &[[f32; N]; 2], value: &[f32; N]) -> [[f32; N]; 2] {
        let mut d = [[0.0f32; N]; 2];
        for l in 0..N {
            let (ax, ay) = (g[0][l], g[1][l]);
            let a = value[l] * self.inv_w[l] + ax * self.ox[l] + ay * self.oy[l];
            let at = a / self.q[l];
            (d[0][l], d[1][l]) = ((a + ax) / self.qr[l] - at, (a + ay) / self.qb[l] - at);
        }
        d
    }
}

impl Fragment<'_> {
    /// The varyings at the pixel (ox, oy) away from this one, into `out`,
    /// interpolated perspective-correctly from this triangle's planes (as
    /// [`Fragment::quad_derivatives`] does: outside the triangle they are
    /// extrapolated, a GPU's helper pixel); returns that pixel's 1/w, or
    /// `None` where 1/w degenerates. Dependent lookups take their level of
    /// detail from the coordinates computed at the quad's pixels.
    pub fn varyings_at(&self, varyings: &[f32], ox: f32, oy: f32, out: &mut [f32]) -> Option<f32> {
        if self.gradients.len() < 2 || self.inv_w == 0.0 {
            return None;
        }
        let n = self.gradients.len() / 2 - 1;
        let (qx, qy) = (self.gradients[2 * n], self.gradients[2 * n + 1]);
        let q = self.inv_w + qx * ox + qy * oy;
        if q.is_nan() || q <= 0.0 {
            return None;
        }
        for (i, (o, v)) in out.iter_mut().zip(varyings).take(n).enumerate() {
            *o = (v * self.inv_w + self.gradients[2 * i] * ox + self.gradients[2 * i + 1] * oy) / q;
        }
        Some(q)
    }
}

/// A snapped, oriented screen-space triangle ready for scan conversion.
#[derive(Clone, Debug)]
pub(crate) struct Tri {
    /// Edge k is opposite vertex k: E_k(p) = dx_k·(p.y − ya_k) − dy_k·(p.x − xa_k).
    pub(crate) dx: [i64; 3],
    pub(crate) dy: [i64; 3],
    pub(crate) xa: [i64; 3],
    pub(crate) ya: [i64; 3],
    /// 0 for top or left edges, 1 otherwise (pixels exactly on the edge are out).
    pub(crate) bias: [i64; 3],
    /// The barycentric weight of vertex k as a plane over the window,
    /// `a·x + b·y + c` at the pixel centre (x + ½, y + ½), from the
    /// *unsnapped* vertex positions: coverage follows the snapped edges (the
    /// fill rule), attributes and depth the float planes, as GPUs do
    /// (Vulkan 1.3 §25.8.1 leaves the precision to the implementation;
    /// llvmpipe sets its planes up in float), so the texture coordinates the
    /// CPU computes are the ones lavapipe computes (`tests/wgsl_agreement.rs`).
    pub(crate) weights: [[f32; 3]; 3],
    /// Window depth per vertex.
    pub(crate) z: [f32; 3],
    /// 1/w per vertex.
    pub(crate) inv_w: [f32; 3],
    /// Inclusive pixel bounds, clamped to the target.
    pub(crate) x0: i32,
    pub(crate) y0: i32,
    pub(crate) x1: i32,
    pub(crate) y1: i32,
    pub(crate) front_facing: bool,
    /// Start of this triangle's 3·N varyings in `PassSetup::varyings`.
    pub(crate) varying_offset: usize,
    /// Start of its 2·(N+1) gradients in `PassSetup::gradients`.
    pub(crate) gradient_offset: usize,
}

impl Tri {
    /// The three edge functions at the subpixel point (px, py).
    #[inline(always)]
    pub(crate) fn edges_at(&self, px: i64, py: i64) -> [i64; 3] {
        std::array::from_fn(|k| self.dx[k] * (py - self.ya[k]) - self.dy[k] * (px - self.xa[k]))
    }

    /// The barycentric weights of the three vertices at pixel (x, y).
    #[inline(always)]
    pub(crate) fn weights_at(&self, x: i32, y: i32) -> [f32; 3] {
        let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
        self.weights.map(|[a, b, c]| a * px + b * py + c)
    }

    /// The top-left fill rule: inside when every biased edge function is ≥ 0.
    /// The one definition both the tiled and the adaptive rasterizer use.
    #[inline(always)]
    pub(crate) fn covers(&self, e: &[i64; 3]) -> bool {
        ((e[0] - self.bias[0]) | (e[1] - self.bias[1]) | (e[2] - self.bias[2])) >= 0
    }
}

#[derive(Default)]
pub(crate) struct PassSetup {
    pub(crate) tris: Vec<Tri>,
    pub(crate) varyings: Vec<f32>,
    pub(crate) gradients: Vec<f32>,
    pub(crate) n_varyings: usize,
    pub(crate) culled: usize,
    pub(crate) degenerate: usize,
}

impl PassSetup {
    pub(crate) fn n_triangles(&self) -> usize {
        self.tris.len()
    }

    /// Triangle `tri`'s varyings (three vertices of `n_varyings`) and its
    /// gradients (d/dx, d/dy of every varying over w, then of 1/w).
    pub(crate) fn inputs(&self, tri: &Tri) -> (&[f32], &[f32]) {
        let n = self.n_varyings;
        (
            &self.varyings[tri.varying_offset..tri.varying_offset + 3 * n],
            &self.gradients[tri.gradient_offset..tri.gradient_offset + 2 * (n + 1)],
        )
    }
}

/// Runs the vertex stage and sets up every triangle of the pass.
pub(crate) fn setup_pass(pass: &Pass, width: u32, height: u32) -> Result<PassSetup, RenderError> {
    let n_vertices = pass.vertex.n_vertices();
    for (triangle, tri) in pass.triangles.iter().enumerate() {
        for &index in tri {
            if index as usize >= n_vertices {
                return Err(RenderError::IndexOutOfRange { triangle, index, n_vertices });
            }
        }
    }
    let n = pass.vertex.n_varyings();
    let mut clip = vec![[0.0f32; 4]; n_vertices];
    let mut vary = vec![0.0f32; n_vertices * n];
    if n == 0 {
        clip.par_iter_mut().enumerate().for_each(|(i, c)| *c = pass.vertex.shade_vertex(i as u32, &mut []));
    } else {
        clip.par_iter_mut().zip(vary.par_chunks_mut(n)).enumerate().for_each(|(i, (c, v))| {
            *c = pass.vertex.shade_vertex(i as u32, v);
        });
    }

    let ctx = SetupCtx {
        clip: &clip,
        vary: &vary,
        n,
        width: width as f64,
        height: height as f64,
        guard: guard_band(width, height),
        cull: pass.state.cull,
    };
    let parts: Vec<PassSetup> = pass.triangles.par_chunks(1024).map(|chunk| ctx.setup_chunk(chunk)).collect();
    let mut out = PassSetup { n_varyings: n, ..PassSetup::default() };
    for part in parts {
        let (vo, go) = (out.varyings.len(), out.gradients.len());
        out.tris.extend(part.tris.into_iter().map(|mut t| {
            t.varying_offset += vo;
            t.gradient_offset += go;
            t
        }));
        out.varyings.extend_from_slice(&part.varyings);
        out.gradients.extend_from_slice(&part.gradients);
        out.culled += part.culled;
        out.degenerate += part.degenerate;
    }
    Ok(out)
}

/// The guard-band factor g: |x/w| ≤ g keeps window coordinates within ±30000 pixels.
fn guard_band(width: u32, height: u32) -> f64 {
    let size = width.max(height) as f64;
    (2.0 * 30000.0 / size - 1.0).clamp(1.0, 64.0)
}

struct SetupCtx<'a> {
    clip: &'a [[f32; 4]],
    vary: &'a [f32],
    n: usize,
    width: f64,
    height: f64,
    guard: f64,
    cull: CullMode,
}

/// Window coordinates are clamped to ±this many pixels (edge functions then fit in i64).
const MAX_WINDOW: f64 = 32768.0;

/// Smallest w kept by clipping, so 1/w stays finite.
const W_EPSILON: f64 = 1e-6;

impl SetupCtx<'_> {
    fn setup_chunk(&self, chunk: &[[u32; 3]]) -> PassSetup {
        let mut out = PassSetup { n_varyings: self.n, ..PassSetup::default() };
        // Polygon scratch: each vertex is [x, y, z, w, varyings...] in f64.
        let stride = 4 + self.n;
        let mut poly: Vec<f64> = Vec::with_capacity(12 * stride);
        let mut next: Vec<f64> = Vec::with_capacity(12 * stride);
        for tri in chunk {
            let positions = tri.map(|i| self.clip[i as usize]);
            if positions.iter().flatten().any(|c| !c.is_finite()) {
                out.degenerate += 1;
                continue;
            }
            poly.clear();
            for &i in tri {
                poly.extend(self.clip[i as usize].iter().map(|&c| c as f64));
                poly.extend(
                    self.vary[i as usize * self.n..(i as usize + 1) * self.n].iter().map(|&c| c as f64),
                );
            }
            let g = self.guard;
            let planes: [fn(&[f64], f64) -> f64; 7] = [
                |v, _| v[3] - W_EPSILON,
                |v, _| v[2] + v[3],
                |v, _| v[3] - v[2],
                |v, g| g * v[3] - v[0],
                |v, g| g * v[3] + v[0],
                |v, g| g * v[3] - v[1],
                |v, g| g * v[3] + v[1],
            ];
            let mut outside = false;
            for plane in planes {
                let count = poly.len() / stride;
                let all_in = (0..count).all(|k| plane(&poly[k * stride..(k + 1) * stride], g) >= 0.0);
                if all_in {
                    continue;
                }
                next.clear();
                for k in 0..count {
                    let a = &poly[k * stride..(k + 1) * stride];
                    let b = &poly[((k + 1) % count) * stride..((k + 1) % count + 1) * stride];
                    let (da, db) = (plane(a, g), plane(b, g));
                    if da >= 0.0 {
                        next.extend_from_slice(a);
                    }
                    if (da >= 0.0) != (db >= 0.0) {
                        // From the inside vertex towards the outside one.
                        let (inside, outside_v, di, d_o) =
                            if da >= 0.0 { (a, b, da, db) } else { (b, a, db, da) };
                        let t = di / (di - d_o);
                        for c in 0..stride {
                            next.push(inside[c] + t * (outside_v[c] - inside[c]));
                        }
                    }
                }
                std::mem::swap(&mut poly, &mut next);
                if poly.len() / stride < 3 {
                    outside = true;
                    break;
                }
            }
            if outside {
                continue;
            }
            let count = poly.len() / stride;
            for k in 1..count - 1 {
                self.emit(
                    &mut out,
                    &poly[0..stride],
                    &poly[k * stride..(k + 1) * stride],
                    &poly[(k + 1) * stride..(k + 2) * stride],
                );
            }
        }
        out
    }

    /// Projects, snaps, culls and sets up one clipped triangle.
    fn emit(&self, out: &mut PassSetup, a: &[f64], b: &[f64], c: &[f64]) {
        let verts = [a, b, c];
        let Some(Snapped { fx, fy, z, inv_w, wx, wy }) = self.snap(&verts) else {
            out.degenerate += 1;
            return;
        };
        let area = (fx[1] - fx[0]) * (fy[2] - fy[0]) - (fy[1] - fy[0]) * (fx[2] - fx[0]);
        if area == 0 {
            out.degenerate += 1;
            return;
        }
        // y points down in window space, so counter-clockwise in NDC is negative here.
        let front_facing = area < 0;
        let culled = match self.cull {
            CullMode::None => false,
            CullMode::Back => !front_facing,
            CullMode::Front => front_facing,
        };
        if culled {
            out.culled += 1;
            return;
        }
        let mut order = [0usize, 1, 2];
        if area < 0 {
            order = [0, 2, 1];
        }
        let area = area.abs();
        let px = order.map(|k| fx[k]);
        let py = order.map(|k| fy[k]);

        let min_x = px.iter().min().copied().unwrap_or(0);
        let max_x = px.iter().max().copied().unwrap_or(0);
        let min_y = py.iter().min().copied().unwrap_or(0);
        let max_y = py.iter().max().copied().unwrap_or(0);
        let x0 = ((min_x - HALF + SUB - 1).div_euclid(SUB)).max(0);
        let y0 = ((min_y - HALF + SUB - 1).div_euclid(SUB)).max(0);
        let x1 = ((max_x - HALF).div_euclid(SUB)).min(self.width as i64 - 1);
        let y1 = ((max_y - HALF).div_euclid(SUB)).min(self.height as i64 - 1);
        if x0 > x1 || y0 > y1 {
            return;
        }

        let mut tri = Tri {
            dx: [0; 3],
            dy: [0; 3],
            xa: [0; 3],
            ya: [0; 3],
            bias: [0; 3],
            weights: weight_planes(order.map(|k| wx[k]), order.map(|k| wy[k])).unwrap_or_else(|| {
                // Degenerate in float but not once snapped: the snapped planes.
                let (sx, sy) = (px.map(|v| v as f64 / SUB as f64), py.map(|v| v as f64 / SUB as f64));
                weight_planes(sx, sy).unwrap_or([[0.0; 3]; 3])
            }),
            z: order.map(|k| z[k]),
            inv_w: order.map(|k| inv_w[k]),
            x0: x0 as i32,
            y0: y0 as i32,
            x1: x1 as i32,
            y1: y1 as i32,
            front_facing,
            varying_offset: out.varyings.len(),
            gradient_offset: out.gradients.len(),
        };
        tri.set_edges(px, py);
        for &k in &order {
            out.varyings.extend(verts[k][4..].iter().map(|&v| v as f32));
        }
        self.push_gradients(out, &verts, order, (px, py), area);
        out.tris.push(tri);
    }

    /// The window positions of a triangle's vertices, in float and snapped
    /// to the subpixel grid, with their depths and 1/w; `None` for a
    /// degenerate one. Clipping keeps w ≥ ε and |x|, |y| ≤ g·w, but with
    /// extreme inputs (|coordinates| ~ 1e30) the intersection arithmetic
    /// cancels; positions are clamped to the fixed-point range so nothing
    /// overflows.
    fn snap(&self, verts: &[&[f64]; 3]) -> Option<Snapped> {
        let mut s =
            Snapped { fx: [0; 3], fy: [0; 3], z: [0.0; 3], inv_w: [0.0; 3], wx: [0.0; 3], wy: [0.0; 3] };
        for (k, v) in verts.iter().enumerate() {
            if v[3].is_nan() || v[3] <= 0.0 {
                return None;
            }
            let iw = 1.0 / v[3].max(W_EPSILON);
            let sx = ((v[0] * iw * 0.5 + 0.5) * self.width).clamp(-MAX_WINDOW, MAX_WINDOW);
            let sy = ((0.5 - v[1] * iw * 0.5) * self.height).clamp(-MAX_WINDOW, MAX_WINDOW);
            if !(sx.is_finite() && sy.is_finite()) {
                return None;
            }
            s.fx[k] = (sx * SUB as f64).round() as i64;
            s.fy[k] = (sy * SUB as f64).round() as i64;
            s.wx[k] = sx;
            s.wy[k] = sy;
            let depth = v[2] * iw * 0.5 + 0.5;
            s.z[k] = if depth.is_nan() { 0.5 } else { depth.clamp(0.0, 1.0) as f32 };
            s.inv_w[k] = iw as f32;
        }
        Some(s)
    }

    /// Pushes the screen-space gradients (per pixel) of v/w for each varying
    /// and of 1/w, over the snapped positions `(px, py)` of `verts` in `order`.
    fn push_gradients(
        &self,
        out: &mut PassSetup,
        verts: &[&[f64]; 3],
        order: [usize; 3],
        (px, py): ([i64; 3], [i64; 3]),
        area: i64,
    ) {
        let sx = px.map(|v| v as f64 / SUB as f64);
        let sy = py.map(|v| v as f64 / SUB as f64);
        let area_px = area as f64 / (SUB * SUB) as f64;
        let iw = order.map(|k| 1.0 / verts[k][3].max(W_EPSILON));
        let mut plane = |q: [f64; 3]| {
            let ddx = ((q[1] - q[0]) * (sy[2] - sy[0]) - (q[2] - q[0]) * (sy[1] - sy[0])) / area_px;
            let ddy = ((q[2] - q[0]) * (sx[1] - sx[0]) - (q[1] - q[0]) * (sx[2] - sx[0])) / area_px;
            out.gradients.push(ddx as f32);
            out.gradients.push(ddy as f32);
        };
        for i in 0..self.n {
            plane([0, 1, 2].map(|j| verts[order[j]][4 + i] * iw[j]));
        }
        plane(iw);
    }
}

/// A triangle's vertices in window space ([`SetupCtx::snap`]).
struct Snapped {
    /// Snapped to 1/SUB pixel.
    fx: [i64; 3],
    fy: [i64; 3],
    z: [f32; 3],
    inv_w: [f32; 3],
    /// Unsnapped, in pixels.
    wx: [f64; 3],
    wy: [f64; 3],
}

impl Tri {
    /// The edge functions from the snapped, ordered positions: edge k is
    /// opposite vertex k, with the top-left fill rule's bias.
    pub(crate) fn set_edges(&mut self, px: [i64; 3], py: [i64; 3]) {
        for k in 0..3 {
            let (ia, ib) = ((k + 1) % 3, (k + 2) % 3);
            let (dx, dy) = (px[ib] - px[ia], py[ib] - py[ia]);
            self.dx[k] = dx;
            self.dy[k] = dy;
            self.xa[k] = px[ia];
            self.ya[k] = py[ia];
            let top_left = (dy == 0 && dx > 0) || dy < 0;
            self.bias[k] = if top_left { 0 } else { 1 };
        }
    }
}

/// The planes `a·x + b·y + c` of the barycentric weights of a triangle with
/// window positions (x_k, y_k): 1 at vertex k, 0 at the other two. `None`
/// when the triangle has no area.
fn weight_planes(x: [f64; 3], y: [f64; 3]) -> Option<[[f32; 3]; 3]> {
    let twice_area = x[0] * (y[1] - y[2]) + x[1] * (y[2] - y[0]) + x[2] * (y[0] - y[1]);
    if twice_area == 0.0 || !twice_area.is_finite() {
        return None;
    }
    Some(std::array::from_fn(|k| {
        let (i, j) = ((k + 1) % 3, (k + 2) % 3);
        [
            ((y[i] - y[j]) / twice_area) as f32,
            ((x[j] - x[i]) / twice_area) as f32,
            ((x[i] * y[j] - x[j] * y[i]) / twice_area) as f32,
        ]
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weight_planes_are_one_at_their_vertex_and_zero_at_the_others() {
        let (x, y) = ([10.25, 200.5, 37.75], [5.5, 40.125, 180.0]);
        let w = weight_planes(x, y).unwrap();
        for (k, wk) in w.iter().enumerate() {
            for v in 0..3 {
                let value = wk[0] as f64 * x[v] + wk[1] as f64 * y[v] + wk[2] as f64;
                assert!(
                    (value - if k == v { 1.0 } else { 0.0 }).abs() < 1e-4,
                    "weight {k} at vertex {v}: {value}"
                );
            }
        }
        assert!(weight_planes([0.0, 1.0, 2.0], [0.0, 1.0, 2.0]).is_none());
    }

    #[test]
    fn guard_band_keeps_coordinates_in_fixed_point_range() {
        for size in [1u32, 64, 1024, 4096, 16384] {
            let g = guard_band(size, size);
            let extent = (0.5 + g / 2.0) * size as f64;
            assert!(extent <= 32768.0, "size {size}: extent {extent}");
            assert!(g >= 1.0);
        }
    }

    /// [`quad_lod_lanes`] is `quad_derivatives` and `quad_lod` lane by
    /// lane, bit for bit: pixels at every quad position, 1/w near zero,
    /// zero and negative (the one-lane fallback), partial batches, a
    /// varying without gradients, fragments of two triangles.
    #[test]
    fn quad_lod_lanes_are_the_one_lane_code_bit_for_bit() {
        use crate::textures::unit;
        let mut x = 0x9e37_79b9u32;
        let mut r = move || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            (x >> 8) as f32 / (1u32 << 23) as f32 - 1.0
        };
        let per = 12;
        let (mut compared, mut mixed_compared) = (0, 0);
        for round in 0..200 {
            // Three varyings of four components, then 1/w's gradients.
            let g: Vec<f32> = (0..2 * 12 + 2).map(|i| r() * if i >= 24 { 0.02 } else { 0.5 }).collect();
            let other: Vec<f32> = g.iter().map(|v| v * 1.5).collect();
            let n = 32 - round % 7;
            let k = round % 2;
            let fragments: Vec<Fragment> = (0..n)
                .map(|i| Fragment {
                    x: (i * 7 + round) as u32,
                    y: (i / 3 + round) as u32,
                    depth: 0.5,
                    front_facing: true,
                    inv_w: match i % 11 {
                        0 => 0.0,
                        1 => -0.01,
                        2 => 1e-30,
                        _ => r().abs() * 0.5,
                    },
                    gradients: if round % 10 == 9 && i == 5 { &other } else { &g },
                })
                .collect();
            let varyings: Vec<f32> = (0..n * per).map(|_| r() * 4.0).collect();
            let (w, h) = if round % 3 == 0 { (256, 64) } else { (16, 16) };
            let mut lod = [0.0f32; 32];
            let left = quad_lod_lanes(&fragments, Vary::by_fragment(&varyings, per), k, (w, h), &mut lod);
            // The same varyings stored by component (the scan loop's rows): the same lanes.
            let rows: Vec<f32> = (0..per * n).map(|i| varyings[(i % n) * per + i / n]).collect();
            let mut by_rows = [0.0f32; 32];
            let left_rows =
                quad_lod_lanes(&fragments, Vary::by_component(&rows, per, n), k, (w, h), &mut by_rows);
            assert_eq!(left_rows, left, "round {round}");
            let bits = |l: &[f32]| l.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert!(bits(&by_rows[..n]) == bits(&lod[..n]), "round {round}");
            for (lane, f) in fragments.iter().enumerate() {
                let vary = &varyings[lane * per + 4 * k..];
                let (du, dv) = (f.quad_derivatives(4 * k, vary[0]), f.quad_derivatives(4 * k + 1, vary[1]));
                let one = unit::quad_lod(w, h, [du[0], dv[0]], [du[1], dv[1]]);
                // The one-lane lanes: 1/w = 0 or a quad whose 1/w reaches 0 (small
                // or negative 1/w here); a batch of two triangles is lanes too.
                assert!(left[lane] || f.inv_w != 0.0, "round {round} lane {lane}");
                assert!(!left[lane] || f.inv_w < 0.1, "round {round} lane {lane}");
                if left[lane] {
                    continue;
                }
                compared += 1;
                mixed_compared += (round % 10 == 9) as u32;
                assert_eq!(
                    one.to_bits(),
                    lod[lane].to_bits(),
                    "round {round} lane {lane}: {one} {}",
                    lod[lane]
                );
            }
        }
        assert!(compared > 3000, "{compared} lanes as lanes");
        assert!(mixed_compared > 40, "{mixed_compared} lanes of two-triangle batches as lanes");
        // A varying past the gradients (k = 2: components 8, 9 of 4 components' gradients).
        let g = [0.1f32; 2 * 4 + 2];
        let fragments: Vec<Fragment> = (0..9)
            .map(|i| Fragment { x: i, y: 1, depth: 0.0, front_facing: true, inv_w: 0.5, gradients: &g })
            .collect();
        let varyings = vec![1.0f32; 9 * per];
        let mut lod = [7.0f32; 32];
        let left = quad_lod_lanes(&fragments, Vary::by_fragment(&varyings, per), 2, (8, 8), &mut lod);
        assert_eq!(left.iter().filter(|&&l| l).count(), 9);
    }
}
