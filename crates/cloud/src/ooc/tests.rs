//! The preparation against the in-memory one: every point's normal and the leaf radius bit
//! for bit, whatever the chunks; bad inputs and limits.

use glam::{DVec3, Vec3};

use super::*;
use crate::rng::{RngExt, seeded};

/// A wavy sheet with clusters of coincident points (which the split halves by position).
fn cloud(n: usize, seed: u64) -> Vec<Point> {
    let mut rng = seeded(seed, "cloud-ooc-test");
    let mut pts = Vec::with_capacity(n);
    while pts.len() < n {
        let (x, y) = (rng.random::<f64>(), rng.random::<f64>());
        let p = DVec3::new(x, y, 0.1 * (6.0 * x).sin() * (4.0 * y).cos());
        let copies = if rng.random::<f64>() < 0.02 { 3 } else { 1 };
        for _ in 0..copies {
            pts.push(Point {
                position: p,
                normal: Vec3::Z,
                color: [rng.random(), 0, 0],
            });
        }
    }
    pts.truncate(n);
    pts
}

fn options(memory_limit: u64) -> Options {
    Options {
        memory_limit,
        bytes_per_point: 640,
        normals: Normals::Estimate { k: 16 },
        radius: Radius::DensitySpacing {
            k: 8,
            sample: 2_000,
            seed: 1,
            factor: 1.5,
        },
        records: Records::default(),
        fail_after_bytes: None,
    }
}

fn run(pts: &[Point], opts: &Options, out: &Path) -> Result<(Prepared, Summary)> {
    let mut at = 0;
    let mut source = |batch: &mut Vec<Point>| -> Result<bool> {
        let end = (at + 5_000).min(pts.len());
        batch.extend_from_slice(&pts[at..end]);
        at = end;
        Ok(at < pts.len())
    };
    prepare(&mut source, opts, out, &mut |_, _| {})
}

#[test]
fn chunked_normals_and_radius_are_the_in_memory_ones() {
    let pts = cloud(30_000, 4);
    let positions: Vec<DVec3> = pts.iter().map(|p| p.position).collect();
    let (want_normals, want_radius) =
        prepare_in_memory(&positions, None, &options(u64::MAX)).unwrap();
    // The orientation's guide is a strict subset here (this crate's tests use a small one), so
    // the out-of-core signs come from the guide's path, not from the whole cloud's tree.
    let guide = crate::orient::select_guide(&positions, crate::orient::guide_max()).len();
    assert!(
        guide > 1_000 && guide < positions.len() / 2,
        "guide of {guide}"
    );
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.lod");
    for limit in [RESERVE + MIN_CHUNK * 640, RESERVE + 9_000 * 640, 1 << 30] {
        let (prepared, summary) = run(&pts, &options(limit), &out).unwrap();
        assert_eq!(
            summary.leaf_radius.to_bits(),
            want_radius.to_bits(),
            "{summary:?}"
        );
        let mut seen = vec![false; pts.len()];
        prepared
            .for_each_chunk(|c| -> Result<()> {
                // Each chunk in input order (the order of QSplat's in-memory sets).
                assert!(c.index.windows(2).all(|w| w[0] < w[1]));
                for (i, &g) in c.index.iter().enumerate() {
                    let g = g as usize;
                    assert!(!seen[g], "point {g} twice");
                    seen[g] = true;
                    assert_eq!(c.positions[i], positions[g]);
                    assert_eq!(c.colors[i], pts[g].color);
                    assert_eq!(c.normals[i].to_array(), want_normals[g].to_array(), "{g}");
                }
                Ok(())
            })
            .unwrap();
        assert!(seen.iter().all(|&s| s));
        match &prepared {
            Prepared::Chunked(chunks) => {
                assert!(limit < 1 << 30 && chunks.len() >= 3, "{summary:?}");
                // Each point written once to the input's files and once to its chunk's (31
                // bytes each without its normal), its normal once (12 bytes), the halos and
                // the normal patches near the chunks' borders (small chunks here: many).
                let per_point = summary.scratch_bytes as f64 / pts.len() as f64;
                assert!(
                    per_point < 31.0 + 31.0 + 12.0 + 30.0,
                    "{per_point} {summary:?}"
                );
                assert_eq!(chunks.len() as u64, summary.chunks);
                let leaves = chunks
                    .parts()
                    .iter()
                    .filter(|p| matches!(p.kind, PartKind::Chunk(_)))
                    .count();
                assert_eq!(leaves, chunks.len());
            }
            Prepared::Whole(_) => assert_eq!(limit, 1 << 30),
        }
        drop(prepared);
        // The scratch folder goes with the result.
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }
}

