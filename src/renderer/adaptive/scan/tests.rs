//! The span-restricted scan and maps against the whole-frame computations
//! ([`super::reference`]), bit for bit, on generated scenes: overlapping
//! triangles of every size (some past the frame's edges, some sharing
//! depths so that the depth test ties), several passes with different
//! depth tests, cleared and uneven starting depths, both edge modes, and
//! frame sizes and band heights that do not divide each other.

use super::reference;
use super::{covered_span, scan, Input, Maps, Start};
use crate::pipeline::{CompareFunc, DepthState};
use crate::renderer::adaptive::EdgeMode;
use crate::renderer::raster::{setup_pass, PassSetup};
use crate::renderer::{CullMode, Fragment, FragmentResult, FragmentStage, Pass, RenderState, VertexStage};

/// Clip positions, no varyings.
struct Points(Vec<[f32; 4]>);

impl VertexStage for Points {
    fn n_vertices(&self) -> usize {
        self.0.len()
    }
    fn n_varyings(&self) -> usize {
        0
    }
    fn shade_vertex(&self, index: u32, _: &mut [f32]) -> [f32; 4] {
        self.0[index as usize]
    }
}

/// Never run: the visibility shades nothing.
struct Unused;

impl FragmentStage for Unused {
    fn shade(&self, _: &Fragment, _: &[f32], _: &mut [f32; 4]) -> FragmentResult {
        FragmentResult::Keep
    }
}

/// A xorshift generator in [0, 1).
struct Rng(u32);

impl Rng {
    fn next(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 17;
        self.0 ^= self.0 << 5;
        (self.0 >> 8) as f32 / (1u32 << 24) as f32
    }
}

/// `n` triangles of pass `p`: large, small and slivers, some reaching past
/// the frame; depths from a few levels (ties between triangles) or any.
fn triangles(rng: &mut Rng, n: usize, round: usize) -> Vec<[f32; 4]> {
    let mut points = Vec::with_capacity(3 * n);
    for t in 0..n {
        let size = match t % 4 {
            0 => 2.4,
            1 => 0.6,
            2 => 0.08,
            _ => 1.2,
        };
        let (cx, cy) = (rng.next() * 2.4 - 1.2, rng.next() * 2.4 - 1.2);
        let level = if round % 2 == 0 { (rng.next() * 3.0).floor() / 4.0 } else { rng.next() };
        for _ in 0..3 {
            let z = if round % 3 == 0 { level * 2.0 - 1.0 } else { level * 2.0 - 1.0 + rng.next() * 0.2 };
            points.push([cx + (rng.next() - 0.5) * size, cy + (rng.next() - 0.5) * size, z, 1.0]);
        }
    }
    points
}

const STATES: [DepthState; 5] = [
    DepthState::LESS_WRITE,
    DepthState { func: CompareFunc::LessEqual, write: true },
    DepthState::EQUAL_NO_WRITE,
    DepthState { func: CompareFunc::Greater, write: false },
    DepthState { func: CompareFunc::Always, write: true },
];

/// Everything the scan computes, and the reference's, for one scene.
fn compare(setups: &[PassSetup], states: &[DepthState], (w, h): (usize, usize), start: &[f32], round: usize) {
    let mut offsets = vec![0];
    for s in setups {
        offsets.push(offsets.last().unwrap() + s.n_triangles());
    }
    let uniform = start.iter().all(|d| d.to_bits() == start[0].to_bits());
    let (want_ids, want_depth, want_ties) = reference::visible(w, start.to_vec(), states, setups, &offsets);
    let mut maps = Maps::default();
    for edges in [EdgeMode::Pass, EdgeMode::Triangle] {
        for spacing in [1, 3, 16, 64] {
            let input = Input { states, setups, offsets: &offsets, edges, spacing };
            let from = if uniform { Start::Uniform(start[0]) } else { Start::Rows(start) };
            // The buffers of the last scene, reused: every entry must be rewritten.
            let (covered, ties) = scan(&input, from, (w, h), &mut maps);
            let at = format!("round {round}, {w}×{h}, {edges:?}, spacing {spacing}");
            assert_eq!(maps.ids, want_ids, "ids, {at}");
            let bits = |d: &[f32]| d.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&maps.depth), bits(&want_depth), "depth, {at}");
            assert_eq!(ties, want_ties, "ties, {at}");
            let keys = reference::surface_keys(&want_ids, &offsets, edges);
            let got_keys = if edges == EdgeMode::Triangle { &maps.ids } else { &maps.keys };
            assert_eq!(*got_keys, keys, "keys, {at}");
            assert_eq!(
                covered,
                want_ids.iter().filter(|&&id| id != u32::MAX).count() as u64,
                "covered, {at}"
            );
            assert_eq!(maps.spans, reference::row_spans(&keys, w), "spans, {at}");
            let edge = reference::edge_map(&keys, w, h);
            // The one stated difference: an uncovered pixel is no edge sample.
            let covered_edge: Vec<bool> = edge.iter().zip(&keys).map(|(&e, &k)| e && k != u32::MAX).collect();
            assert_eq!(maps.edges, covered_edge, "edges, {at}");
            assert_eq!(maps.columns, reference::band_columns(&keys, &edge, (w, h), spacing), "columns, {at}");
        }
    }
}

