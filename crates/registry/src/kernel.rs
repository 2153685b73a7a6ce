//! The measurement kernel: the only code that prepares, times and runs a method.
//!
//! Every caller that measures a method goes through here: the `visible` command, the
//! `visibility`, `robustness`, `scale` and `lod` experiments, and the Python package. A
//! **cell** is one method at one setting on one cloud over a list of views (each named by its
//! index among the dataset's views, which an external program is told); it gives, per view,
//! the method's answer and its timing with the spread of the repeats, or the error that
//! stopped it. A failure is a value, not an abort: a cell whose preparation fails reports the
//! same error for each of its views, and a view that fails does not stop the others, so the
//! experiments can write an error row and go on.
//!
//! The visibility form ([`run`]): the cell's setting is read once into the method's own typed
//! struct (a key it did not read is refused there, before any work), the method is prepared
//! once per cell (per-cloud state: a k-d tree, a BVH; its wall time and an external program's
//! own build seconds are the cell's [`Preparation`], with the setting as it ran), then each view is
//! answered `repeats` times through [`crate::timing`], fewer once the cell's time budget (wall
//! seconds) is spent; the timing is an external program's own reported seconds when it gives
//! them. The level-of-detail form ([`run_lod`]): every setting is read first, then the method
//! builds once per cloud (timed on its own), then each setting's selector selects per view (the
//! part a renderer pays per frame, timed); the splats are made after the clock stops.
//!
//! Scoring is the caller's (methods return indices or splats; the harness scores them against
//! the ground truth), so is where the answers go (rows, files, arrays).

use cloud::Camera;
use splat::render::Splat;

use crate::card::{Card, Kind};
use crate::error::{Error, Result};
use crate::lod::{LodArgs, LodBuilt, LodInput, LodSize, Reads};
use crate::params::Params;
use crate::setting::Setting;
use crate::timing::{self, Timing};
use crate::visibility::{Input, Output, Prepared};

/// One view of a dataset: its index among the dataset's views and its camera.
#[derive(Debug, Clone, Copy)]
pub struct View {
    /// Index among the dataset's views (what an external program is told).
    pub index: usize,
    /// The camera.
    pub camera: Camera,
}

impl View {
    /// Every camera of `cameras`, each with its position as its index.
    pub fn all(cameras: &[Camera]) -> Vec<View> {
        cameras
            .iter()
            .enumerate()
            .map(|(index, &camera)| View { index, camera })
            .collect()
    }
}

/// A visibility cell: one method at one setting, over views.
pub struct Cell<'a> {
    /// The method (a visibility method's card).
    pub method: &'a Card,
    /// Its setting.
    pub params: Params,
    /// The views to answer, in order.
    pub views: &'a [View],
    /// Timed runs per view (at least one).
    pub repeats: usize,
    /// Seconds after which a view's runs stop repeating ([`timing::measure_within`]; `None`:
    /// always `repeats` runs).
    pub budget: Option<f64>,
    /// Answer the views in parallel, one per thread (the answers still reach the caller in the
    /// views' order).
    pub parallel: bool,
}

impl<'a> Cell<'a> {
    /// A cell of `method` at `setting` over `views`, `repeats` timed runs per view (no time
    /// budget), the views answered one after another.
    pub fn new(method: &'a Card, setting: &Setting, views: &'a [View], repeats: usize) -> Self {
        Self {
            method,
            params: setting.params(),
            views,
            repeats,
            budget: None,
            parallel: false,
        }
    }
}

/// A view's answer: the method's output and the timing of its repeats.
#[derive(Debug)]
pub struct Answer {
    /// The last run's output.
    pub output: Output,
    /// Median and spread of the runs: the method's own seconds when it reports them on every
    /// run (an external program), else the wall clock's.
    pub timing: Timing,
    /// Median and spread of the wall clock around each run, whatever the method reports
    /// (for an external program: the protocol and the transfer of answers too).
    pub wall: Timing,
}

