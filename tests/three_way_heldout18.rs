//! Held-out user programs of the eighteenth session
//! (`tests/data/heldout_eighteenth_ref/`): a lighting solution baked in
//! texture space for two objects that share their coordinates (on the
//! oldest target a power in several passes, drawn object by object); a
//! bumped environment map over a minified floor (a dependent lookup, each
//! lookup's level of detail its own); a solid texture repeated through
//! space; an 8-bit G-buffer (negative components clamped, on the
//! combiners too); a slide projected from light 0;
//! a cube-map reflection mixed by a rim weight with a swizzled tuple, a
//! `let` and a uniform; two framebuffers other than C cross-faded in a
//! screen pass, in fixed9 too; and a light-0 program with a `let` on a
//! scene of four lights. Each renders alike on the CPU, wgpu and the
//! independent reference on every target its header names, and wgpu runs
//! every one (`three_way_heldout::renders_alike_everywhere_in`).

use crate::three_way_heldout::held_out_everywhere_in;

held_out_everywhere_in!("heldout_eighteenth_ref":
    baked_gloss_two_objects,
    bumped_sky_floor,
    marble_repeat,
    gbuffer_rgba8_rim,
    slide_projected,
    lacquer_cube_let,
    composite_two_framebuffers,
    four_lights_saturate,
);
