//! A scale cell in a process of its own: the parent's side ([`run_cell`]: the current
//! executable re-run as `scale-cell`, two time caps, the child's lines read as it writes them)
//! and the child's ([`CellArgs`], its flags, parsed by clap for `pointsight` and for a program
//! that embeds the registry alike; [`cell_entry`]; [`run_in_this_process`]; the [`Prepared`]
//! line that restarts the parent's clock).

use std::io::Read as _;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode, Stdio};
use std::time::{Duration, Instant};

use anyhow::Result;
use clap::Parser as _;
use registry::Setting;
use serde::{Deserialize, Serialize};

use super::cell::{cell, ooc_dir};
use super::plan::PREPARE_CAP_FACTOR;
use super::row::{CellOutput, Row};
use crate::run::{Run, absolute};

/// The subcommand a cell process runs under (hidden from `pointsight --help`).
pub const SUBCOMMAND: &str = "scale-cell";

/// The flags of a cell process: one cell of the `scale` experiment, which prints one JSON line
/// with the seconds and the process's peak RSS.
#[derive(Debug, Clone, PartialEq, clap::Args)]
pub struct CellArgs {
    /// The dataset whose mesh is sampled.
    #[arg(long)]
    pub dataset: String,
    /// The cell's method.
    #[arg(long)]
    pub method: String,
    /// Points.
    #[arg(long)]
    pub n: u64,
    /// The method's setting (a `registry::Setting` label; empty: its defaults).
    #[arg(long, default_value = "")]
    pub setting: String,
    /// The parent's run (`crate::run::Run::write_for_child`: its manifest and methods
    /// folders), read instead of this process's own flags and variables.
    #[arg(long)]
    pub run: Option<PathBuf>,
}

impl CellArgs {
    /// The flags that parse back to `self` (after [`SUBCOMMAND`]).
    pub fn to_args(&self) -> Vec<String> {
        vec![
            "--dataset".into(),
            self.dataset.clone(),
            "--method".into(),
            self.method.clone(),
            "--n".into(),
            self.n.to_string(),
            "--setting".into(),
            self.setting.clone(),
        ]
        .into_iter()
        .chain(
            self.run
                .iter()
                .flat_map(|p| ["--run".into(), p.display().to_string()]),
        )
        .collect()
    }
}

/// A cell's command line in a program that embeds the registry: [`CellArgs`] and the data
/// folder.
#[derive(Debug, clap::Parser)]
#[command(name = SUBCOMMAND)]
struct EntryLine {
    #[command(flatten)]
    cell: CellArgs,
    /// Folder of fetched data (default: the one the program gives [`cell_entry`]).
    #[arg(long)]
    data_dir: Option<PathBuf>,
}

/// Runs the cell `args` asks for in this process: [`cell`], the [`Prepared`] line when its
/// input is ready, then its [`CellOutput`] as one JSON line on standard output.
pub fn run_in_this_process(run: &Run, args: &CellArgs, data_dir: &Path) -> Result<()> {
    let setting = Setting::parse(&args.setting);
    let out = cell(
        run,
        &args.dataset,
        &args.method,
        &setting,
        args.n,
        data_dir,
        print_prepared,
    )?;
    println!("{}", serde_json::to_string(&out)?);
    Ok(())
}

/// The entry point of a cell process: when `args` (the process's arguments, program name
/// first) ask for a scale cell, runs it ([`run_in_this_process`]) and returns the exit code;
/// else `None`. `pointsight` reaches it through its own command line; a program that embeds
/// the registry, adds its own methods to its run and runs the scale experiment (whose cells
/// re-run the current executable) calls it first thing in `main` with that run (`run`), to
/// which the parent's run file adds the parent's manifest and methods folders.
pub fn cell_entry(args: &[String], data_dir: &Path, run: Run) -> Option<ExitCode> {
    let rest = args.get(1..)?;
    if rest.first().map(String::as_str) != Some(SUBCOMMAND) {
        return None;
    }
    let go = || -> Result<()> {
        let line = EntryLine::try_parse_from(rest)?;
        let run = match &line.cell.run {
            Some(file) => Run::read_for_child_onto(file, run)?,
            None => run,
        };
        let data_dir = line.data_dir.as_deref().unwrap_or(data_dir);
        let _programs = run.catalogue.end_programs_on_drop();
        run_in_this_process(&run, &line.cell, data_dir)
    };
    Some(match go() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    })
}

