# shellcheck shell=bash
# Shared by the CLI tests: sourced, not run.

# fail MESSAGE: print it and count it in $fails (a test ends with [ "$fails" -eq 0 ])
fails=0
fail() {
  echo "FAIL: $*"
  fails=$((fails + 1))
}

# wait_for_file PID FILE: until FILE exists (0), or process PID has ended or a minute has passed
# (1); the interrupting tests signal the run once its resume file is written
wait_for_file() {
  for _ in $(seq 1200); do
    [ -f "$2" ] && return 0
    kill -0 "$1" 2>/dev/null || return 1
    sleep 0.05
  done
  return 1
}
