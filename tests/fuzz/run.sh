#!/usr/bin/env bash
# run.sh BUILD SECONDS [TARGET...]: runs each libFuzzer target of a STANCE_SANITIZE tree.
#   SECONDS > 0: mutate for that long from the seeds (a working corpus in BUILD/fuzz/corpus/);
#   SECONDS = 0: run the seeds once (the ctest fuzz.<target>.seeds tests);
#   SECONDS = ci: a fixed number of executions per target (about 15 s each on a 2-core machine)
#                 from the seeds alone with seed 1, so that a CI run mutates the same inputs on
#                 every machine: what passed here passes there (make test-sanitize).
# Seeds: the files under tests/fuzz/corpus/<target>/ (the inputs that crashed stance before)
# plus the shipped files: models, scenarios, joint maps and dart-doc's .skel worlds.
# Fails when any target crashes, leaks or gets a sanitizer report; prints executions per target.
set -euo pipefail
build=$(cd "$1" && pwd)
seconds=$2
shift 2
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=(bvh scenario skel joint_map model bvh_track robot_step)
src=$(cd "$(dirname "$0")/../.." && pwd)
dart_skel=/usr/share/doc/dart/data/skel

export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1}
export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$src/tests/fuzz/lsan.supp:print_suppressions=0}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}

# seeds of one target into a fresh folder
make_seeds() {
  local target=$1 out=$2 f
  rm -rf "$out"
  mkdir -p "$out"
  cp "$src/tests/fuzz/corpus/$target/"* "$out/" 2>/dev/null || true
  case $target in
    bvh) cp "$src"/models/*.bvh "$out/" ;;
    scenario) cp "$src"/scenarios/*.yaml "$out/" ;;
    joint_map) cp "$src"/models/maps/*.yaml "$out/" ;;
    skel) [ -d "$dart_skel" ] && cp "$dart_skel"/*.skel "$out/" ;;
    model)
      # byte 0: engine (0 mujoco, 1 dart); byte 1: format (0 MJCF, 1 SKEL, 2 URDF, 3 SDF)
      for f in "$src"/models/*.xml; do
        { printf '\0\0'; cat "$f"; } >"$out/mujoco_$(basename "$f")"
        { printf '\1\0'; cat "$f"; } >"$out/dart_$(basename "$f")"
      done
      for f in "$src"/models/*.urdf "$src"/tests/cli/bad_inputs/*.urdf; do
        { printf '\0\2'; cat "$f"; } >"$out/mujoco_$(basename "$f")"
        { printf '\1\2'; cat "$f"; } >"$out/dart_$(basename "$f")"
      done
      for f in "$src"/tests/cli/bad_inputs/*.sdf "$src"/tests/fuzz/corpus/robots/*.sdf; do
        { printf '\0\3'; cat "$f"; } >"$out/mujoco_$(basename "$f")"
        { printf '\1\3'; cat "$f"; } >"$out/dart_$(basename "$f")"
      done
      for f in cube.skel sphere.skel chain.skel skateboard.skel; do
        [ -f "$dart_skel/$f" ] || continue
        { printf '\0\1'; cat "$dart_skel/$f"; } >"$out/mujoco_$f"
        { printf '\1\1'; cat "$dart_skel/$f"; } >"$out/dart_$f"
      done
      ;;
    bvh_track) cp "$src"/tests/cli/bad_inputs/*.bvh "$out/" ;;
    robot_step)
      # byte 0: format (even URDF, odd SDF), the rest the file; the target's own .urdf and .sdf
      # seeds are kept as plain files and prefixed here like the others
      rm -f "$out"/*.urdf "$out"/*.sdf
      for f in "$src"/tests/fuzz/corpus/robot_step/*.urdf "$src"/models/*.urdf \
        "$src"/tests/cli/bad_inputs/*.urdf; do
        [ -f "$f" ] && { printf '\0'; cat "$f"; } >"$out/urdf_$(basename "$f")"
      done
      for f in "$src"/tests/fuzz/corpus/robot_step/*.sdf "$src"/tests/fuzz/corpus/robots/*.sdf \
        "$src"/tests/cli/bad_inputs/*.sdf; do
        [ -f "$f" ] && { printf '\1'; cat "$f"; } >"$out/sdf_$(basename "$f")"
      done
      ;;
  esac
  return 0
}

# one target: its seeds once (SECONDS = 0) or its budget; prints one line, returns 1 on a finding
fuzz_one() {
  local target=$1 seeds=$build/fuzz/seeds/$1 log=$build/fuzz/$1.log work budget slow runs start
  make_seeds "$target" "$seeds"
  if [ "$seconds" = 0 ]; then
    ./fuzz_"$target" -runs=0 -artifact_prefix=crashes/"$target"- "$seeds" >"$log" 2>&1 || {
      tail -40 "$log"
      echo "fuzz $target: FAILED on its seeds"
      return 1
    }
    echo "fuzz $target: $(ls "$seeds" | wc -l) seeds ran clean"
    return 0
  fi
  work=$build/fuzz/corpus/$target
  budget=(-max_total_time="$seconds")
  slow=30
  if [ "$seconds" = ci ]; then
    work=$build/fuzz/corpus-ci/$target
    rm -rf "$work"
    case $target in
      bvh) runs=150000 ;;
      scenario) runs=20000 ;;
      skel) runs=18000 ;;
      joint_map) runs=28000 ;;
      model) runs=5000 ;;  # both engines, as the input's first byte picks
      bvh_track) runs=2000 ;;  # a character built and a few steps run (most inputs stop early)
      robot_step) runs=3300 ;;  # both engines, a step each
    esac
    budget=(-runs=$runs -seed=1)
    slow=120  # a slow machine must not turn a slow input into a failure
  fi
  mkdir -p "$work"
  start=$(date +%s)
  ./fuzz_"$target" "${budget[@]}" -timeout="$slow" -rss_limit_mb=3072 -print_final_stats=1 \
    -artifact_prefix=crashes/"$target"- "$work" "$seeds" >"$log" 2>&1 || {
    tail -60 "$log"
    echo "fuzz $target: CRASHED (artifact in $build/fuzz/crashes/)"
    return 1
  }
  runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo '?')
  echo "fuzz $target: $runs executions in $(($(date +%s) - start)) s, 0 crashes"
}

cd "$build/fuzz"
mkdir -p crashes
# the targets run side by side, FUZZ_JOBS at a time (default: one per core); each is one
# single-threaded libFuzzer process with its own fixed budget, so the results do not depend on it
jobs=${FUZZ_JOBS:-$(nproc)}
failed=0
running=0
for target in "${targets[@]}"; do
  if [ "$running" -ge "$jobs" ]; then
    wait -n || failed=1
    running=$((running - 1))
  fi
  fuzz_one "$target" &
  running=$((running + 1))
done
while [ "$running" -gt 0 ]; do
  wait -n || failed=1
  running=$((running - 1))
done
exit "$failed"
