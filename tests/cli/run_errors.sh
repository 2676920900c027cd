#!/usr/bin/env bash
# stance run: exit codes and one-line messages for every kind of bad input.
set -u
stance=$1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fails=0
passes=0

# expect CODE PATTERN -- command...: the exit code, and stderr containing PATTERN on one line
expect() {
  local code=$1 pattern=$2
  shift 3
  "$@" >"$tmp/stdout" 2>"$tmp/stderr"
  local rc=$?
  local lines
  lines=$(grep -c . "$tmp/stderr")
  if [ "$rc" -ne "$code" ] || { [ -n "$pattern" ] && ! grep -qF -- "$pattern" "$tmp/stderr"; } ||
    { [ "$code" -eq 2 ] && [ "$lines" -ne 1 ]; }; then
    echo "FAIL: $* -> rc=$rc (want $code), stderr:"
    cat "$tmp/stderr"
    fails=$((fails + 1))
  else
    passes=$((passes + 1))
  fi
}

model=$(pwd)/models/arm3.xml
good() {
  cat >"$tmp/$1" <<YAML
name: t
model: $model
duration: 0.2
controllers:
  - type: hold_pose_pd
    kp: 10
    kd: 1
YAML
}

# a good run writes both files and exits 0
good ok.yaml
expect 0 "" -- "$stance" run "$tmp/ok.yaml" --out "$tmp/out" --quiet
for key in scenario engine seed sim_time fell fall_time wall_time_s metrics; do
  if ! grep -q "\"$key\"" "$tmp/out/summary.json"; then
    echo "FAIL: summary.json lacks $key"
    fails=$((fails + 1))
  fi
done
head -1 "$tmp/out/log.csv" | grep -q '^time,com_x,com_y,com_z,root_x' || {
  echo "FAIL: log.csv header"
  fails=$((fails + 1))
}
[ "$(wc -l <"$tmp/out/log.csv")" -eq 22 ] || {
  echo "FAIL: log.csv rows $(wc -l <"$tmp/out/log.csv") != 22"
  fails=$((fails + 1))
}

expect 2 "no/such.yaml: no such file" -- "$stance" run "$tmp/no/such.yaml"
printf 'name: t\nmodel: [a, b\n' >"$tmp/malformed.yaml"
expect 2 "malformed.yaml:3:1: malformed YAML" -- "$stance" run "$tmp/malformed.yaml"
good unknown.yaml
echo "durration: 3" >>"$tmp/unknown.yaml"
expect 2 "unknown.yaml:8: unknown parameter 'durration' (did you mean 'duration'?)" -- \
  "$stance" run "$tmp/unknown.yaml"
good type.yaml
sed -i 's/kp: 10/kp: [1, 2]/' "$tmp/type.yaml"
expect 2 "type.yaml:6: parameter 'controllers[0].kp': expected a number, found a list" -- \
  "$stance" run "$tmp/type.yaml"
good nan.yaml
sed -i 's/kd: 1/kd: .nan/' "$tmp/nan.yaml"
expect 2 "parameter 'controllers[0].kd': must be a finite number" -- "$stance" run "$tmp/nan.yaml"
good dof.yaml
echo "initial_pose: {elbw: 0.1}" >>"$tmp/dof.yaml"
expect 2 "unknown dof 'elbw' (did you mean 'elbow'?)" -- "$stance" run "$tmp/dof.yaml"
good body.yaml
echo "perturbations: [{body: hnd, force: [1, 0, 0], start: 0, duration: 0.1}]" >>"$tmp/body.yaml"
expect 2 "unknown body 'hnd' (did you mean 'hand'?)" -- "$stance" run "$tmp/body.yaml"
good ctl.yaml
sed -i 's/hold_pose_pd/hold_pose_pdd/' "$tmp/ctl.yaml"
expect 2 "unknown controller type 'hold_pose_pdd' (did you mean 'hold_pose_pd'?)" -- \
  "$stance" run "$tmp/ctl.yaml"
printf '<mujoco>\n<worldbody>\n<body>\n<geom type="sphere" size="0.1"/>\n</worldbody>\n</mujoco>\n' \
  >"$tmp/bad.xml"
good badmodel.yaml
sed -i "s#$model#$tmp/bad.xml#" "$tmp/badmodel.yaml"
expect 2 "bad.xml" -- "$stance" run "$tmp/badmodel.yaml"
printf '<skel version="1.0">\n<world name="w">\n<skeleton name="s">\n<body name="b">\n</skeleton>\n' \
  >"$tmp/bad.skel"
expect 2 "bad.skel:" -- "$stance" info "$tmp/bad.skel" --engine mujoco
expect 2 "--engine: expected mujoco or dart" -- "$stance" run "$tmp/ok.yaml" --engine bullet
expect 2 "--push 'hand,1,2': expected body,fx,fy,fz,start,duration" -- \
  "$stance" run "$tmp/ok.yaml" --push hand,1,2
