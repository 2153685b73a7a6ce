# pointsight: run `just` to list the recipes.

set shell := ["bash", "-euo", "pipefail", "-c"]

# List the recipes.
default:
    @just --list

# Install what is missing (libclang-dev, package lists); safe to re-run.
setup:
    scripts/bootstrap.sh

# Put `pointsight` on the PATH: the release binary in PREFIX/bin, the methods and page scripts
# beside it in PREFIX/share/pointsight (docs/install.md); safe to re-run.
install prefix="~/.local": setup web
    scripts/install.sh --prefix {{prefix}}

# Remove what `just install` put into PREFIX.
uninstall prefix="~/.local":
    cargo uninstall -q --root {{prefix}} harness 2>/dev/null || true
    rm -rf {{prefix}}/bin/pointsight {{prefix}}/share/pointsight

# Download the real meshes into bench-data/ (checksummed; does nothing when present).
fetch: setup
    cargo run -q -p harness -- fetch

# Run every test, the real-data checks included, then the Python package's tests and the
# browser tests of the viewer and the results pages in headless Chromium.
test: fetch python web browser
    POINTSIGHT_REAL_DATA=1 cargo test --workspace
    .venv/bin/pytest -q crates/python/tests
    cargo build -q -p harness --bin pointsight
    cd web && node --test --test-concurrency=1 test/viewer.test.js test/results.test.js

# Build the viewer's script web/dist/viewer.js (three.js bundled by esbuild; npm ci when
# needed), which `pointsight view` embeds; safe to re-run.
web:
    scripts/web.sh

# Install Debian's chromium and chromium-driver for the viewer's browser tests (when missing).
browser:
    scripts/browser.sh

# The browser tests alone: the viewer's pages from `pointsight view` and the results pages from
# `pointsight tables`, opened from disk in headless Chromium.
test-browser: web browser
    cargo build -q -p harness --bin pointsight
    cd web && node --test --test-concurrency=1 test/viewer.test.js test/results.test.js

# Build the Python package into .venv for development (maturin develop, release profile,
# the workspace's target folder).
python: setup
    test -x .venv/bin/python || python3 -m venv .venv
    .venv/bin/pip install -q maturin numpy pytest
    VIRTUAL_ENV="$PWD/.venv" .venv/bin/maturin develop -q --release -m crates/python/Cargo.toml

# Install the peers measured beside our methods (methods/*/method.toml with peer_of): Open3D,
# point-cloud-utils, VTK and py3dtiles into .venv; CGAL and PCL from Debian (then built here).
peers: python
    scripts/peers.sh

# Time raycast's cast against point-cloud-utils' on the same rays, alternated (peer: `just peers`).
raycast-vs-pcu *args:
    .venv/bin/python scripts/raycast-vs-pcu.py {{args}}

# Build the release binary.
build: setup
    cargo build --release -p harness

# Run every experiment in full and write reports/ (--quick: the short version, into
# reports-quick/).
bench *args: build web
    target/release/pointsight fetch
    target/release/pointsight bench {{args}}

# The quick benchmark.
bench-quick: (bench "--quick")

# Redraw every table and plot from the CSVs in reports/, without measuring.
tables: build
    target/release/pointsight tables

# Criterion micro-benchmarks of every crate.
criterion *args: setup
    cargo bench --workspace {{args}}
