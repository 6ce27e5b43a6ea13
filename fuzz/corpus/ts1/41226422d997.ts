!!TS1.0
texture_2d();
dot_product_rectangle_1of2(tex0);
dot_product_rectangle_2of2(tex0);
