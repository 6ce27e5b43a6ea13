!!TS1.0
texture_cube_map();
pass_through();
nop();
cull_fragment(GEQUAL_TO_ZERO, LESS_THAN_ZERO, GEQUAL_TO_ZERO, LESS_THAN_ZERO);
