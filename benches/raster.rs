//! Rasterizer throughput: Mpixel/s filling a 1024×1024 target with an
//! interpolated-colour fragment stage, one thread vs all threads, and time
//! vs triangle count (a full-screen grid of n triangles).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use shadec::renderer::{
    draw, ColorFormat, CullMode, DepthState, Fragment, FragmentResult, FragmentStage, Framebuffer, Pass,
    RenderState, VertexStage,
};

const SIZE: u32 = 1024;

/// A full-screen grid of `cells`² quads, colour varyings per vertex.
struct Grid {
    cells: u32,
}

impl VertexStage for Grid {
    fn n_vertices(&self) -> usize {
        ((self.cells + 1) * (self.cells + 1)) as usize
    }
    fn n_varyings(&self) -> usize {
        3
    }
    fn shade_vertex(&self, index: u32, varyings: &mut [f32]) -> [f32; 4] {
        let (i, j) = (index % (self.cells + 1), index / (self.cells + 1));
        let (u, v) = (i as f32 / self.cells as f32, j as f32 / self.cells as f32);
        varyings.copy_from_slice(&[u, v, 1.0 - u]);
        [2.0 * u - 1.0, 2.0 * v - 1.0, 0.0, 1.0]
    }
}

fn grid_triangles(cells: u32) -> Vec<[u32; 3]> {
    let mut t = Vec::new();
    for j in 0..cells {
        for i in 0..cells {
            let a = j * (cells + 1) + i;
            let b = a + cells + 1;
            t.push([a, a + 1, b + 1]);
            t.push([a, b + 1, b]);
        }
    }
    t
}

struct InterpolatedColor;

impl FragmentStage for InterpolatedColor {
    fn shade(&self, _: &Fragment, v: &[f32], out: &mut [f32; 4]) -> FragmentResult {
        *out = [v[0], v[1], v[2], 1.0];
        FragmentResult::Keep
    }
}

fn render(fb: &mut Framebuffer, grid: &Grid, tris: &[[u32; 3]]) {
    let state = RenderState { cull: CullMode::None, depth: DepthState::DISABLED, ..RenderState::default() };
    draw(fb, &Pass { triangles: tris, vertex: grid, fragment: &InterpolatedColor, state }).unwrap();
}

fn fill_rate(c: &mut Criterion) {
    let mut group = c.benchmark_group("fill_1024");
    group.throughput(Throughput::Elements((SIZE * SIZE) as u64));
    let grid = Grid { cells: 8 };
    let tris = grid_triangles(8);
    for format in [ColorFormat::Rgba8, ColorFormat::F32] {
        let mut fb = Framebuffer::new(SIZE, SIZE, format).unwrap();
        let all = rayon::current_num_threads();
        for threads in [1, all] {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            group
                .bench_function(BenchmarkId::new(format!("{format:?}"), format!("{threads}_threads")), |b| {
                    b.iter(|| pool.install(|| render(&mut fb, &grid, &tris)))
                });
        }
    }
    group.finish();
}

fn triangle_count(c: &mut Criterion) {
    let mut group = c.benchmark_group("triangles_1024");
    let mut fb = Framebuffer::new(SIZE, SIZE, ColorFormat::Rgba8).unwrap();
    for cells in [1u32, 16, 64, 256] {
        let grid = Grid { cells };
        let tris = grid_triangles(cells);
        group.throughput(Throughput::Elements(tris.len() as u64));
        group.bench_function(BenchmarkId::from_parameter(tris.len()), |b| {
            b.iter(|| render(&mut fb, &grid, &tris))
        });
    }
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10);
    targets = fill_rate, triangle_count
}
criterion_main!(benches);
