#!/usr/bin/env bash
# make eval-track's tables (scripts/eval_track_table.py) from batch folders: every run's row, the
# per-clip summary (runs that hold, metric spans, CPU at the seed settings) and both tables put
# between a docs file's markers, the text around them kept.
set -u
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# shellcheck source=tests/cli/lib.sh
. "$(dirname "$0")/lib.sh"

header="clip,frames,clip_s,sim_s,fell,diverged,success,g_mpjpe_m,root_error_m,joint_error_deg,"
header+="foot_skate_m_per_s,error,compute_s_per_sim_s,cpu_s_per_sim_s"
mkdir -p "$tmp/looped/seed1" "$tmp/looped/seed2" "$tmp/looped/kp0.8"
printf '%s\n%s\n%s\n' "$header" "walk,66,1.1,20,0,0,1,0.060,0.040,2.0,0.50,,3.0,4.0" \
  "run,43,0.7,20,0,0,1,0.110,0.090,3.5,0.70,,4.0,6.0" >"$tmp/looped/seed1/results.csv"
printf '%s\n%s\n%s\n' "$header" "walk,66,1.1,20,0,0,1,0.070,0.045,2.5,0.55,,3.5,5.0" \
  "run,43,0.7,20,0,0,0,0.139,0.117,4.1,0.67,,8.0,8.0" >"$tmp/looped/seed2/results.csv"
# kp x0.8: the walk falls; the run's file could not be read (an error row)
printf '%s\n%s\n%s\n' "$header" "walk,66,1.1,1.5,1,0,0,0.300,0.250,9.0,0.90,,3.0,9.0" \
  "run,,,,,,,,,,,run.bvh:3: bad channel,," >"$tmp/looped/kp0.8/results.csv"
printf 'intro\n<!-- EVAL-TRACK-SUMMARY BEGIN -->\nold\n<!-- EVAL-TRACK-SUMMARY END -->\nmiddle\n%s\n' \
  '<!-- EVAL-TRACK BEGIN -->' >"$tmp/results.md"
printf 'old\n<!-- EVAL-TRACK END -->\nend\n' >>"$tmp/results.md"

python3 scripts/eval_track_table.py "$tmp" --groups looped --settings seed1 seed2 kp0.8 \
  --docs "$tmp/results.md" >"$tmp/out" 2>&1 || fail "the table script: $(cat "$tmp/out")"
summary=$(cat "$tmp/summary.md")
grep -qF "| walk | 2 of 3 | 6.0-30.0 | 4.0-25.0 | 2.0-9.0 | 0.50-0.90 | 4.0-5.0 |" <<<"$summary" ||
  fail "walk's summary row: $summary"
grep -qF "| run | 1 of 3 | 11.0-13.9 | 9.0-11.7 | 3.5-4.1 | 0.67-0.70 | 6.0-8.0 |" <<<"$summary" ||
  fail "run's summary row: $summary"
grep -qF "**3 of 6 runs hold**, 1 fell; median G-MPJPE 11.0 cm; CPU per simulated second at the \
defaults: median 5.5 s, at most 8.0 s." <<<"$summary" || fail "the totals: $summary"
table=$(cat "$tmp/table.md")
grep -qF "| walk | kp0.8 | 1.5 | yes | no | 0.300 | 0.250 | 9.00 | 0.900 | 3.0 | 9.0 | FAIL |" \
  <<<"$table" || fail "the fallen run's row: $table"
grep -qF "| run | kp0.8 | - | - | - | - | - | - | - | - | - | ERROR: run.bvh:3: bad channel |" \
  <<<"$table" || fail "the error row: $table"
[ "$(grep -c PASS <<<"$table")" -eq 3 ] || fail "three runs pass: $table"
docs=$(cat "$tmp/results.md")
grep -q "^old$" <<<"$docs" && fail "the docs keep an old table: $docs"
for kept in intro middle end; do
  grep -q "^$kept$" <<<"$docs" || fail "the docs lost '$kept': $docs"
done
grep -qF "| walk | 2 of 3 |" <<<"$docs" || fail "the summary is not in the docs"
grep -qF "| run | seed2 |" <<<"$docs" || fail "the table is not in the docs"

# a docs file without the markers: an error, the file untouched
echo "no markers" >"$tmp/plain.md"
python3 scripts/eval_track_table.py "$tmp" --groups looped --settings seed1 \
  --docs "$tmp/plain.md" >"$tmp/out" 2>&1 && fail "docs without markers accepted"
grep -q "no <!-- EVAL-TRACK BEGIN/END --> markers" "$tmp/out" || fail "message: $(cat "$tmp/out")"
[ "$(cat "$tmp/plain.md")" = "no markers" ] || fail "the file without markers was changed"
[ "$fails" -eq 0 ]
