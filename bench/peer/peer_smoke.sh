#!/usr/bin/env bash
# DART's atlas_simbicon example, headless, for 2 s with a 100 N push at 1 s: it runs, prints its
# JSON line, stays up and walks forward. Skipped (77) until `make bench` has built it.
set -euo pipefail
peer=$1
if [ ! -x "$peer" ]; then
  echo "skipped: $peer not built (make bench, or cmake --build build --target ${peer##*/})"
  exit 77
fi
out=$("$peer" --duration 2 --first-push 1 --push-force 100 --push-duration 0.2)
echo "$out"
/usr/bin/python3 - "$out" <<'PY'
import json, sys
r = json.loads(sys.argv[1])
assert r["sim_time"] == 2.0 and r["fell"] is False, r
assert r["distance_m"] > 0.5, f"walked {r['distance_m']} m in 2 s"
PY
# bad input: one line naming the option, exit 2
set +e
err=$("$peer" --gait nope 2>&1); rc=$?
set -e
[ "$rc" = 2 ] || { echo "--gait nope: exit $rc, expected 2"; exit 1; }
want="stance_atlas_simbicon_peer: --gait: no state machine 'nope' (standing, walking in place,"
want+=" walking, running)"
[ "$err" = "$want" ] || { echo "--gait nope: '$err'"; exit 1; }
echo ok