/// A cell's preparation, timed once.
#[derive(Debug, Clone, PartialEq)]
pub struct Preparation {
    /// Wall seconds of reading the setting and preparing: a built-in method's per-cloud state
    /// (its k-d tree, estimated normals); for an external method, writing the points file it
    /// reads.
    pub seconds: f64,
    /// The structure's build alone ([`Prepared::reported_build_seconds`]: an external
    /// program's `built` line, its BVH or render window; the ray caster's point hierarchy), when the
    /// method accounts for it.
    pub reported_seconds: Option<f64>,
    /// The cold call of an external program the views started
    /// ([`Prepared::cold_call_seconds`]).
    pub cold_call_seconds: Option<f64>,
    /// The setting as it ran: every key the method read, with the value given or its default.
    pub setting: Setting,
}

/// Reads the cell's setting and prepares `cell.method` on `input`, then answers each
/// view: `each` gets every view of the cell, in order, with its answer or the error that
/// stopped it (a failed preparation's error, for every view). Returns the preparation's
/// timing (one run), or its error once every view has been told.
pub fn run<'a>(
    cell: &Cell<'_>,
    input: Input<'a>,
    mut each: impl FnMut(&View, std::result::Result<Answer, &Error>),
) -> Result<Preparation> {
    let mut fail = |e: Error| {
        for view in cell.views {
            each(view, Err(&e));
        }
        Err(e)
    };
    let start = std::time::Instant::now();
    let (setup, setting) = match cell.method.setup(&cell.params) {
        Ok(s) => s,
        Err(e) => return fail(e),
    };
    let prepared = setup.prepare(input);
    let prepare_seconds = start.elapsed().as_secs_f64();
    let prepared = match prepared {
        Ok(p) => p,
        Err(e) => return fail(e),
    };
    if cell.parallel {
        use rayon::prelude::*;
        let (views, prepared) = (cell.views, prepared.as_ref());
        let (repeats, budget) = (cell.repeats, cell.budget);
        let answers: Vec<Result<Answer>> = views
            .par_iter()
            .map(|v| timed(prepared, v, repeats, budget))
            .collect();
        for (view, answer) in cell.views.iter().zip(answers) {
            match answer {
                Ok(a) => each(view, Ok(a)),
                Err(e) => each(view, Err(&e)),
            }
        }
    } else {
        for view in cell.views {
            match timed(prepared.as_ref(), view, cell.repeats, cell.budget) {
                Ok(a) => each(view, Ok(a)),
                Err(e) => each(view, Err(&e)),
            }
        }
    }
    Ok(Preparation {
        seconds: prepare_seconds,
        reported_seconds: prepared.reported_build_seconds(),
        cold_call_seconds: prepared.cold_call_seconds(),
        setting,
    })
}

/// The kernel's one hook for methods that report their own compute seconds (an external
/// program, whose wall time includes starting it, the protocol and the transfer of points and
/// answers): when every run of a measurement reported its seconds, those are its timing;
/// otherwise the wall clock's. Used for visibility answers, LOD builds and LOD selections
/// alike, so no caller chooses between the two.
fn own_or_wall(reported: Vec<Option<f64>>, wall: Timing) -> Timing {
    let own: Option<Vec<f64>> = reported.into_iter().collect();
    match own {
        Some(own) if !own.is_empty() => Timing::of(&own),
        _ => wall,
    }
}

/// Answers one view `repeats` times (at least once; fewer once `budget` seconds are spent)
/// with the one timing helper: the last output and the timing ([`own_or_wall`]:
/// [`Output::reported_seconds`] when the method gives it on every run).
fn timed(
    prepared: &dyn Prepared,
    view: &View,
    repeats: usize,
    budget: Option<f64>,
) -> Result<Answer> {
    let mut reported = Vec::new();
    let (output, wall) = timing::measure_within(repeats, budget, || {
        let out = prepared.visible_at(view.index, &view.camera)?;
        reported.push(out.reported_seconds);
        Ok::<_, Error>(out)
    })?;
    Ok(Answer {
        output,
        timing: own_or_wall(reported, wall),
        wall,
    })
}

/// A level-of-detail cell: one method built once, selecting at each setting over views.
pub struct LodCell<'a> {
    /// The method (a level-of-detail method's card).
    pub method: &'a Card,
    /// The settings to select at, in order.
    pub settings: &'a [Setting],
    /// The views (cameras) to select for, in order.
    pub views: &'a [View],
    /// Timed runs per selection (at least one).
    pub repeats: usize,
    /// Timed builds (at least one; the last build is kept).
    pub build_repeats: usize,
}

