#!/usr/bin/env bash
# make eval-track: the planner's tracking matrix, as batches of `stance bvh track`. Every clip under
# one parameter set: the defaults at planner seeds 1-3, then at seed 1 kp x0.8, kp x1.2, a 1 ms
# and a 2 ms timestep (left out where it is the group's own model step: that is seed 1 again).
# The clips, in groups that share their options (one batch per group and
# setting; a group is a folder of links to its clips, named as the table names them):
#   looped    the synthetic walk and run, and mass_walk, looped for 20 s
#   dataset   every clip in ../shared/data/bvh (the Bandai Namco clips included), once each
#             (mass_walk here is mass_walk_once)
#   mass_walk_humanoid, synthetic_walk_humanoid
#             the clip on MuJoCo's humanoid.xml through its joint map, looped for 10 s
# Writes OUT/<group>/<setting>/ (a batch folder: <clip>/ each, results.csv, results.md,
# results.png), OUT/table.md, and puts the table between the EVAL-TRACK markers of
# docs/results.md. OUT is out/eval_track.
# Usage: scripts/eval_track.sh [BUILD] [SECONDS]   (SECONDS: every clip's length)
# Environment:
#   THREADS=2          threads of the batch (default: every core)
#   EVAL_JOBS=1        clips at once; the default 1 gives each clip every thread, so that its
#                      compute column (wall) is the one of a single run on THREADS threads; the
#                      CPU column is each run's own CPU time, whatever runs beside it
#   EVAL_SET="--set controllers.0.root_force_kd=100"   a candidate change of the shared defaults,
#                      added to every run, into out/eval_track_candidate (the docs are left alone)
#   EVAL_ONLY="synthetic_run mass_walk/kp0.8"   reruns only those clips (or clip/setting rows);
#                      the others are kept from the earlier run's folders (--resume)
#   EVAL_RESUME=1      goes on with an interrupted evaluation (every batch with --resume)
#   EVAL_CLIPS="mass_walk cmu_131_01", EVAL_SETTINGS="seed1 kp0.8"   a subset, into
#                      out/eval_track_subset (the docs are left alone, as with SECONDS)
set -euo pipefail
BUILD=${1:-build}
ONLY_SECONDS=${2:-}
STANCE=$BUILD/stance
EVAL_SET=${EVAL_SET:-}
EVAL_ONLY=${EVAL_ONLY:-}
EVAL_RESUME=${EVAL_RESUME:-}
EVAL_CLIPS=${EVAL_CLIPS:-}
EVAL_SETTINGS=${EVAL_SETTINGS:-}
EVAL_JOBS=${EVAL_JOBS:-1}
SHARED=${STANCE_SHARED:-../shared}
THREADS=${THREADS:-$(nproc)}
OUT=out/eval_track
docs=yes
if [ -n "$EVAL_SET" ]; then
  OUT=out/eval_track_candidate
  docs=no
elif [ -n "$EVAL_CLIPS$EVAL_SETTINGS$ONLY_SECONDS" ]; then
  OUT=out/eval_track_subset
  docs=no
fi
mkdir -p "$OUT/clips"
"$STANCE" bvh synth-walk "$OUT/clips/synthetic_walk.bvh" >/dev/null
"$STANCE" bvh synth-run "$OUT/clips/synthetic_run.bvh" >/dev/null
abs() { echo "$(cd "$(dirname "$1")" && pwd)/$(basename "$1")"; }

# in_list WORD "LIST": WORD is one of the LIST's words (an empty LIST holds every word)
in_list() { [ -z "$2" ] || [[ " $2 " == *" $1 "* ]]; }

