//! A method's card: everything the registry, the experiments, the command line and the Python
//! package know of one method, visibility and level of detail alike, in one value. Its name,
//! summary and typed parameters (each with its default and help, written once), the family its
//! settings group under, its memory per point, whom it is a peer of, what of it the generic
//! experiments must know (instead of its name), the program behind it (availability, version)
//! for an external method, and what runs it ([`Kind`]).
//!
//! A card's setting is read once into the method's own typed struct before any work
//! ([`Card::setup`], [`Card::lod_args`]): the adapter reads the `KEY=VALUE` pairs through a
//! [`Reader`], and a key it did not read is refused there.

use crate::error::{Error, Result};
use crate::lod::{LodArgs, LodMethod};
use crate::params::{Param, ParamDefault, Params, Reader};
use crate::setting::{Setting, Value};
use crate::sweep::MethodSweep;
use crate::visibility::{Method, Setup};

/// One method: its description and what runs it.
pub struct Card {
    /// Name (command line, CSV `method`, sweeps table); one namespace for both kinds.
    pub name: &'static str,
    /// One line for listings.
    pub summary: &'static str,
    /// The keys a setting may set, each with its default and help.
    pub params: &'static [Param],
    /// The family a setting's results group under in plots and tables.
    pub family: Family,
    /// What the scale experiment may know of its memory.
    pub memory: Memory,
    /// True when several views are faster answered in parallel (one view per thread) than one
    /// after another (a method whose single view already uses every core says false).
    pub parallel_views: bool,
    /// For a peer (another project's tool measured beside ours): the family of ours it pairs
    /// with (`hpr`, `raycast`, `splat`, `voxel`, `lod`...); `None` for our own methods.
    pub peer_of: Option<&'static str>,
    /// For a peer: how its keys translate into its partner's where names or units differ.
    pub peer_keys: &'static [PeerKey],
    /// The literature's comparisons the method takes part in (the replicated tables mark it).
    pub compared_in: &'static [Comparison],
    /// Bytes per node of the built structure without colour, as the method's paper counts them
    /// (QSplat: 4, offset words included); `None` where no paper gives such a figure.
    pub bare_node_bytes: Option<u32>,
    /// Its own sweep, for a method that carries one (an external method's `method.toml`, a
    /// method registered at run time); `None`: the built-in grids (`sweeps.toml`) say.
    pub sweep: Option<MethodSweep>,
    /// The program behind an external method (its availability and version); `None` for ours.
    pub program: Option<&'static dyn Program>,
    /// The score it was made for, by which the findings and summaries judge it: the visible
    /// set (per point) or the image it shows (per pixel). Every visibility method is scored
    /// both ways; LOD methods, judged by their rendered image, say [`Metric::Pixels`].
    pub made_for: Metric,
    /// True when it claims to return exactly the set its definition gives (an exact hull, exact
    /// HPR and its peers): the findings check the claim against the exact set where a run has
    /// one (Jaccard 0.999 on every unperturbed cell) and never rank a method that fails it;
    /// `exact = true` in a `method.toml`.
    pub exact: bool,
    /// What runs it.
    pub kind: Kind,
}

/// What runs a method.
#[derive(Clone, Copy)]
pub enum Kind {
    /// A visibility method: indices per view.
    Visibility(&'static dyn Method),
    /// A level-of-detail method: built per cloud, splats per view and setting.
    Lod(&'static dyn LodMethod),
}

/// The score a method was made for ([`Card::made_for`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Metric {
    /// The visible set, point by point: precision, recall and F1 against the reference (HPR,
    /// the robust operator: a verdict per point).
    Points,
    /// The image: each pixel's point truly visible (pixel precision) and the mesh's pixels
    /// covered (coverage), ranked by their harmonic mean (ray casting, z-buffers, screen-space
    /// operators, one point per direction sector: a choice per pixel).
    Pixels,
}

impl Metric {
    /// `points` or `pixels`, as CSVs and `method.toml`'s `made_for` write it.
    pub fn as_str(self) -> &'static str {
        match self {
            Metric::Points => "points",
            Metric::Pixels => "pixels",
        }
    }
}

