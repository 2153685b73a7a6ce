//! The out-of-core build against the in-memory one: the same bytes, several limits, points in
//! any order, coincident points; a full disk; bad limits and inputs; the file read back.

use cloud::rng::{RngExt, seeded};

use super::*;

/// A wavy sheet with clusters of coincident points (different normals and colours), points
/// one ulp apart, a dense knot (a chain of single-octant cells above the chunks) and far
/// outliers.
fn cloud(n: usize, seed: u64) -> Vec<Point> {
    let mut rng = seeded(seed, "spt-ooc-test");
    let mut pts: Vec<Point> = Vec::with_capacity(n);
    while pts.len() < n {
        let (x, y) = (rng.random::<f64>(), rng.random::<f64>());
        let mut p = DVec3::new(x, y, 0.1 * (6.0 * x).sin() * (4.0 * y).cos());
        let r = rng.random::<f64>();
        if r < 0.0005 {
            p += DVec3::new(0.0, 0.0, 3.0 + rng.random::<f64>());
        } else if r < 0.15 {
            // The knot: 15 % of the points within 1e-4 of one spot.
            p = DVec3::new(0.3, 0.6, 0.05) + 1e-4 * DVec3::new(x, y, rng.random::<f64>());
        }
        let copies = if rng.random::<f64>() < 0.02 { 5 } else { 1 };
        for c in 0..copies {
            let q = if c == 4 {
                DVec3::new(p.x.next_up(), p.y, p.z)
            } else {
                p
            };
            let index = pts.len() as u64;
            pts.push(Point {
                position: q,
                normal: Vec3::new(rng.random::<f32>() - 0.5, rng.random::<f32>() - 0.5, 1.0)
                    .normalize(),
                color: [rng.random(), rng.random(), (c * 50) as u8],
                index,
            });
        }
    }
    pts.truncate(n);
    pts
}

fn limit(chunk: u64) -> u64 {
    RESERVE + chunk * BYTES_PER_POINT
}

fn options(chunk: u64, colors: bool) -> Options {
    Options {
        memory_limit: limit(chunk),
        colors,
        fail_after_bytes: None,
    }
}

fn in_memory_spt(pts: &[Point], colors: bool) -> Spt {
    in_memory(
        pts.iter().map(|p| p.position).collect(),
        pts.iter().map(|p| p.normal).collect(),
        colors.then(|| pts.iter().map(|p| p.color).collect()),
        0.004,
    )
    .unwrap()
}

fn out_of_core(pts: &[Point], opts: &Options, out: &Path) -> Result<Summary> {
    let mut b = Builder::new(opts, out)?;
    for batch in pts.chunks(7_000) {
        b.push(batch)?;
    }
    b.finish(0.004, &mut |_, _| {})
}

fn same_bytes(pts: &[Point], colors: bool, chunks: &[u64]) {
    let dir = tempfile::tempdir().unwrap();
    let want = file::to_bytes(&in_memory_spt(pts, colors));
    for &chunk in chunks {
        let out = dir.path().join("t.spt");
        let s = out_of_core(pts, &options(chunk, colors), &out).unwrap();
        if (chunk as usize) < pts.len() {
            assert!(s.chunks >= 5 && s.top_nodes >= 2 && s.runs >= 2, "{s:?}");
        } else {
            assert_eq!(s.chunks, 1);
        }
        let got = std::fs::read(&out).unwrap();
        assert_eq!(got.len(), want.len(), "chunk {chunk}: {s:?}");
        let first = got.iter().zip(&want).position(|(a, b)| a != b);
        assert_eq!(first, None, "chunk {chunk}: {s:?}");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }
}

#[test]
fn the_same_bytes_as_in_memory_at_several_limits() {
    let pts = cloud(60_000, 1);
    same_bytes(&pts, true, &[MIN_CHUNK, 11_000, 100_000]);
    same_bytes(&pts, false, &[MIN_CHUNK]);
}

