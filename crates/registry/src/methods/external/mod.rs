//! External methods, in any language: a folder `methods/NAME/` with a `method.toml` registers a
//! visibility method (or, with `kind = "lod"`, a level-of-detail method) without a Rust
//! change: its card is made from the manifest ([`card`]) and added to a catalogue like any
//! other ([`super::Catalogue::add_external`]). The parts: [`manifest`] (the file, checked),
//! `session` (the program and the wire protocol), `process` (its end: group, escapees,
//! scratch folder), `warm` (protocol 3's one program per cloud), [`points`] (the points
//! handed over), `visibility` and `lod` (the two forms). The protocol (versions 1 to 3;
//! `methods/README.md` is the user's documentation):
//!
//! - The caller writes the cloud once per program as binary little-endian PLY: `x y z`
//!   doubles (point k is index k); from protocol 2 also `nx ny nz` floats (unless the manifest
//!   says `normals = false`), the dataset's normals or, when it has none, the estimates the
//!   `lod` experiment uses (16 nearest neighbours, oriented by Hoppe's spanning tree:
//!   [`points::estimated_normals`]), and the dataset's `red green blue` and `u v` when it has
//!   them. Protocols 1 and 2 start the method's `command` once per setting (the `--set`
//!   pairs), in the method's folder, with `--points FILE --params JSON --protocol P` appended
//!   (`JSON`: the pairs as an object of strings) and, from protocol 2, `--normals dataset` or
//!   `--normals estimated` (when normals are sent) and `--spacing S`, the cloud's density
//!   spacing (`cloud::spacing::density_spacing`, 8 neighbours, 20 000 samples, seed 1: the
//!   unit of our radius factors; absent on clouds of at most 8 points). Protocol 3 starts it
//!   once per cloud, without `--params`, and keeps it for every setting on that cloud.
//! - Per view it writes one line on the program's standard input: `{"view": K, "camera":
//!   CAMERA}` (protocol 3: `{"id": N, "view": K, "camera": CAMERA, "params": JSON}`, N
//!   1, 2, 3… per program), CAMERA being the camera's one serialisation
//!   (`cloud::camera::json`), K the dataset's view index when the caller knows it
//!   (`Prepared::visible_at`; a caller that does not gets its calls counted), and reads one
//!   line from its standard output: `{"visible": [indices...], "seconds": T}` (or
//!   `"visible_file": PATH` naming a file of indices, whitespace-separated, inside the
//!   program's scratch folder: the points file's folder, also its `TMPDIR`; a relative PATH
//!   is relative to it), `T` the program's own compute seconds for that view, which is what
//!   gets reported; or `{"error": MESSAGE}`. Protocol 3's answers echo the request's `"id"`
//!   (an answer with another id or none is an error naming both, never a shifted result) and
//!   may carry `"built_seconds"`, the set-up that request's setting needed (a BVH for its
//!   radius). Exactly one line per request. End of input means exit. Before its first answer
//!   a program may write `{"built": true, "seconds": T}`: its own per-cloud set-up (a BVH, a
//!   render window), reported apart from the per-view times
//!   (`Prepared::reported_build_seconds`, for the setting whose views started it; after a
//!   restart, the restarted program's). The cold call, from starting the program to its
//!   first answer, is reported apart too (`Prepared::cold_call_seconds`).
//! - The LOD form (`kind = "lod"`, protocol 2 or 3): started once per cloud with `--lod --radius R`
//!   appended too (R the full-detail splat radius, world units), the program builds its structure and says so on its first line, `{"built": true,
//!   "seconds": T, "nodes": K, "bytes": B}` (its own build time); then per view and setting it
//!   reads `{"view": K, "camera": CAMERA, "params": JSON}` and answers `{"visible": [...],
//!   "radius": R, "seconds": T}`, R one splat radius (world units) for all or a list, one per
//!   index, and optionally `"bytes_read": B`, the bytes the selection read from the program's
//!   own file (a COPC file), reported as a file selection's reads (`LodSelector::reads`).
//! - The answer is checked with bounded memory: a line longer than the cloud's index range
//!   allows ([`answer_limit`]: 1 MiB plus 48 bytes per point), a `visible_file` larger than
//!   that, more indices than points, indices outside 0..N and repeated ones are errors (the
//!   indices are sorted here). Its lies too: a second line with one answer (which would shift
//!   every later answer by one), a `seconds` that is not a number from 0 to `timeout_seconds`,
//!   a `visible_file` outside its scratch folder (refused unread; no error quotes a file's
//!   content). The program's standard error is kept in memory as its last 64 KiB
//!   (`session::STDERR_TAIL`; nothing on disk). A view that takes longer than
//!   `timeout_seconds` (default 300), a program that exits, or an answer that is not this
//!   protocol is an error naming the method, the view and quoting the end of its stderr; the
//!   program is killed and the next view starts a fresh one (protocol 3: on the same cloud,
//!   serving the later settings).
//! - Each program runs in a process group of its own, killed as a group (whatever it started
//!   with it, and what left the group carrying the session's `POINTSIGHT_PROGRAM` token): at
//!   once when it fails, and when it is done with (the cell is over, or for protocol 3 the
//!   cloud or the run) after its input is closed and 3 s to exit; when pointsight is stopped
//!   by a signal, the harness's `cloud::scratch::cleanup` kills the groups still running and
//!   removes their scratch folders (`$TMPDIR/.pointsight.program-HOST-PID-K`, registered with
//!   `cloud::scratch`, and reclaimed by a later run after a `kill -9`).
//!
//! `method.toml`:
//!
//! ```toml
//! protocol = 3
//! summary = "peer: Open3D's hidden_point_removal (Qhull Qt), R from gamma as ours"
//! command = [".venv/bin/python", "hpr.py"]   # the first element: a path relative to the
//!                                            # folder, or a program on PATH
//! check = [".venv/bin/python", "-c", "import open3d"]   # exits 0 when installed
//! install = "just peers"                     # said when the check fails
//! version = [".venv/bin/python", "-c", "import open3d; print(open3d.__version__)"]
//! peer_of = "hpr"                            # the family of ours it pairs with
//! kind = "visibility"                        # or "lod"
//! made_for = "points"                        # or "pixels": the score it is judged by
//!                                            # (default: points; an LOD method: pixels)
//! exact = true                               # it claims the exact set of its definition
//!                                            # (checked; default: false)
//! timeout_seconds = 120
//! memory_bytes_per_point = 200               # for the scale experiment's memory guard
//!                                            # (undeclared: not run above 10^6 points)
//! normals = false                            # it reads no normals: none are estimated
//!                                            # and sent (default: true, from protocol 2)
//! cameras = ["pinhole", "spherical"]         # models it takes (default: all)
//! grid = [{gamma = ["2", "3"]}]             # what the visibility experiment sweeps, in
//! quick_grid = [{gamma = "3"}]               # registry::sweep's format (lists are swept)
//! default = {gamma = "3"}                    # the default setting in every command; absent:
//!                                            # the [params] defaults ("-": none), sent to
//!                                            # the program when a key is not given
//! family = "open3d-hpr"                      # how its rows group in plots (default: name)
//! skip_robustness = "why"                    # leaves the robustness experiment (listed
//!                                            # with the reason); default: it takes part
//! # peer_keys = {point_size = {ours = "radius_px", factor = 0.5}}: for a peer whose key's
//! # name or unit differs from its partner's (ours = factor x the peer's; same names as is)
//! [params.gamma]
//! default = "3"
//! help = "R = max|p - C| * 10^gamma"
//! ```

