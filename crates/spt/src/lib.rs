//! `spt`: Sequential Point Trees, Dachsbacher, Vogelgsang and Stamminger, SIGGRAPH 2003
//! (seed 002 §5.3).
//!
//! [`hierarchy`] builds the octree of discs with the error metrics e_p (eq. 5.1, 5.2), e_t and
//! e_g (eq. 5.5); [`list`] flattens it into the list sorted by r_max that a view cuts with a
//! sequential scan of a prefix; [`recursive`] is the depth-first traversal of §5.3.3 that the
//! scan must reproduce exactly (a property test checks it for random views and thresholds);
//! [`file`] stores the list as a view reads it, its splats quantised by [`pack`]; [`ooc`]
//! builds that file out of core, the same bytes as the in-memory build; [`paged`] cuts it from
//! the file, reading only the prefix a view needs.
//!
//! The threshold ε is the image-space error e_g / r in radians; [`epsilon_for_pixels`] converts
//! a tolerance in pixels for a camera. Splats are drawn with the node's diameter d (screen size
//! d / r, seed §5.3.3). Points need normals. Like the original (seed §5.3.5) there is no frustum
//! or back-face culling.
//!
//! NOTE (seed erratum): §5.3.3 of the seed says the children are visited when ẽ_g is *below*
//! ε; the original (and the rest of the section) refines while the error is *above* ε and draws
//! a node when it is below or the node is a leaf, which is what this crate does.

pub mod file;
pub mod hierarchy;
pub mod list;
pub mod ooc;
pub mod pack;
pub mod paged;
pub mod recursive;

use cloud::glam::{DVec3, Vec3};
use cloud::{Camera, PointCloud};

pub use cloud::lod_file::{Error, Result};
pub use list::CutStats;

use hierarchy::Hierarchy;
use list::{Quantized, SequentialList};

/// A splat to draw.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Splat {
    /// Centre.
    pub center: DVec3,
    /// Radius (half the node's diameter).
    pub radius: f64,
    /// Unit normal.
    pub normal: Vec3,
    /// Colour in [0, 1].
    pub color: Vec3,
}

/// A built sequential point tree.
#[derive(Debug, Clone, PartialEq)]
pub struct Spt {
    hierarchy: Hierarchy,
    quant: Quantized,
    list: SequentialList,
    leaf_diameter: f64,
    colors: bool,
}

/// Builds the tree of `cloud` (which must have normals) with leaf discs of `leaf_diameter`.
pub fn build(cloud: &PointCloud, leaf_diameter: f64) -> Result<Spt> {
    if cloud.is_empty() {
        return Err(Error::EmptyCloud);
    }
    cloud.validate()?;
    let normals = cloud.normals.as_deref().ok_or(Error::MissingNormals)?;
    if !(leaf_diameter > 0.0) || !leaf_diameter.is_finite() {
        return Err(Error::InvalidParameter {
            name: "leaf_diameter",
            reason: format!("must be positive, got {leaf_diameter}"),
        });
    }
    if cloud.len() > u32::MAX as usize / 2 {
        return Err(Error::InvalidParameter {
            name: "cloud",
            reason: format!("{} points is too many", cloud.len()),
        });
    }
    let hierarchy = hierarchy::build(&hierarchy::Input {
        positions: &cloud.positions,
        normals,
        colors: cloud.colors.as_deref(),
        leaf_diameter,
    });
    let quant = Quantized::new(&hierarchy);
    let list = SequentialList::new(&hierarchy, &quant);
    Ok(Spt {
        hierarchy,
        quant,
        list,
        leaf_diameter,
        colors: cloud.colors.is_some(),
    })
}

/// The threshold ε (radians) for an error of `px` pixels at the centre of `camera`'s image.
pub fn epsilon_for_pixels(camera: &Camera, px: f64) -> f64 {
    px / camera.focal_px()
}

