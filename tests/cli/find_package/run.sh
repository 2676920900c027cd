#!/usr/bin/env bash
# make install into a temporary prefix, then configure and build the outside project beside
# this script against it with find_package(stance), and run it on scenarios/pd_hold.yaml.
#   run.sh BUILD_DIR SOURCE_DIR [COMPILER_LAUNCHER]
set -euo pipefail
build=$1
source=$2
launcher=${3:-}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

cmake --install "$build" --prefix "$tmp/prefix" > "$tmp/install.log"
test -f "$tmp/prefix/lib/cmake/stance/stanceConfig.cmake"
test -f "$tmp/prefix/lib/cmake/stance/stanceConfigVersion.cmake"
test -f "$tmp/prefix/include/stance/engine/engine.h"
test -x "$tmp/prefix/bin/stance"

args=(-DCMAKE_PREFIX_PATH="$tmp/prefix" -DCMAKE_BUILD_TYPE=Release)
if [[ -n "$launcher" ]]; then args+=(-DCMAKE_CXX_COMPILER_LAUNCHER="$launcher"); fi
cmake -S "$source/tests/cli/find_package" -B "$tmp/build" "${args[@]}" > "$tmp/configure.log" ||
  { cat "$tmp/configure.log"; exit 1; }
cmake --build "$tmp/build" > "$tmp/build.log" 2>&1 || { cat "$tmp/build.log"; exit 1; }
"$tmp/build/run_pd_hold" "$source/scenarios/pd_hold.yaml" "$tmp/out"
