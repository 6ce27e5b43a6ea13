//! Held-out user programs of the seventeenth session
//! (`tests/data/heldout_seventeenth_ref/`): multipass blending over
//! geometry that hides itself — three balls in a row over a floor, the
//! farthest drawn first, and a ball over a floor under four lights. Two
//! terms each accumulated (`⊕[add]`) from the first write into a fresh
//! framebuffer; two perturbed projections (`π*`) with nothing drawn under
//! `π`; an ambient and a diffuse term accumulated, then modulated in the
//! blender by a texture; a program written for light 0 accumulated from
//! its first write on a scene of four lights (one pass per light, some
//! culled per object); the static viewpoint of eq. (10) after an
//! accumulation; and holes cut by a discard (`c ? …`) in an accumulation
//! from the first write on (through a hole, the surface behind). Each renders alike on the CPU, wgpu and the independent
//! reference on every target its header names, and wgpu runs every one
//! (`three_way_heldout::renders_alike_everywhere_in`).

use crate::three_way_heldout::held_out_everywhere_in;

held_out_everywhere_in!("heldout_seventeenth_ref":
    accum_two_terms,
    jitter_pair,
    ambient_then_modulate,
    lights_added_first,
    static_view_pair,
    cutout_accum,
);
