#!/usr/bin/env bash
# stance bvh track on a collection's robot file (MJCF, a free joint, no floor): track.yaml adds
# ground.urdf (said in one line; on MuJoCo it becomes a floor in the robot's text) and the robot
# stands on it; the same scenario without it warns at load and falls through. The robot's scene
# file, which includes it and adds a floor, gets no ground and no warning.
set -u
stance=$1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# shellcheck source=tests/cli/lib.sh
. "$(dirname "$0")/lib.sh"

models=tests/models
"$stance" bvh synth-walk "$tmp/walk.bvh" >/dev/null || fail "synth-walk exited $?"
fast=(--engine mujoco --duration 0.3 --threads 1 --set planner.enabled=false --quiet)

# min COM height of a run's summary.json against a bound (the robot's COM starts near 0.9 m)
com_above() {
  python3 - "$1/summary.json" "$2" <<'PY'
import json, sys
low = json.load(open(sys.argv[1]))["metrics"]["min_com_height_m"]
print(f"min COM height {low:.3f} m")
sys.exit(0 if low > float(sys.argv[2]) else 1)
PY
}

# the robot file alone: the ground added, said once, and stood on
"$stance" bvh track "$tmp/walk.bvh" --model "$models/pitch_ankle_robot.xml" --out "$tmp/t" \
  "${fast[@]}" >"$tmp/out" 2>"$tmp/err" || fail "track exited $?: $(cat "$tmp/err")"
[ "$(grep -c "robot.xml brings no ground: track.yaml adds ground.urdf" "$tmp/out")" -eq 1 ] ||
  fail "not said once: $(cat "$tmp/out")"
grep -q -- "- file: ground.urdf" "$tmp/t/track.yaml" || fail "track.yaml: $(cat "$tmp/t/track.yaml")"
grep -q "ground_weld" "$tmp/t/ground.urdf" || fail "no ground.urdf beside track.yaml"
! grep -q "no model is a ground" "$tmp/err" || fail "warned with the ground: $(cat "$tmp/err")"
com_above "$tmp/t" 0.8 || fail "the robot fell with the ground"

# without it: one warning at load, and the robot falls through
grep -v -- "- file: ground.urdf" "$tmp/t/track.yaml" >"$tmp/t/no_ground.yaml"
"$stance" run "$tmp/t/no_ground.yaml" --out "$tmp/n" --set planner.enabled=false --quiet \
  >/dev/null 2>"$tmp/err2" || fail "run without the ground exited $?"
[ "$(grep -c "robot.xml: no model is a ground and the base floats" "$tmp/err2")" -eq 1 ] ||
  fail "no one warning: $(cat "$tmp/err2")"
! com_above "$tmp/n" 0.8 || fail "the robot stayed up without a ground"

# the scene file brings its floor: nothing added, no warning
"$stance" bvh track "$tmp/walk.bvh" --model "$models/pitch_ankle_robot_scene.xml" --out "$tmp/s" \
  "${fast[@]}" >"$tmp/out3" 2>&1 || fail "scene exited $?: $(cat "$tmp/out3")"
! grep -q "ground" "$tmp/s/track.yaml" "$tmp/out3" || fail "a ground added to the scene"
[ ! -e "$tmp/s/ground.urdf" ] || fail "scene: ground.urdf written"
"$stance" run "$tmp/s/track.yaml" --out "$tmp/s2" --set planner.enabled=false --quiet \
  >/dev/null 2>"$tmp/err4" || fail "run of the scene exited $?"
! grep -q "no model is a ground" "$tmp/err4" || fail "the scene warned: $(cat "$tmp/err4")"

[ "$fails" -eq 0 ] && echo "bvh_track_mjcf_ground: ok"
exit "$fails"
