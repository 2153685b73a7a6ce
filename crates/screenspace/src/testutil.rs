//! Test helpers: small seeded clouds and one camera per model.

use cloud::glam::DVec3;
use cloud::rng::{RngExt, seeded};
use cloud::{Camera, Model};

/// The three models' names.
pub const MODELS: [&str; 3] = ["pinhole", "orthographic", "spherical"];

/// A `width` × `height` camera of `model` at (0.3, −0.2, 4) (spherical: at height 1)
/// looking at the origin.
pub fn camera(model: &str, width: u32, height: u32) -> Camera {
    let m = match model {
        "pinhole" => Model::pinhole_fov(45.0, width, height).expect("fov"),
        "orthographic" => Model::Orthographic {
            view_width: 3.0,
            view_height: 3.0 * f64::from(height) / f64::from(width),
        },
        _ => Model::Spherical,
    };
    // The spherical image sees everything: come closer so the layers fill much of it.
    let eye = if model == "spherical" {
        DVec3::new(0.3, -0.2, 1.0)
    } else {
        DVec3::new(0.3, -0.2, 4.0)
    };
    Camera::look_at(eye, DVec3::ZERO, DVec3::Y, m, width, height).expect("camera")
}

/// Two noisy layers (z ≈ 0 and z ≈ −1) of `n` points each in [−1.2, 1.2]², seeded: a
/// front surface with gaps and one behind it.
pub fn layers(n: usize, seed: u64) -> Vec<DVec3> {
    let mut rng = seeded(seed, "screenspace-test-layers");
    let mut out = Vec::with_capacity(2 * n);
    for layer in [0.0, -1.0] {
        for _ in 0..n {
            let x = (rng.random::<f64>() * 2.0 - 1.0) * 1.2;
            let y = (rng.random::<f64>() * 2.0 - 1.0) * 1.2;
            let z = layer + 0.01 * (rng.random::<f64>() - 0.5);
            out.push(DVec3::new(x, y, z));
        }
    }
    out
}
