//! copc_converter's input: the points as an uncompressed LAS 1.4 file (the `las` crate's
//! writer), point format 7 (position, GPS time, RGB) with one Extra Bytes attribute, `index`
//! (u32, LAS Extra Bytes data type 5), each point's original index, declared by an Extra Bytes
//! VLR (LAS 1.4 R15, section 2.5.2). copc_converter reorders the points into its octree and
//! quantises them; it carries Extra Bytes through to the COPC file (its README: "Preserves LAS
//! Extra Bytes ... end-to-end"), so every point of the COPC file names its original index.
//! [`crate::copc::Copc::verify`] checks that every index comes back exactly once.
//!
//! The positions are quantised by a scale of the largest extent / 2^30 (errors below 10^-9 of
//! the extent; only the selection's splat radius reads them back, never the splats'
//! positions, which are pointsight's own). Colours are the dataset's, 8 bits widened to 16
//! (× 257), or a grey where it has none, so the converter compresses what a user's file holds.

use std::path::Path;

use las::{Builder, Color, Point, Transform, Vector, Vlr, Writer, point::Format};

use crate::error::{Error, Result};
use crate::ply::Points;

/// Name of the index attribute.
pub const INDEX_NAME: &str = "index";

/// LAS Extra Bytes data type of the index: 5, unsigned long (u32).
pub const INDEX_TYPE: u8 = 5;

/// The Extra Bytes VLR describing one u32 attribute named [`INDEX_NAME`].
fn extra_bytes_vlr() -> Vlr {
    let mut d = vec![0u8; 192];
    d[2] = INDEX_TYPE;
    d[4..4 + INDEX_NAME.len()].copy_from_slice(INDEX_NAME.as_bytes());
    let description = b"original index (pointsight)";
    d[160..160 + description.len()].copy_from_slice(description);
    Vlr {
        user_id: "LASF_Spec".into(),
        record_id: 4,
        description: "Extra Bytes Record".into(),
        data: d,
    }
}

/// Writes `points` to `path` as described in the module's doc.
pub fn write(path: &Path, points: &Points) -> Result<()> {
    let las = |source| Error::Las {
        path: path.to_owned(),
        source,
    };
    let n = points.positions.len();
    if n == 0 || n > u32::MAX as usize {
        return Err(Error::Usage(format!(
            "{n} points: copc-lod takes 1 to {} points",
            u32::MAX
        )));
    }
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in &points.positions {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    let extent = (0..3).map(|a| hi[a] - lo[a]).fold(0.0, f64::max);
    let scale = if extent > 0.0 {
        extent / f64::from(1u32 << 30)
    } else {
        1e-9
    };
    let mut b = Builder::from((1, 4));
    b.point_format = Format::new(7).map_err(las)?;
    b.point_format.extra_bytes = 4;
    b.transforms = Vector {
        x: Transform {
            scale,
            offset: lo[0],
        },
        y: Transform {
            scale,
            offset: lo[1],
        },
        z: Transform {
            scale,
            offset: lo[2],
        },
    };
    b.generating_software = "pointsight copc-lod".into();
    b.vlrs.push(extra_bytes_vlr());
    let header = b.into_header().map_err(las)?;
    let mut w = Writer::from_path(path, header).map_err(las)?;
    for (k, p) in points.positions.iter().enumerate() {
        let c = points.colors.as_ref().map_or([200, 200, 200], |c| c[k]);
        let wide = |v: u8| u16::from(v) * 257;
        w.write_point(Point {
            x: p[0],
            y: p[1],
            z: p[2],
            return_number: 1,
            number_of_returns: 1,
            gps_time: Some(0.0),
            color: Some(Color::new(wide(c[0]), wide(c[1]), wide(c[2]))),
            extra_bytes: (k as u32).to_le_bytes().to_vec(),
            ..Default::default()
        })
        .map_err(las)?;
    }
    w.close().map_err(las)
}
