#!/usr/bin/env bash
# make eval-track: the planner's tracking matrix. Every clip under one parameter set:
# the defaults at planner seeds 1-5, then at seed 1 kp x0.8, kp x1.2, a 1 ms and a 2 ms timestep.
# Writes out/eval_track/<clip>/<setting>/ (each a bvh track output folder), out/eval_track/table.md,
# and puts the table between the EVAL-TRACK markers of docs/results.md.
# Usage: scripts/eval_track.sh [BUILD] [SECONDS]   (SECONDS: override every clip's length)
# A candidate change to the shared defaults is evaluated with EVAL_SET, e.g.
#   EVAL_SET="--set controllers.0.root_force_kd=100" scripts/eval_track.sh
# which adds those --set arguments to every run, writes to out/eval_track_candidate and leaves
# the docs alone (a candidate's table is not the shipped defaults' table).
# EVAL_ONLY="synthetic_run mass_walk/kp0.8" reruns only those clips (or clip/setting rows); the
# other rows are read from their folders of an earlier run, for a change known not to touch
# them (one that acts only above a body error those rows never reached).
set -euo pipefail
BUILD=${1:-build}
ONLY_SECONDS=${2:-}
STANCE=$BUILD/stance
EVAL_SET=${EVAL_SET:-}
EVAL_ONLY=${EVAL_ONLY:-}
OUT=out/eval_track
[ -n "$EVAL_SET" ] && OUT=out/eval_track_candidate
SHARED=${STANCE_SHARED:-../shared}
THREADS=${THREADS:-$(nproc)}
mkdir -p "$OUT/clips"
"$STANCE" bvh synth-walk "$OUT/clips/synthetic_walk.bvh" >/dev/null
"$STANCE" bvh synth-run "$OUT/clips/synthetic_run.bvh" >/dev/null

# name | bvh | duration | extra arguments
clips=(
  "synthetic_walk|$OUT/clips/synthetic_walk.bvh|20|--loop"
  "synthetic_run|$OUT/clips/synthetic_run.bvh|20|--loop"
)
if [ -f "$SHARED/data/bvh/mass_walk.bvh" ]; then
  clips+=("mass_walk|$SHARED/data/bvh/mass_walk.bvh|20|--loop")
  clips+=("cmu_131_01|$SHARED/data/bvh/cmu_131_01.bvh||")
  clips+=("mass_walk_humanoid|$SHARED/data/bvh/mass_walk.bvh|10|--loop --map models/maps/mass_walk_to_humanoid.yaml --model mujoco://model/humanoid/humanoid.xml")
fi
clips+=("synthetic_walk_humanoid|$OUT/clips/synthetic_walk.bvh|10|--loop --map models/maps/synthetic_walk_to_humanoid.yaml --model mujoco://model/humanoid/humanoid.xml")

row() {  # clip setting dir
  python3 - "$1" "$2" "$3" <<'PY'
import json, sys
clip, setting, d = sys.argv[1:4]
s = json.load(open(d + "/summary.json"))
m = s["metrics"].get("mocap", {})
ok = (not s["fell"]) and m.get("success", False) and m.get("mean_root_error_m", 9) <= 0.2 \
     and m.get("mean_joint_error_deg", 99) <= 6
# a run cut short (Ctrl-C, a killed job) proves nothing about the rest of its clip
verdict = "CUT" if s.get("interrupted") else ("PASS" if ok else "FAIL")
print("| {} | {} | {:.1f} | {} | {} | {:.3f} | {:.3f} | {:.2f} | {:.3f} | {:.1f} | {} |".format(
    clip, setting, s["sim_time"], "yes" if s["fell"] else "no",
    "yes" if m.get("success") else "no", m.get("mean_body_position_error_m", float("nan")),
    m.get("mean_root_error_m", float("nan")), m.get("mean_joint_error_deg", float("nan")),
    m.get("foot_skate_m_per_s", float("nan")), m.get("compute_s_per_sim_s", float("nan")),
    verdict))
PY
}

table="$OUT/table.md"
{
  echo "| clip | setting | sim s | fell | success | G-MPJPE m | root m | joint deg | skate m/s | compute s/s | holds |"
  echo "|---|---|---|---|---|---|---|---|---|---|---|"
} > "$table"
for entry in "${clips[@]}"; do
  IFS='|' read -r name bvh seconds extra <<< "$entry"
  [ -n "$ONLY_SECONDS" ] && seconds=$ONLY_SECONDS
  dur=()
  [ -n "$seconds" ] && dur=(--duration "$seconds")
  # the tracker's shared kp, read from the scenario bvh track writes
  probe="$OUT/$name/probe"
  # shellcheck disable=SC2086
  "$STANCE" bvh track "$bvh" --out "$probe" --duration 0.01 --quiet $extra >/dev/null
  kp=$(sed -n 's/^ *kp: *\([0-9.eE+-]*\) *$/\1/p' "$probe/track.yaml" | head -1)
  settings=("seed1|--set seed=1" "seed2|--set seed=2" "seed3|--set seed=3" "seed4|--set seed=4"
            "seed5|--set seed=5"
            "kp0.8|--set seed=1 --set controllers.0.kp=$(python3 -c "print($kp*0.8)")"
            "kp1.2|--set seed=1 --set controllers.0.kp=$(python3 -c "print($kp*1.2)")"
            "dt1ms|--set seed=1 --set timestep=0.001" "dt2ms|--set seed=1 --set timestep=0.002")
  for s in "${settings[@]}"; do
    IFS='|' read -r sname sargs <<< "$s"
    dir="$OUT/$name/$sname"
    if [ -n "$EVAL_ONLY" ] && ! [[ " $EVAL_ONLY " == *" $name "* || " $EVAL_ONLY " == *" $name/$sname "* ]]; then
      echo "eval-track: $name $sname: kept from the earlier run" >&2
      if [ -f "$dir/summary.json" ]; then row "$name" "$sname" "$dir" >> "$table"; fi
      continue
    fi
    echo "eval-track: $name $sname" >&2
    # shellcheck disable=SC2086
    "$STANCE" bvh track "$bvh" --out "$dir" "${dur[@]}" --threads "$THREADS" --quiet $extra $sargs \
      $EVAL_SET \
      || echo "eval-track: $name $sname exited $?" >&2
    if [ -f "$dir/summary.json" ]; then row "$name" "$sname" "$dir" >> "$table"; fi
  done
done
cat "$table"
if [ -n "$EVAL_SET" ]; then
  echo "eval-track: candidate ($EVAL_SET): table in $table; the docs keep the shipped defaults' table" >&2
  exit 0
fi

# the table into the docs, between the markers
python3 - "$table" docs/results.md <<'PY'
import sys, re
table = open(sys.argv[1]).read().strip()
for path in sys.argv[2:]:
    text = open(path).read()
    new = re.sub(r"(<!-- EVAL-TRACK BEGIN -->\n).*?(\n<!-- EVAL-TRACK END -->)",
                 lambda m: m.group(1) + table + m.group(2), text, flags=re.S)
    if new != text:
        open(path, "w").write(new)
PY
