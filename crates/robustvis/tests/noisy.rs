//! The robust operator against plain HPR on noisy synthetic scenes with analytic visibility:
//! `cloud::synth`'s ball in front of a square (the ball's shadow on the square is the
//! occlusion) and the unit sphere, noise along the normals by `cloud::degrade` (seeded), the
//! truth of each noisy point its clean source's analytic visibility.
//!
//! What the paper leads us to expect (Mehra et al. 2010, project page: "comparison of
//! visibility results by original HPR operator and robust HPR operator on point clouds ...
//! corrupted with uniform random perturbations in the normal direction"): HPR loses visible
//! points under noise (false negatives) where the robust operator keeps them, its errors left
//! near silhouettes. The margins asserted below are the measured ones with slack; the numbers
//! are in each test's comment.

use cloud::degrade::{Degradation, Unit};
use cloud::glam::DVec3;
use cloud::synth::{SpherePlane, sphere_plane_scene, sphere_point_visible, sphere_scene};
use cloud::{PointCloud, degrade};

fn f1(predicted: &[u32], truth: &[bool]) -> f64 {
    let tp = predicted.iter().filter(|&&i| truth[i as usize]).count() as f64;
    let n_true = truth.iter().filter(|&&t| t).count() as f64;
    let n_pred = predicted.len() as f64;
    if n_true + n_pred == 0.0 {
        return 1.0;
    }
    2.0 * tp / (n_true + n_pred)
}

fn noisy(clean: &PointCloud, sigma: f64, seed: u64) -> degrade::Degraded {
    let steps = [Degradation::Noise {
        sigma,
        unit: Unit::Spacing,
        along_normal: true,
    }];
    degrade::apply(clean, &steps, seed).expect("degraded")
}

/// HPR (exact `own` hull) at γ, and at `hpr::auto`'s γ.
fn hpr_f1(points: &[DVec3], eye: DVec3, gamma: f64, truth: &[bool]) -> f64 {
    let params = hpr::HprParams {
        kernel: hpr::Kernel::Linear(hpr::Radius::Gamma(gamma)),
        ..hpr::HprParams::default()
    };
    let own = hull::by_name("own").expect("own");
    let v = hpr::visible(points, eye, &params, own.as_ref()).expect("hpr");
    f1(&v.visible, truth)
}

fn hpr_auto_gamma(points: &[DVec3], eye: DVec3) -> f64 {
    let scale = hpr::auto::CloudScale::of(points).expect("scale");
    let m = points
        .iter()
        .map(|p| (*p - eye).length())
        .fold(0.0, f64::max);
    hpr::auto::auto_gamma(&scale, eye, m)
}

/// The robust operator with the automatic rule (band in noise deviations).
fn robust_f1(points: &[DVec3], eye: DVec3, band: f64, truth: &[bool]) -> (f64, f64) {
    let scale = robustvis::bounds::CloudScale::of(points, 0).expect("scale");
    let m = points
        .iter()
        .map(|p| (*p - eye).length())
        .fold(0.0, f64::max);
    let rule = robustvis::bounds::AutoRule { band, noise: None };
    let tau = robustvis::bounds::auto(&scale, &rule, eye, m).tolerance;
    let choice = robustvis::bounds::auto(
        &scale,
        &robustvis::bounds::AutoRule {
            band: 1.0,
            noise: Some(tau),
        },
        eye,
        m,
    );
    let v = robustvis::visible(points, eye, choice.radius, tau).expect("robust");
    (f1(&v.visible, truth), choice.gamma(m))
}

const GAMMAS: [f64; 9] = [1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 4.5, 5.0, 5.5];

struct Row {
    robust: f64,
    hpr_auto: f64,
    hpr_best: f64,
}

fn measure(
    clean: &PointCloud,
    visible: &dyn Fn(DVec3, DVec3) -> bool,
    eyes: &[DVec3],
    sigma: f64,
) -> Vec<Row> {
    let mut rows = Vec::new();
    for (k, &eye) in eyes.iter().enumerate() {
        let clean_truth: Vec<bool> = clean.positions.iter().map(|&p| visible(p, eye)).collect();
        let d = if sigma > 0.0 {
            noisy(clean, sigma, 24 + k as u64)
        } else {
            degrade::apply(clean, &[], 0).expect("clean")
        };
        let truth = d.truth_of(&clean_truth);
        let pts = &d.cloud.positions;
        let (robust, g) = robust_f1(pts, eye, 3.0, &truth);
        let ga = hpr_auto_gamma(pts, eye);
        let hpr_auto = hpr_f1(pts, eye, ga, &truth);
        let hpr_best = GAMMAS
            .iter()
            .map(|&g| hpr_f1(pts, eye, g, &truth))
            .fold(0.0, f64::max);
        eprintln!(
            "sigma {sigma} eye {eye}: robust {robust:.4} (γ {g:.2}) hpr-auto {hpr_auto:.4} (γ {ga:.2}) hpr-best {hpr_best:.4}"
        );
        rows.push(Row {
            robust,
            hpr_auto,
            hpr_best,
        });
    }
    rows
}

