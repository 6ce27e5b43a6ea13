//! Nothing breaks on hostile geometry: NaN/Inf positions, degenerate and
//! zero-area triangles, vertices behind the camera, huge coordinates. The
//! output stays finite and the rasterizer never panics.
use crate::common;

use common::{ClipVertices, VaryingsAsColor};
use proptest::prelude::*;
use shadec::renderer::{draw, ColorFormat, CullMode, Framebuffer, Pass, RenderError, RenderState};

fn coordinate() -> impl Strategy<Value = f32> {
    prop_oneof![
        4 => -3.0f32..3.0,
        1 => -1e30f32..1e30,
        1 => -1e6f32..1e6,
        1 => Just(0.0f32),
        1 => Just(1e-20f32),
        1 => Just(f32::NAN),
        1 => Just(f32::INFINITY),
        1 => Just(f32::NEG_INFINITY),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn hostile_triangles_give_finite_output(
        raw in prop::collection::vec((coordinate(), coordinate(), coordinate(), coordinate()), 3..9),
        repeat_vertex in prop::bool::ANY,
    ) {
        let mut clip: Vec<[f32; 4]> = raw.iter().map(|c| [c.0, c.1, c.2, c.3]).collect();
        if repeat_vertex {
            clip[1] = clip[0];
        }
        let n = clip.len();
        let varyings = (0..n * 3).map(|i| (i % 7) as f32 * 0.25 - 0.5).collect();
        let verts = ClipVertices { clip, varyings, n: 3 };
        let tris: Vec<[u32; 3]> = (0..n as u32 - 2).map(|i| [0, i + 1, i + 2]).collect();
        let mut fb = Framebuffer::new(40, 30, ColorFormat::F32).unwrap();
        let state = RenderState { cull: CullMode::None, ..RenderState::default() };
        let stats = draw(&mut fb, &Pass { triangles: &tris, vertex: &verts, fragment: &VaryingsAsColor, state }).unwrap();
        for c in fb.to_rgba_f32() {
            prop_assert!(c.iter().all(|v| v.is_finite()), "{:?} {:?}", c, stats);
            // Perspective-correct weights are convex: values stay within the vertices' range.
            prop_assert!(c[..3].iter().all(|v| (-0.5 - 1e-3..=1.0 + 1e-3).contains(v)), "{:?}", c);
        }
        for y in 0..30 {
            for x in 0..40 {
                let d = fb.depth(x, y).unwrap();
                prop_assert!((0.0..=1.0).contains(&d));
            }
        }
    }
}

#[test]
fn triangle_crossing_the_near_plane_is_clipped_not_inverted() {
    // One vertex behind the eye (w < 0): without clipping it would project
    // to the wrong side; clipped, only the part in front is drawn.
    let clip = vec![[-0.5, -0.5, 0.0, 1.0], [0.5, -0.5, 0.0, 1.0], [0.0, 2.0, -3.0, -1.0]];
    let verts = ClipVertices { clip, varyings: vec![1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0], n: 3 };
    let mut fb = Framebuffer::new(32, 32, ColorFormat::F32).unwrap();
    let state = RenderState { cull: CullMode::None, ..RenderState::default() };
    let stats =
        draw(&mut fb, &Pass { triangles: &[[0, 1, 2]], vertex: &verts, fragment: &VaryingsAsColor, state })
            .unwrap();
    assert!(stats.written > 0, "{stats:?}");
    assert!(fb.to_rgba_f32().iter().all(|c| c.iter().all(|v| v.is_finite())));
}

#[test]
fn out_of_range_indices_are_errors() {
    let verts = ClipVertices { clip: vec![[0.0, 0.0, 0.0, 1.0]; 3], varyings: Vec::new(), n: 0 };
    let mut fb = Framebuffer::new(8, 8, ColorFormat::Rgba8).unwrap();
    let err = draw(
        &mut fb,
        &Pass {
            triangles: &[[0, 1, 7]],
            vertex: &verts,
            fragment: &VaryingsAsColor,
            state: RenderState::default(),
        },
    )
    .unwrap_err();
    assert!(matches!(err, RenderError::IndexOutOfRange { index: 7, .. }), "{err}");
    assert!(err.to_string().contains("index buffer"));
}
