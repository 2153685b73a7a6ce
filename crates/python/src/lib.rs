//! `pointsight` for Python: the native half of the package (`pointsight._native`).
//!
//! Thin bindings in the style of `lazrs-python`: numpy arrays in, numpy arrays out, the
//! library crates and the method registry (`registry`) underneath, so the Python keyword
//! arguments are the same keys as the command line's `--set KEY=VALUE`. Everything a user can
//! get wrong is checked by the Python layer (`python/pointsight/__init__.py`: dtypes, shapes,
//! Open3D objects) or by the libraries, whose typed errors become `ValueError`s here; a panic
//! in a library (a bug) is caught and raised as `RuntimeError`, never propagated across the
//! boundary. Arrays are copied into Rust-owned buffers before the GIL is released, so another
//! thread mutating an input array meanwhile cannot change an answer or race with it.
//!
//! The bindings are behind the cargo feature `python` (maturin turns it on with pyo3's
//! `extension-module`), so `cargo test --workspace` builds this crate without libpython.

#[cfg(feature = "python")]
mod bindings;