/// The line a cell process prints when its input is ready (before the timed operation): the
/// time cap of [`run_cell`] covers what comes after it, and the line's seconds are the row's
/// `prepare_seconds`.
#[derive(Debug, Serialize, Deserialize)]
pub struct Prepared {
    /// Always true: tells this line from the final [`CellOutput`].
    pub prepared: bool,
    /// Seconds the preparation took.
    pub seconds: f64,
}

/// Prints the [`Prepared`] line on stdout and flushes it (the `on_prepared` of [`cell`] in a
/// cell process).
pub fn print_prepared(seconds: f64) {
    use std::io::Write as _;
    let line = serde_json::json!({ "prepared": true, "seconds": seconds });
    let mut out = std::io::stdout().lock();
    // A parent that stopped reading only loses the time cap's restart.
    let _ = writeln!(out, "{line}").and_then(|()| out.flush());
}

/// Runs a cell in a child process with two time caps: `cap` on the operation (from the
/// child's [`Prepared`] line on), `PREPARE_CAP_FACTOR` times it on the preparation before.
/// The child's stdout and stderr are read by threads as it writes, so a chatty child cannot
/// block on a full pipe.
pub fn run_cell(
    run_file: &Path,
    dataset: &str,
    method: &str,
    setting: &Setting,
    n: u64,
    data_dir: &Path,
    cap: Duration,
) -> Row {
    let row = run_child(run_file, dataset, method, setting, n, data_dir, cap);
    // An out-of-core cell's files, whether it finished, failed or was killed.
    let dir = ooc_dir(data_dir, method, n);
    if dir.exists() {
        let _ = std::fs::remove_dir_all(&dir);
    }
    row
}

