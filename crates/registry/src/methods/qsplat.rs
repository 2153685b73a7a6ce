//! `qsplat`: QSplat (Rusinkiewicz & Levoy 2000, seed 002 §5.2; the `qsplat` crate), the
//! bounding-sphere tree cut at a projected-size threshold (`threshold_px`). Its setting and
//! splats serve a built QSplat file too (`crate::lod_file`).

use cloud::Camera;
use splat::render::Splat;

use crate::card::{Card, Kind, Memory};
use crate::error::{Error, Result};
use crate::lod::{LodArgs, LodBuilt, LodInput, LodMethod, LodSelector, LodSize, albedo, args_of};
use crate::params::{Param, Reader};

/// The card.
pub static CARD: Card = Card::new(
    "qsplat",
    "QSplat (Rusinkiewicz & Levoy 2000): bounding-sphere tree, projected-size cut (seed 002)",
    Kind::Lod(&Qsplat),
    &[THRESHOLD_PX],
    // 1.25 times the peak per point measured at 10^7 points (build and selection, with the
    // normals, colours and texture coordinates of `LodData`), less the cloud's 48.
    Memory::PerPoint(382),
)
// Without colour: 4 bytes a node, offset words included (the paper's count).
.with_bare_node_bytes(4);

const THRESHOLD_PX: Param = Param::value(
    "threshold_px",
    "2.0",
    "a node is drawn when its projected diameter is below this many pixels",
);

/// The method.
struct Qsplat;

/// Its setting: the traversal (the in-memory tree's and a built file's).
pub(crate) struct Args(pub(crate) qsplat::TraverseParams);

impl LodMethod for Qsplat {
    fn parse(&self, r: &mut Reader<'_>) -> Result<LodArgs> {
        Ok(Box::new(Args(qsplat::TraverseParams {
            threshold_px: r.get(&THRESHOLD_PX)?,
            ..Default::default()
        })))
    }

    fn build(&self, input: &LodInput<'_>) -> Result<Box<dyn LodBuilt>> {
        let tree = qsplat::build_tree(input.cloud, input.radius)
            .map_err(|e| Error::Unsupported(format!("qsplat: {e}")))?;
        Ok(Box::new(Built(tree)))
    }
}

struct Built(qsplat::QTree);

impl LodBuilt for Built {
    fn size(&self) -> LodSize {
        // Bytes as the original counts them (node words and colours, offsets included).
        LodSize {
            nodes: 1 + self.0.words.len(),
            bytes: self.0.payload_bytes() as f64,
        }
    }

    fn selector<'s>(
        &'s self,
        _input: &'s LodInput<'s>,
        args: &'s LodArgs,
    ) -> Result<Box<dyn LodSelector + 's>> {
        Ok(Box::new(Selector {
            tree: &self.0,
            params: &args_of::<Args>(args, CARD.name)?.0,
            last: Vec::new(),
        }))
    }
}

struct Selector<'s> {
    tree: &'s qsplat::QTree,
    params: &'s qsplat::TraverseParams,
    last: Vec<qsplat::traverse::Splat>,
}

impl LodSelector for Selector<'_> {
    fn select(&mut self, camera: &Camera) -> Result<()> {
        self.last = qsplat::traverse(self.tree, camera, self.params);
        Ok(())
    }

    fn splats(&self) -> Vec<Splat> {
        self.last.iter().map(splat_of).collect()
    }
}

/// A QSplat splat as a splat to render.
pub(crate) fn splat_of(s: &qsplat::Splat) -> Splat {
    Splat {
        center: s.center,
        radius: s.radius as f32,
        normal: s.normal.as_vec3(),
        albedo: albedo(s.color),
    }
}
