//! Experiment `background`: seed 000 §5's front/back buffers, measured along a camera orbit.
//!
//! The camera starts at view 0 and orbits the bounding-box centre about the vertical axis at
//! the paper's speed, half a bounding-sphere radius per second, for [`DURATION`] seconds
//! (quick: half), in real time:
//! - `background`: frames at 60 per second; at each frame the main thread checks the flag
//!   (`DoubleBuffer::swap_if_ready`) and, whenever the worker is idle, posts the current eye;
//!   the frame shows the front buffer (`hpr::background`);
//! - `synchronous`: each frame computes HPR for the current eye and shows it when done, so the
//!   frame rate is the inverse of the HPR time.
//!
//! Per frame: the time it is shown, the time of the camera its visible set was computed for,
//! their difference (the age), and (every [`SCORE_EVERY`]-th background frame, every
//! synchronous frame) the F1 of the shown set against the reference for the camera *at the
//! time it is shown*. HPR: linear kernel, γ = 3, exact hull (`own`).

use std::path::Path;
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{Context as _, Result, anyhow};
use cloud::Camera;
use cloud::glam::{DMat3, DVec3};
use hpr::{HprParams, Kernel, Radius};
use serde::{Deserialize, Serialize};
use truth::{Reference, ReferenceParams};

use super::{Context, Experiment, markdown_table};
use crate::datasets::Dataset;
use crate::output::figure::{Axis, Draw, Figure, Panel, Point, Series};
use crate::output::{read_csv, write_atomic, write_csv};
use crate::progress;
use registry::scoring::Score;

/// Seconds of orbit (quick mode: half).
pub const DURATION: f64 = 6.0;
/// Frames per second.
pub const FPS: f64 = 60.0;
/// Background frames scored against the reference: one in this many.
pub const SCORE_EVERY: usize = 3;
/// Katz's γ of the HPR runs.
pub const GAMMA: f64 = 3.0;

/// The experiment.
pub struct BackgroundExperiment;

/// One displayed frame.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Frame {
    /// Dataset name.
    pub dataset: String,
    /// `background` or `synchronous`.
    pub mode: String,
    /// Frame number.
    pub frame: usize,
    /// When the frame is shown, seconds from the start.
    pub time_s: f64,
    /// When the camera of the shown visible set was taken (NaN before the first result).
    pub camera_time_s: f64,
    /// time_s − camera_time_s.
    pub age_s: f64,
    /// Visible points shown.
    pub n_visible: usize,
    /// F1 of the shown set against the reference at time_s (NaN when not scored).
    pub f1: f64,
}

/// The camera `t` seconds into the orbit.
fn orbit_camera(ds: &Dataset, t: f64) -> Result<Camera> {
    let start = ds.view(0)?;
    let bbox = match &ds.mesh {
        Some(m) => m.bbox(),
        None => ds.cloud.bbox(),
    };
    let radius = 0.5 * bbox.context("empty dataset")?.diagonal();
    let distance = (start.eye - start.target).length();
    // Linear speed radius / 2 per second along a circle of radius `distance`.
    let angle = 0.5 * radius / distance * t;
    let rot = DMat3::from_axis_angle(DVec3::Y, angle);
    let eye = start.target + rot * (start.eye - start.target);
    Ok(Camera::look_at(
        eye,
        start.target,
        start.up,
        *start.model(),
        start.width,
        start.height,
    )?)
}

