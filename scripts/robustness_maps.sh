#!/usr/bin/env bash
# The robustness maps of docs/results.md (make robustness-maps): stance robustness on the S0
# standing biped (both engines) and the S1 SIMBICON walkers, each into out/robustness/<name>/,
# its polar plot copied to docs/img/robustness_<name>.png; then the characters' SIMBICON walks
# (Atlas on both engines, MuJoCo's humanoid, fullbody1 on both engines), 8 directions at one phase.
# 11 minutes measured on 2 busy cores for the first four; the characters' about 30 more.
# Names given after the binary: only those maps.
set -euo pipefail
stance=${1:-build/stance}
shift || true
only=" $* "
out=out/robustness
mkdir -p "$out" docs/img
map() {
  local name=$1
  shift
  [ "$only" = "  " ] || [[ "$only" == *" $name "* ]] || return 0
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
# the characters: 0.2 s on the upper body, one phase (a right-foot touchdown) after a 6 s warm-up
map simbicon_atlas_dart scenarios/simbicon_atlas.yaml --engine dart --body utorso --directions 8 \
  --phases 1 --max 800 --tolerance 10 --at 6 --duration 11
map simbicon_atlas_mujoco scenarios/simbicon_atlas.yaml --engine mujoco --body utorso \
  --directions 8 --phases 1 --max 800 --tolerance 10 --at 6 --duration 11
map simbicon_humanoid scenarios/simbicon_humanoid.yaml --body torso --directions 8 --phases 1 \
  --max 400 --tolerance 5 --at 6 --duration 11
map simbicon_fullbody1_mujoco scenarios/simbicon_fullbody1.yaml --engine mujoco --body h_spine \
  --directions 8 --phases 1 --max 400 --tolerance 5 --at 4 --duration 9
map simbicon_fullbody1_dart scenarios/simbicon_fullbody1.yaml --engine dart --body h_spine \
  --directions 8 --phases 1 --max 400 --tolerance 5 --at 4 --duration 9
