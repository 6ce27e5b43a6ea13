//! Binning and per-tile scan conversion. Triangles are binned, in submission
//! order, into the `TILE`×`TILE` tiles their bounding box touches; tiles are
//! then processed in parallel, each owning its colour, depth and stencil, so
//! blending order within a pixel is the submission order.

use rayon::prelude::*;

use super::framebuffer::{ColorTile, TileBuffers, Writer, TILE};
use super::raster::{Fragment, PassSetup, Tri, SUB};
use super::{CompareFunc, DrawStats, FragmentResult, Framebuffer, Pass, StencilOp, BATCH};

pub(crate) fn rasterize(target: &mut Framebuffer, pass: &Pass, setup: &PassSetup) -> DrawStats {
    let tiles_x = target.tiles_x();
    let tiles_y = target.tiles_y();
    let mut bins: Vec<Vec<u32>> = vec![Vec::new(); tiles_x * tiles_y];
    for (i, tri) in setup.tris.iter().enumerate() {
        let (tx0, tx1) = (tri.x0 as usize / TILE, tri.x1 as usize / TILE);
        let (ty0, ty1) = (tri.y0 as usize / TILE, tri.y1 as usize / TILE);
        for ty in ty0..=ty1.min(tiles_y - 1) {
            for tx in tx0..=tx1.min(tiles_x - 1) {
                bins[ty * tiles_x + tx].push(i as u32);
            }
        }
    }
    let (width, height) = (target.width() as i32, target.height() as i32);
    // A clear deferred by `Framebuffer::reset_deferred` is made by each
    // tile's worker just before it scans the tile (`fresh`), in cache.
    let (tiles, fresh) = target.tiles.writing_fused(|t| !bins[t].is_empty());
    tiles
        .par_iter_mut()
        .zip(bins.par_iter())
        .enumerate()
        .filter(|(_, (_, bin))| !bin.is_empty())
        .map(|(t, (tile, bin))| {
            if fresh[t] {
                tile.clear();
            }
            let ox = ((t % tiles_x) * TILE) as i32;
            let oy = ((t / tiles_x) * TILE) as i32;
            let rect = (ox, oy, (ox + TILE as i32).min(width) - 1, (oy + TILE as i32).min(height) - 1);
            raster_tile(tile, rect, bin, pass, setup)
        })
        .reduce(DrawStats::default, |a, b| DrawStats {
            fragments: a.fragments + b.fragments,
            shaded: a.shaded + b.shaded,
            written: a.written + b.written,
            ..DrawStats::default()
        })
}

/// Scan-converts the binned triangles over one tile; `rect` is inclusive.
/// Without a stencil test a fragment's fate is decided before it is shaded
/// (depth test first, then shading, then the writes), so fragments are
/// shaded in batches ([`FragmentStage::shade_batch`]: each writes its own
/// pixel, so the order within a batch does not matter); with one,
/// fragment by fragment.
fn raster_tile(
    tile: &mut TileBuffers,
    rect: (i32, i32, i32, i32),
    bin: &[u32],
    pass: &Pass,
    setup: &PassSetup,
) -> DrawStats {
    if pass.fragment.replaces_depth() {
        raster_tile_replaced_depth(tile, rect, bin, pass, setup)
    } else if pass.state.stencil.enabled {
        raster_tile_stencil(tile, rect, bin, pass, setup)
    } else {
        raster_tile_batched(tile, rect, bin, pass, setup)
    }
}

/// [`raster_tile`] for a stage that replaces the fragment's depth: each
/// fragment is shaded first, then depth-tested with the depth its stage
/// gave it (NV_texture_shader's `DOT_PRODUCT_DEPTH_REPLACE_NV` runs before
/// the depth test). The stencil test is not applied: no plan combines it
/// with a replaced depth.
fn raster_tile_replaced_depth(
    tile: &mut TileBuffers,
    rect: (i32, i32, i32, i32),
    bin: &[u32],
    pass: &Pass,
    setup: &PassSetup,
) -> DrawStats {
    let n = setup.n_varyings;
    let mut varyings = vec![0.0f32; n];
    let mut stats = DrawStats::default();
    let depth = &pass.state.depth;
    for &ti in bin {
        let tri: &Tri = &setup.tris[ti as usize];
        let (vary, gradients) = setup.inputs(tri);
        for_each_covered(tri, rect, |x, y, idx| {
            let (fragment, _, p) = fragment_at(tri, x, y, gradients);
            stats.fragments += 1;
            interpolate(vary, n, p, &mut varyings);
            stats.shaded += 1;
            let mut color = [0.0f32; 4];
            let (result, z) = pass.fragment.shade_with_depth(&fragment, &varyings, &mut color);
            if result == FragmentResult::Discard || !depth.func.test(z, tile.depth[idx]) {
                return;
            }
            if depth.write {
                tile.depth[idx] = z;
            }
            tile.blend_color(idx, &color, &pass.state.blend);
            stats.written += 1;
        });
    }
    stats
}

