#!/usr/bin/env bash
# Peak resident memory of `stance run` over a 60 s and a 600 s run of the scenarios whose
# controllers keep per-step records (SIMBICON's and the slope walker's steps, the tracker's
# exported frames): what still grows with a run's length. Prints docs/results.md's table.
#   bash bench/peak_rss.sh build/stance
set -eu
stance=$1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
echo "| run | 60 s | 600 s | growth per simulated minute |"
echo "|---|---|---|---|"
row() {
  local label=$1
  shift
  local kb=()
  for d in 60 600; do
    rm -rf "$tmp/out"
    /usr/bin/time -f '%M' -o "$tmp/rss" "$stance" run "$@" --duration "$d" --past-fall \
      --out "$tmp/out" --quiet >/dev/null 2>&1 || true
    kb+=("$(tail -1 "$tmp/rss")")
    # the run must have gone its whole length (a diverged or failed run measures nothing)
    python3 -c "import json, sys; t = json.load(open('$tmp/out/summary.json'))['sim_time']
sys.exit(0 if t >= $d - 0.01 else 'run stopped at %g s of $d' % t)" || exit 1
  done
  awk -v l="$label" -v a="${kb[0]}" -v b="${kb[1]}" 'BEGIN {
    printf "| %s | %.1f MB | %.1f MB | %.3f MB |\n", l, a / 1024, b / 1024, (b - a) / 1024 / 9 }'
}
row "\`simbicon_walk\` (MuJoCo, 1700 Hz, steps.csv)" scenarios/simbicon_walk.yaml
row "\`slope_walk\` (steps.csv)" scenarios/slope_walk.yaml
row "\`mocap_track\` (log.csv only)" scenarios/mocap_track.yaml
row "\`mocap_track\` with \`--export-bvh\`" scenarios/mocap_track.yaml --export-bvh "$tmp/out.bvh"