impl Experiment for BackgroundExperiment {
    fn name(&self) -> &'static str {
        "background"
    }

    fn summary(&self) -> &'static str {
        "seed 000 §5: HPR in a background thread with front/back buffers, vs synchronous, along an orbit"
    }

    fn default_datasets(&self, quick: bool) -> &'static [&'static str] {
        if quick {
            &["bunny-69451"]
        } else {
            &["bunny-69451", "dragon-871414"]
        }
    }

    fn measure(&self, ctx: &Context) -> Result<serde_json::Value> {
        let duration = if ctx.quick { DURATION / 2.0 } else { DURATION };
        let params = HprParams {
            kernel: Kernel::Linear(Radius::Gamma(GAMMA)),
            ..HprParams::default()
        };
        let mut frames = Vec::new();
        for name in &ctx.datasets {
            progress::at(name, "hpr (background thread)");
            let ds = ctx.dataset(name)?;
            let points = Arc::new(ds.cloud.positions.clone());
            let mut shown: Vec<(String, usize, f64, f64, Vec<u32>)> = Vec::new();

            // Background: the worker computes for the latest camera; frames never wait.
            let mut worker =
                hpr::background::spawn(Arc::clone(&points), params, hull::by_name("own")?);
            let mut request_times = std::collections::HashMap::new();
            let start = Instant::now();
            let n_frames = (duration * FPS) as usize;
            for frame in 0..n_frames {
                let due = Duration::from_secs_f64(frame as f64 / FPS);
                if let Some(wait) = due.checked_sub(start.elapsed()) {
                    std::thread::sleep(wait);
                }
                let now = start.elapsed().as_secs_f64();
                worker.swap_if_ready().map_err(|e| anyhow!("{e}"))?;
                if !worker.is_busy() {
                    let seq = worker.request(orbit_camera(&ds, now)?.eye);
                    request_times.insert(seq, now);
                }
                let (camera_time, visible) = match worker.front() {
                    Some(f) => {
                        let v = f.result.as_ref().map_err(|e| anyhow!("{e}"))?;
                        (request_times[&f.sequence], v.visible.clone())
                    }
                    None => (f64::NAN, Vec::new()),
                };
                shown.push(("background".into(), frame, now, camera_time, visible));
            }
            drop(worker);

            // Synchronous: each frame waits for its own HPR.
            let hull = hull::by_name("own")?;
            let start = Instant::now();
            let mut frame = 0;
            while start.elapsed().as_secs_f64() < duration {
                let t = start.elapsed().as_secs_f64();
                let v = hpr::visible(&points, orbit_camera(&ds, t)?.eye, &params, hull.as_ref())?;
                // Keep at most 60 frames per second even when HPR is faster than a frame.
                let due = Duration::from_secs_f64(frame as f64 / FPS);
                if let Some(wait) = due.checked_sub(start.elapsed()) {
                    std::thread::sleep(wait);
                }
                shown.push((
                    "synchronous".into(),
                    frame,
                    start.elapsed().as_secs_f64(),
                    t,
                    v.visible,
                ));
                frame += 1;
            }

            // Score offline, against the reference for the camera at the time each frame shows
            // (a dataset without a mesh is not scored: F1 stays NaN).
            let reference = ds.mesh.as_ref().map(Reference::new).transpose()?;
            let to_score: Vec<usize> = (0..shown.len())
                .filter(|_| reference.is_some())
                .filter(|&k| shown[k].0 == "synchronous" || shown[k].1.is_multiple_of(SCORE_EVERY))
                .collect();
            let bar = progress::bar(to_score.len() as u64, format!("background {name} scoring"));
            let mut f1 = vec![f64::NAN; shown.len()];
            for (k, reference) in to_score.into_iter().zip(reference.iter().cycle()) {
                let cam = orbit_camera(&ds, shown[k].2)?;
                let truth = reference
                    .visibility(ds.truth_points(), &cam, &ReferenceParams::default())?
                    .visible;
                f1[k] = Score::of(&shown[k].4, &truth).f1();
                bar.inc(1);
            }
            bar.finish_and_clear();
            for (k, (mode, frame, time_s, camera_time_s, visible)) in shown.into_iter().enumerate()
            {
                frames.push(Frame {
                    dataset: name.clone(),
                    mode,
                    frame,
                    time_s,
                    camera_time_s,
                    age_s: time_s - camera_time_s,
                    n_visible: visible.len(),
                    f1: f1[k],
                });
            }
        }
        write_csv(&ctx.out_dir.join("results.csv"), &frames)?;
        Ok(serde_json::json!({
            "duration_s": duration,
            "fps": FPS,
            "camera_speed": "half the bounding-sphere radius per second, orbit about +y through view 0",
            "hpr": format!("linear kernel, gamma {GAMMA}, hull own"),
            "score_every_background_frame": SCORE_EVERY,
        }))
    }

    fn render(&self, _: &registry::Catalogue, dir: &Path) -> Result<()> {
        let frames: Vec<Frame> = read_csv(&dir.join("results.csv"))?;
        let datasets = crate::output::distinct(frames.iter().map(|f| f.dataset.as_str()));
        let mut f1_panels: Vec<Panel> = Vec::new();
        let mut age_panels: Vec<Panel> = Vec::new();
        let mut table = Vec::new();
        for d in &datasets {
            let (mut f1_series, mut age_series) = (Vec::new(), Vec::new());
            for mode in ["synchronous", "background"] {
                let fs: Vec<&Frame> = frames
                    .iter()
                    .filter(|f| f.dataset == *d && f.mode == *mode)
                    .collect();
                if fs.is_empty() {
                    continue;
                }
                // Frames before the first result show nothing; they are counted but not plotted.
                let shown: Vec<&&Frame> =
                    fs.iter().filter(|f| f.camera_time_s.is_finite()).collect();
                let first_result = shown.first().map_or(f64::NAN, |f| f.time_s);
                // HPR (linear kernel) in two modes: the mode is the variant.
                f1_series.push(Series::new(
                    "hpr",
                    "hpr-linear",
                    mode,
                    Draw::Line,
                    shown
                        .iter()
                        .filter(|f| f.f1.is_finite())
                        .map(|f| Point::new(f.time_s, f.f1))
                        .collect(),
                ));
                age_series.push(Series::new(
                    "hpr",
                    "hpr-linear",
                    mode,
                    Draw::Line,
                    fs.iter()
                        .filter(|f| f.age_s.is_finite())
                        .map(|f| Point::new(f.time_s, 1000.0 * f.age_s))
                        .collect(),
                ));
                let scored: Vec<f64> = shown
                    .iter()
                    .map(|f| f.f1)
                    .filter(|v| v.is_finite())
                    .collect();
                let ages: Vec<f64> = shown
                    .iter()
                    .map(|f| f.age_s)
                    .filter(|v| v.is_finite())
                    .collect();
                let duration = fs.last().map_or(0.0, |f| f.time_s).max(1e-9);
                let updates = shown
                    .windows(2)
                    .filter(|w| w[1].camera_time_s != w[0].camera_time_s)
                    .count()
                    + usize::from(!shown.is_empty());
                table.push(vec![
                    d.clone(),
                    mode.to_string(),
                    fs.len().to_string(),
                    format!("{:.1}", fs.len() as f64 / duration),
                    format!("{:.0}", 1000.0 * first_result),
                    format!("{:.1}", updates as f64 / duration),
                    format!(
                        "{:.0}",
                        1000.0 * ages.iter().sum::<f64>() / ages.len().max(1) as f64
                    ),
                    format!("{:.0}", 1000.0 * ages.iter().copied().fold(0.0, f64::max)),
                    format!(
                        "{:.4}",
                        scored.iter().sum::<f64>() / scored.len().max(1) as f64
                    ),
                    format!(
                        "{:.4}",
                        scored.iter().copied().fold(f64::INFINITY, f64::min)
                    ),
                ]);
            }
            f1_panels.push(Panel {
                title: d.clone(),
                series: f1_series,
            });
            age_panels.push(Panel {
                title: d.clone(),
                series: age_series,
            });
        }
        let f1 = Figure::new(
            "f1_time",
            "F1 of the displayed visible set along the orbit",
            Axis::linear("time (s)"),
            Axis::linear("F1 against the reference of the current camera"),
        )
        .panels(f1_panels)
        .write(dir)?;
        let age = Figure::new(
            "age_time",
            "Age of the displayed visible set",
            Axis::linear("time (s)"),
            Axis::linear("age (ms)"),
        )
        .panels(age_panels)
        .write(dir)?;
        let summary = format!(
            "Seed 000 §5 measured: HPR (γ = {GAMMA}, exact hull) in a worker thread with \
             front/back buffers against computing it synchronously every frame, while the camera \
             orbits at half a bounding-sphere radius per second (the paper's speed), 60 frames \
             per second, in real time on this machine. F1 is against the reference of the camera \
             at the moment the frame is shown. Ages and F1 count the frames from the first visible set \
             on (before it, the background version shows nothing).\n\n{}\n{f1}{age}Per-frame rows: \
             [results.csv](results.csv).\n",
            markdown_table(
                &[
                    "dataset",
                    "mode",
                    "frames",
                    "frames/s",
                    "first set shown at (ms)",
                    "visible-set updates/s",
                    "mean age (ms)",
                    "max age (ms)",
                    "mean F1",
                    "min F1"
                ],
                &table
            )
        );
        write_atomic(&dir.join("summary.md"), summary.as_bytes())
    }
}
