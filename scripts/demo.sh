#!/usr/bin/env bash
# the main job: run every shipped scenario headless on its own engine, and the two-engine ones on
# DART too, printing each summary. Outputs go to out/demo/<scenario>-<engine>/.
set -uo pipefail
stance=${1:-build/stance}
out=${OUT:-out/demo}
status=0
run() {
  local scenario=$1
  shift
  local tag
  tag=$(basename "$scenario" .yaml)
  [ $# -gt 0 ] && tag="$tag-${2:-}"
  echo "== stance run $scenario $*"
  "$stance" run "$scenario" "$@" --out "$out/$tag"
  local rc=$?
  [ $rc -eq 0 ] || status=$rc
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
exit $status
