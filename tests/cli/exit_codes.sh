#!/usr/bin/env bash
# the exit codes: 0 a completed run (a fall too), 2 bad input found where it enters, 70 a bug with
# 'internal error:' (forced by STANCE_TEST_INTERNAL_ERROR, a switch for this test only).
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
