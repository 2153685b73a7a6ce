//! The camera's one serialisation: a JSON object tagged with its model. The views file (one
//! object per line), the external-method protocol and the Python package all use it.
//!
//! What we write holds everything a consumer may want, whichever way the camera was built:
//!
//! ```json
//! {"model": "pinhole", "width": 1280, "height": 720,
//!  "eye": [x, y, z], "target": [x, y, z], "up": [x, y, z],
//!  "camera_to_world": [[r00, r01, r02, ex], [r10, r11, r12, ey], [r20, r21, r22, ez], [0, 0, 0, 1]],
//!  "fx": 623.5, "fy": 623.5, "cx": 640, "cy": 360, "fov_y_deg": 60}
//! ```
//!
//! `camera_to_world` has OpenCV axes (columns: right, down, forward; the last column is the
//! eye). Orthographic cameras carry `view_width` and `view_height` (world units) instead of the
//! intrinsics; spherical cameras carry no intrinsics.
//!
//! What we read needs less: `model`, `width`, `height`; a pose, either `camera_to_world` or
//! `eye` and `target` (with `up`, default +z, or +y when the view is along z); pinhole
//! intrinsics, either `fx`, `fy`, `cx`, `cy` or `fov_y_deg` (centred, square pixels). Where both
//! forms are given they must agree (to 1e-9 relative); unknown keys are refused, so a typo is an
//! error rather than a silent default.

use glam::DVec3;
use serde::{Deserialize, Serialize};

use super::{Camera, Model};
use crate::error::{Error, Result};

/// The wire form of a [`Camera`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraJson {
    /// `pinhole`, `orthographic` or `spherical`.
    pub model: String,
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Eye (centre of projection).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub eye: Option<[f64; 3]>,
    /// A point on the optical axis.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target: Option<[f64; 3]>,
    /// Up vector (look-at form).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub up: Option<[f64; 3]>,
    /// Camera-to-world 4 × 4 matrix, rows, OpenCV axes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub camera_to_world: Option<[[f64; 4]; 4]>,
    /// Pinhole focal length x, pixels.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fx: Option<f64>,
    /// Pinhole focal length y, pixels.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fy: Option<f64>,
    /// Pinhole principal point x, pixels.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cx: Option<f64>,
    /// Pinhole principal point y, pixels.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cy: Option<f64>,
    /// Pinhole vertical field of view, degrees.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fov_y_deg: Option<f64>,
    /// Orthographic view box width, world units.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub view_width: Option<f64>,
    /// Orthographic view box height, world units.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub view_height: Option<f64>,
}

fn bad(msg: impl Into<String>) -> Error {
    Error::DegenerateCamera(msg.into())
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * (1.0 + a.abs().max(b.abs()))
}

impl From<&Camera> for CameraJson {
    fn from(c: &Camera) -> Self {
        let mut j = CameraJson {
            model: c.model().name().to_owned(),
            width: c.width,
            height: c.height,
            eye: Some(c.eye.to_array()),
            target: Some(c.target.to_array()),
            up: Some(c.up.to_array()),
            camera_to_world: Some(c.camera_to_world()),
            fx: None,
            fy: None,
            cx: None,
            cy: None,
            fov_y_deg: None,
            view_width: None,
            view_height: None,
        };
        match *c.model() {
            Model::Pinhole { fx, fy, cx, cy } => {
                j.fx = Some(fx);
                j.fy = Some(fy);
                j.cx = Some(cx);
                j.cy = Some(cy);
                j.fov_y_deg = c.fov_y_deg();
            }
            Model::Orthographic {
                view_width,
                view_height,
            } => {
                j.view_width = Some(view_width);
                j.view_height = Some(view_height);
            }
            Model::Spherical => {}
        }
        j
    }
}

impl TryFrom<&CameraJson> for Camera {
    type Error = Error;

