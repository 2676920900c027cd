#!/usr/bin/env bash
# stance bvh track: a clip tracked in free mode with the planner writes the scenario it ran, the
# character, summary.json with metrics.mocap, log.csv and tracked.bvh; --human-limits clamps the
# character to a person's torques; bad input exits 2 and leaves an earlier output folder as it was.
set -u
stance=$1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fails=0
fail() {
  echo "FAIL: $*"
  fails=$((fails + 1))
}

# a smaller planner budget than the shipped one: this checks the outputs, and it also runs in
# the sanitizer tree, where a rollout step is many times slower
"$stance" bvh track models/synthetic_walk.bvh --loop --duration 0.4 --threads 2 --out "$tmp/t" \
  --set planner.samples=12 --set planner.horizon_s=0.35 --set log.rate_hz=1e6 \
  --quiet >"$tmp/out" 2>&1 || fail "track exited $?: $(cat "$tmp/out")"
for f in track.yaml character.xml summary.json log.csv tracked.bvh; do
  [ -s "$tmp/t/$f" ] || fail "no $f"
done
grep -q "enabled: true" "$tmp/t/track.yaml" || fail "the scenario has no planner"
python3 - "$tmp/t" <<'PY' || fail "summary.json"
import json, sys
s = json.load(open(sys.argv[1] + "/summary.json"))
m = s["metrics"]["mocap"]
for k in ("mean_body_position_error_m", "success", "mean_joint_error_deg", "mean_root_error_m",
          "foot_skate_m_per_s", "compute_s_per_sim_s", "cpu_s_per_sim_s"):
    assert k in m, k
assert m["cpu_s_per_sim_s"] > 0 and m["cpu_s_per_sim_s"] == s["metrics"]["cpu_s_per_sim_s"], m
assert s["metrics"]["planner"]["plans"] >= 9, s["metrics"]["planner"]
assert abs(s["sim_time"] - 0.4) < 0.01, s["sim_time"]
PY
# log.csv's per-step body error (a row every step here) is what G-MPJPE averages: its mean over
# the rows of the steps computed (all but the last, the state after the last step) is the summary's
python3 - "$tmp/t" <<'PY' || fail "log.csv's tracking_body_error_m against summary.json"
import csv, json, sys
rows = list(csv.DictReader(open(sys.argv[1] + "/log.csv")))
s = json.load(open(sys.argv[1] + "/summary.json"))
g = s["metrics"]["mocap"]["mean_body_position_error_m"]
errors = [float(r["tracking_body_error_m"]) for r in rows[:-1]]
assert len(errors) == s["steps"], (len(errors), s["steps"])
assert min(errors) >= 0 and max(errors) > min(errors), (min(errors), max(errors))
mean = sum(errors) / len(errors)
assert abs(mean - g) <= 1e-7 * g, (mean, g)
PY
# the exported motion reads back as a BVH
"$stance" bvh info "$tmp/t/tracked.bvh" >"$tmp/info" 2>&1 || fail "tracked.bvh: $(cat "$tmp/info")"

# --human-limits: the character's joints get a person's peak torques (bvh2mjcf's), clamped
"$stance" bvh track models/synthetic_walk.bvh --loop --duration 0.1 --threads 2 --human-limits \
  --out "$tmp/h" --set planner.samples=12 --set planner.horizon_s=0.35 \
  --quiet >"$tmp/hout" 2>&1 || fail "track --human-limits exited $?: $(cat "$tmp/hout")"
grep -q 'name="LeftUpLeg".*actuatorfrcrange="-245 245"' "$tmp/h/character.xml" ||
  fail "--human-limits: no hip limit in character.xml"
grep -q "torque_limits: on" "$tmp/h/track.yaml" || fail "--human-limits: not clamped"
python3 - "$tmp/h" <<'PY' || fail "--human-limits: summary.json's torque_limit"
import json, sys
t = json.load(open(sys.argv[1] + "/summary.json"))["metrics"]["torque_limit"]
assert t["clamping"] is True and t["limit"] > 0, t
PY

