//! Fuzzing every reader: arbitrary bytes and mutated valid files (bytes overwritten, inserted,
//! deleted, truncated, spans duplicated, header numbers replaced by extreme ones) must give an
//! `Ok` or a `ReadError`: no panic, no abort, and no allocation the file's size does not
//! justify. A counting global allocator (`peak_alloc`) records the peak of live bytes while a
//! reader runs; it must stay under `ALLOWANCE + 64 × file size` (the readers reserve at most
//! 2^16 elements before data backs a header's count, and buffer 64 KiB). One test runs every
//! reader in turn, so the process-wide count is the reader's own.
//!
//! A LAS or LAZ that reads without an error has every point inside its header's box (issue
//! 41: corruption is caught, not read as data).
//!
//! Cases: `POINTSIGHT_FUZZ_CASES` per reader (default 400, so about 4,000 in `cargo test`);
//! `POINTSIGHT_SLOW=1` raises the default to 10,000 per reader (10^5 in all).

use std::path::{Path, PathBuf};

use peak_alloc::PeakAlloc;
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};

/// Counts live bytes and their peak (process-wide: this binary has one test, and the readers
/// run on its thread, so the figures are the reader's).
#[global_allocator]
static ALLOCATOR: PeakAlloc = PeakAlloc;

/// Fixed memory a reader may use whatever the file: 2^16 reserved elements of the widest
/// per-point record the readers keep (about 60 bytes), buffers, the E57 and LAZ decoders' state.
const ALLOWANCE: usize = 8 << 20;

fn cases() -> u32 {
    std::env::var("POINTSIGHT_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(if std::env::var("POINTSIGHT_SLOW").as_deref() == Ok("1") {
            10_000
        } else {
            400
        })
}

/// A LAZ of three LASzip chunks (101,000 points: 50,000, 50,000, 1,000), which the reader
/// decodes in parallel: its mutations reach the parallel decoder and the checks before it.
fn several_chunks_laz() -> Vec<u8> {
    let cloud = cloud::PointCloud {
        positions: (0..101_000)
            .map(|i| {
                let t = f64::from(i) * 1e-3;
                cloud::glam::DVec3::new(t.sin(), t.cos(), t * 0.01)
            })
            .collect(),
        ..Default::default()
    };
    let dir = tempfile::tempdir().expect("a temp dir");
    let path = dir.path().join("chunks.laz");
    cloud::io::las::write_las(&path, &cloud).expect("written");
    assert!(
        cloud::io::las::LasStream::open(&path, &Default::default())
            .expect("opens")
            .parallel,
        "the seed goes to the parallel decoder"
    );
    std::fs::read(&path).expect("read back")
}

/// The valid files the mutations start from.
fn seeds(ext: &str) -> Vec<Vec<u8>> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data");
    let file = |rel: &str| std::fs::read(root.join(rel)).expect("a seed file");
    let tri = "0 0 0\n1 0 0\n0 1 0\n0.5 0.5 1\n";
    match ext {
        "ply" => {
            let mut binary = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n".to_vec();
            for v in [0f32, 0., 0., 1., 0., 0., 0., 1., 0.] {
                binary.extend_from_slice(&v.to_le_bytes());
            }
            binary.push(3);
            for i in [0i32, 1, 2] {
                binary.extend_from_slice(&i.to_le_bytes());
            }
            vec![
                b"ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n0 0 0 255 0 0\n1 0 0 0 255 0\n0 1 0 0 0 255\n0.5 0.5 1 1 2 3\n3 0 1 2\n3 0 1 3\n".to_vec(),
                binary,
            ]
        }
        "off" => vec![
            format!("OFF\n4 2 0\n{tri}3 0 1 2\n3 0 1 3\n").into_bytes(),
            file("../../examples/own-data/scene.off"),
        ],
        "obj" => vec![
            b"# a tetrahedron\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvt 0 0\nv 0.5 0.5 1\nf 1/1/1 2 3\nf 1 2 4\nf -1 -2 -3\n".to_vec(),
        ],
        "xyz" => vec![
            tri.as_bytes().to_vec(),
            b"0 0 0 0 0 1\n1 0 0 0 0.6 0.8\n".to_vec(),
            b"# x y z r g b\n0 0 0 0 0 1\n1 0 0 255 10 0\n".to_vec(),
        ],
        "pcd" => vec![
            file("formats/tiny_ascii.pcd"),
            file("formats/tiny_binary.pcd"),
            file("formats/tiny_compressed.pcd"),
        ],
        "las" => vec![file("formats/tiny.las")],
        "laz" => vec![file("formats/tiny.laz"), several_chunks_laz()],
        "e57" => vec![file("formats/tiny.e57")],
        "jsonl" => vec![
            file("../../examples/own-data/scanner.jsonl"),
            br#"{"model":"pinhole","width":64,"height":48,"eye":[0,0,5],"target":[0,0,0],"up":[0,1,0],"fov_y_deg":40}
{"model":"orthographic","width":64,"height":48,"camera_to_world":[[1,0,0,0],[0,-1,0,0],[0,0,-1,5],[0,0,0,1]],"view_width":2,"view_height":1.5}
"#
            .to_vec(),
        ],
        "txt" => vec![file("colmap/images.txt")],
        other => panic!("no seeds for {other}"),
    }
}

