#!/usr/bin/env bash
# with the include directories the model layer's library compiles with, a source in src/motion
# includes its own layer's and the layers' below (compiles) but not the engine above (fails).
#   upward_include.sh CXX "DIR;DIR;..."
set -u
cxx=$1
IFS=';' read -r -a dirs <<<"$2"
flags=()
for d in "${dirs[@]}"; do flags+=(-I "$d"); done
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
printf '#include "motion/bvh.h"\n#include "params/params.h"\n#include "core/error.h"\n' >"$tmp/down.cc"
printf '#include "engine/engine.h"\n' >"$tmp/up.cc"
"$cxx" -std=c++20 -fsyntax-only "${flags[@]}" "$tmp/down.cc" ||
  { echo "FAIL: a downward include does not compile"; exit 1; }
if "$cxx" -std=c++20 -fsyntax-only "${flags[@]}" "$tmp/up.cc" 2>"$tmp/err"; then
  echo "FAIL: the model layer can include engine/engine.h"
  exit 1
fi
grep -Eq "engine/engine.h(: No such file|' file not found)" "$tmp/err" || { cat "$tmp/err"; exit 1; }
echo "ok: model -> engine does not compile"
