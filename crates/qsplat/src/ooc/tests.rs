//! The out-of-core build against the in-memory one: the same bytes at several limits, with
//! given and estimated normals, fixed and density-spacing radii; full disks and bad inputs.

use std::io;
use std::path::Path;

use cloud::glam::{DVec3, Vec3};
use cloud::ooc::{MIN_CHUNK, Normals, Point, RESERVE, Radius, Summary};
use cloud::rng::{RngExt, seeded};

use super::*;
use crate::Error;

/// A cloud with clusters of coincident points (different normals and colours) and
/// points one ulp apart, which exercise the halving by position, on a wavy sheet, and
/// some far outliers (chunks of fewer points than the neighbour count).
pub(crate) fn cloud(n: usize, seed: u64) -> Vec<Point> {
    let mut rng = seeded(seed, "ooc-test");
    let mut pts = Vec::with_capacity(n);
    while pts.len() < n {
        let (x, y) = (rng.random::<f64>(), rng.random::<f64>());
        let mut p = DVec3::new(x, y, 0.1 * (6.0 * x).sin() * (4.0 * y).cos());
        if rng.random::<f64>() < 0.0005 {
            p += DVec3::new(0.0, 0.0, 3.0 + rng.random::<f64>());
        }
        let copies = if rng.random::<f64>() < 0.02 { 5 } else { 1 };
        for c in 0..copies {
            let normal = Vec3::new(rng.random(), rng.random(), 1.0).normalize();
            let q = if c == 4 {
                DVec3::new(p.x.next_up(), p.y, p.z)
            } else {
                p
            };
            pts.push(Point {
                position: q,
                normal,
                color: [rng.random(), rng.random(), (c * 50) as u8],
            });
        }
    }
    pts.truncate(n);
    pts
}

fn in_memory_bytes(pts: &[Point], opts: &Options) -> Vec<u8> {
    let (tree, _) = in_memory(
        pts.iter().map(|p| p.position).collect(),
        Some(pts.iter().map(|p| p.normal).collect()),
        Some(pts.iter().map(|p| p.color).collect()),
        opts,
    )
    .unwrap();
    crate::file::to_bytes(&tree)
}

fn out_of_core(pts: &[Point], opts: &Options, out: &Path) -> Result<Summary> {
    let mut at = 0;
    let mut source = |batch: &mut Vec<Point>| -> Result<bool> {
        let end = (at + 10_000).min(pts.len());
        batch.extend_from_slice(&pts[at..end]);
        at = end;
        Ok(at < pts.len())
    };
    build_file(&mut source, opts, out, &mut |_, _| {})
}

fn limit(chunk: u64) -> u64 {
    RESERVE + chunk * BYTES_PER_POINT
}

fn options(chunk: u64, colors: bool, normals: Normals, radius: Radius) -> Options {
    Options {
        memory_limit: limit(chunk),
        colors,
        normals,
        radius,
        grid: None,
        fail_after_bytes: None,
    }
}

const DENSITY: Radius = Radius::DensitySpacing {
    k: 8,
    sample: 2_000,
    seed: 1,
    factor: 1.5,
};

fn same_bytes(pts: &[Point], normals: Normals, radius: Radius, colors: bool, chunks: &[u64]) {
    same_bytes_on(pts, normals, radius, colors, None, chunks);
}

/// [`same_bytes`] with the scratch records' positions on `grid`.
fn same_bytes_on(
    pts: &[Point],
    normals: Normals,
    radius: Radius,
    colors: bool,
    grid: Option<cloud::ooc::Grid>,
    chunks: &[u64],
) {
    let dir = tempfile::tempdir().unwrap();
    let want = in_memory_bytes(pts, &options(1 << 30, colors, normals, radius));
    for &chunk in chunks {
        let out = dir.path().join("t.qsplat");
        let opts = Options {
            grid,
            ..options(chunk, colors, normals, radius)
        };
        let s = out_of_core(pts, &opts, &out).unwrap();
        if (chunk as usize) < pts.len() {
            assert!(s.chunks >= 5 && s.top_levels >= 2, "{s:?}");
        } else {
            assert_eq!(s.chunks, 1);
        }
        let got = std::fs::read(&out).unwrap();
        assert_eq!(
            got.len(),
            want.len(),
            "{normals:?} {radius:?} chunk {chunk}"
        );
        let first = got.iter().zip(&want).position(|(a, b)| a != b);
        assert_eq!(first, None, "{normals:?} {radius:?} chunk {chunk}: {s:?}");
        // Only the output is left beside it.
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
        crate::file::read(&out).unwrap();
    }
}

#[test]
fn the_same_bytes_with_given_normals_and_radius() {
    let pts = cloud(50_000, 1);
    for colors in [true, false] {
        same_bytes(
            &pts,
            Normals::Given,
            Radius::Fixed(0.002),
            colors,
            &[MIN_CHUNK, 9_000, 100_000],
        );
    }
}

#[test]
fn the_same_bytes_with_estimated_normals_and_density_spacing() {
    let pts = cloud(40_000, 2);
    same_bytes(
        &pts,
        Normals::Estimate { k: 16 },
        DENSITY,
        true,
        &[MIN_CHUNK, 7_000, 9_500],
    );
    same_bytes(&pts, Normals::Given, DENSITY, false, &[MIN_CHUNK]);
}

