#!/usr/bin/env bash
# docs/robots.md's worked example runs: the commands between its robots-example markers, each
# shortened (runs to 0.3 s, the tracker without its planner), must exit 0 and write their
# summary.json. Skipped without dart-doc's Atlas.
set -u
stance=$1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# shellcheck source=tests/cli/lib.sh
. "$(dirname "$0")/lib.sh"

if [ ! -f /usr/share/doc/dart/data/sdf/atlas/atlas_v3_no_head.urdf ]; then
  echo "no dart-doc Atlas: skipped"
  exit 0
fi
commands=$(sed -n '/<!-- robots-example:begin -->/,/<!-- robots-example:end -->/p' \
  docs/robots.md | grep '^stance ')
[ "$(echo "$commands" | wc -l)" -ge 5 ] || fail "docs/robots.md: fewer than 5 example commands"
short_run=(--duration 0.3 --quiet)
short_track=(--duration 0.3 --threads 1 --set planner.enabled=false --quiet)
while read -r line; do
  read -r -a words <<<"${line//out\//$tmp/}"
  args=("${words[@]:1}")
  case "${args[0]} ${args[1]:-}" in
    "run "*) args+=("${short_run[@]}") ;;
    "bvh track") args+=("${short_track[@]}") ;;
  esac
  echo "stance ${args[*]}"
  "$stance" "${args[@]}" >"$tmp/stdout" 2>"$tmp/stderr" ||
    fail "'$line' exited $?: $(head -3 "$tmp/stderr")"
done <<<"$commands"
for run in atlas_stand atlas_walk atlas_track; do
  [ -s "$tmp/$run/summary.json" ] || fail "$run wrote no summary.json"
done
[ -s "$tmp/atlas_track/map.yaml" ] || fail "bvh track wrote no map.yaml"
[ "$fails" -eq 0 ] && echo "PASS"
