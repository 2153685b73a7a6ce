//! The command line (clap). The output contract of each subcommand is documented on it and
//! fixed: later experiments and external checks parse it.

use std::path::PathBuf;

use clap::{Parser, Subcommand, ValueEnum};

pub use crate::visible::ParallelViews;

/// pointsight: a benchmark harness for point-cloud visibility and level-of-detail methods.
///
/// Folders: the data folder and the methods folder are the flags' (or their environment
/// variables'), else the clone's `bench-data/` and `methods/` when the working directory is
/// inside a pointsight clone, else the per-user data folder (`$XDG_DATA_HOME/pointsight` or
/// `~/.local/share/pointsight`) and the methods installed beside the binary
/// (`PREFIX/share/pointsight/methods`); `harness::paths` is the rule.
#[derive(Debug, Parser)]
#[command(name = "pointsight", version = crate::paths::VERSION, about, long_about)]
pub struct Cli {
    /// A dataset manifest (TOML) naming datasets made of your files; default:
    /// `pointsight.toml` in the working directory when it exists.
    #[arg(long, global = true, env = "POINTSIGHT_MANIFEST")]
    pub manifest: Option<PathBuf>,
    /// A folder of external methods (`NAME/method.toml` each; see methods/README.md) added to
    /// the installed ones (repeatable; a name already taken is an error). The installed methods
    /// are `POINTSIGHT_METHODS` (folders joined as PATH joins them), else the clone's
    /// `methods/`, else `PREFIX/share/pointsight/methods` beside the binary.
    #[arg(long, global = true)]
    pub methods_dir: Vec<PathBuf>,
    /// Leave the installed methods out: only `--methods-dir`'s (and the built-in ones) run.
    #[arg(long, global = true)]
    pub no_installed_methods: bool,
    /// Folder of fetched data; default: the clone's `bench-data/`, else
    /// `$XDG_DATA_HOME/pointsight` (or `~/.local/share/pointsight`).
    #[arg(long, global = true, env = "POINTSIGHT_DATA")]
    pub data_dir: Option<PathBuf>,
    /// No progress on standard error (bars, the run's line, notes); warnings and errors stay.
    /// Progress is drawn only when standard error is a terminal anyway.
    #[arg(long, short = 'q', global = true)]
    pub quiet: bool,
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// Subcommands.
// The enum is parsed once per process: the size of its largest variant does not matter.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Download the real meshes (Debian's libcgal-demo) into the data folder, checksummed.
    Fetch,
    /// Where the data, methods and reports folders and the page scripts are for this working
    /// directory, and which step of the rule chose each (`harness::paths`): one `NAME=PATH
    /// (why)` line each.
    Paths,
    /// One line per dataset: name, number of points, availability, role (tuning: settings are
    /// chosen on it; evaluation: never; own: a manifest's), description.
    Datasets,
    /// The visibility and LOD methods and their --set parameters. An external method's
    /// program is checked (is it installed here?) only with `--check`, which runs every
    /// method's `check` command at once; without it the listing takes no time.
    Methods {
        /// Run every external method's check and say which are not installed, and how to
        /// install them.
        #[arg(long)]
        check: bool,
    },
    /// Write a dataset's points: binary little-endian PLY (x y z, double), or LAS/LAZ when the
    /// output ends in .las or .laz (coordinates quantised; the scale is printed).
    Export {
        /// Dataset name.
        #[arg(long)]
        dataset: String,
        /// Output file.
        #[arg(long)]
        out: PathBuf,
        /// Also write the dataset's normals (a sampled mesh's: each point's triangle's normal):
        /// in LAS/LAZ as extra bytes `NormalX`, `NormalY`, `NormalZ` (f32, the names PDAL and
        /// CloudCompare read), in PLY as `nx ny nz`. An error when the dataset has none.
        #[arg(long)]
        normals: bool,
    },
    /// A dataset's views: CSV (view,eye_x,eye_y,eye_z,target_x,target_y,target_z,up_x,up_y,up_z,
    /// fov_y_deg,width,height; look-at pinhole views) or JSON lines (one camera per line, any
    /// model: the views file that `visible --views` reads).
    Views {
        /// Dataset name.
        #[arg(long)]
        dataset: String,
        /// Output file (standard output when absent).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Output format.
        #[arg(long, value_enum, default_value_t = ViewsFormat::Csv)]
        format: ViewsFormat,
    },
    /// Run one method on one view or many.
    ///
    /// One view (`--view K`, the dataset's views): write the visible indices, ascending, one per
    /// line, to the file `--out`; the last line on stdout is `method=M points=N visible=K
    /// seconds=T` (T: the method's compute time). With `--out -` the indices are standard
    /// output and those lines go to standard error.
    ///
    /// Many views (`--views FILE`, or `--view all` or a list `K1,K2,...`): `--out` is a folder
    /// that gets `view-K.txt` per view; one line `view=K method=M points=N visible=V
    /// seconds=T` per view, then `views=V points=N seconds=T views_per_second=R` (T: wall time
    /// of all views; per-dataset preparation is done once and excluded).
    Visible {
        /// The points, mesh and camera.
        #[command(flatten)]
        source: SourceArgs,
        /// View index, `all`, or a comma-separated list of indices (default: 0, or `all`
        /// with `--views`).
        #[arg(long)]
        view: Option<String>,
        /// Method name (see `pointsight methods`).
        #[arg(long)]
        method: String,
        /// Method parameter, KEY=VALUE or METHOD.KEY=VALUE (repeatable), typed by the method
        /// before any data is read; one value each (a list A,B,C is a sweep: `run`, `bench`).
        #[arg(long = "set", value_name = "[METHOD.]KEY=VALUE")]
        set: Vec<String>,
        /// Output file for the indices (one view) or folder (many views). `-`: the indices on
        /// standard output (one view), the other lines on standard error.
        #[arg(long)]
        out: PathBuf,
        /// Also score the visible set against the reference (printed before each contract line).
        #[arg(long)]
        score: bool,
        /// Runs per view, 1 to 1000; `seconds` is their median and a line before it gives the
        /// spread.
        #[arg(long, default_value_t = 1, value_parser = repeat_count)]
        repeat: usize,
        /// Many views: answer them in parallel (`yes`), one after another (`no`), or as the
        /// method prefers (`auto`: in parallel for hpr, reference and exact, whose single view
        /// leaves cores idle).
        #[arg(long, value_enum, default_value_t = ParallelViews::Auto)]
        parallel_views: ParallelViews,
    },
    /// Write an interactive 3D page (one self-contained HTML file, no server) of every chosen
    /// method's visible set from one view, coloured against the reference as in renders.png.
    ///
    /// Prints `page=FILE points=N shown=M methods=K bytes=B` (M < N when `--max-points`
    /// subsampled the page).
    View {
        /// The points, mesh and camera.
        #[command(flatten)]
        source: SourceArgs,
        /// View index (default 0).
        #[arg(long, default_value_t = 0)]
        view: usize,
        /// Comma-separated method names (default: every registered method with a sweep that
        /// can run here, external ones and peers included, at its sweep's default setting).
        #[arg(long, value_delimiter = ',')]
        methods: Option<Vec<String>>,
        /// Method parameter, KEY=VALUE or METHOD.KEY=VALUE (repeatable): over the default
        /// setting of every chosen method that has KEY (or of METHOD alone), typed by each
        /// method before any data is read; one value each (a list A,B,C is a sweep: `run`,
        /// `bench`).
        #[arg(long = "set", value_name = "[METHOD.]KEY=VALUE")]
        set: Vec<String>,
        /// At most this many points on the page (a uniform subsample; the scores stay those of
        /// the whole cloud).
        #[arg(long)]
        max_points: Option<usize>,
        /// Also write the harness's static render of the view (the reference's classes, as the
        /// first panel of renders.png, uncropped) to this PNG.
        #[arg(long)]
        png: Option<PathBuf>,
        /// The page (HTML).
        #[arg(long)]
        out: PathBuf,
        /// A level-of-detail page instead: the full detail and each LOD method's selection
        /// (`--methods` names LOD methods; default every one with a sweep), each splat at its
        /// size; `--max-points` is then per method and `--png` the full detail's render.
        #[arg(long)]
        lod: bool,
        /// With --lod: the view's eye moved to this many times its distance from the target
        /// (the `lod` experiment's distances are 1 and 2).
        #[arg(long, default_value_t = crate::experiments::lod::FAR_DISTANCE)]
        distance: f64,
    },
    /// One cell of the `scale` experiment, in its own process (internal): prints one JSON line
    /// with the seconds and the process's peak RSS.
    #[command(hide = true)]
    ScaleCell(crate::experiments::scale::child::CellArgs),
    /// Build an LOD method's file from a point file (LAS, LAZ, PLY, E57, ...) within a memory
    /// limit: out of core when the cloud does not fit (scratch files in a hidden folder beside
    /// --out, removed after, also on failure), the same bytes as the in-memory build. Prints
    /// one line: `points=N seconds=T points_per_second=R peak_rss_bytes=B chunks=C
    /// top_levels=L leaf_radius=X file_bytes=F scratch_bytes=S scratch_peak_bytes=P
    /// normals=given|estimated neighbour_queries=Q stage_seconds=read:T1,split:T2,...` (S:
    /// written to scratch in all; P: the most on disk at once; normals: the file's (PLY, PCD,
    /// XYZ, E57, LAS/LAZ extra bytes `NormalX`.. or `nx`..: each a unit vector, else an error)
    /// or estimated from 16 neighbours; Q: points whose neighbours were searched, the spacing
    /// sample's alone when the normals are given; the wall-clock seconds of each stage: read,
    /// split, guide, normals (within chunks), halos (across their borders), then roots,
    /// encode, write for QSplat or count, distribute, build, merge for SPT; read, build in
    /// memory).
    LodBuild {
        /// The point file.
        #[arg(long)]
        cloud: PathBuf,
        /// The LOD method (qsplat, spt).
        #[arg(long, default_value = "qsplat")]
        method: String,
        /// Peak memory of the build, like 512MiB or 4GiB.
        #[arg(long, default_value = "1GiB")]
        memory_limit: String,
        /// The output file.
        #[arg(long)]
        out: PathBuf,
        /// Build in memory (the reference the out-of-core build equals).
        #[arg(long)]
        in_memory: bool,
    },
    /// Read a point or mesh file and describe it: points, faces, attributes, bounding box,
    /// scanners, which normals it gives (`normals=FIELDS (WHERE)`, such as
    /// `normals=NormalX,NormalY,NormalZ (LAS extra bytes, f32)`, or `normals=- ...` when
    /// none), coincident points (`distinct_positions=M duplicates=D most_copies=C`), and the
    /// read time (`points=N ... read_seconds=T points_per_second=R`).
    Inspect {
        /// The file.
        file: PathBuf,
        /// Its format when the extension does not say.
        #[arg(long)]
        format: Option<String>,
        /// LAS/LAZ: keep only these classification codes (comma-separated).
        #[arg(long, value_delimiter = ',')]
        classes: Option<Vec<u8>>,
        /// E57: read only this scan.
        #[arg(long)]
        scan: Option<usize>,
        /// XYZ: what each column holds, e.g. `x,y,z,r,g,b` or `x,y,z,nx,ny,nz` (`_` for a
        /// column not read). Without it, a header line (`# x y z nx ny nz`, `//X,Y,Z,R,G,B`)
        /// decides; else six columns are normals only when every triple has unit length, colours
        /// only when all are integers 0-255, and refused otherwise.
        #[arg(long, value_parser = parse_columns)]
        columns: Option<cloud::io::xyz::Columns>,
    },
    /// Run an experiment: results.csv, plots and tables into its output folder.
    ///
    /// On your own files as `visible` takes them: `--cloud FILE` (and `--mesh FILE` for the
    /// ground truth) with `--eye X,Y,Z` or `--views FILE`; the dataset is named after the
    /// file. Without `--cloud`, `--eye` or `--views` replace every dataset's own views.
    Run {
        /// Experiment name.
        experiment: String,
        /// Comma-separated datasets (default: the experiment's own list).
        #[arg(long, value_delimiter = ',', conflicts_with = "cloud")]
        datasets: Option<Vec<String>>,
        /// Fewer datasets, views and repeats.
        #[arg(long)]
        quick: bool,
        /// Output folder (default reports/EXPERIMENT, reports-quick/EXPERIMENT with --quick:
        /// in the clone, else in the working directory).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Your point and mesh files.
        #[command(flatten)]
        files: FileArgs,
        /// The cameras.
        #[command(flatten)]
        camera: CameraArgs,
        /// Sweeps, repeats, shard.
        #[command(flatten)]
        sweep: SweepFlags,
    },
    /// Run every experiment with its default datasets, then write the report.
    Bench {
        /// Quick mode for every experiment.
        #[arg(long)]
        quick: bool,
        /// Comma-separated datasets for every experiment instead of their own lists (for
        /// example the synthetic ones, which need no download).
        #[arg(long, value_delimiter = ',')]
        datasets: Option<Vec<String>>,
        /// Comma-separated experiments to run (default: every one, in report order).
        #[arg(long, value_delimiter = ',')]
        experiments: Option<Vec<String>>,
        /// Reports folder (default reports/, reports-quick/ with --quick: in the clone, else
        /// in the working directory).
        #[arg(long)]
        reports: Option<PathBuf>,
        /// Sweeps, repeats, shard.
        #[command(flatten)]
        sweep: SweepFlags,
    },
    /// Combine the reports folders of a sharded run (`--shard K/N` each) into one, as an
    /// unsharded run would have written it, then draw its plots, tables and report.
    Merge {
        /// The merged reports folder.
        #[arg(long)]
        out: PathBuf,
        /// The shards' folders: each what `run EXPERIMENT --shard K/N --out DIR` wrote (DIR
        /// holds metadata.json) or `bench --shard K/N --reports DIR` (DIR/EXPERIMENT/).
        #[arg(required = true)]
        shards: Vec<PathBuf>,
    },
    /// Print the built-in sweeps (every method's grid), a starting point for `--config`.
    Sweeps,
    /// List the scratch and staging folders and files that runs left beside their outputs
    /// (`.NAME.chunks-HOST-PID-K`, `.NAME.partial-…`, `.NAME.previous-…`) in the given folders
    /// and below, with their state: stale (this host's, its process gone), in use, or another
    /// host's (a shared file system: left alone). A dry run unless `--remove`, which removes
    /// the stale ones (a `previous` folder whose output is missing is put back) and lock
    /// files no process holds. One line per path, then `N stale path(s)`.
    Clean {
        /// Folders to look in (default: the working directory).
        folders: Vec<PathBuf>,
        /// Remove what is stale (without it, only list).
        #[arg(long)]
        remove: bool,
    },
    /// Write the viewer pages of the visibility and lod experiments' real datasets
    /// (reports/viewer/, each at most 5 MiB) and assemble reports/README.md from the
    /// experiments' results.
    Report {
        /// Reports folder (default reports/: in the clone, else in the working directory).
        #[arg(long)]
        reports: Option<PathBuf>,
    },
    /// Redraw every experiment's tables and plots from its CSVs (no measuring), then the report.
    Tables {
        /// Reports folder (default reports/: in the clone, else in the working directory).
        #[arg(long)]
        reports: Option<PathBuf>,
    },
}

