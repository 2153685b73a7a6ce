//! The command line (clap). The output contract of each subcommand is documented on it and
//! fixed: later experiments and external checks parse it.

use std::path::PathBuf;

use clap::{Parser, Subcommand};

/// pointsight: a benchmark harness for point-cloud visibility and level-of-detail methods.
#[derive(Debug, Parser)]
#[command(name = "pointsight", version, about, long_about = None)]
pub struct Cli {
    /// Folder of fetched data.
    #[arg(
        long,
        global = true,
        env = "POINTSIGHT_DATA",
        default_value = "bench-data"
    )]
    pub data_dir: PathBuf,
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// Subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Download the real meshes (Debian's libcgal-demo) into the data folder, checksummed.
    Fetch,
    /// One line per dataset: name, number of points, availability, description.
    Datasets,
    /// The visibility methods and their --set parameters.
    Methods,
    /// Write a dataset's points as binary little-endian PLY (x y z, double).
    Export {
        /// Dataset name.
        #[arg(long)]
        dataset: String,
        /// Output file.
        #[arg(long)]
        out: PathBuf,
    },
    /// A dataset's views as CSV: view,eye_x,eye_y,eye_z,target_x,target_y,target_z,up_x,up_y,up_z,fov_y_deg,width,height.
    Views {
        /// Dataset name.
        #[arg(long)]
        dataset: String,
        /// Output file (standard output when absent).
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Run one method on one view; write the visible indices, ascending, one per line. The last
    /// line on stdout is `method=M points=N visible=K seconds=T` (T: the method's compute time).
    Visible {
        /// Dataset name.
        #[arg(long)]
        dataset: String,
        /// View index.
        #[arg(long)]
        view: usize,
        /// Method name (see `pointsight methods`).
        #[arg(long)]
        method: String,
        /// Method parameter, KEY=VALUE (repeatable).
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
        /// Output file for the indices.
        #[arg(long)]
        out: PathBuf,
        /// Also score the visible set against the reference (printed before the last line).
        #[arg(long)]
        score: bool,
    },
    /// Run an experiment: results.csv, plots and tables into its output folder.
    Run {
        /// Experiment name.
        experiment: String,
        /// Comma-separated datasets (default: the experiment's own list).
        #[arg(long, value_delimiter = ',')]
        datasets: Option<Vec<String>>,
        /// Fewer datasets, views and repeats.
        #[arg(long)]
        quick: bool,
        /// Output folder (default reports/EXPERIMENT).
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Run every experiment with its default datasets into reports/, then write the report.
    Bench {
        /// Quick mode for every experiment.
        #[arg(long)]
        quick: bool,
        /// Comma-separated datasets for every experiment instead of their own lists (for
        /// example the synthetic ones, which need no download).
        #[arg(long, value_delimiter = ',')]
        datasets: Option<Vec<String>>,
        /// Reports folder.
        #[arg(long, default_value = "reports")]
        reports: PathBuf,
    },
    /// Assemble reports/README.md from the experiments' results.
    Report {
        /// Reports folder.
        #[arg(long, default_value = "reports")]
        reports: PathBuf,
    },
    /// Redraw every experiment's tables and plots from its CSVs (no measuring), then the report.
    Tables {
        /// Reports folder.
        #[arg(long, default_value = "reports")]
        reports: PathBuf,
    },
}
