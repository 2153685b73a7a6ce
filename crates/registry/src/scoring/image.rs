//! Image metrics beside [`super::sets`]: how far a render is from a reference render of the same
//! view. PSNR is over the RGB pixels covered in either image (the background excluded, so the
//! object's screen size does not inflate it; capped at 100 dB for identical images); SSIM
//! (Wang et al. 2004) is on luma in 8 × 8 windows at a stride of 4 with C1 = (0.01·255)²,
//! C2 = (0.03·255)², averaged over the windows that touch the reference's covered pixels; the
//! hole fraction is the share of the reference's covered pixels the image leaves empty.

use splat::render::Image;

/// PSNR over the pixels covered in either image, capped at 100 dB.
pub fn psnr(reference: &Image, image: &Image) -> f64 {
    let (mut se, mut n) = (0.0f64, 0usize);
    for (i, (&a, &b)) in reference.covered.iter().zip(&image.covered).enumerate() {
        if a || b {
            for c in 0..3 {
                let d = f64::from(reference.rgb[3 * i + c]) - f64::from(image.rgb[3 * i + c]);
                se += d * d;
            }
            n += 3;
        }
    }
    if n == 0 || se == 0.0 {
        return 100.0;
    }
    (10.0 * (255.0f64 * 255.0 / (se / n as f64)).log10()).min(100.0)
}

fn luma(img: &Image) -> Vec<f64> {
    img.rgb
        .chunks_exact(3)
        .map(|p| 0.299 * f64::from(p[0]) + 0.587 * f64::from(p[1]) + 0.114 * f64::from(p[2]))
        .collect()
}

/// Mean SSIM on luma, 8 × 8 windows at stride 4, over windows touching reference coverage.
pub fn ssim(reference: &Image, image: &Image) -> f64 {
    const WIN: usize = 8;
    const STRIDE: usize = 4;
    let (c1, c2) = ((0.01f64 * 255.0).powi(2), (0.03f64 * 255.0).powi(2));
    let (w, h) = (reference.width as usize, reference.height as usize);
    let (a, b) = (luma(reference), luma(image));
    let (mut sum, mut count) = (0.0, 0usize);
    let mut y = 0;
    while y + WIN <= h {
        let mut x = 0;
        while x + WIN <= w {
            let mut touched = false;
            let (mut sa, mut sb, mut saa, mut sbb, mut sab) = (0.0, 0.0, 0.0, 0.0, 0.0);
            for yy in y..y + WIN {
                for xx in x..x + WIN {
                    let i = yy * w + xx;
                    touched |= reference.covered[i];
                    let (p, q) = (a[i], b[i]);
                    sa += p;
                    sb += q;
                    saa += p * p;
                    sbb += q * q;
                    sab += p * q;
                }
            }
            if touched {
                let n = (WIN * WIN) as f64;
                let (ma, mb) = (sa / n, sb / n);
                let va = saa / n - ma * ma;
                let vb = sbb / n - mb * mb;
                let cov = sab / n - ma * mb;
                sum += ((2.0 * ma * mb + c1) * (2.0 * cov + c2))
                    / ((ma * ma + mb * mb + c1) * (va + vb + c2));
                count += 1;
            }
            x += STRIDE;
        }
        y += STRIDE;
    }
    if count == 0 { 1.0 } else { sum / count as f64 }
}

/// Share of the reference's covered pixels that `image` leaves empty.
pub fn hole_fraction(reference: &Image, image: &Image) -> f64 {
    let covered = reference.covered.iter().filter(|&&c| c).count();
    let holes = reference
        .covered
        .iter()
        .zip(&image.covered)
        .filter(|&(&a, &b)| a && !b)
        .count();
    if covered == 0 {
        0.0
    } else {
        holes as f64 / covered as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(w: u32, h: u32, f: impl Fn(u32, u32) -> Option<[u8; 3]>) -> Image {
        let mut rgb = Vec::new();
        let mut covered = Vec::new();
        for y in 0..h {
            for x in 0..w {
                let c = f(x, y);
                covered.push(c.is_some());
                rgb.extend(c.unwrap_or([255, 255, 255]));
            }
        }
        Image {
            width: w,
            height: h,
            rgb,
            covered,
        }
    }

    #[test]
    fn identical_images_score_perfectly() {
        let a = image(32, 32, |x, y| {
            (x > 4 && y > 4).then_some([x as u8 * 7, 90, 30])
        });
        assert_eq!(psnr(&a, &a), 100.0);
        assert!((ssim(&a, &a) - 1.0).abs() < 1e-12);
        assert_eq!(hole_fraction(&a, &a), 0.0);
    }

    #[test]
    fn known_error_gives_known_psnr_and_holes() {
        let a = image(16, 16, |_, _| Some([100, 100, 100]));
        let b = image(16, 16, |x, _| (x < 8).then_some([110, 110, 110]));
        // Left half off by 10, right half empty (white, 155 away): MSE = (100 + 155²) / 2.
        let mse = (100.0 + 155.0f64 * 155.0) / 2.0;
        assert!((psnr(&a, &b) - 10.0 * (255.0f64 * 255.0 / mse).log10()).abs() < 1e-9);
        assert!((hole_fraction(&a, &b) - 0.5).abs() < 1e-12);
        assert!(ssim(&a, &b) < 0.9);
    }
}
