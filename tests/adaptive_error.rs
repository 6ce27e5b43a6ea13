//! Error bounds of adaptive sample shading (seeds/004 Section 2.1): on
//! smooth regions the error stays within the threshold, spot cut-offs are
//! not smeared, and light culling (Section 2.2) never drops a light that
//! changes a pixel by more than its tolerance.

use crate::adaptive_common;

use adaptive_common::{adaptive, full, lit, max_diff};
use shadec::renderer::{image_error, AdaptiveSettings, EdgeMode};

#[test]
fn error_is_within_the_threshold_on_smooth_regions() {
    // A region is smooth when the full image changes by less than the
    // threshold between any two pixels of the same 16-pixel cell's
    // neighbourhood; there interpolation cannot go further than the threshold.
    let (scene, lit) = lit("adaptive_sphere_4lights.ron", None);
    let reference = full(&scene, &lit);
    let (w, h) = (scene.resolution.0 as usize, scene.resolution.1 as usize);
    let mut checked = 0;
    for t in [0.02f32, 0.04, 0.085] {
        let (image, _) = adaptive(&scene, &lit, &AdaptiveSettings::new(16, t, EdgeMode::Pass));
        for cy in 0..h / 16 {
            for cx in 0..w / 16 {
                // Cell with its border rows/columns (the samples it is interpolated from).
                let (x0, y0, x1, y1) =
                    (cx * 16, cy * 16, (cx * 16 + 16).min(w - 1), (cy * 16 + 16).min(h - 1));
                let px: Vec<[f32; 4]> =
                    (y0..=y1).flat_map(|y| (x0..=x1).map(move |x| y * w + x)).map(|i| reference[i]).collect();
                let covered = px.iter().all(|c| c[3] > 0.0);
                let range = (0..3)
                    .map(|c| {
                        let lo = px.iter().map(|p| p[c]).fold(f32::INFINITY, f32::min);
                        let hi = px.iter().map(|p| p[c]).fold(f32::NEG_INFINITY, f32::max);
                        hi - lo
                    })
                    .fold(0.0, f32::max);
                if !covered || range > t {
                    continue;
                }
                checked += 1;
                for y in y0..=y1 {
                    for x in x0..=x1 {
                        let d = max_diff(reference[y * w + x], image[y * w + x]);
                        assert!(d <= t, "threshold {t}: pixel ({x}, {y}) off by {d}");
                    }
                }
            }
        }
    }
    assert!(checked > 100, "only {checked} smooth cells");
}

#[test]
fn spot_cut_off_is_not_smeared() {
    let (scene, lit) = lit("adaptive_spot_cutoff.ron", None);
    let reference = full(&scene, &lit);
    let w = scene.resolution.0 as usize;
    let t = 0.085;
    for spacing in [8, 16] {
        let (image, stats) = adaptive(&scene, &lit, &AdaptiveSettings::new(spacing, t, EdgeMode::Triangle));
        let mut edge_pixels = 0;
        for (i, r) in reference.iter().enumerate() {
            let (x, y) = (i % w, i / w);
            // Pixels on both sides of the cut-off edge: a neighbour differs by more than the threshold.
            let jump = [(1i64, 0i64), (0, 1)].iter().any(|&(dx, dy)| {
                let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                nx < w as i64
                    && (ny as usize) < reference.len() / w
                    && max_diff(*r, reference[ny as usize * w + nx as usize]) > t
            });
            if jump {
                edge_pixels += 1;
                let d = max_diff(*r, image[i]);
                assert!(d <= t, "spacing {spacing}: cut-off pixel ({x}, {y}) off by {d}");
            }
        }
        assert!(edge_pixels > 200, "the scene has a sharp cut-off ({edge_pixels} pixels)");
        let e = image_error(&reference, &image);
        println!(
            "spot spacing {spacing}: {:.2} % shaded, max {:.4}, PSNR {:.2}",
            100.0 * stats.fraction_shaded(),
            e.max_abs,
            e.psnr
        );
        assert!(e.max_abs <= t, "max error {}", e.max_abs);
    }
}

#[test]
fn light_culling_never_drops_a_light_that_matters() {
    let tolerance = 0.01;
    for name in [
        "adaptive_sphere_4lights.ron",
        "adaptive_cube_1light.ron",
        "adaptive_cube_4lights.ron",
        "adaptive_spot_cutoff.ron",
    ] {
        let (scene, all) = lit(name, None);
        let (_, culled) = lit(name, Some(tolerance));
        let reference = full(&scene, &all);
        let image = full(&scene, &culled);
        let e = image_error(&reference, &image);
        let r = culled.relevance;
        let counts = culled.take_term_counts();
        println!(
            "{name}: {}/{} terms skipped per polygon, {}/{} per pixel, max {:.5}",
            r.skipped,
            r.terms,
            counts.skipped,
            counts.skipped + counts.evaluated,
            e.max_abs
        );
        assert!(e.max_abs < tolerance, "{name}: culling changed a pixel by {}", e.max_abs);
        assert!(r.skipped > 0, "{name}: nothing culled");
        assert_eq!(all.relevance.skipped, 0);
    }
}

#[test]
fn culling_and_adaptive_shading_together() {
    let (scene, all) = lit("adaptive_cube_4lights.ron", None);
    let (_, culled) = lit("adaptive_cube_4lights.ron", Some(0.01));
    let reference = full(&scene, &all);
    let (image, stats) = adaptive(&scene, &culled, &AdaptiveSettings::new(16, 0.085, EdgeMode::Triangle));
    let e = image_error(&reference, &image);
    println!(
        "cube 4 lights, culled + adaptive: {:.2} % shaded, PSNR {:.2}",
        100.0 * stats.fraction_shaded(),
        e.psnr
    );
    assert!(e.psnr >= 40.0);
}
