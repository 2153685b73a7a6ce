#!/usr/bin/env bash
# Builds the viewer's script, web/dist/viewer.js (three.js and the viewer bundled by esbuild,
# both pinned by web/package-lock.json), that `pointsight view` embeds in its pages. Installs
# the npm packages (npm ci) when node_modules is missing or older than the lockfile, and
# rebuilds only when a source is newer than the bundle. Safe to re-run.
set -euo pipefail
cd "$(dirname "$0")/../web"
if ! command -v npm >/dev/null; then
  echo "web: npm not found; install Node.js (Debian: apt-get install nodejs npm)" >&2
  exit 1
fi
if [ ! -f node_modules/.package-lock.json ] || [ package-lock.json -nt node_modules/.package-lock.json ]; then
  echo "web: npm ci"
  npm ci --no-audit --no-fund --loglevel=error
fi
if [ ! -f dist/viewer.js ] || [ -n "$(find src package-lock.json -newer dist/viewer.js -print -quit)" ]; then
  echo "web: building dist/viewer.js"
  npm run -s build
fi
echo "web: ok (dist/viewer.js, $(wc -c <dist/viewer.js) bytes)"
