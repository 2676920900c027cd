#!/usr/bin/env bash
# stance bvh track on DART's Atlas with no --map (issue 45): the map found from its tree, the
# URDF's effort limits read and clamped (torque_limits: auto), and the synthetic walk tracked
# without a fall and with success at the default gains and at kp x0.8 and x1.2, on MuJoCo
# (1 s each, a light planner on one thread: some 5 s of CPU per run). Longer runs and mass_walk:
# docs/robots.md.
set -u
stance=$1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# shellcheck source=tests/cli/lib.sh
. "$(dirname "$0")/lib.sh"

atlas=/usr/share/doc/dart/data/sdf/atlas/atlas_v3_no_head.urdf
if [ ! -f "$atlas" ]; then
  echo "no dart-doc Atlas: skipped"
  exit 0
fi
"$stance" bvh synth-walk "$tmp/walk.bvh" >/dev/null 2>&1 || fail "synth-walk"
for kp in 2000 1600 2400; do
  kd=$(python3 -c "print(175 * $kp / 2000)")
  "$stance" bvh track "$tmp/walk.bvh" --model "dart://sample/sdf/atlas/atlas_v3_no_head.urdf" \
    --out "$tmp/kp$kp" --duration 1 --threads 1 --set planner.samples=12 \
    --set planner.horizon_s=0.35 \
    --set controllers.0.kp="$kp" --set controllers.0.kd="$kd" --quiet >"$tmp/out$kp" 2>&1 ||
    fail "kp $kp: exited $?: $(cat "$tmp/out$kp")"
  grep -q "joint_map: map.yaml" "$tmp/kp$kp/track.yaml" || fail "kp $kp: no map found"
  python3 - "$tmp/kp$kp/summary.json" "$kp" <<'PY' || fail "kp $kp: summary.json"
import json, sys
s = json.load(open(sys.argv[1]))
m = s["metrics"]
assert not s["fell"], ("fell", sys.argv[2], s.get("fall_reason"))
assert m["mocap"]["success"] is True, ("no success", sys.argv[2], m["mocap"])
t = m["torque_limit"]
# the URDF's effort limits were read (260 N m at the hip pitch ... 60 at the wrist) and every
# torque was clamped to them
assert t["clamping"] is True and 60 <= t["limit"] <= 700, t
assert 0 <= t["share_at_limit"] <= 1, t
PY
done
[ "$fails" -eq 0 ]
