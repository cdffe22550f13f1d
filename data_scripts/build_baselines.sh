#!/bin/sh
# Build the two external baselines into .cache/third_party/ (ignored by git):
#   .cache/third_party/bin/bff-command-line   Boundary First Flattening CLI (Sawhney & Crane 2018), MIT
#   .cache/third_party/bin/OptCuts_bin        OptCuts (Li et al. 2018), MIT; bundles Triangle (research use only)
#
# Sources: the offline bundles in ../shared/third_party (THIRD_PARTY=DIR to point elsewhere), whose
# build_bff.sh / build_optcuts.sh are the source of truth for the flags; without them, upstream is
# cloned from GitHub at the pinned commits below and built with the same flags (OptCuts then downloads
# its own TBB at configure time, as upstream does).
#
# Debian/Ubuntu packages needed (INSTALL_DEPS=1 runs apt-get for them):
#   build-essential cmake patch git libsuitesparse-dev libtbb-dev libglfw3-dev libgl1-mesa-dev
#
# Usage: sh data_scripts/build_baselines.sh            (make baselines)
#   JOBS=N      parallel make jobs (default 2)
#   ONLY=bff    or ONLY=optcuts: build one of the two
#   FORCE=1     rebuild even when the binary exists
set -eu
ROOT=$(cd "$(dirname "$0")/.." && pwd)
DEST=${DEST:-$ROOT/.cache/third_party}
THIRD_PARTY=${THIRD_PARTY:-$ROOT/../shared/third_party}
JOBS=${JOBS:-2}
ONLY=${ONLY:-}
FORCE=${FORCE:-0}
export JOBS

BFF_URL=https://github.com/GeometryCollective/boundary-first-flattening.git
BFF_COMMIT=6924b2fd22fc26cb25d532a8130a0b44454dbeb0
OPTCUTS_URL=https://github.com/liminchen/OptCuts.git
OPTCUTS_COMMIT=cd2302671af7954f263b0ea93d8419aa943d54be

if [ "${INSTALL_DEPS:-0}" = 1 ]; then
  apt-get install -y build-essential cmake patch git libsuitesparse-dev libtbb-dev libglfw3-dev libgl1-mesa-dev
fi

mkdir -p "$DEST/bin" "$DEST/src"
if [ -d "$THIRD_PARTY" ] && [ -f "$THIRD_PARTY/build_bff.sh" ]; then
  THIRD_PARTY=$(cd "$THIRD_PARTY" && pwd)
  echo "== sources: offline bundles in $THIRD_PARTY"
  if command -v sha256sum >/dev/null 2>&1 && [ -f "$THIRD_PARTY/SHA256SUMS" ]; then
    (cd "$THIRD_PARTY" && sha256sum --quiet -c SHA256SUMS) || { echo "sha256 mismatch in $THIRD_PARTY" >&2; exit 1; }
  fi
  OFFLINE=1
else
  echo "== no offline bundles at $THIRD_PARTY: cloning upstream from GitHub"
  OFFLINE=0
fi

# clone URL COMMIT DIR: a shallow-as-possible checkout of one commit, with submodules.
clone() {
  if [ ! -d "$3/.git" ]; then
    rm -rf "$3"
    git clone --quiet "$1" "$3"
  fi
  git -C "$3" fetch --quiet origin "$2" 2>/dev/null || true
  git -C "$3" checkout --quiet "$2"
  git -C "$3" submodule update --quiet --init --recursive
}

build_bff() {
  out=$DEST/bin/bff-command-line
  if [ -x "$out" ] && [ "$FORCE" != 1 ]; then echo "== bff-command-line: already built ($out)"; return; fi
  echo "== building bff-command-line (Boundary First Flattening @ ${BFF_COMMIT%${BFF_COMMIT#???????}})"
  work=$DEST/src/bff
  rm -rf "$work"
  mkdir -p "$work"
  if [ "$OFFLINE" = 1 ]; then
    (cd "$work" && sh "$THIRD_PARTY/build_bff.sh" "$THIRD_PARTY/bff-cli-src-6924b2f.tar.gz" "$work")
  else
    src=$work/boundary-first-flattening
    clone "$BFF_URL" "$BFF_COMMIT" "$src"
    # the option is BFF_BUILD_GUI (upstream's Dockerfile passes -DBUILD_GUI=Off, which is ignored)
    nice -n 10 cmake -S "$src" -B "$src/build" -DCMAKE_BUILD_TYPE=Release -DBFF_BUILD_CLI=ON -DBFF_BUILD_GUI=OFF
    nice -n 10 make -C "$src/build" -j"$JOBS" bff-command-line
  fi
  cp "$work/boundary-first-flattening/build/bff-command-line" "$out"
  echo "== built $out"
}

build_optcuts() {
  out=$DEST/bin/OptCuts_bin
  if [ -x "$out" ] && [ "$FORCE" != 1 ]; then echo "== OptCuts_bin: already built ($out)"; return; fi
  echo "== building OptCuts_bin (OptCuts @ ${OPTCUTS_COMMIT%${OPTCUTS_COMMIT#???????}})"
  work=$DEST/src/optcuts
  rm -rf "$work"
  mkdir -p "$work"
  if [ "$OFFLINE" = 1 ]; then
    (cd "$work" && sh "$THIRD_PARTY/build_optcuts.sh" "$THIRD_PARTY/optcuts-src-cd23026.tar.gz" "$work")
  else
    src=$work/OptCuts
    clone "$OPTCUTS_URL" "$OPTCUTS_COMMIT" "$src"
    # upstream as is: its cmake downloads TBB (and uses the vendored libigl/glfw)
    nice -n 10 cmake -S "$src" -B "$src/build" -DCMAKE_BUILD_TYPE=Release
    nice -n 10 make -C "$src/build" -j"$JOBS" OptCuts_bin
  fi
  cp "$work/OptCuts/build/OptCuts_bin" "$out"
  echo "== built $out"
}

case "$ONLY" in
  ""|bff) build_bff ;;
esac
case "$ONLY" in
  ""|optcuts) build_optcuts ;;
esac

cat <<'EOF'
== LICENCES: BFF (MIT), RectangleBinPack (public domain), OptCuts (MIT), libigl and Eigen (MPL2).
== NOTE: OptCuts bundles Jonathan Shewchuk's Triangle (ext/libigl/external/triangle), which is
==       free for RESEARCH USE ONLY: no commercial use without an arrangement with its author.
==       OptCuts_bin is therefore for non-commercial research; do not redistribute it commercially.
== Binaries in .cache/third_party/bin/ (found automatically; $NEURALUV_BFF / $NEURALUV_OPTCUTS override).
EOF
