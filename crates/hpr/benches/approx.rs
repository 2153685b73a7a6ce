//! Criterion benchmark of approximate HPR (`hpr::approx`, Machado e Silva et al. 2012) at
//! several k beside exact HPR, on a synthetic cloud: a bumpy closed surface of 200,000 seeded
//! points seen from outside (γ = 3, linear kernel). The Jaccard index of each approximate
//! answer against the exact one is printed once before the timings, so speed and accuracy cost
//! sit side by side. Run it twice in one sitting (A B A B) and report both.

use std::hint::black_box;
use std::time::Duration;

use cloud::glam::DVec3;
use cloud::rng::{RngExt, seeded};
use criterion::{Criterion, criterion_group, criterion_main};
use hpr::approx::ApproxParams;
use hpr::{HprParams, Kernel, Radius};

fn bumpy(n: usize) -> Vec<DVec3> {
    let mut rng = seeded(24, "approx-bench");
    (0..n)
        .map(|_| {
            let z: f64 = 2.0 * rng.random::<f64>() - 1.0;
            let phi = std::f64::consts::TAU * rng.random::<f64>();
            let r = (1.0 - z * z).sqrt();
            let radius = 1.0 + 0.3 * (3.0 * z.acos()).sin() * (2.0 * phi).cos();
            DVec3::new(r * phi.cos(), r * phi.sin(), z) * radius
        })
        .collect()
}

fn jaccard(a: &[u32], b: &[u32]) -> f64 {
    let sa: std::collections::HashSet<u32> = a.iter().copied().collect();
    let inter = b.iter().filter(|i| sa.contains(i)).count();
    inter as f64 / (a.len() + b.len() - inter).max(1) as f64
}

fn benches(c: &mut Criterion) {
    let points = bumpy(200_000);
    let eye = DVec3::new(0.3, 0.2, 3.0);
    let kernel = Kernel::Linear(Radius::Gamma(3.0));
    let own = hull::by_name("own").expect("own");
    let exact_params = HprParams {
        kernel,
        ..HprParams::default()
    };
    let exact = hpr::visible(&points, eye, &exact_params, own.as_ref()).expect("hpr");
    let ks: Vec<u64> = [64u64, 128, 256, 512, 1024, 2048]
        .iter()
        .map(|m| 6 * m * m)
        .collect();
    for &k in &ks {
        let a = hpr::approx::visible(
            &points,
            eye,
            &ApproxParams { kernel, sectors: k },
            own.as_ref(),
        )
        .expect("approx");
        eprintln!(
            "k {k}: jaccard {:.4} (visible {} of exact {}, representatives {})",
            jaccard(&a.visible, &exact.visible),
            a.visible.len(),
            exact.visible.len(),
            a.representatives
        );
    }
    let mut g = c.benchmark_group("approx-vs-exact-bumpy200k");
    g.sample_size(10)
        .measurement_time(Duration::from_secs(8))
        .warm_up_time(Duration::from_secs(2));
    g.bench_function("exact", |b| {
        b.iter(|| hpr::visible(black_box(&points), eye, &exact_params, own.as_ref()).expect("hpr"))
    });
    for &k in &ks {
        let p = ApproxParams { kernel, sectors: k };
        g.bench_function(format!("approx k{k}"), |b| {
            b.iter(|| {
                hpr::approx::visible(black_box(&points), eye, &p, own.as_ref()).expect("approx")
            })
        });
    }
    g.finish();
}

criterion_group!(approx_benches, benches);
criterion_main!(approx_benches);
