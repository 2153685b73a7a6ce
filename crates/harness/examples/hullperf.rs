use hpr::{Kernel, Radius};
use std::time::Instant;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let ds = harness::datasets::load(&args[1], std::path::Path::new("/tmp/bd")).unwrap();
    let gamma: f64 = args[2].parse().unwrap();
    let which: Vec<&str> = args[3].split(',').collect();
    let view: usize = args.get(4).map(|s| s.parse().unwrap()).unwrap_or(0);
    let eye = ds.views[view].eye;
    let t = hpr::transform::transform(
        &ds.cloud.positions,
        eye,
        Kernel::Linear(Radius::Gamma(gamma)),
    )
    .unwrap();
    let mut results = Vec::new();
    for name in which {
        let h = hull::by_name(name).unwrap();
        let start = Instant::now();
        let r = h.vertices(&t.points);
        let el = start.elapsed().as_secs_f64();
        match &r {
            Ok(v) => println!("{name}: {el:.3} s, {} vertices", v.len()),
            Err(e) => println!("{name}: {el:.3} s, error {e}"),
        }
        if name == "own" {
            let start = Instant::now();
            let (_, stats) = hull::own::hull_with_stats(&t.points).unwrap();
            println!(
                "own again {:.3}s stats {:?}",
                start.elapsed().as_secs_f64(),
                stats
            );
        }
        results.push((name, r));
    }
    if results.len() >= 2 {
        if let (Ok(a), Ok(b)) = (&results[0].1, &results[1].1) {
            let common = a.iter().filter(|v| b.binary_search(v).is_ok()).count();
            println!(
                "common {common}, only {} {}, only {} {}",
                results[0].0,
                a.len() - common,
                results[1].0,
                b.len() - common
            );
        }
    }
}
