#!/usr/bin/env bash
# Installs the Debian packages polishpath's tests use (headless chromium for the
# report's browser test). Does nothing when they are present; when they cannot be
# installed (not root, no apt), says so and the browser test skips with that reason.
set -u
if [ "${1:-}" = "--fast" ]; then
  # for `make bench`: SuiteSparse headers so scikit-sparse (CHOLMOD) can build, serial OpenBLAS
  if [ "$(id -u)" = "0" ] && command -v apt-get >/dev/null 2>&1 && ! dpkg -s libsuitesparse-dev >/dev/null 2>&1; then
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq >/dev/null 2>&1 || true
    apt-get install -y -qq --no-install-recommends libsuitesparse-dev libopenblas0-serial >/dev/null 2>&1 \
      || echo "note: could not install libsuitesparse-dev; benchmarks use SuperLU (slower)." >&2
  fi
  exit 0
fi
if command -v chromium >/dev/null 2>&1 || command -v chromium-browser >/dev/null 2>&1; then
  exit 0
fi
if [ "$(id -u)" != "0" ] || ! command -v apt-get >/dev/null 2>&1; then
  echo "note: chromium not found and cannot apt-get install it here; the browser test will skip." >&2
  exit 0
fi
echo "installing chromium (Debian) for the report's browser test..." >&2
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq >/dev/null 2>&1 || true
apt-get install -y -qq --no-install-recommends chromium >/dev/null 2>&1 \
  || echo "note: apt-get install chromium failed; the browser test will skip." >&2
exit 0