#[test]
fn points_in_any_order_give_the_same_bytes() {
    let pts = cloud(30_000, 2);
    let want = file::to_bytes(&in_memory_spt(&pts, true));
    let mut shuffled = pts.clone();
    let mut rng = seeded(9, "shuffle");
    for i in (1..shuffled.len()).rev() {
        shuffled.swap(i, rng.random_range(0..=i));
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("t.spt");
    out_of_core(&shuffled, &options(MIN_CHUNK, true), &out).unwrap();
    assert!(std::fs::read(&out).unwrap() == want);
}

#[test]
fn the_file_cuts_as_the_tree_does() {
    let pts = cloud(20_000, 3);
    let spt = in_memory_spt(&pts, true);
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("t.spt");
    out_of_core(&pts, &options(MIN_CHUNK, true), &out).unwrap();
    let mut f = crate::paged::PagedTree::open(&out).unwrap();
    assert_eq!(f.header().entries, spt.len() as u64);
    assert_eq!(f.header().points, 20_000);
    let (mut a, mut b) = (Vec::new(), Vec::new());
    for eye in [
        DVec3::new(0.5, 0.5, 2.0),
        DVec3::new(3.0, -1.0, 0.5),
        DVec3::new(0.3, 0.6, 0.06),
    ] {
        for eps in [0.0, 1e-3, 1e-2, 0.1] {
            let sa = spt.cut_into(eye, eps, &mut a).unwrap();
            let sb = f.cut_into(eye, eps, &mut b).unwrap();
            assert_eq!(a, b);
            assert_eq!(sa, sb);
            assert_eq!(spt.file_splats(&a), f.splats(&b).unwrap());
        }
    }
}

#[test]
fn truncated_and_lying_files_are_refused_when_opened() {
    let pts = cloud(5_000, 4);
    let bytes = file::to_bytes(&in_memory_spt(&pts, true));
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.spt");
    let open = |b: &[u8]| {
        std::fs::write(&path, b).unwrap();
        crate::paged::PagedTree::open(&path)
    };
    assert!(open(&bytes).is_ok());
    for cut in [0, 10, file::HEADER, bytes.len() - 1] {
        let e = open(&bytes[..cut]).unwrap_err();
        assert!(matches!(e, Error::Corrupt { .. }), "{e}");
    }
    let mut lying = bytes.clone();
    lying[24..32].copy_from_slice(&u64::MAX.to_le_bytes());
    assert!(matches!(
        open(&lying),
        Err(Error::Checksum { offset: 0, .. })
    ));
    // Past the header's checksum, the counts are checked against the length.
    file::reseal(&mut lying, false);
    assert!(matches!(open(&lying), Err(Error::Corrupt { .. })));
    let mut magic = bytes.clone();
    magic[0] = b'X';
    assert!(open(&magic).unwrap_err().to_string().contains("magic"));
    assert!(matches!(
        crate::paged::PagedTree::open(Path::new("/nonexistent/x.spt")),
        Err(Error::Io { .. })
    ));
}

#[test]
fn a_full_disk_is_an_error_and_leaves_nothing() {
    let pts = cloud(30_000, 5);
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("t.spt");
    for after in [1_000u64, 1_000_000, 2_500_000, 4_000_000] {
        let opts = Options {
            fail_after_bytes: Some(after),
            ..options(MIN_CHUNK, true)
        };
        let e = out_of_core(&pts, &opts, &out).unwrap_err();
        match &e {
            Error::Io { source, .. } => {
                assert_eq!(source.kind(), io::ErrorKind::StorageFull, "{e}")
            }
            other => panic!("{other}"),
        }
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }
}

#[test]
fn bad_limits_and_inputs() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("t.spt");
    let small = Options {
        memory_limit: 16 << 20,
        ..options(0, false)
    };
    let e = out_of_core(&cloud(100, 6), &small, &out).err().unwrap();
    assert!(e.to_string().contains("below what"), "{e}");
    let opts = options(MIN_CHUNK, false);
    assert!(matches!(
        out_of_core(&[], &opts, &out),
        Err(Error::EmptyCloud)
    ));
    let mut pts = cloud(100, 6);
    pts[7].position.y = f64::NAN;
    assert!(matches!(
        out_of_core(&pts, &opts, &out),
        Err(Error::Cloud(cloud::Error::NonFinite { index: 7 }))
    ));
    let mut pts = cloud(10_000, 6);
    pts[3].index = 5;
    let e = out_of_core(&pts, &opts, &out).unwrap_err();
    assert!(e.to_string().contains("given twice or missing"), "{e}");
    let mut pts = cloud(10_000, 6);
    pts[3].index = 10_000;
    let e = out_of_core(&pts, &opts, &out).unwrap_err();
    assert!(e.to_string().contains("must be 0..10000"), "{e}");
    // More coincident points than a chunk holds.
    let mut pts = cloud(10_000, 6);
    for p in &mut pts[..5_000] {
        p.position = DVec3::splat(0.25);
    }
    let e = out_of_core(&pts, &opts, &out).unwrap_err();
    assert!(e.to_string().contains("coincident"), "{e}");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

/// `pts` prepared by `cloud::ooc::prepare` (in input order, their own normals, a fixed
/// radius) in chunks of at most `prep_chunk` points, then built by [`build_prepared`] under
/// `opts` (its full disk also the preparation's); returns the build's summary and the
/// preparation's scratch bytes.
fn from_prepared(
    pts: &[Point],
    prep_chunk: u64,
    opts: &Options,
    out: &Path,
) -> Result<(Summary, u64)> {
    from_prepared_records(pts, prep_chunk, opts, out, cloud::ooc::Records::default())
}

/// [`from_prepared`] with the preparation's records kept as `records` says (a grid).
fn from_prepared_records(
    pts: &[Point],
    prep_chunk: u64,
    opts: &Options,
    out: &Path,
    records: cloud::ooc::Records,
) -> Result<(Summary, u64)> {
    let mut sorted = pts.to_vec();
    sorted.sort_by_key(|p| p.index);
    let mut at = 0;
    let mut source = |batch: &mut Vec<cloud::ooc::Point>| -> Result<bool> {
        let end = (at + 7_000).min(sorted.len());
        batch.extend(sorted[at..end].iter().map(|p| cloud::ooc::Point {
            position: p.position,
            normal: p.normal,
            color: p.color,
        }));
        at = end;
        Ok(at < sorted.len())
    };
    let prep = cloud::ooc::Options {
        memory_limit: cloud::ooc::RESERVE + prep_chunk * PREPARE_BYTES_PER_POINT,
        bytes_per_point: PREPARE_BYTES_PER_POINT,
        normals: cloud::ooc::Normals::Given,
        radius: cloud::ooc::Radius::Fixed(0.002),
        records,
        fail_after_bytes: opts.fail_after_bytes,
    };
    let (prepared, summary) = cloud::ooc::prepare(&mut source, &prep, out, &mut |_, _| {})?;
    let s = build_prepared(prepared, opts, out, 0.004, &mut |_, _| {})?;
    Ok((s, summary.scratch_bytes))
}

#[test]
fn prepared_chunks_read_where_they_lie_give_the_same_bytes() {
    let pts = cloud(60_000, 7);
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("t.spt");
    for colors in [true, false] {
        let want = file::to_bytes(&in_memory_spt(&pts, colors));
        // Chunked preparations (this build's chunks smaller, larger, and the whole cloud),
        // and a whole one (pushed).
        for (prep_chunk, chunk) in [
            (MIN_CHUNK, 11_000),
            (9_000, MIN_CHUNK),
            (9_000, 100_000),
            (100_000, MIN_CHUNK),
        ] {
            let (s, prep_bytes) =
                from_prepared(&pts, prep_chunk, &options(chunk, colors), &out).unwrap();
            let got = std::fs::read(&out).unwrap();
            let first = got.iter().zip(&want).position(|(a, b)| a != b);
            assert_eq!(
                (got.len(), first),
                (want.len(), None),
                "{prep_chunk}/{chunk}: {s:?}"
            );
            assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
            let n = pts.len() as u64;
            if prep_chunk < 60_000 && chunk < 60_000 {
                assert!(s.chunks >= 5 && s.runs >= 2, "{s:?}");
                // The scratch counts the preparation's files with the build's, and the
                // prepared points are not copied: the pushed route's bytes less its copy.
                let pushed = out_of_core(&pts, &options(chunk, colors), &out).unwrap();
                assert_eq!(
                    s.scratch_bytes - prep_bytes,
                    pushed.scratch_bytes - n * REC as u64,
                    "{s:?}, preparation {prep_bytes}, pushed {pushed:?}"
                );
                eprintln!(
                    "{prep_chunk}/{chunk}: {:.1} B/pt written ({:.1} by the preparation), \
                     {:.1} at once; pushed: {:.1} more, {:.1} at once",
                    s.scratch_bytes as f64 / n as f64,
                    prep_bytes as f64 / n as f64,
                    s.scratch_peak_bytes as f64 / n as f64,
                    pushed.scratch_bytes as f64 / n as f64,
                    pushed.scratch_peak_bytes as f64 / n as f64,
                );
            }
        }
    }
}

#[test]
fn points_on_the_inputs_grid_are_distributed_as_its_integers() {
    // The cloud on a LAS-like grid (every position `scale * i + offset`, exactly).
    let grid = cloud::ooc::Grid {
        scale: [2f64.powi(-24), 3e-7, 2f64.powi(-23)],
        offset: [0.125, -0.25, 0.5],
    };
    let mut pts = cloud(40_000, 12);
    for p in &mut pts {
        for a in 0..3 {
            let i = ((p.position[a] - grid.offset[a]) / grid.scale[a]).round() as i32;
            p.position[a] = grid.coordinate(a, i);
        }
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("t.spt");
    let n = pts.len() as u64;
    for colors in [true, false] {
        let want = file::to_bytes(&in_memory_spt(&pts, colors));
        for (prep_chunk, chunk) in [(MIN_CHUNK, 9_000), (9_000, MIN_CHUNK)] {
            let mut written = Vec::new();
            for g in [None, Some(grid)] {
                let records = cloud::ooc::Records { grid: g, colors };
                let (s, prep_bytes) =
                    from_prepared_records(&pts, prep_chunk, &options(chunk, colors), &out, records)
                        .unwrap();
                assert_eq!(
                    std::fs::read(&out).unwrap(),
                    want,
                    "{g:?} {prep_chunk}/{chunk}"
                );
                assert!(s.chunks >= 4, "{s:?}");
                written.push(s.scratch_bytes - prep_bytes);
            }
            // Each point is distributed once: 12 bytes of position instead of 24.
            assert_eq!(written[0] - written[1], 12 * n, "{written:?}");
        }
    }
}

#[test]
fn a_full_disk_while_reading_prepared_chunks_leaves_nothing() {
    let pts = cloud(30_000, 8);
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("t.spt");
    let (s, prep_bytes) = from_prepared(&pts, MIN_CHUNK, &options(MIN_CHUNK, true), &out).unwrap();
    std::fs::remove_file(&out).unwrap();
    // Within the preparation, in the distribution, in the runs and in the merge.
    for after in [
        prep_bytes / 2,
        prep_bytes + 1_000,
        prep_bytes + (s.scratch_bytes - prep_bytes) / 2,
        s.scratch_bytes - 1_000,
    ] {
        let opts = Options {
            fail_after_bytes: Some(after),
            ..options(MIN_CHUNK, true)
        };
        let e = from_prepared(&pts, MIN_CHUNK, &opts, &out).unwrap_err();
        match &e {
            Error::Io { source, .. } => {
                assert_eq!(source.kind(), io::ErrorKind::StorageFull, "{after}: {e}")
            }
            other => panic!("{after}: {other}"),
        }
        let left: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert!(left.is_empty(), "{after}: {left:?}");
    }
}