/// The family a setting's results group under.
#[derive(Debug, Clone, Copy)]
pub enum Family {
    /// The method's name.
    Name,
    /// This name.
    Named(&'static str),
    /// A function of the setting (HPR's kernels are families of their own).
    Of(fn(&Setting) -> &'static str),
}

/// What the scale experiment may know of a method's memory, so that its guard can refuse a
/// cell that cannot fit before it starts.
#[derive(Debug, Clone, PartialEq)]
pub enum Memory {
    /// Bytes per point the method needs beyond the sampled cloud's own 48 (its peak measured at
    /// 10^7 points, with a margin).
    PerPoint(u64),
    /// Not known: not run above [`Memory::UNKNOWN_LIMIT`] points.
    Unknown,
    /// The method takes no part in the scale experiment, for this reason (the report prints it).
    OptOut(String),
}

impl Memory {
    /// The most points a method of unknown memory is run on.
    pub const UNKNOWN_LIMIT: u64 = 1_000_000;
}

/// One translated parameter of a peer (`method.toml`'s `[peer_keys]`): the peer's `peer` at
/// value v stands for the partner's `ours` at `factor` × v.
#[derive(Debug, Clone, PartialEq)]
pub struct PeerKey {
    /// The peer's key.
    pub peer: &'static str,
    /// The partner's key.
    pub ours: &'static str,
    /// The partner's value over the peer's.
    pub factor: f64,
}

/// A comparison from the literature that the experiments replicate as a table, marking the
/// methods the paper compared.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Comparison {
    /// Mehra et al. 2010: HPR against the robust operator under noise along the normal.
    Mehra2010,
    /// Biasutti et al. 2019: their method against HPR and Pintus et al.'s on simulated scans.
    Biasutti2019,
}

/// The program behind an external method.
pub trait Program: Sync {
    /// `Ok` when it can run here; else why not (its environment is missing).
    fn availability(&self) -> std::result::Result<(), String>;
    /// Its version as its `version` command prints it; `None` without one.
    fn version(&self) -> Option<String>;
}

impl Card {
    /// A built-in card: its name, summary, what runs it, its parameters and its memory, every
    /// other field at its default, which the `with_` methods change where a method differs:
    /// its own name as its family, views one after another, no peer, no comparison of the
    /// literature, no paper's node size, the built-in sweeps, no program, not exact, and made
    /// for the visible set (a visibility method) or the image (an LOD method). Const, so a
    /// card stays a `static`.
    pub const fn new(
        name: &'static str,
        summary: &'static str,
        kind: Kind,
        params: &'static [Param],
        memory: Memory,
    ) -> Card {
        Card {
            name,
            summary,
            params,
            family: Family::Name,
            memory,
            parallel_views: false,
            peer_of: None,
            peer_keys: &[],
            compared_in: &[],
            bare_node_bytes: None,
            sweep: None,
            program: None,
            made_for: match kind {
                Kind::Visibility(_) => Metric::Points,
                Kind::Lod(_) => Metric::Pixels,
            },
            exact: false,
            kind,
        }
    }

    /// With the family its settings group under.
    pub const fn with_family(mut self, family: Family) -> Card {
        self.family = family;
        self
    }

    /// With several views answered in parallel, one a thread.
    pub const fn with_parallel_views(mut self) -> Card {
        self.parallel_views = true;
        self
    }

    /// Taking part in these comparisons of the literature.
    pub const fn with_compared_in(mut self, compared_in: &'static [Comparison]) -> Card {
        self.compared_in = compared_in;
        self
    }

    /// With its paper's bytes per node of the bare structure.
    pub const fn with_bare_node_bytes(mut self, bytes: u32) -> Card {
        self.bare_node_bytes = Some(bytes);
        self
    }

    /// Made for this score.
    pub const fn with_made_for(mut self, metric: Metric) -> Card {
        self.made_for = metric;
        self
    }

