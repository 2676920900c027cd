#!/usr/bin/env bash
# stance bvh track over a folder: one subfolder per clip with the files of that clip's single run,
# byte for byte (summary.json's wall clock aside); results.csv and results.md with a row per clip,
# an unreadable clip a row with its error (exit 2); --resume after a clip's folder is deleted,
# after Ctrl-C and after a kill gives the same results; bad input is one line and exit 2.
set -u
# shellcheck source=tests/cli/lib.sh
. "$(dirname "$0")/lib.sh"
stance=$1
tmp=$(mktemp -d)
pid=
trap '[ -n "$pid" ] && kill -9 "$pid" 2>/dev/null; rm -rf "$tmp"' EXIT

# two short clips, one in a subfolder, and a file that is not a BVH
mkdir -p "$tmp/clips/more"
"$stance" bvh synth-walk "$tmp/clips/walk.bvh" >/dev/null || fail "synth-walk"
"$stance" bvh synth-run "$tmp/clips/more/run.bvh" >/dev/null || fail "synth-run"
printf 'HIERARCHY\nROOT Hips\n{\n' >"$tmp/clips/broken.bvh"
echo "not a clip" >"$tmp/clips/notes.txt"
# a small planner: this checks the batch, not the tracking
opts=(--duration 0.3 --threads 2 --set planner.samples=8 --set planner.horizon_s=0.3 --quiet)

# results.csv without its wall-clock and CPU-time columns (the last two), for comparing runs
results() {
  python3 -c "
import csv, sys
for row in csv.reader(open(sys.argv[1])): print(row[:-2])" "$1"
}
# summary.json without the wall-clock fields
summary() {
  python3 -c "
import json, sys
s = json.load(open(sys.argv[1]))
for k in ('wall_time_s',): s.pop(k)
for k in ('realtime_factor', 'compute_s_per_sim_s', 'cpu_s_per_sim_s'): s['metrics'].pop(k)
for k in ('compute_s_per_sim_s', 'cpu_s_per_sim_s'): s['metrics']['mocap'].pop(k)
print(json.dumps(s, sort_keys=True))" "$1"
}
# same_clip DIR_A DIR_B: the same files of one clip's run
same_clip() {
  for f in track.yaml character.xml log.csv tracked.bvh; do
    cmp -s "$1/$f" "$2/$f" || fail "$f differs: $1 and $2"
  done
  [ "$(summary "$1/summary.json")" = "$(summary "$2/summary.json")" ] ||
    fail "summary.json differs: $1 and $2"
}

"$stance" bvh track "$tmp/clips" --out "$tmp/all" "${opts[@]}" >"$tmp/out" 2>"$tmp/err"
code=$?
[ "$code" -eq 2 ] || fail "a batch with an unreadable clip exited $code, want 2: $(cat "$tmp/err")"
python3 - "$tmp/all/results.csv" <<'PY' || fail "results.csv: $(cat "$tmp/all/results.csv")"
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
assert [r["clip"] for r in rows] == ["broken", "more/run", "walk"], rows
broken, run, walk = rows
assert "broken.bvh:4" in broken["error"] and broken["g_mpjpe_m"] == "", broken
for r in (run, walk):
    assert r["error"] == "" and r["fell"] == "0" and r["success"] == "1", r
    assert abs(float(r["sim_s"]) - 0.3) < 1e-9 and 0 < float(r["g_mpjpe_m"]) < 0.2, r
assert walk["frames"] == "67" and run["frames"] == "43", rows
assert broken["cpu_s_per_sim_s"] == "", broken
PY
grep -q "^3 clips: 2 succeeded (66.7%), 0 fell, 0 diverged, 1 could not be read; G-MPJPE median" \
  "$tmp/out" || fail "no summary line: $(cat "$tmp/out")"
grep -q "^3 clips: 2 succeeded" "$tmp/all/results.md" || fail "results.md has no summary line"
grep -q "^| walk | 67 |" "$tmp/all/results.md" || fail "results.md: $(cat "$tmp/all/results.md")"
[ "$(grep -c '^error: ' "$tmp/err")" -eq 1 ] || fail "not one error line: $(cat "$tmp/err")"
if command -v gnuplot >/dev/null; then
  [ -s "$tmp/all/results.png" ] || fail "no results.png"
fi
[ -d "$tmp/all/broken" ] && fail "the unreadable clip got a folder"

