//! `pointsight fetch`: the real meshes, from Debian's `libcgal-demo` package, checksummed.
//!
//! The catalogue of those meshes ([`MESH_FILES`]: file, path in the package, SHA-256) is here,
//! with the meshes a learned method is trained on ([`TRAINING_MESH_FILES`], fetched apart);
//! the built-in datasets made of them are [`crate::datasets::builtin`]'s.
//!
//! Steps, each skipped when its result is already there (the command is idempotent):
//! 1. every mesh in [`MESH_FILES`] present under `bench-data/meshes/` with the right SHA-256:
//!    nothing to do;
//! 2. otherwise find `bench-data/.cache/libcgal-demo_*.deb`, or download it with
//!    `apt-get download libcgal-demo` into that folder;
//! 3. stream the package's file system out with `dpkg-deb --fsys-tarfile`, take
//!    `usr/share/doc/libcgal-dev/data.tar.gz` from it and the meshes from that (`tar` and
//!    `flate2` crates: no `tar` binary, nothing unpacked that is not needed);
//! 4. check each mesh's SHA-256 and move it into place (write to a temporary file, rename).
//!
//! Where `apt-get` or `dpkg-deb` is missing the error says so and how to proceed by hand.

use std::fs;
use std::io::{self, Read};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use anyhow::{Context, Result, bail};
use sha2::{Digest, Sha256};

/// A mesh file of the fetched data set.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MeshFile {
    /// File name under `bench-data/meshes/`.
    pub file: &'static str,
    /// Path inside `data.tar.gz` of `libcgal-demo`.
    pub archive_path: &'static str,
    /// SHA-256 of the file.
    pub sha256: &'static str,
}

/// The Stanford Bunny as CGAL ships it (37,706 vertices, 75,408 triangles, closed).
pub const BUNNY_MESH: MeshFile = MeshFile {
    file: "bunny00.off",
    archive_path: "data/meshes/bunny00.off",
    sha256: "ab651cb04955c161efaeb079035a1e5e1f0e0d1f816a2df67beaea68f393ff2b",
};

/// The Chinese Dragon as CGAL ships it (10,000 vertices, 19,994 triangles).
pub const DRAGON_MESH: MeshFile = MeshFile {
    file: "ChineseDragon-10kv.off",
    archive_path: "data/meshes/ChineseDragon-10kv.off",
    sha256: "f633bdfaac7a0f99e0fab668c34862f0c26f341cfdb4665bab282d79b788db02",
};

/// The Armadillo as CGAL ships it (26,002 vertices, 52,000 triangles): the real mesh standing
/// in for seed 003's gargoyle.
pub const ARMADILLO_MESH: MeshFile = MeshFile {
    file: "armadillo.off",
    archive_path: "data/meshes/armadillo.off",
    sha256: "6f7f3ca1abc506569466b72f2f59d49493a284e7376d7a7e23c08115ec8cec4e",
};

/// An elephant (2,775 vertices, 5,558 triangles, closed): trunk, tusks and legs that hide one
/// another. An evaluation mesh (the tuning/evaluation protocol: never used for tuning).
pub const ELEPHANT_MESH: MeshFile = MeshFile {
    file: "elephant.off",
    archive_path: "data/meshes/elephant.off",
    sha256: "be4e1ea68f5f840a3d2ada69d828222e76a57d9e25b21e19a9deacd3f2328e02",
};

/// A camel (9,770 vertices, 19,536 triangles, closed): four thin legs, neck and humps. An
/// evaluation mesh.
pub const CAMEL_MESH: MeshFile = MeshFile {
    file: "camel.off",
    archive_path: "data/meshes/camel.off",
    sha256: "9ac960a9fee27e6fcc6baaa2340260834625084ee20f4a97194212404e650a22",
};

/// A triceratops (2,832 vertices, 5,660 triangles, closed): legs, horns and frill. An
/// evaluation mesh.
pub const TRICERATOPS_MESH: MeshFile = MeshFile {
    file: "triceratops.off",
    archive_path: "data/meshes/triceratops.off",
    sha256: "0fb444933884486a09eb4329a832f15ab792590f2a5bb75385d157e654ddbf5c",
};