    /// Claiming exact answers (the findings check the claim).
    pub const fn with_exact(mut self) -> Card {
        self.exact = true;
        self
    }
}

impl Card {
    /// The family of `setting`'s results.
    pub fn family(&self, setting: &Setting) -> String {
        match self.family {
            Family::Name => self.name.to_owned(),
            Family::Named(name) => name.to_owned(),
            Family::Of(f) => f(setting).to_owned(),
        }
    }

    /// `Ok` when the method can run here; else why not.
    pub fn availability(&self) -> std::result::Result<(), String> {
        self.program.map_or(Ok(()), Program::availability)
    }

    /// The version of the program behind it, for run metadata; `None`: our own (the build's
    /// version says it).
    pub fn version(&self) -> Option<String> {
        self.program.and_then(Program::version)
    }

    /// True for a method loaded from a `method.toml` (an external program).
    pub fn is_external(&self) -> bool {
        self.program.is_some()
    }

    /// True for a level-of-detail method.
    pub fn is_lod(&self) -> bool {
        matches!(self.kind, Kind::Lod(_))
    }

    /// The parameter called `key`.
    pub fn param(&self, key: &str) -> Option<&'static Param> {
        self.params.iter().find(|p| p.key == key)
    }

    /// The setting a setting-less call runs, as a sweep names it: every parameter the default
    /// setting names ([`Param::named`]) at its default ([`ParamDefault::Per`] at the other
    /// parameter's default). A key it leaves out reads as its default too, so `visible`,
    /// `view`, the experiments and Python, given nothing, all run this.
    pub fn default_setting(&self) -> Setting {
        let mut out = Setting::default();
        for p in self.params.iter().filter(|p| p.named) {
            let value = match p.default {
                ParamDefault::Value(v) => Some(v),
                ParamDefault::Per { key, values } => self.param(key).and_then(|other| {
                    let ParamDefault::Value(at) = other.default else {
                        return None;
                    };
                    values.iter().find(|(when, _)| *when == at).map(|(_, v)| *v)
                }),
                ParamDefault::Rule(_) => None,
            };
            if let Some(v) = value {
                out.0.insert(p.key.to_owned(), Value::parse(v));
            }
        }
        out
    }

    /// A reading of `params` against the card's parameters.
    fn reader<'p>(&self, params: &'p Params) -> Reader<'p> {
        Reader::new(self.name, self.params, params)
    }

    /// A visibility method's setting read into its own typed struct (refusing keys it did not
    /// read), ready to prepare on a cloud, with the setting as it runs (every key read, given
    /// or default).
    pub fn setup(&self, params: &Params) -> Result<(Box<dyn Setup>, Setting)> {
        let Kind::Visibility(method) = self.kind else {
            return Err(Error::Unsupported(format!(
                "{} is a level-of-detail method: the lod experiment runs it",
                self.name
            )));
        };
        let mut reader = self.reader(params);
        let setup = method.parse(&mut reader)?;
        Ok((setup, reader.finish()?))
    }

    /// Types `params` as the method reads them, without any data: a bad value, or a key the
    /// method does not read, is the error it would be when the method runs; else the setting as
    /// it would run. Commands call it when they read their command line, before loading a
    /// cloud.
    pub fn check(&self, params: &Params) -> Result<Setting> {
        match self.kind {
            Kind::Visibility(_) => self.setup(params).map(|(_, setting)| setting),
            Kind::Lod(_) => self.lod_args(params).map(|(_, setting)| setting),
        }
    }

    /// A level-of-detail method's setting read into its own typed struct (refusing keys it did
    /// not read), with the setting as it runs.
    pub fn lod_args(&self, params: &Params) -> Result<(LodArgs, Setting)> {
        let Kind::Lod(method) = self.kind else {
            return Err(Error::Unsupported(format!(
                "{} is a visibility method, not a level-of-detail one",
                self.name
            )));
        };
        let mut reader = self.reader(params);
        let args = method.parse(&mut reader)?;
        Ok((args, reader.finish()?))
    }
}
