//! `registry`: the one place a method plugs in, and the one place a method is measured, for the
//! harness (`pointsight`) and the Python package alike, so both speak one parameter vocabulary.
//!
//! Every method is a [`Card`] ([`card`]): its name, typed parameters (default and help written
//! once), family, memory per point, peer pairing and what runs it, a visibility [`Method`]
//! (indices per view) or a level-of-detail [`LodMethod`] (splats per view and setting). The
//! catalogue ([`methods`]) holds the built-in cards, one adapter module each, and those
//! registered at run time (external programs' `method.toml` folders, a test's own). Each
//! method reads its setting once, into a struct of its own, before any work ([`params`]).
//! Every caller measures a method through [`kernel`], the one code path that reads, prepares,
//! times and runs one; `seconds` in every report is the time of `Prepared::visible_at` (or an
//! LOD selection) alone, measured by [`timing`]. Methods return indices or splats; callers
//! score them ([`scoring`]: ann-benchmarks' rule). The settings each method is measured at are
//! data ([`sweep`], `sweeps.toml`).
//!
//! This crate knows nothing of the command line, datasets, plots or reports: its input is a
//! cloud and, for the ground truth, a mesh ([`Input`]); its errors speak of parameters, values
//! and reasons ([`Error`]), which the command line and Python frame in their own words.
//!
//! Modules import downwards only: `error`, `setting`, `timing` and `scoring` at the bottom;
//! `params` (on `setting`); `visibility` and `lod` (on `params`); `sweep`; `card` (on those);
//! `kernel` (on `card`); `methods` (the adapters, on everything below) and `lod_file` (on the
//! `qsplat` and `spt` adapters); `set` (the command line's `[METHOD.]KEY=VALUE` pairs, on the
//! catalogue). Nothing imports this root.

pub mod card;
pub mod error;
pub mod kernel;
pub mod lod;
pub mod lod_file;
pub mod methods;
pub mod params;
pub mod scoring;
pub mod set;
pub mod setting;
pub mod sweep;
pub mod timing;
pub mod visibility;

pub use card::{Card, Comparison, Family, Kind, Memory, Metric, PeerKey, Program};
pub use error::{Error, Result};
pub use lod::LodMethod;
pub use methods::external::end_programs_of;
pub use methods::{BUILT_IN, Catalogue, EndPrograms, builtin_card};
pub use params::{Param, ParamDefault, Params, Reader};
pub use set::{Assignment, Assignments};
pub use setting::{Setting, Value};
pub use sweep::{MethodSweep, Sweeps};
pub use visibility::{Input, Method, Output, PixelChoice, Prepared, Setup};
