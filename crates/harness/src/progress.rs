//! Progress on standard error: the experiments' own bars (indicatif, [`bar`]) and, for a run of
//! several experiments (`bench`), one line above them ([`Run`]): experiment k of n, the current
//! dataset and method ([`at`]), the time elapsed and an estimate of the time left.
//!
//! Nothing is drawn or written (bars, the run's line, [`note`]s) when standard error is not a
//! terminal or with `--quiet` ([`set_quiet`]): a script that reads standard error sees only
//! warnings ([`warn_once`]) and errors. Standard output is never touched here.
//!
//! The time left: when the previous run left metadata for every experiment still to come (its
//! `seconds`, same mode and datasets), the sum of those, with the current experiment's share
//! being what its previous run took beyond the time spent on it so far (or, once that is past,
//! its own fraction's estimate below); otherwise the elapsed fraction of the cells: the run's
//! fraction done is (experiments done + the current one's fraction) / n, the current one's
//! fraction being (datasets done + the current bar's position / length) / its datasets, and the
//! time left is the elapsed time × (1 − fraction) / fraction.

use std::io::IsTerminal as _;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};

static QUIET: AtomicBool = AtomicBool::new(false);

/// Silences every bar and note of this process (`--quiet`).
pub fn set_quiet(quiet: bool) {
    QUIET.store(quiet, Ordering::Relaxed);
}

/// True when progress is drawn: standard error is a terminal and `--quiet` was not given.
pub fn enabled() -> bool {
    !QUIET.load(Ordering::Relaxed) && std::io::stderr().is_terminal()
}

/// The run in progress: its bars (the [`MultiProgress`] every new bar joins) and its state.
struct Active {
    multi: MultiProgress,
    state: Arc<Mutex<State>>,
}

static ACTIVE: Mutex<Option<Active>> = Mutex::new(None);

/// What the run's line is computed from.
#[derive(Debug, Clone)]
struct State {
    /// Experiment names, in run order.
    names: Vec<String>,
    /// Seconds each took in the previous run (its metadata), when known.
    previous: Vec<Option<f64>>,
    /// The current experiment (0-based), its datasets, and when it started.
    current: usize,
    datasets: Vec<String>,
    started: Instant,
    experiment_started: Instant,
    dataset: String,
    method: String,
    /// The current experiment's newest bar.
    bar: Option<ProgressBar>,
}

impl State {
    /// The current experiment's fraction done, from its datasets and its newest bar.
    fn experiment_fraction(&self) -> f64 {
        let n = self.datasets.len().max(1) as f64;
        let done = self
            .datasets
            .iter()
            .position(|d| *d == self.dataset)
            .unwrap_or(0) as f64;
        let in_bar = self.bar.as_ref().map_or(0.0, |b| {
            let len = b.length().unwrap_or(0);
            if len == 0 {
                0.0
            } else {
                (b.position() as f64 / len as f64).min(1.0)
            }
        });
        ((done + in_bar) / n).min(1.0)
    }

    /// Seconds left, or `None` before anything can be said.
    fn seconds_left(&self) -> Option<f64> {
        let k = self.current;
        let fraction = self.experiment_fraction();
        let spent = self.experiment_started.elapsed().as_secs_f64();
        let from_fraction = |spent: f64, f: f64| (f > 0.0).then(|| spent * (1.0 - f) / f);
        if self.previous[k..].iter().all(Option::is_some) {
            let before: f64 = self.previous[k + 1..].iter().flatten().sum();
            let current = self.previous[k].unwrap_or(0.0);
            let left_here = if spent < current {
                current - spent
            } else {
                from_fraction(spent, fraction).unwrap_or(0.0)
            };
            return Some(left_here + before);
        }
        let n = self.names.len().max(1) as f64;
        let run_fraction = (k as f64 + fraction) / n;
        from_fraction(self.started.elapsed().as_secs_f64(), run_fraction)
    }

