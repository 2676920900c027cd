#!/usr/bin/env bash
# stance sweep: outputs, identical CSVs for 1 and 2 threads, the plot, and bad input.
set -u
stance=$1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fails=0
fail() {
  echo "FAIL: $*"
  fails=$((fails + 1))
}

scn=scenarios/slope_walk.yaml
for n in 1 2; do
  "$stance" sweep "$scn" --param controllers.0.hip_kp --values 9,10.5 --duration 15 \
    --threads $n --out "$tmp/t$n" --quiet >"$tmp/stdout$n" 2>"$tmp/stderr$n" ||
    fail "sweep --threads $n exited $? ($(cat "$tmp/stderr$n"))"
done
[ -s "$tmp/t1/sweep.csv" ] && [ -s "$tmp/t1/points.csv" ] || fail "sweep.csv/points.csv missing"
head -1 "$tmp/t1/sweep.csv" | grep -q '^controllers.0.hip_kp,fell,diverged,sim_time,error,' ||
  fail "sweep.csv header: $(head -1 "$tmp/t1/sweep.csv")"
[ "$(wc -l <"$tmp/t1/sweep.csv")" -eq 3 ] || fail "sweep.csv rows"
cmp -s "$tmp/t1/sweep.csv" "$tmp/t2/sweep.csv" || fail "sweep.csv differs between 1 and 2 threads"
cmp -s "$tmp/t1/points.csv" "$tmp/t2/points.csv" || fail "points.csv differs between 1 and 2 threads"

# the plot, when gnuplot is there
if command -v gnuplot >/dev/null 2>&1; then
  "$stance" sweep "$scn" --param controllers.0.hip_kp --from 9 --to 10 --steps 2 --duration 15 \
    --set controllers.0.transient_steps=5 --out "$tmp/plot" --plot --quiet >/dev/null 2>"$tmp/stderr_plot" || fail "sweep --plot"
  [ -s "$tmp/plot/steady_step_lengths_m.png" ] || fail "no PNG: $(cat "$tmp/stderr_plot")"
  head -c 8 "$tmp/plot/steady_step_lengths_m.png" | grep -q PNG || fail "not a PNG"
fi

# bad input: one line on stderr, exit 2
"$stance" sweep "$scn" --param controllers.0.hip_kpp --values 1,2 --out "$tmp/bad" \
  >/dev/null 2>"$tmp/err1"
rc=$?
{ [ $rc -eq 2 ] && grep -q "hip_kpp" "$tmp/err1" && [ "$(grep -c . "$tmp/err1")" -eq 1 ]; } ||
  fail "bad key: rc=$rc $(cat "$tmp/err1")"
"$stance" sweep "$scn" --param controllers.0.hip_kp --out "$tmp/bad" >/dev/null 2>"$tmp/err2"
rc=$?
{ [ $rc -eq 2 ] && grep -q "give --from and --to, or --values" "$tmp/err2"; } ||
  fail "no values: rc=$rc $(cat "$tmp/err2")"
"$stance" sweep "$scn" --param controllers.0.hip_kp --values 4,abc >/dev/null 2>"$tmp/err3"
rc=$?
{ [ $rc -eq 2 ] && grep -q "'abc' is not a finite number" "$tmp/err3"; } ||
  fail "bad value: rc=$rc $(cat "$tmp/err3")"

echo "$fails failed"
[ "$fails" -eq 0 ]