    fn try_from(j: &CameraJson) -> Result<Camera> {
        let (w, h) = (j.width, j.height);
        let refuse = |keys: &[(&str, bool)]| -> Result<()> {
            match keys.iter().find(|(_, present)| *present) {
                Some((k, _)) => Err(bad(format!("{k} does not apply to {} cameras", j.model))),
                None => Ok(()),
            }
        };
        let model = match j.model.as_str() {
            "pinhole" => {
                refuse(&[
                    ("view_width", j.view_width.is_some()),
                    ("view_height", j.view_height.is_some()),
                ])?;
                let from_fov = j
                    .fov_y_deg
                    .map(|fov| Model::pinhole_fov(fov, w, h))
                    .transpose()?;
                match (j.fx, j.fy, j.cx, j.cy) {
                    (Some(fx), Some(fy), Some(cx), Some(cy)) => {
                        if let Some(Model::Pinhole { fy: f, .. }) = from_fov
                            && !close(f, fy)
                        {
                            return Err(bad(format!(
                                "fov_y_deg {} gives fy = {f} but fy is {fy}",
                                j.fov_y_deg.unwrap_or_default()
                            )));
                        }
                        Model::Pinhole { fx, fy, cx, cy }
                    }
                    (None, None, None, None) => from_fov
                        .ok_or_else(|| bad("a pinhole camera needs fx, fy, cx, cy or fov_y_deg"))?,
                    _ => return Err(bad("give all four of fx, fy, cx, cy, or none")),
                }
            }
            "orthographic" => {
                refuse(&[
                    ("fx", j.fx.is_some()),
                    ("fy", j.fy.is_some()),
                    ("cx", j.cx.is_some()),
                    ("cy", j.cy.is_some()),
                    ("fov_y_deg", j.fov_y_deg.is_some()),
                ])?;
                match (j.view_width, j.view_height) {
                    (Some(view_width), Some(view_height)) => Model::Orthographic {
                        view_width,
                        view_height,
                    },
                    _ => {
                        return Err(bad(
                            "an orthographic camera needs view_width and view_height",
                        ));
                    }
                }
            }
            "spherical" => {
                refuse(&[
                    ("fx", j.fx.is_some()),
                    ("fy", j.fy.is_some()),
                    ("cx", j.cx.is_some()),
                    ("cy", j.cy.is_some()),
                    ("fov_y_deg", j.fov_y_deg.is_some()),
                    ("view_width", j.view_width.is_some()),
                    ("view_height", j.view_height.is_some()),
                ])?;
                Model::Spherical
            }
            other => {
                return Err(bad(format!(
                    "unknown camera model {other:?}: expected pinhole, orthographic or spherical"
                )));
            }
        };
        let from_matrix = j
            .camera_to_world
            .map(|m| Camera::from_camera_to_world(m, model, w, h))
            .transpose()?;
        let camera = match (j.eye, j.target) {
            (Some(eye), Some(target)) => {
                let (eye, target) = (DVec3::from_array(eye), DVec3::from_array(target));
                let up = match j.up {
                    Some(up) => DVec3::from_array(up),
                    None => default_up(target - eye),
                };
                Camera::look_at(eye, target, up, model, w, h)?
            }
            (None, None) => {
                if j.up.is_some() {
                    return Err(bad("up needs eye and target"));
                }
                from_matrix
                    .ok_or_else(|| bad("a camera needs camera_to_world, or eye and target"))?
            }
            _ => return Err(bad("give eye and target together")),
        };
        if let Some(m) = from_matrix {
            let scale = 1.0 + camera.eye.length();
            let agrees = (m.eye - camera.eye).length() <= 1e-9 * scale
                && (m.rotation() - camera.rotation())
                    .to_cols_array()
                    .iter()
                    .all(|v| v.abs() <= 1e-9);
            if !agrees {
                return Err(bad(
                    "camera_to_world disagrees with eye, target and up: give one pose",
                ));
            }
        }
        Ok(camera)
    }
}

/// +z, or +y when the view direction is within about 1° of ±z.
pub fn default_up(view: DVec3) -> DVec3 {
    if super::direction(view).z.abs() > 1f64.to_radians().cos() {
        DVec3::Y
    } else {
        DVec3::Z
    }
}

impl Camera {
    /// The camera as one JSON object (no newline).
    pub fn to_json(&self) -> String {
        // Serialising plain numbers and strings cannot fail.
        serde_json::to_string(&CameraJson::from(self)).unwrap_or_default()
    }

