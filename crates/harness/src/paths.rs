//! Where pointsight's folders are: the one rule every command resolves its data folder, its
//! methods folder, its reports folder and its page scripts by, so that a command does the same
//! from any working directory.
//!
//! **The clone.** A pointsight clone is found by walking up from the working directory to the
//! first folder that holds every one of [`CLONE_MARKERS`] (`crates/harness/Cargo.toml`,
//! `methods/README.md`, `bench-data/README.md`: together, files only a pointsight clone has).
//!
//! **The data folder** (the fetched meshes and `pointsight fetch`'s download cache), first that
//! applies:
//! 1. `--data-dir DIR` or `POINTSIGHT_DATA=DIR`;
//! 2. the clone's `bench-data/` when the working directory is inside a clone;
//! 3. the per-user data folder: `$XDG_DATA_HOME/pointsight` when `XDG_DATA_HOME` is set (an
//!    absolute path, as the XDG Base Directory specification requires), else
//!    `~/.local/share/pointsight`.
//!
//! **The installed methods** (external methods and peers, `NAME/method.toml` each):
//! 1. `POINTSIGHT_METHODS=DIR` (several folders joined as `PATH` joins them);
//! 2. the clone's `methods/` when the working directory is inside a clone;
//! 3. the methods installed beside the binary: `PREFIX/share/pointsight/methods` for a binary in
//!    `PREFIX/bin/` (`just install`).
//!
//! `--methods-dir DIR` adds DIR's methods to those (a name already taken is an error) and
//! `--no-installed-methods` leaves the installed ones out ([`methods_folders`]).
//!
//! A methods folder that cannot be read is said on standard error ([`Place::warning`]), never
//! taken silently for an empty one.
//!
//! **The reports folder** (`run`, `bench`, `report`, `tables` without `--out`/`--reports`): the
//! clone's `reports/` inside a clone, else `reports/` in the working directory; quick runs
//! (`--quick`) write `reports-quick/` instead ([`reports_dir`]), so a quick run never replaces a
//! full run's results.
//!
//! **The page scripts** (`viewer.js` for `pointsight view` and the report's viewer pages, and
//! any other bundled page script such as `results.js`): built by `just web` (npm and esbuild in
//! `web/`) into `web/dist/`, and *installed beside the binary* by `just install`
//! (`PREFIX/share/pointsight/web/`), not embedded in it. They are looked for ([`script`]) in the
//! file an environment variable names (`POINTSIGHT_VIEWER_JS`, ...), else the clone's
//! `web/dist/` (inside a clone), else `PREFIX/share/pointsight/web/`. Why beside and not
//! embedded: the scripts are built by node, outside cargo; embedding them would make every
//! `cargo build` depend on an earlier `just web` (or embed a stale or absent script without
//! anyone noticing), while beside the binary they follow the same rule as the methods, a clone's
//! `just web` is used at once without reinstalling, and a missing script is an error that says
//! how to build or install it. The build's own source path is never looked at: a binary works
//! the same wherever its clone went.

use std::path::{Path, PathBuf};

use anyhow::{Result, bail};

/// Files that, all present under one folder, mark it as the root of a pointsight clone.
pub const CLONE_MARKERS: &[&str] = &[
    "crates/harness/Cargo.toml",
    "methods/README.md",
    "bench-data/README.md",
];

/// `PREFIX/share/pointsight`, relative to `PREFIX`: where `just install` puts what sits beside
/// the binary.
pub const SHARE: &str = "share/pointsight";

/// The version line of `pointsight --version`: the crate's version and the git revision it was
/// built from (`build.rs`).
pub const VERSION: &str = env!("POINTSIGHT_VERSION");

/// The git revision the binary was built from (`git rev-parse HEAD` at build time), or
/// `unknown`.
pub const BUILD_REVISION: &str = env!("POINTSIGHT_GIT_REVISION");

/// Why a folder is the one used: which step of the rule chose it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Origin {
    /// Given: a flag or its environment variable.
    Given,
    /// The clone the working directory is in.
    Clone(PathBuf),
    /// The per-user data folder (XDG).
    User,
    /// Installed beside the binary.
    Installed,
    /// Added to the installed methods (`--methods-dir`).
    Added,
}

