!!TS1.0
texture_1d();
texture_2d();
texture_rectangle();
texture_3d();
