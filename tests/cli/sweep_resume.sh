#!/usr/bin/env bash
# Ctrl-C on `stance sweep` keeps every finished run (sweep.partial.json), and --resume runs the
# rest into sweep.csv and points.csv equal to an uninterrupted sweep's.
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
sweep=(sweep scenarios/simbicon_walk.yaml --param controllers.0.gait.states.0.cv --from 0
  --to 0.4 --steps 24 --duration 6 --threads 1 --quiet)

"$stance" "${sweep[@]}" --out "$tmp/whole" >/dev/null || fail "uninterrupted sweep"
[ -f "$tmp/whole/sweep.partial.json" ] && fail "a finished sweep left its resume file"

"$stance" "${sweep[@]}" --out "$tmp/cut" >/dev/null 2>"$tmp/cut.err" &
pid=$!
wait_for_file "$pid" "$tmp/cut/sweep.partial.json"
kill -INT "$pid" 2>/dev/null
wait "$pid"
code=$?
pid=
if [ "$code" -eq 130 ]; then
  grep -q "interrupted: .* --resume" "$tmp/cut.err" || fail "no resume hint: $(cat "$tmp/cut.err")"
  [ -f "$tmp/cut/sweep.csv" ] && fail "an interrupted sweep wrote sweep.csv"
  # another value list is refused
  other=("${sweep[@]}")
  other[9]=25  # --steps 25
  "$stance" "${other[@]}" --resume "$tmp/cut" >/dev/null 2>"$tmp/err"
  [ $? -eq 2 ] || fail "a resume with other values was not refused with exit 2"
  grep -q "option 'values' was" "$tmp/err" || fail "mismatch message: $(cat "$tmp/err")"
  "$stance" "${sweep[@]}" --resume "$tmp/cut" >/dev/null || fail "resume"
else
  [ "$code" -eq 0 ] || fail "interrupted sweep exited $code"
fi
for f in sweep.csv points.csv; do
  cmp -s "$tmp/whole/$f" "$tmp/cut/$f" || fail "resumed $f differs from the uninterrupted sweep's"
done
[ -f "$tmp/cut/sweep.partial.json" ] && fail "the resumed sweep left its resume file"
[ $fails -eq 0 ] && echo "sweep_resume: all checks passed"
exit $((fails > 0))
