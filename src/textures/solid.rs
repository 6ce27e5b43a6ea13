//! A solid (3-D) texture as the renderer stores it: the slices of a
//! [`SIDE`]×[`SIDE`]×[`SLICES`] volume tiled into one square 2-D texel grid
//! of [`crate::pipeline::RENDERED_TEXTURE_SIZE`], so that the texel pass
//! the compiler bakes it with is an ordinary texture-shading pass (Pipeline
//! Grammar, eq. (13)) over that grid. Its lookups are 3-D: GeForce3's
//! TEXTURE_3D (OpenGL 1.2's 3-D textures; the texture shader's
//! `texture_3d()` stage, NV_texture_shader2) filtered trilinearly — the
//! eight texels around the point, weighted by their distances along each
//! axis (GL_LINEAR on a 3-D texture, no mipmaps), clamped to the edge or
//! repeated as the texture is declared (GL 1.2 §3.8.7: a repeated
//! texel index wraps modulo the size, the filter's too).
//! The hardware's filter weights were fixed point; here they are `f32`.

use super::{Filter, Wrap};

/// Texels along x and y of one slice.
pub const SIDE: u32 = 64;
/// Slices along z.
pub const SLICES: u32 = 16;
/// Slices per row of the tiled grid.
pub const TILES: u32 = 4;
/// The tiled grid's side: [`TILES`] · [`SIDE`] (the rendered size).
pub const GRID: u32 = TILES * SIDE;

/// The texel of the tiled grid holding volume texel (x, y, z).
fn tiled_index(x: u32, y: u32, z: u32) -> usize {
    let (tx, ty) = (z % TILES, z / TILES);
    ((ty * SIDE + y) * GRID + tx * SIDE + x) as usize
}

/// Volume texel (x, y, z) of the tiled grid `pixels`, clamped to the edge
/// or wrapped (`wrap`).
fn fetch(pixels: &[[f32; 4]], [x, y, z]: [i64; 3], wrap: Wrap) -> [f32; 4] {
    let c = |v: i64, n: u32| match wrap {
        Wrap::ClampToEdge => v.clamp(0, n as i64 - 1) as u32,
        Wrap::Repeat => v.rem_euclid(n as i64) as u32,
    };
    pixels.get(tiled_index(c(x, SIDE), c(y, SIDE), c(z, SLICES))).copied().unwrap_or([0.0; 4])
}

/// The volume sampled at `c` (clamped to [0, 1]³ or repeated, `wrap`): the
/// nearest texel, or the trilinear blend of the eight around it.
/// `pixels` is the tiled grid ([`GRID`]² texels, row-major); another size
/// reads as zero.
pub fn sample(pixels: &[[f32; 4]], c: [f64; 3], filter: Filter, wrap: Wrap) -> [f64; 4] {
    if pixels.len() != (GRID * GRID) as usize || c.iter().any(|v| !v.is_finite()) {
        return [0.0; 4];
    }
    let n = [SIDE as f64, SIDE as f64, SLICES as f64];
    if filter == Filter::Nearest {
        let i: [i64; 3] = std::array::from_fn(|k| (c[k] * n[k]).floor() as i64);
        return fetch(pixels, i, wrap).map(|v| v as f64);
    }
    let inside = |v: f64| if wrap == Wrap::Repeat { v } else { v.clamp(0.0, 1.0) };
    let f: [f64; 3] = std::array::from_fn(|k| inside(c[k]) * n[k] - 0.5);
    let i0: [i64; 3] = std::array::from_fn(|k| f[k].floor() as i64);
    let a: [f64; 3] = std::array::from_fn(|k| f[k] - i0[k] as f64);
    let mut out = [0.0; 4];
    for corner in 0..8 {
        let b = [corner & 1, (corner >> 1) & 1, (corner >> 2) & 1];
        let w: f64 = (0..3).map(|k| if b[k] == 1 { a[k] } else { 1.0 - a[k] }).product();
        let t = fetch(pixels, std::array::from_fn(|k| i0[k] + b[k] as i64), wrap);
        for (o, v) in out.iter_mut().zip(t) {
            *o += w * v as f64;
        }
    }
    out
}

/// The point of [0, 1]³ whose texel the tiled grid's texel centre
/// (u, v) ∈ [0, 1]² holds: `(fract(4u), fract(4v), (4·⌊4v⌋ + ⌊4u⌋ + ½)/16)`
/// (what the baked texel pass computes from its texel coordinate).
pub fn point_of(u: f64, v: f64) -> [f64; 3] {
    let t = TILES as f64;
    let (x, y) = (u * t, v * t);
    [x.fract(), y.fract(), ((y.floor() * t + x.floor()) + 0.5) / SLICES as f64]
}

/// The texels along each axis.
const N: [f64; 3] = [SIDE as f64, SIDE as f64, SLICES as f64];

/// The texture coordinate of the place `t` ∈ [0, 1]³ of a box when the
/// box's corners are the first and last texel centres:
/// `(t·(N − 1) + ½)/N` per axis, so that no lookup inside the box is
/// clamped and the texels span it exactly.
pub fn coordinate(t: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|k| (t[k] * (N[k] - 1.0) + 0.5) / N[k])
}