/// A head and shoulders bust ("mannequin devil": 12,977 vertices, 25,888 triangles, open at the
/// neck: 64 boundary edges): smooth concavities (eye sockets, ears, neck) rather than limbs. An
/// evaluation mesh.
pub const MANNEQUIN_MESH: MeshFile = MeshFile {
    file: "mannequin-devil.off",
    archive_path: "data/meshes/mannequin-devil.off",
    sha256: "9424b7132b58766984051fb7757543e88972f91fe7e9565d4e5b715b204f74a5",
};

/// Every mesh `pointsight fetch` provides.
pub const MESH_FILES: &[MeshFile] = &[
    BUNNY_MESH,
    DRAGON_MESH,
    ARMADILLO_MESH,
    ELEPHANT_MESH,
    CAMEL_MESH,
    TRICERATOPS_MESH,
    MANNEQUIN_MESH,
];

/// A training mesh of `data/meshes/` in the package, by name and SHA-256.
macro_rules! training {
    ($name:literal, $sha256:literal) => {
        MeshFile {
            file: concat!($name, ".off"),
            archive_path: concat!("data/meshes/", $name, ".off"),
            sha256: $sha256,
        }
    };
}

/// The meshes a learned method may be trained on (the `neuralvis` training's): 36 further meshes
/// of the same package, none of them a tuning or an evaluation dataset's. `fetch_training`
/// puts them in `bench-data/training-meshes/`, apart from the benchmark's.
#[rustfmt::skip]
pub const TRAINING_MESH_FILES: &[MeshFile] = &[
    training!("anchor", "5009b3400b73ef199b6ac9a24a27f4f76e1aa7b71d957a50cb6dcbe09868ff3b"),
    training!("bear", "058f6ce62635e5f86958adea9706a8dca3ebe4fae76a0d32b8318d107d40bda6"),
    training!("blobby", "ab217f67fefdf8a8e01563d09135f05ab02330064a3c0180570546887d01b7f1"),
    training!("bones", "004bd26f0029910eb2e2fd38b7ca11ea05dd4182e247c0fb778533b860dd7ab2"),
    training!("cactus", "333a41cbf5e30f2f675392adb7b0f7fb3f5919b39f15d2ae280830e662247925"),
    training!("couplingdown", "01fc9017b44a803b1130f8f5d51f0c7d8bbfa27b908f5166c498fe21e57f2284"),
    training!("cross", "712151027be1e259be1a4049a383ad8884ced0282d4c64e75d0cc4d24e6005ab"),
    training!("diplodocus", "661fdac29eca4b205e354da112b3cbfd08dcfae07df989234b71421e62521c96"),
    training!("dragknob", "4411436ff04757c16ad1c08d631c86ef7e968f1e026193e668c66a19951ca10c"),
    training!("eight", "58fa129fbd64d519034b12c73ecb463ae55832710aa34fddd0504debd044f71d"),
    training!("elk", "7f1229fd3de0b4fc0884bbbfbd056a57ff0cb0f7afd71b5168a84209cc585abb"),
    training!("fandisk", "edffb263f037b023757259befd5532fccb48bdc3c35a1da2e11e235a647bd050"),
    training!("femur", "75d208fabf7a7b134cfcf2171bad68c331e3bff55309ffe38a01a7b31352fbc6"),
    training!("hand", "cfcf1562726167ca704a091a8651bfd1d72f6eb96b4b2819321f0520721b35c7"),
    training!("handle", "df86377baeaa1ed1a437710e0364a72af06d3bca21b84a57cd1b46a64f67f054"),
    training!("head", "75aecfdbf9c0386dd839f5bf0322fb5a889ed7efd31d040f125e383041b4b919"),
    training!("helmet", "0669ab781a80570cfdd2932b06a7c33f89fd855a9ddb69dc45e50082253a5a32"),
    training!("horizons", "d46d1272317bf7e1603b6bb42274f06e53c05f5421fc3e122a0e32fa1e11d43b"),
    training!("joint", "a412da1a4b90a1d018d44e0b06307ee692da4afd255975d2a93945e091098649"),
    training!("knot1", "13d9d2f3459189630680dad6a3b5528d5cc794967b791580a0e1f6642903d030"),
    training!("knot2", "6c90e93f1a966abd73847d40909a90c0b2067affdd471a27b50c2d4416142c06"),
    training!("mech-holes-shark", "2ad3d8fb970b319eb8a32040664c25d4e01370f20ad57f4fde5c63fef3b6cca9"),
    training!("mushroom", "03768b314714676d9305361c7c124be3b2c991c59fe8c752a49047115b4dfa00"),
    training!("nefertiti", "d8b13239b988d0262fbc91e88da1d314eeb1b284c327a3fe76089c2b54886ccf"),
    training!("pinion", "191a8cdfa3807e09d7dffb4bdc94dabe1231b4594001ca134100a9a32e996599"),
    training!("pipe", "de951aa3c0c9f6617b422e833116a1523fd41abfb588444f71eeed42378ef9bf"),
    training!("rotor", "8db85ca5041eef6d952e48f0553a25fddb42f237b80a37b7aff096b8df3aca32"),
    training!("spool", "84ec2367becf6994f96055fa88aaf3a00df1fdd84bd0fa615bdc043c9944b7b1"),
    training!("star", "8a7a48b6641373552134c30cf9c36888ade73e9def5bafe100b7536b9740078f"),
    training!("tripod", "f31df43fc9209d8863eb48b0bb1ca088169ffab52d5d93096e87d6bee26c982d"),
    training!("turbine", "8ae52b6b325a05e0755983706ab55aba0f42d3ea0569dd29b33cdcb16c20f4c8"),
    training!("double-torus-3-holes", "12243967111005f77d8b1bf8fa09df9984738f5ed85a20603eead8a2dc7e0055"),
    training!("blob", "01008093fb7b30be2865d579a018bc930e7462c08ffd42773f452e74a4347b0c"),
    training!("three_peaks", "6b985fb7f6f2a6dc15dd311758aa1eeb0725cfb32bcacef8a767b910c9a2d8d4"),
    training!("retinal", "02547bcd1f28149862ff28056614418c0fca73033dfec1a07e8e91e4c78544b7"),
    training!("boeing", "a50af346f5fda821844907e2f020f27a9d399dc5c39f4fbb5344f13ca6002a7a"),
];