/// Where the points, the mesh and the cameras come from (`visible` and `view`): a dataset, or
/// a user's files and camera.
#[derive(Debug, Clone, clap::Args)]
pub struct SourceArgs {
    /// Dataset name (built-in or from the manifest).
    #[arg(long, required_unless_present = "cloud", conflicts_with = "cloud")]
    pub dataset: Option<String>,
    /// Your point and mesh files.
    #[command(flatten)]
    pub files: FileArgs,
    /// The cameras.
    #[command(flatten)]
    pub camera: CameraArgs,
}

/// A user's point file and mesh (`visible`, `view`, `run`).
#[derive(Debug, Clone, Default, clap::Args)]
pub struct FileArgs {
    /// A point file instead of a dataset (ply, off, obj, xyz, las, laz, e57, pcd).
    #[arg(long)]
    pub cloud: Option<PathBuf>,
    /// A mesh file for the ground truth (`visible --score`, `view`, `run`), with `--cloud`.
    #[arg(long, requires = "cloud")]
    pub mesh: Option<PathBuf>,
    /// The cloud file's format when its extension does not say.
    #[arg(long)]
    pub format: Option<String>,
    /// LAS/LAZ: keep only these classification codes (comma-separated).
    #[arg(long, value_delimiter = ',')]
    pub classes: Option<Vec<u8>>,
    /// E57: read only this scan (0-based).
    #[arg(long, conflicts_with = "merge_scans")]
    pub scan: Option<usize>,
    /// E57: merge every scan into one cloud (each point keeps its scan).
    #[arg(long)]
    pub merge_scans: bool,
    /// XYZ: what each column holds, e.g. `x,y,z,r,g,b` or `x,y,z,nx,ny,nz` (`_` for a
    /// column not read). Without it, a header line (`# x y z nx ny nz`, `//X,Y,Z,R,G,B`)
    /// decides; else six columns are normals only when every triple has unit length, colours
    /// only when all are integers 0-255, and refused otherwise.
    #[arg(long, value_parser = parse_columns)]
    pub columns: Option<cloud::io::xyz::Columns>,
    /// Off-surface tolerance for scoring (world units; default: one density spacing).
    #[arg(long)]
    pub surface_tolerance: Option<f64>,
    /// Score against a mesh that does not fit the points anyway: without it, a dataset whose
    /// points lie more than 1 % farther than 3 density spacings from its mesh is refused
    /// (scale, offset, units, another mesh); with it, its rows are marked
    /// `mesh_fit=off-surface`.
    #[arg(long)]
    pub allow_off_surface: bool,
}

