#!/usr/bin/env bash
# Installs the peers pointsight measures beside its own methods into .venv (made by
# `just python`): Open3D's CPU wheel (`open3d-cpu` from PyPI, installed without its
# visualisation dependencies' heavy tree: numpy, plus plotly, dash and nbformat, which its
# import needs), and the system libraries it loads (libgomp1, libusb-1.0-0). Safe to re-run.
set -euo pipefail
cd "$(dirname "$0")/.."
as_root() {
  if [ "$(id -u)" -eq 0 ]; then "$@"; elif command -v sudo >/dev/null; then sudo "$@"; else
    echo "peers: need root for: $*" >&2; return 1; fi
}
if command -v apt-get >/dev/null; then
  for pkg in libgomp1 libusb-1.0-0; do
    if ! dpkg -s "$pkg" >/dev/null 2>&1; then
      echo "peers: installing $pkg"
      as_root apt-get update -qq
      as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "$pkg" >/dev/null
    fi
  done
fi
if ! .venv/bin/python -c "import open3d" >/dev/null 2>&1; then
  echo "peers: installing open3d-cpu into .venv"
  .venv/bin/pip install -q --no-deps open3d-cpu
  .venv/bin/pip install -q numpy plotly dash nbformat
fi
echo "peers: ok ($(.venv/bin/python -c 'import open3d; print("open3d", open3d.__version__)'))"
