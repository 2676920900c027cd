#!/usr/bin/env bash
# make bench's tracking video and viewer figures (issue 42), on the synthetic walk tracked with the
# planner at the shipped defaults:
#  - what --record costs: the same 2 s `stance bvh track` with and without --record, twice each,
#    alternated; the ratio of the quicker of each pair (goal: at most 1.3);
#  - whether the viewer keeps real time: 10 s of wall time of `stance bvh track --view` under
#    Xvfb, the simulated time over the wall time (goal: at least 0.9), beside the pace of the run
#    alone (the same 2 s without a window) and the viewer's pace with the planner off (what the
#    window itself costs: 1.0x when it leaves the physics enough). Skipped without xvfb-run.
#   bench/tracking_view.sh [BUILD_DIR]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-build}
[[ $build = /* ]] || build=$root/$build
stance=$build/stance
clip=$root/models/synthetic_walk.bvh
if [ ! -x "$stance" ]; then
  echo "tracking_view.sh: $stance not found (build the stance_cli target)" >&2
  exit 2
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

wall_of() {  # the command's wall time in seconds
  local t0 t1
  t0=$(date +%s.%N)
  "$@" >"$tmp/out.txt" 2>&1 || { echo "nan"; return; }
  t1=$(date +%s.%N)
  python3 -c "print(f'{$t1 - $t0:.2f}')"
}

track=(bvh track "$clip" --loop --duration 2 --threads 2 --quiet)
echo "tracking_view.sh: 2 s of the tracked walk, with and without --record (twice each)" >&2
plain=() recorded=()
for _ in 1 2; do
  plain+=("$(wall_of "$stance" "${track[@]}" --out "$tmp/plain")")
  recorded+=("$(wall_of "$stance" "${track[@]}" --out "$tmp/rec" --record "$tmp/rec/walk.mp4")")
done
python3 - "${plain[@]}" "${recorded[@]}" <<'PY'
import sys
plain, rec = [float(x) for x in sys.argv[1:3]], [float(x) for x in sys.argv[3:5]]
print(f"--record of 2 s of the tracked walk (640x360, 30 fps): {min(rec):.2f} s against "
      f"{min(plain):.2f} s without, {min(rec) / min(plain):.2f}x (runs: {rec} / {plain}; goal 1.3x)")
print(f"the tracked walk alone, planner on: {2 / min(plain):.3f}x real time")
PY

if ! command -v xvfb-run >/dev/null; then
  echo "viewer on the tracked walk: not measured (no xvfb-run)"
  exit 0
fi
echo "tracking_view.sh: 10 s of the viewer on the tracked walk under Xvfb" >&2
if xvfb-run -a -s "-screen 0 1400x900x24" "$stance" bvh track "$clip" --loop --duration 600 \
  --threads 2 --out "$tmp/view" --view --quit-after 10 >"$tmp/view.txt" 2>&1; then
  pace=$(grep -o '[0-9.]*x real time' "$tmp/view.txt" | head -1)
  echo "viewer on the tracked walk, planner on (Xvfb, 10 s of wall time): ${pace:-no figure} (goal 0.9x)"
else
  echo "viewer on the tracked walk: the viewer failed: $(tail -1 "$tmp/view.txt")"
fi
if xvfb-run -a -s "-screen 0 1400x900x24" "$stance" bvh track "$clip" --loop --duration 600 \
  --threads 2 --out "$tmp/view_off" --view --quit-after 10 --set planner.enabled=false \
  >"$tmp/view_off.txt" 2>&1; then
  pace=$(grep -o '[0-9.]*x real time' "$tmp/view_off.txt" | head -1)
  echo "viewer on the tracked walk, planner off (the window's own cost): ${pace:-no figure}"
fi
