//! COLMAP text models: `cameras.txt` (intrinsics) and `images.txt` (poses).
//!
//! Format (COLMAP's documentation, "Output format"):
//! - `cameras.txt`: `CAMERA_ID MODEL WIDTH HEIGHT PARAMS...` per line; `SIMPLE_PINHOLE` has
//!   `f cx cy`, `PINHOLE` has `fx fy cx cy`. Models with lens distortion (`SIMPLE_RADIAL`,
//!   `RADIAL`, `OPENCV`, `FULL_OPENCV`, `OPENCV_FISHEYE`, ...) are refused with an error naming
//!   the model: undistort first (`colmap image_undistorter` writes `PINHOLE` cameras).
//! - `images.txt`: two lines per image, `IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME` and the
//!   image's 2-d points (ignored; the line may be empty). The pose is world-to-camera: x_cam =
//!   R(q)·x_world + t, camera axes x right, y down, z forward (OpenCV), so the eye is −Rᵀt.
//! - `#` lines are comments. COLMAP's pixel convention (the centre of the top-left pixel is
//!   (0.5, 0.5)) is ours, so cx, cy are used as they are.
//!
//! - The header comments COLMAP writes (`# Number of cameras: N`, `# Number of images: N,
//!   mean observations per image: M`) are checked against the lines read: a file cut short is
//!   an error, not fewer views. Files without them (written by hand) are read as they are.
//!
//! Errors name the file and the line.

use std::collections::BTreeMap;
use std::io::BufRead;
use std::path::{Path, PathBuf};

use super::{open, parse_f64};
use crate::camera::{Camera, Model};
use crate::error::{Location, ReadError, ReadErrorKind};

/// One registered image.
#[derive(Debug, Clone, PartialEq)]
pub struct ColmapImage {
    /// COLMAP's image id.
    pub image_id: u64,
    /// The image file name.
    pub name: String,
    /// Its camera (intrinsics of its CAMERA_ID, pose of the image).
    pub camera: Camera,
}

/// The data lines of a model file (number, text), and the count its header comment declares
/// (`# Number of images: N, ...`, as COLMAP writes it) with that comment's line number.
struct Lines {
    data: Vec<(usize, String)>,
    declared: Option<(usize, u64)>,
}

fn lines(path: &Path, what: &str) -> Result<Lines, ReadError> {
    let reader = open(path)?;
    let mut out = Lines {
        data: Vec::new(),
        declared: None,
    };
    let key = format!("Number of {what}:");
    for (k, line) in reader.lines().enumerate() {
        let line =
            line.map_err(|e| ReadError::new(path, Location::Line(k + 1), ReadErrorKind::Io(e)))?;
        let trimmed = line.trim_start();
        if let Some(comment) = trimmed.strip_prefix('#') {
            if let Some(rest) = comment.trim_start().strip_prefix(&key)
                && out.declared.is_none()
            {
                let digits: String = rest
                    .trim_start()
                    .chars()
                    .take_while(char::is_ascii_digit)
                    .collect();
                out.declared = digits.parse().ok().map(|n| (k + 1, n));
            }
        } else {
            out.data.push((k + 1, line));
        }
    }
    Ok(out)
}

/// Fails when the file declares a count of `what` other than `found` (a file cut short, or
/// lines lost).
fn check_declared(path: &Path, lines: &Lines, what: &str, found: usize) -> Result<(), ReadError> {
    match lines.declared {
        Some((line, n)) if n != found as u64 => Err(ReadError::new(
            path,
            Location::Line(line),
            ReadErrorKind::Truncated {
                what: if what == "images" {
                    "images"
                } else {
                    "cameras"
                },
                expected: usize::try_from(n).unwrap_or(usize::MAX),
                found,
            },
        )),
        _ => Ok(()),
    }
}

fn numbers(tokens: &[&str]) -> Result<Vec<f64>, ReadErrorKind> {
    tokens.iter().map(|t| parse_f64(t)).collect()
}

fn integer(token: &str) -> Result<u64, ReadErrorKind> {
    token.parse().map_err(|_| ReadErrorKind::NotANumber {
        field: token.to_owned(),
    })
}