#[test]
fn bad_inputs_and_limits_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.lod");
    let e = run(&cloud(100, 1), &options(16 << 20), &out).unwrap_err();
    assert!(
        matches!(
            e,
            Error::InvalidParameter {
                name: "memory_limit",
                ..
            }
        ),
        "{e}"
    );
    assert!(matches!(
        run(&[], &options(1 << 30), &out),
        Err(Error::EmptyCloud)
    ));
    let mut pts = cloud(100, 1);
    pts[3].position.x = f64::INFINITY;
    assert!(matches!(
        run(&pts, &options(1 << 30), &out),
        Err(Error::Cloud(crate::Error::NonFinite { index: 3 }))
    ));
    let given = Options {
        normals: Normals::Given,
        ..options(1 << 30)
    };
    // A given normal that is NaN, zero or not normalised: refused, naming the point.
    for bad in [Vec3::NAN, Vec3::ZERO, Vec3::new(0.0, 0.0, 1.01)] {
        let mut pts = cloud(100, 1);
        pts[5].normal = bad;
        let e = run(&pts, &given, &out).unwrap_err();
        assert!(
            matches!(
                &e,
                Error::InvalidParameter {
                    name: "normals",
                    reason,
                } if reason.starts_with("point 5 has the normal")
            ),
            "{e}"
        );
        let positions: Vec<DVec3> = pts.iter().map(|p| p.position).collect();
        let normals = pts.iter().map(|p| p.normal).collect();
        let e = prepare_in_memory(&positions, Some(normals), &given).unwrap_err();
        assert!(e.to_string().contains("point 5 has the normal"), "{e}");
    }
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

/// Given normals are kept bit for bit, the leaf radius is the in-memory one, and only the
/// spacing sample's points are searched (at most twice each: within their chunk, then with
/// its halo), where estimated normals search every point at least once.
#[test]
fn given_normals_search_only_the_spacing_sample() {
    let mut pts = cloud(30_000, 9);
    let mut rng = seeded(3, "given-normals");
    for p in &mut pts {
        let v = Vec3::new(
            rng.random::<f32>() - 0.5,
            rng.random::<f32>() - 0.5,
            rng.random::<f32>() + 0.1,
        );
        p.normal = v.normalize();
    }
    let positions: Vec<DVec3> = pts.iter().map(|p| p.position).collect();
    let given_normals: Vec<Vec3> = pts.iter().map(|p| p.normal).collect();
    let given = |limit| Options {
        normals: Normals::Given,
        ..options(limit)
    };
    let (_, want_radius) =
        prepare_in_memory(&positions, Some(given_normals.clone()), &given(u64::MAX)).unwrap();
    let Radius::DensitySpacing { sample, .. } = options(0).radius else {
        unreachable!("the tests' options use the density spacing")
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.lod");
    for limit in [RESERVE + MIN_CHUNK * 640, RESERVE + 9_000 * 640, 1 << 30] {
        let (prepared, summary) = run(&pts, &given(limit), &out).unwrap();
        assert_eq!(
            summary.leaf_radius.to_bits(),
            want_radius.to_bits(),
            "{limit}"
        );
        assert!(
            summary.neighbour_queries >= sample.min(pts.len()) as u64 / 2
                && summary.neighbour_queries <= 2 * sample as u64,
            "{limit}: {summary:?}"
        );
        if limit < 1 << 30 {
            assert!(summary.chunks >= 3, "{summary:?}");
        }
        prepared
            .for_each_chunk(|c| -> Result<()> {
                for (i, &g) in c.index.iter().enumerate() {
                    assert_eq!(
                        c.normals[i].to_array(),
                        given_normals[g as usize].to_array()
                    );
                }
                Ok(())
            })
            .unwrap();
        // The same cloud with its normals estimated: every point searched.
        let (_, estimated) = run(&pts, &options(limit), &out).unwrap();
        assert!(
            estimated.neighbour_queries >= pts.len() as u64,
            "{limit}: {estimated:?}"
        );
    }
}

/// What a preparation's split made: each chunk's input indices (in its order) and box, and the
/// parts above them.
fn split_of(prepared: &Prepared) -> Vec<(Vec<u64>, [u64; 6], String)> {
    let Prepared::Chunked(chunks) = prepared else {
        panic!("not chunked");
    };
    let bits = |b: (DVec3, DVec3)| {
        let (lo, hi) = (b.0.to_array(), b.1.to_array());
        [lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]].map(f64::to_bits)
    };
    let mut out: Vec<_> = (0..chunks.len())
        .map(|c| {
            let set = &chunks.chunks[c];
            (
                chunks.load(c).unwrap().index,
                bits(set.bbox.unwrap()),
                format!("{}", set.overlap),
            )
        })
        .collect();
    out.extend(
        chunks
            .parts()
            .iter()
            .map(|p| (Vec::new(), bits(p.bbox), format!("{:?}", p.kind))),
    );
    out
}