/// Calls `visit(x, y, idx)` for every pixel of `tri` inside `rect` that
/// the triangle covers, in scan order (`idx`: the pixel in the tile).
fn for_each_covered(tri: &Tri, rect: (i32, i32, i32, i32), mut visit: impl FnMut(i32, i32, usize)) {
    let x0 = tri.x0.max(rect.0);
    let y0 = tri.y0.max(rect.1);
    let x1 = tri.x1.min(rect.2);
    let y1 = tri.y1.min(rect.3);
    if x0 > x1 || y0 > y1 {
        return;
    }
    // Edge-function steps per pixel in x and y.
    let step_x = tri.dy.map(|d| -d * SUB);
    let px0 = x0 as i64 * SUB + SUB / 2;
    for y in y0..=y1 {
        let py = y as i64 * SUB + SUB / 2;
        let mut e = tri.edges_at(px0, py);
        let row = (y - rect.1) as usize * TILE;
        let lx0 = (x0 - rect.0) as usize;
        for x in x0..=x1 {
            if tri.covers(&e) {
                visit(x, y, row + lx0 + (x - x0) as usize);
            }
            for k in 0..3 {
                e[k] += step_x[k];
            }
        }
    }
}

/// The fragment of `tri` at pixel (x, y), its depth and its
/// perspective-correct weights (`gradients`: the triangle's).
pub(crate) fn fragment_at<'a>(
    tri: &Tri,
    x: i32,
    y: i32,
    gradients: &'a [f32],
) -> (Fragment<'a>, f32, [f32; 3]) {
    let l = tri.weights_at(x, y);
    let z = (l[0] * tri.z[0] + l[1] * tri.z[1] + l[2] * tri.z[2]).clamp(0.0, 1.0);
    let pw = [l[0] * tri.inv_w[0], l[1] * tri.inv_w[1], l[2] * tri.inv_w[2]];
    let q = pw[0] + pw[1] + pw[2];
    let inv_q = 1.0 / q;
    let fragment =
        Fragment { x: x as u32, y: y as u32, depth: z, front_facing: tri.front_facing, inv_w: q, gradients };
    (fragment, z, [pw[0] * inv_q, pw[1] * inv_q, pw[2] * inv_q])
}

/// Interpolates the triangle's varyings `vary` (three vertices of `n`)
/// with the weights `p` into `out`.
#[inline(always)]
pub(crate) fn interpolate(vary: &[f32], n: usize, p: [f32; 3], out: &mut [f32]) {
    let (a, b, c) = (&vary[..n], &vary[n..2 * n], &vary[2 * n..3 * n]);
    for (((v, a), b), c) in out.iter_mut().zip(a).zip(b).zip(c) {
        *v = p[0] * a + p[1] * b + p[2] * c;
    }
}

/// The fragments waiting to be shaded together, of one triangle or of
/// several: at most one per pixel (`pending`: a bit per pixel of each of
/// the tile's rows), so that each writes its own pixel.
struct Batch<'a> {
    fragments: Vec<Fragment<'a>>,
    pixels: Vec<(usize, f32)>,
    /// The varyings by component: value `c` of fragment `i` at
    /// `c * ROW + i` (a span's lanes are stored eight at a time, so a row
    /// has room for a span past the batch's last fragment).
    rows: Vec<f32>,
    /// Varyings per fragment.
    per: usize,
    out: [[f32; 4]; BATCH],
    results: [FragmentResult; BATCH],
    /// `out` quantized for an 8-bit target.
    quantized: [[u8; 4]; BATCH],
    pending: [u64; TILE],
}

