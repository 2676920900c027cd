#!/usr/bin/env bash
# stance robustness end to end: the output files, Ctrl-C keeps every finished direction and phase,
# --resume finishes the rest into files equal to an uninterrupted run's, and bad input is one line
# with exit 2.
set -u
# shellcheck source=tests/cli/lib.sh
. "$(dirname "$0")/lib.sh"
stance=$1
tmp=$(mktemp -d)
pid=
trap '[ -n "$pid" ] && kill -9 "$pid" 2>/dev/null; rm -rf "$tmp"' EXIT
fails=0
fail() {
  echo "FAIL: $*"
  fails=$((fails + 1))
}
map="scenarios/simbicon_walk.yaml --body torso --phases 4 --max 400 --tolerance 5 --at 3 \
  --duration 7 --threads 1 --quiet"

# shellcheck disable=SC2086
"$stance" robustness $map --out "$tmp/whole" >"$tmp/whole.txt" 2>&1 || fail "uninterrupted run"
for f in robustness.csv thresholds.csv summary.json robustness.png; do
  [ -s "$tmp/whole/$f" ] || fail "no $f"
done
[ -f "$tmp/whole/robustness.partial.json" ] && fail "a finished run left its resume file"
# a planar walker: two directions (its plane's senses) x 4 phases, a header and 8 rows
[ "$(wc -l <"$tmp/whole/thresholds.csv")" -eq 9 ] || fail "thresholds.csv rows"
grep -q "planar model" "$tmp/whole.txt" || fail "the planar note is not printed"
grep -q '"kind": "walker"' "$tmp/whole/summary.json" || fail "not found to be a walker"

# Ctrl-C once the first direction and phase are kept: exit 130, no final files
# shellcheck disable=SC2086
"$stance" robustness $map --out "$tmp/cut" >"$tmp/cut.txt" 2>"$tmp/cut.err" &
pid=$!
wait_for_file "$pid" "$tmp/cut/robustness.partial.json"
kill -INT "$pid" 2>/dev/null
wait "$pid"
code=$?
pid=
if [ "$code" -eq 130 ]; then
  grep -q "interrupted: .* --resume" "$tmp/cut.err" || fail "no resume hint: $(cat "$tmp/cut.err")"
  [ -f "$tmp/cut/thresholds.csv" ] && fail "an interrupted run wrote thresholds.csv"
  [ -f "$tmp/cut/robustness.partial.json" ] || fail "no resume file"
else
  # the machine was faster than the signal: then the files must be whole already
  [ "$code" -eq 0 ] || fail "interrupted run exited $code"
fi

# a resume with another option is refused, the kept cells untouched
if [ "$code" -eq 130 ]; then
  before=$(md5sum "$tmp/cut/robustness.partial.json")
  # shellcheck disable=SC2086
  "$stance" robustness ${map/--max 400/--max 300} --resume "$tmp/cut" >/dev/null 2>"$tmp/err"
  [ $? -eq 2 ] || fail "a resume with another --max was not refused with exit 2"
  grep -q "option 'max' was 400" "$tmp/err" || fail "resume mismatch message: $(cat "$tmp/err")"
  [ "$(md5sum "$tmp/cut/robustness.partial.json")" = "$before" ] || fail "refused resume wrote"
  # shellcheck disable=SC2086
  "$stance" robustness $map --resume "$tmp/cut" >"$tmp/resume.txt" 2>&1 || fail "resume"
fi
for f in robustness.csv thresholds.csv summary.json; do
  cmp -s "$tmp/whole/$f" "$tmp/cut/$f" || fail "resumed $f differs from the uninterrupted run's"
done
[ -f "$tmp/cut/robustness.partial.json" ] && fail "the resumed run left its resume file"

# bad input: one line, exit 2
check_bad() {
  local expect=$1
  shift
  "$stance" "$@" >/dev/null 2>"$tmp/err"
  local c=$?
  [ $c -eq 2 ] || fail "exit $c (not 2) for: $*"
  [ "$(wc -l <"$tmp/err")" -eq 1 ] || fail "not one line for: $*: $(cat "$tmp/err")"
  grep -q -- "$expect" "$tmp/err" || fail "no '$expect' for: $*: $(cat "$tmp/err")"
}
check_bad "directions 0" robustness scenarios/biped_stand.yaml --body h_spine --directions 0 \
  --out "$tmp/bad"
check_bad "unknown body 'h_spline'" robustness scenarios/biped_stand.yaml --body h_spline \
  --out "$tmp/bad"
check_bad "--point 'middle'" robustness scenarios/biped_stand.yaml --body h_spine --point middle \
  --out "$tmp/bad"
check_bad "nothing to resume" robustness scenarios/biped_stand.yaml --body h_spine \
  --resume "$tmp/none"
[ -e "$tmp/bad" ] && fail "bad input created the output folder"

[ $fails -eq 0 ] && echo "robustness: all checks passed"
exit $((fails > 0))
