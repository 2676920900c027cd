#!/usr/bin/env bash
# The inputs that once crashed stance (issue 17), each now one located error and exit 2: SKEL
# and MJCF on DART (assertion aborts, a segfault, a negative mass that loaded), a second BVH
# ROOT (segfault in bvh2mjcf and bvh retarget), a frame count beyond the data, deep nesting,
# names the writer could not write back. A deep SKEL chain stops at the body limit.
set -u
stance=$1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fails=0
passes=0

# expect PREFIX -- command...: exit 2 and one stderr line starting with PREFIX
expect() {
  local prefix=$1
  shift 2
  "$@" >"$tmp/stdout" 2>"$tmp/stderr"
  local rc=$?
  if [ "$rc" -ne 2 ] || [ "$(grep -c . "$tmp/stderr")" -ne 1 ] ||
    [ "$(head -c ${#prefix} "$tmp/stderr")" != "$prefix" ]; then
    echo "FAIL: $* -> rc=$rc (want 2), stderr:"
    head -c 2000 "$tmp/stderr"
    fails=$((fails + 1))
  else
    passes=$((passes + 1))
  fi
}

# one body whose element on line 4 is $1, joined to the world by a joint of type $2 whose
# element on line 7 is $3
skel() {
  printf '<skel><world>\n<skeleton name="s">\n<body name="a">\n%s\n</body>\n' "$1"
  printf '<joint type="%s" name="j">\n%s\n<parent>world</parent><child>a</child>\n' "$2" "$3"
  printf '</joint>\n</skeleton></world></skel>\n'
}
box='<collision_shape><geometry><box><size>%s</size></box></geometry></collision_shape>'
# shellcheck disable=SC2059
skel "$(printf "$box" "0 1 1")" free "" >"$tmp/box.skel"
skel '<transformation>0 0 0 0 0</transformation>' free "" >"$tmp/tf5.skel"
skel '<inertia><mass>1</mass><offset>0 0</offset></inertia>' free "" >"$tmp/vec2.skel"
skel "" hinge2 "" >"$tmp/joint.skel"
skel '<gravity>yes</gravity>' free "" >"$tmp/bool.skel"
skel "" ball '<init_pos>0 0</init_pos>' >"$tmp/initpos.skel"
skel "" revolute '<axis><xyz>0 0 1</xyz></axis><dof local_index="3"><damping>1</damping></dof>' \
  >"$tmp/damping.skel"
skel '<visualization_shape><geometry><mesh/></geometry></visualization_shape>' free "" \
  >"$tmp/mesh.skel"
soft='<soft_shape><total_mass>1</total_mass><geometry><box><size>1 1 1</size>'
skel "$soft<frags>nan 2 2</frags></box></geometry></soft_shape>" free "" >"$tmp/soft.skel"
skel '<inertia><mass>-1</mass></inertia>' free "" >"$tmp/neg.skel"
printf '<skel><world>\n<physics><time_step>nan</time_step></physics>\n</world></skel>\n' \
  >"$tmp/nan.skel"

expect "error: $tmp/box.skel:4: <size>: every number must be positive" -- \
  "$stance" info "$tmp/box.skel" --engine dart
expect "error: $tmp/tf5.skel:4: <transformation>: expected 6 numbers, found 5" -- \
  "$stance" info "$tmp/tf5.skel" --engine dart
expect "error: $tmp/vec2.skel:4: <offset>: expected 3 numbers, found 2" -- \
  "$stance" info "$tmp/vec2.skel" --engine dart
expect "error: $tmp/joint.skel:6: joint 'j': unsupported joint type 'hinge2'" -- \
  "$stance" info "$tmp/joint.skel" --engine dart
expect "error: $tmp/bool.skel:4: <gravity>: expected true/false/1/0, found 'yes'" -- \
  "$stance" info "$tmp/bool.skel" --engine dart
expect "error: $tmp/initpos.skel:7: <init_pos>: expected 3 numbers, found 2" -- \
  "$stance" info "$tmp/initpos.skel" --engine dart
expect "error: $tmp/damping.skel:7: joint 'j' has 1 dofs; <dof> needs local_index in [0, 1)" -- \
  "$stance" info "$tmp/damping.skel" --engine dart
expect "error: $tmp/mesh.skel:4: <mesh> is missing <file_name>" -- \
  "$stance" info "$tmp/mesh.skel" --engine dart
expect "error: $tmp/soft.skel:4: <frags>: 'nan' is not a number" -- \
  "$stance" info "$tmp/soft.skel" --engine dart
expect "error: $tmp/neg.skel:4: <mass> must be positive, found -1" -- \
  "$stance" info "$tmp/neg.skel" --engine dart
expect "error: $tmp/neg.skel:4: <mass> must be positive, found -1" -- \
  "$stance" info "$tmp/neg.skel" --engine mujoco
