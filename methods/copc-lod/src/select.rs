//! The per-view selection from a COPC octree, and each selected point's splat radius.
//!
//! **Which nodes.** A node's point spacing is the COPC info VLR's root spacing halved per level
//! (COPC 1.0: "spacing ... This value is halved at each octree level"; copc_converter samples
//! each node on a grid of 128 cells per axis of its cube, one point per occupied cell, and
//! writes spacing = root side / 128). Projected at the node's nearest distance to the eye `d`
//! (0 inside the cube) with the camera's focal length `f` (pixels, the larger of `fx`, `fy`),
//! it is `p = f · s / d` pixels, the most any of the node's points lie apart on screen. The
//! traversal starts at the root and, at a node within the view frustum, selects it and
//! descends into its children while `p ≥ threshold`: it stops descending where the projected
//! spacing falls below the threshold, the node there included (the level that first reaches
//! the threshold is the one drawn, as PDAL's COPC reader reads levels down to the first whose
//! spacing is at most its `resolution`). So a node is selected iff it is inside the frustum
//! and every ancestor's projected spacing is at least the threshold; threshold 0 selects
//! every node in the frustum. Frustum culling: a node is left out (with its subtree) when all
//! eight corners of its cube lie outside one plane of the pinhole frustum (the four side
//! planes through the eye and the image border, and the plane z = 0 in front of it), a
//! conservative test that keeps a subtree whenever its parent is kept.
//!
//! **Splat radius.** Every point of a node is one of the node's samples, at most one per grid
//! cell of side `s` of its level, so `s` stands for the sample's density spacing where the
//! traversal stopped. A point's radius is that of a full-detail splat (`R`, pointsight's
//! `--radius`: 1.5 density spacings `S`, its `--spacing`) scaled to the spacing of the deepest
//! selected node that contains it, `M` at level `D`: `max(R, R · s_D / S)`. Where `M` has no
//! child in the point's octant, every point of that octant is drawn (no deeper node holds any),
//! so the radius is `R`. Without `--spacing` (clouds of at most 8 points) every radius is `R`.

use crate::copc::Copc;
use crate::error::{Error, Result};

/// A pinhole camera, as the protocol's camera JSON gives it.
#[derive(Debug, Clone)]
pub struct View {
    /// The eye.
    pub eye: [f64; 3],
    /// Camera axes in world coordinates: right, down, forward (OpenCV).
    pub axes: [[f64; 3]; 3],
    /// Focal lengths and principal point, pixels.
    pub fx: f64,
    /// Focal length y.
    pub fy: f64,
    /// Principal point x.
    pub cx: f64,
    /// Principal point y.
    pub cy: f64,
    /// Image size, pixels.
    pub width: f64,
    /// Image height.
    pub height: f64,
}

