#!/usr/bin/env bash
# Builds the pages' scripts: web/dist/viewer.js (three.js and the viewer), that `pointsight view`
# embeds in its pages, and web/dist/results.js (Observable Plot and the results page), that
# `pointsight report` and `tables` embed in each experiment's results.html; bundled by esbuild,
# every package pinned by web/package-lock.json. Installs the npm packages (npm ci) when
# node_modules is missing or older than the lockfile, and rebuilds only when a source is newer
# than a bundle. Safe to re-run.
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
stale=0
for out in dist/viewer.js dist/results.js; do
  if [ ! -f "$out" ] || [ -n "$(find src package-lock.json -newer "$out" -print -quit)" ]; then stale=1; fi
done
if [ "$stale" = 1 ]; then
  echo "web: building dist/viewer.js and dist/results.js"
  npm run -s build
fi
echo "web: ok (dist/viewer.js, $(wc -c <dist/viewer.js) bytes; dist/results.js, $(wc -c <dist/results.js) bytes)"
