!!TS1.0
texture_2d();
dot_product_cube_map_and_reflect_cube_map_const_eye_1of3(tex0, 0.5, 0.5, -0.5);
dot_product_cube_map_and_reflect_cube_map_const_eye_2of3(tex0);
dot_product_cube_map_and_reflect_cube_map_const_eye_3of3(tex0);
