!!TS1.0
cull_fragment(LESS_THAN_ZERO, GEQUAL_TO_ZERO, LESS_THAN_ZERO, GEQUAL_TO_ZERO);
nop();
nop();
nop();
