#!/usr/bin/env bash
# mpirun -np 2 spreads `stance bvh track FOLDER` over two ranks: every clip's folder and
# results.csv (its wall-clock and CPU-time columns aside) equal a threaded single-process batch's, and after
# --resume too.
set -u
# shellcheck source=tests/cli/lib.sh
. "$(dirname "$0")/../cli/lib.sh"
stance=$1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# root in containers and CI; more ranks than cores on a small machine
mpi=(mpirun -np 2 --oversubscribe --allow-run-as-root)
export OMPI_MCA_btl_vader_single_copy_mechanism=none

mkdir -p "$tmp/clips"
"$stance" bvh synth-walk "$tmp/clips/walk.bvh" >/dev/null || fail "synth-walk"
"$stance" bvh synth-run "$tmp/clips/run.bvh" >/dev/null || fail "synth-run"
cp "$tmp/clips/walk.bvh" "$tmp/clips/walk_again.bvh"
opts=(--duration 0.3 --threads 1 --set planner.samples=8 --set planner.horizon_s=0.3 --quiet
  --no-plot)

"$stance" bvh track "$tmp/clips" --out "$tmp/threads" "${opts[@]}" --jobs 2 >/dev/null ||
  fail "threaded batch"
"${mpi[@]}" "$stance" bvh track "$tmp/clips" --out "$tmp/mpi" "${opts[@]}" >"$tmp/mpi.txt" 2>&1 ||
  fail "mpirun batch: $(tail -3 "$tmp/mpi.txt")"
# rank 0 alone writes the table and prints the summary
[ "$(grep -c '^3 clips: ' "$tmp/mpi.txt")" -eq 1 ] ||
  fail "not one summary line: $(cat "$tmp/mpi.txt")"
python3 - "$tmp/threads/results.csv" "$tmp/mpi/results.csv" <<'PY' || fail "results.csv differs"
import csv, sys
a, b = ([row[:-2] for row in csv.reader(open(p))] for p in sys.argv[1:3])
assert len(a) == 4 and a == b, (a, b)
PY
for clip in run walk walk_again; do
  for f in track.yaml character.xml log.csv tracked.bvh; do
    cmp -s "$tmp/threads/$clip/$f" "$tmp/mpi/$clip/$f" || fail "$clip/$f differs under mpirun"
  done
done

# --resume under mpirun: a deleted clip is tracked again, the same
rm -rf "$tmp/mpi/walk"
"${mpi[@]}" "$stance" bvh track "$tmp/clips" --out "$tmp/mpi" "${opts[@]}" --resume \
  >"$tmp/mpi.txt" 2>&1 || fail "mpirun --resume: $(tail -3 "$tmp/mpi.txt")"
grep -q "(2 kept from the earlier run)" "$tmp/mpi.txt" || fail "resume: $(cat "$tmp/mpi.txt")"
for f in track.yaml character.xml log.csv tracked.bvh; do
  cmp -s "$tmp/threads/walk/$f" "$tmp/mpi/walk/$f" || fail "walk/$f differs after --resume"
done
python3 - "$tmp/threads/results.csv" "$tmp/mpi/results.csv" <<'PY' || fail "resumed results.csv"
import csv, sys
a, b = ([row[:-2] for row in csv.reader(open(p))] for p in sys.argv[1:3])
assert a == b, (a, b)
PY

[ "$fails" -eq 0 ] && echo "mpi track_batch: all checks passed"
exit $((fails > 0))
