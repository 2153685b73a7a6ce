#!/usr/bin/env bash
# Installs the peers pointsight measures beside its own methods (methods/*/method.toml whose
# summary starts with "peer:"), only what is missing, and says how long each took. Safe to
# re-run.
# - open3d-hpr: Open3D's CPU wheel (`open3d-cpu` from PyPI) into .venv, without its
#   visualisation dependencies' heavy tree (numpy, plus plotly, dash and nbformat, which its
#   import needs), and the system libraries it loads (libgomp1, libusb-1.0-0);
# - cgal-hpr: Debian's libcgal-dev (header-only) with gmp and mpfr, and g++, then builds
#   methods/cgal-hpr/cgal_hpr;
# - pcu-raycast: point-cloud-utils (PyPI, Embree inside the wheel) into .venv;
# - vtk-zbuffer: VTK's wheel (PyPI `vtk`) into .venv, and what its offscreen EGL window needs
#   on a machine without a display: Debian's libegl1, libegl-mesa0, libgbm1 and
#   libgl1-mesa-dri (Mesa's software rasteriser);
# - pcl-voxel: Debian's libpcl-dev (about 400 packages, 1.1 GB installed, 150 s on the
#   development machine), then builds methods/pcl-voxel/pcl_voxel;
# - py3dtiles-lod: py3dtiles with its PLY reader (`py3dtiles[ply]`, PyPI) into .venv;
# - copc-lod: copc_converter from crates.io (`cargo install --locked`, pinned) and the peer's
#   own program (methods/copc-lod, its committed Cargo.lock), both into .tools/bin (about
#   2.5 minutes on 2 cores, most of it copc_converter's build).
# Debian packages go in with --no-install-recommends. The peers share one protocol helper per
# language in methods/_shared/ (the Python peers import it, the C++ ones include it).
set -euo pipefail
cd "$(dirname "$0")/.."
as_root() {
  if [ "$(id -u)" -eq 0 ]; then "$@"; elif command -v sudo >/dev/null; then sudo "$@"; else
    echo "peers: need root for: $*" >&2; return 1; fi
}
apt_updated=0
apt_install() {
  local missing=()
  for pkg in "$@"; do
    dpkg -s "$pkg" >/dev/null 2>&1 || missing+=("$pkg")
  done
  [ "${#missing[@]}" -eq 0 ] && return 0
  command -v apt-get >/dev/null || { echo "peers: no apt-get to install ${missing[*]}" >&2; return 1; }
  if [ "$apt_updated" -eq 0 ]; then as_root apt-get update -qq; apt_updated=1; fi
  echo "peers: installing ${missing[*]}"
  as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
    "${missing[@]}" >/dev/null
}
# The C++ peers' shared protocol helper (header-only): a change rebuilds them.
protocol_hpp=methods/_shared/pointsight_protocol.hpp
timed() {
  local name=$1 start=$SECONDS
  shift
  "$@"
  echo "peers: $name ready in $((SECONDS - start)) s"
}

open3d() {
  apt_install libgomp1 libusb-1.0-0
  if ! .venv/bin/python -c "import open3d" >/dev/null 2>&1; then
    echo "peers: installing open3d-cpu into .venv"
    .venv/bin/pip install -q --no-deps open3d-cpu
    .venv/bin/pip install -q numpy plotly dash nbformat
  fi
}

cgal() {
  apt_install g++ libcgal-dev libgmp-dev libmpfr-dev
  local dir=methods/cgal-hpr
  if [ ! -x "$dir/cgal_hpr" ] || [ "$dir/cgal_hpr.cpp" -nt "$dir/cgal_hpr" ] \
    || [ "$protocol_hpp" -nt "$dir/cgal_hpr" ]; then
    echo "peers: building $dir/cgal_hpr"
    # No FMA contraction: the flipped coordinates must be bit-identical to pointsight's.
    g++ -O2 -std=c++17 -ffp-contract=off -DNDEBUG -o "$dir/cgal_hpr.tmp" "$dir/cgal_hpr.cpp" \
      -lgmp -lmpfr
    mv "$dir/cgal_hpr.tmp" "$dir/cgal_hpr"
  fi
}

