//! The points handed to an external program: the cloud written once per program as binary
//! little-endian PLY (`x y z` doubles; with protocol 2 and later the normals, the dataset's
//! or estimated ones, unless the manifest says `normals = false`, and the dataset's colours
//! and texture coordinates), and the normals protocol 2 sends (which our disc ray cast, a
//! peer's partner, uses too).

use std::borrow::Cow;
use std::path::Path;

use cloud::glam::Vec3;

use super::manifest::{ExternalMethod, external_error};
use crate::error::Result;

/// The normals protocol 2 sends for a cloud without its own: 16 nearest neighbours (fewer on
/// a smaller cloud), oriented by Hoppe's spanning tree (`cloud::orient`), as the `lod`
/// experiment estimates them.
pub fn estimated_normals(positions: &[cloud::glam::DVec3]) -> Result<Vec<Vec3>> {
    Ok(cloud::normals::estimate_normals(
        positions,
        16.min(positions.len()),
        cloud::normals::Orientation::Propagated,
    )?)
}

/// The normals protocol 2 sends (and our disc ray cast, its partner, uses): the cloud's own
/// (`"dataset"`), else [`estimated_normals`] (`"estimated"`).
pub fn cloud_normals(cloud: &cloud::PointCloud) -> Result<(Cow<'_, [Vec3]>, &'static str)> {
    Ok(match &cloud.normals {
        Some(n) => (Cow::Borrowed(&n[..]), "dataset"),
        None => (
            Cow::Owned(estimated_normals(&cloud.positions)?),
            "estimated",
        ),
    })
}

/// Writes the cloud for `method`'s program: `x y z` (protocol 1); with protocol 2 and later
/// the normals too (`normals`, else the dataset's, else estimated) unless its manifest says
/// `normals = false`, and the dataset's colours and texture coordinates. Returns the
/// `--normals` word (when normals are sent).
pub(super) fn write_points(
    method: &ExternalMethod,
    path: &Path,
    cloud: &cloud::PointCloud,
    normals: Option<&[Vec3]>,
) -> Result<Option<&'static str>> {
    if method.protocol < 2 {
        let positions_only = cloud::PointCloud {
            positions: cloud.positions.clone(),
            ..Default::default()
        };
        cloud::io::ply_write::write_ply(path, &positions_only)?;
        return Ok(None);
    }
    let (normals, origin) = match (normals, method.sends_normals) {
        (_, false) => (None, None),
        (Some(n), true) => (Some(Cow::Borrowed(n)), Some("given")),
        (None, true) => {
            let (n, origin) = cloud_normals(cloud).map_err(|e| {
                external_error(method.name, format!("cannot estimate normals to send: {e}"))
            })?;
            (Some(n), Some(origin))
        }
    };
    let out = cloud::PointCloud {
        positions: cloud.positions.clone(),
        normals: normals.map(Cow::into_owned),
        colors: cloud.colors.clone(),
        uvs: cloud.uvs.clone(),
        ..Default::default()
    };
    cloud::io::ply_write::write_ply(path, &out)?;
    Ok(origin)
}
