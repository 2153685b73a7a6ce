//! `copc-lod`: copc_converter's COPC octree as a pointsight LOD method (methods/README.md,
//! protocol 3 or 2, the LOD form).
//!
//! Started once per cloud with `--points FILE --protocol 3 [--normals W] [--spacing S] --lod
//! --radius R` (protocol 2: `--params JSON` too, ignored: each request carries its setting
//! either way), one process serving every setting, it
//! 1. reads the points (`ply`) and writes them as an uncompressed LAS 1.4 file with each
//!    point's original index as the Extra Bytes attribute `index` (`input`);
//! 2. runs copc_converter on it (the binary beside this one, else on PATH) with `--threads T`
//!    (`--threads`, default `RAYON_NUM_THREADS`, else every core: what pointsight's own
//!    builds use) and `--memory-limit M` (`--memory-limit`, default `1Gi`, the limit of
//!    pointsight's out-of-core builds in the scale experiment), and reports the converter's
//!    wall time as its build seconds, the COPC file's nodes and bytes as its size (writing the
//!    LAS before it and checking the file after it are said on standard error);
//! 3. opens the COPC file (`copc`) and checks that every original index comes back exactly
//!    once;
//! 4. per view and setting, reads `{"id": N, "view", "camera", "params": {"spacing_px": T}}`,
//!    selects the octree's nodes for the view (`select`), reads and decodes their chunks from
//!    the file, and answers `{"id": N, "visible": [...], "radius": [...], "seconds": T,
//!    "bytes_read": B}`: the indices of the selected nodes' points, each point's splat radius,
//!    its own seconds for the view (traversal, reads, decoding, radii) and the bytes of the
//!    chunks it read. A request it cannot answer gets `{"id": N, "error": "..."}`. The id
//!    (protocol 3) is echoed as sent, first; a request without one (protocol 2) gets an answer
//!    without one.
//!
//! `--copc FILE` opens an existing COPC file of the same cloud instead of building one (its
//! build seconds are then 0); `--save-copc FILE` keeps a copy of the one built. The scratch
//! folder (the LAS, the converter's temporary files, the COPC file) is removed at the end of
//! input.

mod copc;
mod error;
mod input;
mod ply;
mod select;

use std::fmt::Write as _;
use std::io::{BufRead, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode, Stdio};
use std::time::Instant;

use error::{Error, Result, io};

/// The command line.
#[derive(Debug, Default)]
struct Args {
    points: Option<PathBuf>,
    lod: bool,
    radius: Option<f64>,
    spacing: Option<f64>,
    copc: Option<PathBuf>,
    save_copc: Option<PathBuf>,
    memory_limit: String,
    threads: Option<usize>,
    version: bool,
}

fn parse_args() -> Result<Args> {
    let mut a = Args {
        memory_limit: "1Gi".into(),
        ..Default::default()
    };
    let mut it = std::env::args().skip(1);
    let number = |k: &str, v: Option<String>| -> Result<f64> {
        v.as_deref()
            .and_then(|v| v.parse::<f64>().ok())
            .filter(|v| v.is_finite() && *v >= 0.0)
            .ok_or_else(|| Error::Usage(format!("{k} takes a number >= 0, got {v:?}")))
    };
    while let Some(k) = it.next() {
        match k.as_str() {
            "--points" => a.points = it.next().map(PathBuf::from),
            "--params" | "--normals" => {
                it.next();
            }
            "--protocol" => {
                let v = it.next().unwrap_or_default();
                if v != "2" && v != "3" {
                    return Err(Error::Usage(format!(
                        "--protocol {v:?}: copc-lod speaks protocol 2 or 3 (the LOD form)"
                    )));
                }
            }
            "--spacing" => a.spacing = Some(number(&k, it.next())?),
            "--radius" => a.radius = Some(number(&k, it.next())?),
            "--lod" => a.lod = true,
            "--copc" => a.copc = it.next().map(PathBuf::from),
            "--save-copc" => a.save_copc = it.next().map(PathBuf::from),
            "--memory-limit" => {
                a.memory_limit = it
                    .next()
                    .ok_or_else(|| Error::Usage("--memory-limit takes a size".into()))?;
            }
            "--threads" => {
                a.threads = Some(
                    it.next()
                        .and_then(|v| v.parse().ok())
                        .filter(|&t| t > 0)
                        .ok_or_else(|| Error::Usage("--threads takes a count > 0".into()))?,
                );
            }
            "--version" => a.version = true,
            other => return Err(Error::Usage(format!("unknown argument {other:?}"))),
        }
    }
    Ok(a)
}

/// A scratch folder, removed on drop.
struct Scratch(PathBuf);

