#!/usr/bin/env bash
# the main job: run every shipped scenario headless on its own engine, and the two-engine ones on
# DART too, printing each summary, then one line per run: whether the scenario's expectation (its
# `expect` block, docs/scenarios.md) held. Outputs go to out/demo/<scenario>-<engine>/. The exit
# code is the last failed run's (a missed expectation is a result, as a fall is: it is listed, and
# the test ShippedScenario/ScenarioExpectation fails on it).
set -uo pipefail
stance=${1:-build/stance}
out=${OUT:-out/demo}
status=0
verdicts=()
printed=$(mktemp)
trap 'rm -f "$printed"' EXIT
run() {
  local scenario=$1
  shift
  local tag
  tag=$(basename "$scenario" .yaml)
  [ $# -gt 0 ] && tag="$tag-${2:-}"
  echo "== stance run $scenario $*"
  "$stance" run "$scenario" "$@" --out "$out/$tag" | tee "$printed"
  local rc=${PIPESTATUS[0]}
  [ $rc -eq 0 ] || status=$rc
  local verdict
  verdict=$(grep -m1 '^  expectation ' "$printed" | sed 's/^  //')
  [ -n "$verdict" ] || [ $rc -eq 0 ] || verdict="exit $rc, no verdict"
  verdicts+=("$tag: ${verdict:-no expectation}")
  echo
}
for scenario in scenarios/*.yaml; do
  run "$scenario"
done
# the same scenarios on the other engine
for name in pd_hold biped_stand biped_skateboard simbicon_walk simbicon_fullbody1; do
  [ -f "scenarios/$name.yaml" ] && run "scenarios/$name.yaml" --engine dart
done
echo "outputs in $out/"
echo
echo "== what each run shows: its scenario's expectation"
held=0
for v in "${verdicts[@]}"; do
  echo "$v"
  case $v in *": expectation held "*) held=$((held + 1)) ;; esac
done
echo "$held of ${#verdicts[@]} held"
exit $status