# a clip that begins with a T-pose frame (cgspeed's CMU release): info says where the motion
# starts, and track starts there
python3 - models/synthetic_walk.bvh "$tmp/t_posed.bvh" <<'PY' || fail "writing the T-posed clip"
import re, sys
head, motion = open(sys.argv[1]).read().split("MOTION\n")
lines = motion.splitlines()
frames = int(lines[0].split()[1])
channels = len(lines[2].split())
t_pose = " ".join(["0"] * channels)
open(sys.argv[2], "w").write(head + "MOTION\nFrames: %d\n%s\n%s\n%s\n" % (
    frames + 1, lines[1], t_pose, "\n".join(lines[2:])))
PY
"$stance" bvh info "$tmp/t_posed.bvh" >"$tmp/info" 2>&1 || fail "info on the T-posed clip"
grep -q "motion from: frame 1" "$tmp/info" || fail "info: $(cat "$tmp/info")"
grep -q "legs:        left LeftUpLeg .. LeftFoot, right RightUpLeg .. RightFoot" "$tmp/info" ||
  fail "info's legs: $(cat "$tmp/info")"
"$stance" bvh info --json "$tmp/t_posed.bvh" | python3 -c "
import json, sys
d = json.load(sys.stdin)
assert d['first_motion_frame'] == 1 and d['root_body'] == 'Hips' and d['root_carriers'] == [], d
assert d['legs']['right'] == {'thigh': 'RightUpLeg', 'foot': 'RightFoot'}, d['legs']" ||
  fail "info --json on the T-posed clip"
"$stance" bvh track "$tmp/t_posed.bvh" --duration 0.05 --threads 2 --out "$tmp/tp" \
  --set planner.samples=4 --set planner.horizon_s=0.1 --quiet >"$tmp/out" 2>&1 ||
  fail "track of the T-posed clip exited $?: $(cat "$tmp/out")"
grep -q "first_frame: 1$" "$tmp/tp/track.yaml" || fail "track.yaml: $(cat "$tmp/tp/track.yaml")"

# a clip at the highest frame rate the reader takes (10 kHz) that is the walk played 167 times
# too fast: the character is flung off within milliseconds. That blow-up is the run's divergence
# (exit 3, "diverged": true), not a fall with a footnote
sed 's/^Frame Time: .*/Frame Time: 0.0001/' models/synthetic_walk.bvh >"$tmp/fast.bvh"
"$stance" bvh track "$tmp/fast.bvh" --duration 0.5 --threads 2 --out "$tmp/fast" \
  --set planner.samples=4 --set planner.horizon_s=0.1 --quiet >"$tmp/out" 2>&1
code=$?
[ "$code" -eq 3 ] || fail "the flung character exited $code, want 3: $(cat "$tmp/out")"
grep -q "error: simulation diverged" "$tmp/out" || fail "no divergence message: $(cat "$tmp/out")"
python3 -c "
import json, sys
s = json.load(open(sys.argv[1]))
assert s['diverged'] is True and s['divergence'], s" "$tmp/fast/summary.json" ||
  fail "summary.json of the flung character"

# bad input: exit 2, one line naming the problem, the folder untouched
sum_before=$(cat "$tmp/t"/* | md5sum)
"$stance" bvh track "$tmp/missing.bvh" --out "$tmp/t" >"$tmp/err" 2>&1
code=$?
[ "$code" -eq 2 ] || fail "a missing clip exited $code"
grep -q "missing.bvh" "$tmp/err" || fail "the message does not name the file: $(cat "$tmp/err")"
"$stance" bvh track models/synthetic_walk.bvh --map models/maps/synthetic_walk_to_humanoid.yaml \
  --out "$tmp/t" >"$tmp/err" 2>&1
code=$?
[ "$code" -eq 2 ] || fail "--map without --model exited $code"
grep -q -- "--map needs --model" "$tmp/err" || fail "message: $(cat "$tmp/err")"
"$stance" bvh track models/synthetic_walk.bvh --last-frame 100000 --out "$tmp/t" >"$tmp/err" 2>&1
[ $? -eq 2 ] || fail "a frame range past the clip was accepted"
[ "$(cat "$tmp/t"/* | md5sum)" = "$sum_before" ] || fail "bad input changed the output folder"

echo "$fails failed"
[ "$fails" -eq 0 ]
