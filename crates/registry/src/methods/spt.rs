//! `spt`: Sequential Point Trees (Dachsbacher et al. 2003, seed 002 §5.3; the `spt` crate), the
//! sequential list cut at a screen-space error ε of `epsilon_px` pixels. Its setting and
//! splats serve a built SPT file too (`crate::lod_file`).

use cloud::Camera;
use splat::render::Splat;

use crate::card::{Card, Kind, Memory};
use crate::error::{Error, Result};
use crate::lod::{LodArgs, LodBuilt, LodInput, LodMethod, LodSelector, LodSize, args_of};
use crate::params::{Param, Reader};

/// The card.
pub static CARD: Card = Card::new(
    "spt",
    "Sequential Point Trees (Dachsbacher et al. 2003): sorted list cut at an error (seed 002)",
    Kind::Lod(&Spt),
    &[EPSILON_PX],
    // 1.25 times the peak per point measured at 10^7 points (build and selection, with the
    // normals, colours and texture coordinates of `LodData`), less the cloud's 48.
    Memory::PerPoint(392),
);

const EPSILON_PX: Param = Param::value(
    "epsilon_px",
    "1.0",
    "screen-space error ε in pixels (spt::epsilon_for_pixels)",
);

/// The method.
struct Spt;

/// Its setting: the error in pixels (the in-memory list's and a built file's).
pub(crate) struct Args(pub(crate) f64);

impl LodMethod for Spt {
    fn parse(&self, r: &mut Reader<'_>) -> Result<LodArgs> {
        Ok(Box::new(Args(r.get(&EPSILON_PX)?)))
    }

    fn build(&self, input: &LodInput<'_>) -> Result<Box<dyn LodBuilt>> {
        let s = spt::build(input.cloud, 2.0 * input.radius)
            .map_err(|e| Error::Unsupported(format!("spt: {e}")))?;
        Ok(Box::new(Built(s)))
    }
}

struct Built(spt::Spt);

impl LodBuilt for Built {
    fn size(&self) -> LodSize {
        LodSize {
            nodes: self.0.len(),
            bytes: 0.0,
        }
    }

    fn selector<'s>(
        &'s self,
        _input: &'s LodInput<'s>,
        args: &'s LodArgs,
    ) -> Result<Box<dyn LodSelector + 's>> {
        Ok(Box::new(Selector {
            spt: &self.0,
            pixels: args_of::<Args>(args, CARD.name)?.0,
            entries: Vec::new(),
        }))
    }
}

struct Selector<'s> {
    spt: &'s spt::Spt,
    pixels: f64,
    entries: Vec<u32>,
}

impl LodSelector for Selector<'_> {
    fn select(&mut self, camera: &Camera) -> Result<()> {
        let eps = spt::epsilon_for_pixels(camera, self.pixels);
        self.spt
            .cut_into(camera.eye, eps, &mut self.entries)
            .map(|_| ())
            .map_err(|e| Error::Unsupported(format!("spt: {e}")))
    }

    fn splats(&self) -> Vec<Splat> {
        self.spt
            .splats(&self.entries)
            .iter()
            .map(splat_of)
            .collect()
    }
}

/// A sequential point tree's splat as the renderer's.
pub(crate) fn splat_of(s: &spt::Splat) -> Splat {
    Splat {
        center: s.center,
        radius: s.radius as f32,
        normal: s.normal,
        albedo: s.color,
    }
}