#[test]
fn span_restricted_visibility_and_maps_equal_the_whole_frame_computation_bit_for_bit() {
    let mut rng = Rng(0x2545_f491);
    let sizes = [(1, 1), (7, 3), (64, 64), (100, 70), (130, 129), (33, 200)];
    let mut checked_ties = false;
    for round in 0..24 {
        let (w, h) = sizes[round % sizes.len()];
        let n_passes = 1 + round % 3;
        let mut meshes: Vec<Points> =
            (0..n_passes).map(|_| Points(triangles(&mut rng, 6 + round % 9, round))).collect();
        // The same mesh again with `Less` (a second pass over the same
        // geometry): its fragments tie where the first pass's won.
        let again = round % 4 == 1 && n_passes > 1;
        if again {
            meshes[1] = Points(meshes[0].0.clone());
        }
        let indices: Vec<Vec<[u32; 3]>> = meshes
            .iter()
            .map(|m| (0..m.0.len() as u32 / 3).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect())
            .collect();
        let states: Vec<DepthState> =
            (0..n_passes)
                .map(|p| {
                    if again && p < 2 {
                        DepthState::LESS_WRITE
                    } else {
                        STATES[(round + 2 * p) % STATES.len()]
                    }
                })
                .collect();
        let setups: Vec<PassSetup> = (0..n_passes)
            .map(|p| {
                let state = RenderState { cull: CullMode::None, depth: states[p], ..RenderState::default() };
                let pass = Pass { triangles: &indices[p], vertex: &meshes[p], fragment: &Unused, state };
                setup_pass(&pass, w as u32, h as u32).unwrap()
            })
            .collect();
        let start: Vec<f32> = if round % 4 == 3 {
            (0..w * h).map(|i| if i % 5 == 0 { 0.5 } else { rng.next() }).collect()
        } else {
            vec![1.0; w * h]
        };
        compare(&setups, &states, (w, h), &start, round);
        let mut offsets = vec![0];
        for s in &setups {
            offsets.push(offsets.last().unwrap() + s.n_triangles());
        }
        checked_ties |= reference::visible(w, start.clone(), &states, &setups, &offsets).2;
    }
    assert!(checked_ties, "no generated scene had a depth tie");
}

/// [`covered_span`] is, row by row, the pixels `Tri::covers` accepts.
#[test]
fn covered_spans_are_the_pixels_the_fill_rule_covers() {
    use crate::renderer::raster::SUB;
    let mut rng = Rng(0x1234_5678);
    let mut rows = 0;
    for round in 0..40 {
        let mesh = Points(triangles(&mut rng, 12, round));
        let indices: Vec<[u32; 3]> = (0..12).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect();
        let state = RenderState { cull: CullMode::None, ..RenderState::default() };
        let pass = Pass { triangles: &indices, vertex: &mesh, fragment: &Unused, state };
        let setup = setup_pass(&pass, 97, 61).unwrap();
        for tri in &setup.tris {
            for y in tri.y0..=tri.y1 {
                let covered: Vec<i32> = (tri.x0..=tri.x1)
                    .filter(|&x| {
                        tri.covers(&tri.edges_at(x as i64 * SUB + SUB / 2, y as i64 * SUB + SUB / 2))
                    })
                    .collect();
                let want = covered.first().map(|&a| (a, *covered.last().unwrap()));
                assert_eq!(covered_span(tri, y), want, "round {round}, row {y}");
                rows += 1;
            }
        }
    }
    assert!(rows > 1000, "{rows} rows");
}
