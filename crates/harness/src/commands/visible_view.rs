//! The commands that look at visible sets, `visible` (one method on one view or many, with
//! `--score`; its body is [`crate::visible`]) and `view` (the interactive 3D page of every
//! method's visible set, [`crate::view`], or of each LOD method's selection with `--lod`): the
//! command line's source flags made a [`visible::Source`].

use crate::run::Run;
use std::path::Path;

use anyhow::Result;

use crate::{cli, view, visible};

/// `pointsight visible`'s `--view`: as given, else every camera of a views file alone, else 0.
pub fn default_view(view: Option<String>, source: &cli::SourceArgs) -> String {
    view.unwrap_or_else(|| {
        if source.camera.views.is_some() {
            "all"
        } else {
            "0"
        }
        .into()
    })
}

/// `pointsight visible`.
pub fn visible(run: &Run, request: &visible::Request, data_dir: &Path) -> Result<()> {
    visible::run(run, request, data_dir).map_err(cli::frame_set)
}

/// `pointsight view`: the page of `request`, an LOD page with `lod` (its eye at `distance`
/// times the view's distance); prints the page's line.
pub fn view(
    run: &Run,
    request: &view::Request,
    lod: bool,
    distance: f64,
    data_dir: &Path,
) -> Result<()> {
    let page = if lod {
        view::lod::run(run, request, view::lod::LodRequest { distance }, data_dir)?
    } else {
        if distance != view::lod::DEFAULT_DISTANCE {
            anyhow::bail!("--distance is for level-of-detail pages (--lod)");
        }
        view::run(run, request, data_dir)?
    };
    println!("{}", page.line());
    Ok(())
}

/// The source flags of `visible` and `view` as a [`visible::Source`].
pub fn source_of(a: cli::SourceArgs) -> Result<visible::Source> {
    source_from(a.dataset, a.files, a.camera)
}

/// A dataset name or a user's files, and the cameras, as a [`visible::Source`] (`visible`,
/// `view`, and `run`, which has no `--dataset`).
pub fn source_from(
    dataset: Option<String>,
    f: cli::FileArgs,
    c: cli::CameraArgs,
) -> Result<visible::Source> {
    Ok(visible::Source {
        dataset,
        cloud: f.cloud,
        mesh: f.mesh,
        read: cloud::io::ReadOptions {
            format: super::parse_format(f.format)?,
            classes: f.classes,
            scan: f.scan,
            columns: f.columns,
        },
        merge_scans: f.merge_scans,
        surface_tolerance: f.surface_tolerance,
        allow_off_surface: f.allow_off_surface,
        camera: visible::CameraFlags {
            eye: c.eye,
            target: c.target,
            up: c.up,
            fov_y_deg: c.fov_y,
            width: c.width,
            height: c.height,
        },
        views: c.views,
    })
}
