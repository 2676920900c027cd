#!/usr/bin/env bash
# The peer of issue 19, side by side: DART's own atlas_simbicon example controller (bench/peer/,
# compiled from dart-doc's sources, nothing copied) and stance's Atlas walk on DART, one right
# after the other, the same length under the same pushes and fall criterion, printed as the
# section "The peer: DART's atlas_simbicon" of docs/results.md in markdown (docs/simbicon.md,
# "The peer").
# `make bench` runs it after bench/report.sh's table; `make bench-atlas` runs it alone.
#   bench/atlas_peer.sh [BUILD_DIR] [--json OUT.json]
# STANCE_PEER_SCENARIO runs another stance scenario in the walk's place (e.g.
# scenarios/atlas_stand.yaml while simbicon_atlas.yaml is not there); STANCE_PEER_DURATION
# (default 60 s) and STANCE_PEER_PUSH_N (default 100 N) change the run.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-build}
[[ $build = /* ]] || build=$root/$build
json_out=""
if [ "${2:-}" = "--json" ]; then json_out=${3:?--json needs a file}; fi
python=/usr/bin/python3
stance=$build/stance
peer=$build/stance_atlas_simbicon_peer
scenario=${STANCE_PEER_SCENARIO:-$root/scenarios/simbicon_atlas.yaml}
[[ $scenario = /* ]] || scenario=$PWD/$scenario
duration=${STANCE_PEER_DURATION:-60}
# the schedule (docs/simbicon.md): pushes on the pelvis, forward, back, left, right in turn
push_n=${STANCE_PEER_PUSH_N:-100} push_s=0.2 push_first=5 push_every=5
fall_fraction=0.8
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
note=""
add_note() { note="${note:+$note; }$1"; }

# DART's example first
if [ -x "$peer" ]; then
  echo "atlas_peer.sh: DART's atlas_simbicon example, $duration s" >&2
  "$peer" --duration "$duration" --push-force "$push_n" --push-duration "$push_s" \
    --first-push "$push_first" --push-every "$push_every" --fall-fraction "$fall_fraction" \
    >"$tmp/peer.json" 2>"$tmp/peer.err" ||
    add_note "DART's example failed: $(tail -1 "$tmp/peer.err")"
else
  # the target exists either way; without dart-doc's sources it says why it skipped
  why=$(cmake --build "$build" --target stance_atlas_simbicon_peer 2>&1 |
    sed -n 's/.*stance_atlas_simbicon_peer skipped: //p' | head -1 || true)
  add_note "DART's atlas_simbicon example was not run: ${why:-$peer not built}"
fi

# then stance, the peer's schedule as the scenario's perturbations at the pelvis's origin (where
# DART's addExtForce acts) and the same fall criterion
if [ ! -f "$scenario" ]; then
  add_note "stance's Atlas walk was not run: ${scenario#"$root"/} is absent"
elif [ ! -x "$stance" ]; then
  add_note "stance's Atlas walk was not run: $stance not built"
else
  echo "atlas_peer.sh: stance, ${scenario#"$root"/}, $duration s" >&2
  pushes=$("$python" -c "
n, s, first, every, d = $push_n, $push_s, $push_first, $push_every, $duration
dirs = ['[{0}, 0, 0]', '[-{0}, 0, 0]', '[0, {0}, 0]', '[0, -{0}, 0]']
out, k = [], 0
while n and first + k * every < d:
    out.append('{body: pelvis, force: %s, start: %g, duration: %g, point: origin}'
               % (dirs[k % 4].format(n), first + k * every, s))
    k += 1
print('[' + ', '.join(out) + ']')")
  rc=0
  "$stance" run "$scenario" --engine dart --duration "$duration" --quiet \
    --set "perturbations=$pushes" --set fall.enabled=true \
    --set fall.com_height_fraction="$fall_fraction" --set 'fall.allowed_contacts=[l_foot, r_foot]' \
    --out "$tmp/stance" >/dev/null 2>"$tmp/stance.err" || rc=$?
  # 0: it ran (a fall is a result); 3: it diverged, outputs written
  if [ "$rc" != 0 ] && [ "$rc" != 3 ]; then
    add_note "stance run failed (exit $rc): $(tail -1 "$tmp/stance.err")"
    rm -rf "$tmp/stance"
  fi
fi

PYTHONPATH="$root/bench" "$python" - "$tmp" "$note" "$json_out" "$scenario" "$duration" \
  "$push_n" "$push_s" "$push_first" "$push_every" "$fall_fraction" <<'PY'
import csv, datetime, json, os, sys

import yaml

tmp, note, json_out, scenario = sys.argv[1:5]
duration, push_n, push_s, push_first, push_every, fall_fraction = sys.argv[5:11]

from bench_format import fmt

def fixed(x, unit):
    # two decimals, no "-0.00"
    text = f"{x:.2f}"
    return ("0.00" if text == "-0.00" else text) + " " + unit

def row(who, how, time_up, forward, lateral, wall, fell, reason):
    up = fixed(time_up, "s") + (f" (fell: {reason})" if fell else " (no fall)")
    speed = forward / time_up if time_up else 0
    return [who, how, up, fixed(forward, "m"), fixed(lateral, "m"), fixed(speed, "m/s"),
            fmt(wall)]

rows, results = [], {}
peer_json = os.path.join(tmp, "peer.json")
if os.path.exists(peer_json) and os.path.getsize(peer_json):
    p = json.loads(open(peer_json).read().strip().splitlines()[-1])
    results["dart_example"] = p
    rows.append(row(f"DART's `atlas_simbicon` example (its Controller, \"{p['gait']}\")",
                    f"DART 6.12, `atlas_v3_no_head.sdf` (STL meshes, "
                    f"{p['collision_detector'].upper()}), {p['timestep'] * 1e3:g} ms",
                    p["time_up_s"], p["distance_m"], p["lateral_m"], p["wall_s_per_sim_s"],
                    p["fell"], p["fall_reason"]))

summary = os.path.join(tmp, "stance", "summary.json")
if os.path.exists(summary):
    sm = json.load(open(summary))
    # time up: to the fall (or the divergence), else the whole run; the pelvis (the root) from
    # log.csv at that time
    end = sm["fall_time"] if sm["fell"] else sm["sim_time"]
    log = list(csv.DictReader(open(os.path.join(tmp, "stance", "log.csv"))))
    last = log[0]
    for r in log:
        if float(r["time"]) <= end + 1e-9:
            last = r
    forward = float(last["root_x"]) - float(log[0]["root_x"])
    lateral = float(last["root_y"]) - float(log[0]["root_y"])
    reason = sm.get("fall_reason", "") if sm["fell"] else ""
    if sm["diverged"]:
        reason = "diverged: " + sm.get("divergence", "")
    doc = yaml.safe_load(open(scenario))
    models = doc.get("model")
    models = models if isinstance(models, list) else [models]
    model = models[0]["file"] if isinstance(models[0], dict) else models[0]
    step = doc.get("timestep")
    entry = models[0] if isinstance(models[0], dict) else {}
    meshes = ("meshes as their bounding boxes" if entry.get("mesh_collision", "box") == "box"
              else "meshes")
    wall = sm["metrics"].get("compute_s_per_sim_s")
    name = os.path.basename(scenario)
    results["stance"] = {"scenario": name, "time_up_s": end, "forward_m": forward,
                         "lateral_m": lateral, "fell": sm["fell"], "diverged": sm["diverged"],
                         "fall_reason": reason, "wall_s_per_sim_s": wall}
    rows.append(row(f"stance, `{name}`",
                    f"DART 6.12, `{os.path.basename(model)}` ({meshes})"
                    + (f", {step * 1e3:g} ms" if step else ""),
                    end, forward, lateral, wall, sm["fell"] or sm["diverged"], reason))

load = open("/proc/loadavg").read().split()[:3]
print(f"`make bench` (bench/atlas_peer.sh), "
      f"{datetime.datetime.now(datetime.timezone.utc).isoformat(timespec='seconds')}: "
      f"{os.cpu_count()} CPUs, load average {', '.join(load)}.")
print()
print(f"{duration} s on DART; pushes of {push_n} N for {push_s} s on the pelvis (at its origin), "
      f"forward, back, left, right in turn, every {push_every} s from t = {push_first} s; a fall: "
      f"the COM below {fall_fraction} of its start height above the ground, or a body other than "
      "the feet touching it. Forward and lateral (left +): the pelvis's travel until the fall or "
      "the end; speed: forward over time up; wall time per simulated second: the stepping loop "
      "alone, models loaded.")
if note:
    print(f"\nNote: {note}.")
if rows:
    print()
    print("| controller | engine, model, step | time up | forward | lateral | speed "
          "| wall s per simulated s |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        print("| " + " | ".join(r) + " |")
if json_out:
    with open(json_out, "w") as f:
        json.dump(results, f, indent=1)
PY