/// Where [`Batch::flush`] writes the kept colours without
/// [`TileBuffers::blend_kept`].
enum Fast<'t> {
    /// `C ← src` on a float target (or fixed point held in float).
    Replace(&'t mut [[f32; 4]]),
    /// `C ← C + src` on a float target.
    Add(&'t mut [[f32; 4]]),
    /// `C ← src` on an 8-bit target.
    Rgba8(&'t mut [[u8; 4]]),
    /// Any other target or blend: `blend_kept`.
    General,
}

/// [`quantize_unorm8`](super::framebuffer::quantize_unorm8) of every
/// value of a batch's colours (all [`BATCH`] lanes, those past its
/// fragments unread), written as one fixed-length loop the compiler
/// vectorises. The same values: `max` takes a NaN to 0, as `clamp` and the
/// saturating cast do, and the value is then in [0.5, 255.5], where the
/// conversion truncates as the cast does.
#[inline(always)]
#[allow(clippy::manual_clamp, reason = "`max` then `min` take a NaN to 0; `clamp` keeps it")]
fn quantize_lanes(src: &[[f32; 4]; BATCH], dst: &mut [[u8; 4]; BATCH]) {
    for (d, &v) in dst.as_flattened_mut().iter_mut().zip(src.as_flattened()) {
        let q = v.max(0.0).min(1.0) * 255.0 + 0.5;
        // SAFETY: `q` is finite and in [0.5, 255.5] (a NaN `v` is 0 after
        // `max`), so it fits an `i32`.
        *d = unsafe { q.to_int_unchecked::<i32>() } as u8;
    }
}

impl Batch<'_> {
    /// Shades the waiting fragments and writes those kept. Inlined into
    /// the scan loop (compiled with its vector features); a float target
    /// written without blending or added to (the plans' passes) takes
    /// depth and colour of each kept fragment in one loop, as
    /// [`TileBuffers::blend_kept`] writes the colour (the same values).
    #[inline(always)]
    fn flush(&mut self, tile: &mut TileBuffers, pass: &Pass, writer: Writer, stats: &mut DrawStats) {
        let k = self.fragments.len();
        if k == 0 {
            return;
        }
        pass.fragment.shade_batch_rows(
            &self.fragments,
            (&self.rows, self.per, ROW),
            &mut self.out[..k],
            &mut self.results[..k],
        );
        stats.shaded += k as u64;
        let (pixels, out, results) = (&self.pixels[..k], &self.out[..k], &self.results[..k]);
        let depth_write = pass.state.depth.write;
        let TileBuffers { color, depth, .. } = &mut *tile;
        // `C ← src` on a float or fixed-point-in-float target (values as
        // computed, `blend_kept`), `C ← C + src` on a float one, `C ← src`
        // on an 8-bit one (the batch's colours quantized first, as one
        // vector loop, the values of `quantize_unorm8`).
        let fast = match (color, writer) {
            (ColorTile::F32(c) | ColorTile::Unorm(c), Writer::Replace) => Fast::Replace(c),
            (ColorTile::F32(c), Writer::Add) => Fast::Add(c),
            (ColorTile::Rgba8(c), Writer::Replace) => Fast::Rgba8(c),
            _ => Fast::General,
        };
        let general = matches!(fast, Fast::General);
        // Each kept fragment's depth (when written) and colour (`write`,
        // given the fragment's place in the batch, its pixel and colour).
        #[inline(always)]
        #[allow(clippy::type_complexity, reason = "the batch's three arrays, lane by lane")]
        fn each_kept(
            (pixels, out, results): (&[(usize, f32)], &[[f32; 4]], &[FragmentResult]),
            depth: Option<&mut [f32]>,
            mut write: impl FnMut(usize, usize, &[f32; 4]),
        ) -> u64 {
            let mut written = 0;
            let mut depth = depth;
            for (j, ((&(idx, z), s), r)) in pixels.iter().zip(out).zip(results).enumerate() {
                if *r == FragmentResult::Keep {
                    if let Some(d) = depth.as_deref_mut() {
                        d[idx] = z;
                    }
                    write(j, idx, s);
                    written += 1;
                }
            }
            written
        }
        let depth = depth_write.then_some(&mut depth[..]);
        let batch = (pixels, out, results);
        let written = match fast {
            Fast::Replace(c) => each_kept(batch, depth, |_, i, s| c[i] = *s),
            Fast::Add(c) => each_kept(batch, depth, |_, i, s| {
                c[i] = [s[0] + c[i][0], s[1] + c[i][1], s[2] + c[i][2], s[3] + c[i][3]]
            }),
            Fast::Rgba8(c) => {
                let q = &mut self.quantized;
                quantize_lanes(&self.out, q);
                each_kept(batch, depth, |j, i, _| c[i] = q[j])
            }
            Fast::General => each_kept(batch, depth, |_, _, _| {}),
        };
        stats.written += written;
        if general {
            tile.blend_kept(pixels, out, results, &pass.state.blend, writer);
        }
        // Every row clear (a few vector stores) rather than the rows of the batch's pixels.
        self.pending = [0; TILE];
        self.fragments.clear();
        self.pixels.clear();
    }
}

/// [`raster_tile`] without a stencil test: depth-tested fragments are
/// shaded in batches of up to [`BATCH`], filled across triangles (Kilgard's
/// torus at 1024² has triangles of a few dozen pixels per tile): a span
/// that reaches a pixel already waiting in the batch flushes it first, so
/// its depth test sees the earlier fragment's depth and the blends keep
/// the submission order. Each row's covered
/// span ([`Spans`]) is taken [`SPAN`] pixels at a time: their
/// weights, depths and depth test as lanes ([`Span`]), the same formulas
/// as [`fragment_at`] (so the same values, bit for bit).
fn raster_tile_batched(
    tile: &mut TileBuffers,
    rect: (i32, i32, i32, i32),
    bin: &[u32],
    pass: &Pass,
    setup: &PassSetup,
) -> DrawStats {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
        // SAFETY: the CPU has the features the function is compiled for.
        return unsafe { raster_tile_batched_avx2(tile, rect, bin, pass, setup) };
    }
    raster_tile_batched_body::<false>(tile, rect, bin, pass, setup)
}