/// Numbers that break counts, sizes and offsets when written over a header field.
const EXTREMES: [u64; 8] = [
    0,
    1,
    0x7F,
    0xFFFF,
    0x7FFF_FFFF,
    0xFFFF_FFFF,
    u64::MAX / 2,
    u64::MAX,
];
const TEXT_EXTREMES: [&str; 8] = [
    "0",
    "-1",
    "nan",
    "inf",
    "1e308",
    "99999999999999999999",
    "4294967296",
    "",
];

/// One edit of a file.
#[derive(Debug, Clone)]
enum Edit {
    Overwrite(usize, u8),
    Insert(usize, u8),
    Delete(usize),
    Truncate(usize),
    Duplicate(usize, usize),
    Number(usize, usize, bool),
    Token(usize, usize),
}

fn edit() -> impl Strategy<Value = Edit> {
    prop_oneof![
        (any::<usize>(), any::<u8>()).prop_map(|(p, b)| Edit::Overwrite(p, b)),
        (any::<usize>(), any::<u8>()).prop_map(|(p, b)| Edit::Insert(p, b)),
        any::<usize>().prop_map(Edit::Delete),
        any::<usize>().prop_map(Edit::Truncate),
        (any::<usize>(), 1..64usize).prop_map(|(p, n)| Edit::Duplicate(p, n)),
        (any::<usize>(), 0..EXTREMES.len(), any::<bool>())
            .prop_map(|(p, k, wide)| Edit::Number(p, k, wide)),
        (any::<usize>(), 0..TEXT_EXTREMES.len()).prop_map(|(p, k)| Edit::Token(p, k)),
    ]
}

fn apply(bytes: &mut Vec<u8>, edit: &Edit) {
    let at = |p: usize, len: usize| if len == 0 { 0 } else { p % len };
    match *edit {
        Edit::Overwrite(p, b) => {
            if !bytes.is_empty() {
                let i = at(p, bytes.len());
                bytes[i] = b;
            }
        }
        Edit::Insert(p, b) => {
            let i = at(p, bytes.len() + 1);
            bytes.insert(i, b);
        }
        Edit::Delete(p) => {
            if !bytes.is_empty() {
                let i = at(p, bytes.len());
                bytes.remove(i);
            }
        }
        Edit::Truncate(p) => bytes.truncate(at(p, bytes.len() + 1)),
        Edit::Duplicate(p, n) => {
            let i = at(p, bytes.len() + 1);
            let span: Vec<u8> = bytes[i..(i + n).min(bytes.len())].to_vec();
            bytes.splice(i..i, span);
        }
        Edit::Number(p, k, wide) => {
            let value = EXTREMES[k];
            let raw: Vec<u8> = if wide {
                value.to_le_bytes().to_vec()
            } else {
                (value as u32).to_le_bytes().to_vec()
            };
            let i = at(p, bytes.len() + 1);
            let end = (i + raw.len()).min(bytes.len());
            bytes.splice(i..end, raw);
        }
        Edit::Token(p, k) => {
            // Replace the number (a run of digits) at or after p by an extreme token.
            let i = at(p, bytes.len() + 1);
            let Some(start) = bytes[i..]
                .iter()
                .position(u8::is_ascii_digit)
                .map(|s| s + i)
            else {
                return;
            };
            let len = bytes[start..]
                .iter()
                .take_while(|b| b.is_ascii_digit() || **b == b'.')
                .count();
            bytes.splice(start..start + len, TEXT_EXTREMES[k].bytes());
        }
    }
}

/// A fuzz input: arbitrary bytes, or a seed file with edits.
fn input(ext: &'static str) -> BoxedStrategy<Vec<u8>> {
    let seeds = seeds(ext);
    let n = seeds.len();
    prop_oneof![
        1 => proptest::collection::vec(any::<u8>(), 0..512),
        4 => (0..n, proptest::collection::vec(edit(), 1..6)).prop_map(move |(k, edits)| {
            let mut bytes = seeds[k].clone();
            for e in &edits {
                apply(&mut bytes, e);
            }
            bytes
        }),
    ]
    .boxed()
}

