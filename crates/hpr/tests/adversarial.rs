//! Exact HPR on adversarial clouds: every answer is certified (`hull::check::verify` on the
//! flipped set with the eye: a closed, consistently oriented hull with every point beneath every
//! facet) and, on small clouds, equal to the brute-force extreme points. The clouds: γ outside
//! the experiments' range (1.5 and 5.5), clouds around the eye (the eye inside the hull), points
//! on rays through the eye (exactly collinear with it before the flip), coplanar slabs,
//! duplicates in shuffled order, exactly cospherical integer points around the eye.

use cloud::glam::DVec3;
use hpr::{HprParams, Kernel, Radius};
use hull::check::{extreme_points_brute_force, verify};

/// A seeded uniform generator on [0, 1) (`cloud::rng`).
fn rng(seed: u64) -> impl FnMut() -> f64 {
    use cloud::rng::RngExt as _;
    let mut r = cloud::rng::seeded(seed, "hpr-adversarial");
    move || r.random::<f64>()
}

fn params(gamma: f64) -> HprParams {
    HprParams {
        kernel: Kernel::Linear(Radius::Gamma(gamma)),
        perturb: 0.0,
        seed: 0,
    }
}

/// Runs exact HPR, certifies the hull of the flipped set with the eye, and (for at most
/// `brute_limit` points) compares with the brute-force extreme points. Returns the visible set.
fn certified(points: &[DVec3], eye: DVec3, gamma: f64, brute_limit: usize) -> Vec<u32> {
    let own = hull::by_name("own").expect("the own hull");
    let visible = hpr::visible(points, eye, &params(gamma), own.as_ref())
        .expect("exact HPR answers")
        .visible;
    let flipped = hpr::transform::transform(points, eye, params(gamma).kernel)
        .expect("the flip")
        .points;
    assert_eq!(flipped.len(), points.len() + 1, "the eye is the last point");
    let h = hull::incremental::hull(&flipped).expect("the hull");
    verify(&flipped, &h.facets, &h.vertices).unwrap_or_else(|e| panic!("certificate: {e}"));
    let eye_index = points.len() as u32;
    let mut from_hull: Vec<u32> = h
        .vertices
        .iter()
        .copied()
        .filter(|&v| v != eye_index)
        .collect();
    from_hull = hpr::with_duplicates(points, from_hull);
    assert_eq!(
        visible, from_hull,
        "HPR's answer is the certified hull's vertices"
    );
    if points.len() <= brute_limit {
        let brute = extreme_points_brute_force(&flipped).expect("the flipped set spans 3-d");
        let brute: Vec<u32> = brute.into_iter().filter(|&v| v != eye_index).collect();
        assert_eq!(hpr::with_duplicates(points, brute), visible, "brute force");
    }
    visible
}

fn noisy_sphere(n: usize, radius: f64, noise: f64, seed: u64) -> Vec<DVec3> {
    let mut r = rng(seed);
    (0..n)
        .map(|_| {
            let z = 2.0 * r() - 1.0;
            let phi = std::f64::consts::TAU * r();
            let s = (1.0 - z * z).sqrt();
            DVec3::new(s * phi.cos(), s * phi.sin(), z) * (radius * (1.0 + noise * (r() - 0.5)))
        })
        .collect()
}

#[test]
fn gammas_outside_the_experiments_range() {
    let eye = DVec3::new(0.3, -0.2, 4.0);
    for gamma in [1.5, 5.5] {
        for seed in 0..3 {
            certified(&noisy_sphere(50, 1.0, 0.2, seed), eye, gamma, 50);
            let v = certified(&noisy_sphere(3000, 1.0, 0.05, seed), eye, gamma, 0);
            assert!(!v.is_empty());
        }
    }
}

