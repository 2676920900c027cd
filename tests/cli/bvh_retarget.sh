#!/usr/bin/env bash
# stance bvh retarget: a clip mapped onto a model, written as a table of q and v.
set -u
stance=$1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fails=0
fail() {
  echo "FAIL: $*"
  fails=$((fails + 1))
}

humanoid=/usr/share/mujoco/model/humanoid/humanoid.xml
if [ ! -f "$humanoid" ]; then
  echo "no libmujoco-samples: skipped"
  exit 0
fi
"$stance" bvh retarget models/synthetic_walk.bvh "$tmp/walk.csv" \
  --map models/maps/synthetic_walk_to_humanoid.yaml --model "$humanoid" --loop --duration 3 \
  >"$tmp/out" 2>&1 || fail "retarget exited $?: $(cat "$tmp/out")"
# 3 s at the clip's 60 Hz (the table runs two frames past), a header naming q's and v's entries
rows=$(($(wc -l <"$tmp/walk.csv") - 1))
[ "$rows" -eq 182 ] || fail "rows: $rows"
header=$(head -1 "$tmp/walk.csv")
case "$header" in
time,root_pos_x,root_pos_y,root_pos_z,root_qw,root_qx,root_qy,root_qz,abdomen_z,*v_root_pos_x*) ;;
*) fail "header: $header" ;;
esac
cols=$(head -1 "$tmp/walk.csv" | tr ',' '\n' | wc -l)
[ "$cols" -eq $((1 + 28 + 27)) ] || fail "columns: $cols"
# every value is a finite number and the root walks forward over the 3 s
python3 - "$tmp/walk.csv" <<'PY' || fail "values"
import csv, math, sys
rows = list(csv.DictReader(open(sys.argv[1])))
assert all(math.isfinite(float(v)) for r in rows for v in r.values())
dx = float(rows[-1]["root_pos_x"]) - float(rows[0]["root_pos_x"])
dy = float(rows[-1]["root_pos_y"]) - float(rows[0]["root_pos_y"])
assert math.hypot(dx, dy) > 2.0, (dx, dy)
PY

# bad input: one line naming the file, exit 2, and the earlier output left whole
cp "$tmp/walk.csv" "$tmp/before.csv"
sed 's/Hips: pelvis/Hips: pelvs/' models/maps/synthetic_walk_to_humanoid.yaml >"$tmp/bad.yaml"
"$stance" bvh retarget models/synthetic_walk.bvh "$tmp/walk.csv" --map "$tmp/bad.yaml" \
  --model "$humanoid" 2>"$tmp/err" >/dev/null
rc=$?
[ "$rc" -eq 2 ] || fail "bad map: exit $rc"
grep -qF "bad.yaml:" "$tmp/err" && grep -qF "(did you mean 'pelvis'?)" "$tmp/err" ||
  fail "bad map message: $(cat "$tmp/err")"
[ "$(grep -c . "$tmp/err")" -eq 1 ] || fail "bad map: more than one line"
cmp -s "$tmp/walk.csv" "$tmp/before.csv" || fail "the earlier output changed"

[ "$fails" -eq 0 ] && echo "bvh retarget: all passed"
[ "$fails" -eq 0 ]
