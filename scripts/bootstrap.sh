#!/usr/bin/env bash
# Installs what pointsight's build and data need, only where it is missing:
# - libclang-dev (bindgen for the bundled Qhull), via apt-get;
# - python3-venv where Debian's python3 lacks venv (for `just python`);
# - the `just` runner: `pip install rust-just`, else `cargo install just`;
# - Debian package lists, when `apt-get download libcgal-demo` could not find the package.
# Safe to run again; prints what it does.
set -euo pipefail

as_root() {
  if [ "$(id -u)" -eq 0 ]; then "$@"; elif command -v sudo >/dev/null; then sudo "$@"; else
    echo "bootstrap: need root for: $*" >&2; return 1; fi
}

apt_updated=0
apt_update_once() {
  if [ "$apt_updated" -eq 0 ]; then
    echo "bootstrap: apt-get update"
    as_root apt-get update -qq
    apt_updated=1
  fi
}

if command -v apt-get >/dev/null; then
  if ! dpkg -s libclang-dev >/dev/null 2>&1; then
    apt_update_once
    echo "bootstrap: installing libclang-dev"
    as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq libclang-dev >/dev/null
  fi
  # `just python` makes a virtual environment: Debian splits venv/ensurepip out of python3.
  if command -v python3 >/dev/null && ! python3 -c "import venv, ensurepip" >/dev/null 2>&1; then
    apt_update_once
    echo "bootstrap: installing python3-venv"
    as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq python3-venv >/dev/null
  fi
  # `pointsight fetch` downloads libcgal-demo with apt-get: the lists must know it.
  if ! apt-cache show libcgal-demo >/dev/null 2>&1; then
    apt_update_once
  fi
else
  echo "bootstrap: apt-get not found; install libclang (for bindgen) by hand if the build fails" >&2
fi

if ! command -v just >/dev/null; then
  if command -v pip3 >/dev/null || command -v pip >/dev/null; then
    echo "bootstrap: installing just (pip install rust-just)"
    "$(command -v pip3 || command -v pip)" install -q rust-just || true
    hash -r
  fi
  if ! command -v just >/dev/null; then
    echo "bootstrap: installing just (cargo install just)"
    cargo install --locked -q just
  fi
fi
echo "bootstrap: ok ($(just --version))"