#[test]
fn clouds_around_the_eye() {
    // The eye inside the cloud: it is not a hull vertex, every direction has a facet.
    for (gamma, seed) in [(1.5, 1), (3.0, 2), (5.5, 3)] {
        certified(
            &noisy_sphere(45, 1.0, 0.3, seed),
            DVec3::new(0.01, 0.02, -0.03),
            gamma,
            45,
        );
        let v = certified(&noisy_sphere(4000, 1.0, 0.1, seed), DVec3::ZERO, gamma, 0);
        assert!(v.len() > 100, "points all around are seen: {}", v.len());
    }
}

#[test]
fn points_on_rays_through_the_eye() {
    // Four points on each of twelve rays from the eye, with integer coordinates: exactly
    // collinear with the eye in the input, and within rounding of it after the flip, where
    // every facet through the eye meets a ray's points nearly edge-on. The brute force decides.
    let eye = DVec3::new(0.0, 0.0, 50.0);
    let mut r = rng(7);
    let mut pts = Vec::new();
    for _ in 0..12 {
        let step = DVec3::new(
            (r() * 9.0).floor() - 4.0,
            (r() * 9.0).floor() - 4.0,
            -(r() * 3.0).floor() - 2.0,
        );
        for k in 1..=4 {
            pts.push(eye + step * f64::from(k));
        }
    }
    for gamma in [1.5, 3.0, 5.5] {
        let v = certified(&pts, eye, gamma, 60);
        assert!(!v.is_empty());
    }
}

#[test]
fn coplanar_slabs_and_exactly_cospherical_points() {
    // Three slabs of an integer grid (many points coplanar in the input) and the integer points
    // of a sphere around the eye (cospherical exactly: they flip onto one sphere).
    let mut slabs = Vec::new();
    for z in [0.0, 2.0, 4.0] {
        for x in -5..=5 {
            for y in -5..=5 {
                slabs.push(DVec3::new(f64::from(x), f64::from(y), z));
            }
        }
    }
    for eye in [
        DVec3::new(0.0, 0.0, 20.0),
        DVec3::new(7.0, 1.0, 2.0),
        DVec3::new(0.5, 0.25, 2.0),
    ] {
        for gamma in [1.5, 3.0, 5.5] {
            certified(&slabs, eye, gamma, 0);
        }
    }
    let small: Vec<DVec3> = slabs
        .iter()
        .copied()
        .filter(|p| p.x.abs() <= 1.0 && p.y.abs() <= 1.0)
        .collect();
    certified(&small, DVec3::new(0.5, 0.25, 9.0), 3.0, 60);
    let mut sphere = Vec::new();
    for x in -5i32..=5 {
        for y in -5i32..=5 {
            for z in -5i32..=5 {
                if x * x + y * y + z * z == 25 {
                    sphere.push(DVec3::new(f64::from(x), f64::from(y), f64::from(z)));
                }
            }
        }
    }
    for gamma in [1.5, 5.5] {
        let v = certified(&sphere, DVec3::ZERO, gamma, 0);
        assert_eq!(
            v.len(),
            sphere.len(),
            "every point of a sphere around the eye is seen"
        );
    }
}

#[test]
fn duplicates_in_shuffled_order_are_all_reported() {
    let base = noisy_sphere(400, 1.0, 0.1, 11);
    let eye = DVec3::new(0.0, 0.5, 3.0);
    let unique = certified(&base, eye, 3.0, 0);
    // Every point three times, in a shuffled order of the points: indices 3i, 3i+1, 3i+2 are point
    // (7i mod n) of the base cloud.
    let n = base.len();
    let mut dup = Vec::new();
    for i in 0..n {
        let p = base[(7 * i) % n];
        dup.extend([p, p, p]);
    }
    let v = certified(&dup, eye, 3.0, 0);
    let mut expected: Vec<u32> = (0..dup.len() as u32)
        .filter(|&k| {
            unique
                .binary_search(&(((7 * (k as usize / 3)) % n) as u32))
                .is_ok()
        })
        .collect();
    expected.sort_unstable();
    assert_eq!(v, expected);
}
