#!/usr/bin/env bash
# stance list: a controller's parameters with default, unit, range and help (from its visit());
# every registered type listed by `stance list controllers`; an unknown name is one line, exit 2.
set -u
# shellcheck source=tests/cli/lib.sh
. "$(dirname "$0")/lib.sh"
stance=$1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# one known line: stable_pd's kp, 400 N m/rad in 0 .. 1e7, with its help
"$stance" list stable_pd >"$tmp/pd.txt" 2>&1 || fail "list stable_pd exited $?"
grep -Eq '^  kp +400 +N m/rad +0 \.\. 10000000 +position gain' "$tmp/pd.txt" ||
  fail "stable_pd's kp line: $(cat "$tmp/pd.txt")"
grep -Eq '^  parameter +default +unit +range +help$' "$tmp/pd.txt" || fail "no header line"
# nested structs and list items by their --set paths
"$stance" list simbicon >"$tmp/simbicon.txt" 2>&1 || fail "list simbicon exited $?"
grep -Eq '^  gait\.states\[\]\.cd +0 +rad/m +-100 \.\. 100 +feedback on distance d' \
  "$tmp/simbicon.txt" || fail "simbicon's gait.states[].cd line"

# every registered type, each with its parameters
"$stance" list controllers >"$tmp/all.txt" 2>&1 || fail "list controllers exited $?"
for type in hold_pose_pd stable_pd ankle_strategy simbicon slope_walker lqr mocap_retarget; do
  grep -q "^$type: " "$tmp/all.txt" || fail "list controllers lacks $type"
done
# a number with neither unit nor help is a gap in its visit(): none in the registered types
# (columns by the offsets of each type's header line)
awk '/^[a-z_]+: / { type = $1; next }
  /^  parameter / { u = index($0, "unit"); r = index($0, "range"); h = index($0, "help"); next }
  /^  / {
    unit = substr($0, u, r - u); help = substr($0, h); gsub(/ /, "", unit); gsub(/ /, "", help)
    if ($2 ~ /^-?[0-9][0-9.e+-]*$/ && unit == "" && help == "") print type " " $1
  }' "$tmp/all.txt" >"$tmp/bare.txt"
[ -s "$tmp/bare.txt" ] && fail "numbers without unit or help: $(tr '\n' ' ' <"$tmp/bare.txt")"

# the default still lists the types and the shipped scenarios
"$stance" list >"$tmp/default.txt" 2>&1 || fail "list exited $?"
{ grep -q '^  simbicon ' "$tmp/default.txt" &&
  grep -q '^  scenarios/biped_stand.yaml$' "$tmp/default.txt"; } || fail "stance list: default"

# an unknown name: one line on stderr naming it (with the nearest type), exit 2
"$stance" list simbicn >"$tmp/out" 2>"$tmp/err"
code=$?
[ $code -eq 2 ] || fail "list simbicn exited $code"
[ "$(grep -c . "$tmp/err")" -eq 1 ] && grep -q "'simbicn'.*did you mean 'simbicon'" "$tmp/err" ||
  fail "list simbicn: $(cat "$tmp/err")"
[ -s "$tmp/out" ] && fail "list simbicn printed on stdout: $(cat "$tmp/out")"

echo "$fails failed"
[ "$fails" -eq 0 ]
