//! The points `lod-build` prepares, batch by batch, from any point file: a LAS or LAZ file
//! streamed ([`read_ahead`](super::read_ahead), its extra-bytes normals where it has them), any
//! other format read whole first and handed over in batches. Each point carries its colour and
//! normal where the file gives them; what the file gives is in [`Info`].

use std::path::Path;
use std::thread::Scope;

use anyhow::Result;
use cloud::glam::Vec3;
use cloud::lod_file::Error;
use cloud::ooc::Point;

use super::read_ahead::ReadAhead;

/// Points handed over at a time from a file read whole.
const WHOLE_BATCH: usize = 1 << 16;

/// What an input file gives.
#[derive(Debug, Clone, PartialEq)]
pub struct Info {
    /// Points (a LAS or LAZ file's header's count; a file read whole, its points).
    pub points: u64,
    /// Whether the points have colours.
    pub colors: bool,
    /// Where the file's normals come from (`cloud::io::Loaded::normal_fields`), or `None`
    /// when it gives none (they are then estimated).
    pub normals: Option<String>,
    /// The grid a LAS or LAZ file's positions lie on (the scratch keeps its integers).
    pub grid: Option<cloud::ooc::Grid>,
}

/// The points of an input file, in the file's order.
pub struct Input<'scope> {
    ahead: Option<ReadAhead<'scope>>,
    loaded: Option<cloud::PointCloud>,
    at: usize,
}

impl<'scope> Input<'scope> {
    /// Opens `path`: a LAS or LAZ file is decoded on a thread of `scope` in batches that
    /// `memory_limit` allows; any other file is read whole now.
    pub fn open<'env>(
        scope: &'scope Scope<'scope, 'env>,
        path: &'env Path,
        memory_limit: u64,
    ) -> Result<(Self, Info)> {
        if cloud::io::Format::of_path(path) == Some(cloud::io::Format::Las) {
            let (ahead, info) = ReadAhead::open(scope, path, memory_limit)?;
            let info = Info {
                points: info.announced,
                colors: info.with_color,
                normals: info.normals.as_ref().map(|n| n.describe()),
                // A LAS file's positions are integers of its grid: the scratch keeps those.
                grid: Some(info.grid),
            };
            return Ok((
                Input {
                    ahead: Some(ahead),
                    loaded: None,
                    at: 0,
                },
                info,
            ));
        }
        let loaded = cloud::io::read_with(path, &cloud::io::ReadOptions::default())?;
        let c = loaded.cloud;
        let info = Info {
            points: c.len() as u64,
            colors: c.colors.is_some(),
            normals: loaded.normal_fields,
            grid: None,
        };
        Ok((
            Input {
                ahead: None,
                loaded: Some(c),
                at: 0,
            },
            info,
        ))
    }

    /// Appends the next batch to `batch` (or replaces it: it is cleared by the caller);
    /// `false` after the last. A file read whole is dropped with its last batch.
    pub fn next(&mut self, batch: &mut Vec<Point>) -> Result<bool, Error> {
        if let Some(a) = self.ahead.as_mut() {
            return a.next(batch);
        }
        let Some(c) = self.loaded.as_ref() else {
            return Ok(false);
        };
        let end = (self.at + WHOLE_BATCH).min(c.len());
        batch.extend((self.at..end).map(|i| Point {
            position: c.positions[i],
            normal: c.normals.as_ref().map_or(Vec3::ZERO, |n| n[i]),
            color: c.colors.as_ref().map_or([0; 3], |k| k[i]),
        }));
        self.at = end;
        let more = self.at < c.len();
        if !more {
            self.loaded = None;
        }
        Ok(more)
    }
}

/// Every point of `path` as `lod-build` reads it within `memory_limit` (batch by batch, as
/// [`Input`] gives them), and what the file gives: for tests and tools that check what a
/// build is fed.
pub fn read_points(path: &Path, memory_limit: u64) -> Result<(Info, Vec<Point>)> {
    std::thread::scope(|scope| {
        let (mut input, info) = Input::open(scope, path, memory_limit)?;
        let mut all = Vec::new();
        let mut batch = Vec::new();
        loop {
            batch.clear();
            let more = input.next(&mut batch)?;
            all.extend_from_slice(&batch);
            if !more {
                break;
            }
        }
        Ok((info, all))
    })
}