impl Scratch {
    fn new() -> Result<Scratch> {
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.subsec_nanos());
        let dir = std::env::temp_dir().join(format!("copc-lod-{}-{nanos}", std::process::id()));
        std::fs::create_dir_all(&dir).map_err(io(&dir))?;
        Ok(Scratch(dir))
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// copc_converter: beside this program (both go to the tool folder), else on PATH.
fn converter() -> PathBuf {
    std::env::current_exe()
        .ok()
        .and_then(|e| e.parent().map(|d| d.join("copc_converter")))
        .filter(|p| p.is_file())
        .unwrap_or_else(|| PathBuf::from("copc_converter"))
}

/// The threads pointsight's own builds use: `RAYON_NUM_THREADS`, else every core.
fn default_threads() -> usize {
    std::env::var("RAYON_NUM_THREADS")
        .ok()
        .and_then(|v| v.parse().ok())
        .filter(|&t: &usize| t > 0)
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
}

/// Runs copc_converter on `las` into `out`; returns its wall seconds.
fn convert(las: &Path, out: &Path, tmp: &Path, args: &Args) -> Result<f64> {
    let threads = args.threads.unwrap_or_else(default_threads);
    let program = converter();
    let start = Instant::now();
    let status = Command::new(&program)
        .arg(las)
        .arg(out)
        .args(["--memory-limit", &args.memory_limit])
        .args(["--threads", &threads.to_string()])
        .arg("--temp-dir")
        .arg(tmp)
        .args(["--progress", "plain"])
        .stdin(Stdio::null())
        .stdout(Stdio::from(std::io::stderr()))
        .status()
        .map_err(|e| Error::Converter(format!("cannot start {}: {e}", program.display())))?;
    let seconds = start.elapsed().as_secs_f64();
    if !status.success() {
        return Err(Error::Converter(format!(
            "{} exited with {status} (its output is in this program's standard error)",
            program.display()
        )));
    }
    Ok(seconds)
}

/// One JSON line on standard output, flushed.
fn say(line: &str) -> Result<()> {
    let mut out = std::io::stdout().lock();
    out.write_all(line.as_bytes())
        .and_then(|()| out.write_all(b"\n"))
        .and_then(|()| out.flush())
        .map_err(|e| Error::Usage(format!("standard output: {e}")))
}

fn error_line(e: &Error) -> String {
    serde_json::json!({ "error": e.to_string() }).to_string()
}

/// `answer` (a JSON object's text) with the request's `id` as its first member, when the
/// request had one.
fn with_id(id: Option<&serde_json::Value>, answer: String) -> String {
    match (id, answer.strip_prefix('{')) {
        (Some(id), Some(rest)) => {
            let sep = if rest.trim_start().starts_with('}') {
                ""
            } else {
                ","
            };
            format!("{{\"id\":{id}{sep}{rest}")
        }
        _ => answer,
    }
}

/// The threshold of a request's `params` (`spacing_px`, pixels, default 1).
fn threshold(params: Option<&serde_json::Value>) -> Result<f64> {
    let v = params.and_then(|p| p.get("spacing_px"));
    let text = match v {
        None => return Ok(1.0),
        Some(serde_json::Value::String(s)) => s.clone(),
        Some(other) => other.to_string(),
    };
    text.parse::<f64>()
        .ok()
        .filter(|t| t.is_finite() && *t >= 0.0)
        .ok_or_else(|| Error::Usage(format!("spacing_px={text}: expected pixels >= 0")))
}

/// One view's answer line.
fn answer(file: &copc::Copc, request: &serde_json::Value, radii: &select::Radii) -> Result<String> {
    let camera = request
        .get("camera")
        .ok_or_else(|| Error::Usage("request has no camera".into()))?;
    let view = select::View::from_json(camera)?;
    let t = threshold(request.get("params"))?;
    let start = Instant::now();
    let (mut nodes, selected) = select::select_nodes(file, &view, t);
    // Chunks in file order: one forward pass over the file.
    nodes.sort_by_key(|&k| file.nodes[k].offset);
    let mut seen = vec![false; file.n_points as usize];
    let mut visible = String::with_capacity(16);
    let mut radius = String::with_capacity(16);
    let mut bytes_read = 0;
    let mut count = 0usize;
    let mut last_radius = (f64::NAN, String::new());
    for &k in &nodes {
        let (pts, bytes) = file.read_node(k, true)?;
        bytes_read += bytes;
        for (&i, &p) in pts.indices.iter().zip(&pts.positions) {
            if std::mem::replace(&mut seen[i as usize], true) {
                return Err(error::copc(
                    &file.path,
                    format!("index {i} comes back twice"),
                ));
            }
            let r = select::radius_of(file, &selected, k, p, radii);
            if r != last_radius.0 {
                // A few distinct radii: each written once, as the shortest text of the f32
                // pointsight keeps (at most 12 characters: an answer stays within the
                // protocol's 24 bytes a point with indices below 10^8).
                last_radius = (r, format!("{:e}", r as f32));
            }
            let sep = if count == 0 { "" } else { "," };
            // Writing to a String cannot fail.
            let _ = write!(visible, "{sep}{i}");
            radius.push_str(sep);
            radius.push_str(&last_radius.1);
            count += 1;
        }
    }
    let seconds = start.elapsed().as_secs_f64();
    Ok(format!(
        "{{\"visible\":[{visible}],\"radius\":[{radius}],\"seconds\":{seconds},\"bytes_read\":{bytes_read}}}"
    ))
}

fn run(args: &Args) -> Result<()> {
    let points_path = args
        .points
        .as_deref()
        .ok_or_else(|| Error::Usage("--points FILE is required".into()))?;
    let radius = args
        .radius
        .filter(|r| *r > 0.0)
        .ok_or_else(|| Error::Usage("--radius R > 0 is required".into()))?;
    let points = ply::read(points_path)?;
    let n = points.positions.len() as u64;
    let scratch = Scratch::new()?;
    let (path, build_seconds) = match &args.copc {
        Some(p) => (p.clone(), 0.0),
        None => {
            let las = scratch.0.join("input.las");
            let t = Instant::now();
            input::write(&las, &points)?;
            eprintln!(
                "copc-lod: wrote {} points to {} in {:.3} s",
                n,
                las.display(),
                t.elapsed().as_secs_f64()
            );
            let out = scratch.0.join("cloud.copc.laz");
            let tmp = scratch.0.join("tmp");
            std::fs::create_dir_all(&tmp).map_err(io(&tmp))?;
            let seconds = convert(&las, &out, &tmp, args)?;
            std::fs::remove_file(&las).map_err(io(&las))?;
            if let Some(keep) = &args.save_copc {
                std::fs::copy(&out, keep).map_err(io(keep))?;
            }
            (out, seconds)
        }
    };
    drop(points);
    let t = Instant::now();
    let file = copc::Copc::open(&path, n)?;
    let read = file.verify()?;
    eprintln!(
        "copc-lod: {}: {} nodes, {} bytes; every index back once (read {} bytes, {:.3} s)",
        path.display(),
        file.nodes.len(),
        file.file_bytes,
        read + file.opened_bytes,
        t.elapsed().as_secs_f64()
    );
    say(&serde_json::json!({
        "built": true,
        "seconds": build_seconds,
        "nodes": file.nodes.len(),
        "bytes": file.file_bytes,
        "hierarchy_bytes": file.opened_bytes,
    })
    .to_string())?;
    let radii = select::Radii {
        full: radius,
        spacing: args.spacing,
    };
    let stdin = std::io::stdin();
    for line in stdin.lock().lines() {
        let line = line.map_err(|e| Error::Usage(format!("standard input: {e}")))?;
        if line.trim().is_empty() {
            continue;
        }
        let request = serde_json::from_str::<serde_json::Value>(&line)
            .map_err(|e| Error::Usage(format!("request is not JSON: {e}")));
        let id = request.as_ref().ok().and_then(|r| r.get("id")).cloned();
        let reply = request
            .and_then(|request| answer(&file, &request, &radii))
            .unwrap_or_else(|e| error_line(&e));
        say(&with_id(id.as_ref(), reply))?;
    }
    Ok(())
}

fn main() -> ExitCode {
    let args = match parse_args() {
        Ok(a) => a,
        Err(e) => {
            let _ = say(&error_line(&e));
            return ExitCode::from(2);
        }
    };
    if args.version {
        // The tool's version, and a failure when the converter is missing (the manifest's
        // check).
        let program = converter();
        return match Command::new(&program).arg("--version").output() {
            Ok(o) if o.status.success() => {
                let v = String::from_utf8_lossy(&o.stdout);
                println!(
                    "{} (copc-lod {})",
                    v.lines().next().unwrap_or("copc_converter").trim(),
                    env!("CARGO_PKG_VERSION")
                );
                ExitCode::SUCCESS
            }
            Ok(o) => {
                eprintln!("copc-lod: {} --version: {}", program.display(), o.status);
                ExitCode::FAILURE
            }
            Err(e) => {
                eprintln!("copc-lod: cannot run {}: {e}", program.display());
                ExitCode::FAILURE
            }
        };
    }
    if !args.lod {
        let _ = say(&error_line(&Error::Usage(
            "copc-lod speaks the LOD form only (kind = lod)".into(),
        )));
        return ExitCode::from(2);
    }
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("copc-lod: {e}");
            let _ = say(&error_line(&e));
            ExitCode::FAILURE
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn answers_echo_the_request_id_first() {
        let id = serde_json::json!(7);
        let answer = r#"{"visible":[1,2],"radius":1.5,"seconds":0.1}"#.to_string();
        assert_eq!(
            with_id(Some(&id), answer.clone()),
            r#"{"id":7,"visible":[1,2],"radius":1.5,"seconds":0.1}"#
        );
        assert_eq!(with_id(None, answer.clone()), answer);
        let error = error_line(&Error::Usage("request has no camera".into()));
        assert_eq!(
            with_id(Some(&id), error.clone()),
            r#"{"id":7,"error":"request has no camera"}"#
        );
        assert_eq!(with_id(None, error), r#"{"error":"request has no camera"}"#);
        assert_eq!(with_id(Some(&id), "{}".into()), r#"{"id":7}"#);
    }
}
