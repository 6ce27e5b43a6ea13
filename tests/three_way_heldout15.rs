//! Held-out user programs of the fifteenth session
//! (`tests/data/heldout_fifteenth_ref/`), written as a new user would and
//! not among the examples: deferred toon shading and a two-lobe highlight
//! through float G-buffers (fat framebuffers), satin shaded from a fat
//! texture, a chrome ball and a sky-lit plastic ball in a scene's
//! dual-paraboloid sky, a shadow map and shadow volumes over a floor,
//! lighting baked over texels under a tiled base, Gooch warm-to-cool
//! shading, a slide projected by one spot with a second as fill, a frame
//! rendered into a texture and cross-faded, and a Fresnel weight passed
//! through the framebuffer's alpha. Each renders alike on the CPU, wgpu
//! and the independent reference on every target its header names, in f32
//! (and fixed9 on the combiner targets), on at least a tenth of the frame,
//! most of it lit (`three_way_heldout::renders_alike_in`).

use crate::three_way_heldout::held_out_in;

held_out_in!("heldout_fifteenth_ref":
    deferred_toon_ink,
    deferred_two_lobe,
    fat_texels_satin,
    sky_chrome_ball,
    sky_ambient_plastic,
    shadow_map_spot_floor,
    stencil_shadow_gloss,
    baked_light_texels,
    gooch_warm_cool,
    slide_and_fill,
    frame_echo,
    fresnel_alpha_pass,
);
