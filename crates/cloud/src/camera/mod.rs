//! Cameras as users have them: pinhole (intrinsics fx, fy, cx, cy), orthographic (a view box)
//! and spherical (an equirectangular 360° × 180° image around a scanner), each with a pose.
//!
//! One type, [`Camera`], serves every method, the ground truth, the views file and the
//! external-method protocol ([`json`] is its serialisation). Conventions, used everywhere:
//! - camera axes are OpenCV's (and COLMAP's): `right` (image x), `down` (image y) and
//!   `forward` (the optical axis), orthonormal and right-handed, stored as the columns of the
//!   camera-to-world rotation; [`Camera::true_up`] is −`down`;
//! - pixel space: x to the right in [0, width), y downwards in [0, height); pixel (i, j) covers
//!   [i, i+1) × [j, j+1) and its centre is (i + 0.5, j + 0.5) (COLMAP's convention: the
//!   principal point of a centred camera is (width/2, height/2));
//! - **pinhole**: x = cx + fx·(v·right)/z, y = cy + fy·(v·down)/z with v = p − eye and depth
//!   z = v·forward > 0;
//! - **orthographic**: a view box of `view_width` × `view_height` world units centred on the
//!   optical axis: x = width/2 + (v·right)·width/view_width, likewise y; depth z = v·forward > 0
//!   (the plane through the eye is the near plane); every pixel's ray is parallel to forward and
//!   starts on that plane;
//! - **spherical** (equirectangular): azimuth φ = atan2(v·right, v·forward) ∈ (−π, π], polar
//!   angle θ = angle between v and true_up ∈ [0, π]; x = width·(1/2 + φ/2π), y = height·θ/π;
//!   depth is the range |v|. The forward direction is the image centre, straight up the top
//!   row. There is no frustum: every direction is in the image.
//!
//! "Depth" is what a z-buffer of the model compares: distance along the optical axis for
//! pinhole and orthographic, range for spherical. [`Camera::ray`] inverts [`Camera::project`]:
//! `origin + direction · depth` is the point.

pub mod json;

use glam::{DMat3, DQuat, DVec3};

use crate::error::{Error, Result};

/// A point projected into the image.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Projection {
    /// Continuous pixel x (0 at the left edge).
    pub x: f64,
    /// Continuous pixel y (0 at the top edge).
    pub y: f64,
    /// Depth (see the module doc): positive for every projected point.
    pub depth: f64,
}

impl Projection {
    /// The pixel containing the projection, if it lies inside a `width` × `height` image.
    #[inline]
    pub fn pixel(&self, width: u32, height: u32) -> Option<(u32, u32)> {
        if self.x >= 0.0 && self.y >= 0.0 && self.x < width as f64 && self.y < height as f64 {
            Some((self.x as u32, self.y as u32))
        } else {
            None
        }
    }
}

/// The projection model of a camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Model {
    /// Central projection with focal lengths and principal point in pixels.
    Pinhole {
        /// Focal length along x, pixels.
        fx: f64,
        /// Focal length along y, pixels.
        fy: f64,
        /// Principal point x, pixels (width/2 for a centred camera).
        cx: f64,
        /// Principal point y, pixels.
        cy: f64,
    },
    /// Parallel projection of a view box centred on the optical axis.
    Orthographic {
        /// Width of the view box, world units.
        view_width: f64,
        /// Height of the view box, world units.
        view_height: f64,
    },
    /// Equirectangular 360° × 180° image around the eye.
    Spherical,
}

