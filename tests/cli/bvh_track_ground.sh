#!/usr/bin/env bash
# stance bvh track on a URDF robot, which brings no floor: track.yaml adds ground.urdf (said in
# one line) and the robot stands on it; the same scenario without it warns at load and the
# root falls through. An MJCF model with its own floor gets no ground.
set -u
stance=$1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# shellcheck source=tests/cli/lib.sh
. "$(dirname "$0")/lib.sh"

atlas=dart://sample/sdf/atlas/atlas_v3_no_head.urdf
if [ ! -f /usr/share/doc/dart/data/sdf/atlas/atlas_v3_no_head.urdf ]; then
  echo "no dart-doc Atlas: skipped"
  exit 0
fi
"$stance" bvh synth-walk "$tmp/walk.bvh" >/dev/null || fail "synth-walk exited $?"
fast=(--engine mujoco --duration 0.3 --threads 1 --set planner.enabled=false --quiet)

# min COM height of a run's summary.json, checked against a bound (Atlas's COM starts at 1.18 m)
com_above() {
  python3 - "$1/summary.json" "$2" <<'PY'
import json, sys
low = json.load(open(sys.argv[1]))["metrics"]["min_com_height_m"]
print(f"min COM height {low:.3f} m")
sys.exit(0 if low > float(sys.argv[2]) else 1)
PY
}

# the ground added, said once, and stood on
"$stance" bvh track "$tmp/walk.bvh" --model "$atlas" --out "$tmp/t" "${fast[@]}" >"$tmp/out" \
  2>"$tmp/err" || fail "track exited $?: $(cat "$tmp/err")"
[ "$(grep -c "brings no ground: track.yaml adds ground.urdf" "$tmp/out")" -eq 1 ] ||
  fail "not said once: $(cat "$tmp/out")"
grep -q -- "- file: ground.urdf" "$tmp/t/track.yaml" ||
  fail "track.yaml: $(cat "$tmp/t/track.yaml")"
grep -q "ground_weld" "$tmp/t/ground.urdf" || fail "no ground.urdf beside track.yaml"
! grep -q "no model is a ground" "$tmp/err" || fail "warned with the ground: $(cat "$tmp/err")"
com_above "$tmp/t" 1.0 || fail "the root fell with the ground"

# without it: a warning at load, and the root falls through
grep -v -- "- file: ground.urdf" "$tmp/t/track.yaml" >"$tmp/t/no_ground.yaml"
"$stance" run "$tmp/t/no_ground.yaml" --out "$tmp/n" --set planner.enabled=false --quiet \
  >/dev/null 2>"$tmp/err2" || fail "run without the ground exited $?"
[ "$(grep -c "no_head.urdf: no model is a ground and the base floats" "$tmp/err2")" -eq 1 ] ||
  fail "no one warning: $(cat "$tmp/err2")"
! com_above "$tmp/n" 1.0 || fail "the root stayed up without a ground"

# an MJCF model brings its floor: nothing added
humanoid=/usr/share/mujoco/model/humanoid/humanoid.xml
if [ -f "$humanoid" ]; then
  "$stance" bvh track models/synthetic_walk.bvh --model "$humanoid" --out "$tmp/h" \
    --duration 0.05 --quiet >"$tmp/out3" 2>&1 || fail "humanoid exited $?: $(cat "$tmp/out3")"
  ! grep -q "ground" "$tmp/h/track.yaml" "$tmp/out3" || fail "a ground added to humanoid.xml"
  [ ! -e "$tmp/h/ground.urdf" ] || fail "humanoid: ground.urdf written"
fi

[ "$fails" -eq 0 ] && echo "bvh_track_ground: ok"
exit "$fails"