/// Reads `cameras.txt`: camera id → (model, width, height).
pub fn read_cameras(path: &Path) -> Result<BTreeMap<u64, (Model, u32, u32)>, ReadError> {
    let mut cameras = BTreeMap::new();
    let lines = lines(path, "cameras")?;
    for (line_no, line) in lines.data.iter().cloned() {
        let here = |kind| ReadError::new(path, Location::Line(line_no), kind);
        let tokens: Vec<&str> = line.split_whitespace().collect();
        if tokens.is_empty() {
            continue;
        }
        if tokens.len() < 4 {
            return Err(here(ReadErrorKind::FieldCount {
                expected: 4,
                found: tokens.len(),
            }));
        }
        let id = integer(tokens[0]).map_err(here)?;
        let width = integer(tokens[2]).map_err(here)?;
        let height = integer(tokens[3]).map_err(here)?;
        let (Ok(width), Ok(height)) = (u32::try_from(width), u32::try_from(height)) else {
            return Err(here(ReadErrorKind::Camera(format!(
                "image size {width}x{height} is too large"
            ))));
        };
        let params = numbers(&tokens[4..]).map_err(here)?;
        let need = |n: usize| {
            if params.len() == n {
                Ok(())
            } else {
                Err(here(ReadErrorKind::FieldCount {
                    expected: 4 + n,
                    found: tokens.len(),
                }))
            }
        };
        let model = match tokens[1] {
            "SIMPLE_PINHOLE" => {
                need(3)?;
                Model::Pinhole {
                    fx: params[0],
                    fy: params[0],
                    cx: params[1],
                    cy: params[2],
                }
            }
            "PINHOLE" => {
                need(4)?;
                Model::Pinhole {
                    fx: params[0],
                    fy: params[1],
                    cx: params[2],
                    cy: params[3],
                }
            }
            other => {
                return Err(here(ReadErrorKind::Unsupported(format!(
                    "COLMAP camera model {other} (camera {id}) has lens distortion, which \
                     pointsight does not undistort; run `colmap image_undistorter`, which writes \
                     PINHOLE cameras, and use its sparse model (PINHOLE and SIMPLE_PINHOLE are \
                     read)"
                ))));
            }
        };
        if cameras.insert(id, (model, width, height)).is_some() {
            return Err(here(ReadErrorKind::Camera(format!(
                "camera id {id} repeats"
            ))));
        }
    }
    check_declared(path, &lines, "cameras", cameras.len())?;
    Ok(cameras)
}