impl Model {
    /// The model's name as the views file and error messages spell it.
    pub fn name(&self) -> &'static str {
        match self {
            Model::Pinhole { .. } => "pinhole",
            Model::Orthographic { .. } => "orthographic",
            Model::Spherical => "spherical",
        }
    }

    /// A centred pinhole model with square pixels and the vertical field of view `fov_y_deg`.
    pub fn pinhole_fov(fov_y_deg: f64, width: u32, height: u32) -> Result<Self> {
        if !(fov_y_deg > 0.0 && fov_y_deg < 180.0) {
            return Err(Error::DegenerateCamera(format!(
                "vertical field of view {fov_y_deg} is not in (0, 180) degrees"
            )));
        }
        let f = 0.5 * height as f64 / (0.5 * fov_y_deg.to_radians()).tan();
        Ok(Model::Pinhole {
            fx: f,
            fy: f,
            cx: 0.5 * width as f64,
            cy: 0.5 * height as f64,
        })
    }

    fn validate(&self) -> Result<()> {
        match *self {
            Model::Pinhole { fx, fy, cx, cy } => {
                if !(fx > 0.0 && fy > 0.0 && fx.is_finite() && fy.is_finite()) {
                    return Err(Error::DegenerateCamera(format!(
                        "pinhole focal lengths must be positive and finite, got fx={fx}, fy={fy}"
                    )));
                }
                if !(cx.is_finite() && cy.is_finite()) {
                    return Err(Error::DegenerateCamera(format!(
                        "pinhole principal point is not finite: cx={cx}, cy={cy}"
                    )));
                }
            }
            Model::Orthographic {
                view_width,
                view_height,
            } => {
                if !(view_width > 0.0
                    && view_height > 0.0
                    && view_width.is_finite()
                    && view_height.is_finite())
                {
                    return Err(Error::DegenerateCamera(format!(
                        "orthographic view box must be positive and finite, got \
                         {view_width} x {view_height}"
                    )));
                }
            }
            Model::Spherical => {}
        }
        Ok(())
    }
}

/// A number for a message: plain when moderate, else in scientific notation.
fn num(v: f64) -> String {
    if v == 0.0 || (1e-4..1e7).contains(&v.abs()) {
        format!("{v}")
    } else {
        format!("{v:.6e}")
    }
}

/// A point for a message.
fn point(p: DVec3) -> String {
    format!("({}, {}, {})", num(p.x), num(p.y), num(p.z))
}

/// How near a point the eye may be, in diameters of the cloud ([`Camera::check_view_of`]).
pub const EYE_CLEARANCE: f64 = 1e-9;

/// The least extent of a cloud, as a fraction of its farthest distance from the eye
/// ([`Camera::check_view_of`]): single precision's epsilon, 2^-23.
pub const MIN_EXTENT: f64 = f32::EPSILON as f64;

/// A camera: a pose (eye and orientation), a projection model and an image size.
///
/// Build it with [`Camera::new`] (a look-at pinhole with a vertical field of view),
/// [`Camera::look_at`] (any model), [`Camera::from_pose`] (a camera-to-world rotation and the
/// eye) or [`Camera::from_world_to_camera`] (COLMAP's quaternion and translation). The public
/// fields describe the camera; change a camera through the constructors, not by assigning them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Centre of projection (for orthographic: the centre of the near plane).
    pub eye: DVec3,
    /// A point on the optical axis in front of the eye (the look-at target, or eye + forward
    /// for cameras built from a pose).
    pub target: DVec3,
    /// The requested up vector (not necessarily orthogonal to the view direction).
    pub up: DVec3,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    model: Model,
    right: DVec3,
    down: DVec3,
    forward: DVec3,
}

/// `v` normalised after dividing by its largest component, so that vectors near the ends of
/// the f64 range neither overflow nor underflow; zero for a zero or non-finite vector.
pub(crate) fn direction(v: DVec3) -> DVec3 {
    let m = v.abs().max_element();
    if m > 0.0 && m.is_finite() {
        (v / m).normalize_or_zero()
    } else {
        DVec3::ZERO
    }
}

impl Camera {
    /// A look-at pinhole camera with square pixels, the principal point at the image centre and
    /// the vertical field of view `fov_y_deg`; fails when eye = target, up is parallel to the
    /// view direction, the field of view is outside (0, 180) degrees, the image is empty or a
    /// value is not finite.
    pub fn new(
        eye: DVec3,
        target: DVec3,
        up: DVec3,
        fov_y_deg: f64,
        width: u32,
        height: u32,
    ) -> Result<Self> {
        Self::look_at(
            eye,
            target,
            up,
            Model::pinhole_fov(fov_y_deg, width, height)?,
            width,
            height,
        )
    }

    /// A camera of any model looking from `eye` at `target` with `up` as the image's up.
    pub fn look_at(
        eye: DVec3,
        target: DVec3,
        up: DVec3,
        model: Model,
        width: u32,
        height: u32,
    ) -> Result<Self> {
        if !(eye.is_finite() && target.is_finite() && up.is_finite()) {
            return Err(Error::DegenerateCamera(
                "non-finite eye, target or up".into(),
            ));
        }
        let unit = direction;
        let (difference, up) = (target - eye, unit(up));
        if !difference.is_finite() {
            return Err(Error::DegenerateCamera(format!(
                "eye {eye} and target {target} are too far apart for f64"
            )));
        }
        let forward = unit(difference);
        if forward == DVec3::ZERO {
            return Err(Error::DegenerateCamera("eye and target coincide".into()));
        }
        let right = forward.cross(up).normalize_or_zero();
        if right == DVec3::ZERO || forward.cross(up).length() < 1e-9 * up.length() {
            return Err(Error::DegenerateCamera(
                "the up vector is parallel to the view direction".into(),
            ));
        }
        let true_up = right.cross(forward);
        Self::build(
            eye, target, up, model, width, height, right, -true_up, forward,
        )
    }

