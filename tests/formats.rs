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

/// The unit normals of make_formats.py's normals files.
const NORMALS: [[f32; 3]; 5] = [
    [0.0, 0.0, 1.0],
    [1.0, 0.0, 0.0],
    [0.6, 0.8, 0.0],
    [0.0, -0.6, 0.8],
    [-0.48, 0.6, 0.64],
];

/// Every normal of `got` within `tolerance` of [`NORMALS`] (0: the very f32 values).
fn assert_normals(name: &str, got: &[cloud::glam::Vec3], tolerance: f32) {
    assert_eq!(got.len(), NORMALS.len(), "{name}");
    for (g, want) in got.iter().zip(NORMALS) {
        let want = cloud::glam::Vec3::from_array(want);
        assert!(
            (*g - want).abs().max_element() <= tolerance,
            "{name}: {g} vs {want}"
        );
    }
}

/// A 1 GiB limit: the build's reading of a small file in one batch.
const LIMIT: u64 = 1 << 30;

/// LAS and LAZ normals as laspy writes them under each naming convention (f32 `NormalX`..,
/// f64 `normal x`.. after another field, i16 `nx`.. scaled by 1e-4): read whole, and streamed
/// as `lod-build` reads them (`harness::lod_build::input`), equal to the file's.
#[test]
fn las_and_laz_extra_bytes_normals_under_each_name_streamed_and_whole() {
    for (stem, names, tolerance) in [
        (
            "normals_pdal",
            "NormalX,NormalY,NormalZ (LAS extra bytes, f32)",
            0.0,
        ),
        (
            "normals_spaced",
            "normal x,normal y,normal z (LAS extra bytes, f64)",
            0.0,
        ),
        (
            "normals_nxyz",
            "nx,ny,nz (LAS extra bytes, i16, scaled)",
            1e-6,
        ),
    ] {
        for ext in ["las", "laz"] {
            let name = format!("{stem}.{ext}");
            let whole = read(&data(&name)).unwrap();
            assert_eq!(whole.cloud.positions, expected(), "{name}");
            assert_eq!(whole.normal_fields.as_deref(), Some(names), "{name}");
            assert_normals(&name, whole.cloud.normals.as_deref().unwrap(), tolerance);
            let (info, points) = harness::lod_build::input::read_points(&data(&name), LIMIT)
                .unwrap_or_else(|e| panic!("{name}: {e:#}"));
            assert_eq!(info.normals.as_deref(), Some(names), "{name}");
            let streamed: Vec<_> = points.iter().map(|p| p.normal).collect();
            assert_eq!(
                Some(&streamed),
                whole.cloud.normals.as_ref(),
                "{name}: streamed and whole"
            );
            let positions: Vec<DVec3> = points.iter().map(|p| p.position).collect();
            assert_eq!(positions, expected(), "{name}");
        }
    }
    // A file without normals: none, streamed or whole.
    assert_eq!(read(&data("tiny.laz")).unwrap().normal_fields, None);
    let (info, _) = harness::lod_build::input::read_points(&data("tiny.laz"), LIMIT).unwrap();
    assert_eq!(info.normals, None);
}

/// PLY and PCD normals (written by hand, ASCII) equal the file's, read whole and as the
/// build reads them.
#[test]
fn ply_and_pcd_normals_streamed_and_whole() {
    for (name, fields) in [
        ("tiny_normals.ply", "nx,ny,nz (PLY vertex properties)"),
        (
            "tiny_normals.pcd",
            "normal_x,normal_y,normal_z (PCD fields)",
        ),
    ] {
        let whole = read(&data(name)).unwrap();
        assert_eq!(whole.normal_fields.as_deref(), Some(fields), "{name}");
        assert_normals(name, whole.cloud.normals.as_deref().unwrap(), 0.0);
        let (info, points) = harness::lod_build::input::read_points(&data(name), LIMIT).unwrap();
        assert_eq!(info.normals.as_deref(), Some(fields), "{name}");
        let streamed: Vec<_> = points.iter().map(|p| p.normal).collect();
        assert_eq!(Some(&streamed), whole.cloud.normals.as_ref(), "{name}");
    }
}

/// A LAZ file (written by the `las` crate with our Extra Bytes VLR) whose normal is NaN or of
/// length zero is refused, naming the file and the point, read whole or streamed; so is one
/// whose descriptors place the normals past the record.
#[test]
fn a_laz_whose_normal_is_nan_or_zero_is_refused_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    for (name, bad) in [
        ("nan.laz", [f32::NAN, 0.0, 1.0]),
        ("zero.laz", [0.0, 0.0, 0.0]),
        ("long.las", [0.0, 1.5, 0.0]),
    ] {
        let path = dir.path().join(name);
        let mut header = las::Builder::from((1, 4));
        header.point_format = las::point::Format::new(0).unwrap();
        header.point_format.extra_bytes = cloud::io::las_extra::NORMAL_BYTES;
        header.point_format.is_compressed = name.ends_with(".laz");
        header.vlrs.push(cloud::io::las_extra::write_normals_vlr());
        let mut w = las::Writer::from_path(&path, header.into_header().unwrap()).unwrap();
        for i in 0..4 {
            let n = if i == 2 { bad } else { [0.0, 0.0, 1.0] };
            w.write_point(las::Point {
                x: f64::from(i),
                y: 0.0,
                z: 0.0,
                extra_bytes: cloud::io::las_extra::normal_bytes(n.into()),
                ..las::Point::default()
            })
            .unwrap();
        }
        w.close().unwrap();
        let err = read(&path).unwrap_err().to_string();
        assert!(
            err.contains(name) && err.contains("point 2 has the normal"),
            "{err}"
        );
        let err = format!(
            "{:#}",
            harness::lod_build::input::read_points(&path, LIMIT).unwrap_err()
        );
        assert!(
            err.contains(name) && err.contains("point 2 has the normal"),
            "{err}"
        );
    }
}

