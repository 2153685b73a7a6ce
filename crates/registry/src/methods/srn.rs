//! `srn`: seed 003 (Qu et al. 2006; the `srn` crate): each point kept when its random number is
//! below its importance (the texture's JPEG2000 visual masking) times `scale`, splats grown by
//! 1/√I.

use cloud::Camera;
use splat::render::Splat;
use srn::{MaskingParams, Srn, SrnParams, masking_map};

use crate::card::{Card, Kind, Memory};
use crate::error::{Error, Result};
use crate::lod::{LodArgs, LodBuilt, LodInput, LodMethod, LodSelector, LodSize, args_of};
use crate::params::{Param, Reader};

/// The card.
pub static CARD: Card = Card::new(
    "srn",
    "SRN (seed 003): random numbers against a JPEG2000 visual-masking importance",
    Kind::Lod(&SrnMethod),
    &[SCALE],
    // 1.25 times the peak per point measured at 10^7 points (build and selection, with the
    // normals, colours and texture coordinates of `LodData`), less the cloud's 48.
    Memory::PerPoint(72),
);

const SCALE: Param = Param::value(
    "scale",
    "1.0",
    "density scale: a point is kept when its random number is below scale × importance (1: the paper)",
);

/// The method.
struct SrnMethod;

/// Its setting.
struct Args(SrnParams);

impl LodMethod for SrnMethod {
    fn parse(&self, r: &mut Reader<'_>) -> Result<LodArgs> {
        Ok(Box::new(Args(SrnParams {
            scale: r.get(&SCALE)?,
            ..SrnParams::default()
        })))
    }

    fn build(&self, input: &LodInput<'_>) -> Result<Box<dyn LodBuilt>> {
        let err = |e: srn::Error| Error::Unsupported(format!("srn: {e}"));
        let texture = input.texture.ok_or_else(|| {
            Error::Unsupported(
                "srn needs a texture: its importance is the texture's visual masking".into(),
            )
        })?;
        let map = masking_map(texture, &MaskingParams::default()).map_err(err)?;
        Ok(Box::new(Built(
            Srn::new(input.uvs, &map, input.seed).map_err(err)?,
        )))
    }
}

struct Built(Srn);

impl LodBuilt for Built {
    fn size(&self) -> LodSize {
        let n = self.0.len();
        LodSize {
            nodes: n,
            bytes: 8.0 * n as f64,
        }
    }

    fn selector<'s>(
        &'s self,
        input: &'s LodInput<'s>,
        args: &'s LodArgs,
    ) -> Result<Box<dyn LodSelector + 's>> {
        Ok(Box::new(Selector {
            srn: &self.0,
            input,
            params: &args_of::<Args>(args, CARD.name)?.0,
            kept: Vec::new(),
        }))
    }
}

struct Selector<'s> {
    srn: &'s Srn,
    input: &'s LodInput<'s>,
    params: &'s SrnParams,
    kept: Vec<u32>,
}

impl LodSelector for Selector<'_> {
    fn select(&mut self, _camera: &Camera) -> Result<()> {
        self.srn
            .select_into(self.params, &mut self.kept)
            .map_err(|e| Error::Unsupported(format!("srn: {e}")))
    }

    fn splats(&self) -> Vec<Splat> {
        self.kept
            .iter()
            .map(|&i| {
                let i = i as usize;
                let grow = f64::from(self.srn.radius_factor(i, self.params));
                self.input.point_splat(i, self.input.radius * grow)
            })
            .collect()
    }
}
