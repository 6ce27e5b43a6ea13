//! Held-out user programs of the sixteenth session
//! (`tests/data/heldout_sixteenth_ref/`), each of a kind the independent
//! reference refused or wgpu could not run before: shadow volumes counted
//! in front of the surface (z-pass, `<` and `≤`) and behind it with `≥`,
//! over one ball and over two whose shadows overlap (a count of 2); a
//! program written for light 0 on scenes of three and four lights with
//! shadow volumes, a shadow map, texture shading, a stencil decal and a
//! frame rendered into a texture; a 3-D texture filled over its texels and
//! a baked one (`bake`), read trilinearly at the object's position; and a
//! stencil written over the screen. Each renders alike on the CPU, wgpu
//! and the reference on every target its header names, and wgpu runs
//! every one of them (`three_way_heldout::renders_alike_everywhere_in`).

use crate::three_way_heldout::held_out_everywhere_in;

held_out_everywhere_in!("heldout_sixteenth_ref":
    zpass_shadow_floor,
    zpass_two_shadows,
    zfail_inclusive_gloss,
    zpass_inclusive_facing,
    lamp_shadow_volumes,
    lamp_shadow_map,
    lamp_texture_shading,
    lamp_stencil_decal,
    lamp_frame_echo,
    volume_texel_rings,
    volume_baked_marble,
    stencil_screen_vignette,
);