    /// The run's line: where it is and the time left first (a narrow terminal cuts the end).
    fn line(&self) -> String {
        let mut out = format!(
            "experiment {} of {}: {} · time left {} (elapsed {})",
            self.current + 1,
            self.names.len(),
            self.names.get(self.current).map_or("", String::as_str),
            self.seconds_left()
                .map_or("estimating".to_owned(), |s| format!("~{}", duration(s))),
            duration(self.started.elapsed().as_secs_f64()),
        );
        for part in [&self.dataset, &self.method] {
            if !part.is_empty() {
                out.push_str(" · ");
                out.push_str(part);
            }
        }
        out
    }
}

/// `1h 02m`, `3m 05s`, `42s`.
pub fn duration(seconds: f64) -> String {
    let s = seconds.max(0.0).round() as u64;
    match (s / 3600, (s / 60) % 60, s % 60) {
        (0, 0, s) => format!("{s}s"),
        (0, m, s) => format!("{m}m {s:02}s"),
        (h, m, _) => format!("{h}h {m:02}m"),
    }
}

/// A bar of `len` steps with a message (hidden when progress is not drawn); during a [`Run`],
/// below the run's line.
pub fn bar(len: u64, message: impl Into<String>) -> ProgressBar {
    if !enabled() {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(len);
    bar.set_style(
        ProgressStyle::with_template(
            "{msg:<28} [{elapsed_precise}] {wide_bar} {pos}/{len} (eta {eta})",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar.set_message(message.into());
    let active = ACTIVE.lock().ok();
    if let Some(Some(a)) = active.as_deref() {
        let bar = a.multi.add(bar);
        if let Ok(mut s) = a.state.lock() {
            s.bar = Some(bar.clone());
        }
        return bar;
    }
    bar
}

/// Says where the run is: the current dataset and method (shown on the run's line; nothing
/// outside a [`Run`] or when progress is not drawn).
pub fn at(dataset: &str, method: &str) {
    if let Ok(active) = ACTIVE.lock()
        && let Some(a) = active.as_ref()
        && let Ok(mut s) = a.state.lock()
    {
        dataset.clone_into(&mut s.dataset);
        method.clone_into(&mut s.method);
    }
}

/// A line of progress on standard error (above the bars during a [`Run`]); nothing when
/// progress is not drawn.
pub fn note(line: impl AsRef<str>) {
    if !enabled() {
        return;
    }
    let multi = ACTIVE
        .lock()
        .ok()
        .and_then(|a| a.as_ref().map(|a| a.multi.clone()));
    match multi {
        Some(m) => {
            let _ = m.println(line.as_ref());
        }
        None => eprintln!("{}", line.as_ref()),
    }
}

/// A warning on standard error, once per process however often it is raised (a dataset
/// loaded by several experiments warns once); shown with `--quiet` too, above the bars when
/// they are drawn.
pub fn warn_once(line: impl AsRef<str>) {
    static SAID: Mutex<Vec<String>> = Mutex::new(Vec::new());
    let line = line.as_ref();
    if let Ok(mut said) = SAID.lock() {
        if said.iter().any(|s| s == line) {
            return;
        }
        said.push(line.to_owned());
    }
    let multi = ACTIVE
        .lock()
        .ok()
        .and_then(|a| a.as_ref().map(|a| a.multi.clone()));
    match multi.filter(|_| enabled()) {
        Some(m) => {
            let _ = m.println(line);
        }
        None => eprintln!("{line}"),
    }
}

/// The progress of a run of several experiments: its line above the experiments' bars,
/// redrawn twice a second until dropped.
pub struct Run {
    top: Option<(ProgressBar, Arc<Mutex<State>>)>,
    stop: Arc<AtomicBool>,
    ticker: Option<std::thread::JoinHandle<()>>,
}

impl Run {
    /// Starts the run of `experiments` (name, and the seconds its previous run took when
    /// known), or nothing when progress is not drawn.
    pub fn start(experiments: Vec<(String, Option<f64>)>) -> Self {
        let stop = Arc::new(AtomicBool::new(false));
        if !enabled() || experiments.is_empty() {
            return Self {
                top: None,
                stop,
                ticker: None,
            };
        }
        let now = Instant::now();
        let (names, previous) = experiments.into_iter().unzip();
        let state = Arc::new(Mutex::new(State {
            names,
            previous,
            current: 0,
            datasets: Vec::new(),
            started: now,
            experiment_started: now,
            dataset: String::new(),
            method: String::new(),
            bar: None,
        }));
        let multi = MultiProgress::with_draw_target(ProgressDrawTarget::stderr());
        let top = multi.add(ProgressBar::new_spinner());
        top.set_style(
            ProgressStyle::with_template("{spinner} {wide_msg}")
                .unwrap_or_else(|_| ProgressStyle::default_spinner()),
        );
        if let Ok(mut a) = ACTIVE.lock() {
            *a = Some(Active {
                multi,
                state: state.clone(),
            });
        }
        let ticker = {
            let (top, state, stop) = (top.clone(), state.clone(), stop.clone());
            std::thread::spawn(move || {
                while !stop.load(Ordering::Relaxed) {
                    // The line is made with the state's lock held, then drawn without it.
                    let line = state.lock().map(|s| s.line()).ok();
                    if let Some(line) = line {
                        top.set_message(line);
                    }
                    top.tick();
                    std::thread::sleep(Duration::from_millis(500));
                }
            })
        };
        Self {
            top: Some((top, state)),
            stop,
            ticker: Some(ticker),
        }
    }

    /// Experiment `k` (0-based) starts, over `datasets`.
    pub fn experiment(&self, k: usize, datasets: &[String]) {
        if let Some((_, state)) = &self.top
            && let Ok(mut s) = state.lock()
        {
            s.current = k.min(s.names.len().saturating_sub(1));
            s.datasets = datasets.to_vec();
            s.experiment_started = Instant::now();
            s.dataset.clear();
            s.method.clear();
            s.bar = None;
        }
    }
}

impl Drop for Run {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.ticker.take() {
            let _ = t.join();
        }
        if let Some((top, _)) = &self.top {
            top.finish_and_clear();
        }
        if let Ok(mut a) = ACTIVE.lock() {
            *a = None;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn state(previous: Vec<Option<f64>>, current: usize) -> State {
        let now = Instant::now();
        State {
            names: (0..previous.len()).map(|k| format!("e{k}")).collect(),
            previous,
            current,
            datasets: vec!["a".into(), "b".into()],
            started: now - Duration::from_secs(100),
            experiment_started: now - Duration::from_secs(10),
            dataset: "b".into(),
            method: "hpr".into(),
            bar: None,
        }
    }

    #[test]
    fn the_time_left_comes_from_the_previous_run_when_it_covers_the_rest() {
        let s = state(vec![None, Some(30.0), Some(50.0)], 1);
        let left = s.seconds_left().unwrap();
        // 30 - 10 spent on the current one, then 50.
        assert!((left - 70.0).abs() < 0.5, "{left}");
        let line = s.line();
        assert!(
            line.starts_with("experiment 2 of 3: e1 · time left ~1m 1"),
            "{line}"
        );
        assert!(line.ends_with("(elapsed 1m 40s) · b · hpr"), "{line}");
    }

    #[test]
    fn else_from_the_elapsed_fraction_of_the_cells() {
        // Experiment 2 of 3, half its datasets done: a fraction of 1.5 / 3 after 100 s.
        let s = state(vec![Some(1.0), None, Some(5.0)], 1);
        let left = s.seconds_left().unwrap();
        assert!((left - 100.0).abs() < 0.5, "{left}");
        // Nothing done yet: nothing to say.
        let mut s = state(vec![None, None], 0);
        s.dataset = "a".into();
        assert_eq!(s.seconds_left(), None);
        assert!(
            s.line()
                .starts_with("experiment 1 of 2: e0 · time left estimating (elapsed"),
            "{}",
            s.line()
        );
    }

    #[test]
    fn durations_read_as_a_clock() {
        assert_eq!(duration(42.4), "42s");
        assert_eq!(duration(185.0), "3m 05s");
        assert_eq!(duration(3720.0), "1h 02m");
    }

    #[test]
    fn quiet_hides_bars() {
        set_quiet(true);
        assert!(!enabled());
        assert!(bar(3, "x").is_hidden());
        set_quiet(false);
    }
}
