//! The operator against a brute force of the same rule: every level's pixel recomputed as
//! the nearest point of its level-0 block (no pyramid), every neighbour cell of every level
//! enumerated, angles by `acos` and the open fraction as the mean of 1 − cos θ_s.

use super::*;
use crate::testutil::{MODELS, camera, layers};

fn levels_until_one_pixel(w: u32, h: u32, levels: u32) -> u32 {
    let mut n = 1;
    while n < levels && !(w.div_ceil(1 << (n - 1)) == 1 && h.div_ceil(1 << (n - 1)) == 1) {
        n += 1;
    }
    n
}

fn block_nearest(b: &DepthBuffer, l: u32, cx: i64, cy: i64) -> u32 {
    let s = 1i64 << l;
    let (w, h) = (i64::from(b.width), i64::from(b.height));
    let mut best = EMPTY;
    let mut best_key = (f64::INFINITY, u32::MAX);
    for y in cy * s..((cy + 1) * s).min(h) {
        for x in cx * s..((cx + 1) * s).min(w) {
            let j = b.point[(y * w + x) as usize];
            if j != EMPTY {
                let key = (b.depth[j as usize], j);
                if key < best_key {
                    best_key = key;
                    best = j;
                }
            }
        }
    }
    best
}

fn brute(points: &[DVec3], b: &DepthBuffer, viewer: Viewer, p: &PintusParams) -> Vec<f64> {
    use std::f64::consts::FRAC_PI_2;
    let (w, h) = (i64::from(b.width), i64::from(b.height));
    let levels = levels_until_one_pixel(b.width, b.height, p.levels);
    let hw = i64::from(p.half_width);
    let mut out = vec![f64::NAN; b.point.len()];
    for y in 0..h {
        for x in 0..w {
            let i = b.point[(y * w + x) as usize];
            if i == EMPTY {
                continue;
            }
            let mut theta = vec![FRAC_PI_2; p.sectors as usize];
            for l in 0..levels {
                let (lw, lh) = ((w + (1 << l) - 1) >> l, (h + (1 << l) - 1) >> l);
                let (lx, ly) = (x >> l, y >> l);
                for cy in 0..lh {
                    for cx in 0..lw {
                        let in_x = if b.wrap_x {
                            (-hw..=hw).any(|d| (lx + d).rem_euclid(lw) == cx)
                        } else {
                            (cx - lx).abs() <= hw
                        };
                        if !in_x || (cy - ly).abs() > hw {
                            continue;
                        }
                        let j = block_nearest(b, l, cx, cy);
                        if j == EMPTY || j == i {
                            continue;
                        }
                        let v = points[j as usize] - points[i as usize];
                        let c = (viewer.toward(points[i as usize]).dot(v) / v.length())
                            .clamp(-1.0, 1.0);
                        let angle = c.acos();
                        let (qx, qy) = b.xy(b.pixel_of[j as usize]);
                        let (ox, oy) = b.offset(x, y, qx, qy);
                        if angle < FRAC_PI_2 && (ox, oy) != (0, 0) {
                            let s = sector(ox, oy, p.sectors);
                            theta[s] = theta[s].min(angle);
                        }
                    }
                }
            }
            out[(y * w + x) as usize] =
                theta.iter().map(|t| 1.0 - t.cos()).sum::<f64>() / f64::from(p.sectors);
        }
    }
    out
}

#[test]
fn matches_the_brute_force_on_every_model_and_setting() {
    let points = layers(400, 7);
    let settings = [
        PintusParams::default(),
        PintusParams {
            sectors: 4,
            half_width: 1,
            levels: 1,
            ..PintusParams::default()
        },
        PintusParams {
            sectors: 16,
            half_width: 3,
            levels: 6,
            ..PintusParams::default()
        },
    ];
    let mut totals = (0usize, 0usize);
    for model in MODELS {
        for (w, h) in [(40, 30), (33, 17)] {
            let cam = camera(model, w, h);
            let b = DepthBuffer::build(&points, &cam).expect("buffer");
            for p in &settings {
                let pyr = Pyramid::build(&b, p.levels);
                let fast = open_fraction(&points, &b, &pyr, Viewer::of(&cam), p);
                let slow = brute(&points, &b, Viewer::of(&cam), p);
                let mut compared = 0;
                for (k, (f, s)) in fast.iter().zip(&slow).enumerate() {
                    assert_eq!(f.is_nan(), s.is_nan(), "{model} pixel {k}");
                    if !f.is_nan() {
                        assert!((f - s).abs() < 1e-9, "{model} {p:?} pixel {k}: {f} vs {s}");
                        compared += 1;
                    }
                }
                assert!(compared > 50, "{model}: only {compared} occupied pixels");
                let lo = fast.iter().filter(|v| **v < 0.25).count();
                let hi = fast.iter().filter(|v| **v >= 0.25).count();
                totals.0 += lo;
                totals.1 += hi;
            }
        }
    }
    // The rule separates something: neither all pixels low nor all high.
    assert!(totals.0 > 0 && totals.1 > 0, "{totals:?}");
}

#[test]
fn a_point_behind_a_ring_of_nearer_points_is_hidden_and_they_are_not() {
    // A far point at the centre, eight near points around it one pixel away on screen.
    let cam = camera("orthographic", 21, 21);
    let centre = cam.eye + cam.forward() * 3.0;
    let px = 3.0 / 21.0;
    let mut pts = vec![centre];
    for (dx, dy) in [
        (-1, -1),
        (0, -1),
        (1, -1),
        (-1, 0),
        (1, 0),
        (-1, 1),
        (0, 1),
        (1, 1),
    ] {
        pts.push(
            cam.eye
                + cam.forward() * 1.0
                + cam.right() * (f64::from(dx) * px)
                + cam.down() * (f64::from(dy) * px),
        );
    }
    let v = visible(&pts, &cam, &PintusParams::default()).expect("run");
    assert!(!v.visible.contains(&0), "the far point is hidden");
    assert_eq!(v.visible, (1..9).collect::<Vec<u32>>());
    assert!(v.score[0] < 0.05, "{}", v.score[0]);
    assert!(v.score[1] > 0.9);
}

#[test]
fn bad_parameters_are_errors() {
    let pts = layers(10, 1);
    let cam = camera("pinhole", 16, 16);
    for p in [
        PintusParams {
            sectors: 0,
            ..PintusParams::default()
        },
        PintusParams {
            half_width: 0,
            ..PintusParams::default()
        },
        PintusParams {
            levels: 0,
            ..PintusParams::default()
        },
        PintusParams {
            levels: 99,
            ..PintusParams::default()
        },
        PintusParams {
            threshold: f64::NAN,
            ..PintusParams::default()
        },
        PintusParams {
            threshold: -0.1,
            ..PintusParams::default()
        },
        PintusParams {
            depth_tolerance: f64::INFINITY,
            ..PintusParams::default()
        },
    ] {
        let e = visible(&pts, &cam, &p).expect_err("bad parameter");
        assert!(matches!(e, Error::InvalidParameter { .. }), "{p:?}: {e}");
    }
}
