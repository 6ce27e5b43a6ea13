!!TS1.0
texture_2d();
offset_2d(tex0, 0.5, -0.25, 0.125, 1);
offset_2d_scale(tex1, 1, 0, 0, 1, 0.5, -0.25);
offset_rectangle(tex0, 2, 0, 0, 2);
