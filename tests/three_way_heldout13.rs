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

use crate::three_way_heldout::held_out_in;

held_out_in!("heldout_thirteenth":
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