/// [`raster_tile_batched`] compiled for 8-lane vectors (the same values:
/// no operation is contracted into a fused one).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn raster_tile_batched_avx2(
    tile: &mut TileBuffers,
    rect: (i32, i32, i32, i32),
    bin: &[u32],
    pass: &Pass,
    setup: &PassSetup,
) -> DrawStats {
    raster_tile_batched_body::<true>(tile, rect, bin, pass, setup)
}

/// The scan loop; `AVX2`: compiled with AVX2 (the lanes taken into the
/// batch packed by a permutation, [`compress`]).
// Indexed loops over several lane arrays at once are the form that vectorises.
#[allow(clippy::needless_range_loop)]
#[inline(always)]
fn raster_tile_batched_body<const AVX2: bool>(
    tile: &mut TileBuffers,
    rect: (i32, i32, i32, i32),
    bin: &[u32],
    pass: &Pass,
    setup: &PassSetup,
) -> DrawStats {
    let n = setup.n_varyings;
    let mut stats = DrawStats::default();
    let func = pass.state.depth.func;
    let writer = Writer::of(&pass.state.blend);
    let mut batch = Batch {
        fragments: Vec::with_capacity(BATCH),
        pixels: Vec::with_capacity(BATCH),
        rows: vec![0.0; ROW * n],
        per: n,
        out: [[0.0; 4]; BATCH],
        results: [FragmentResult::Discard; BATCH],
        quantized: [[0; 4]; BATCH],
        pending: [0; TILE],
    };
    for &ti in bin {
        let tri: &Tri = &setup.tris[ti as usize];
        let (vary, gradients) = setup.inputs(tri);
        // The three vertices' varyings.
        let (va, rest) = vary.split_at(n);
        let (vb, vc) = rest.split_at(n);
        for (y, xa, xb, idx0) in Spans::of(tri, rect) {
            let mut x = xa;
            while x <= xb {
                let k = ((xb - x + 1) as usize).min(SPAN);
                let at = idx0 + (x - xa) as usize;
                let (row, bit) = (at / TILE, at % TILE);
                if batch.pending[row] & (((1u64 << k) - 1) << bit) != 0 {
                    batch.flush(tile, pass, writer, &mut stats);
                }
                let span = Span::at(tri, x, y);
                stats.fragments += k as u64;
                let mut pass_mask = depth_mask(func, &span.z, &tile.depth[at..at + k]);
                while pass_mask != 0 {
                    // The passing lanes that fit in the batch, the rest after a flush.
                    let take = first_bits(pass_mask, BATCH - batch.fragments.len());
                    pass_mask &= !take;
                    let len = batch.fragments.len();
                    // The taken lanes' weights packed to the front (a
                    // permutation each), then each varying's row of the
                    // batch from them (vector code, `interpolate`'s formula
                    // lane by lane, so the same values).
                    let mut p = [[0.0f32; SPAN]; 3];
                    for (p, s) in p.iter_mut().zip(&span.p) {
                        compress::<AVX2>(s, take, p);
                    }
                    // A row has room for a span past the batch's last
                    // fragment (no rows at all without varyings).
                    let rows = batch.rows.get_mut(len..).unwrap_or_default().chunks_mut(ROW);
                    for (((&a, &b), &cc), comp) in va.iter().zip(vb).zip(vc).zip(rows) {
                        if let Some(dst) = comp.first_chunk_mut::<SPAN>() {
                            for j in 0..SPAN {
                                dst[j] = p[0][j] * a + p[1][j] * b + p[2][j] * cc;
                            }
                        }
                    }
                    let taken = &PACK[take as usize % (1 << SPAN)][..take.count_ones() as usize];
                    let (z, q) = (&span.z, &span.q);
                    batch.fragments.extend(taken.iter().map(|&j| Fragment {
                        x: (x + j as i32) as u32,
                        y: y as u32,
                        depth: z[j as usize % SPAN],
                        front_facing: tri.front_facing,
                        inv_w: q[j as usize % SPAN],
                        gradients,
                    }));
                    batch.pixels.extend(taken.iter().map(|&j| (at + j as usize, z[j as usize % SPAN])));
                    // The lanes taken lie within the tile's row (bit + k ≤ TILE).
                    batch.pending[row] |= u64::from(take) << bit;
                    if batch.fragments.len() == BATCH {
                        batch.flush(tile, pass, writer, &mut stats);
                    }
                }
                x += SPAN as i32;
            }
        }
    }
    batch.flush(tile, pass, writer, &mut stats);
    stats
}

