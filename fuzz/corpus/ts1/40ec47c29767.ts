!!TS1.0
texture_2d();
dot_product_3d_1of3(expand(tex0));
dot_product_3d_2of3(expand(tex0));
dot_product_3d_3of3(expand(tex0));
