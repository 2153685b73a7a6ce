//! The readers on files written by other tools (laspy, lazrs, pye57) or by hand
//! (`tests/data/formats/make_formats.py` says how), with known values; round trips of what we
//! write; errors naming the file and the place.

use std::path::{Path, PathBuf};

use cloud::glam::DVec3;
use cloud::io::{Format, ReadOptions, read, read_with};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../tests/data/formats")
        .join(name)
}

/// The points of make_formats.py.
fn expected() -> Vec<DVec3> {
    [
        [500000.125, 4000000.250, 100.500],
        [500001.000, 4000000.000, 101.000],
        [500000.000, 4000001.500, 99.750],
        [500002.375, 4000002.000, 100.000],
        [500000.500, 4000000.500, 102.125],
    ]
    .iter()
    .map(|&p| DVec3::from_array(p))
    .collect()
}

const COLORS: [[u8; 3]; 5] = [
    [255, 0, 0],
    [0, 255, 0],
    [0, 0, 255],
    [10, 20, 30],
    [200, 100, 50],
];
const INTENSITY: [u16; 5] = [100, 200, 300, 400, 65535];
const CLASSES: [u8; 5] = [2, 2, 6, 1, 6];

#[test]
fn las_and_laz_from_laspy() {
    for name in ["tiny.las", "tiny.laz"] {
        let c = read(&data(name)).unwrap().cloud;
        assert_eq!(c.positions, expected(), "{name}");
        assert_eq!(c.colors.as_deref(), Some(&COLORS[..]), "{name}");
        assert_eq!(c.intensity.as_deref(), Some(&INTENSITY[..]), "{name}");
        assert_eq!(c.classification.as_deref(), Some(&CLASSES[..]), "{name}");
        // Filtering by classification: buildings (6) only.
        let options = ReadOptions {
            classes: Some(vec![6]),
            ..ReadOptions::default()
        };
        let b = read_with(&data(name), &options).unwrap().cloud;
        assert_eq!(b.positions, vec![expected()[2], expected()[4]]);
        let none = ReadOptions {
            classes: Some(vec![9]),
            ..ReadOptions::default()
        };
        assert!(read_with(&data(name), &none).is_err());
    }
}

#[test]
fn las_laz_round_trip_of_what_we_write() {
    let dir = tempfile::tempdir().unwrap();
    let mut cloud = read(&data("tiny.las")).unwrap().cloud;
    cloud.positions[0] += DVec3::new(1e-4, 0.0, 0.0);
    for name in ["out.las", "out.laz"] {
        let path = dir.path().join(name);
        let scale = cloud::io::las::write_las(&path, &cloud).unwrap();
        let back = read(&path).unwrap().cloud;
        for (a, b) in back.positions.iter().zip(&cloud.positions) {
            assert!(
                (*a - *b).abs().max_element() <= 0.5 * scale + 1e-12,
                "{a} vs {b}"
            );
        }
        assert_eq!(back.colors, cloud.colors);
        assert_eq!(back.intensity, cloud.intensity);
        assert_eq!(back.classification, cloud.classification);
    }
}

#[test]
fn a_laz_of_several_chunks_decodes_in_parallel_as_on_one_thread() {
    // 130,000 points: three LASzip chunks of 50,000 (the writer's default), so the chunk table
    // passes the parallel decoder's checks; the answer must be the one-thread decoder's.
    let n = 130_000;
    let cloud = cloud::PointCloud {
        positions: (0..n)
            .map(|i| {
                let t = f64::from(i) * 1e-3;
                DVec3::new(t.sin() * 10.0, t.cos() * 7.0, t * 0.01)
            })
            .collect(),
        colors: Some(
            (0..n)
                .map(|i| [(i % 251) as u8, (i % 13) as u8, 7])
                .collect(),
        ),
        ..Default::default()
    };
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("many.laz");
    cloud::io::las::write_las(&path, &cloud).unwrap();
    let open = |one_thread| {
        let options = cloud::io::las::LasOptions {
            one_thread,
            ..Default::default()
        };
        let stream = cloud::io::las::LasStream::open(&path, &options).unwrap();
        let parallel = stream.parallel;
        (
            parallel,
            cloud::io::las::read_las(&path, &options).unwrap().cloud,
        )
    };
    let (parallel, many) = open(false);
    let (one, single) = open(true);
    assert!(
        parallel && !one,
        "the parallel decoder was {parallel}, the one-thread {one}"
    );
    assert_eq!(many.positions, single.positions);
    assert_eq!(many.colors, single.colors);
    assert_eq!(many.positions.len(), n as usize);
    // A one-chunk file (the tiny one) stays on one thread.
    let tiny = cloud::io::las::LasStream::open(&data("tiny.laz"), &Default::default()).unwrap();
    assert!(!tiny.parallel);
}

#[test]
fn pcd_ascii_binary_and_compressed_by_hand() {
    let local: Vec<DVec3> = expected()
        .iter()
        .map(|p| *p - DVec3::new(500000.0, 4000000.0, 100.0))
        .collect();
    for name in ["tiny_ascii.pcd", "tiny_binary.pcd", "tiny_compressed.pcd"] {
        let c = read(&data(name)).unwrap().cloud;
        assert_eq!(c.positions, local, "{name}");
        assert_eq!(c.colors.as_deref(), Some(&COLORS[..]), "{name}");
        let i = c.intensity.unwrap();
        for (a, b) in i.iter().zip(INTENSITY) {
            assert!(a.abs_diff(b) <= 1, "{name}: {a} vs {b}");
        }
    }
}