#[test]
fn the_split_is_the_same_on_disk_in_subsets_and_in_memory() {
    // Clusters of copies of one point fill several chunks (halved by position).
    let mut pts = cloud(60_000, 7);
    // On a grid, as a LAS file's are: points on split planes.
    for p in &mut pts {
        p.position = (p.position * 256.0).round() / 256.0;
    }
    for i in (0..pts.len()).step_by(5).take(9_000) {
        pts[i].position = DVec3::new(0.25, 0.5, 0.0);
    }
    let opts = Options {
        normals: Normals::Given,
        radius: Radius::Fixed(0.01),
        ..options(RESERVE + MIN_CHUNK * 640)
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.lod");
    let mut want = None;
    let mut subset_written = 0;
    // Every level by a pass over the input; passes, then subsets of at most 7,000 or 25,000
    // points; all in memory at once.
    for fits in [0, 7_000, 25_000, u64::MAX] {
        partition::SUBSET_POINTS.set(Some(fits));
        let (prepared, summary) = run(&pts, &opts, &out).unwrap();
        partition::SUBSET_POINTS.set(None);
        let got = split_of(&prepared);
        if fits == 7_000 {
            subset_written = summary.scratch_bytes;
        }
        assert!(summary.chunks >= 20, "{summary:?}");
        let rec = 24 + 3 + 4 + 12;
        let writes = summary.scratch_bytes as f64 / (rec * pts.len()) as f64;
        // The input and the chunks; the subsets once more, when there are (a set in a subset
        // may be a chunk already: 15 % of the points at 7,000, all at 25,000).
        match fits {
            0 | u64::MAX => assert!((writes - 2.0).abs() < 1e-9, "{fits}: {writes} {summary:?}"),
            7_000 => assert!(
                writes > 2.1 && writes <= 3.0,
                "{fits}: {writes} {summary:?}"
            ),
            _ => assert!(
                writes > 2.9 && writes <= 3.0,
                "{fits}: {writes} {summary:?}"
            ),
        }
        match &want {
            None => want = Some(got),
            Some(w) => assert!(*w == got, "subsets of {fits} points split otherwise"),
        }
        drop(prepared);
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }
    // A full disk while the input, the subsets or the chunks are written: an error, and the
    // scratch gone.
    let written = subset_written;
    for at in [written / 4, written / 2, written * 3 / 4, written - 1_000] {
        partition::SUBSET_POINTS.set(Some(7_000));
        let full = Options {
            fail_after_bytes: Some(at),
            ..opts.clone()
        };
        let e = run(&pts, &full, &out).unwrap_err();
        partition::SUBSET_POINTS.set(None);
        assert!(
            matches!(&e, Error::Io { source, .. } if source.kind() == std::io::ErrorKind::StorageFull),
            "{at}: {e}"
        );
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }
}
