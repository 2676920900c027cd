#!/usr/bin/env bash
# stance tune resumes: Ctrl-C (SIGINT) after the first generation keeps the finished generations
# and the optimiser's state (exit 130, one line saying how to go on); --resume with other options
# is refused (one line, exit 2); --resume DIR finishes the search, and tune.csv, best.yaml and
# best_scenario.yaml equal those of an uninterrupted run, for both methods.
set -u
# shellcheck source=tests/cli/lib.sh
. "$(dirname "$0")/lib.sh"
stance=$1
tmp=$(mktemp -d)
pids=()
# shellcheck disable=SC2154
trap 'for p in "${pids[@]}"; do kill -9 "$p" 2>/dev/null; done; rm -rf "$tmp"' EXIT
fails=0
fail() {
  echo "FAIL: $*"
  fails=$((fails + 1))
}

# wait (up to a minute; not a timing check) until the tune $1 has written its first checkpoint
# the arm of pd_hold: 10 generations of cheap runs, each a few tenths of a second
args=(scenarios/pd_hold.yaml --param controllers.0.kp=5:200:log --param controllers.0.kd=0.1:20:log
  --neighbour "controllers.0.kp*=0.8" --metric "com_displacement_m+0.01*torque_rms"
  --duration 10 --budget 40 --population 4 --quiet)

for method in cem cmaes; do
  whole=$tmp/whole_$method
  part=$tmp/part_$method
  "$stance" tune "${args[@]}" --method "$method" --threads 2 --out "$whole" >/dev/null ||
    fail "$method: uninterrupted tune"
  [ -e "$whole/tune.partial.json" ] && fail "$method: a finished tune left tune.partial.json"

  # SIGINT once the first generation is written
  "$stance" tune "${args[@]}" --method "$method" --threads 2 --out "$part" >/dev/null \
    2>"$tmp/stderr" &
  pid=$!
  pids+=("$pid")
  if ! wait_for_file "$pid" "$part/tune.partial.json"; then
    fail "$method: no tune.partial.json written"
    continue
  fi
  kill -INT "$pid"
  wait "$pid"
  rc=$?
  [ "$rc" -eq 130 ] || fail "$method: SIGINT: exit $rc, want 130"
  grep -qx "interrupted: [0-9]* of 10 generations done, kept in $part/tune.partial.json; finish them with the same command and --resume $part" \
    "$tmp/stderr" || fail "$method: SIGINT message: $(cat "$tmp/stderr")"
  # what is kept: whole generations of the uninterrupted run, so far
  rows=$(($(wc -l <"$part/tune.csv") - 1))
  { [ $((rows % 4)) -eq 0 ] && [ "$rows" -ge 4 ] && [ "$rows" -lt 40 ]; } ||
    fail "$method: $rows candidates kept"
  head -$((rows + 1)) "$whole/tune.csv" | cmp -s - "$part/tune.csv" ||
    fail "$method: the kept rows differ from the uninterrupted run's"
  [ "$(find "$part" -name '.*.tmp' | wc -l)" -eq 0 ] || fail "$method: SIGINT left a temporary"

  # other options: refused, one line, exit 2, nothing changed
  before=$(md5sum "$part/tune.partial.json")
  "$stance" tune "${args[@]}" --method "$method" --seed 9 --resume "$part" >/dev/null \
    2>"$tmp/err"
  rc=$?
  { [ $rc -eq 2 ] && [ "$(grep -c . "$tmp/err")" -eq 1 ] &&
    grep -qxF "error: --resume $part: option 'seed' was 1 in the interrupted run, now 9" \
      "$tmp/err"; } || fail "$method: other seed: rc=$rc $(cat "$tmp/err")"
  [ "$(md5sum "$part/tune.partial.json")" = "$before" ] || fail "$method: a refused resume wrote"

  # the same command (another thread count is fine) and --resume: the uninterrupted files
  "$stance" tune "${args[@]}" --method "$method" --threads 1 --resume "$part" >/dev/null \
    2>"$tmp/err" || fail "$method: resume exited $? ($(cat "$tmp/err"))"
  for f in tune.csv best.yaml best_scenario.yaml; do
    cmp "$whole/$f" "$part/$f" || fail "$method: resumed $f differs"
  done
  [ -e "$part/tune.partial.json" ] && fail "$method: tune.partial.json left after the resume"
done

# nothing to resume
"$stance" tune "${args[@]}" --resume "$tmp/whole_cem" >/dev/null 2>"$tmp/err"
rc=$?
{ [ $rc -eq 2 ] && grep -qxF "error: --resume $tmp/whole_cem: no tune.partial.json there (nothing to resume)" \
  "$tmp/err"; } || fail "nothing to resume: rc=$rc $(cat "$tmp/err")"

echo "$fails failed"
[ "$fails" -eq 0 ]