mod lod;
pub mod manifest;
pub mod points;
mod process;
mod session;
#[cfg(test)]
mod tests;
#[cfg(test)]
mod tests_contract;
#[cfg(test)]
mod tests_warm;
mod visibility;
mod warm;

use std::path::Path;

use crate::card::{Card, Family, Kind as CardKind, Memory};
use crate::error::{Error, Result};

pub use manifest::{ExternalMethod, Kind, PROTOCOL, PROTOCOLS};
pub use process::end_programs_of;
pub use session::answer_limit;

/// The card of an external method (leaked, as the method is: the registry's methods live for
/// the process).
pub fn card(m: &'static ExternalMethod) -> &'static Card {
    let kind = match m.kind {
        Kind::Visibility => {
            CardKind::Visibility(Box::leak(Box::new(visibility::Visibility::new(m))))
        }
        Kind::Lod => CardKind::Lod(Box::leak(Box::new(lod::Lod(m)))),
    };
    Box::leak(Box::new(Card {
        name: m.name,
        summary: m.summary,
        params: m.params,
        family: m.family.as_deref().map_or(Family::Name, |f| {
            Family::Named(manifest::leak(f.to_owned()))
        }),
        // What the program and this process together need per point beyond the cloud, as the
        // method.toml declares it; undeclared: not run above Memory::UNKNOWN_LIMIT points.
        memory: m
            .memory_bytes_per_point
            .map_or(Memory::Unknown, Memory::PerPoint),
        parallel_views: false,
        peer_of: m.peer_of,
        peer_keys: m.peer_keys,
        compared_in: &[],
        bare_node_bytes: None,
        sweep: m.sweep.clone(),
        program: Some(m),
        made_for: m.made_for,
        exact: m.exact,
        kind,
    }))
}

impl super::Catalogue {
    /// Loads the external methods under `dir` (`NAME/method.toml` each) and adds their cards.
    /// Names must not shadow built-in methods (visibility or LOD: one namespace); a method
    /// already in the catalogue under the same name is kept (adding the same folder twice is
    /// harmless). An external card and its manifest live for the process (the cards' fields
    /// are `'static`): a few kilobytes a folder loaded.
    pub fn add_external(&mut self, dir: &Path) -> Result<()> {
        for m in ExternalMethod::load_dir(dir)? {
            if super::builtin_card(m.name()).is_some() {
                return Err(Error::Unsupported(format!(
                    "external method {} in {} shadows a built-in method",
                    m.name(),
                    dir.display()
                )));
            }
            if self.card_named(m.name()).is_some() {
                continue;
            }
            self.add(card(Box::leak(Box::new(m))))?;
        }
        Ok(())
    }
}
