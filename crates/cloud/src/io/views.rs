//! Views files: the cameras a user brings.
//!
//! - JSON lines (`.jsonl`, `.json`): one camera per line in the camera's one serialisation
//!   (`cloud::camera::json`), tagged with its model; blank lines and lines starting with `#`
//!   are skipped. [`write_views`] writes it.
//! - COLMAP text models: a folder holding `cameras.txt` and `images.txt`, or the path of
//!   `images.txt` itself ([`super::colmap`]).
//!
//! [`read_views`] chooses by the path. Errors name the file and the line.

use std::io::BufRead;
use std::path::Path;

use super::open;
use crate::camera::Camera;
use crate::error::{Location, ReadError, ReadErrorKind};

/// Reads a views file (JSON lines) or a COLMAP text model (folder or `images.txt`).
pub fn read_views(path: &Path) -> Result<Vec<Camera>, ReadError> {
    let is_colmap = path.is_dir() || path.file_name().is_some_and(|n| n == "images.txt");
    if is_colmap {
        let images = if path.is_dir() {
            path.join("images.txt")
        } else {
            path.to_owned()
        };
        return Ok(super::colmap::read_colmap(&images)?
            .into_iter()
            .map(|i| i.camera)
            .collect());
    }
    read_jsonl(path)
}

/// Reads a JSON-lines views file.
pub fn read_jsonl(path: &Path) -> Result<Vec<Camera>, ReadError> {
    let mut reader = open(path)?;
    let mut cameras = Vec::new();
    let mut line = String::new();
    let mut line_no = 0;
    loop {
        line.clear();
        let n = reader
            .read_line(&mut line)
            .map_err(|e| ReadError::new(path, Location::Line(line_no + 1), ReadErrorKind::Io(e)))?;
        if n == 0 {
            break;
        }
        line_no += 1;
        let text = line.trim();
        if text.is_empty() || text.starts_with('#') {
            continue;
        }
        let camera = Camera::from_json(text).map_err(|e| {
            ReadError::new(
                path,
                Location::Line(line_no),
                ReadErrorKind::Camera(e.to_string()),
            )
        })?;
        cameras.push(camera);
    }
    if cameras.is_empty() {
        return Err(ReadError::new(path, Location::File, ReadErrorKind::Empty));
    }
    Ok(cameras)
}

/// The JSON-lines text of `cameras`, one per line.
pub fn write_views(cameras: &[Camera]) -> String {
    let mut s = String::new();
    for c in cameras {
        s.push_str(&c.to_json());
        s.push('\n');
    }
    s
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;
    use crate::camera::Model;

    #[test]
    fn round_trip_and_errors_name_the_line() {
        let dir = tempfile::tempdir().unwrap();
        let cams = vec![
            Camera::new(
                DVec3::new(0.0, 0.0, 4.0),
                DVec3::ZERO,
                DVec3::Y,
                50.0,
                64,
                48,
            )
            .unwrap(),
            Camera::look_at(DVec3::X, DVec3::ZERO, DVec3::Z, Model::Spherical, 64, 32).unwrap(),
        ];
        let path = dir.path().join("views.jsonl");
        std::fs::write(&path, format!("# my views\n\n{}", write_views(&cams))).unwrap();
        assert_eq!(read_views(&path).unwrap(), cams);

        std::fs::write(
            &path,
            format!("{}{{\"model\":\"pinhole\"}}\n", write_views(&cams)),
        )
        .unwrap();
        let err = read_views(&path).unwrap_err();
        assert_eq!(err.location, Location::Line(3));
        assert!(
            err.to_string().contains("views.jsonl: line 3: bad camera"),
            "{err}"
        );

        std::fs::write(&path, "# nothing\n").unwrap();
        assert!(matches!(
            read_views(&path).unwrap_err().kind,
            ReadErrorKind::Empty
        ));
    }
}