    /// A camera from its camera-to-world rotation (columns: right, down, forward in world
    /// coordinates, OpenCV axes) and its eye. The matrix must be a rotation (orthonormal,
    /// determinant +1) to 1e-6.
    pub fn from_pose(
        rotation: DMat3,
        eye: DVec3,
        model: Model,
        width: u32,
        height: u32,
    ) -> Result<Self> {
        check_rotation(&rotation)?;
        if !eye.is_finite() {
            return Err(Error::DegenerateCamera("non-finite eye".into()));
        }
        // Re-orthonormalise so that projections and rays invert each other to rounding.
        let forward = rotation.z_axis.normalize();
        let right = (rotation.x_axis - forward * rotation.x_axis.dot(forward)).normalize();
        let down = forward.cross(right);
        Self::build(
            eye,
            eye + forward,
            -down,
            model,
            width,
            height,
            right,
            down,
            forward,
        )
    }

    /// A camera from a 4 × 4 camera-to-world matrix (rows; the last must be 0 0 0 1).
    pub fn from_camera_to_world(
        matrix: [[f64; 4]; 4],
        model: Model,
        width: u32,
        height: u32,
    ) -> Result<Self> {
        if matrix.iter().flatten().any(|v| !v.is_finite()) {
            return Err(Error::DegenerateCamera(
                "camera_to_world has a non-finite entry".into(),
            ));
        }
        if matrix[3] != [0.0, 0.0, 0.0, 1.0] {
            return Err(Error::DegenerateCamera(format!(
                "camera_to_world's last row must be 0 0 0 1, got {:?}",
                matrix[3]
            )));
        }
        let rotation = DMat3::from_cols(
            DVec3::new(matrix[0][0], matrix[1][0], matrix[2][0]),
            DVec3::new(matrix[0][1], matrix[1][1], matrix[2][1]),
            DVec3::new(matrix[0][2], matrix[1][2], matrix[2][2]),
        );
        let eye = DVec3::new(matrix[0][3], matrix[1][3], matrix[2][3]);
        Self::from_pose(rotation, eye, model, width, height)
    }

    /// A camera from COLMAP's world-to-camera pose: the rotation as a quaternion (qw, qx, qy,
    /// qz; normalised here, refused when its norm is not within 1e-3 of 1) and the translation
    /// t, so that x_cam = R·x_world + t and the eye is −Rᵀt.
    pub fn from_world_to_camera(
        q: [f64; 4],
        t: [f64; 3],
        model: Model,
        width: u32,
        height: u32,
    ) -> Result<Self> {
        let [qw, qx, qy, qz] = q;
        let norm = (qw * qw + qx * qx + qy * qy + qz * qz).sqrt();
        if !(norm.is_finite() && (norm - 1.0).abs() < 1e-3) {
            return Err(Error::DegenerateCamera(format!(
                "the quaternion ({qw}, {qx}, {qy}, {qz}) is not a unit quaternion (norm {norm})"
            )));
        }
        let q = DQuat::from_xyzw(qx / norm, qy / norm, qz / norm, qw / norm);
        let world_to_camera = DMat3::from_quat(q);
        let t = DVec3::from_array(t);
        if !t.is_finite() {
            return Err(Error::DegenerateCamera("non-finite translation".into()));
        }
        let camera_to_world = world_to_camera.transpose();
        let eye = -(camera_to_world * t);
        Self::from_pose(camera_to_world, eye, model, width, height)
    }

    #[allow(clippy::too_many_arguments)]
    fn build(
        eye: DVec3,
        target: DVec3,
        up: DVec3,
        model: Model,
        width: u32,
        height: u32,
        right: DVec3,
        down: DVec3,
        forward: DVec3,
    ) -> Result<Self> {
        if width == 0 || height == 0 {
            return Err(Error::DegenerateCamera(format!(
                "image size {width}x{height}"
            )));
        }
        model.validate()?;
        Ok(Self {
            eye,
            target,
            up,
            width,
            height,
            model,
            right,
            down,
            forward,
        })
    }

