//! `cloud`: the data every pointsight method shares.
//!
//! - [`PointCloud`] (f64 positions, optional normals, colours, texture coordinates and surface
//!   provenance) and [`TriMesh`], borrowed by the method crates without copies;
//! - readers for PLY, OFF and XYZ and a binary PLY writer ([`io`]), with typed errors that name
//!   the file and the line or byte ([`ReadError`]);
//! - area-weighted seeded surface sampling ([`sample`]), k-NN normal estimation ([`normals`])
//!   over canonical neighbourhoods ([`knn`]: ties by index, coincident points in bounded work);
//! - the [`Camera`] (pinhole, orthographic, spherical; its JSON form) and deterministic
//!   viewpoint sets ([`views`]);
//! - the memory guard for allocations sized by user input ([`memory`]);
//! - lossless recentring of georeferenced clouds ([`recentre`]);
//! - synthetic scenes with analytic visibility ([`synth`]) and seeded random streams ([`rng`]);
//! - the front/back buffer with a background thread of seed 000 §5 ([`double_buffer`]);
//! - scratch files for out-of-core builds ([`spill`]) and the method-neutral out-of-core
//!   preparation of an LOD build: chunks, normals, leaf radius ([`ooc`]); scratch and staging
//!   paths named after their owner, registered for removal on a signal, found again after a
//!   crash ([`scratch`]).
//!
//! This crate knows nothing of any method, of experiments, plots or the command line.

pub mod bbox;
pub mod camera;
pub mod compact;
pub mod degrade;
pub mod double_buffer;
pub mod eigen3;
pub mod error;
pub mod io;
pub mod knn;
pub mod knn_grid;
pub mod lod_file;
pub mod memory;
pub mod mesh;
pub mod normals;
pub mod ooc;
pub mod orient;
pub mod points;
pub mod recentre;
pub mod rng;
pub mod sample;
pub mod scratch;
pub mod spacing;
pub mod spill;
pub mod synth;
pub mod views;

pub use bbox::Aabb;
pub use camera::{Camera, Model, Projection};
pub use error::{Error, Location, ReadError, ReadErrorKind, Result};
pub use glam;
pub use kiddo;
pub use mesh::TriMesh;
pub use points::{PointCloud, SurfaceSample};
pub use views::ViewSpec;
