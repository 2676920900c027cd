#!/usr/bin/env bash
# mpirun -np 2 spreads sweep, robustness and tune over two ranks (threads inside each): the files rank 0
# writes equal a threaded single-process run's, byte for byte; and a plain run never starts MPI.
set -u
stance=$1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fails=0
fail() {
  echo "FAIL: $*"
  fails=$((fails + 1))
}
# root in containers and CI; more ranks than cores on a small machine
mpi=(mpirun -np 2 --oversubscribe --allow-run-as-root)
export OMPI_MCA_btl_vader_single_copy_mechanism=none

sweep=(sweep scenarios/simbicon_walk.yaml --param controllers.0.gait.states.0.cv --from 0 --to 0.4
  --steps 7 --duration 4 --quiet)
"$stance" "${sweep[@]}" --threads 2 --out "$tmp/sweep_threads" >/dev/null || fail "threaded sweep"
"${mpi[@]}" "$stance" "${sweep[@]}" --threads 1 --out "$tmp/sweep_mpi" >"$tmp/mpi.txt" 2>&1 ||
  fail "mpirun sweep: $(tail -3 "$tmp/mpi.txt")"
for f in sweep.csv points.csv; do
  cmp -s "$tmp/sweep_threads/$f" "$tmp/sweep_mpi/$f" || fail "sweep $f differs under mpirun"
done
# rank 0 alone prints: one summary line, not two
[ "$(grep -c '^swept ' "$tmp/mpi.txt")" -eq 1 ] || fail "not one summary line: $(cat "$tmp/mpi.txt")"

map=(robustness scenarios/simbicon_walk.yaml --body torso --phases 3 --max 400 --tolerance 10
  --at 3 --duration 7 --quiet --no-plot)
"$stance" "${map[@]}" --threads 2 --out "$tmp/map_threads" >/dev/null || fail "threaded map"
for threads in 1 2; do
  "${mpi[@]}" "$stance" "${map[@]}" --threads $threads --out "$tmp/map_mpi$threads" \
    >"$tmp/mpi.txt" 2>&1 || fail "mpirun map: $(tail -3 "$tmp/mpi.txt")"
  for f in robustness.csv thresholds.csv summary.json; do
    cmp -s "$tmp/map_threads/$f" "$tmp/map_mpi$threads/$f" ||
      fail "robustness $f differs under mpirun with $threads threads per rank"
  done
done

# tune: every rank draws the same candidates and gathers every score; rank 0 writes
for method in cem cmaes; do
  tune=(tune scenarios/pd_hold.yaml --param controllers.0.kp=20:120 --param controllers.0.kd=1:10
    --neighbour "controllers.0.kp*=0.8" --budget 12 --population 4 --duration 1.5 --quiet
    --method $method)
  "$stance" "${tune[@]}" --threads 2 --out "$tmp/tune_threads_$method" >/dev/null ||
    fail "threaded tune ($method)"
  "${mpi[@]}" "$stance" "${tune[@]}" --threads 1 --out "$tmp/tune_mpi_$method" >"$tmp/mpi.txt" \
    2>&1 || fail "mpirun tune ($method): $(tail -3 "$tmp/mpi.txt")"
  for f in tune.csv best.yaml best_scenario.yaml; do
    cmp -s "$tmp/tune_threads_$method/$f" "$tmp/tune_mpi_$method/$f" ||
      fail "tune ($method) $f differs under mpirun"
  done
done

# a plain run never initialises MPI: nothing on stderr, exit 0
"$stance" run scenarios/pd_hold.yaml --duration 0.2 --quiet 2>"$tmp/err" || fail "plain run"
[ -s "$tmp/err" ] && fail "a plain run wrote to stderr: $(cat "$tmp/err")"

[ $fails -eq 0 ] && echo "mpi: all checks passed"
exit $((fails > 0))