expect "error: $tmp/nan.skel:2: <time_step>: 'nan' is not a number" -- \
  "$stance" info "$tmp/nan.skel" --engine dart

# MJCF on DART: MuJoCo's compiler first
printf '<mujoco>\n<worldbody>\n<body>\n<freejoint/>\n<geom type="sphere" size="-1"/>\n' \
  >"$tmp/sphere.xml"
printf '</body>\n</worldbody>\n</mujoco>\n' >>"$tmp/sphere.xml"
expect "error: $tmp/sphere.xml:5: " -- "$stance" info "$tmp/sphere.xml" --engine dart

# a deep SKEL chain: refused at the body limit, with the line of the first body too many
{
  printf '<skel><world>\n<skeleton name="chain">\n'
  for i in $(seq 0 1000); do printf '<body name="b%d"/>\n' "$i"; done
  printf '<joint type="free" name="j0"><parent>world</parent><child>b0</child></joint>\n'
  for i in $(seq 1 1000); do
    printf '<joint type="weld" name="j%d"><parent>b%d</parent><child>b%d</child></joint>\n' \
      "$i" $((i - 1)) "$i"
  done
  printf '</skeleton></world></skel>\n'
} >"$tmp/chain.skel"
expect "error: $tmp/chain.skel:1003: more than 1000 bodies in one file" -- \
  "$stance" info "$tmp/chain.skel"
expect "error: $tmp/chain.skel:1003: more than 1000 bodies in one file" -- \
  "$stance" convert "$tmp/chain.skel" "$tmp/chain.xml"

# BVH: a second ROOT (once a segfault in bvh2mjcf and bvh retarget)
printf 'HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 0\n}\nROOT c\n{\nOFFSET 0 0 0\n' \
  >"$tmp/roots.bvh"
printf 'CHANNELS 0\nEnd Site\n{\nOFFSET 0 -0.1 0\n}\n}\nMOTION\nFrames: 0\nFrame Time: 1\n' \
  >>"$tmp/roots.bvh"
expect "error: $tmp/roots.bvh:7: a second ROOT" -- "$stance" bvh2mjcf "$tmp/roots.bvh" \
  "$tmp/roots.xml"
expect "error: $tmp/roots.bvh:7: a second ROOT" -- "$stance" bvh retarget "$tmp/roots.bvh" \
  "$tmp/q.csv" --map models/maps/synthetic_walk_to_fullbody1.yaml \
  --model dart://sample/skel/fullbody1.skel

# 40 million frames claimed by a tiny file: refused before any allocation
printf 'HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 1 Xrotation\n}\nMOTION\n' >"$tmp/frames.bvh"
printf 'Frames: 40000000\nFrame Time: 1\n0\n' >>"$tmp/frames.bvh"
expect "error: $tmp/frames.bvh:8: 'Frames: 40000000' x 1 joints is more than" -- \
  "$stance" bvh info "$tmp/frames.bvh"
sed -i 's/40000000/4000000/' "$tmp/frames.bvh"
expect "error: $tmp/frames.bvh:11: truncated data: 'Frames: 4000000' (line 8) but only 1" -- \
  "$stance" bvh info "$tmp/frames.bvh"

# 100k nesting levels: refused at the depth limit (90), quickly
{
  printf 'HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 0\n'
  for i in $(seq 1 100000); do printf 'JOINT j%d\n{\nOFFSET 0 1 0\n' "$i"; done
} >"$tmp/deep.bvh"
expect "error: $tmp/deep.bvh:273: joints nested more than 90 deep" -- \
  "$stance" bvh info "$tmp/deep.bvh"
expect "error: $tmp/deep.bvh:273: joints nested more than 90 deep" -- \
  "$stance" bvh2mjcf "$tmp/deep.bvh" "$tmp/deep.xml"

# names: not UTF-8, or not writable back as BVH
printf 'HIERARCHY\nROOT H\xfcfte\n{\nOFFSET 0 0 0\nCHANNELS 0\n}\nMOTION\nFrames: 0\n' \
  >"$tmp/latin1.bvh"
printf 'Frame Time: 1\n' >>"$tmp/latin1.bvh"
expect "error: $tmp/latin1.bvh:2: joint name has a byte that is not UTF-8 (0xfc)" -- \
  "$stance" bvh info "$tmp/latin1.bvh" --json
printf 'HIERARCHY\nROOT a{ {\nOFFSET 0 0 0\nCHANNELS 0\n}\nMOTION\nFrames: 0\nFrame Time: 1\n' \
  >"$tmp/brace.bvh"
expect "error: $tmp/brace.bvh:2: joint name 'a{' has a character BVH cannot write back" -- \
  "$stance" bvh info "$tmp/brace.bvh"

echo "$passes passed, $fails failed"
[ "$fails" -eq 0 ]
