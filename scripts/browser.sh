#!/usr/bin/env bash
# Installs the headless browser the viewer's tests drive: Debian's `chromium` and
# `chromium-driver` (apt-get, --no-install-recommends), only when missing. Safe to re-run.
set -euo pipefail
as_root() {
  if [ "$(id -u)" -eq 0 ]; then "$@"; elif command -v sudo >/dev/null; then sudo "$@"; else
    echo "browser: need root for: $*" >&2; return 1; fi
}
missing=()
for pkg in chromium chromium-driver; do
  dpkg -s "$pkg" >/dev/null 2>&1 || missing+=("$pkg")
done
if [ "${#missing[@]}" -gt 0 ]; then
  if ! command -v apt-get >/dev/null; then
    echo "browser: apt-get not found; install chromium by hand for the viewer's tests" >&2
    exit 1
  fi
  echo "browser: installing ${missing[*]}"
  as_root apt-get -o DPkg::Lock::Timeout=600 update -qq
  as_root env DEBIAN_FRONTEND=noninteractive apt-get -o DPkg::Lock::Timeout=600 install -y -qq --no-install-recommends \
    "${missing[@]}" >/dev/null
fi
echo "browser: ok ($(chromium --version 2>/dev/null || echo 'chromium: version unknown'))"
