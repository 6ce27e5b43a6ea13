//! How far one rendered image is from another ([`compare`]).

use crate::renderer::Framebuffer;

/// The error of `test` against `reference` over RGB: max abs, RMSE, PSNR.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ErrorReport {
    pub max_abs: f32,
    pub rmse: f64,
    pub psnr: f64,
}

/// Compares two images of the same size; both are clamped to [0, 1] first
/// (what a display shows).
pub fn compare(reference: &Framebuffer, test: &Framebuffer) -> ErrorReport {
    let clamp = |v: Vec<[f32; 4]>| {
        v.into_iter().map(|p| p.map(|c| if c.is_nan() { 0.0 } else { c.clamp(0.0, 1.0) })).collect::<Vec<_>>()
    };
    let a = clamp(reference.to_rgba_f32());
    let b = clamp(test.to_rgba_f32());
    let e = crate::renderer::image_error(&a, &b);
    let rmse = if e.psnr.is_infinite() { 0.0 } else { 10f64.powf(-e.psnr / 20.0) };
    ErrorReport { max_abs: e.max_abs, rmse, psnr: e.psnr }
}