    /// Parses one JSON camera object.
    pub fn from_json(text: &str) -> Result<Camera> {
        let j: CameraJson =
            serde_json::from_str(text).map_err(|e| bad(format!("malformed camera JSON: {e}")))?;
        Camera::try_from(&j)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Vec<Camera> {
        let eye = DVec3::new(1.5, -2.25, 3.0);
        vec![
            Camera::new(eye, DVec3::ZERO, DVec3::Y, 47.3, 1280, 720).unwrap(),
            Camera::look_at(
                eye,
                DVec3::ZERO,
                DVec3::Z,
                Model::Pinhole {
                    fx: 900.0,
                    fy: 880.5,
                    cx: 611.25,
                    cy: 351.0,
                },
                1280,
                720,
            )
            .unwrap(),
            Camera::look_at(
                eye,
                DVec3::ZERO,
                DVec3::Z,
                Model::Orthographic {
                    view_width: 3.0,
                    view_height: 1.5,
                },
                800,
                400,
            )
            .unwrap(),
            Camera::look_at(eye, DVec3::ZERO, DVec3::Z, Model::Spherical, 2048, 1024).unwrap(),
        ]
    }

    #[test]
    fn round_trip_is_exact() {
        for c in sample() {
            let text = c.to_json();
            assert!(!text.contains('\n'));
            assert_eq!(Camera::from_json(&text).unwrap(), c, "{text}");
        }
    }

    #[test]
    fn short_forms_are_read() {
        let c = Camera::from_json(
            r#"{"model":"pinhole","width":640,"height":480,"eye":[0,0,5],"target":[0,0,0],"up":[0,1,0],"fov_y_deg":60}"#,
        )
        .unwrap();
        let reference = Camera::new(
            DVec3::new(0.0, 0.0, 5.0),
            DVec3::ZERO,
            DVec3::Y,
            60.0,
            640,
            480,
        )
        .unwrap();
        assert_eq!(c, reference);
        // A pose alone: identity rotation looks along +z with y down.
        let c = Camera::from_json(
            r#"{"model":"pinhole","width":100,"height":100,"fx":50,"fy":50,"cx":50,"cy":50,
                "camera_to_world":[[1,0,0,0],[0,1,0,0],[0,0,1,-4],[0,0,0,1]]}"#,
        )
        .unwrap();
        let p = c.project(DVec3::new(1.0, 1.0, 1.0)).unwrap();
        assert!((p.x - 60.0).abs() < 1e-12 && (p.y - 60.0).abs() < 1e-12 && p.depth == 5.0);
        // Default up is +z.
        let c = Camera::from_json(
            r#"{"model":"spherical","width":64,"height":32,"eye":[0,0,0],"target":[1,0,0]}"#,
        )
        .unwrap();
        assert_eq!(c.true_up(), DVec3::Z);
    }

    #[test]
    fn contradictions_and_typos_are_errors() {
        for (text, needle) in [
            (
                r#"{"model":"fisheye","width":1,"height":1}"#,
                "unknown camera model",
            ),
            (
                r#"{"model":"pinhole","width":1,"height":1,"eye":[0,0,1],"target":[0,0,0],"fov":60}"#,
                "unknown field",
            ),
            (
                r#"{"model":"pinhole","width":1,"height":1,"eye":[0,0,1],"target":[0,0,0]}"#,
                "needs fx",
            ),
            (
                r#"{"model":"pinhole","width":10,"height":10,"eye":[0,0,1],"target":[0,0,0],"fov_y_deg":60,"fx":1,"fy":1,"cx":5,"cy":5}"#,
                "fov_y_deg",
            ),
            (
                r#"{"model":"spherical","width":1,"height":1,"eye":[0,0,1],"target":[0,0,0],"fx":3}"#,
                "does not apply",
            ),
            (
                r#"{"model":"spherical","width":4,"height":2,"eye":[0,0,1],"target":[0,0,0],"up":[0,1,0],
                   "camera_to_world":[[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}"#,
                "disagrees",
            ),
            (
                r#"{"model":"spherical","width":4,"height":2}"#,
                "camera_to_world",
            ),
            (
                r#"{"model":"orthographic","width":4,"height":2,"eye":[0,0,1],"target":[0,0,0]}"#,
                "view_width",
            ),
            (
                r#"{"model":"pinhole","width":4,"height":2,"eye":[0,0,1],"target":[0,0,1],"fov_y_deg":60}"#,
                "coincide",
            ),
            (r#"not json"#, "malformed"),
        ] {
            let err = Camera::from_json(text).unwrap_err().to_string();
            assert!(err.contains(needle), "{text}: {err}");
        }
    }
}