pcu() {
  if ! .venv/bin/python -c "import point_cloud_utils" >/dev/null 2>&1; then
    echo "peers: installing point-cloud-utils into .venv"
    .venv/bin/pip install -q numpy point-cloud-utils
  fi
}

vtk_() {
  apt_install libegl1 libegl-mesa0 libgbm1 libgl1-mesa-dri
  if ! .venv/bin/python -c "import vtk" >/dev/null 2>&1; then
    echo "peers: installing vtk into .venv"
    .venv/bin/pip install -q numpy vtk
  fi
  local window
  window=$(cd methods/vtk-zbuffer && ../../.venv/bin/python zbuffer.py --points /dev/null \
    --window-class 2>/dev/null | tail -1 || true)
  echo "peers: VTK opens a $window"
}

pcl() {
  apt_install g++ libpcl-dev
  local dir=methods/pcl-voxel inc
  inc=$(ls -d /usr/include/pcl-1.* | sort -V | tail -1)
  if [ ! -x "$dir/pcl_voxel" ] || [ "$dir/pcl_voxel.cpp" -nt "$dir/pcl_voxel" ] \
    || [ "$protocol_hpp" -nt "$dir/pcl_voxel" ]; then
    echo "peers: building $dir/pcl_voxel"
    g++ -O2 -std=c++17 -DNDEBUG -I"$inc" -I/usr/include/eigen3 -o "$dir/pcl_voxel.tmp" \
      "$dir/pcl_voxel.cpp" -lpcl_filters -lpcl_common
    mv "$dir/pcl_voxel.tmp" "$dir/pcl_voxel"
  fi
}

py3dtiles_() {
  if ! .venv/bin/python -c "import py3dtiles, plyfile" >/dev/null 2>&1; then
    echo "peers: installing py3dtiles[ply] into .venv"
    .venv/bin/pip install -q "py3dtiles[ply]"
  fi
}

copc() {
  local version=0.16.0 dir=methods/copc-lod
  if [ "$(.tools/bin/copc_converter --version 2>/dev/null)" != "copc_converter $version" ]; then
    echo "peers: cargo install copc_converter $version into .tools"
    cargo install -q --locked --version "$version" --root .tools copc_converter
  fi
  if [ ! -x .tools/bin/copc-lod ] || [ -n "$(find "$dir/src" "$dir/Cargo.toml" "$dir/Cargo.lock" \
      -newer .tools/bin/copc-lod)" ]; then
    echo "peers: building $dir into .tools/bin"
    cargo install -q --locked --path "$dir" --root .tools --target-dir .tools/target --force
  fi
}

test -x .venv/bin/python || python3 -m venv .venv
timed open3d-hpr open3d
timed cgal-hpr cgal
timed pcu-raycast pcu
timed vtk-zbuffer vtk_
timed pcl-voxel pcl
timed py3dtiles-lod py3dtiles_
timed copc-lod copc
echo "peers: ok ($(.venv/bin/python -c 'import open3d; print("open3d", open3d.__version__)'),"\
" $(methods/cgal-hpr/cgal_hpr --version),"\
" point-cloud-utils $(.venv/bin/python -c 'import importlib.metadata as m; print(m.version("point-cloud-utils"))'),"\
" vtk $(.venv/bin/python -c 'import vtk; print(vtk.vtkVersion.GetVTKVersion())'),"\
" $(methods/pcl-voxel/pcl_voxel --version),"\
" py3dtiles $(.venv/bin/python -c 'import importlib.metadata as m; print(m.version("py3dtiles"))'),"\
" $(.tools/bin/copc-lod --version))"