/// The cameras (`visible`, `view`, `run`): one from flags, or a views file.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct CameraArgs {
    /// Eye, world coordinates: X,Y,Z.
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub eye: Option<[f64; 3]>,
    /// Target (default: the centre of the cloud's bounding box).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true, requires = "eye")]
    pub target: Option<[f64; 3]>,
    /// Up vector (default +z, or +y when looking along z).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true, requires = "eye")]
    pub up: Option<[f64; 3]>,
    /// Vertical field of view in degrees (default: fits the cloud).
    #[arg(long = "fov-y", requires = "eye", allow_hyphen_values = true)]
    pub fov_y: Option<f64>,
    /// Image width (default 1280; with `--eye`, else the view's own).
    #[arg(long, requires = "eye")]
    pub width: Option<u32>,
    /// Image height (default 720; with `--eye`, else the view's own).
    #[arg(long, requires = "eye")]
    pub height: Option<u32>,
    /// A views file (JSON lines, or a COLMAP text model: its folder or images.txt) instead
    /// of the dataset's own views.
    #[arg(long)]
    pub views: Option<PathBuf>,
}

/// `--columns`: XYZ column names (`cloud::io::xyz::Columns`).
fn parse_columns(text: &str) -> Result<cloud::io::xyz::Columns, String> {
    text.parse()
}

