//! Held-out user programs of the fifteenth session
//! (`tests/data/heldout_fifteenth/`), written as a new user would and not
//! among the examples, with the examples' images: an alpha-tested decal
//! lit per vertex, a two-texture `interpolate` under Gouraud light, an
//! emboss bump from two height lookups, a Schlick-Fresnel `mix` of a
//! colour and a cube map, hemisphere light from the normal's y, a light map
//! × base × detail at 2×, two explicitly indexed lights, half-Lambert
//! squared, a baked two-dimensional highlight table indexed by a shader's
//! channels, four terms accumulated by `⊕[add]`, a screen pass grading a
//! framebuffer, a texture's red channel driving a `lerp` of two tints, a
//! stencil mask from a texture's green, and (on wgsl) a projected cookie
//! under the light's intensity, a float framebuffer tonemapped, an
//! Oren–Nayar-like shader, gloss in alpha and cel shading with a rim. Each
//! renders alike on the CPU, wgpu and the independent reference on every
//! target its header names (`three_way_heldout::renders_alike_in`).

use crate::three_way_heldout::held_out_in;

held_out_in!("heldout_fifteenth":
    decal_cutout,
    aniso_strip,
    emboss,
    fresnel_env,
    hemisphere,
    lightmap_detail,
    two_lights,
    wrap_lambert,
    ward_table,
    accumulate4,
    screen_tone,
    swizzle_mix,
    stencil_mask,
    spot_cookie_atten,
    float_fb,
    oren_nayarish,
    gloss_alpha,
    toon_rim,
);
