#!/usr/bin/env bash
# S0's push thresholds beside the seed's own loop (make compare-seed), measured in one run:
#   the seed: ../shared/peers/dartpy_biped_spd.py --thresholds (dartpy, Debian's python3-dartpy)
#   stance with the seed's protocol: DART, 0.1 s on h_spine at its origin from t = 2 s, 5 s runs,
#     fallen when the COM is below 60% of its start height (no contact rule), bisection on 0..400 N
#     to 1 N, the seed's ankle bands alone with its per-step derivative
#   stance's own scenario: the same protocol on biped_stand.yaml as shipped (the push at the COM,
#     10 s runs, a non-foot contact is a fall too, the capture term, the derivative of DART's C++
#     tutorial)
# Prints a Markdown table. About 3 minutes on 2 cores.
set -euo pipefail
stance=${1:-build/stance}
peer=${2:-../shared/peers/dartpy_biped_spd.py}
[ -f "$peer" ] || { echo "error: $peer not found (the seed's loop, from ../shared/peers)" >&2; exit 2; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

/usr/bin/python3 "$peer" --thresholds 2>/dev/null >"$tmp/peer.txt" &
peer_pid=$!
common=(scenarios/biped_stand.yaml --engine dart --body h_spine --axis x --max 400 --tolerance 1
  --at 2 --push-duration 0.1 --quiet --threads 1)
"$stance" push-threshold "${common[@]}" --point origin --duration 5 \
  --set "fall.allowed_contacts=[]" --set controllers.1.capture.gain=0 \
  --set controllers.1.derivative=per_step >"$tmp/seed_protocol.txt"
"$stance" push-threshold "${common[@]}" >"$tmp/shipped.txt"
wait "$peer_pid"

# "+x: survives A N, falls at B N" (the peer) or "  +x: survives A N, falls at B N (n trials)"
row() {
  local label=$1 file=$2 plus minus
  plus=$(grep -o '+x: survives [0-9.]* N, falls at [0-9.]* N' "$file" | sed 's/+x: survives //')
  minus=$(grep -o '\-x: survives [0-9.]* N, falls at [0-9.]* N' "$file" | sed 's/-x: survives //')
  echo "| $label | $plus | $minus |"
}
echo "| run (DART 6.12, 0.1 s on h_spine, 1 N bisection) | +x survives, falls at | -x survives, falls at |"
echo "| --- | --- | --- |"
row "the seed's loop in dartpy" "$tmp/peer.txt"
row "stance, the seed's protocol" "$tmp/seed_protocol.txt"
row "stance, biped_stand.yaml as shipped" "$tmp/shipped.txt"
