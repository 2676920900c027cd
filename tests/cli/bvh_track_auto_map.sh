#!/usr/bin/env bash
# stance bvh track --model without --map: the joint map found from the model's tree, printed,
# written to DIR/map.yaml and read back with --map; a model without legs is one clear line and
# exit 2, with nothing written.
set -u
stance=$1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# shellcheck source=tests/cli/lib.sh
. "$(dirname "$0")/lib.sh"

humanoid=/usr/share/mujoco/model/humanoid/humanoid.xml
if [ ! -f "$humanoid" ]; then
  echo "no libmujoco-samples: skipped"
  exit 0
fi
walk=models/synthetic_walk.bvh

# found, printed, written, and the same map read back
"$stance" bvh track "$walk" --model "$humanoid" --out "$tmp/auto" --duration 0.05 --quiet \
  >"$tmp/out" 2>&1 || fail "auto map run exited $?: $(cat "$tmp/out")"
grep -q "14 of 14 roles matched" "$tmp/out" || fail "report: $(cat "$tmp/out")"
grep -q "left thigh *LeftUpLeg -> left_thigh" "$tmp/out" || fail "report: $(cat "$tmp/out")"
grep -q '"LeftUpLeg": "left_thigh"' "$tmp/auto/map.yaml" || fail "map.yaml: $(cat "$tmp/auto/map.yaml")"
grep -q "joint_map: map.yaml" "$tmp/auto/track.yaml" || fail "track.yaml names no map.yaml"
"$stance" bvh track "$walk" --model "$humanoid" --map "$tmp/auto/map.yaml" --out "$tmp/back" \
  --duration 0.05 --quiet >"$tmp/out2" 2>&1 || fail "map.yaml passed back: $(cat "$tmp/out2")"

# no legs: one line naming the model's bodies, exit 2, no --out
cat >"$tmp/no_legs.xml" <<'EOF'
<mujoco>
  <worldbody>
    <body name="base" pos="0 0 1">
      <freejoint name="root"/>
      <geom type="box" size="0.2 0.1 0.05" mass="4"/>
      <body name="arm" pos="0.2 0 0">
        <joint name="shoulder" type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" mass="1"/>
      </body>
    </body>
  </worldbody>
</mujoco>
EOF
"$stance" bvh track "$walk" --model "$tmp/no_legs.xml" --out "$tmp/none" >"$tmp/o3" 2>"$tmp/e3"
code=$?
[ "$code" -eq 2 ] || fail "no legs: exit $code"
[ "$(wc -l <"$tmp/e3")" -eq 1 ] || fail "no legs: not one line: $(cat "$tmp/e3")"
grep -q "no_legs.xml: found no two legs .*bodies: base, arm" "$tmp/e3" ||
  fail "no legs: $(cat "$tmp/e3")"
[ ! -e "$tmp/none" ] || fail "no legs: --out was made"

# --map needs --model
"$stance" bvh track "$walk" --map "$tmp/auto/map.yaml" --out "$tmp/m" >"$tmp/o4" 2>"$tmp/e4"
code=$?
[ "$code" -eq 2 ] || fail "--map alone: exit $code"
grep -q -- "--map needs --model" "$tmp/e4" || fail "--map alone: $(cat "$tmp/e4")"

[ "$fails" -eq 0 ] && echo "bvh_track_auto_map: ok"
exit "$fails"
