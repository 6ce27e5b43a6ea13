//! Normal maps made here from their definition (Kilgard 2000, Section 5.3,
//! Appendices E and F), not by the texture unit's generator: the height
//! field (an image's luminance, or the golf-ball dimples that stand in for a
//! missing file — data, as an image's texels are) is differenced forward to
//! the right and one row on, `n = (dcy, −dcx, 1)/|…|` with
//! `dc = scale·(c − c′)`, wrapping at the edges, alpha 1 at the base
//! level. Each further level is Appendix F's filter: the four vectors of a 2×2
//! block denormalized by their alpha, averaged; the average's direction,
//! normalized, in RGB and its length (at most 1) in alpha.
//!
//! Stored as declared: an 8-bit format holds Appendix E's bytes —
//! `(GLubyte)(128 + 127·n)`, C's truncation, and `255·mag` truncated —
//! and each level is filtered from the bytes of the one above, decoded
//! `(b − 128)/127`, the exact inverse of the encoding; a float format holds
//! `½n + ½` and the length unquantized. `bumps(cells)` is the dimples'
//! normal map (scale 4) in a signed format: the range-compressed texel
//! expanded, `2t − 1` (Kilgard's bytes expanded in `signed8`; at 16 bits,
//! k/32767, as NV_texture_shader's signed HILO16 channels hold it).

use super::sampling::Level;
use crate::textures::generators::HeightField;

/// How the texels are stored.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Storage {
    /// Appendix E's bytes.
    Bytes,
    /// Unquantized, range-compressed.
    Float,
}

/// One texel while filtering: the unit vector and its length.
type Texel = ([f64; 3], f64);

fn normalize(v: [f64; 3]) -> [f64; 3] {
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if l > 0.0 && l.is_finite() {
        v.map(|c| c / l)
    } else {
        [0.0, 0.0, 1.0]
    }
}

/// C's `(GLubyte)(128 + 127·c)`: truncation towards zero.
fn byte(c: f64) -> f64 {
    (128.0 + 127.0 * c.clamp(-1.0, 1.0)).trunc().clamp(0.0, 255.0)
}

/// What the storage keeps of a texel: Appendix E's bytes decoded again.
fn stored(storage: Storage, (n, mag): Texel) -> Texel {
    match storage {
        Storage::Bytes => {
            (n.map(|c| (byte(c) - 128.0) / 127.0), (255.0 * mag.clamp(0.0, 1.0)).trunc() / 255.0)
        }
        Storage::Float => (n, mag),
    }
}

/// The texel as the texture unit reads it: RGB range-compressed, alpha the
/// length; of a [`stored`] texel (whose bytes are `128 + 127·c` exactly).
fn texel(storage: Storage, (n, mag): Texel) -> [f64; 4] {
    match storage {
        Storage::Bytes => {
            let b = n.map(|c| (128.0 + 127.0 * c).round() / 255.0);
            [b[0], b[1], b[2], mag]
        }
        Storage::Float => [0.5 * n[0] + 0.5, 0.5 * n[1] + 0.5, 0.5 * n[2] + 0.5, mag],
    }
}

/// Appendix E: the base level, from the height field `h` (row-major, row
/// 0 at t = 0), wrapping.
fn base(h: &HeightField, scale: f64) -> Vec<Texel> {
    let (w, ht) = (h.width as usize, h.height as usize);
    let at = |x: usize, y: usize| f64::from(h.heights[(y % ht) * w + x % w]);
    let mut out = Vec::with_capacity(w * ht);
    for i in 0..ht {
        for j in 0..w {
            let c = at(j, i);
            let dcx = scale * (c - at(j + 1, i));
            let dcy = scale * (c - at(j, i + 1));
            out.push((normalize([dcy, -dcx, 1.0]), 1.0));
        }
    }
    out
}