/// A built structure's timing and size.
#[derive(Debug, Clone, Copy)]
pub struct Built {
    /// Median and spread of the builds.
    pub timing: Timing,
    /// Its size.
    pub size: LodSize,
}

/// One selection: the splats to draw and the timing of the selection alone.
#[derive(Debug)]
pub struct Selection {
    /// The splats (made after the clock stopped).
    pub splats: Vec<Splat>,
    /// Median and spread of the selections.
    pub timing: Timing,
    /// What the last selection read from storage (a structure selected from a file).
    pub reads: Option<Reads>,
}

/// Reads every setting of the cell (a bad one is refused for its views, later), builds
/// `cell.method` on `input` once (`build_repeats` timed builds), then, for each setting in order
/// and each view in order, selects: `each` gets (the setting's position in `cell.settings`, the
/// view's position in `cell.views`, the selection or the error that stopped it: a bad
/// setting's, for each of its views). Returns the build's timing and size, or its error (then
/// `each` is not called).
pub fn run_lod(
    cell: &LodCell<'_>,
    input: &LodInput<'_>,
    each: impl FnMut(usize, usize, std::result::Result<Selection, &Error>),
) -> Result<Built> {
    let args = read_settings(cell);
    let (built, timing) = build_lod(cell.method, input, cell.build_repeats)?;
    select(cell, &args, built.as_ref(), input, each);
    Ok(timing)
}

/// Each setting of `cell` read by its method.
fn read_settings(cell: &LodCell<'_>) -> Vec<Result<LodArgs>> {
    cell.settings
        .iter()
        .map(|s| cell.method.lod_args(&s.params()).map(|(args, _)| args))
        .collect()
}

/// The build half of [`run_lod`], for a caller that keeps the structure and selects later
/// (Python's `Lod`): `repeats` timed builds, the last one returned with the timing and size.
/// Builds and selections are timed as answers are: a program's own reported seconds
/// (`LodBuilt::reported_build_seconds`, `LodSelector::reported_seconds`) when it gives them,
/// else the wall clock.
pub fn build_lod(
    method: &Card,
    input: &LodInput<'_>,
    repeats: usize,
) -> Result<(Box<dyn LodBuilt>, Built)> {
    let Kind::Lod(lod) = method.kind else {
        return Err(Error::Unsupported(format!(
            "{} is a visibility method, not a level-of-detail one",
            method.name
        )));
    };
    let mut reported = Vec::new();
    let (built, wall) = timing::measure(repeats, || {
        let built = lod.build(input)?;
        reported.push(built.reported_build_seconds());
        Ok::<_, Error>(built)
    })?;
    let timing = own_or_wall(reported, wall);
    let size = built.size();
    Ok((built, Built { timing, size }))
}

/// The selection half of [`run_lod`] on a structure `built` from `input` by `cell.method`
/// (`cell.build_repeats` is not used).
pub fn select_lod(
    cell: &LodCell<'_>,
    built: &dyn LodBuilt,
    input: &LodInput<'_>,
    each: impl FnMut(usize, usize, std::result::Result<Selection, &Error>),
) {
    select(cell, &read_settings(cell), built, input, each);
}

/// Selects at each setting read (`args`, in the order of `cell.settings`) and each view.
fn select(
    cell: &LodCell<'_>,
    args: &[Result<LodArgs>],
    built: &dyn LodBuilt,
    input: &LodInput<'_>,
    mut each: impl FnMut(usize, usize, std::result::Result<Selection, &Error>),
) {
    for (k, args) in args.iter().enumerate() {
        let selector = match args {
            Ok(args) => built.selector(input, args),
            Err(e) => {
                for v in 0..cell.views.len() {
                    each(k, v, Err(e));
                }
                continue;
            }
        };
        let mut selector = match selector {
            Ok(s) => s,
            Err(e) => {
                for v in 0..cell.views.len() {
                    each(k, v, Err(&e));
                }
                continue;
            }
        };
        for (v, view) in cell.views.iter().enumerate() {
            let mut reported = Vec::new();
            let measured = timing::measure(cell.repeats, || {
                selector.select_at(view.index, &view.camera)?;
                reported.push(selector.reported_seconds());
                Ok::<_, Error>(())
            });
            match measured {
                Ok(((), wall)) => each(
                    k,
                    v,
                    Ok(Selection {
                        splats: selector.splats(),
                        timing: own_or_wall(reported, wall),
                        reads: selector.reads(),
                    }),
                ),
                Err(e) => each(k, v, Err(&e)),
            }
        }
    }
}

