//! Held-out user programs of the eighteenth session
//! (`tests/data/heldout_eighteenth/`), written as a new user would and not
//! among the examples: Blinn-Phong through a normalization cube map, GL's
//! separate specular colour, a grey and a sepia screen pass, two-sided
//! diffuse, squared-exponential fog, the texture environment's decal and
//! signed-add modes, DOT3 bump mapping in the texture environment, three
//! named lights with their intensities, diffuse light from a panorama
//! indexed by the normal, a specular power through a baked 1-D table, a
//! translucent second draw, colour uniforms, a stencil window, two spot
//! lights per vertex, a baked checkerboard, a tinted cube-map reflection,
//! Phong's reflection-vector highlight per pixel and two lights
//! accumulated over one texture; then a soft two-tone by `smoothstep`,
//! `reflect()` into a panorama, a band chosen by two conditions, a
//! uniform exponent, top-level lets, four lights into a float framebuffer
//! tone-mapped in a screen pass, `min`/`clamp` of two lights, a 16-bit
//! texture with gloss in alpha, strand lighting from the tangent and
//! alpha written then read in a screen pass.
//! Each renders alike on the CPU, wgpu and the independent reference on
//! every target its header names (`three_way_heldout::renders_alike_in`).

use crate::three_way_heldout::held_out_everywhere_in;
use shadec::numerics::Precision;

held_out_everywhere_in!("heldout_eighteenth":
    accum_two_lights_tex,
    blinn_ncube,
    checker_procedural,
    decal_mode,
    dot3_env,
    exponent_lookup,
    fog_exp2,
    glass_blend,
    grayscale_post,
    irradiance_env,
    reflect_tint,
    separate_specular,
    sepia,
    signed_detail,
    specular_power_pp,
    spot_cone,
    stencil_window,
    three_lights,
    two_sided,
    uniform_colour,
    alpha_out,
    cross_tangent,
    float_accum,
    min_clamp,
    reflect_fn,
    rgba16_tex,
    select_band,
    smooth_toon,
    top_lets,
    uniform_power,
);
