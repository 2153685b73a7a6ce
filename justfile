# pointsight: run `just` to list the recipes.

set shell := ["bash", "-euo", "pipefail", "-c"]

# List the recipes.
default:
    @just --list

# Install what is missing (libclang-dev, package lists); safe to re-run.
setup:
    scripts/bootstrap.sh

# Download the real meshes into bench-data/ (checksummed; does nothing when present).
fetch: setup
    cargo run -q -p harness -- fetch

# Run every test, the real-data checks included.
test: fetch
    POINTSIGHT_REAL_DATA=1 cargo test --workspace

# Build the release binary.
build: setup
    cargo build --release -p harness

# Run every experiment in full and write reports/ (add --quick for the short version).
bench *args: build fetch
    target/release/pointsight bench {{args}}

# The quick benchmark.
bench-quick: (bench "--quick")

# Redraw every table and plot from the CSVs in reports/, without measuring.
tables: build
    target/release/pointsight tables

# Criterion micro-benchmarks of every crate.
criterion *args: setup
    cargo bench --workspace {{args}}