#[test]
fn e57_scans_with_their_poses_from_pye57() {
    let path = data("tiny.e57");
    let scans = cloud::io::e57::read_e57(&path).unwrap();
    assert_eq!(scans.0.len(), 2);
    let mean = expected().iter().copied().sum::<DVec3>() / 5.0;
    let local: Vec<DVec3> = expected().iter().map(|p| *p - mean).collect();
    // Scan 0: identity pose. Scan 1: 90° about z, then moved by (10, 0, 0). pye57 stores
    // the coordinates as 32-bit floats.
    for (a, b) in scans.0[0].cloud.positions.iter().zip(&local) {
        assert!((*a - *b).length() < 1e-6, "{a} vs {b}");
    }
    for (a, b) in scans.0[1].cloud.positions.iter().zip(&local) {
        let rotated = DVec3::new(-b.y, b.x, b.z) + DVec3::new(10.0, 0.0, 0.0);
        assert!((*a - rotated).length() < 1e-6, "{a} vs {rotated}");
    }
    assert_eq!(scans.0[1].scanner.position, DVec3::new(10.0, 0.0, 0.0));
    assert_eq!(scans.0[1].name.as_deref(), Some("scan-b"));
    // The scanner as a spherical camera: looking along its x axis, which the pose turns to +y.
    let cam = scans.0[1].scanner.camera(64, 32).unwrap();
    assert!((cam.forward() - DVec3::Y).length() < 1e-12);
    // Merged by default, each point with its scan; one scan on request.
    let merged = read(&path).unwrap();
    assert_eq!(merged.cloud.len(), 10);
    assert_eq!(
        merged.cloud.scan.as_deref(),
        Some(&[0, 0, 0, 0, 0, 1, 1, 1, 1, 1][..])
    );
    assert_eq!(merged.scanners.len(), 2);
    let one = read_with(
        &path,
        &ReadOptions {
            scan: Some(1),
            ..ReadOptions::default()
        },
    )
    .unwrap();
    assert_eq!(one.cloud.positions, scans.0[1].cloud.positions);
    let err = read_with(
        &path,
        &ReadOptions {
            scan: Some(2),
            ..ReadOptions::default()
        },
    )
    .unwrap_err();
    assert!(err.to_string().contains("scans 0..1"), "{err}");
}

#[test]
fn a_format_can_be_named_and_bad_files_are_named() {
    let dir = tempfile::tempdir().unwrap();
    // A PCD under another extension, read by naming the format.
    let renamed = dir.path().join("points.dat");
    std::fs::copy(data("tiny_ascii.pcd"), &renamed).unwrap();
    assert!(read(&renamed).is_err());
    let c = read_with(
        &renamed,
        &ReadOptions {
            format: Some(Format::Pcd),
            ..ReadOptions::default()
        },
    )
    .unwrap();
    assert_eq!(c.cloud.len(), 5);
    // Truncated binary PCD: the header's count is checked against the file before reading.
    let bytes = std::fs::read(data("tiny_binary.pcd")).unwrap();
    let short = dir.path().join("short.pcd");
    std::fs::write(&short, &bytes[..bytes.len() - 7]).unwrap();
    let err = read(&short).unwrap_err().to_string();
    assert!(
        err.contains("short.pcd") && err.contains("truncated"),
        "{err}"
    );
    // A compressed PCD whose sizes lie.
    let mut bytes = std::fs::read(data("tiny_compressed.pcd")).unwrap();
    let at = bytes
        .windows(22)
        .position(|w| w == b"DATA binary_compressed")
        .unwrap()
        + 23;
    bytes[at + 4..at + 8].copy_from_slice(&u32::MAX.to_le_bytes());
    let lying = dir.path().join("lying.pcd");
    std::fs::write(&lying, &bytes).unwrap();
    let err = read(&lying).unwrap_err().to_string();
    assert!(err.contains("lying.pcd") && err.contains("byte"), "{err}");
    // A LAS file cut short, and one whose header claims more points than it holds.
    let las = std::fs::read(data("tiny.las")).unwrap();
    let cut = dir.path().join("cut.las");
    std::fs::write(&cut, &las[..las.len() - 30]).unwrap();
    let err = read(&cut).unwrap_err().to_string();
    assert!(err.contains("cut.las"), "{err}");
    // An E57 whose XML section is broken.
    let mut e57 = std::fs::read(data("tiny.e57")).unwrap();
    if let Some(at) = e57.windows(5).position(|w| w == b"<?xml") {
        e57[at + 1] = b'!';
    }
    let broken = dir.path().join("broken.e57");
    std::fs::write(&broken, &e57).unwrap();
    let err = read(&broken).unwrap_err().to_string();
    assert!(err.contains("broken.e57"), "{err}");
    // Empty files.
    for ext in ["las", "laz", "pcd", "e57", "obj"] {
        let empty = dir.path().join(format!("empty.{ext}"));
        std::fs::write(&empty, b"").unwrap();
        let err = read(&empty).unwrap_err().to_string();
        assert!(err.contains(&format!("empty.{ext}")), "{err}");
    }
}
