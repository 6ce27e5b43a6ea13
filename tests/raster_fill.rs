//! The fill rule: shared edges are covered exactly once, with no cracks.
use crate::common;

use common::{hit_counts, ClipVertices};
use proptest::prelude::*;

#[test]
fn quad_of_two_triangles_covers_every_pixel_once() {
    for (w, h, corners) in [
        (32u32, 32u32, [[0.0f32, 0.0], [32.0, 0.0], [32.0, 32.0], [0.0, 32.0]]),
        (40, 30, [[3.3, 2.7], [35.1, 4.2], [33.9, 27.5], [1.2, 25.8]]),
        (64, 64, [[10.5, 10.5], [50.5, 10.5], [50.5, 50.5], [10.5, 50.5]]),
    ] {
        let v = ClipVertices::from_pixels(&corners, w, h);
        // Both windings of the diagonal.
        for tris in [[[0u32, 1, 2], [0, 2, 3]], [[0, 1, 3], [1, 2, 3]]] {
            let (counts, _) = hit_counts(&v, &tris, w, h);
            assert!(counts.iter().all(|&c| c == 0.0 || c == 1.0), "a pixel was hit twice");
            let single = hit_counts(&ClipVertices::from_pixels(&corners, w, h), &tris[..1], w, h).0;
            let other = hit_counts(&ClipVertices::from_pixels(&corners, w, h), &tris[1..], w, h).0;
            for i in 0..counts.len() {
                assert_eq!(counts[i], single[i] + other[i]);
            }
            if corners[0] == [0.0, 0.0] {
                assert!(counts.iter().all(|&c| c == 1.0), "full-target quad must cover all pixels");
            }
            // Axis-aligned quad with half-pixel corners: exactly 40×40 centres inside.
            if corners[0] == [10.5, 10.5] {
                assert_eq!(counts.iter().filter(|&&c| c == 1.0).count(), 40 * 40);
            }
        }
    }
}

#[test]
fn fan_around_a_vertex_has_no_cracks_or_double_hits() {
    let (w, h) = (96u32, 96u32);
    let centre = [47.3f32, 48.9];
    let n = 37;
    let mut points = vec![centre];
    for k in 0..n {
        let a = k as f32 / n as f32 * std::f32::consts::TAU;
        points.push([centre[0] + 40.0 * a.cos(), centre[1] + 40.0 * a.sin()]);
    }
    let tris: Vec<[u32; 3]> = (0..n).map(|k| [0, 1 + k as u32, 1 + ((k + 1) % n) as u32]).collect();
    let (counts, stats) = hit_counts(&ClipVertices::from_pixels(&points, w, h), &tris, w, h);
    assert_eq!(stats.triangles_setup, n);
    assert!(counts.iter().all(|&c| c == 0.0 || c == 1.0), "double hit");
    // Every pixel centre well inside the polygon (inscribed radius minus a margin) is hit.
    let inscribed = 40.0 * (std::f32::consts::PI / n as f32).cos();
    for y in 0..h {
        for x in 0..w {
            let (dx, dy) = (x as f32 + 0.5 - centre[0], y as f32 + 0.5 - centre[1]);
            let r = (dx * dx + dy * dy).sqrt();
            let c = counts[(y * w + x) as usize];
            if r < inscribed - 0.1 {
                assert_eq!(c, 1.0, "crack at ({x}, {y})");
            } else if r > 40.1 {
                assert_eq!(c, 0.0, "hit outside at ({x}, {y})");
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// A triangle split at an interior point into three covers exactly the
    /// pixels of the whole triangle, each once — also when the corners lie far
    /// outside the target (guard-band clipping) and at perspective w ≠ 1.
    #[test]
    fn split_triangle_covers_the_same_pixels_once(
        a in (-80.0f32..120.0, -80.0f32..120.0),
        b in (-80.0f32..120.0, -80.0f32..120.0),
        c in (-80.0f32..120.0, -80.0f32..120.0),
        far in prop::bool::ANY,
        bary in (0.15f32..0.7, 0.15f32..0.7),
        ws in (0.5f32..3.0, 0.5f32..3.0, 0.5f32..3.0),
    ) {
        let (w, h) = (48u32, 40u32);
        let scale = if far { 900.0 } else { 1.0 };
        let pts = [[a.0 * scale, a.1], [b.0, b.1 * scale], [c.0, c.1]];
        let (u, v) = (bary.0, bary.1 * (1.0 - bary.0));
        let p = [
            pts[0][0] * u + pts[1][0] * v + pts[2][0] * (1.0 - u - v),
            pts[0][1] * u + pts[1][1] * v + pts[2][1] * (1.0 - u - v),
        ];
        let wv = [ws.0, ws.1, ws.2];
        let mut clip: Vec<[f32; 4]> = pts.iter().zip(wv).map(|(q, wq)| common::pixel_to_clip(*q, w, h, 0.0, wq)).collect();
        clip.push(common::pixel_to_clip(p, w, h, 0.0, 1.0));
        let verts = ClipVertices { clip, varyings: Vec::new(), n: 0 };
        let whole = hit_counts(&verts, &[[0, 1, 2]], w, h).0;
        let split = hit_counts(&verts, &[[0, 1, 3], [1, 2, 3], [2, 0, 3]], w, h).0;
        for i in 0..whole.len() {
            prop_assert!(split[i] <= 1.0, "pixel {} hit {} times", i, split[i]);
            prop_assert_eq!(split[i], whole[i], "pixel {}", i);
        }
    }
}