/// Reads one input as `ext`; returns the peak of bytes it allocated beyond what was live, and
/// the error message if any.
fn read_counted(dir: &Path, ext: &str, bytes: &[u8]) -> (usize, Option<String>) {
    let path: PathBuf = if ext == "txt" {
        // A COLMAP model: images.txt beside the valid cameras.txt.
        let cameras =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/colmap/cameras.txt");
        std::fs::copy(cameras, dir.join("cameras.txt")).expect("copy cameras.txt");
        dir.join("images.txt")
    } else {
        dir.join(format!("fuzz.{ext}"))
    };
    std::fs::write(&path, bytes).expect("write the fuzz input");
    let before = ALLOCATOR.current_usage();
    ALLOCATOR.reset_peak_usage();
    let error = if matches!(ext, "jsonl" | "txt") {
        cloud::io::views::read_views(&path).err()
    } else {
        cloud::io::read(&path).err()
    };
    (
        ALLOCATOR.peak_usage().saturating_sub(before),
        error.map(|e| e.to_string()),
    )
}

/// Whether every point `cloud::io::read` gives for the LAS/LAZ `bytes` (read as `fuzz.EXT` in
/// `dir`) lies in the box of its header (bytes 179 to 226), widened by half a step of the
/// scale (bytes 131 to 154) and a few units in the last place.
fn inside_las_box(bytes: &[u8], dir: &Path, ext: &str) -> bool {
    let f = |at: usize| {
        let mut b = [0u8; 8];
        b.copy_from_slice(&bytes[at..at + 8]);
        f64::from_le_bytes(b)
    };
    let loaded = cloud::io::read(&dir.join(format!("fuzz.{ext}"))).expect("read again");
    loaded.cloud.positions.iter().all(|p| {
        (0..3).all(|a| {
            let (hi, lo) = (f(179 + 16 * a), f(187 + 16 * a));
            let slack = 0.5 * f(131 + 8 * a).abs() + 4.0 * f64::EPSILON * lo.abs().max(hi.abs());
            lo - slack <= p[a] && p[a] <= hi + slack
        })
    })
}

fn fuzz(ext: &'static str) {
    let dir = tempfile::tempdir().expect("a temporary folder");
    // A fixed seed per reader, so `cargo test` is reproducible; POINTSIGHT_FUZZ_SEED varies it.
    let seed: u64 = std::env::var("POINTSIGHT_FUZZ_SEED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(0);
    let mut key = [0u8; 32];
    key[..8].copy_from_slice(&seed.to_le_bytes());
    key[8..8 + ext.len()].copy_from_slice(ext.as_bytes());
    let mut runner = TestRunner::new_with_rng(
        Config {
            cases: cases(),
            failure_persistence: None,
            ..Config::default()
        },
        TestRng::from_seed(RngAlgorithm::ChaCha, &key),
    );
    let failed = std::env::temp_dir().join(format!("pointsight-fuzz-failure.{ext}"));
    let worst = std::cell::Cell::new(0usize);
    let result = runner.run(&input(ext), |bytes| {
        let (peak, error) = read_counted(dir.path(), ext, &bytes);
        // `read` catches a parser's panic and reports it; the fuzzing still counts it a failure.
        let message = error.unwrap_or_default();
        let budget = ALLOWANCE + 64 * bytes.len();
        if message.contains("panicked") || peak > budget {
            // The last (smallest) failing input, to reproduce with `pointsight inspect`.
            std::fs::write(&failed, &bytes).expect("keep the failing input");
        }
        prop_assert!(!message.contains("panicked"), "{message}");
        if matches!(ext, "las" | "laz") && message.is_empty() {
            // Corruption is caught, not read as data: whatever a mutated LAS/LAZ decodes to
            // lies in its header's box (with half a step of its scale).
            prop_assert!(
                inside_las_box(&bytes, dir.path(), ext),
                "a point outside the box"
            );
        }
        prop_assert!(
            peak <= budget,
            "a {}-byte .{ext} made the reader hold {peak} bytes (budget {budget})",
            bytes.len()
        );
        worst.set(worst.get().max(peak));
        Ok(())
    });
    if let Err(e) = result {
        panic!(".{ext}: {e} (input kept in {})", failed.display());
    }
    eprintln!(
        "fuzz .{ext}: {} cases, no panic, largest peak {} bytes",
        cases(),
        worst.get()
    );
}

#[test]
fn fuzz_every_reader() {
    for ext in [
        "ply", "off", "obj", "xyz", "pcd", "las", "laz", "e57", "jsonl", "txt",
    ] {
        fuzz(ext);
    }
}