/// What we write with normals reads back the same (LAS and LAZ: extra bytes; PLY: nx ny nz),
/// and a normal that is not a unit vector is refused, no file left.
#[test]
fn normals_we_write_read_back_and_bad_ones_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mut cloud = read(&data("tiny_normals.ply")).unwrap().cloud;
    for name in ["n.las", "n.laz", "n.ply"] {
        let path = dir.path().join(name);
        if name.ends_with(".ply") {
            cloud::io::ply_write::write_ply(&path, &cloud).unwrap();
        } else {
            cloud::io::las::write_las(&path, &cloud).unwrap();
        }
        let back = read(&path).unwrap();
        assert_eq!(back.cloud.normals, cloud.normals, "{name}");
    }
    let laz = read(&dir.path().join("n.laz")).unwrap();
    assert_eq!(
        laz.normal_fields.as_deref(),
        Some("NormalX,NormalY,NormalZ (LAS extra bytes, f32)")
    );
    if let Some(n) = cloud.normals.as_mut() {
        n[3] *= 2.0;
    }
    let path = dir.path().join("bad.laz");
    let err = cloud::io::las::write_las(&path, &cloud)
        .unwrap_err()
        .to_string();
    assert!(err.contains("point 3 has the normal"), "{err}");
    assert!(!path.exists());
}

/// `pointsight inspect FILE [ARGS]`: exit code, standard output, standard error.
fn inspect(file: &Path, args: &[&str]) -> (i32, String, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_pointsight"))
        .arg("inspect")
        .arg(file)
        .args(args)
        .output()
        .expect("the pointsight binary runs");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn xyz_columns_are_read_by_the_documented_rule() {
    let dir = tempfile::tempdir().unwrap();
    let file = |name: &str, text: &str| {
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        p
    };
    // Six unnamed columns: integers 0-255 are colours (they were read as normals), unit
    // triples are normals.
    let colours = file(
        "rgb.xyz",
        "0 0 0 200 100 50\n1 0 0 10 20 30\n0 1 0 255 0 0\n",
    );
    let (code, stdout, _) = inspect(&colours, &[]);
    assert_eq!(code, 0);
    assert!(stdout.contains("attributes=colors"), "{stdout}");
    let c = read(&colours).unwrap().cloud;
    assert_eq!(
        c.colors,
        Some(vec![[200, 100, 50], [10, 20, 30], [255, 0, 0]])
    );
    assert_eq!(c.normals, None);
    let normals = file("n.xyz", "0 0 0 0 0 1\n1 0 0 0.6 0 -0.8\n0 1 0 1 0 0\n");
    assert!(inspect(&normals, &[]).1.contains("attributes=normals"));
    // Neither, and both: refused, naming both readings and how to say which.
    let neither = file("neither.xyz", "0 0 0 200 100 50\n1 0 0 0.5 0.5 0.5\n");
    let (code, _, stderr) = inspect(&neither, &[]);
    assert_eq!(code, 1);
    assert!(
        stderr.contains("neither.xyz: file: six columns without a header")
            && stderr.contains("neither normals (line 1:")
            && stderr.contains("nor colours (line 2: 0.5 is not an integer from 0 to 255)")
            && stderr.contains("--columns x,y,z,nx,ny,nz or --columns x,y,z,r,g,b"),
        "{stderr}"
    );
    let both = file("both.xyz", "0 0 0 0 0 1\n1 0 0 1 0 0\n");
    let (code, _, stderr) = inspect(&both, &[]);
    assert_eq!(code, 1);
    assert!(
        stderr.contains("read both as unit normals and as colours"),
        "{stderr}"
    );
    // The flag decides; so does a header, ours or CloudCompare's.
    assert!(
        inspect(&both, &["--columns", "x,y,z,r,g,b"])
            .1
            .contains("attributes=colors")
    );
    assert!(
        inspect(&both, &["--columns", "x,y,z,nx,ny,nz"])
            .1
            .contains("attributes=normals")
    );
    let headed = file("h.xyz", "# x y z nx ny nz\n0 0 0 0 0 1\n1 0 0 1 0 0\n");
    assert!(inspect(&headed, &[]).1.contains("attributes=normals"));
    let cc = file(
        "cc.txt",
        "//X,Y,Z,R,G,B\n0.5,0.25,1,0,0,1\n1.5,0.25,1,1,0,0\n",
    );
    let c = read(&cc).unwrap().cloud;
    assert_eq!(c.colors, Some(vec![[0, 0, 1], [1, 0, 0]]));
    assert_eq!(c.positions[1], DVec3::new(1.5, 0.25, 1.0));
    // A bad flag is a usage error naming the names.
    let (code, _, stderr) = inspect(&both, &["--columns", "x,y,q"]);
    assert_eq!(code, 2);
    assert!(stderr.contains("unknown column \"q\""), "{stderr}");
}