/// The folder under the data folder that [`fetch_training`] fills.
pub const TRAINING_MESHES_DIR: &str = "training-meshes";

/// Path of a fetched mesh under `data_dir`.
pub fn mesh_path(data_dir: &Path, mesh: &MeshFile) -> PathBuf {
    data_dir.join("meshes").join(mesh.file)
}

const PACKAGE: &str = "libcgal-demo";
const DATA_ARCHIVE: &str = "usr/share/doc/libcgal-dev/data.tar.gz";

/// Lower-case hex SHA-256 of `bytes`.
pub fn sha256_hex(bytes: &[u8]) -> String {
    hex(&Sha256::digest(bytes))
}

/// Lower-case hex of a digest.
fn hex(digest: &[u8]) -> String {
    digest.iter().map(|b| format!("{b:02x}")).collect()
}

/// True when `path` exists and has the expected checksum.
/// SHA-256 of a file, hex, read in chunks (user files can be gigabytes).
pub fn sha256_file(path: &Path) -> Result<String> {
    let mut file =
        fs::File::open(path).with_context(|| format!("cannot read {}", path.display()))?;
    let mut hasher = Sha256::new();
    let mut buf = vec![0u8; 1 << 20];
    loop {
        let n = file
            .read(&mut buf)
            .with_context(|| format!("cannot read {}", path.display()))?;
        if n == 0 {
            break;
        }
        hasher.update(&buf[..n]);
    }
    Ok(hex(&hasher.finalize()))
}

fn is_valid(path: &Path, mesh: &MeshFile) -> Result<bool> {
    match fs::read(path) {
        Ok(bytes) => Ok(sha256_hex(&bytes) == mesh.sha256),
        Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(false),
        Err(e) => Err(e).with_context(|| format!("cannot read {}", path.display())),
    }
}

/// What `fetch` did, for its report.
#[derive(Debug, Default)]
pub struct FetchReport {
    /// Meshes that were already in place.
    pub present: Vec<&'static str>,
    /// Meshes written by this call.
    pub written: Vec<&'static str>,
}

