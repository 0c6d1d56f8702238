#!/usr/bin/env bash
# Fetches LinuxCNC's standalone G-code interpreter `rs274` (Debian package
# linuxcnc-uspace) into a cache folder WITHOUT installing it: installing the package
# pulls systemd and ~125 packages, while the interpreter alone needs the package's own
# libraries plus libboost-python1.74.0. So: `apt-get download` the .deb files and
# unpack them with `dpkg -x`; every library `ldd` still reports missing is fetched the
# same way. A wrapper `rs274` that sets LD_LIBRARY_PATH is written into the cache.
#
# Idempotent and quiet when done already. Prints nothing but a note when it cannot
# fetch (no apt-get, no network): the tests that need rs274 then skip with that reason.
#
#   scripts/get-linuxcnc.sh            fetch if needed (quiet when present)
#   scripts/get-linuxcnc.sh --path     print the wrapper's path (fetch first if needed)
#
# Cache: $POLISHPATH_CACHE/linuxcnc (default ${XDG_CACHE_HOME:-$HOME/.cache}/polishpath/linuxcnc).
set -u
CACHE="${POLISHPATH_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/polishpath}/linuxcnc"
ROOT="$CACHE/root"
WRAP="$CACHE/rs274"
LIBS="$ROOT/usr/lib:$ROOT/usr/lib/x86_64-linux-gnu:$ROOT/lib/x86_64-linux-gnu"

say_path() { [ "${1:-}" = "--path" ] && echo "$WRAP"; }

smoke() {  # the wrapper runs a two-line program with a tool table: exit 0
  local d; d="$(mktemp -d)"
  printf 'T1 P1 D0.0 Z0.0 ;\n' >"$d/t.tbl"
  printf 'G21 G90\nG01 X1 F100\nM30\n' >"$d/a.ngc"
  "$WRAP" -t "$d/t.tbl" -g "$d/a.ngc" "$d/out" >/dev/null 2>&1 && grep -q STRAIGHT_FEED "$d/out"
  local rc=$?; rm -rf "$d"; return $rc
}

if [ -x "$WRAP" ] && smoke; then say_path "$@"; exit 0; fi

if ! command -v apt-get >/dev/null 2>&1 || ! command -v dpkg >/dev/null 2>&1; then
  echo "note: no apt-get/dpkg here: cannot fetch LinuxCNC's rs274; the tests that need it will skip." >&2
  exit 0
fi

mkdir -p "$CACHE/debs" "$ROOT" || { echo "note: cannot create $CACHE; rs274 tests will skip." >&2; exit 0; }

fetch() {  # fetch PACKAGE: download it (unless cached) and unpack it into $ROOT
  local pkg="$1" deb
  deb="$(ls "$CACHE/debs/${pkg}"_*.deb 2>/dev/null | head -1)"
  if [ -z "$deb" ]; then
    if ! (cd "$CACHE/debs" && apt-get download -qq "$pkg" >/dev/null 2>&1); then
      # stale package lists: refresh once (root only) and try again
      [ "$(id -u)" = "0" ] || return 1
      apt-get update -qq >/dev/null 2>&1
      (cd "$CACHE/debs" && apt-get download -qq "$pkg" >/dev/null 2>&1) || return 1
    fi
    deb="$(ls "$CACHE/debs/${pkg}"_*.deb 2>/dev/null | head -1)"
  fi
  [ -n "$deb" ] && dpkg -x "$deb" "$ROOT"
}

# Debian package holding each library rs274 links against (Debian 12 names); only the
# ones `ldd` reports missing are fetched, so a full desktop fetches just the first two.
pkg_of() {
  case "$1" in
    libboost_python3*) echo libboost-python1.74.0 ;;
    libpython3.11*) echo libpython3.11 ;;
    libedit.so*) echo libedit2 ;;
    libtirpc.so*) echo libtirpc3 ;;
    libexpat.so*) echo libexpat1 ;;
    libbsd.so*) echo libbsd0 ;;
    libmd.so*) echo libmd0 ;;
    libtinfo.so*) echo libtinfo6 ;;
    libgssapi_krb5*) echo libgssapi-krb5-2 ;;
    libkrb5.so*) echo libkrb5-3 ;;
    libk5crypto*) echo libk5crypto3 ;;
    libkrb5support*) echo libkrb5support0 ;;
    libcom_err*) echo libcomerr2 ;;
    libkeyutils*) echo libkeyutils1 ;;
    libz.so*) echo zlib1g ;;
    *) echo "" ;;
  esac
}

echo "fetching LinuxCNC's rs274 interpreter (Debian linuxcnc-uspace, unpacked, not installed) into $CACHE ..." >&2
fetch linuxcnc-uspace || { echo "note: apt-get download linuxcnc-uspace failed (no network or no such package); rs274 tests will skip." >&2; exit 0; }
for _ in 1 2 3 4; do
  missing="$(LD_LIBRARY_PATH="$LIBS" ldd "$ROOT/usr/bin/rs274" 2>/dev/null | awk '/not found/ {print $1}' | sort -u)"
  [ -z "$missing" ] && break
  for lib in $missing; do
    pkg="$(pkg_of "$lib")"
    [ -n "$pkg" ] && fetch "$pkg" || echo "note: cannot fetch the package holding $lib." >&2
  done
done

cat >"$WRAP" <<EOF
#!/bin/sh
# LinuxCNC's standalone interpreter, unpacked by polishpath's scripts/get-linuxcnc.sh
LD_LIBRARY_PATH="$LIBS\${LD_LIBRARY_PATH:+:\$LD_LIBRARY_PATH}" exec "$ROOT/usr/bin/rs274" "\$@"
EOF
chmod +x "$WRAP"
if ! smoke; then
  echo "note: rs274 was unpacked but does not run here (see: LD_LIBRARY_PATH=$LIBS ldd $ROOT/usr/bin/rs274); rs274 tests will skip." >&2
  rm -f "$WRAP"
  exit 0
fi
cat >&2 <<EOF
LinuxCNC's rs274 is ready: $WRAP
Run it on a G-code file (a tool table is required, one line such as 'T1 P1 D0 Z0 ;'):
  $WRAP -t TOOL_TABLE -g FILE.ngc OUT
OUT then holds the canonical machining calls (STRAIGHT_FEED, SET_FEED_RATE, ...); errors go to stderr, exit 1.
EOF
say_path "$@"
exit 0