/// Output format of `views`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ViewsFormat {
    /// The look-at CSV (pinhole views only).
    Csv,
    /// JSON lines, one camera per line, any model.
    Jsonl,
}

/// Parses `X,Y,Z`.
pub fn parse_vec3(text: &str) -> Result<[f64; 3], String> {
    let parts: Vec<&str> = text.split(',').collect();
    if parts.len() != 3 {
        return Err(format!("expected X,Y,Z, got {text:?}"));
    }
    let mut out = [0.0; 3];
    for (o, p) in out.iter_mut().zip(&parts) {
        *o = p
            .trim()
            .parse::<f64>()
            .map_err(|_| format!("{p:?} is not a number"))?;
        if !o.is_finite() {
            return Err(format!("{p:?} is not finite"));
        }
    }
    Ok(out)
}

/// `--set`'s framing of the registry's parameter errors (which speak of parameter names and
/// values): `--set KEY=VALUE: why` for a value, `--set PAIR: why` for a pair that is not one.
/// Every other error, and the context around the registry's, is left as it is.
pub fn frame_set(err: anyhow::Error) -> anyhow::Error {
    let mut framed = false;
    let parts: Vec<String> = err
        .chain()
        .map(|cause| match cause.downcast_ref::<registry::Error>() {
            Some(registry::Error::BadValue { key, value, reason }) => {
                framed = true;
                format!("--set {key}={value}: {reason}")
            }
            Some(registry::Error::BadPair { pair, reason }) => {
                framed = true;
                format!("--set {pair}: {reason}")
            }
            _ => cause.to_string(),
        })
        .collect();
    if framed {
        anyhow::anyhow!(parts.join(": "))
    } else {
        err
    }
}

