#!/usr/bin/env bash
# Installs pointsight into a prefix: the binary in PREFIX/bin/, and beside it, in
# PREFIX/share/pointsight/, what it reads at run time from outside a clone (harness::paths):
#   methods/   a copy of this clone's methods/ (external methods and peers, with the peers'
#              programs `just peers` built in their folders);
#   web/       the page scripts web/dist/*.js (`just web`: viewer.js, and results.js where it
#              is built), which `pointsight view` and the report's pages embed;
#   examples/  a copy of this clone's examples/ (the small files the docs' examples use:
#              `cp -r PREFIX/share/pointsight/examples .` and they run as written);
#   .venv      a symbolic link to this clone's .venv when there is one (the Python peers'
#              method.toml name ../../.venv/bin/python, relative to their folder).
# The data folder is not installed: `pointsight fetch` fills $XDG_DATA_HOME/pointsight (or
# ~/.local/share/pointsight) when run outside a clone.
#
# Usage: scripts/install.sh [--prefix PREFIX] [--bin FILE] [--web-dist DIR]
#   --prefix PREFIX  default ~/.local (then ~/.local/bin must be on PATH)
#   --bin FILE       install this built binary instead of `cargo install --path crates/harness`
#   --web-dist DIR   the built page scripts (default web/dist)
# Re-running replaces the installed files (methods/, web/ and examples/ whole). Uninstall:
#   rm -rf PREFIX/bin/pointsight PREFIX/share/pointsight
# (and PREFIX/.crates.toml, PREFIX/.crates2.json if nothing else was installed there by cargo).
set -euo pipefail
clone="$(cd "$(dirname "$0")/.." && pwd)"
prefix="${HOME:?HOME is not set; give --prefix}/.local"
bin=""
web_dist="$clone/web/dist"
while [ $# -gt 0 ]; do
  case "$1" in
    --prefix) prefix="$2"; shift 2 ;;
    --prefix=*) prefix="${1#*=}"; shift ;;
    --bin) bin="$2"; shift 2 ;;
    --bin=*) bin="${1#*=}"; shift ;;
    --web-dist) web_dist="$2"; shift 2 ;;
    --web-dist=*) web_dist="${1#*=}"; shift ;;
    -h | --help) sed -n '2,21p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "install: unknown argument $1 (see --help)" >&2; exit 2 ;;
  esac
done
case "$prefix" in
  /*) ;;
  *) prefix="$PWD/$prefix" ;;
esac
share="$prefix/share/pointsight"

# The binary.
mkdir -p "$prefix/bin"
if [ -n "$bin" ]; then
  install -m 0755 "$bin" "$prefix/bin/pointsight.partial"
  mv -f "$prefix/bin/pointsight.partial" "$prefix/bin/pointsight"
else
  cargo install --locked --quiet --path "$clone/crates/harness" --root "$prefix" --force
fi

# Beside it: each folder staged, then swapped in, so a failed copy leaves the previous one.
mkdir -p "$share"
replace() { # replace NAME SOURCE_DIR [FILES...]: share/NAME becomes a copy
  local name="$1" src="$2"
  shift 2
  rm -rf "$share/.$name.partial"
  mkdir -p "$share/.$name.partial"
  if [ $# -eq 0 ]; then
    cp -R "$src/." "$share/.$name.partial/"
  else
    cp "$@" "$share/.$name.partial/"
  fi
  find "$share/.$name.partial" -name __pycache__ -prune -exec rm -rf {} +
  rm -rf "$share/$name"
  mv "$share/.$name.partial" "$share/$name"
}
replace methods "$clone/methods"
replace examples "$clone/examples"
shopt -s nullglob
scripts=("$web_dist"/*.js)
shopt -u nullglob
if [ ${#scripts[@]} -gt 0 ]; then
  replace web "$web_dist" "${scripts[@]}"
else
  rm -rf "$share/web"
  echo "install: no page script in $web_dist: \`pointsight view\` and the report's viewer pages" \
    "will say so; run \`just web\`, then install again" >&2
fi
if [ -d "$clone/.venv" ]; then
  ln -sfn "$clone/.venv" "$share/.venv"
else
  rm -f "$share/.venv"
fi

version="$("$prefix/bin/pointsight" --version)"
echo "installed $version: $prefix/bin/pointsight, $share/{methods,web,examples}"
case ":$PATH:" in
  *":$prefix/bin:"*) ;;
  *) echo "note: $prefix/bin is not on PATH; add it (e.g. export PATH=\"$prefix/bin:\$PATH\")" ;;
esac
