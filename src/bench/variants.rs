//! The technique variants `shadec bench` measures, each a
//! program, a target and a precision mode on a scene, grouped by the ground
//! truth they are measured against.

use crate::numerics::Precision;

/// A scene of the bench, embedded so that `shadec bench` needs no files.
#[derive(Clone, Copy, Debug)]
pub struct BenchScene {
    pub name: &'static str,
    pub ron: &'static str,
}

/// A coarse sphere (12 × 6 facets) under one point light.
pub const SPHERE: BenchScene =
    BenchScene { name: "scenes/bench_sphere.ron", ron: include_str!("../../scenes/bench_sphere.ron") };
/// Kilgard's bump-mapped torus (the default of `shadec render`).
pub const TORUS: BenchScene =
    BenchScene { name: "scenes/kilgard_torus.ron", ron: include_str!("../../scenes/kilgard_torus.ron") };

/// A program of the bench.
#[derive(Clone, Copy, Debug)]
pub struct Program {
    pub name: &'static str,
    pub source: &'static str,
}

macro_rules! program {
    ($file:literal) => {
        Program {
            name: concat!("src/bench/programs/", $file),
            source: include_str!(concat!("programs/", $file)),
        }
    };
}

/// Phong per pixel with the true `pow` and renormalized vectors: the
/// shared model's reference.
pub const PHONG_EXACT: Program = program!("phong_exact.shd");
/// Phong per vertex, colours interpolated (Gouraud).
pub const GOURAUD: Program = program!("gouraud.shd");
/// Phong per pixel from interpolated vectors left unnormalized.
pub const PHONG_UNNORMALIZED: Program = program!("phong_unnormalized.shd");
/// Phong per pixel, vectors renormalized by a Taylor step.
pub const PHONG_TAYLOR: Program = program!("phong_taylor.shd");
/// Phong per pixel, vectors renormalized by an 8-bit normalization cube map.
pub const PHONG_CUBE8: Program = program!("phong_cube8.shd");
/// Phong per pixel, vectors renormalized by a 16-bit normalization cube map.
pub const PHONG_CUBE16: Program = program!("phong_cube16.shd");
/// The specular exponent by `pow`.
pub const EXPONENT_POW: Program = program!("exponent_pow.shd");
/// The specular exponent by repeated squaring.
pub const EXPONENT_SQUARING: Program = program!("exponent_squaring.shd");
/// The specular exponent by a table lookup.
pub const EXPONENT_LOOKUP: Program = program!("exponent_lookup.shd");
/// Kilgard 2000's bump mapping, the example program.
pub const KILGARD: Program = Program {
    name: "examples/kilgard_bump_mapping.shd",
    source: include_str!("../../examples/kilgard_bump_mapping.shd"),
};
/// Torrance–Sparrow evaluated per pixel: the factored form's reference.
pub const TORRANCE_SPARROW_PER_PIXEL: Program = program!("torrance_sparrow_per_pixel.shd");
/// Torrance–Sparrow factored into tables (Heidrich & Seidel 1999), the
/// example program.
pub const HEIDRICH_SEIDEL: Program = Program {
    name: "examples/torrance_sparrow_factored.shd",
    source: include_str!("../../examples/torrance_sparrow_factored.shd"),
};

/// One measured technique.
#[derive(Clone, Copy, Debug)]
pub struct Variant {
    /// Short, file-name safe (`phong_cube8`): names the difference image.
    pub name: &'static str,
    pub program: Program,
    pub target: &'static str,
    pub mode: Precision,
    /// What the variant approximates, and how, with the paper reference.
    pub approximates: &'static str,
}

/// Variants measured against one ground truth: the exact render (f64,
/// vectors renormalized, true pow, no lookup tables) of `truth` on `scene`.
#[derive(Clone, Debug)]
pub struct Group {
    pub name: &'static str,
    pub scene: BenchScene,
    pub truth: Program,
    pub truth_target: &'static str,
    pub variants: Vec<Variant>,
}