    /// The same pose and field of view at another image size: pinhole focal lengths scale with
    /// the height (square pixels stay square) and the principal point proportionally;
    /// orthographic keeps its view box; spherical keeps the whole sphere.
    pub fn with_resolution(&self, width: u32, height: u32) -> Result<Self> {
        let model = match self.model {
            Model::Pinhole { fx, fy, cx, cy } => {
                let s = height as f64 / self.height as f64;
                Model::Pinhole {
                    fx: fx * s,
                    fy: fy * s,
                    cx: cx * width as f64 / self.width as f64,
                    cy: cy * s,
                }
            }
            m => m,
        };
        Self::build(
            self.eye,
            self.target,
            self.up,
            model,
            width,
            height,
            self.right,
            self.down,
            self.forward,
        )
    }

    /// The same camera with the world moved by −`offset` (eye and target shifted; orientation,
    /// model and image unchanged): the camera in a recentred frame.
    pub fn translated(&self, offset: DVec3) -> Self {
        Self {
            eye: self.eye - offset,
            target: self.target - offset,
            ..*self
        }
    }

    /// The same camera for a world scaled by `factor` about the origin (a power of two from
    /// [`crate::recentre::exact_scale`] keeps it exact): the eye and target scale, and so does
    /// an orthographic view box; pinhole intrinsics and spherical images are scale-free.
    pub fn scaled(&self, factor: f64) -> Self {
        let model = match self.model {
            Model::Orthographic {
                view_width,
                view_height,
            } => Model::Orthographic {
                view_width: view_width * factor,
                view_height: view_height * factor,
            },
            m => m,
        };
        Self {
            eye: self.eye * factor,
            target: self.target * factor,
            model,
            ..*self
        }
    }

    /// The projection model.
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// Unit view direction (optical axis).
    pub fn forward(&self) -> DVec3 {
        self.forward
    }

    /// Unit right vector of the image.
    pub fn right(&self) -> DVec3 {
        self.right
    }

    /// Unit down vector of the image (OpenCV's y axis).
    pub fn down(&self) -> DVec3 {
        self.down
    }

    /// Unit up vector of the image (orthogonal to forward and right).
    pub fn true_up(&self) -> DVec3 {
        -self.down
    }

    /// The camera-to-world rotation: columns right, down, forward.
    pub fn rotation(&self) -> DMat3 {
        DMat3::from_cols(self.right, self.down, self.forward)
    }

    /// The 4 × 4 camera-to-world matrix (rows), OpenCV axes.
    pub fn camera_to_world(&self) -> [[f64; 4]; 4] {
        let (r, d, f, e) = (self.right, self.down, self.forward, self.eye);
        [
            [r.x, d.x, f.x, e.x],
            [r.y, d.y, f.y, e.y],
            [r.z, d.z, f.z, e.z],
            [0.0, 0.0, 0.0, 1.0],
        ]
    }

    /// Vertical field of view in degrees of a pinhole camera (`None` for the other models).
    pub fn fov_y_deg(&self) -> Option<f64> {
        match self.model {
            Model::Pinhole { fy, .. } => {
                Some((2.0 * (0.5 * self.height as f64 / fy).atan()).to_degrees())
            }
            _ => None,
        }
    }

    /// True for models with a frustum (pinhole, orthographic); false for the spherical image,
    /// which sees every direction.
    pub fn has_frustum(&self) -> bool {
        !matches!(self.model, Model::Spherical)
    }

    /// Depth of `p` (along the optical axis; range for spherical).
    #[inline]
    pub fn depth(&self, p: DVec3) -> f64 {
        let v = p - self.eye;
        match self.model {
            Model::Spherical => v.length(),
            _ => v.dot(self.forward),
        }
    }

