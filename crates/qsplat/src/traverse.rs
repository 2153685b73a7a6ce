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

/// The root of a tree: its sphere (stored in full), word and colour.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Root {
    /// Sphere centre.
    pub center: DVec3,
    /// Sphere radius.
    pub radius: f64,
    /// Its word (the sphere bits unused).
    pub word: u32,
    /// Its colour (RGB565).
    pub color: u16,
}

/// Where a traversal reads a tree's words: the in-memory [`QTree`] or a built file read on
/// demand ([`crate::paged::PagedTree`]).
pub trait Nodes {
    /// Why a word could not be read.
    type Error;
    /// The root.
    fn root(&self) -> Root;
    /// Words after the root.
    fn word_count(&self) -> usize;
    /// Whether the tree has colours.
    fn colored(&self) -> bool;
    /// Word `at` (`at < word_count()`).
    fn word(&mut self, at: usize) -> Result<u32, Self::Error>;
    /// The colour of word `at` (`at < word_count()`; only asked when [`Nodes::colored`]).
    fn color(&mut self, at: usize) -> Result<u16, Self::Error>;
    /// A word the traversal cannot use (`at`: its position, or `usize::MAX` for the root):
    /// `Some` error to stop with, or `None` to skip the rest of that group silently (a
    /// validated in-memory tree never has one).
    fn corrupt(&self, at: usize, reason: &str) -> Option<Self::Error>;
}

impl Nodes for &QTree {
    type Error = std::convert::Infallible;
    fn root(&self) -> Root {
        Root {
            center: self.root_center,
            radius: self.root_radius,
            word: self.root_word,
            color: self.root_color,
        }
    }
    fn word_count(&self) -> usize {
        self.words.len()
    }
    fn colored(&self) -> bool {
        self.colors.is_some()
    }
    fn word(&mut self, at: usize) -> Result<u32, Self::Error> {
        Ok(self.words[at])
    }
    fn color(&mut self, at: usize) -> Result<u16, Self::Error> {
        Ok(self.colors.as_ref().map_or(0, |c| c[at]))
    }
    fn corrupt(&self, _at: usize, _reason: &str) -> Option<Self::Error> {
        None
    }
}

/// The splats `tree` draws for `camera`.
pub fn traverse(tree: &QTree, camera: &Camera, params: &TraverseParams) -> Vec<Splat> {
    let mut out = Vec::new();
    match walk(&mut &*tree, Some((camera, params)), |s| out.push(s)) {
        Ok(()) => out,
        Err(never) => match never {},
    }
}

/// [`traverse`] on any [`Nodes`] (a built file read on demand).
pub fn traverse_nodes<N: Nodes>(
    nodes: &mut N,
    camera: &Camera,
    params: &TraverseParams,
) -> Result<Vec<Splat>, N::Error> {
    let mut out = Vec::new();
    walk(nodes, Some((camera, params)), |s| out.push(s))?;
    Ok(out)
}

/// Every leaf of the tree, decoded, depth first (the full-detail splats, for a reference
/// render of a tree whose points are not in memory); returns how many.
pub fn leaves<N: Nodes>(nodes: &mut N, mut emit: impl FnMut(Splat)) -> Result<u64, N::Error> {
    let mut count = 0u64;
    walk(nodes, None, |s| {
        count += 1;
        emit(s);
    })?;
    Ok(count)
}

/// A node on the traversal's stack: its decoded sphere, word and colour.
struct Item {
    center: DVec3,
    radius: f64,
    word: Word,
    color: u16,
    /// Position of its children's group.
    children_at: usize,
    /// Inside every frustum plane (its subtree is not tested again).
    inside: bool,
    depth: u16,
}

