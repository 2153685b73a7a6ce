//! A dataset that is a built LOD file (the manifest's `lod_file`): a QSplat or sequential point
//! tree file that `pointsight lod-build` wrote (told apart by its magic), which the `lod`
//! experiment selects from without loading it (`registry::lod_file`); the other experiments
//! need points and refuse it by name.
//!
//! The file's coordinates are world coordinates (no recentring). Its views are the manifest's
//! views file (world coordinates), or the Fibonacci set of its `view_spec` around the bounds
//! the file keeps (QSplat: the root sphere's box, centre ± radius on each axis; SPT: the leaf
//! discs' box); so they are not the views of the cloud the file was built from unless a views
//! file gives them.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use cloud::Camera;

use super::SourceFile;
use super::files::ViewsFrom;

/// A built LOD file with its views.
#[derive(Debug, Clone)]
pub struct LodFileDataset {
    /// Name used on the command line.
    pub name: String,
    /// The file.
    pub path: PathBuf,
    /// The method that built it (`qsplat`, `spt`).
    pub method: &'static str,
    /// Its points (leaves).
    pub n_points: u64,
    /// Its viewpoints, world coordinates.
    pub views: Vec<Camera>,
    /// The file (and views file) with their SHA-256.
    pub files: Vec<SourceFile>,
}

/// Opens the LOD file at `path` (its header checked) with views from `views`.
pub fn open(name: &str, path: &Path, views: &ViewsFrom) -> Result<LodFileDataset> {
    // A FIFO or a device would block the reads below forever.
    cloud::io::regular_file(path).with_context(|| format!("dataset {name}"))?;
    let info = registry::lod_file::file_info(path).with_context(|| format!("dataset {name}"))?;
    let mut files = vec![SourceFile {
        path: path.to_owned(),
        sha256: crate::fetch::sha256_file(path)?,
    }];
    let views = match views {
        ViewsFrom::Spec(spec) => cloud::views::fibonacci_views(&info.bounds, spec)?,
        ViewsFrom::File(p) => {
            files.push(SourceFile {
                path: p.clone(),
                sha256: crate::fetch::sha256_file(p)
                    .or_else(|_| crate::fetch::sha256_file(&p.join("images.txt")))?,
            });
            cloud::io::views::read_views(p)?
        }
        ViewsFrom::Scanners => bail!("dataset {name}: a lod_file has no scanners"),
    };
    Ok(LodFileDataset {
        name: name.to_owned(),
        path: path.to_owned(),
        method: info.method,
        n_points: info.n_points,
        views,
        files,
    })
}
