#!/usr/bin/env bash
# the exit codes: 0 a completed run (a fall too), 2 bad input found where it enters, 4 a missed
# expectation under --check, 70 a bug with 'internal error:' (forced by STANCE_TEST_INTERNAL_ERROR,
# a switch for this test only).
set -u
stance=$1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fails=0
passes=0

# expect CODE PREFIX -- command...: the exit code and a one-line stderr starting with PREFIX
expect() {
  local code=$1 prefix=$2
  shift 3
  "$@" >"$tmp/stdout" 2>"$tmp/stderr"
  local rc=$?
  if [ "$rc" -ne "$code" ] || [ "$(grep -c . "$tmp/stderr")" -ne 1 ] ||
    [ "$(head -c ${#prefix} "$tmp/stderr")" != "$prefix" ]; then
    echo "FAIL: $* -> rc=$rc (want $code), stderr:"
    cat "$tmp/stderr"
    fails=$((fails + 1))
  else
    passes=$((passes + 1))
  fi
}

# a fall is a result: exit 0, and the summary says so
"$stance" run scenarios/pd_hold.yaml --set controllers.0.kp=0 --set controllers.0.kd=0 \
  --set fall.enabled=true --set fall.com_height_fraction=0.9 --out "$tmp/fall" --quiet
rc=$?
if [ "$rc" -ne 0 ] || ! grep -q '"fell": true' "$tmp/fall/summary.json"; then
  echo "FAIL: a fall -> rc=$rc (want 0) or no fell: true"
  fails=$((fails + 1))
fi

# the scenario's expectation: --check turns a miss into exit 4 with its one line; without --check
# a miss is a result (exit 0, "held": false in summary.json)
held='expect={fell: false, metrics: [{name: pushes_survived, min: 1}]}'
missed='expect={fell: false, metrics: [{name: torque_rms, max: 1}]}'
"$stance" run scenarios/pd_hold.yaml --set "$held" --check --quiet --out "$tmp/held"
rc=$?
if [ "$rc" -ne 0 ] || ! grep -q '"held": true' "$tmp/held/summary.json"; then
  echo "FAIL: a held expectation with --check -> rc=$rc (want 0) or no held: true"
  fails=$((fails + 1))
fi
"$stance" run scenarios/pd_hold.yaml --set "$missed" --quiet --out "$tmp/missed"
rc=$?
if [ "$rc" -ne 0 ] || ! grep -q '"held": false' "$tmp/missed/summary.json"; then
  echo "FAIL: a missed expectation without --check -> rc=$rc (want 0) or no held: false"
  fails=$((fails + 1))
fi
expect 4 "expectation NOT held at 5.000 s: no fall; torque_rms 10.71 not <= 1" -- \
  "$stance" run scenarios/pd_hold.yaml --set "$missed" --check --quiet --out "$tmp/missed"
# pd_hold without its expect block (the block's indented lines and comments go with it)
awk '/^expect:/ {skip = 1; next} skip && /^[ #]/ {next} {skip = 0; print}' scenarios/pd_hold.yaml |
  sed "s#\.\./models#$(pwd)/models#" >"$tmp/no_expect.yaml"
expect 2 "error: $tmp/no_expect.yaml: --check: the scenario has no 'expect' block to check" -- \
  "$stance" run "$tmp/no_expect.yaml" --check --out "$tmp/no_expect"

# every command's boundary: a bug is exit 70 and one line starting 'internal error:'
for cmd in "run scenarios/pd_hold.yaml --quiet" "info models/arm3.xml" "list" \
  "sweep scenarios/pd_hold.yaml --param duration --values 1 --quiet" \
  "bvh synth-walk $tmp/walk.bvh" "bvh synth-run $tmp/run.bvh"; do
  # shellcheck disable=SC2086
  expect 70 "internal error: " -- env STANCE_TEST_INTERNAL_ERROR=1 "$stance" $cmd
done

# the synthetic run: written, and a clip `bvh info` reads (43 frames at 60 fps)
"$stance" bvh synth-run "$tmp/run.bvh" >/dev/null
rc=$?
if [ "$rc" -ne 0 ] || ! "$stance" bvh info "$tmp/run.bvh" | grep -q "43"; then
  echo "FAIL: bvh synth-run -> rc=$rc, or bvh info does not read 43 frames"
  fails=$((fails + 1))
fi

# bad input that yaml-cpp or the file system would otherwise report as an exception
model=$(pwd)/models/arm3.xml
printf 'name: t\nmodel: %s\ncontrollers: [{type: hold_pose_pd, {a: 1}: 2}]\n' "$model" \
  >"$tmp/key.yaml"
expect 2 "error: $tmp/key.yaml:3: a key must be a word, found a mapping" -- \
  "$stance" run "$tmp/key.yaml" --out "$tmp/out"
expect 2 "error: --set name.x=1: 'x' is inside a value, not a mapping" -- \
  "$stance" run scenarios/pd_hold.yaml --set name.x=1 --out "$tmp/out"
expect 2 "error: $tmp: cannot open BVH file (a folder)" -- "$stance" bvh info "$tmp"
expect 2 "error: $tmp: a folder, not a YAML file" -- "$stance" run "$tmp"
if [ -f /usr/share/mujoco/model/humanoid/humanoid.xml ]; then
  expect 2 "error: $tmp: cannot write (" -- "$stance" bvh retarget models/synthetic_walk.bvh \
    "$tmp" --map models/maps/synthetic_walk_to_humanoid.yaml \
    --model mujoco://model/humanoid/humanoid.xml
fi
: >"$tmp/file"
expect 2 "error: --out $tmp/file: " -- "$stance" run scenarios/pd_hold.yaml --out "$tmp/file"

echo "$passes passed, $fails failed"
[ "$fails" -eq 0 ]
