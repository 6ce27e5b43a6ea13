!!TS1.0
texture_2d();
dot_product_depth_replace_1of2(expand(tex0));
dot_product_depth_replace_2of2(expand(tex0));