fn mean(rows: &[Row], f: impl Fn(&Row) -> f64) -> f64 {
    rows.iter().map(f).sum::<f64>() / rows.len() as f64
}

fn sphere_plane() -> (PointCloud, SpherePlane) {
    let (scene, g) = sphere_plane_scene(8_000, 12_000, 5);
    (scene.cloud, g)
}

const EYES: [DVec3; 3] = [
    DVec3::new(0.4, -2.6, 2.4),
    DVec3::new(2.8, 0.6, 1.6),
    DVec3::new(-0.3, 0.2, 4.0),
];

/// Measured (20,000 points, 3 views, band 3σ̂, both with their automatic rules): mean F1 at
/// σ = 0.5 spacings robust 0.9233, HPR (`hpr::auto`'s γ) 0.8655 (+0.058); at σ = 1 robust
/// 0.8542, HPR 0.7440 (+0.110); robust better on every view. HPR at its best γ of the grid
/// 1.5..5.5 *chosen on the noisy data against the truth* (an oracle no user has) is better
/// still: 0.9547 and 0.9253; the rule's R (γ 2.0-2.3) is smaller than that oracle's.
#[test]
fn under_normal_noise_the_robust_operator_beats_hpr_on_the_ball_and_square() {
    let (clean, g) = sphere_plane();
    for (sigma, margin) in [(0.5, 0.04), (1.0, 0.08)] {
        let rows = measure(&clean, &|p, e| g.visible(p, e), &EYES, sigma);
        let (r, a, b) = (
            mean(&rows, |r| r.robust),
            mean(&rows, |r| r.hpr_auto),
            mean(&rows, |r| r.hpr_best),
        );
        eprintln!("sigma {sigma}: mean robust {r:.4} hpr-auto {a:.4} hpr-best {b:.4}");
        assert!(r >= a + margin, "sigma {sigma}: robust {r} hpr-auto {a}");
        assert!(
            rows.iter().all(|row| row.robust > row.hpr_auto),
            "sigma {sigma}"
        );
        // The oracle-tuned HPR stays ahead by less than 0.1 (measured 0.031, 0.071).
        assert!(r >= b - 0.1, "sigma {sigma}: robust {r} hpr-best {b}");
    }
}

/// Measured: clean, the noise estimate is near 0, so τ ≈ 0 and the rule's γ is HPR's: mean F1
/// 0.9746 for both, 0.9846 for HPR at its oracle-best γ. The unit sphere at σ = 1 spacing
/// (6,000 points, eye at distance 3): robust 0.689, HPR (auto) 0.618 (HPR's oracle best 0.887).
#[test]
fn noise_free_the_robust_operator_is_not_much_worse_than_hpr() {
    let (clean, g) = sphere_plane();
    let rows = measure(&clean, &|p, e| g.visible(p, e), &EYES, 0.0);
    let (r, a, b) = (
        mean(&rows, |r| r.robust),
        mean(&rows, |r| r.hpr_auto),
        mean(&rows, |r| r.hpr_best),
    );
    eprintln!("clean: mean robust {r:.4} hpr-auto {a:.4} hpr-best {b:.4}");
    assert!(
        r >= a - 0.005 && r >= b - 0.02,
        "clean: robust {r} hpr {a} best {b}"
    );
    let sphere = sphere_scene(6_000).cloud;
    let rows = measure(
        &sphere,
        &|p, e| sphere_point_visible(DVec3::ZERO, p, e),
        &[DVec3::new(0.0, 0.0, 3.0)],
        1.0,
    );
    eprintln!(
        "sphere sigma 1: robust {:.4} hpr-auto {:.4}",
        rows[0].robust, rows[0].hpr_auto
    );
    assert!(rows[0].robust >= rows[0].hpr_auto + 0.04, "sphere");
}