impl View {
    /// Reads the camera of a request (`model` `pinhole` only).
    pub fn from_json(c: &serde_json::Value) -> Result<View> {
        let bad = |what: &str| Error::Usage(format!("camera: {what}"));
        let model = c.get("model").and_then(|m| m.as_str()).unwrap_or("");
        if model != "pinhole" {
            return Err(bad(&format!(
                "copc-lod takes pinhole cameras, not {model:?}"
            )));
        }
        let num = |k: &str| {
            c.get(k)
                .and_then(serde_json::Value::as_f64)
                .filter(|v| v.is_finite())
                .ok_or_else(|| bad(&format!("no number {k}")))
        };
        let m = c
            .get("camera_to_world")
            .and_then(|m| m.as_array())
            .filter(|m| m.len() >= 3)
            .ok_or_else(|| bad("no camera_to_world"))?;
        let mut rows = [[0.0; 4]; 3];
        for (r, row) in rows.iter_mut().enumerate() {
            let cols = m[r]
                .as_array()
                .filter(|c| c.len() == 4)
                .ok_or_else(|| bad("camera_to_world is not 4 x 4"))?;
            for (k, v) in cols.iter().enumerate() {
                row[k] = v
                    .as_f64()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| bad("camera_to_world has a non-number"))?;
            }
        }
        // Columns: right, down, forward; the last column is the eye.
        let axes = [0, 1, 2].map(|c| [rows[0][c], rows[1][c], rows[2][c]]);
        let eye = [rows[0][3], rows[1][3], rows[2][3]];
        let view = View {
            eye,
            axes,
            fx: num("fx")?,
            fy: num("fy")?,
            cx: num("cx")?,
            cy: num("cy")?,
            width: num("width")?,
            height: num("height")?,
        };
        if !(view.fx > 0.0 && view.fy > 0.0 && view.width > 0.0 && view.height > 0.0) {
            return Err(bad("focal lengths and size must be positive"));
        }
        Ok(view)
    }

    /// `p` in camera coordinates (x right, y down, z forward).
    fn to_camera(&self, p: [f64; 3]) -> [f64; 3] {
        let d = [p[0] - self.eye[0], p[1] - self.eye[1], p[2] - self.eye[2]];
        self.axes.map(|a| a[0] * d[0] + a[1] * d[1] + a[2] * d[2])
    }

    /// True when the box `lo..hi` lies wholly outside one plane of the frustum.
    pub fn culls(&self, lo: [f64; 3], hi: [f64; 3]) -> bool {
        let corners: Vec<[f64; 3]> = (0..8)
            .map(|k| {
                let pick = |a: usize| if (k >> a) & 1 == 1 { hi[a] } else { lo[a] };
                self.to_camera([pick(0), pick(1), pick(2)])
            })
            .collect();
        // Each plane as a linear form in camera coordinates, >= 0 on the frustum's side: in
        // front of the eye, u >= 0, u <= width, v >= 0, v <= height.
        let planes = [
            [0.0, 0.0, 1.0],
            [self.fx, 0.0, self.cx],
            [-self.fx, 0.0, self.width - self.cx],
            [0.0, self.fy, self.cy],
            [0.0, -self.fy, self.height - self.cy],
        ];
        planes.iter().any(|a| {
            corners
                .iter()
                .all(|c| a[0] * c[0] + a[1] * c[1] + a[2] * c[2] < 0.0)
        })
    }

    /// The distance from the eye to the box `lo..hi` (0 inside it).
    pub fn distance(&self, lo: [f64; 3], hi: [f64; 3]) -> f64 {
        let mut d2 = 0.0;
        for a in 0..3 {
            let e = self.eye[a];
            let g = (lo[a] - e).max(e - hi[a]).max(0.0);
            d2 += g * g;
        }
        d2.sqrt()
    }

    /// The focal length that projects a world length at distance 1 to pixels.
    pub fn focal(&self) -> f64 {
        self.fx.max(self.fy)
    }
}

/// Node `k`'s point spacing projected at its nearest distance to the eye, pixels (infinite
/// when the eye is inside its cube).
pub fn projected_spacing(copc: &Copc, view: &View, k: usize) -> f64 {
    let (lo, hi) = copc.bounds(k);
    let d = view.distance(lo, hi);
    let s = copc.level_spacing(copc.nodes[k].key.l);
    if d > 0.0 {
        view.focal() * s / d
    } else {
        f64::INFINITY
    }
}

/// The nodes selected for `view` at `threshold` pixels (see the module's doc), in traversal
/// order, and a flag per node.
pub fn select_nodes(copc: &Copc, view: &View, threshold: f64) -> (Vec<usize>, Vec<bool>) {
    let mut selected = vec![false; copc.nodes.len()];
    let mut order = Vec::new();
    let mut stack = vec![0usize];
    while let Some(k) = stack.pop() {
        let (lo, hi) = copc.bounds(k);
        if view.culls(lo, hi) {
            continue;
        }
        selected[k] = true;
        order.push(k);
        if projected_spacing(copc, view, k) >= threshold {
            stack.extend(copc.nodes[k].children.iter().flatten().map(|&c| c as usize));
        }
    }
    (order, selected)
}