/// A resolved folder and why it was chosen.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Place {
    /// The folder.
    pub path: PathBuf,
    /// Which step of the rule chose it.
    pub origin: Origin,
}

impl Place {
    /// How the folder was chosen, in words (for messages).
    pub fn why(&self) -> String {
        match &self.origin {
            Origin::Given => "given by flag or environment variable".into(),
            Origin::Clone(root) => format!("the clone at {}", root.display()),
            Origin::User => "the per-user data folder".into(),
            Origin::Installed => "installed beside the binary".into(),
            Origin::Added => "added by --methods-dir".into(),
        }
    }

    /// A warning when this methods folder cannot be read (missing, not a folder, no
    /// permission), naming it and saying what follows; `None` when it can.
    pub fn warning(&self) -> Option<String> {
        match std::fs::read_dir(&self.path) {
            Ok(_) => None,
            Err(e) => Some(format!(
                "warning: the methods folder {} ({}) cannot be read ({e}): no external method \
                 or peer is available{}",
                self.path.display(),
                self.why(),
                match self.origin {
                    Origin::Given | Origin::Added => "",
                    _ => {
                        "; set POINTSIGHT_METHODS, add --methods-dir, run from inside a pointsight \
                         clone, or install with `just install` from one"
                    }
                }
            )),
        }
    }
}

/// The root of the pointsight clone `dir` is in (or `dir` itself), if any.
pub fn clone_root(dir: &Path) -> Option<PathBuf> {
    dir.ancestors()
        .find(|d| CLONE_MARKERS.iter().all(|m| d.join(m).is_file()))
        .map(Path::to_path_buf)
}

/// The clone the working directory is in, if any.
pub fn working_clone() -> Option<PathBuf> {
    std::env::current_dir().ok().and_then(|d| clone_root(&d))
}

/// `PREFIX/share/pointsight` for the running binary in `PREFIX/bin/` (symbolic links
/// followed), if its path can be known.
pub fn installed_share() -> Option<PathBuf> {
    let exe = std::env::current_exe().ok()?;
    let exe = exe.canonicalize().unwrap_or(exe);
    Some(exe.parent()?.parent()?.join(SHARE))
}

/// The per-user data folder: `$XDG_DATA_HOME/pointsight` (when set and absolute), else
/// `$HOME/.local/share/pointsight`.
pub fn user_data_dir(xdg_data_home: Option<&Path>, home: Option<&Path>) -> Result<PathBuf> {
    if let Some(x) = xdg_data_home.filter(|x| x.is_absolute()) {
        return Ok(x.join("pointsight"));
    }
    match home.filter(|h| !h.as_os_str().is_empty()) {
        Some(h) => Ok(h.join(".local/share/pointsight")),
        None => bail!(
            "no data folder: HOME and XDG_DATA_HOME are unset; give one with --data-dir or \
             POINTSIGHT_DATA"
        ),
    }
}

fn env_path(var: &str) -> Option<PathBuf> {
    std::env::var_os(var)
        .filter(|v| !v.is_empty())
        .map(PathBuf::from)
}

/// The data folder by the rule above (`given`: `--data-dir` or `POINTSIGHT_DATA`).
pub fn data_dir(given: Option<PathBuf>, clone: Option<&Path>) -> Result<Place> {
    if let Some(path) = given {
        return Ok(Place {
            path,
            origin: Origin::Given,
        });
    }
    if let Some(root) = clone {
        return Ok(Place {
            path: root.join("bench-data"),
            origin: Origin::Clone(root.to_owned()),
        });
    }
    let path = user_data_dir(
        env_path("XDG_DATA_HOME").as_deref(),
        env_path("HOME").as_deref(),
    )?;
    Ok(Place {
        path,
        origin: Origin::User,
    })
}

/// The methods folder by the rule above (`given`: `--methods-dir` or `POINTSIGHT_METHODS`).
pub fn methods_dir(given: Option<PathBuf>, clone: Option<&Path>) -> Place {
    if let Some(path) = given {
        return Place {
            path,
            origin: Origin::Given,
        };
    }
    if let Some(root) = clone {
        return Place {
            path: root.join("methods"),
            origin: Origin::Clone(root.to_owned()),
        };
    }
    Place {
        // Without a known binary path: a folder that does not exist, which the warning names.
        path: installed_share()
            .unwrap_or_else(|| PathBuf::from(SHARE))
            .join("methods"),
        origin: Origin::Installed,
    }
}

