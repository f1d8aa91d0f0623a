//! Statistics of the difference between two images, for GPU-against-reference checks.

use image::RgbaImage;

/// Per-pixel difference statistics over the RGB channels, in units of 1/255.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageDiff {
    /// Mean absolute difference over every channel of every pixel.
    pub mean: f64,
    /// 99th percentile of the per-pixel maximum channel difference.
    pub p99: f64,
    /// Largest channel difference.
    pub max: f64,
    /// Fraction of pixels differing by more than 16/255 in some channel.
    pub frac_over_16: f64,
}

/// Compares two images of the same size; `None` if the sizes differ.
pub fn diff(a: &RgbaImage, b: &RgbaImage) -> Option<ImageDiff> {
    if a.dimensions() != b.dimensions() {
        return None;
    }
    let mut sum = 0u64;
    let mut per_pixel: Vec<u8> = Vec::with_capacity(a.len() / 4);
    for (pa, pb) in a.pixels().zip(b.pixels()) {
        let mut m = 0u8;
        for c in 0..3 {
            let d = pa.0[c].abs_diff(pb.0[c]);
            sum += u64::from(d);
            m = m.max(d);
        }
        per_pixel.push(m);
    }
    let n = per_pixel.len().max(1);
    per_pixel.sort_unstable();
    let p99 = per_pixel[((n as f64 * 0.99) as usize).min(n - 1)];
    let over = per_pixel.iter().filter(|&&d| d > 16).count();
    Some(ImageDiff {
        mean: sum as f64 / (3 * n) as f64,
        p99: f64::from(p99),
        max: f64::from(per_pixel.last().copied().unwrap_or(0)),
        frac_over_16: over as f64 / n as f64,
    })
}

/// An image of the absolute difference, amplified 4x, for looking at failures.
pub fn difference_image(a: &RgbaImage, b: &RgbaImage) -> RgbaImage {
    let (w, h) = a.dimensions();
    RgbaImage::from_fn(w, h, |x, y| {
        let pa = a.get_pixel(x, y).0;
        let pb = b.get_pixel_checked(x, y).map_or([0; 4], |p| p.0);
        let d = |c: usize| pa[c].abs_diff(pb[c]).saturating_mul(4);
        image::Rgba([d(0), d(1), d(2), 255])
    })
}
