#!/usr/bin/env bash
# The bad-input table. Every row of tests/cli/bad_inputs.table runs one stance command on a
# malformed input (the files in tests/cli/bad_inputs/) in a scratch folder whose output folder
# `out/` holds a previous good run's files. Each row checks: the exit code; that the one-line
# message names the place (its `where`: file:line, the parameter or the option); the whole
# message; and that `out/` is left byte for byte as it was (no file changed, added or removed,
# temporaries included). CONTRIBUTING.md's table is printed from the same file (--markdown), and
# this test checks that CONTRIBUTING.md holds exactly that table, so the two cannot disagree.
#   bash tests/cli/bad_inputs.sh build/stance     run every row
#   bash tests/cli/bad_inputs.sh --markdown       print CONTRIBUTING.md's table
# A row: area | input | command (after `stance`) | exit | where | message (stderr, exact)
set -u
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
table=$here/bad_inputs.table

rows() { grep -v -e '^[[:space:]]*#' -e '^[[:space:]]*$' "$table"; }

# the fields of one row into area, input, command, code, where, message (the rest of the line)
split_row() {
  local rest=$1
  area=${rest%% | *} rest=${rest#* | }
  input=${rest%% | *} rest=${rest#* | }
  command=${rest%% | *} rest=${rest#* | }
  code=${rest%% | *} rest=${rest#* | }
  where=${rest%% | *} rest=${rest#* | }
  message=$rest
}

markdown() {
  local n=0
  echo "| # | area | input | command | exit | message |"
  echo "|---|---|---|---|---|---|"
  while IFS= read -r row; do
    split_row "$row"
    n=$((n + 1))
    echo "| $n | $area | ${input//|/\\|} | \`stance ${command//|/\\|}\` | $code | \`${message//|/\\|}\` |"
  done < <(rows)
}

if [ "${1:-}" = "--markdown" ]; then
  markdown
  exit 0
fi

stance=$(cd "$(dirname "$1")" && pwd)/$(basename "$1")
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fails=0
passes=0
fail() {
  echo "FAIL: $*"
  fails=$((fails + 1))
}

# CONTRIBUTING.md's table is this file's
expected=$(markdown)
in_doc=$(sed -n '/<!-- bad-inputs:begin -->/,/<!-- bad-inputs:end -->/p' "$root/CONTRIBUTING.md" |
  sed '1d;$d')
[ "$expected" = "$in_doc" ] ||
  fail "CONTRIBUTING.md's bad-input table differs from $table (regenerate: bash $0 --markdown)"
[ "$(rows | wc -l)" -ge 30 ] || fail "fewer than 30 rows"

# the inputs, and a previous good run's files in good_out/
cp -r "$here/bad_inputs/." "$work/"
cp "$root/models/arm3.xml" "$root/models/synthetic_walk.bvh" "$work/"
cd "$work" || exit 1
"$stance" run good.yaml --out good_out --quiet >/dev/null 2>&1 || fail "the good run"
"$stance" bvh synth-walk good_out/clip.bvh >/dev/null || fail "synth-walk"
"$stance" bvh2mjcf good.bvh good_out/character.xml >/dev/null || fail "bvh2mjcf"
"$stance" convert good.skel good_out/model.xml >/dev/null || fail "convert"
printf 'time,previous\n0,1\n' >good_out/table.csv
[ -s good_out/summary.json ] && [ -s good_out/log.csv ] || fail "the good run's outputs"

# a build without the viewer (the sanitizer tree) refuses --record before it reads the options
# those rows check; the viewer build runs them
viewer=1
"$stance" run missing.yaml --screenshot x.png 2>&1 | grep -q "viewer build" && viewer=0
skipped=0

# what a folder holds: every entry (hidden ones too) and every file's checksum
snapshot() { (cd "$1" && find . | sort && find . -type f -exec md5sum {} + | sort); }
before=$(snapshot good_out)

n=0
while IFS= read -r row; do
  split_row "$row"
  n=$((n + 1))
  if [ "$viewer" -eq 0 ] && [[ "$command" == *--record* ]]; then
    skipped=$((skipped + 1))
    continue
  fi
  rm -rf out
  cp -a good_out out
  eval "args=($command)"
  "$stance" "${args[@]}" >stdout 2>stderr </dev/null
  rc=$?
  got=$(cat stderr)
  ok=1
  [ "$rc" -eq "$code" ] || { fail "row $n ($command): exit $rc, want $code"; ok=0; }
  [ "$(grep -c . stderr)" -eq 1 ] || { fail "row $n ($command): not one line on stderr"; ok=0; }
  [[ "$got" == *"$where"* ]] || { fail "row $n ($command): the message lacks '$where'"; ok=0; }
  [ "$got" = "$message" ] || { fail "row $n ($command): message differs"; ok=0; }
  [ "$(snapshot out)" = "$before" ] || { fail "row $n ($command): out/ changed"; ok=0; }
  if [ "$ok" -eq 1 ]; then
    passes=$((passes + 1))
  else
    echo "  stderr: $got"
    echo "  want:   $message"
  fi
done < <(rows)

echo "$passes passed, $fails failed, $skipped skipped (no viewer in this build)"
[ "$fails" -eq 0 ]