/// Every group of the bench, in report order.
pub fn groups() -> Vec<Group> {
    use Precision::*;
    let v = |name, program, target, mode, approximates| Variant { name, program, target, mode, approximates };
    vec![
        Group {
            name: "Phong: renormalization (n = 16, coarse sphere)",
            scene: SPHERE,
            truth: PHONG_EXACT,
            truth_target: "wgsl",
            variants: vec![
                v("gouraud", GOURAUD, "geforce3", F32, "shading per vertex, colours interpolated (Pipeline Grammar, eq. (1))"),
                v("phong_unnormalized", PHONG_UNNORMALIZED, "wgsl", F32, "per pixel, L and H interpolated and not renormalized (planned for wgsl: geforce3's primary colour cannot carry a signed vector)"),
                v("phong_unnormalized_fixed9", PHONG_UNNORMALIZED, "wgsl", Fixed9, "the same in a per-operation 8-bit model: the combiner generator cannot realize it on geforce3 yet, so it runs for wgsl"),
                v("phong_taylor", PHONG_TAYLOR, "wgsl", F32, "renormalized by the Taylor series in the combiners (GeForce3 Phong, Formula 6)"),
                v("phong_taylor_fixed9", PHONG_TAYLOR, "wgsl", Fixed9, "the same in a per-operation 8-bit model (not realized on geforce3 yet: wgsl)"),
                v("phong_cube8", PHONG_CUBE8, "geforce3", F32, "renormalized by an 8-bit normalization cube map (Kilgard 2000, App. D)"),
                v("phong_cube8_fixed9", PHONG_CUBE8, "geforce3", Fixed9, "the same in the combiners' 8 bits + sign"),
                v("phong_cube16", PHONG_CUBE16, "geforce3", F32, "renormalized by a 16-bit normalization cube map"),
                v("phong_cube8_geforce256", PHONG_CUBE8, "geforce256", Fixed9, "the hand-written 8-bit cube map on a GeForce 256, bit-faithful"),
                v("phong_lowered_geforce3", PHONG_EXACT, "geforce3", Fixed9, "the reference program lowered by the compiler (normalization cube map), bit-faithful"),
                v("phong_lowered_geforce256", PHONG_EXACT, "geforce256", Fixed9, "the reference program lowered by the compiler (cube map, x^16 multiplied across passes), bit-faithful"),
                v("phong_exact_f32", PHONG_EXACT, "wgsl", F32, "normalize and pow in f32 (a modern shader)"),
                v("phong_exact", PHONG_EXACT, "wgsl", Exact, "the reference itself (f64)"),
            ],
        },
        Group {
            name: "Specular exponent (n = 64, coarse sphere)",
            scene: SPHERE,
            truth: EXPONENT_POW,
            truth_target: "wgsl",
            variants: vec![
                v("exponent_squaring", EXPONENT_SQUARING, "geforce3", Fixed9, "x^64 by six squarings, each rounded to 8 bits (GeForce3 Phong, Section 4.4)"),
                v("exponent_lookup", EXPONENT_LOOKUP, "wgsl", F32, "x^64 from an 8-bit 1-D lookup texture, the rest in f32 (shadec generates no GeForce3 texture-shader stage for a 1-D table at one dot product: on geforce3 this program plans by squaring)"),
                v("exponent_pow", EXPONENT_POW, "wgsl", F32, "true pow in f32"),
            ],
        },
        Group {
            name: "Kilgard's bump mapping (Kilgard 2000, torus, 3 passes on a GeForce 256)",
            scene: TORUS,
            truth: KILGARD,
            truth_target: "geforce256",
            variants: vec![
                v("kilgard_fixed9", KILGARD, "geforce256", Fixed9, "the register combiners' precision: 8-bit textures, framebuffer, 9-bit maths"),
                v("kilgard_f32", KILGARD, "geforce256", F32, "the same passes in float (cube-map normalization, ^8 by squaring)"),
                v("kilgard_exact", KILGARD, "geforce256", Exact, "the reference itself"),
            ],
        },
        Group {
            name: "Heidrich-Seidel factorized Torrance-Sparrow vs the exact BRDF (Heidrich & Seidel 1999, coarse sphere)",
            scene: SPHERE,
            truth: TORRANCE_SPARROW_PER_PIXEL,
            truth_target: "wgsl",
            variants: vec![
                v("heidrich_seidel_fixed9", HEIDRICH_SEIDEL, "geforce3", Fixed9, "F·D and G/(π cos β) from 8-bit textures at per-vertex cosines, 8-bit maths"),
                v("heidrich_seidel_f32", HEIDRICH_SEIDEL, "geforce3", F32, "the same factor textures in float maths"),
                v("heidrich_seidel_exact", HEIDRICH_SEIDEL, "geforce3", Exact, "exact factors at the per-vertex cosines, interpolated without renormalization"),
                v("torrance_sparrow_per_pixel_f32", TORRANCE_SPARROW_PER_PIXEL, "wgsl", F32, "the 8-bit factor textures at per-pixel cosines (dependent reads)"),
            ],
        },
    ]
}
