#!/usr/bin/env bash
# stance tune: outputs on a tiny budget, the --set lines, and bad input (one line, exit 2).
set -u
stance=$1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fails=0
fail() {
  echo "FAIL: $*"
  fails=$((fails + 1))
}

scn=scenarios/biped_stand.yaml
"$stance" tune "$scn" --param controllers.0.kp=20:1000:log --param controllers.0.kd=2:100:log \
  --neighbour "controllers.0.kp*=0.8,controllers.0.kd*=0.8" --set controllers.0.kp=40 \
  --set controllers.0.kd=4 --budget 6 --population 3 --duration 1 --threads 2 \
  --metric com_displacement_m --out "$tmp/t" >"$tmp/stdout" 2>"$tmp/stderr" ||
  fail "tune exited $? ($(cat "$tmp/stderr"))"
[ -s "$tmp/t/tune.csv" ] && [ -s "$tmp/t/best.yaml" ] && [ -s "$tmp/t/best_scenario.yaml" ] ||
  fail "tune.csv/best.yaml/best_scenario.yaml missing"
head -1 "$tmp/t/tune.csv" | grep -q '^generation,index,controllers.0.kp,controllers.0.kd,robust_score,worst_time_up_s,mean_metric,failed_runs$' ||
  fail "tune.csv header: $(head -1 "$tmp/t/tune.csv")"
[ "$(wc -l <"$tmp/t/tune.csv")" -eq 7 ] || fail "tune.csv rows: $(wc -l <"$tmp/t/tune.csv")"
# the first row is the start: the scenario's values after --set
sed -n 2p "$tmp/t/tune.csv" | grep -q '^0,0,40,4,' || fail "start row: $(sed -n 2p "$tmp/t/tune.csv")"
grep -q '^controllers.0.kp: ' "$tmp/t/best.yaml" || fail "best.yaml has no kp"
grep -q '^#   --set controllers.0.kd=' "$tmp/t/best.yaml" || fail "best.yaml has no --set lines"
[ "$(grep -c '^generation ' "$tmp/stdout")" -eq 2 ] || fail "progress lines: $(cat "$tmp/stdout")"
grep -q '^  --set controllers.0.kp=' "$tmp/stdout" || fail "no --set lines on stdout"

# bad input: one line on stderr naming the argument, exit 2, no output folder
check_bad() {
  local what=$1 pattern=$2
  shift 2
  "$stance" tune "$scn" --duration 0.3 --budget 2 --out "$tmp/bad" "$@" >/dev/null 2>"$tmp/err"
  local rc=$?
  { [ $rc -eq 2 ] && grep -qF -- "$pattern" "$tmp/err" && [ "$(grep -c . "$tmp/err")" -eq 1 ]; } ||
    fail "$what: rc=$rc $(cat "$tmp/err")"
}
check_bad "malformed param" "--param 'controllers.0.kp=20'" --param controllers.0.kp=20
check_bad "lo >= hi" "--param 'controllers.0.kp=500:100'" --param controllers.0.kp=500:100
check_bad "log with lo <= 0" "--param 'controllers.0.kp=0:100:log'" --param controllers.0.kp=0:100:log
check_bad "unknown key" "--param 'controllers.0.kpp=1:2'" --param controllers.0.kpp=1:2
check_bad "malformed neighbour" "--neighbour 'controllers.0.kp*=abc'" \
  --param controllers.0.kp=100:500 --neighbour "controllers.0.kp*=abc"
check_bad "unknown neighbour key" "--neighbour 'controllers.0.kq*=2'" \
  --param controllers.0.kp=100:500 --neighbour "controllers.0.kq*=2"
check_bad "unknown metric" "--metric 'mocap.mean_joint_error_deg'" \
  --param controllers.0.kp=100:500 --metric mocap.mean_joint_error_deg
check_bad "no param" "--param" --metric com_displacement_m
[ -e "$tmp/bad" ] && fail "a failed tune wrote $tmp/bad"

echo "$fails failed"
[ "$fails" -eq 0 ]
