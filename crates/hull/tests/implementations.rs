//! Every implementation behind the one trait: the same answer as `own` on easy input, typed
//! errors (never a panic escaping) on hostile input.

use hull::{HullError, NAMES, by_name};

fn cube_with_interior(n: usize) -> Vec<[f64; 3]> {
    let mut pts = Vec::new();
    for i in 0..8 {
        pts.push([
            (i & 1) as f64 * 2.0 - 1.0,
            ((i >> 1) & 1) as f64 * 2.0 - 1.0,
            ((i >> 2) & 1) as f64 * 2.0 - 1.0,
        ]);
    }
    let mut s = 99u64;
    for _ in 0..n {
        let mut r = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64 * 1.8 - 0.9
        };
        pts.push([r(), r(), r()]);
    }
    pts
}

fn sphere(n: usize) -> Vec<[f64; 3]> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|k| {
            let z = 1.0 - (2.0 * k as f64 + 1.0) / n as f64;
            let r = (1.0 - z * z).sqrt();
            [
                r * (k as f64 * golden).cos(),
                r * (k as f64 * golden).sin(),
                z,
            ]
        })
        .collect()
}

#[test]
fn all_implementations_find_the_cube_corners() {
    let pts = cube_with_interior(2_000);
    for name in NAMES {
        let v = by_name(name).unwrap().vertices(&pts).unwrap();
        assert_eq!(v, (0..8).collect::<Vec<u32>>(), "{name}");
    }
}

#[test]
fn all_implementations_keep_every_point_of_a_sphere() {
    let pts = sphere(3_000);
    let expected: Vec<u32> = (0..3_000).collect();
    for name in NAMES {
        let v = by_name(name).unwrap().vertices(&pts).unwrap();
        assert_eq!(v, expected, "{name}");
    }
}

#[test]
fn hostile_inputs_give_errors_not_panics() {
    let flat: Vec<[f64; 3]> = (0..50)
        .map(|i| [i as f64, (i * 7 % 13) as f64, 0.0])
        .collect();
    let huge: Vec<[f64; 3]> = cube_with_interior(20)
        .iter()
        .map(|p| p.map(|c| c * 1e300))
        .collect();
    for name in NAMES {
        let h = by_name(name).unwrap();
        // Whatever the crate thinks of a flat set, the call returns (Ok or Err) and never
        // unwinds into the caller; `own` says it is degenerate.
        let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| h.vertices(&flat)));
        assert!(r.is_ok(), "{name} let a panic escape on coplanar input");
        let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| h.vertices(&huge)));
        assert!(r.is_ok(), "{name} let a panic escape on huge coordinates");
    }
    assert!(matches!(
        by_name("own").unwrap().vertices(&flat),
        Err(HullError::Degenerate(_))
    ));
}
