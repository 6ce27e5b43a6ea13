//! Held-out user programs of the thirteenth session
//! (`tests/data/heldout_thirteenth/`), written as a user would and not
//! among the examples: a brick torus filtered trilinearly under a
//! parameterized highlight, two lamps summed inside one `δ` on the cube, a
//! slide projected onto a textured ball, a cube-map reflection `mix`ed by
//! a saturated Fresnel weight, lighting accumulated in a float framebuffer
//! named `Hdr`, gloss in a texture's alpha with a tuple-returning shader
//! read by channel, a floor texture over the sum of four indexed lamps, a
//! 16-bit base under a modulate-2× detail map with a `let`, and a tiled
//! floor receding to the horizon. Most are minified `trilinear` textures:
//! each is compared against the reference's level-of-detail range (GL
//! §3.8.8) on at least a tenth of the frame, in f32 on every target its
//! header names and in fixed9 on the combiner targets
//! (`three_way_heldout::renders_alike_in`).

use crate::three_way_heldout::{data, renders_alike_in};

macro_rules! held_out {
    ($($name:ident),* $(,)?) => {
        $(
            #[test]
            fn $name() {
                renders_alike_in(&data("heldout_thirteenth"), stringify!($name)).unwrap_or_else(|e| panic!("{e}"));
            }
        )*
    };
}

held_out!(
    brick_torus_trilinear,
    two_lamps_one_delta,
    slide_projector_sphere,
    chrome_fresnel_mix,
    hdr_accumulation,
    gloss_in_alpha_swizzle,
    lamp_row_floor,
    deep_detail_sixteen_bit,
    wet_floor_reflection,
);

/// Every program of the folder has its named test above.
#[test]
fn every_thirteenth_held_out_program_has_a_test() {
    let here = include_str!("three_way_heldout13.rs");
    for entry in std::fs::read_dir(data("heldout_thirteenth")).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "shd") {
            let stem = path.file_stem().unwrap().to_string_lossy().to_string();
            assert!(here.contains(&format!("    {stem},\n")), "{stem} has no test");
        }
    }
}