/// The methods folders of a command, in order: the installed ones by the rule above
/// (`installed`: `POINTSIGHT_METHODS`'s folders, if set), unless `no_installed`, then each of
/// `added` (`--methods-dir`).
pub fn methods_folders(
    installed: Option<&std::ffi::OsStr>,
    clone: Option<&Path>,
    no_installed: bool,
    added: &[PathBuf],
) -> Vec<Place> {
    let mut out = Vec::new();
    if !no_installed {
        match installed.filter(|v| !v.is_empty()) {
            Some(v) => out.extend(std::env::split_paths(v).map(|path| Place {
                path,
                origin: Origin::Given,
            })),
            None => out.push(methods_dir(None, clone)),
        }
    }
    // A folder named twice (the installed one given again) is read once.
    let same = |a: &Path, b: &Path| match (a.canonicalize(), b.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => a == b,
    };
    for path in added {
        if !out.iter().any(|p| same(&p.path, path)) {
            out.push(Place {
                path: path.clone(),
                origin: Origin::Added,
            });
        }
    }
    out
}

/// The reports folder of a run without `--out`/`--reports`: `reports/` (`reports-quick/` for
/// a quick run) in the clone, else in the working directory.
pub fn reports_dir(quick: bool, clone: Option<&Path>) -> PathBuf {
    let name = if quick { "reports-quick" } else { "reports" };
    match clone {
        Some(root) => root.join(name),
        None => PathBuf::from(name),
    }
}

/// Where the page script `file` (`viewer.js`, `results.js`) is looked for, in order: the file
/// the environment variable `var` names (alone, when set), the clone's `web/dist/FILE`, then
/// `PREFIX/share/pointsight/web/FILE`.
pub fn script_candidates(file: &str, var: &str) -> Vec<PathBuf> {
    if let Some(p) = env_path(var) {
        return vec![p];
    }
    let mut out = Vec::new();
    if let Some(root) = working_clone() {
        out.push(root.join("web/dist").join(file));
    }
    if let Some(share) = installed_share() {
        out.push(share.join("web").join(file));
    }
    out
}

/// The first of `candidates` that is a file, if any.
pub fn find_script(candidates: &[PathBuf]) -> Option<&PathBuf> {
    candidates.iter().find(|p| p.is_file())
}

/// The text of the page script `file` (see [`script_candidates`]), or an error that names
/// where it was looked for and how to get it.
pub fn script(file: &str, var: &str) -> Result<String> {
    let candidates = script_candidates(file, var);
    match find_script(&candidates) {
        Some(p) => std::fs::read_to_string(p)
            .map_err(|e| anyhow::anyhow!("cannot read the page script {}: {e}", p.display())),
        None => bail!("{}", missing_script(file, var, &candidates)),
    }
}

