#!/usr/bin/env bash
# the main job: run the shipped scenarios headless on both engines and print their summaries.
set -uo pipefail
stance=${1:-build/stance}
out=${OUT:-out/demo}
status=0
run() {
  local scenario=$1 engine=$2
  echo "== stance run $scenario --engine $engine"
  "$stance" run "$scenario" --engine "$engine" --out "$out/$(basename "$scenario" .yaml)-$engine"
  local rc=$?
  [ $rc -eq 0 ] || status=$rc
}
run scenarios/pd_hold.yaml mujoco
run scenarios/pd_hold.yaml dart
for s in biped_stand biped_push; do
  if [ -f scenarios/$s.yaml ]; then run scenarios/$s.yaml mujoco; run scenarios/$s.yaml dart; fi
done
echo "outputs in $out/"
exit $status