fn run_child(
    run_file: &Path,
    dataset: &str,
    method: &str,
    setting: &Setting,
    n: u64,
    data_dir: &Path,
    cap: Duration,
) -> Row {
    let row = |seconds: f64, peak: u64, status: String, prepare_seconds: f64| Row {
        seconds,
        peak_rss_bytes: peak,
        prepare_seconds,
        ..Row::not_run(method, n, status)
    };
    let exe = match std::env::current_exe() {
        Ok(e) => e,
        Err(e) => return row(f64::NAN, 0, format!("error: {e}"), f64::NAN),
    };
    let args = CellArgs {
        dataset: dataset.to_owned(),
        method: method.to_owned(),
        n,
        setting: setting.label(),
        run: Some(absolute(run_file)),
    };
    let mut command = Command::new(exe);
    command
        .arg(SUBCOMMAND)
        .args(args.to_args())
        .arg("--data-dir")
        .arg(absolute(data_dir));
    let child = command
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn();
    let mut child = match child {
        Ok(c) => c,
        Err(e) => {
            return row(
                f64::NAN,
                0,
                format!("error: cannot start the cell: {e}"),
                f64::NAN,
            );
        }
    };
    // stdout line by line (the prepared line restarts the clock; the last other line is the
    // answer); of stderr the last 64 to 128 KiB.
    let (lines_tx, lines) = std::sync::mpsc::channel::<String>();
    let stdout = child.stdout.take().map(|s| {
        std::thread::spawn(move || {
            use std::io::BufRead as _;
            for line in std::io::BufReader::new(s).lines().map_while(Result::ok) {
                if lines_tx.send(line).is_err() {
                    break;
                }
            }
        })
    });
    let stderr = child.stderr.take().map(|mut s| {
        std::thread::spawn(move || {
            let mut tail: Vec<u8> = Vec::new();
            let mut buf = [0u8; 8192];
            while let Ok(k) = s.read(&mut buf) {
                if k == 0 {
                    break;
                }
                tail.extend_from_slice(&buf[..k]);
                if tail.len() > 1 << 17 {
                    tail.drain(..tail.len() - (1 << 16));
                }
            }
            String::from_utf8_lossy(&tail).into_owned()
        })
    });
    let mut start = Instant::now();
    let mut prepare_seconds = f64::NAN;
    let mut last: Option<String> = None;
    let take_lines = |last: &mut Option<String>, prepare_seconds: &mut f64, start: &mut Instant| {
        for line in lines.try_iter() {
            match serde_json::from_str::<Prepared>(&line) {
                Ok(p) if p.prepared && prepare_seconds.is_nan() => {
                    *prepare_seconds = p.seconds;
                    *start = Instant::now();
                }
                _ => *last = Some(line),
            }
        }
    };
    loop {
        take_lines(&mut last, &mut prepare_seconds, &mut start);
        match child.try_wait() {
            Ok(Some(status)) => {
                if let Some(t) = stdout {
                    let _ = t.join();
                }
                take_lines(&mut last, &mut prepare_seconds, &mut start);
                let err = stderr.and_then(|t| t.join().ok()).unwrap_or_default();
                if !status.success() {
                    let last = err
                        .lines()
                        .rev()
                        .map(|l| l.trim().trim_start_matches("error: "))
                        .find(|l| !l.is_empty())
                        .map(str::to_owned)
                        // Killed (a signal, the kernel's OOM killer) or silent: say how it ended.
                        .unwrap_or_else(|| {
                            format!("the cell's process {status} and wrote no error")
                        });
                    let refused = last.contains("refused before allocating");
                    return row(
                        f64::NAN,
                        0,
                        format!("{}: {last}", if refused { "refused" } else { "error" }),
                        prepare_seconds,
                    );
                }
                return match last.as_deref().map(serde_json::from_str::<CellOutput>) {
                    Some(Ok(o)) => Row {
                        detail: o.detail,
                        angle_median_deg: o.accuracy.angle_median_deg,
                        angle_p95_deg: o.accuracy.angle_p95_deg,
                        sign_agreement: o.accuracy.sign_agreement,
                        build_seconds: o.build_seconds,
                        ..row(o.seconds, o.peak_rss_bytes, "ok".into(), o.prepare_seconds)
                    },
                    _ => row(
                        f64::NAN,
                        0,
                        format!(
                            "error: unreadable cell output {:?}",
                            last.unwrap_or_default()
                        ),
                        prepare_seconds,
                    ),
                };
            }
            Ok(None) => {
                let preparing = prepare_seconds.is_nan();
                let limit = if preparing {
                    cap * PREPARE_CAP_FACTOR
                } else {
                    cap
                };
                if start.elapsed() > limit {
                    let _ = child.kill();
                    let _ = child.wait();
                    // What its external programs left (their groups and folders): a killed
                    // cell ran no cleanup of its own.
                    registry::end_programs_of(child.id());
                    cloud::scratch::remove_stale_programs();
                    let status = if preparing {
                        format!(
                            "timeout: preparing the input took over {} s",
                            limit.as_secs()
                        )
                    } else {
                        format!("timeout after {} s", cap.as_secs())
                    };
                    return row(f64::NAN, 0, status, prepare_seconds);
                }
                std::thread::sleep(Duration::from_millis(20));
            }
            Err(e) => return row(f64::NAN, 0, format!("error: {e}"), prepare_seconds),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cells_flags_parse_back_and_bad_ones_are_refused() {
        let args = CellArgs {
            dataset: "dragon-871414".into(),
            method: "hpr".into(),
            n: 10_000,
            setting: "gamma=4".into(),
            run: Some(PathBuf::from("/tmp/run.json")),
        };
        let line = [SUBCOMMAND.to_owned()]
            .into_iter()
            .chain(args.to_args())
            .chain(["--data-dir".to_owned(), "/data".to_owned()]);
        let parsed = EntryLine::try_parse_from(line).unwrap();
        assert_eq!(parsed.cell, args);
        assert_eq!(parsed.data_dir.as_deref(), Some(Path::new("/data")));
        let e = EntryLine::try_parse_from([SUBCOMMAND, "--dataset", "d", "--n", "10"]).unwrap_err();
        assert!(e.to_string().contains("--method"), "{e}");
        let e = EntryLine::try_parse_from([
            SUBCOMMAND,
            "--dataset",
            "d",
            "--method",
            "m",
            "--n",
            "ten",
        ])
        .unwrap_err();
        assert!(e.to_string().contains("ten"), "{e}");
        // Not a cell: the program goes on.
        assert!(
            cell_entry(
                &["prog".into(), "other".into()],
                Path::new("/"),
                Run::builtin()
            )
            .is_none()
        );
    }
}