/// The place in the box of a texel centre's coordinate `c` (the inverse
/// of [`coordinate`]).
pub fn place(c: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|k| (c[k] * N[k] - 0.5) / (N[k] - 1.0))
}

/// The tiled grid of `f` (a function of the place in the box, [0, 1]³),
/// each channel rounded to 8 bits (an RGBA8 3-D texture), `f` evaluated
/// at the texel centres.
pub fn bake(f: &mut dyn FnMut([f64; 3]) -> [f64; 4]) -> Vec<[f32; 4]> {
    let mut out = vec![[0.0; 4]; (GRID * GRID) as usize];
    for j in 0..GRID {
        for i in 0..GRID {
            let p = place(point_of((i as f64 + 0.5) / GRID as f64, (j as f64 + 0.5) / GRID as f64));
            let v = f(p);
            out[(j * GRID + i) as usize] = v.map(|x| ((x.clamp(0.0, 1.0) * 255.0).round() / 255.0) as f32);
        }
    }
    out
}

/// The largest difference, over channels and `probes` places of the box
/// (a fixed low-discrepancy sequence, so the bound is reproducible),
/// between `f` and its 8-bit volume `baked` read back trilinearly at
/// [`coordinate`].
pub fn measured_error(baked: &[[f32; 4]], f: &mut dyn FnMut([f64; 3]) -> [f64; 4], probes: usize) -> f64 {
    // Additive recurrence on the plastic-number generalisation (R3).
    let g = 1.220_744_084_605_759_5_f64;
    let alpha = [1.0 / g, 1.0 / (g * g), 1.0 / (g * g * g)];
    let mut worst: f64 = 0.0;
    for k in 0..probes {
        let p: [f64; 3] = std::array::from_fn(|d| (0.5 + alpha[d] * (k as f64 + 1.0)).fract());
        let want = f(p);
        let got = sample(baked, coordinate(p), Filter::Bilinear, Wrap::ClampToEdge);
        for c in 0..4 {
            worst = worst.max((want[c].clamp(0.0, 1.0) - got[c]).abs());
        }
    }
    worst
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn texel_centres_map_to_volume_texel_centres() {
        let p = point_of(0.5 / GRID as f64, 0.5 / GRID as f64);
        assert!((p[0] - 0.5 / SIDE as f64).abs() < 1e-12 && (p[2] - 0.5 / SLICES as f64).abs() < 1e-12);
        // The last texel of the grid is the last slice's far corner.
        let q = point_of(1.0 - 0.5 / GRID as f64, 1.0 - 0.5 / GRID as f64);
        assert!((q[0] - (1.0 - 0.5 / SIDE as f64)).abs() < 1e-12);
        assert!((q[2] - (1.0 - 0.5 / SLICES as f64)).abs() < 1e-12);
    }

    #[test]
    fn trilinear_reproduces_an_affine_function_between_texel_centres() {
        let mut f = |p: [f64; 3]| [p[0], p[1], p[2], 1.0];
        let grid: Vec<[f32; 4]> = {
            let mut exact = vec![[0.0; 4]; (GRID * GRID) as usize];
            for j in 0..GRID {
                for i in 0..GRID {
                    let p = point_of((i as f64 + 0.5) / GRID as f64, (j as f64 + 0.5) / GRID as f64);
                    exact[(j * GRID + i) as usize] = f(p).map(|v| v as f32);
                }
            }
            exact
        };
        let p = [0.3, 0.61, 0.47];
        let s = sample(&grid, p, Filter::Bilinear, Wrap::ClampToEdge);
        for k in 0..3 {
            assert!((s[k] - p[k]).abs() < 1e-6, "{s:?} at {p:?}");
        }
        // 8-bit storage of the same function over the box: half a step.
        let baked = bake(&mut f);
        let e = measured_error(&baked, &mut f, 512);
        assert!(e <= 0.5 / 255.0 + 1e-6 && e > 0.0, "{e}");
    }

    #[test]
    fn a_repeated_volume_wraps_and_a_clamped_one_does_not() {
        let grid: Vec<[f32; 4]> = (0..GRID * GRID).map(|i| [(i % 97) as f32 / 97.0, 0.0, 0.0, 1.0]).collect();
        for filter in [Filter::Nearest, Filter::Bilinear] {
            let p = [0.23, 0.71, 0.38];
            let shifted = [p[0] + 1.0, p[1] - 2.0, p[2] + 3.0];
            let inside = sample(&grid, p, filter, Wrap::Repeat);
            let wrapped = sample(&grid, shifted, filter, Wrap::Repeat);
            assert!(
                wrapped.iter().zip(inside).all(|(a, b)| (a - b).abs() < 1e-6),
                "{filter:?}: {wrapped:?} {inside:?}"
            );
            assert!(inside[0] > 0.0);
            // Across the edge the filter blends the texels of both sides.
            let edge = sample(&grid, [0.0, 0.5, 0.5], filter, Wrap::Repeat);
            let far = sample(&grid, [1.0, 0.5, 0.5], filter, Wrap::Repeat);
            assert_eq!(edge, far, "{filter:?}");
            let clamped = sample(&grid, shifted, filter, Wrap::ClampToEdge);
            assert_eq!(clamped, sample(&grid, [1.0, 0.0, 1.0], filter, Wrap::ClampToEdge), "{filter:?}");
        }
    }
}