/// Pixels of a row the scan loop takes together.
const SPAN: usize = 8;

/// The length of a batch's row of varyings ([`Batch::rows`]).
const ROW: usize = BATCH + SPAN;

/// The lowest `k` set bits of `mask` (all of them where it has no more).
#[inline(always)]
fn first_bits(mask: u32, k: usize) -> u32 {
    if mask.count_ones() as usize <= k {
        return mask;
    }
    let (mut rest, mut taken) = (mask, 0);
    for _ in 0..k {
        taken |= rest & rest.wrapping_neg();
        rest &= rest - 1;
    }
    taken
}

/// Per mask of a span's lanes, the lanes set in it in order (then 0s): the
/// permutation that packs them to the front.
static PACK: [[u32; SPAN]; 1 << SPAN] = {
    let mut t = [[0u32; SPAN]; 1 << SPAN];
    let mut m = 0;
    while m < 1 << SPAN {
        let (mut j, mut at) = (0, 0);
        while j < SPAN {
            if m & (1 << j) != 0 {
                t[m][at] = j as u32;
                at += 1;
            }
            j += 1;
        }
        m += 1;
    }
    t
};

/// The lanes of `v` that `mask` sets, packed to the front of `out` (the
/// lanes after them hold anything).
#[inline(always)]
fn compress<const AVX2: bool>(v: &[f32; SPAN], mask: u32, out: &mut [f32; SPAN]) {
    let pack = &PACK[mask as usize & ((1 << SPAN) - 1)];
    #[cfg(target_arch = "x86_64")]
    if AVX2 {
        use std::arch::x86_64::{
            __m256i, _mm256_loadu_ps, _mm256_loadu_si256, _mm256_permutevar8x32_ps, _mm256_storeu_ps,
        };
        // SAFETY: only compiled into `raster_tile_batched_avx2`, whose CPU
        // has AVX2; eight lanes of each array.
        unsafe {
            let idx = _mm256_loadu_si256(pack.as_ptr() as *const __m256i);
            _mm256_storeu_ps(out.as_mut_ptr(), _mm256_permutevar8x32_ps(_mm256_loadu_ps(v.as_ptr()), idx));
        }
        return;
    }
    for (o, &j) in out.iter_mut().zip(pack) {
        *o = v[j as usize];
    }
}

/// [`SPAN`] pixels of a row from (x, y) on: depth, 1/w and the
/// perspective-correct weights, as [`fragment_at`] computes each (lanes
/// past the covered span are computed and not used).
struct Span {
    z: [f32; SPAN],
    q: [f32; SPAN],
    p: [[f32; SPAN]; 3],
}

impl Span {
    /// One loop over the pixels (vector code), each lane [`fragment_at`]'s
    /// formulas in its order.
    #[inline(always)]
    fn at(tri: &Tri, x: i32, y: i32) -> Span {
        let py = y as f32 + 0.5;
        let mut s = Span { z: [0.0; SPAN], q: [0.0; SPAN], p: [[0.0; SPAN]; 3] };
        let [w0, w1, w2] = tri.weights;
        for j in 0..SPAN {
            let px = (x + j as i32) as f32 + 0.5;
            let l = [
                w0[0] * px + w0[1] * py + w0[2],
                w1[0] * px + w1[1] * py + w1[2],
                w2[0] * px + w2[1] * py + w2[2],
            ];
            s.z[j] = (l[0] * tri.z[0] + l[1] * tri.z[1] + l[2] * tri.z[2]).clamp(0.0, 1.0);
            let pw = [l[0] * tri.inv_w[0], l[1] * tri.inv_w[1], l[2] * tri.inv_w[2]];
            let q = pw[0] + pw[1] + pw[2];
            let inv_q = 1.0 / q;
            s.q[j] = q;
            (s.p[0][j], s.p[1][j], s.p[2][j]) = (pw[0] * inv_q, pw[1] * inv_q, pw[2] * inv_q);
        }
        s
    }
}

