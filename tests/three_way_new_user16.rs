//! Held-out user programs of the sixteenth session
//! (`tests/data/heldout_sixteenth/`), written as a new user would and not
//! among the examples: Gooch shading with a smoothstep rim, procedural
//! stripes (`fract`, `step`), a decal laid by `⊕[decal]` over lit wood,
//! textured Blinn-Phong, exponential fog per vertex, a light-0 program on
//! four lights, dot3 with a normalization cube map under `⊕`, two-sided
//! light with `sign`/`abs`, uniforms scaling a detail map at 2×, paper
//! `⊕[interpolate]` over wood plus an accumulated ambient, a computed
//! sphere-map reflection, three fixed-function layers (`⊕[add_signed]`, a
//! light map on the second coordinate set), a shadow map written `≤`, and
//! two explicit lights over a texture. Each renders alike on the CPU, wgpu
//! and the independent reference on every target its header names
//! (`three_way_heldout::renders_alike_in`).

use crate::three_way_heldout::held_out_in;

held_out_in!("heldout_sixteenth":
    gooch,
    stripes,
    decal_mode,
    blinn_tex,
    exp_fog,
    lights4_highlight,
    dot3_env,
    sign_abs,
    uniform_tint,
    paper_interp,
    mirror_sphere,
    layers3,
    shadow_lit,
    four_lights_tex,
);