/// The error text for a page script found nowhere.
pub fn missing_script(file: &str, var: &str, candidates: &[PathBuf]) -> String {
    format!(
        "the page script {file} is not built or installed (looked for {}): in a pointsight \
         clone run `just web` (npm and esbuild in web/); for an installed pointsight run `just \
         install` from the clone (it builds and installs the scripts into \
         PREFIX/{SHARE}/web/); or set {var} to a built {file}",
        if candidates.is_empty() {
            "nowhere: no clone around the working directory and no known binary path".to_owned()
        } else {
            candidates
                .iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        }
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fake_clone(root: &Path) {
        for m in CLONE_MARKERS {
            let p = root.join(m);
            std::fs::create_dir_all(p.parent().unwrap()).unwrap();
            std::fs::write(p, "").unwrap();
        }
    }

    #[test]
    fn the_clone_is_found_from_inside_and_only_with_every_marker() {
        let tmp = tempfile::tempdir().unwrap();
        let root = tmp.path().join("clone");
        let deep = root.join("crates/harness/src");
        std::fs::create_dir_all(&deep).unwrap();
        // Every marker but one: not a clone.
        fake_clone(&root);
        std::fs::remove_file(root.join("methods/README.md")).unwrap();
        assert_eq!(clone_root(&deep), None);
        fake_clone(&root);
        assert_eq!(clone_root(&deep), Some(root.clone()));
        assert_eq!(clone_root(&root), Some(root.clone()));
        assert_eq!(clone_root(tmp.path()), None);
        // This workspace is a clone.
        let here = Path::new(env!("CARGO_MANIFEST_DIR"));
        assert_eq!(
            clone_root(here).map(|p| p.canonicalize().unwrap()),
            Some(here.join("../..").canonicalize().unwrap())
        );
    }

    #[test]
    fn the_data_folder_rule() {
        let clone = Path::new("/c");
        let given = data_dir(Some("/given".into()), Some(clone)).unwrap();
        assert_eq!((given.path, given.origin), ("/given".into(), Origin::Given));
        let cloned = data_dir(None, Some(clone)).unwrap();
        assert_eq!(cloned.path, PathBuf::from("/c/bench-data"));
        assert_eq!(
            user_data_dir(Some(Path::new("/x")), Some(Path::new("/h"))).unwrap(),
            PathBuf::from("/x/pointsight")
        );
        // A relative XDG_DATA_HOME is ignored, as the specification says.
        assert_eq!(
            user_data_dir(Some(Path::new("rel")), Some(Path::new("/h"))).unwrap(),
            PathBuf::from("/h/.local/share/pointsight")
        );
        let err = user_data_dir(None, None).unwrap_err().to_string();
        assert!(err.contains("POINTSIGHT_DATA"), "{err}");
    }

    #[test]
    fn the_methods_and_reports_rules() {
        let clone = Path::new("/c");
        assert_eq!(
            methods_dir(None, Some(clone)).path,
            PathBuf::from("/c/methods")
        );
        assert_eq!(
            methods_dir(Some("/m".into()), Some(clone)).origin,
            Origin::Given
        );
        // --methods-dir adds to the installed folders; --no-installed-methods drops them; the
        // installed folder named again is read once.
        let folders = |env: Option<&str>, no: bool, added: &[&str]| {
            let added: Vec<PathBuf> = added.iter().map(PathBuf::from).collect();
            methods_folders(env.map(std::ffi::OsStr::new), Some(clone), no, &added)
                .into_iter()
                .map(|p| (p.path.display().to_string(), p.origin))
                .collect::<Vec<_>>()
        };
        let mine = ("/mine".to_owned(), Origin::Added);
        let cloned = ("/c/methods".to_owned(), Origin::Clone(clone.to_owned()));
        assert_eq!(
            folders(None, false, &["/mine"]),
            [cloned.clone(), mine.clone()]
        );
        assert_eq!(folders(None, true, &["/mine"]), std::slice::from_ref(&mine));
        assert_eq!(folders(None, false, &["/c/methods"]), [cloned]);
        assert_eq!(
            folders(Some("/a:/b"), false, &["/mine"]),
            [
                ("/a".to_owned(), Origin::Given),
                ("/b".to_owned(), Origin::Given),
                mine
            ]
        );
        assert!(folders(Some("/a"), true, &[]).is_empty());
        let installed = methods_dir(None, None);
        assert_eq!(installed.origin, Origin::Installed);
        assert!(installed.path.ends_with("share/pointsight/methods"));
        assert_eq!(
            reports_dir(true, Some(clone)),
            Path::new("/c/reports-quick")
        );
        assert_eq!(reports_dir(false, None), Path::new("reports"));
    }

    #[test]
    fn an_unreadable_methods_folder_is_named() {
        let place = Place {
            path: "/nonexistent/pointsight-methods".into(),
            origin: Origin::Given,
        };
        let w = place.warning().unwrap();
        assert!(w.contains("/nonexistent/pointsight-methods"), "{w}");
        let tmp = tempfile::tempdir().unwrap();
        let ok = Place {
            path: tmp.path().into(),
            origin: Origin::Given,
        };
        assert_eq!(ok.warning(), None);
    }

    #[test]
    fn a_missing_script_says_how_to_get_it() {
        let text = missing_script(
            "viewer.js",
            "POINTSIGHT_VIEWER_JS",
            &["/a/viewer.js".into()],
        );
        for needle in [
            "/a/viewer.js",
            "just web",
            "just install",
            "POINTSIGHT_VIEWER_JS",
        ] {
            assert!(text.contains(needle), "{needle}: {text}");
        }
    }
}