/// What the experiments sweep, how often they time, and which part of the cells to run.
#[derive(Debug, Clone, clap::Args)]
pub struct SweepFlags {
    /// A sweeps file (TOML, `registry::sweep`'s format) replacing the grid of every method it
    /// names; `pointsight sweeps` prints the built-in one to start from.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Method parameter over the sweeps, KEY=VALUE or METHOD.KEY=VALUE (repeatable), a list
    /// KEY=A,B,C sweeping it: each method it names (or that has KEY) is measured at its default
    /// setting (after `--config`) with each key at each value given, the lists' product;
    /// typed by each method before any data is read.
    #[arg(long = "set", value_name = "[METHOD.]KEY=VALUE")]
    pub set: Vec<String>,
    /// Timed runs per call, 1 to 1000 (default: the sweeps file's `repeats`, else 3).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub repeats: Option<u32>,
    /// Seconds after which a call's timed runs stop repeating: a call slower than this is timed
    /// once (every row says how many runs it had); `inf` always makes `--repeats` runs.
    #[arg(long, value_name = "SECONDS", default_value_t = crate::experiments::TIME_BUDGET, value_parser = time_budget)]
    pub time_budget: f64,
    /// Run only the K-th of N parts of the cells (1-based), for `pointsight merge`.
    #[arg(long, value_name = "K/N")]
    pub shard: Option<crate::shard::Shard>,
    /// `scale` only: the largest cloud size, a whole number or a power of ten such as `1e9`
    /// (default 10^7; quick 10^6). The out-of-core builds run at every power of ten from 10^6
    /// up to it, the in-core cells from 10^4 up to it or 10^8, whichever is smaller.
    #[arg(long, value_name = "N", value_parser = point_count)]
    pub max_points: Option<u64>,
}

