#!/usr/bin/env bash
# Outputs are never torn: a run killed (SIGKILL) while writing leaves the previous complete files,
# its temporary is removed by the next run into the folder, and Ctrl-C (SIGINT) ends a run with
# exit 130, a whole log.csv and a summary.json saying "interrupted": true.
set -u
stance=$1
tmp=$(mktemp -d)
pids=()
trap 'for p in "${pids[@]}"; do kill -9 "$p" 2>/dev/null; done; rm -rf "$tmp"' EXIT
fails=0
fail() {
  echo "FAIL: $*"
  fails=$((fails + 1))
}
sums() { (cd "$1" && md5sum summary.json log.csv); }

# wait (up to a minute; not a timing check) until the run $1 has streamed $2 bytes of log.csv
wait_for_log() {
  local tmpfile="$tmp/out/.log.csv.stance-$1.tmp"
  for _ in $(seq 600); do
    [ -f "$tmpfile" ] && [ "$(stat -c %s "$tmpfile")" -ge "$2" ] && return 0
    kill -0 "$1" 2>/dev/null || return 1
    sleep 0.1
  done
  return 1
}

long="scenarios/pd_hold.yaml --duration 100000 --quiet --out $tmp/out"

# a previous complete run
"$stance" run scenarios/pd_hold.yaml --duration 1 --quiet --out "$tmp/out" || fail "first run"
before=$(sums "$tmp/out")

# SIGKILL in the middle of writing log.csv: the previous files stay whole, the temporary remains
# shellcheck disable=SC2086
"$stance" run $long &
pid=$!
pids+=("$pid")
if wait_for_log "$pid" 200000; then
  kill -9 "$pid"
  wait "$pid" 2>/dev/null
  [ "$(sums "$tmp/out")" = "$before" ] || fail "SIGKILL changed summary.json or log.csv"
  [ -f "$tmp/out/.log.csv.stance-$pid.tmp" ] || fail "no temporary left by the killed run"
else
  fail "the long run did not start writing"
fi

# the next run into the folder removes the killed run's temporary and writes whole files
"$stance" run scenarios/pd_hold.yaml --duration 0.5 --quiet --out "$tmp/out" || fail "next run"
leftovers=$(find "$tmp/out" -name '.*.tmp' | wc -l)
[ "$leftovers" -eq 0 ] || fail "$leftovers temporaries left after the next run"
[ "$(tail -1 "$tmp/out/log.csv" | cut -d, -f1)" = "0.500000" ] || fail "next run's log.csv"

# SIGINT: exit 130, the log flushed and renamed, the summary says interrupted at its time
"$stance" run $long 2>"$tmp/stderr" &
pid=$!
pids+=("$pid")
if wait_for_log "$pid" 200000; then
  kill -INT "$pid"
  wait "$pid"
  rc=$?
  [ "$rc" -eq 130 ] || fail "SIGINT: exit $rc, want 130"
  grep -q "^interrupted at t=[0-9.]* s; summary.json and log.csv written$" "$tmp/stderr" ||
    fail "SIGINT message: $(cat "$tmp/stderr")"
  python3 - "$tmp/out" <<'PY' || fail "SIGINT outputs"
import csv, json, sys
d = sys.argv[1]
s = json.load(open(d + "/summary.json"))
assert s["interrupted"] is True and s["diverged"] is False, s
rows = list(csv.reader(open(d + "/log.csv")))
assert all(len(r) == len(rows[0]) for r in rows), "a torn row"
last = float(rows[-1][0])
assert 1 < s["sim_time"] < 100000 and abs(last - s["sim_time"]) < 0.011, (last, s["sim_time"])
PY
  [ "$(find "$tmp/out" -name '.*.tmp' | wc -l)" -eq 0 ] || fail "SIGINT left a temporary"
else
  fail "the long run did not start writing"
fi

echo "$fails failed"
[ "$fails" -eq 0 ]
