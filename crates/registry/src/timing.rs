//! The one timing helper: every `seconds` pointsight reports comes from [`measure`].
//!
//! A call is run `repeats` times (at least once) with `std::time::Instant` around the call
//! alone; the result keeps the median and the spread (minimum, maximum, quartiles) and how many
//! samples there were, so a comparison can say how sure it is. Quartiles are the medians of
//! the lower and upper halves (Tukey's hinges); with one sample every statistic is that sample.
//!
//! [`measure_within`] also takes a time budget: no new run starts once the runs so far have
//! taken that many seconds (Google Benchmark's minimum-time rule turned into a maximum), so a
//! call of many seconds is timed fewer times than a call of milliseconds. The statistics say
//! how many samples there were; the first run is always made.

use std::time::Instant;

/// Timing statistics of repeated runs, seconds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Timing {
    /// Median.
    pub median: f64,
    /// Fastest run.
    pub min: f64,
    /// Slowest run.
    pub max: f64,
    /// Lower hinge.
    pub q1: f64,
    /// Upper hinge.
    pub q3: f64,
    /// Number of runs.
    pub samples: usize,
}

fn median_of(sorted: &[f64]) -> f64 {
    let n = sorted.len();
    if n == 0 {
        return f64::NAN;
    }
    if n % 2 == 1 {
        sorted[n / 2]
    } else {
        0.5 * (sorted[n / 2 - 1] + sorted[n / 2])
    }
}

impl Timing {
    /// The statistics of `samples` (seconds).
    pub fn of(samples: &[f64]) -> Self {
        let mut s = samples.to_vec();
        s.sort_by(f64::total_cmp);
        let n = s.len();
        let half = n / 2;
        let (lower, upper) = if n <= 1 {
            (&s[..], &s[..])
        } else {
            (&s[..half], &s[n - half..])
        };
        Self {
            median: median_of(&s),
            min: s.first().copied().unwrap_or(f64::NAN),
            max: s.last().copied().unwrap_or(f64::NAN),
            q1: median_of(lower),
            q3: median_of(upper),
            samples: n,
        }
    }
}

/// Runs `f` `repeats` times (at least once), timing each run; returns the last output and the
/// statistics. The first error ends the measurement.
pub fn measure<T, E>(repeats: usize, f: impl FnMut() -> Result<T, E>) -> Result<(T, Timing), E> {
    measure_within(repeats, None, f)
}

/// [`measure`], but no run after the first starts once the runs so far have taken `budget`
/// seconds (`None`: no budget, always `repeats` runs).
pub fn measure_within<T, E>(
    repeats: usize,
    budget: Option<f64>,
    mut f: impl FnMut() -> Result<T, E>,
) -> Result<(T, Timing), E> {
    measure_reported(repeats, budget, || {
        let start = Instant::now();
        let out = f()?;
        Ok((out, start.elapsed().as_secs_f64()))
    })
}

/// [`measure_within`] for a call that reports its own seconds (the part of its work being
/// measured, e.g. HPR's flip + hull + mapping without the caller's bookkeeping): `f` returns
/// its output and those seconds, and the budget counts them.
pub fn measure_reported<T, E>(
    repeats: usize,
    budget: Option<f64>,
    mut f: impl FnMut() -> Result<(T, f64), E>,
) -> Result<(T, Timing), E> {
    let repeats = repeats.max(1);
    let mut times = Vec::with_capacity(repeats);
    let mut last = None;
    let mut spent = 0.0;
    for _ in 0..repeats {
        if budget.is_some_and(|b| !times.is_empty() && spent >= b) {
            break;
        }
        let (out, t) = f()?;
        spent += t;
        times.push(t);
        last = Some(out);
    }
    match last {
        Some(out) => Ok((out, Timing::of(&times))),
        // `repeats >= 1`, so the loop ran.
        None => unreachable!("measure ran at least once"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reported_seconds_are_the_timing_and_count_against_the_budget() {
        let mut calls = 0;
        let (last, t) = measure_reported(3, Some(1.0), || {
            calls += 1;
            Ok::<_, ()>((calls, 0.6))
        })
        .unwrap();
        // 0.6 s after the first run, 1.2 s after the second: no third.
        assert_eq!((last, t.samples, t.median), (2, 2, 0.6));
        let (_, t) = measure_reported(3, None, || Ok::<_, ()>(((), 0.6))).unwrap();
        assert_eq!(t.samples, 3);
        assert_eq!(
            measure_reported(3, None, || Err::<((), f64), _>("no")),
            Err("no")
        );
    }

    #[test]
    fn statistics_of_known_samples() {
        let t = Timing::of(&[5.0, 1.0, 3.0, 2.0, 4.0]);
        assert_eq!((t.median, t.min, t.max, t.samples), (3.0, 1.0, 5.0, 5));
        assert_eq!((t.q1, t.q3), (1.5, 4.5));
        let t = Timing::of(&[2.0, 4.0]);
        assert_eq!((t.median, t.q1, t.q3), (3.0, 2.0, 4.0));
        let t = Timing::of(&[7.0]);
        assert_eq!(
            (t.median, t.min, t.max, t.q1, t.q3),
            (7.0, 7.0, 7.0, 7.0, 7.0)
        );
    }

    #[test]
    fn measure_runs_the_requested_times_and_stops_at_an_error() {
        let mut calls = 0;
        let (out, t) = measure(4, || {
            calls += 1;
            Ok::<_, ()>(calls)
        })
        .unwrap();
        assert_eq!((out, t.samples), (4, 4));
        let mut calls = 0;
        let err = measure(4, || {
            calls += 1;
            if calls == 2 { Err("boom") } else { Ok(calls) }
        });
        assert_eq!(err.unwrap_err(), "boom");
        assert_eq!(calls, 2);
        assert_eq!(measure(0, || Ok::<_, ()>(1)).unwrap().1.samples, 1);
    }

    #[test]
    fn a_budget_stops_new_runs_once_spent_but_never_the_first() {
        let sleep = || {
            std::thread::sleep(std::time::Duration::from_millis(20));
            Ok::<_, ()>(())
        };
        // Spent after two runs of >= 20 ms: the third does not start.
        let (_, t) = measure_within(10, Some(0.03), sleep).unwrap();
        assert_eq!(t.samples, 2);
        // A budget of zero still makes the first run.
        assert_eq!(measure_within(10, Some(0.0), sleep).unwrap().1.samples, 1);
        // No budget, or one never reached: every repeat.
        assert_eq!(measure_within(3, None, sleep).unwrap().1.samples, 3);
        assert_eq!(
            measure_within(3, Some(1e9), || Ok::<_, ()>(()))
                .unwrap()
                .1
                .samples,
            3
        );
    }
}