/// The lanes of `z` (the first `stored.len()`) that pass the depth test
/// `func` against `stored`, as bits; the function matched once per span.
#[inline(always)]
fn depth_mask(func: CompareFunc, z: &[f32; SPAN], stored: &[f32]) -> u32 {
    let lanes = |test: fn(f32, f32) -> bool| {
        z.iter().zip(stored).enumerate().fold(0u32, |m, (j, (&z, &d))| m | ((test(z, d) as u32) << j))
    };
    match func {
        CompareFunc::Never => 0,
        CompareFunc::Less => lanes(|z, d| z < d),
        CompareFunc::LessEqual => lanes(|z, d| z <= d),
        CompareFunc::Equal => lanes(|z, d| z == d),
        CompareFunc::Greater => lanes(|z, d| z > d),
        CompareFunc::GreaterEqual => lanes(|z, d| z >= d),
        CompareFunc::NotEqual => lanes(|z, d| z != d),
        CompareFunc::Always => (1u32 << stored.len()) - 1,
    }
}

/// The covered spans of `tri` inside `rect`, row by row: (y, xa, xb, idx)
/// with the covered pixels `xa..=xb` (`idx`: pixel `xa` in the tile). The
/// covered pixels of a row are one run: each edge function is affine in x,
/// so each edge's inside is a ray of the row, and three rays meet in an
/// interval. An iterator rather than a visitor, so that the loop over the
/// spans is compiled with the function it is in (a closure would not
/// share [`raster_tile_batched`]'s vector features).
struct Spans<'t> {
    tri: &'t Tri,
    rect: (i32, i32, i32, i32),
    y: i32,
    x0: i32,
    x1: i32,
    y1: i32,
}

impl Spans<'_> {
    fn of(tri: &Tri, rect: (i32, i32, i32, i32)) -> Spans<'_> {
        let (x0, x1) = (tri.x0.max(rect.0), tri.x1.min(rect.2));
        let (y0, y1) = (tri.y0.max(rect.1), tri.y1.min(rect.3));
        // An empty column range leaves no row.
        Spans { tri, rect, y: y0, x0, x1, y1: if x0 > x1 { y0 - 1 } else { y1 } }
    }
}

impl Iterator for Spans<'_> {
    type Item = (i32, i32, i32, usize);

    /// Each row's span ([`row_span`]): the same integers as
    /// [`for_each_covered`]'s per-pixel test, so the same pixels
    /// (`spans_are_the_covered_pixels`).
    #[inline(always)]
    fn next(&mut self) -> Option<Self::Item> {
        while self.y <= self.y1 {
            let y = self.y;
            self.y += 1;
            if let Some((xa, xb)) = row_span(self.tri, (self.x0, self.x1), y) {
                return Some((y, xa, xb, (y - self.rect.1) as usize * TILE + (xa - self.rect.0) as usize));
            }
        }
        None
    }
}

/// The pixels `xa..=xb` of row `y` within columns `x0..=x1` that `tri`
/// covers by the top-left fill rule (`Tri::covers` at each pixel centre),
/// `None` where none is: solved from the edge functions at the row's pixel
/// `x0` (a division per edge that bounds the span, instead of testing the
/// pixels one by one): edge k at pixel `x0 + i` is `a + i·s` (exact
/// integers, `a` less its bias, `s = −dy·SUB`); with `s > 0` it holds from
/// ⌈−a/s⌉ on, with `s < 0` up to ⌊a/−s⌋, with `s = 0` everywhere or
/// nowhere. The one solver of the tiled rasterizer ([`Spans`]) and of the
/// adaptive draw's visibility.
#[inline(always)]
pub(crate) fn row_span(tri: &Tri, (x0, x1): (i32, i32), y: i32) -> Option<(i32, i32)> {
    let e = tri.edges_at(x0 as i64 * SUB + SUB / 2, y as i64 * SUB + SUB / 2);
    let (mut lo, mut hi) = (0i64, (x1 - x0) as i64);
    for (k, e) in e.iter().enumerate() {
        let (a, s) = (e - tri.bias[k], -tri.dy[k] * SUB);
        if s > 0 {
            if a < 0 {
                lo = lo.max((s - 1 - a) / s);
            }
        } else if a < 0 {
            return None;
        } else if s < 0 {
            hi = hi.min(a / -s);
        }
    }
    (lo <= hi).then(|| (x0 + lo as i32, x0 + hi as i32))
}

