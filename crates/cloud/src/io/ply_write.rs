//! Binary little-endian PLY writer.
//!
//! Writes `x y z` as `double`, so the exported points are bit-for-bit the ones experiments use,
//! plus `nx ny nz` (float), `red green blue` (uchar) and `u v` (float) when the cloud has them.
//! The format is simple enough that a hand-written writer is clearer and much faster than
//! building `ply-rs-bw`'s per-element maps; the tests read the output back with `ply-rs-bw`.

use std::io::{self, Write};
use std::path::Path;

use crate::error::{Error, Result};
use crate::points::PointCloud;

/// Writes `cloud` as a binary little-endian PLY file (vertices only).
pub fn write_ply(path: &Path, cloud: &PointCloud) -> Result<()> {
    let io_err = |source| Error::Write {
        path: path.to_owned(),
        source,
    };
    super::atomic::write_with(path, |out| write_ply_to(out, cloud)).map_err(io_err)
}

/// Writes `cloud` as binary little-endian PLY to any writer.
pub fn write_ply_to(out: &mut impl Write, cloud: &PointCloud) -> io::Result<()> {
    let mut header = format!(
        "ply\nformat binary_little_endian 1.0\ncomment written by pointsight\n\
         element vertex {}\nproperty double x\nproperty double y\nproperty double z\n",
        cloud.len()
    );
    if cloud.normals.is_some() {
        header.push_str("property float nx\nproperty float ny\nproperty float nz\n");
    }
    if cloud.colors.is_some() {
        header.push_str("property uchar red\nproperty uchar green\nproperty uchar blue\n");
    }
    if cloud.uvs.is_some() {
        header.push_str("property float u\nproperty float v\n");
    }
    header.push_str("end_header\n");
    out.write_all(header.as_bytes())?;
    for (i, p) in cloud.positions.iter().enumerate() {
        for c in p.to_array() {
            out.write_all(&c.to_le_bytes())?;
        }
        if let Some(normals) = &cloud.normals {
            for c in normals[i].to_array() {
                out.write_all(&c.to_le_bytes())?;
            }
        }
        if let Some(colors) = &cloud.colors {
            out.write_all(&colors[i])?;
        }
        if let Some(uvs) = &cloud.uvs {
            for c in uvs[i].to_array() {
                out.write_all(&c.to_le_bytes())?;
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use glam::{DVec3, Vec2, Vec3};

    use super::*;
    use crate::io::ply::read_ply;

    proptest::proptest! {
        #[test]
        fn any_finite_positions_round_trip(coords in proptest::collection::vec(
            (proptest::num::f64::NORMAL, proptest::num::f64::NORMAL, proptest::num::f64::NORMAL), 1..50)) {
            let cloud = PointCloud {
                positions: coords.iter().map(|&(x, y, z)| DVec3::new(x, y, z)).collect(),
                ..PointCloud::default()
            };
            let mut bytes = Vec::new();
            write_ply_to(&mut bytes, &cloud).unwrap();
            let dir = tempfile::tempdir().unwrap();
            let path = dir.path().join("p.ply");
            std::fs::write(&path, bytes).unwrap();
            proptest::prop_assert_eq!(read_ply(&path).unwrap().cloud.positions, cloud.positions);
        }
    }

    #[test]
    fn round_trip_through_ply_rs_bw() {
        let cloud = PointCloud {
            positions: vec![
                DVec3::new(0.1, -2.5, 1e-9),
                DVec3::new(981.0717163086, 3.0, 4.0),
            ],
            normals: Some(vec![Vec3::X, Vec3::Z]),
            colors: Some(vec![[1, 2, 3], [250, 251, 252]]),
            uvs: Some(vec![Vec2::new(0.25, 0.5), Vec2::new(1.0, 0.0)]),
            ..PointCloud::default()
        };
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("c.ply");
        write_ply(&path, &cloud).unwrap();
        let back = read_ply(&path).unwrap().cloud;
        assert_eq!(back, cloud);
    }
}