/// Makes sure every mesh is in `data_dir/meshes`, downloading the package if needed.
pub fn fetch(data_dir: &Path) -> Result<FetchReport> {
    fetch_into(data_dir, "meshes", MESH_FILES)
}

/// Makes sure every training mesh ([`TRAINING_MESH_FILES`]) is in
/// `data_dir/training-meshes`, from the same package.
pub fn fetch_training(data_dir: &Path) -> Result<FetchReport> {
    fetch_into(data_dir, TRAINING_MESHES_DIR, TRAINING_MESH_FILES)
}

/// Path of a fetched training mesh under `data_dir`.
pub fn training_mesh_path(data_dir: &Path, mesh: &MeshFile) -> PathBuf {
    data_dir.join(TRAINING_MESHES_DIR).join(mesh.file)
}

/// Makes sure every mesh of `catalogue` is in `data_dir/folder`.
fn fetch_into(
    data_dir: &Path,
    folder: &str,
    catalogue: &'static [MeshFile],
) -> Result<FetchReport> {
    let path_of = |mesh: &MeshFile| data_dir.join(folder).join(mesh.file);
    let mut report = FetchReport::default();
    let mut missing = Vec::new();
    for mesh in catalogue {
        if is_valid(&path_of(mesh), mesh)? {
            report.present.push(mesh.file);
        } else {
            missing.push(*mesh);
        }
    }
    if missing.is_empty() {
        return Ok(report);
    }
    let cache = data_dir.join(".cache");
    fs::create_dir_all(&cache).with_context(|| format!("cannot create {}", cache.display()))?;
    let deb = match find_deb(&cache)? {
        Some(deb) => deb,
        None => download_deb(&cache)?,
    };
    let archive = data_archive_from_deb(&deb)?;
    let meshes_dir = data_dir.join(folder);
    fs::create_dir_all(&meshes_dir)
        .with_context(|| format!("cannot create {}", meshes_dir.display()))?;
    let mut tar = tar::Archive::new(flate2::read::GzDecoder::new(&archive[..]));
    for entry in tar
        .entries()
        .context("data.tar.gz is not a tar.gz archive")?
    {
        let mut entry = entry.context("corrupt entry in data.tar.gz")?;
        let path = entry
            .path()?
            .to_string_lossy()
            .trim_start_matches("./")
            .to_owned();
        let Some(mesh) = missing.iter().find(|m| m.archive_path == path) else {
            continue;
        };
        let mut bytes = Vec::new();
        entry.read_to_end(&mut bytes)?;
        let sum = sha256_hex(&bytes);
        if sum != mesh.sha256 {
            bail!(
                "{} in {} has SHA-256 {sum}, expected {}: a different libcgal-demo version? \
                 pointsight's datasets are defined on 5.5.1 (Debian 12)",
                mesh.archive_path,
                deb.display(),
                mesh.sha256
            );
        }
        let target = path_of(mesh);
        let tmp = target.with_extension("off.part");
        fs::write(&tmp, &bytes).with_context(|| format!("cannot write {}", tmp.display()))?;
        fs::rename(&tmp, &target).with_context(|| format!("cannot write {}", target.display()))?;
        report.written.push(mesh.file);
    }
    let not_found: Vec<_> = missing
        .iter()
        .filter(|m| !report.written.contains(&m.file))
        .map(|m| m.archive_path)
        .collect();
    if !not_found.is_empty() {
        bail!("{} lacks {}", deb.display(), not_found.join(", "));
    }
    Ok(report)
}

fn find_deb(cache: &Path) -> Result<Option<PathBuf>> {
    let mut debs: Vec<PathBuf> = fs::read_dir(cache)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with(PACKAGE) && n.ends_with(".deb"))
        })
        .collect();
    debs.sort();
    Ok(debs.pop())
}