/// The depth-first traversal: for a camera, the cut of the module's documentation; without
/// one, every leaf (no culling, no level of detail). Positions only grow along a path and at
/// most one node per word is visited, so a damaged tree cannot make it loop.
fn walk<N: Nodes>(
    nodes: &mut N,
    view: Option<(&Camera, &TraverseParams)>,
    mut emit: impl FnMut(Splat),
) -> Result<(), N::Error> {
    let planes = view.map(|(camera, _)| frustum(camera));
    let root = nodes.root();
    let n = nodes.word_count();
    let Some(word) = Word::unpack(root.word) else {
        return nodes
            .corrupt(usize::MAX, "bad root tree bits")
            .map_or(Ok(()), Err);
    };
    let mut stack = vec![Item {
        center: root.center,
        radius: root.radius,
        word,
        color: root.color,
        children_at: 0,
        inside: false,
        depth: 0,
    }];
    let mut visited = 0usize;
    while let Some(mut it) = stack.pop() {
        visited += 1;
        if visited > n + 1 {
            return nodes
                .corrupt(it.children_at, "more nodes reached than the tree has words")
                .map_or(Ok(()), Err);
        }
        if let (Some((_, params)), Some(planes)) = (view, &planes)
            && params.frustum_cull
            && !it.inside
        {
            let mut all_in = true;
            let mut out_of_one = false;
            for (n, d) in planes {
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
            it.inside = all_in;
        }
        let normal = quant::decode_normal(it.word.normal);
        let mut refine = it.word.children > 0;
        if let Some((camera, params)) = view {
            let v = it.center - camera.eye;
            let dist = v.length();
            if params.backface_cull && dist > it.radius {
                let sin_cone = quant::decode_cone_sin(it.word.cone);
                if normal.dot(v) > sin_cone * dist + it.radius {
                    continue;
                }
            }
            let depth = v.dot(camera.forward()).max(1e-12);
            let projected = 2.0 * it.radius / camera.pixel_size_at(depth);
            refine = refine && projected > params.threshold_px;
        }
        if refine {
            // Depth first, children in order: pushed last to first.
            let from = stack.len();
            push_children(nodes, &it, n, &mut stack)?;
            stack[from..].reverse();
            continue;
        }
        let color = if nodes.colored() {
            quant::decode_rgb565(it.color)
        } else {
            [180, 180, 180]
        };
        emit(Splat {
            center: it.center,
            radius: it.radius,
            normal,
            color,
            level: it.depth,
        });
    }
    Ok(())
}

/// Pushes the children of `it` (the group at `it.children_at`, after its offset word if it has
/// one) in order, their spheres decoded relative to its; a word that cannot be used stops with
/// [`Nodes::corrupt`]'s error or ends the group.
fn push_children<N: Nodes>(
    nodes: &mut N,
    it: &Item,
    n: usize,
    stack: &mut Vec<Item>,
) -> Result<(), N::Error> {
    let group = it.children_at;
    let first = group + usize::from(it.word.grandchildren);
    let end = first + usize::from(it.word.children);
    if end > n {
        return nodes
            .corrupt(group, "a group runs past the end")
            .map_or(Ok(()), Err);
    }
    let mut grand_at = if it.word.grandchildren {
        let at = nodes.word(group)? as usize;
        if at < end || at >= n {
            return nodes
                .corrupt(group, "an offset points outside the words after its group")
                .map_or(Ok(()), Err);
        }
        at
    } else {
        0
    };
    for at in first..end {
        let Some(w) = Word::unpack(nodes.word(at)?) else {
            return nodes
                .corrupt(at, "grandchildren without children")
                .map_or(Ok(()), Err);
        };
        let Some((center, radius)) = quant::decode_sphere(w.sphere, it.center, it.radius) else {
            return nodes
                .corrupt(at, "sphere index out of range")
                .map_or(Ok(()), Err);
        };
        if u32::from(w.normal) >= quant::NORMAL_CODES {
            return nodes
                .corrupt(at, "normal code out of range")
                .map_or(Ok(()), Err);
        }
        if w.children > 0 && !it.word.grandchildren {
            return nodes
                .corrupt(at, "a node has children but its group has no offset")
                .map_or(Ok(()), Err);
        }
        let color = if nodes.colored() { nodes.color(at)? } else { 0 };
        stack.push(Item {
            center,
            radius,
            word: w,
            color,
            children_at: grand_at,
            inside: it.inside,
            depth: it.depth.saturating_add(1),
        });
        if w.children > 0 {
            grand_at += usize::from(w.grandchildren) + usize::from(w.children);
        }
    }
    Ok(())
}