/// Each view of a cell with its answer or its error's message.
pub type Answers = Vec<(View, std::result::Result<Answer, String>)>;

/// [`run`], with the answers collected: each view with its answer or its error's message, and
/// the preparation's seconds or its error.
pub fn collect(cell: &Cell<'_>, input: Input<'_>) -> (Result<Preparation>, Answers) {
    let mut answers = Vec::with_capacity(cell.views.len());
    let prepared = run(cell, input, |view, answer| {
        answers.push((*view, answer.map_err(|e| e.to_string())));
    });
    (prepared, answers)
}

#[cfg(test)]
mod tests {
    use std::sync::atomic::{AtomicUsize, Ordering};

    use cloud::glam::DVec3;

    use super::*;
    use crate::card::Kind;
    use crate::visibility::{Method, Output, Prepared, Setup};
    use crate::{Memory, Reader};

    /// Counts its preparations and its answers.
    struct Counting {
        prepared: AtomicUsize,
        answered: AtomicUsize,
    }

    impl Method for Counting {
        fn parse(&self, _: &mut Reader<'_>) -> Result<Box<dyn Setup>> {
            let _ = self;
            Ok(Box::new(CountingSetup(&COUNTING)))
        }
    }

    struct CountingSetup(&'static Counting);

    impl Setup for CountingSetup {
        fn prepare<'a>(&'a self, _: Input<'a>) -> Result<Box<dyn Prepared + 'a>> {
            self.0.prepared.fetch_add(1, Ordering::SeqCst);
            Ok(Box::new(CountingPrepared(self.0)))
        }
    }

    struct CountingPrepared(&'static Counting);

    impl Prepared for CountingPrepared {
        fn visible(&self, _: &Camera) -> Result<Output> {
            self.0.answered.fetch_add(1, Ordering::SeqCst);
            Ok(Output::default())
        }
        fn reported_build_seconds(&self) -> Option<f64> {
            Some(0.25)
        }
    }

    static COUNTING: Counting = Counting {
        prepared: AtomicUsize::new(0),
        answered: AtomicUsize::new(0),
    };

    #[test]
    fn a_cell_prepares_once_for_all_its_views_and_reports_the_build_apart() {
        static CARD: Card = Card::new(
            "kernel-test-counting",
            "test",
            Kind::Visibility(&COUNTING),
            &[],
            Memory::Unknown,
        );
        let cloud =
            cloud::PointCloud::from_positions(vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z])
                .unwrap();
        let bbox = cloud.bbox().unwrap();
        let views: Vec<View> = cloud::views::fibonacci_views(&bbox, &Default::default())
            .unwrap()
            .into_iter()
            .take(5)
            .enumerate()
            .map(|(index, camera)| View { index, camera })
            .collect();
        assert_eq!(views.len(), 5);
        let input = Input {
            cloud: &cloud,
            mesh: None,
        };
        for parallel in [false, true] {
            let before = COUNTING.prepared.load(Ordering::SeqCst);
            let answered = COUNTING.answered.load(Ordering::SeqCst);
            let mut cell = Cell::new(&CARD, &Setting::default(), &views, 3);
            cell.parallel = parallel;
            let (prepared, answers) = collect(&cell, input);
            let prepared = prepared.unwrap();
            assert_eq!(COUNTING.prepared.load(Ordering::SeqCst), before + 1);
            assert_eq!(COUNTING.answered.load(Ordering::SeqCst), answered + 15);
            assert_eq!(answers.len(), 5);
            assert!(answers.iter().all(|(_, a)| a.is_ok()));
            assert_eq!(prepared.reported_seconds, Some(0.25));
            assert!(prepared.seconds >= 0.0);
        }
    }
}