/// Appendix F: the level below `(w, h)`, each texel the mean of a 2×2
/// block (wrapping, so that N×1 and 1×N levels filter) of denormalized
/// vectors.
fn down(level: &[Texel], w: usize, h: usize) -> (Vec<Texel>, usize, usize) {
    let (nw, nh) = ((w / 2).max(1), (h / 2).max(1));
    let mut out = Vec::with_capacity(nw * nh);
    for i in 0..nh {
        for j in 0..nw {
            let mut sum = [0.0; 3];
            for (dy, dx) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
                let (n, mag) = level[((2 * i + dy) % h) * w + (2 * j + dx) % w];
                for c in 0..3 {
                    sum[c] += mag * n[c];
                }
            }
            let l = (sum[0] * sum[0] + sum[1] * sum[1] + sum[2] * sum[2]).sqrt();
            let n = if l == 0.0 { [0.0, 0.0, 1.0] } else { sum.map(|c| c / l) };
            out.push((n, (l / 4.0).min(1.0)));
        }
    }
    (out, nw, nh)
}

/// The normal map of `h` at `scale`: level 0 and, with `mipmap`, Appendix
/// F's chain down to 1×1.
pub fn levels(h: &HeightField, scale: f64, storage: Storage, mipmap: bool) -> Vec<Level> {
    let (mut w, mut ht) = (h.width as usize, h.height as usize);
    let mut level: Vec<Texel> = base(h, scale).into_iter().map(|t| stored(storage, t)).collect();
    let as_level = |l: &[Texel], w: usize, ht: usize| Level {
        width: w as u32,
        height: ht as u32,
        texels: l.iter().map(|&t| texel(storage, t)).collect(),
    };
    let mut out = vec![as_level(&level, w, ht)];
    while mipmap && (w > 1 || ht > 1) {
        let (next, nw, nh) = down(&level, w, ht);
        level = next.into_iter().map(|t| stored(storage, t)).collect();
        (w, ht) = (nw, nh);
        out.push(as_level(&level, w, ht));
    }
    out
}

/// A signed format's texels: RGB expanded `2t − 1` (and at 16 bits held
/// as k/32767), alpha as is.
pub fn expanded(levels: &mut [Level], sixteen: bool) {
    for t in levels.iter_mut().flat_map(|l| l.texels.iter_mut()) {
        for c in t.iter_mut().take(3) {
            let v = 2.0 * *c - 1.0;
            *c = if sixteen { (v.clamp(-1.0, 1.0) * 32767.0).round() / 32767.0 } else { v };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A flat field is the unperturbed normal (0, 0, 1): bytes 128, 128, 255.
    #[test]
    fn a_flat_field_is_the_unperturbed_normal() {
        let hf = HeightField { width: 4, height: 4, heights: vec![0.5; 16] };
        let l = levels(&hf, 4.0, Storage::Bytes, true);
        assert_eq!(l.len(), 3);
        for level in &l {
            for t in &level.texels {
                assert_eq!(t.map(|c| (c * 255.0).round()), [128.0, 128.0, 255.0, 255.0]);
            }
        }
    }

    /// A ramp rising along s: Appendix E's n = (dcy, −dcx, 1)/|…| with
    /// dcx = scale·(c − cx) = −0.1 and dcy = 0, so n ∝ (0, 0.1, 1).
    #[test]
    fn a_ramp_along_s_tilts_the_normal_about_y() {
        let heights = (0..16).map(|i| (i % 4) as f32 * 0.1).collect();
        let hf = HeightField { width: 4, height: 4, heights };
        let l = levels(&hf, 1.0, Storage::Float, false);
        // Texel (0, 0): c = 0, cx = 0.1, dcx = −0.1, dcy = 0: n ∝ (0, 0.1, 1).
        let t = l[0].texels[0];
        let n = [2.0 * t[0] - 1.0, 2.0 * t[1] - 1.0, 2.0 * t[2] - 1.0];
        let len = (1.0f64 + 0.01).sqrt();
        assert!(
            n[0].abs() < 1e-6 && (n[1] - 0.1 / len).abs() < 1e-6 && (n[2] - 1.0 / len).abs() < 1e-6,
            "{n:?}"
        );
    }
}