/// Positions on a LAS-like grid (`scale · i + offset`, the `las` crate's formula), which the
/// scratch records keep as integers: the same bytes, with and without colours.
#[test]
fn the_same_bytes_with_positions_kept_as_integers_of_their_grid() {
    let grid = cloud::ooc::Grid {
        scale: [1e-5, 1e-5, 1e-6],
        offset: [0.3, -0.2, 1_000.0],
    };
    let mut pts = cloud(40_000, 2);
    for p in &mut pts {
        for a in 0..3 {
            let i = ((p.position[a] - grid.offset[a]) / grid.scale[a]).round();
            p.position[a] = grid.scale[a] * i + grid.offset[a];
        }
    }
    for colors in [true, false] {
        same_bytes_on(
            &pts,
            Normals::Estimate { k: 16 },
            DENSITY,
            colors,
            Some(grid),
            &[MIN_CHUNK, 9_500],
        );
    }
    same_bytes_on(
        &pts,
        Normals::Given,
        Radius::Fixed(0.002),
        true,
        Some(grid),
        &[7_000],
    );
    // A point off the grid it declares is an error naming it, and leaves nothing behind.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("t.qsplat");
    pts[777].position.x += 0.3 * grid.scale[0];
    let opts = Options {
        grid: Some(grid),
        ..options(MIN_CHUNK, true, Normals::Estimate { k: 16 }, DENSITY)
    };
    let e = out_of_core(&pts, &opts, &out).unwrap_err().to_string();
    assert!(e.contains("point 777") && e.contains("grid"), "{e}");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

#[test]
fn a_full_disk_is_an_error_and_leaves_nothing() {
    let pts = cloud(30_000, 2);
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("t.qsplat");
    let whole = options(MIN_CHUNK, true, Normals::Estimate { k: 16 }, DENSITY);
    // Failures from the first bytes to the last stage's (every stage writes scratch).
    let total = out_of_core(&pts, &whole, &out).unwrap().scratch_bytes;
    std::fs::remove_file(&out).unwrap();
    for after in [1_000u64, total / 4, total / 2, total * 9 / 10, total - 1] {
        let opts = Options {
            fail_after_bytes: Some(after),
            ..whole.clone()
        };
        let e = out_of_core(&pts, &opts, &out).unwrap_err();
        match &e {
            Error::Io { source, .. } => {
                assert_eq!(source.kind(), io::ErrorKind::StorageFull, "{e}");
            }
            other => panic!("{other}"),
        }
        assert!(e.to_string().contains("no space left"), "{e}");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }
}

#[test]
fn bad_limits_and_inputs() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("t.qsplat");
    let small = Options {
        memory_limit: 16 << 20,
        ..options(0, false, Normals::Given, Radius::Fixed(0.01))
    };
    let e = out_of_core(&cloud(100, 3), &small, &out).unwrap_err();
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
    assert!(e.to_string().contains("below what"), "{e}");
    let opts = options(MIN_CHUNK, false, Normals::Given, Radius::Fixed(0.01));
    assert!(matches!(
        out_of_core(&[], &opts, &out),
        Err(Error::EmptyCloud)
    ));
    let mut pts = cloud(100, 3);
    pts[7].position.y = f64::NAN;
    assert!(matches!(
        out_of_core(&pts, &opts, &out),
        Err(Error::Cloud(cloud::Error::NonFinite { index: 7 }))
    ));
    // A source that fails midway (a truncated file) fails the build.
    let mut calls = 0;
    let mut source = |batch: &mut Vec<Point>| -> Result<bool> {
        calls += 1;
        if calls == 3 {
            return Err(Error::Corrupt {
                format: crate::file::FORMAT,
                path: "in.las".into(),
                offset: 1234,
                reason: "truncated".into(),
            });
        }
        batch.extend(cloud(5_000, calls));
        Ok(true)
    };
    let e = build_file(&mut source, &opts, &out, &mut |_, _| {}).unwrap_err();
    assert!(e.to_string().contains("truncated"), "{e}");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

#[test]
fn the_same_bytes_when_copies_of_a_point_fill_several_chunks() {
    // 14,000 copies of one point and 6,000 one ulp beside it (interleaved, with their own
    // normals and colours) among a sheet: the split halves them by position over chunks.
    let mut pts = cloud(20_000, 5);
    let p = pts[11].position;
    let mut rng = seeded(6, "ooc-copies");
    for i in 0..20_000usize {
        let position = if i % 10 < 3 {
            DVec3::new(p.x.next_up(), p.y, p.z)
        } else {
            p
        };
        let normal = Vec3::new(rng.random(), rng.random(), 1.0).normalize();
        let at = (i * 7_919) % pts.len();
        pts.insert(
            at,
            Point {
                position,
                normal,
                color: [(i % 251) as u8, 0, 9],
            },
        );
    }
    same_bytes(
        &pts,
        Normals::Given,
        Radius::Fixed(0.002),
        true,
        &[MIN_CHUNK, 6_000],
    );
}