# each clip's folder is its single run's
"$stance" bvh track "$tmp/clips/more/run.bvh" --out "$tmp/single" "${opts[@]}" >/dev/null 2>&1 ||
  fail "the single run exited $?"
same_clip "$tmp/all/more/run" "$tmp/single"
# its own CPU time too, though the batch ran two clips at once in one process: loose bounds, the
# same order of magnitude (timing decides nothing finer)
python3 - "$tmp/all/results.csv" "$tmp/single/summary.json" <<'PY' || fail "per-clip CPU time"
import csv, json, sys
row = [r for r in csv.DictReader(open(sys.argv[1])) if r["clip"] == "more/run"][0]
single = json.load(open(sys.argv[2]))["metrics"]["mocap"]["cpu_s_per_sim_s"]
assert single > 0 and single / 3 < float(row["cpu_s_per_sim_s"]) < single * 3, (row, single)
PY
results "$tmp/all/results.csv" >"$tmp/expected"

# --resume after a clip's folder is deleted: that clip runs again, the same
cp -r "$tmp/all" "$tmp/again"
rm -rf "$tmp/again/walk"
"$stance" bvh track "$tmp/clips" --out "$tmp/again" "${opts[@]}" --resume >"$tmp/out" 2>&1
grep -q "(1 kept from the earlier run)" "$tmp/out" || fail "resume kept: $(cat "$tmp/out")"
same_clip "$tmp/all/walk" "$tmp/again/walk"
results "$tmp/again/results.csv" | cmp -s - "$tmp/expected" || fail "resumed results.csv differs"

# Ctrl-C, then a kill: the finished clips are kept and --resume gives the same results. One clip
# at a time, the broken one first
for signal in INT KILL; do
  cut="$tmp/cut_$signal"
  "$stance" bvh track "$tmp/clips" --out "$cut" "${opts[@]}" --jobs 1 >/dev/null 2>"$tmp/err" &
  pid=$!
  wait_for_file "$pid" "$cut/more/run/summary.json"
  kill -"$signal" "$pid" 2>/dev/null
  wait "$pid" 2>/dev/null
  code=$?
  pid=
  if [ "$signal" = INT ] && [ "$code" -eq 130 ]; then
    grep -q "^interrupted: .* --resume" "$tmp/err" || fail "no resume hint: $(cat "$tmp/err")"
    [ -f "$cut/results.csv" ] && fail "an interrupted batch wrote results.csv"
  fi
  "$stance" bvh track "$tmp/clips" --out "$cut" "${opts[@]}" --resume >/dev/null 2>&1
  [ $? -eq 2 ] || fail "the resumed batch ($signal) did not exit 2"
  results "$cut/results.csv" | cmp -s - "$tmp/expected" || fail "results.csv after $signal differs"
  same_clip "$tmp/all/walk" "$cut/walk"
done

# another option on --resume is refused
"$stance" bvh track "$tmp/clips" --out "$tmp/again" --duration 0.2 --resume --quiet \
  >/dev/null 2>"$tmp/err"
[ $? -eq 2 ] || fail "a resume with another --duration was not refused"
grep -q "option 'duration' was 0.3" "$tmp/err" || fail "mismatch message: $(cat "$tmp/err")"

# bad input: one line, exit 2
mkdir "$tmp/empty"
bad() {  # expected-message args...
  local want=$1
  shift
  "$stance" bvh track "$@" --out "$tmp/bad" --quiet >/dev/null 2>"$tmp/err"
  local c=$?
  [ "$c" -eq 2 ] || fail "bvh track $* exited $c, want 2"
  [ "$(wc -l <"$tmp/err")" -eq 1 ] || fail "bvh track $*: not one line: $(cat "$tmp/err")"
  grep -q -- "$want" "$tmp/err" || fail "bvh track $*: $(cat "$tmp/err")"
}
bad "empty: no .bvh file in this folder" "$tmp/empty"
bad "nothing.bvh: no such file or folder" "$tmp/clips/walk.bvh" "$tmp/nothing.bvh"
bad "no file or folder matches" "$tmp/none/*.bvh"
bad "has no track_batch.json" "$tmp/clips" --resume
bad "one clip alone has nothing to resume" "$tmp/clips/walk.bvh" --resume
bad "--record: renders one clip" "$tmp/clips" --record "$tmp/x.mp4"
[ -d "$tmp/bad" ] && fail "bad input wrote its output folder"

echo "$fails failed"
[ "$fails" -eq 0 ]
