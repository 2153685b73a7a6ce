//! `random`: the baseline any level-of-detail method must beat: each point kept when its
//! seeded uniform number is below `fraction`, splats grown by 1/√f.

use cloud::Camera;
use cloud::rng::{RngExt, seeded};
use splat::render::Splat;

use crate::card::{Card, Kind, Memory};
use crate::error::Result;
use crate::lod::{LodArgs, LodBuilt, LodInput, LodMethod, LodSelector, LodSize, args_of};
use crate::params::{Param, Reader};

/// The card.
pub static CARD: Card = Card::new(
    "random",
    "baseline: a seeded uniform random subset, splats grown by 1/sqrt(fraction)",
    Kind::Lod(&Random),
    &[FRACTION],
    // 1.25 times the peak per point measured at 10^7 points (build and selection, with the
    // normals, colours and texture coordinates of `LodData`), less the cloud's 48.
    Memory::PerPoint(72),
);

const FRACTION: Param = Param::value(
    "fraction",
    "0.1",
    "share of the points kept (each by its seeded uniform number)",
);

/// The method.
struct Random;

/// Its setting: the fraction kept.
struct Args(f64);

impl LodMethod for Random {
    fn parse(&self, r: &mut Reader<'_>) -> Result<LodArgs> {
        let fraction: f64 = r.get(&FRACTION)?;
        if !(fraction > 0.0 && fraction <= 1.0) {
            return Err(r.bad(&FRACTION, fraction, "expected 0 < fraction <= 1"));
        }
        Ok(Box::new(Args(fraction)))
    }

    fn build(&self, input: &LodInput<'_>) -> Result<Box<dyn LodBuilt>> {
        let mut rng = seeded(input.seed, "lod-random-baseline");
        Ok(Box::new(Built(
            (0..input.cloud.len())
                .map(|_| rng.random::<f32>())
                .collect(),
        )))
    }
}

struct Built(Vec<f32>);

impl LodBuilt for Built {
    fn size(&self) -> LodSize {
        LodSize {
            nodes: self.0.len(),
            bytes: 4.0 * self.0.len() as f64,
        }
    }

    fn selector<'s>(
        &'s self,
        input: &'s LodInput<'s>,
        args: &'s LodArgs,
    ) -> Result<Box<dyn LodSelector + 's>> {
        Ok(Box::new(Selector {
            numbers: &self.0,
            input,
            fraction: args_of::<Args>(args, CARD.name)?.0,
            kept: Vec::new(),
        }))
    }
}

struct Selector<'s> {
    numbers: &'s [f32],
    input: &'s LodInput<'s>,
    fraction: f64,
    kept: Vec<u32>,
}

impl LodSelector for Selector<'_> {
    fn select(&mut self, _camera: &Camera) -> Result<()> {
        self.kept.clear();
        self.kept.extend(
            self.numbers
                .iter()
                .enumerate()
                .filter(|(_, r)| f64::from(**r) < self.fraction)
                .map(|(i, _)| i as u32),
        );
        Ok(())
    }

    fn splats(&self) -> Vec<Splat> {
        let radius = self.input.radius / self.fraction.sqrt();
        self.kept
            .iter()
            .map(|&i| self.input.point_splat(i as usize, radius))
            .collect()
    }
}
