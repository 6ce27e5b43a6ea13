!!TS1.0
texture_2d();
dot_product_cube_map_1of3(expand(tex0));
dot_product_cube_map_2of3(expand(tex0));
dot_product_cube_map_3of3(expand(tex0));