expect 2 "(from --set) parameter 'duration': expected a number" -- \
  "$stance" run "$tmp/ok.yaml" --set duration=abc

# a joint map with a misspelt clip joint names the map file and line (mocap_retarget)
if [ -f /usr/share/mujoco/model/humanoid/humanoid.xml ]; then
  sed 's/LeftLeg: left_shin/LeftLegg: left_shin/' models/maps/synthetic_walk_to_humanoid.yaml \
    >"$tmp/map.yaml"
  expect 2 "map.yaml:15: the clip has no joint 'LeftLegg' (did you mean 'LeftLeg'?)" -- \
    "$stance" run scenarios/mocap_retarget.yaml --set "controllers.0.joint_map=$tmp/map.yaml"
  expect 2 "none.yaml: cannot read the joint map" -- \
    "$stance" run scenarios/mocap_retarget.yaml --set "controllers.0.joint_map=$tmp/none.yaml"
fi

# a diverging run exits 3, says when, and still writes valid outputs
good diverge.yaml
sed -i 's/kp: 10/kp: 1e9/; s/kd: 1/kd: 1e7/' "$tmp/diverge.yaml"
expect 3 "diverged" -- "$stance" run "$tmp/diverge.yaml" --out "$tmp/div"
python3 -c "import json,sys; d=json.load(open('$tmp/div/summary.json')); sys.exit(0 if d['diverged'] else 1)" || {
  echo "FAIL: diverged summary"
  fails=$((fails + 1))
}

# absurd gains diverge on DART too: exit 3 with the time, the dof and a whole summary and log
expect 3 "error: simulation diverged: DART instability at t=0.00" -- \
  "$stance" run scenarios/pd_hold.yaml --engine dart --set controllers.0.kp=1e12 \
  --out "$tmp/div_dart" --quiet
python3 - "$tmp/div_dart" <<'PY' || {
import csv, json, math, sys
d = json.load(open(sys.argv[1] + "/summary.json"))
assert d["diverged"] and "on dof '" in d["divergence"] and d["sim_time"] < 0.1, d
rows = list(csv.reader(open(sys.argv[1] + "/log.csv")))
assert len(rows) >= 2 and all(len(r) == len(rows[0]) for r in rows)
assert all(math.isfinite(float(x)) for r in rows[1:] for x in r), "a non-finite value in log.csv"
PY
  echo "FAIL: DART divergence outputs"
  fails=$((fails + 1))
}

# a scenario without a name is named after its file, whose name may hold bytes that are not
# UTF-8: summary.json is still written (the bytes as U+FFFD), not lost to an internal error
good ok.yaml
sed '/^name:/d' "$tmp/ok.yaml" >"$tmp/"$'walk\xff.yaml'
expect 0 "" -- "$stance" run "$tmp/"$'walk\xff.yaml' --out "$tmp/not_utf8" --quiet
python3 -c "import json,sys; d=json.load(open('$tmp/not_utf8/summary.json', encoding='utf-8'));
sys.exit(0 if d['scenario'] == 'walk\ufffd' else 1)" || {
  echo "FAIL: summary.json of a scenario file whose name is not UTF-8"
  fails=$((fails + 1))
}
# sweep and tune keep the file's name in JSON (their resume files): one line, exit 2, not a bug's 70
expect 2 "walk\xFF.yaml: the file name is not UTF-8 (byte 0xFF at character" -- \
  "$stance" sweep "$tmp/"$'walk\xff.yaml' --param duration --values 0.1 --out "$tmp/sw" --quiet
expect 2 "walk\xFF.yaml: the file name is not UTF-8 (byte 0xFF at character" -- \
  "$stance" tune "$tmp/"$'walk\xff.yaml' --param controllers.0.kp=1:10 --out "$tmp/tu" --quiet

# a resume file nested 100,000 deep is refused while it is read (printing it overflowed the stack)
mkdir -p "$tmp/deep_resume"
python3 -c "
d = 100000
open('$tmp/deep_resume/sweep.partial.json', 'w').write('{\"options\": {\"duration\": null, \"engine\": \"\", \"param\": \"duration\", \"values\": [0.1], \"sets\": [], \"scenario\": ' + '[' * d + ']' * d + '}, \"done\": {}}')
open('$tmp/deep_resume/tune.partial.json', 'w').write('[' * d + ']' * d)"
expect 2 "deep_resume/sweep.partial.json: nested more than 64 deep" -- \
  "$stance" sweep "$tmp/ok.yaml" --param duration --values 0.1 --resume "$tmp/deep_resume" --quiet
expect 2 "deep_resume/tune.partial.json: nested more than 64 deep" -- \
  "$stance" tune "$tmp/ok.yaml" --param controllers.0.kp=1:10 --resume "$tmp/deep_resume" --quiet

echo "$passes passed, $fails failed"
[ "$fails" -eq 0 ]