/// Splat radii: the full-detail radius and the density spacing it stands for.
#[derive(Debug, Clone, Copy)]
pub struct Radii {
    /// Full-detail splat radius `R`, world units.
    pub full: f64,
    /// The cloud's density spacing `S` (None: every radius is `R`).
    pub spacing: Option<f64>,
}

impl Radii {
    /// The radius of a sample at spacing `s`.
    pub fn at(&self, s: f64) -> f64 {
        match self.spacing {
            Some(sp) if sp > 0.0 => self.full.max(self.full * s / sp),
            _ => self.full,
        }
    }
}

/// The radius of point `p` of selected node `k` (see the module's doc).
pub fn radius_of(copc: &Copc, selected: &[bool], k: usize, p: [f64; 3], radii: &Radii) -> f64 {
    let mut m = k;
    loop {
        let (lo, hi) = copc.bounds(m);
        let mut dir = 0;
        for a in 0..3 {
            if p[a] >= 0.5 * (lo[a] + hi[a]) {
                dir |= 1 << a;
            }
        }
        match copc.nodes[m].children[dir] {
            Some(c) if selected[c as usize] => m = c as usize,
            Some(_) => return radii.at(copc.level_spacing(copc.nodes[m].key.l)),
            None => return radii.full,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Eye at z = 5 looking down −z, 640 × 480, f = 500.
    fn view() -> View {
        let json = serde_json::json!({
            "model": "pinhole", "width": 640, "height": 480,
            "camera_to_world": [[1, 0, 0, 0], [0, -1, 0, 0], [0, 0, -1, 5], [0, 0, 0, 1]],
            "fx": 500, "fy": 500, "cx": 320, "cy": 240
        });
        View::from_json(&json).expect("a pinhole camera")
    }

    #[test]
    fn a_box_is_culled_only_wholly_outside_one_plane() {
        let v = view();
        // In view, straddling the image border, behind the eye, beside the frustum.
        assert!(!v.culls([-0.5; 3], [0.5; 3]));
        assert!(!v.culls([3.0, -0.1, -0.1], [4.0, 0.1, 0.1])); // u 620 to 720 at depth 5
        assert!(v.culls([-1.0, -1.0, 6.0], [1.0, 1.0, 7.0]));
        // x = 4 at depth 5 projects to u = 720 > 640.
        assert!(v.culls([4.0, -0.1, -0.1], [4.5, 0.1, 0.1]));
        // Above the image (v < 0 is +y here: the camera's y points down).
        assert!(v.culls([-0.1, 3.0, -0.1], [0.1, 3.5, 0.1]));
        assert!(!v.culls([-0.1, 2.0, -0.1], [0.1, 2.5, 0.1]));
    }

    #[test]
    fn the_distance_is_to_the_nearest_point_of_the_box() {
        let v = view();
        assert_eq!(v.distance([-1.0, -1.0, -1.0], [1.0, 1.0, 1.0]), 4.0);
        assert_eq!(v.distance([-1.0, -1.0, 4.0], [1.0, 1.0, 6.0]), 0.0);
        assert!((v.distance([3.0, 4.0, 5.0], [4.0, 5.0, 6.0]) - 5.0).abs() < 1e-12);
        assert_eq!(v.focal(), 500.0);
    }

    #[test]
    fn radii_grow_with_the_spacing_and_never_below_full_detail() {
        let r = Radii {
            full: 0.3,
            spacing: Some(0.2),
        };
        assert_eq!(r.at(0.1), 0.3);
        assert!((r.at(0.8) - 1.2).abs() < 1e-12);
        let none = Radii {
            full: 0.3,
            spacing: None,
        };
        assert_eq!(none.at(0.8), 0.3);
    }
}