fn download_deb(cache: &Path) -> Result<PathBuf> {
    eprintln!(
        "downloading {PACKAGE} with apt-get into {}",
        cache.display()
    );
    let status = Command::new("apt-get")
        .args(["download", PACKAGE])
        .current_dir(cache)
        .stdin(Stdio::null())
        .status();
    match status {
        Err(e) if e.kind() == io::ErrorKind::NotFound => bail!(
            "apt-get is not available here. Download {PACKAGE} (5.5.1-2, Debian 12) by hand from a \
             Debian mirror, put the .deb into {} and run `pointsight fetch` again",
            cache.display()
        ),
        Err(e) => Err(e).context("cannot run apt-get"),
        Ok(s) if !s.success() => bail!(
            "`apt-get download {PACKAGE}` failed ({s}); run `apt-get update` first if the package \
             lists are empty, or put the .deb into {} by hand",
            cache.display()
        ),
        Ok(_) => find_deb(cache)?.with_context(|| {
            format!(
                "apt-get reported success but no {PACKAGE} .deb is in {}",
                cache.display()
            )
        }),
    }
}

fn data_archive_from_deb(deb: &Path) -> Result<Vec<u8>> {
    let child = Command::new("dpkg-deb")
        .arg("--fsys-tarfile")
        .arg(deb)
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn();
    let mut child = match child {
        Err(e) if e.kind() == io::ErrorKind::NotFound => bail!(
            "dpkg-deb is not available here; extract {DATA_ARCHIVE} from {} by hand and put \
             data/meshes/*.off into bench-data/meshes/",
            deb.display()
        ),
        other => other.context("cannot run dpkg-deb")?,
    };
    let stdout = child.stdout.take().context("dpkg-deb has no stdout")?;
    let mut found = None;
    let mut outer = tar::Archive::new(stdout);
    for entry in outer.entries()? {
        let mut entry = entry?;
        let path = entry
            .path()?
            .to_string_lossy()
            .trim_start_matches("./")
            .to_owned();
        if path == DATA_ARCHIVE {
            let mut bytes = Vec::new();
            entry.read_to_end(&mut bytes)?;
            found = Some(bytes);
            break;
        }
    }
    // Drain and reap the child whatever happened above.
    drop(outer);
    let status = child.wait()?;
    match found {
        Some(bytes) => Ok(bytes),
        None if !status.success() => bail!("dpkg-deb failed on {} ({status})", deb.display()),
        None => bail!("{} has no {DATA_ARCHIVE}", deb.display()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_catalogue_entry_is_checksummed_and_the_fetched_files_match() {
        for (i, m) in MESH_FILES.iter().enumerate() {
            assert!(
                MESH_FILES[i + 1..].iter().all(|o| o.file != m.file),
                "{} twice",
                m.file
            );
            assert_eq!(m.archive_path, format!("data/meshes/{}", m.file));
            assert!(
                m.sha256.len() == 64
                    && m.sha256
                        .bytes()
                        .all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b)),
                "{}: {}",
                m.file,
                m.sha256
            );
        }
        // With the fetched meshes (`just test` fetches first): each file in the clone's data
        // folder has its catalogue checksum, the one `fetch` checks the package's copy against.
        if std::env::var_os("POINTSIGHT_REAL_DATA").is_some() {
            let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../bench-data");
            for m in MESH_FILES {
                let path = mesh_path(&data, m);
                let sum =
                    sha256_file(&path).unwrap_or_else(|e| panic!("{e:#} (run `pointsight fetch`)"));
                assert_eq!(sum, m.sha256, "{}", path.display());
                assert!(is_valid(&path, m).unwrap());
            }
        }
    }

    #[test]
    fn the_training_catalogue_is_checksummed_and_shares_no_mesh_with_the_benchmark() {
        assert_eq!(TRAINING_MESH_FILES.len(), 36);
        for (i, m) in TRAINING_MESH_FILES.iter().enumerate() {
            assert!(
                TRAINING_MESH_FILES[i + 1..]
                    .iter()
                    .all(|o| o.file != m.file),
                "{} twice",
                m.file
            );
            assert!(
                MESH_FILES
                    .iter()
                    .all(|b| b.file != m.file && b.sha256 != m.sha256)
            );
            assert_eq!(m.archive_path, format!("data/meshes/{}", m.file));
            assert_eq!(m.sha256.len(), 64, "{}", m.file);
        }
    }

    #[test]
    fn sha256_of_known_input() {
        assert_eq!(
            sha256_hex(b"abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
    }
}
