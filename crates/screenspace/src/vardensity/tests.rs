//! The operator against a brute force of the same rule: every occupied pixel within reach
//! sorted by (distance², pixel index), the k first taken, the score by its formula.

use super::*;
use crate::testutil::{MODELS, camera, layers};

fn brute(b: &DepthBuffer, p: &VardensityParams) -> Vec<f64> {
    let (w, h) = (i64::from(b.width), i64::from(b.height));
    let r = i64::from(p.max_radius);
    let mut out = vec![f64::NAN; b.point.len()];
    for y in 0..h {
        for x in 0..w {
            let i = b.point[(y * w + x) as usize];
            if i == EMPTY {
                continue;
            }
            let mut all = Vec::new();
            for qy in 0..h {
                for qx in 0..w {
                    let px = (qy * w + qx) as u32;
                    if (qx, qy) == (x, y) || b.point[px as usize] == EMPTY {
                        continue;
                    }
                    let (dx, dy) = b.offset(x, y, qx, qy);
                    if dx.abs().max(dy.abs()) <= r {
                        all.push((dx * dx + dy * dy, px));
                    }
                }
            }
            all.sort_unstable();
            all.truncate(p.k as usize);
            let d = b.depth[i as usize];
            let ds: Vec<f64> = all
                .iter()
                .map(|&(_, px)| b.depth[b.point[px as usize] as usize])
                .collect();
            let v = if ds.is_empty() {
                1.0
            } else {
                let lo = ds.iter().copied().fold(f64::INFINITY, f64::min);
                let hi = ds.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                if d <= lo {
                    1.0
                } else if hi == lo {
                    0.0
                } else {
                    (-((d - lo) / (hi - lo)).powi(2)).exp()
                }
            };
            out[(y * w + x) as usize] = v;
        }
    }
    out
}

#[test]
fn matches_the_brute_force_on_every_model_and_setting() {
    let points = layers(300, 11);
    let settings = [
        VardensityParams::default(),
        VardensityParams {
            k: 1,
            max_radius: 2,
            ..VardensityParams::default()
        },
        VardensityParams {
            k: 24,
            max_radius: 40,
            ..VardensityParams::default()
        },
    ];
    let mut totals = (0usize, 0usize);
    for model in MODELS {
        for (w, h) in [(40, 30), (33, 17), (8, 64)] {
            let cam = camera(model, w, h);
            let b = DepthBuffer::build(&points, &cam).expect("buffer");
            for p in &settings {
                let fast = pixel_scores(&b, p);
                let slow = brute(&b, p);
                for (k, (f, s)) in fast.iter().zip(&slow).enumerate() {
                    assert_eq!(f.is_nan(), s.is_nan(), "{model} pixel {k}");
                    if !f.is_nan() {
                        assert!((f - s).abs() < 1e-12, "{model} {p:?} pixel {k}: {f} vs {s}");
                    }
                }
                let lo = fast.iter().filter(|v| **v < 0.1).count();
                let hi = fast.iter().filter(|v| **v >= 0.1).count();
                totals.0 += lo;
                totals.1 += hi;
            }
        }
    }
    // The rule separates something: neither all pixels low nor all high.
    assert!(totals.0 > 0 && totals.1 > 0, "{totals:?}");
}

#[test]
fn the_score_follows_its_formula() {
    assert_eq!(score(1.0, [].into_iter()), 1.0);
    assert_eq!(score(1.0, [1.0, 2.0].into_iter()), 1.0);
    assert_eq!(score(3.0, [2.0, 2.0].into_iter()), 0.0);
    assert!((score(2.0, [1.0, 2.0].into_iter()) - (-1.0f64).exp()).abs() < 1e-15);
    assert!(score(10.0, [1.0, 1.1].into_iter()) < 1e-100);
}

#[test]
fn bad_parameters_are_errors() {
    let pts = layers(10, 1);
    let cam = camera("spherical", 16, 8);
    for p in [
        VardensityParams {
            k: 0,
            ..VardensityParams::default()
        },
        VardensityParams {
            max_radius: 0,
            ..VardensityParams::default()
        },
        VardensityParams {
            threshold: f64::NAN,
            ..VardensityParams::default()
        },
        VardensityParams {
            threshold: 1.5,
            ..VardensityParams::default()
        },
        VardensityParams {
            depth_tolerance: -1.0,
            ..VardensityParams::default()
        },
    ] {
        let e = visible(&pts, &cam, &p).expect_err("bad parameter");
        assert!(matches!(e, Error::InvalidParameter { .. }), "{p:?}: {e}");
    }
}