    /// Projects `p`; `None` when it is not in front of the eye (depth ≤ 0; for spherical: p is
    /// the eye). The result may lie outside the image; use [`Projection::pixel`] to clip.
    #[inline]
    pub fn project(&self, p: DVec3) -> Option<Projection> {
        let v = p - self.eye;
        match self.model {
            Model::Pinhole { fx, fy, cx, cy } => {
                let depth = v.dot(self.forward);
                if depth <= 0.0 {
                    return None;
                }
                let inv = 1.0 / depth;
                Some(Projection {
                    x: cx + fx * v.dot(self.right) * inv,
                    y: cy + fy * v.dot(self.down) * inv,
                    depth,
                })
            }
            Model::Orthographic {
                view_width,
                view_height,
            } => {
                let depth = v.dot(self.forward);
                if depth <= 0.0 {
                    return None;
                }
                Some(Projection {
                    x: 0.5 * self.width as f64 + v.dot(self.right) * self.width as f64 / view_width,
                    y: 0.5 * self.height as f64
                        + v.dot(self.down) * self.height as f64 / view_height,
                    depth,
                })
            }
            Model::Spherical => {
                let depth = v.length();
                if !(depth > 0.0) {
                    return None;
                }
                let (x, y) = self.spherical_pixel(v, depth);
                Some(Projection { x, y, depth })
            }
        }
    }

    #[inline]
    fn spherical_pixel(&self, v: DVec3, range: f64) -> (f64, f64) {
        use std::f64::consts::PI;
        let phi = v.dot(self.right).atan2(v.dot(self.forward));
        let cos_theta = (-v.dot(self.down) / range).clamp(-1.0, 1.0);
        let theta = cos_theta.acos();
        // φ = π maps to x = width, outside [0, width): fold it onto the left edge.
        let mut x = self.width as f64 * (0.5 + phi / (2.0 * PI));
        if x >= self.width as f64 {
            x -= self.width as f64;
        }
        (x, self.height as f64 * theta / PI)
    }

    /// The ray through the continuous pixel position (x, y): `(origin, direction)` such that
    /// `origin + direction · depth` is the point at that pixel and depth. Pinhole: the
    /// direction's forward component is 1; orthographic: the direction is forward and the
    /// origin lies on the near plane; spherical: the direction is a unit vector.
    #[inline]
    pub fn ray(&self, x: f64, y: f64) -> (DVec3, DVec3) {
        match self.model {
            Model::Pinhole { fx, fy, cx, cy } => (
                self.eye,
                self.forward + self.right * ((x - cx) / fx) + self.down * ((y - cy) / fy),
            ),
            Model::Orthographic {
                view_width,
                view_height,
            } => (
                self.eye
                    + self.right * ((x - 0.5 * self.width as f64) * view_width / self.width as f64)
                    + self.down
                        * ((y - 0.5 * self.height as f64) * view_height / self.height as f64),
                self.forward,
            ),
            Model::Spherical => {
                use std::f64::consts::PI;
                let phi = (x / self.width as f64 - 0.5) * 2.0 * PI;
                let theta = y / self.height as f64 * PI;
                let (sp, cp) = phi.sin_cos();
                let (st, ct) = theta.sin_cos();
                (
                    self.eye,
                    (self.forward * cp + self.right * sp) * st - self.down * ct,
                )
            }
        }
    }

    /// A pinhole camera's pixel-centre rays as two tables: the direction of pixel (x, y)'s ray
    /// is `columns[x] + rows[y]`, bit for bit [`Camera::ray`]`(x + 0.5, y + 0.5)`'s (its
    /// origin the eye), so that a caller testing many pixels adds two vectors per pixel
    /// instead of recomputing the ray. `None` for the other models.
    pub fn pinhole_ray_tables(&self) -> Option<(Vec<DVec3>, Vec<DVec3>)> {
        let Model::Pinhole { fx, fy, cx, cy } = self.model else {
            return None;
        };
        let columns = (0..self.width)
            .map(|x| self.forward + self.right * ((f64::from(x) + 0.5 - cx) / fx))
            .collect();
        let rows = (0..self.height)
            .map(|y| self.down * ((f64::from(y) + 0.5 - cy) / fy))
            .collect();
        Some((columns, rows))
    }

    /// Origin of the ray that reaches `p` (the eye, or for orthographic the foot of `p` on the
    /// near plane): the segment from it to `p` is what an occluder of `p` must cross.
    #[inline]
    pub fn ray_origin_for(&self, p: DVec3) -> DVec3 {
        match self.model {
            Model::Orthographic { .. } => p - self.forward * (p - self.eye).dot(self.forward),
            _ => self.eye,
        }
    }

    /// Size in world units of one pixel at depth `depth` (the geometric mean of its two sides;
    /// for spherical: at the equator).
    #[inline]
    pub fn pixel_size_at(&self, depth: f64) -> f64 {
        match self.model {
            Model::Pinhole { fx, fy, .. } => depth / (fx * fy).sqrt(),
            Model::Orthographic {
                view_width,
                view_height,
            } => (view_width / self.width as f64 * view_height / self.height as f64).sqrt(),
            Model::Spherical => {
                depth
                    * (2.0 * std::f64::consts::PI / self.width as f64 * std::f64::consts::PI
                        / self.height as f64)
                        .sqrt()
            }
        }
    }