# link GROUP NAME FILE: the group's folder gets NAME.bvh -> FILE (unless EVAL_CLIPS leaves it out)
link() {
  in_list "$2" "$EVAL_CLIPS" || return 0
  mkdir -p "$(dirname "$OUT/groups/$1/$2")"
  ln -sfn "$(abs "$3")" "$OUT/groups/$1/$2.bvh"
}
rm -rf "$OUT/groups"
link looped synthetic_walk "$OUT/clips/synthetic_walk.bvh"
link looped synthetic_run "$OUT/clips/synthetic_run.bvh"
link synthetic_walk_humanoid synthetic_walk_humanoid "$OUT/clips/synthetic_walk.bvh"
if [ -f "$SHARED/data/bvh/mass_walk.bvh" ]; then
  link looped mass_walk "$SHARED/data/bvh/mass_walk.bvh"
  link mass_walk_humanoid mass_walk_humanoid "$SHARED/data/bvh/mass_walk.bvh"
  while IFS= read -r f; do
    name=${f#"$SHARED/data/bvh/"}
    name=${name%.bvh}
    [ "$name" = mass_walk ] && name=mass_walk_once
    link dataset "$name" "$f"
  done < <(find "$SHARED/data/bvh" -name '*.bvh' | LC_ALL=C sort)
else
  echo "eval-track: $SHARED/data/bvh not found: the synthetic clips alone" >&2
fi

# name | options (the clips' length is ONLY_SECONDS when given)
groups=(
  "looped|--loop --duration 20"
  "dataset|"
  "mass_walk_humanoid|--loop --duration 10 --map models/maps/mass_walk_to_humanoid.yaml --model mujoco://model/humanoid/humanoid.xml"
  "synthetic_walk_humanoid|--loop --duration 10 --map models/maps/synthetic_walk_to_humanoid.yaml --model mujoco://model/humanoid/humanoid.xml"
)

# the tracker's shared kp, read from the scenario bvh track writes
probe="$OUT/probe"
"$STANCE" bvh track "$OUT/clips/synthetic_walk.bvh" --out "$probe" --duration 0.01 --quiet >/dev/null
kp=$(sed -n 's/^ *kp: *\([0-9.eE+-]*\) *$/\1/p' "$probe/track.yaml" | head -1)
settings=("seed1|--set seed=1" "seed2|--set seed=2" "seed3|--set seed=3"
  "kp0.8|--set seed=1 --set controllers.0.kp=$(python3 -c "print($kp*0.8)")"
  "kp1.2|--set seed=1 --set controllers.0.kp=$(python3 -c "print($kp*1.2)")"
  "dt1ms|--set seed=1 --set timestep=0.001" "dt2ms|--set seed=1 --set timestep=0.002")

# EVAL_ONLY: the clips of DIR (a batch folder of SETTING) it names lose their summary.json, so
# that --resume runs them again and keeps the rest
forget_only() {
  local dir=$1 setting=$2 summary clip
  while IFS= read -r summary; do
    clip=${summary#"$dir/"}
    clip=${clip%/summary.json}
    if [[ " $EVAL_ONLY " == *" $clip "* || " $EVAL_ONLY " == *" $clip/$setting "* ]]; then
      rm -f "$summary"
    fi
  done < <(find "$dir" -name summary.json)
}

# own_timestep GROUP OPTIONS: the model step of the group's runs (a 0.01 s probe of its first clip)
own_timestep() {
  local first
  first=$(find "$OUT/groups/$1" -name '*.bvh' | LC_ALL=C sort | head -1)
  # shellcheck disable=SC2001,SC2086
  "$STANCE" bvh track "$first" --out "$probe" --quiet \
    $(echo "$2" | sed 's/--loop//; s/--duration [0-9.]*//') --duration 0.01 >/dev/null
  python3 -c 'import json, sys; j = json.load(open(sys.argv[1]))
print(round(j["sim_time"] / j["steps"], 6))' "$probe/summary.json"
}

for g in "${groups[@]}"; do
  IFS='|' read -r group options <<<"$g"
  [ -d "$OUT/groups/$group" ] || continue
  timestep=$(own_timestep "$group" "$options")
  if [ -n "$ONLY_SECONDS" ]; then
    # shellcheck disable=SC2001
    options="$(echo "$options" | sed 's/--duration [0-9.]*//') --duration $ONLY_SECONDS"
  fi
  for s in "${settings[@]}"; do
    IFS='|' read -r setting sargs <<<"$s"
    in_list "$setting" "$EVAL_SETTINGS" || continue
    # a timestep setting equal to the model's own step is the seed-1 run again
    if [[ "$sargs" == *"timestep="* ]] && python3 -c 'import sys
sys.exit(abs(float(sys.argv[1]) - float(sys.argv[2])) > 1e-9)' "${sargs##*timestep=}" "$timestep"; then
      continue
    fi
    dir="$OUT/$group/$setting"
    resume=()
    if [ -f "$dir/track_batch.json" ] && [ -n "$EVAL_ONLY$EVAL_RESUME" ]; then
      resume=(--resume)
      [ -n "$EVAL_ONLY" ] && forget_only "$dir" "$setting"
    fi
    echo "eval-track: $group $setting" >&2
    code=0
    # shellcheck disable=SC2086
    "$STANCE" bvh track "$OUT/groups/$group" --out "$dir" --threads "$THREADS" --jobs "$EVAL_JOBS" \
      --quiet $options $sargs $EVAL_SET "${resume[@]}" || code=$?
    if [ "$code" -eq 130 ]; then
      echo "eval-track: interrupted; go on with EVAL_RESUME=1 $0 $*" >&2
      exit 130
    fi
    [ "$code" -eq 0 ] || echo "eval-track: $group $setting exited $code" >&2
  done
done

# the tables: every run (OUT/table.md), and per clip (OUT/summary.md); the docs get both
docs_args=()
[ "$docs" = yes ] && docs_args=(--docs docs/results.md)
python3 scripts/eval_track_table.py "$OUT" --groups "${groups[@]%%|*}" \
  --settings "${settings[@]%%|*}" "${docs_args[@]}"
if [ "$docs" = no ]; then
  echo "eval-track: a candidate or a subset: tables in $OUT; the docs keep the full matrix's" >&2
fi