/// Reads `images.txt` and the `cameras.txt` beside it, in the order of `images.txt`.
pub fn read_colmap(images_txt: &Path) -> Result<Vec<ColmapImage>, ReadError> {
    let cameras_txt: PathBuf = images_txt.with_file_name("cameras.txt");
    let cameras = read_cameras(&cameras_txt)?;
    let all = lines(images_txt, "images")?;
    let lines = &all.data;
    let mut images = Vec::new();
    let mut k = 0;
    while k < lines.len() {
        let (line_no, line) = &lines[k];
        let here = |kind| ReadError::new(images_txt, Location::Line(*line_no), kind);
        let tokens: Vec<&str> = line.split_whitespace().collect();
        if tokens.is_empty() {
            // A blank line where an image line is due: trailing lines at the end of the file.
            k += 1;
            continue;
        }
        if tokens.len() < 10 {
            return Err(here(ReadErrorKind::FieldCount {
                expected: 10,
                found: tokens.len(),
            }));
        }
        let image_id = integer(tokens[0]).map_err(here)?;
        let v = numbers(&tokens[1..8]).map_err(here)?;
        let camera_id = integer(tokens[8]).map_err(here)?;
        let &(model, width, height) = cameras.get(&camera_id).ok_or_else(|| {
            here(ReadErrorKind::Camera(format!(
                "image {image_id} uses camera {camera_id}, which {} does not define",
                cameras_txt.display()
            )))
        })?;
        let camera = Camera::from_world_to_camera(
            [v[0], v[1], v[2], v[3]],
            [v[4], v[5], v[6]],
            model,
            width,
            height,
        )
        .map_err(|e| here(ReadErrorKind::Camera(e.to_string())))?;
        images.push(ColmapImage {
            image_id,
            name: tokens[9..].join(" "),
            camera,
        });
        // Skip the image's 2-d points line.
        k += 2;
    }
    check_declared(images_txt, &all, "images", images.len())?;
    if images.is_empty() {
        return Err(ReadError::new(
            images_txt,
            Location::File,
            ReadErrorKind::Empty,
        ));
    }
    Ok(images)
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;

    fn write(dir: &Path, cameras: &str, images: &str) -> PathBuf {
        std::fs::write(dir.join("cameras.txt"), cameras).unwrap();
        std::fs::write(dir.join("images.txt"), images).unwrap();
        dir.join("images.txt")
    }

    /// A camera at (0, 0, −5) looking along +z (identity rotation, t = (0, 0, 5)) and one at
    /// (5, 0, 0) looking along −x (rotated 90° about y: R = [[0,0,1],[0,1,0],[−1,0,0]], rows
    /// right = +z, down = +y, forward = −x; q = (cos 45°, 0, sin 45°, 0), t = −R·eye = (0, 0, 5)).
    const CAMERAS: &str =
        "# Camera list\n1 PINHOLE 640 480 500 510 320 240\n2 SIMPLE_PINHOLE 100 100 50 50 50\n";
    const IMAGES: &str = "# Image list\n\
        1 1 0 0 0 0 0 5 1 front.jpg\n\
        100.5 200.5 -1 300 10 2\n\
        2 0.7071067811865476 0 0.7071067811865476 0 0 0 5 2 side image.png\n\
        \n";

    #[test]
    fn known_cameras_give_the_expected_eye_and_image() {
        let dir = tempfile::tempdir().unwrap();
        let images = read_colmap(&write(dir.path(), CAMERAS, IMAGES)).unwrap();
        assert_eq!(images.len(), 2);
        let (a, b) = (&images[0].camera, &images[1].camera);
        assert_eq!(images[1].name, "side image.png");
        assert!((a.eye - DVec3::new(0.0, 0.0, -5.0)).length() < 1e-12);
        assert!(
            (b.eye - DVec3::new(5.0, 0.0, 0.0)).length() < 1e-9,
            "{}",
            b.eye
        );
        // The origin is at each principal point; (1, 1, 0) is right of and below it for the
        // first (x right, y down): x = 320 + 500·1/5, y = 240 + 510·1/5.
        let p = a.project(DVec3::new(1.0, 1.0, 0.0)).unwrap();
        assert!((p.x - 420.0).abs() < 1e-9 && (p.y - 342.0).abs() < 1e-9 && p.depth == 5.0);
        let q = b.project(DVec3::ZERO).unwrap();
        assert!((q.x - 50.0).abs() < 1e-9 && (q.y - 50.0).abs() < 1e-9);
        assert!((q.depth - 5.0).abs() < 1e-9);
        // Seen from +x looking at −x, +z is to the right: x = 50 + 50·1/5.
        let r = b.project(DVec3::new(0.0, 0.0, 1.0)).unwrap();
        assert!((r.x - 60.0).abs() < 1e-9, "{r:?}");
        // And through the views dispatcher, folder or file.
        assert_eq!(
            super::super::views::read_views(dir.path()).unwrap().len(),
            2
        );
    }

    #[test]
    fn distortion_and_bad_lines_are_named() {
        let dir = tempfile::tempdir().unwrap();
        let err = read_colmap(&write(
            dir.path(),
            "1 OPENCV 640 480 500 500 320 240 0.1 0.01 0 0\n",
            IMAGES,
        ))
        .unwrap_err()
        .to_string();
        assert!(err.contains("OPENCV") && err.contains("line 1"), "{err}");
        let err = read_colmap(&write(dir.path(), CAMERAS, "1 1 0 0 0 0 0 5 9 x.jpg\n\n"))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("camera 9") && err.contains("images.txt: line 1"),
            "{err}"
        );
        let err = read_colmap(&write(dir.path(), CAMERAS, "1 1 0 0 zero 0 0 5 1 x.jpg\n"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("zero"), "{err}");
        let err = read_colmap(&write(dir.path(), CAMERAS, "1 3 0 0 0 0 0 5 1 x.jpg\n"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("unit quaternion"), "{err}");
    }

    #[test]
    fn colmap_s_own_counts_are_checked() {
        let dir = tempfile::tempdir().unwrap();
        // Cut short after the first image (of 2 declared).
        let cut = "# Image list\n# Number of images: 2, mean observations per image: 1\n\
                   1 1 0 0 0 0 0 5 1 front.jpg\n100.5 200.5 -1\n";
        let err = read_colmap(&write(dir.path(), CAMERAS, cut))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains(
                "images.txt: line 2: truncated: the header announces 2 images but the \
                          data ends after 1"
            ),
            "{err}"
        );
        let cameras = format!("# Number of cameras: 3\n{CAMERAS}");
        let err = read_colmap(&write(dir.path(), &cameras, IMAGES))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("cameras.txt: line 1") && err.contains("3 cameras"),
            "{err}"
        );
        // The counts right: read.
        let whole = format!("# Number of images: 2\n{IMAGES}");
        let cameras = format!("# Number of cameras: 2\n{CAMERAS}");
        assert_eq!(
            read_colmap(&write(dir.path(), &cameras, &whole))
                .unwrap()
                .len(),
            2
        );
    }
}