pub(crate) fn check(eye: DVec3, epsilon: f64) -> Result<f32> {
    if !eye.is_finite() {
        return Err(Error::InvalidParameter {
            name: "eye",
            reason: format!("must be finite, got {eye}"),
        });
    }
    if !(epsilon >= 0.0) || !epsilon.is_finite() {
        return Err(Error::InvalidParameter {
            name: "epsilon",
            reason: format!("must be finite and ≥ 0, got {epsilon}"),
        });
    }
    Ok((epsilon * epsilon) as f32)
}

impl Spt {
    /// The hierarchy.
    pub fn hierarchy(&self) -> &Hierarchy {
        &self.hierarchy
    }

    /// The leaf discs' diameter.
    pub fn leaf_diameter(&self) -> f64 {
        self.leaf_diameter
    }

    /// The sequential list.
    pub fn list(&self) -> &SequentialList {
        &self.list
    }

    /// Entries of the list (= nodes of the hierarchy).
    pub fn len(&self) -> usize {
        self.list.entries.len()
    }

    /// Never: a tree has at least its root.
    pub fn is_empty(&self) -> bool {
        self.list.entries.is_empty()
    }

    /// The sequential cut for an eye and a threshold ε (radians): the selected list entries,
    /// ascending, appended to `out` (cleared first). An eye inside a node's box has r = 0 there,
    /// so that part of the object is drawn at full resolution.
    pub fn cut_into(&self, eye: DVec3, epsilon: f64, out: &mut Vec<u32>) -> Result<CutStats> {
        let eps2 = check(eye, epsilon)?;
        out.clear();
        let root = &self.quant.boxes[self.hierarchy.root()];
        Ok(self.list.cut_into(root, self.quant.eye(eye), eps2, out))
    }

    /// [`Spt::cut_into`] into a new vector.
    pub fn cut(&self, eye: DVec3, epsilon: f64) -> Result<(Vec<u32>, CutStats)> {
        let mut out = Vec::new();
        let stats = self.cut_into(eye, epsilon, &mut out)?;
        Ok((out, stats))
    }

    /// The recursive traversal of §5.3.3: the hierarchy nodes drawn, in depth-first order.
    pub fn cut_recursive(&self, eye: DVec3, epsilon: f64) -> Result<Vec<u32>> {
        let eps2 = check(eye, epsilon)?;
        Ok(recursive::cut(
            &self.hierarchy,
            &self.quant,
            self.quant.eye(eye),
            eps2,
        ))
    }

    /// The hierarchy node of a list entry.
    pub fn node_of(&self, entry: u32) -> u32 {
        self.list.node[entry as usize]
    }

    /// The splat of a hierarchy node.
    pub fn node_splat(&self, node: u32) -> Splat {
        let n = &self.hierarchy.nodes[node as usize];
        Splat {
            center: self.hierarchy.origin + n.center.as_dvec3(),
            radius: f64::from(n.radius()),
            normal: n.normal,
            color: n.color,
        }
    }

    /// The splats of a cut's entries as its file stores them ([`pack`]: centres and normals
    /// quantised, colours in 8 bits): what [`paged::PagedTree::splats`] reads back.
    pub fn file_splats(&self, entries: &[u32]) -> Vec<Splat> {
        let grid = file::grid_of(self);
        let mut b = Vec::with_capacity(pack::SPLAT + pack::COLOR);
        entries
            .iter()
            .map(|&e| {
                let q = self.list.entries[e as usize].b;
                let n = &self.hierarchy.nodes[self.node_of(e) as usize];
                b.clear();
                pack::push_splat(&mut b, n, &q, &grid);
                pack::push_color(&mut b, n);
                let (center, radius, normal) = pack::splat_of(&b, &q, grid.origin, grid.cell);
                Splat {
                    center,
                    radius: f64::from(radius),
                    normal,
                    color: if self.colors {
                        pack::color_of(&b[pack::SPLAT..])
                    } else {
                        Vec3::splat(0.75)
                    },
                }
            })
            .collect()
    }

    /// The splats of a cut's entries.
    pub fn splats(&self, entries: &[u32]) -> Vec<Splat> {
        entries
            .iter()
            .map(|&e| self.node_splat(self.node_of(e)))
            .collect()
    }
}

#[cfg(test)]
mod tests;