/// A cloud size (`--max-points`): a whole number of at least 10^4, or `1eK` (K from 4 to 12).
fn point_count(s: &str) -> Result<u64, String> {
    let err =
        || format!("expected a point count from 10000 to 1e12 (a whole number or 1eK), got {s:?}");
    let n = match s.split_once(['e', 'E']) {
        Some(("1", k)) => {
            let k: u32 = k.parse().map_err(|_| err())?;
            10u64.checked_pow(k).ok_or_else(err)?
        }
        Some(_) => return Err(err()),
        None => s.parse::<u64>().map_err(|_| err())?,
    };
    if (10_000..=1_000_000_000_000).contains(&n) {
        Ok(n)
    } else {
        Err(err())
    }
}

/// A time budget in seconds (`--time-budget`): zero or more, `inf` for none.
fn time_budget(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(b) if b >= 0.0 => Ok(b),
        _ => Err(format!("expected seconds (0 or more, or inf), got {s:?}")),
    }
}

/// A run count of 1 to 1000 (`--repeat`): every run's time is kept, so the count sizes memory.
fn repeat_count(s: &str) -> Result<usize, String> {
    match s.parse::<usize>() {
        Ok(n) if (1..=registry::sweep::MAX_REPEATS).contains(&n) => Ok(n),
        _ => Err(format!(
            "expected a whole number from 1 to {}, got {s:?}",
            registry::sweep::MAX_REPEATS
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::point_count;

    #[test]
    fn a_point_count_is_a_whole_number_or_a_power_of_ten() {
        assert_eq!(point_count("1e9"), Ok(1_000_000_000));
        assert_eq!(point_count("250000"), Ok(250_000));
        for bad in ["2e9", "1e13", "1e3", "999", "-5", "1.5e8", "lots", "1e"] {
            let e = point_count(bad).unwrap_err();
            assert!(e.contains(bad), "{bad}: {e}");
        }
    }
}
