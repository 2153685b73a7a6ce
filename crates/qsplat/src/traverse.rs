//! QSplat's view-dependent traversal (Rusinkiewicz and Levoy 2000, §4; seed 002 §5.2.2).
//!
//! Depth first from the root, decoding each node's sphere relative to its parent's:
//! - **frustum culling**: a sphere entirely outside one of the view's side or near planes is
//!   skipped with its subtree; a sphere entirely inside all of them exempts its subtree from
//!   further tests;
//! - **back-face culling** with the normal cone: a node whose every normal faces away from the
//!   eye (n · v̂ > sin(cone) + r/|v|, v from the eye to the centre; conservative for the
//!   sphere's extent) is skipped;
//! - **level of detail**: a node is drawn as one splat (its decoded sphere, normal and colour)
//!   when it is a leaf or its projected diameter 2r·f/depth is at most the threshold in pixels;
//!   otherwise its children are visited.
//!
//! Every decision uses the decoded (quantised) values, as the original renderer does. The
//! traversal is for pinhole cameras (any intrinsics; `cloud::camera`): callers check the model
//! (`Camera::require`); the frustum of another model would be wrong here.

use cloud::Camera;
use cloud::glam::DVec3;

use crate::quant;
use crate::tree::{QTree, Word};

/// Traversal options.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TraverseParams {
    /// Largest projected diameter, in pixels, drawn as one splat.
    pub threshold_px: f64,
    /// Skip spheres outside the view frustum.
    pub frustum_cull: bool,
    /// Skip nodes whose normal cone faces away.
    pub backface_cull: bool,
}

impl Default for TraverseParams {
    fn default() -> Self {
        Self {
            threshold_px: 1.0,
            frustum_cull: true,
            backface_cull: true,
        }
    }
}

/// A splat to draw.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Splat {
    /// Centre.
    pub center: DVec3,
    /// Radius.
    pub radius: f64,
    /// Unit normal.
    pub normal: DVec3,
    /// RGB colour (RGB565 decoded; mid grey without colours).
    pub color: [u8; 3],
    /// Depth of the node in the tree (0 for the root).
    pub level: u16,
}

/// Planes of the view frustum (inward normals): left, right, top, bottom, near; through the
/// eye and the image's edges, so any pinhole intrinsics (off-centre principal point, fx ≠ fy)
/// are honoured.
fn frustum(camera: &Camera) -> [(DVec3, f64); 5] {
    let (w, h) = (camera.width as f64, camera.height as f64);
    let dir = |x: f64, y: f64| camera.ray(x, y).1;
    let (c00, c10, c11, c01) = (dir(0.0, 0.0), dir(w, 0.0), dir(w, h), dir(0.0, h));
    let centre = dir(0.5 * w, 0.5 * h);
    let plane = |a: DVec3, b: DVec3| {
        let n = a.cross(b).normalize();
        let n = if n.dot(centre) < 0.0 { -n } else { n };
        (n, n.dot(camera.eye))
    };
    let f = camera.forward();
    [
        plane(c00, c01),
        plane(c10, c11),
        plane(c00, c10),
        plane(c01, c11),
        (f, f.dot(camera.eye)),
    ]
}

/// The splats `tree` draws for `camera`.
pub fn traverse(tree: &QTree, camera: &Camera, params: &TraverseParams) -> Vec<Splat> {
    let planes = frustum(camera);
    let mut out = Vec::new();
    let Some(root) = Word::unpack(tree.root_word) else {
        return out;
    };
    // Stack entries: (node word position or usize::MAX for the root, decoded sphere, word,
    // position of its children group, inside-frustum flag, depth).
    struct Item {
        center: DVec3,
        radius: f64,
        word: Word,
        color: u16,
        children_at: usize,
        inside: bool,
        depth: u16,
    }
    let mut stack = vec![Item {
        center: tree.root_center,
        radius: tree.root_radius,
        word: root,
        color: tree.root_color,
        children_at: 0,
        inside: false,
        depth: 0,
    }];
    while let Some(it) = stack.pop() {
        let mut inside = it.inside;
        if params.frustum_cull && !inside {
            let mut all_in = true;
            let mut out_of_one = false;
            for (n, d) in &planes {
                let s = n.dot(it.center) - d;
                if s < -it.radius {
                    out_of_one = true;
                    break;
                }
                if s < it.radius {
                    all_in = false;
                }
            }
            if out_of_one {
                continue;
            }
            inside = all_in;
        }
        let v = it.center - camera.eye;
        let dist = v.length();
        let normal = quant::decode_normal(it.word.normal);
        if params.backface_cull && dist > it.radius {
            let sin_cone = quant::decode_cone_sin(it.word.cone);
            if normal.dot(v) > sin_cone * dist + it.radius {
                continue;
            }
        }
        let depth = v.dot(camera.forward()).max(1e-12);
        let projected = 2.0 * it.radius / camera.pixel_size_at(depth);
        if it.word.children == 0 || projected <= params.threshold_px {
            let color = if tree.colors.is_some() {
                quant::decode_rgb565(it.color)
            } else {
                [180, 180, 180]
            };
            out.push(Splat {
                center: it.center,
                radius: it.radius,
                normal,
                color,
                level: it.depth,
            });
            continue;
        }
        // Children: the group at `children_at`, after its offset word if it has one.
        let group = it.children_at;
        let first = group + usize::from(it.word.grandchildren);
        let mut grand_at = if it.word.grandchildren {
            tree.words[group] as usize
        } else {
            0
        };
        let mut kids = Vec::with_capacity(4);
        for at in first..first + usize::from(it.word.children) {
            let Some(w) = Word::unpack(tree.words[at]) else {
                break;
            };
            let Some((c, r)) = quant::decode_sphere(w.sphere, it.center, it.radius) else {
                break;
            };
            let color = tree.colors.as_ref().map_or(0, |cs| cs[at]);
            kids.push(Item {
                center: c,
                radius: r,
                word: w,
                color,
                children_at: grand_at,
                inside,
                depth: it.depth + 1,
            });
            if w.children > 0 {
                grand_at += usize::from(w.grandchildren) + w.children as usize;
            }
        }
        // Depth first, children in order.
        stack.extend(kids.into_iter().rev());
    }
    out
}