/// [`raster_tile`] with a stencil test: fragment by fragment, since a
/// fragment that fails a test may still be shaded for its stencil update.
fn raster_tile_stencil(
    tile: &mut TileBuffers,
    rect: (i32, i32, i32, i32),
    bin: &[u32],
    pass: &Pass,
    setup: &PassSetup,
) -> DrawStats {
    let n = setup.n_varyings;
    let mut varyings = vec![0.0f32; n];
    let mut stats = DrawStats::default();
    let state = &pass.state;
    let stencil = &state.stencil;
    let depth = &state.depth;
    for &ti in bin {
        let tri: &Tri = &setup.tris[ti as usize];
        let (vary, gradients) = setup.inputs(tri);
        for_each_covered(tri, rect, |x, y, idx| {
            let (fragment, z, p) = fragment_at(tri, x, y, gradients);
            stats.fragments += 1;
            // Interpolates the varyings and runs the fragment stage.
            let mut shade = |out: &mut [f32; 4], stats: &mut DrawStats| {
                interpolate(vary, n, p, &mut varyings);
                stats.shaded += 1;
                pass.fragment.shade(&fragment, &varyings, out)
            };
            let mut color = [0.0f32; 4];
            let stored_stencil = tile.stencil[idx];
            if !stencil.test(stored_stencil) {
                // A discarded fragment must not touch the stencil: shade only if it matters.
                if stencil.fail != StencilOp::Keep && shade(&mut color, &mut stats) == FragmentResult::Keep {
                    stencil.update(&mut tile.stencil[idx], stencil.fail);
                }
            } else if !depth.func.test(z, tile.depth[idx]) {
                if stencil.depth_fail != StencilOp::Keep
                    && shade(&mut color, &mut stats) == FragmentResult::Keep
                {
                    stencil.update(&mut tile.stencil[idx], stencil.depth_fail);
                }
            } else if shade(&mut color, &mut stats) == FragmentResult::Keep {
                let op =
                    if tri.front_facing { stencil.pass } else { stencil.back_pass.unwrap_or(stencil.pass) };
                stencil.update(&mut tile.stencil[idx], op);
                if depth.write {
                    tile.depth[idx] = z;
                }
                tile.blend_color(idx, &color, &state.blend);
                stats.written += 1;
            }
        });
    }
    stats
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A triangle with the snapped vertices `(px, py)` (1/SUB pixel), as
    /// the rasterizer sets its edges up.
    fn triangle(px: [i64; 3], py: [i64; 3], (width, height): (i64, i64)) -> Tri {
        let lo =
            |v: [i64; 3]| (v.iter().min().copied().unwrap_or(0) - SUB / 2 + SUB - 1).div_euclid(SUB).max(0);
        let hi =
            |v: [i64; 3], n: i64| (v.iter().max().copied().unwrap_or(0) - SUB / 2).div_euclid(SUB).min(n - 1);
        let mut tri = Tri {
            dx: [0; 3],
            dy: [0; 3],
            xa: [0; 3],
            ya: [0; 3],
            bias: [0; 3],
            weights: [[0.0; 3]; 3],
            z: [0.0; 3],
            inv_w: [1.0; 3],
            x0: lo(px) as i32,
            y0: lo(py) as i32,
            x1: hi(px, width) as i32,
            y1: hi(py, height) as i32,
            front_facing: true,
            varying_offset: 0,
            gradient_offset: 0,
        };
        tri.set_edges(px, py);
        tri
    }

    /// [`first_bits`] takes the lowest `k` set bits, and [`compress`] packs
    /// the lanes a mask sets in order, the same with and without AVX2, for
    /// every mask of a span.
    #[test]
    fn first_bits_and_compress_take_the_lanes_in_order() {
        let v: [f32; SPAN] = std::array::from_fn(|j| j as f32 + 0.5);
        for mask in 0u32..1 << SPAN {
            let set: Vec<usize> = (0..SPAN).filter(|&j| mask & (1 << j) != 0).collect();
            for k in 0..=SPAN + 1 {
                let want = set.iter().take(k).fold(0u32, |m, &j| m | 1 << j);
                assert_eq!(first_bits(mask, k), want, "mask {mask:08b}, k {k}");
            }
            let mut out = [f32::NAN; SPAN];
            compress::<false>(&v, mask, &mut out);
            let packed: Vec<f32> = set.iter().map(|&j| v[j]).collect();
            assert_eq!(&out[..set.len()], &packed[..], "mask {mask:08b}");
            #[cfg(target_arch = "x86_64")]
            if std::arch::is_x86_feature_detected!("avx2") {
                #[target_feature(enable = "avx2")]
                unsafe fn avx2(v: &[f32; SPAN], mask: u32, out: &mut [f32; SPAN]) {
                    compress::<true>(v, mask, out)
                }
                let mut vector = [f32::NAN; SPAN];
                // SAFETY: the CPU has AVX2.
                unsafe { avx2(&v, mask, &mut vector) };
                assert_eq!(&vector[..set.len()], &packed[..], "mask {mask:08b}, AVX2");
            }
        }
    }

    /// The spans solved row by row cover exactly the pixels the per-pixel
    /// test covers, for triangles of every orientation and size (slivers,
    /// horizontal and vertical edges, vertices on pixel centres, both
    /// windings' fill-rule biases), clipped to tiles they cross or miss.
    #[test]
    fn spans_are_the_covered_pixels() {
        let mut x = 0x2545_f491u32;
        let mut r = move |n: i64| {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            (x as i64).rem_euclid(n)
        };
        let (mut pixels, mut rows) = (0usize, 0usize);
        for round in 0..4000 {
            let scale = [SUB * 3, SUB * 20, SUB * 90, SUB * 300][round % 4];
            let centre = (r(160 * SUB), r(160 * SUB));
            let mut px = [0; 3].map(|_| centre.0 + r(scale) - scale / 2);
            let mut py = [0; 3].map(|_| centre.1 + r(scale) - scale / 2);
            match round % 9 {
                // A horizontal and a vertical edge; vertices on pixel centres.
                0 => py[1] = py[0],
                1 => px[2] = px[1],
                2 => {
                    px = px.map(|v| v / SUB * SUB + SUB / 2);
                    py = py.map(|v| v / SUB * SUB + SUB / 2);
                }
                _ => {}
            }
            let tri = triangle(px, py, (192, 192));
            let (ox, oy) = (r(3) as i32 * TILE as i32, r(3) as i32 * TILE as i32);
            let rect = (ox, oy, ox + TILE as i32 - 1, oy + TILE as i32 - 1);
            let mut expected = Vec::new();
            for_each_covered(&tri, rect, |x, y, idx| expected.push((x, y, idx)));
            let mut got = Vec::new();
            for (y, xa, xb, idx) in Spans::of(&tri, rect) {
                rows += 1;
                assert!(xa <= xb, "round {round}: empty span");
                got.extend((xa..=xb).map(|x| (x, y, idx + (x - xa) as usize)));
            }
            pixels += got.len();
            assert_eq!(got, expected, "round {round}: {px:?} {py:?} in {rect:?}");
        }
        assert!(pixels > 100_000 && rows > 10_000, "{pixels} pixels in {rows} spans");
    }

    /// The batch's 8-bit colours are [`quantize_unorm8`]'s, bit for bit:
    /// every value around each of the 256 rounding steps, both zeros, NaN,
    /// the infinities and values far out of range, a batch at a time (the
    /// last one's tail of NaN).
    #[test]
    fn quantized_lanes_are_quantize_unorm8() {
        use super::super::framebuffer::quantize_unorm8;
        let mut values =
            vec![0.0, -0.0, 1.0, f32::NAN, -f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 1e9, -1e9];
        for step in 0..=256u32 {
            let edge = (step as f32 - 0.5) / 255.0;
            let mut below = edge;
            let mut above = edge;
            for _ in 0..3 {
                below = f32::from_bits(below.to_bits().wrapping_sub(1));
                above = f32::from_bits(above.to_bits().wrapping_add(1));
                values.extend([below, above]);
            }
            values.push(edge);
        }
        values.extend((0..4001).map(|i| i as f32 / 4000.0 * 1.5 - 0.25));
        let mut got = Vec::with_capacity(values.len());
        for chunk in values.chunks(4 * BATCH) {
            let mut src = [[f32::NAN; 4]; BATCH];
            src.as_flattened_mut()[..chunk.len()].copy_from_slice(chunk);
            let mut dst = [[7; 4]; BATCH];
            quantize_lanes(&src, &mut dst);
            got.extend_from_slice(&dst.as_flattened()[..chunk.len()]);
        }
        let expected: Vec<u8> = values.iter().map(|&v| quantize_unorm8(v)).collect();
        let differ: Vec<(f32, u8, u8)> = values
            .iter()
            .zip(got.iter().zip(&expected))
            .filter(|(_, (g, e))| g != e)
            .map(|(&v, (&g, &e))| (v, g, e))
            .collect();
        assert!(
            differ.is_empty(),
            "{} of {} values differ: {:?}",
            differ.len(),
            values.len(),
            &differ[..differ.len().min(8)]
        );
        assert!(expected.contains(&255) && expected.contains(&0) && expected.contains(&128));
    }
}
