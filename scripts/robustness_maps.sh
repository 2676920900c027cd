#!/usr/bin/env bash
# The README's robustness maps (make robustness-maps): stance robustness on the S0 standing biped
# (both engines) and the S1 SIMBICON walkers, each into out/robustness/<name>/, its polar plot
# copied to docs/img/robustness_<name>.png. 11 minutes measured on 2 busy cores.
set -euo pipefail
stance=${1:-build/stance}
out=out/robustness
mkdir -p "$out" docs/img
map() {
  local name=$1
  shift
  echo "== $name: stance robustness $*"
  "$stance" robustness "$@" --quiet --out "$out/$name"
  cp "$out/$name/robustness.png" "docs/img/robustness_$name.png"
}
map biped_stand_mujoco scenarios/biped_stand.yaml --engine mujoco --body h_spine \
  --directions 8 --phases 2 --max 400 --tolerance 4
map biped_stand_dart scenarios/biped_stand.yaml --engine dart --body h_spine \
  --directions 8 --phases 2 --max 400 --tolerance 4
map simbicon_walk scenarios/simbicon_walk.yaml --body torso --phases 4 --max 800 --tolerance 5 \
  --at 3 --duration 8
map simbicon_walk_3d scenarios/simbicon_walk_3d.yaml --body torso --directions 8 --phases 4 \
  --max 800 --tolerance 5 --at 3 --duration 8