    /// Focal length in pixels of a centred, square-pixel pinhole (the geometric mean of fx and
    /// fy), or the equivalent `1 / pixel_size_at(1)` of the other models.
    pub fn focal_px(&self) -> f64 {
        1.0 / self.pixel_size_at(1.0)
    }

    /// Fails when this camera cannot look at the cloud `positions` (in the frame the methods
    /// see: a dataset's recentred one), with the same refusal for the ground truth and every
    /// method (without it, an eye on a point gives HPR's refusal, 1 point for the ray cast and
    /// 0 for the reference):
    /// - the eye within [`EYE_CLEARANCE`] of the cloud's diameter of a point: the direction to
    ///   that point, and so its visibility, is undefined;
    /// - the eye so far that the cloud's extent is below [`MIN_EXTENT`] of its distance: the
    ///   coordinates relative to the eye can no longer tell the cloud's points apart at the
    ///   precision of single-precision depth buffers (the ground truth's raster and the splats
    ///   hold depths so), and at f64's own limit every point collapses onto one (an eye at
    ///   10^300 made the ground truth call a whole sphere visible).
    ///
    /// Orthographic cameras have no centre of projection and are not checked. A cloud of one
    /// position has no diameter and is left to the methods (which refuse it).
    pub fn check_view_of(&self, positions: &[DVec3]) -> Result<()> {
        use rayon::prelude::*;
        if matches!(self.model, Model::Orthographic { .. }) || positions.is_empty() {
            return Ok(());
        }
        let Some(bbox) = crate::bbox::Aabb::from_points(positions) else {
            return Ok(());
        };
        let extent = bbox.max - bbox.min;
        // Lengths of vectors scaled by their largest component: no overflow near f64's ends.
        let length = |v: DVec3| {
            let m = v.abs().max_element();
            if m > 0.0 && m.is_finite() {
                m * (v / m).length()
            } else {
                m
            }
        };
        let diameter = length(extent);
        if !(diameter > 0.0) {
            return Ok(());
        }
        let far = length(bbox.center() - self.eye) + 0.5 * diameter;
        if diameter < MIN_EXTENT * far {
            return Err(Error::DegenerateCamera(format!(
                "the eye at {} is {} from the cloud, {} times its extent {}: beyond {} times, \
                 the cloud is below the precision of its coordinates as seen from the eye",
                point(self.eye),
                num(far),
                num(far / diameter),
                num(diameter),
                num(1.0 / MIN_EXTENT)
            )));
        }
        let eye = self.eye;
        let nearest = positions
            .par_iter()
            .enumerate()
            .map(|(i, p)| (length(*p - eye), i))
            .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        if let Some((d, i)) = nearest
            && d <= EYE_CLEARANCE * diameter
        {
            return Err(Error::DegenerateCamera(format!(
                "the eye at {} is {} from point {i}, within {EYE_CLEARANCE:e} of the cloud's \
                 diameter {}: seen from a point of the cloud, visibility is undefined",
                point(eye),
                num(d),
                num(diameter)
            )));
        }
        Ok(())
    }

    /// Fails with an error naming `method` and this camera's model unless the model is one of
    /// `supported`.
    pub fn require(&self, method: &str, supported: &[&str]) -> Result<()> {
        if supported.contains(&self.model.name()) {
            Ok(())
        } else {
            Err(Error::UnsupportedCamera {
                method: method.to_owned(),
                model: self.model.name(),
                supported: supported.join(", "),
            })
        }
    }
}

fn check_rotation(r: &DMat3) -> Result<()> {
    if !r.is_finite() {
        return Err(Error::DegenerateCamera(
            "the rotation has a non-finite entry".into(),
        ));
    }
    let should_be_identity = r.transpose() * *r;
    let off = (should_be_identity - DMat3::IDENTITY)
        .to_cols_array()
        .iter()
        .fold(0.0f64, |m, v| m.max(v.abs()));
    let det = r.determinant();
    if off > 1e-6 || (det - 1.0).abs() > 1e-6 {
        return Err(Error::DegenerateCamera(format!(
            "the camera rotation is not a rotation matrix (|RᵀR − I| = {off:.2e}, det = {det:.6})"
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests;
