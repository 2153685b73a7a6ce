//! The bodies of the `pointsight` commands, one module per family of commands; the crate
//! root's [`crate::run`] only dispatches to them.
//!
//! - [`data`]: `fetch`, `datasets`, `export`, `inspect`, `views` (datasets and files);
//! - [`catalogue`]: `methods`, `sweeps` (what can be measured and how);
//! - [`visible_view`]: `visible`, `view` (one method's or every method's visible set);
//! - [`lod`]: `lod-build` (an LOD file within a memory limit);
//! - [`experiments`]: `run`, `bench`, `merge`, `report`, `tables`, `scale-cell`.

pub mod catalogue;
pub mod data;
pub mod experiments;
pub mod lod;
pub mod visible_view;

use anyhow::{Context, Result};

/// A `--format` name as a reader format, or an error listing the known ones.
pub fn parse_format(name: Option<String>) -> Result<Option<cloud::io::Format>> {
    name.map(|f| {
        cloud::io::Format::from_name(&f)
            .with_context(|| format!("unknown format {f:?}; known: {}", cloud::io::Format::NAMES))
    })
    .transpose()
}
