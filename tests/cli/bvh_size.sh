#!/usr/bin/env bash
# a clip's size: bvh info prints the character's standing height, speed and heading; a
# clip whose detected size is no person's is warned about with its numbers and the setting that
# overrides it (--scale-to-meters, scale_to_meters), which silences it; tracked.bvh starts where
# the source does, unless --origin-centred.
set -u
stance=$1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# shellcheck source=tests/cli/lib.sh
. "$(dirname "$0")/lib.sh"

"$stance" bvh synth-walk "$tmp/walk.bvh" >/dev/null || fail "synth-walk"
"$stance" bvh info "$tmp/walk.bvh" >"$tmp/info" 2>&1 || fail "info: $(cat "$tmp/info")"
grep -q "^height:      1.79 m standing, legs 0.99 m" "$tmp/info" || fail "height: $(cat "$tmp/info")"
grep -q "^speed:       1.27 m/s mean" "$tmp/info" || fail "speed: $(cat "$tmp/info")"
grep -q "^heading:     facing 0.0 deg, travelling 0.0 deg" "$tmp/info" || fail "heading"
grep -q "warning" "$tmp/info" && fail "a person-sized walk is warned about: $(cat "$tmp/info")"

# the root 16 times as fast (Zposition, the third number of every motion row): 20 m/s
python3 - "$tmp/walk.bvh" "$tmp/fast.bvh" <<'PY' || fail "writing the fast clip"
import sys
head, motion = open(sys.argv[1]).read().split("MOTION\n")
lines = motion.splitlines()
rows = []
for row in lines[2:]:
    v = row.split()
    v[2] = repr(float(v[2]) * 16)
    rows.append(" ".join(v))
open(sys.argv[2], "w").write(head + "MOTION\n" + "\n".join(lines[:2] + rows) + "\n")
PY
"$stance" bvh info "$tmp/fast.bvh" >"$tmp/info" 2>&1 || fail "info on the fast clip"
grep -q "^warning: .*fast.bvh: the root moves at up to 20.3 m/s.*--scale-to-meters" "$tmp/info" ||
  fail "info's warning: $(cat "$tmp/info")"
"$stance" bvh info --json "$tmp/fast.bvh" | python3 -c "
import json, sys
c = json.load(sys.stdin)['character']
assert abs(c['peak_speed_mps'] - 20.3) < 0.1 and len(c['warnings']) == 1, c" ||
  fail "info --json's character"
"$stance" bvh2mjcf "$tmp/fast.bvh" "$tmp/fast.xml" >"$tmp/out" 2>"$tmp/err" || fail "bvh2mjcf"
grep -q "^warning: .*the root moves at up to 20.3 m/s" "$tmp/err" || fail "bvh2mjcf: $(cat "$tmp/err")"
"$stance" bvh2mjcf "$tmp/fast.bvh" "$tmp/fast.xml" --scale-to-meters 0.01 >"$tmp/out" 2>"$tmp/err" ||
  fail "bvh2mjcf --scale-to-meters"
[ -s "$tmp/err" ] && fail "a given scale is warned about: $(cat "$tmp/err")"
"$stance" bvh2mjcf "$tmp/fast.bvh" "$tmp/fast.xml" --scale-to-meters -1 >"$tmp/out" 2>"$tmp/err"
[ $? -eq 2 ] || fail "--scale-to-meters -1 was accepted"
grep -q -- "--scale-to-meters" "$tmp/err" || fail "the message does not name the option"

# bvh track: the warning at the run, once; a given scale goes into the character and track.yaml
track() {  # clip out [args...]
  local clip=$1 out=$2
  shift 2
  "$stance" bvh track "$clip" --out "$out" --duration 0.05 --threads 1 \
    --set planner.samples=4 --set planner.horizon_s=0.1 --quiet "$@"
}
track "$tmp/fast.bvh" "$tmp/t_fast" >"$tmp/out" 2>"$tmp/err" || fail "track: $(cat "$tmp/err")"
[ "$(grep -c "the root moves at up to 20.3 m/s" "$tmp/err")" -eq 1 ] ||
  fail "track's warning: $(cat "$tmp/err")"
track "$tmp/fast.bvh" "$tmp/t_given" --scale-to-meters 0.02 >"$tmp/out" 2>"$tmp/err" ||
  fail "track --scale-to-meters: $(cat "$tmp/err")"
grep -q "scale_to_meters: 0.02" "$tmp/t_given/track.yaml" || fail "track.yaml has no scale"
grep -q "warning" "$tmp/err" && fail "a given scale is warned about: $(cat "$tmp/err")"

# tracked.bvh starts where the source starts (the root's channels of the first frame), or with
# --origin-centred above the origin and on the ground
first_root() { sed -n '/^MOTION/,$p' "$1" | sed -n 4p | cut -d' ' -f1-6; }
track "$tmp/walk.bvh" "$tmp/t_walk" >"$tmp/out" 2>&1 || fail "track the walk: $(cat "$tmp/out")"
python3 - "$(first_root "$tmp/walk.bvh")" "$(first_root "$tmp/t_walk/tracked.bvh")" <<'PY' ||
import sys
a, b = ([float(x) for x in s.split()] for s in sys.argv[1:3])
assert max(abs(x - y) for x, y in zip(a[:3], b[:3])) < 1.0, (a, b)   # cm
assert max(abs(x - y) for x, y in zip(a[3:], b[3:])) < 1.0, (a, b)   # deg
PY
  fail "tracked.bvh does not start at the source's root"
track "$tmp/walk.bvh" "$tmp/t_centred" --origin-centred >"$tmp/out" 2>&1 || fail "--origin-centred"
grep -q "export_origin_centred: true" "$tmp/t_centred/track.yaml" || fail "track.yaml: centred"

echo "$fails failed"
[ "$fails" -eq 0 ]
