!!TS1.0
texture_2d();
offset_rectangle_scale(tex0, 1, 0, 0, 1, 2, 0);
dependent_ar(tex1);
dependent_gb(tex0);
