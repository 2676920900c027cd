#!/usr/bin/env bash
# make bench: the Google Benchmark suite (build/stance_bench) and, in the same run, the seed's S0
# loop (../shared/peers/dartpy_biped_spd.py under Debian's python3-dartpy), printed as the
# benchmark table of docs/results.md in markdown. Every comparison with the seed is a ratio of
# two figures measured minutes apart in this one run, and both figures are shown.
#   bench/report.sh [BUILD_DIR] [--json OUT.json]
# STANCE_BENCH_MIN_TIME (seconds per benchmark, default 0.5; the S0 ones get 4x) trades time for
# noise.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-build}
[[ $build = /* ]] || build=$root/$build
json_out=""
if [ "${2:-}" = "--json" ]; then json_out=${3:?--json needs a file}; fi
bench=$build/stance_bench
peer=$root/../shared/peers/dartpy_biped_spd.py
python=/usr/bin/python3
min_time=${STANCE_BENCH_MIN_TIME:-0.5}

if [ ! -x "$bench" ]; then
  echo "report.sh: $bench not found (build it: cmake --build $build --target stance_bench)" >&2
  exit 2
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# the S0 benchmarks first, the seed's loop right after them (the machine as busy as for them),
# then everything else
run_bench() {  # NAME FILTER MIN_TIME
  echo "report.sh: stance_bench --benchmark_filter='$2'" >&2
  "$bench" --benchmark_filter="$2" --benchmark_min_time="$3" \
    --benchmark_out="$tmp/$1.json" --benchmark_out_format=json >/dev/null
}
run_bench s0 '^BM_Biped' "$("$python" -c "print(4 * $min_time)")"

peer_note=""
if [ -f "$peer" ] && "$python" -c 'import dartpy' 2>/dev/null; then
  echo "report.sh: the seed's loop, $peer" >&2
  # the peer times itself (wall clock); its CPU over wall says how busy the machine was
  /usr/bin/time -f '%U %S %e' -o "$tmp/peer_time" "$python" "$peer" >"$tmp/peer.txt" 2>/dev/null
elif [ ! -f "$peer" ]; then
  peer_note="the seed's loop was not run: $peer is absent"
else
  peer_note="the seed's loop was not run: $python has no dartpy (Debian: python3-dartpy)"
fi

run_bench rest '-^BM_Biped' "$min_time"

# batch runs per second: 144 runs of the planar SIMBICON walk (4 s each) as a sweep on 1 and 2
# threads and, when the build has MPI, on 2 ranks of 1 thread, one right after the other
stance=$build/stance
batch=(sweep "$root/scenarios/simbicon_walk.yaml" --param controllers.0.gait.states.0.cv
  --from 0.1 --to 0.3 --steps 144 --duration 4 --quiet)
wall_of() {  # the command's wall time in seconds
  local t0 t1
  t0=$(date +%s.%N)
  "$@" >/dev/null 2>&1 || { echo "nan"; return; }
  t1=$(date +%s.%N)
  "$python" -c "print($t1 - $t0)"
}
if [ -x "$stance" ]; then
  echo "report.sh: batch runs, 1 and 2 threads, 2 MPI ranks" >&2
  {
    echo "runs 144"
    echo "threads1 $(wall_of "$stance" "${batch[@]}" --threads 1 --out "$tmp/b1")"
    echo "threads2 $(wall_of "$stance" "${batch[@]}" --threads 2 --out "$tmp/b2")"
    if command -v mpirun >/dev/null && grep -q 'STANCE_WITH_MPI:BOOL=ON' "$build/CMakeCache.txt"; then
      echo "mpi2 $(OMPI_MCA_btl_vader_single_copy_mechanism=none wall_of mpirun -np 2 \
        --oversubscribe --allow-run-as-root "$stance" "${batch[@]}" --threads 1 --out "$tmp/bm")"
    fi
  } >"$tmp/batch.txt"
fi

PYTHONPATH="$root/bench" "$python" - "$tmp" "$peer_note" "$json_out" <<'PY'
import json, os, sys

tmp, peer_note, json_out = sys.argv[1], sys.argv[2], sys.argv[3]
runs, context = {}, {}
for name in ("s0", "rest"):
    with open(os.path.join(tmp, name + ".json")) as f:
        data = json.load(f)
    context = data.get("context", context)
    for b in data["benchmarks"]:
        runs[b["name"].removesuffix("/real_time")] = b

def get(name, key):
    b = runs.get(name)
    if b is None or b.get("error_occurred"):
        return None
    return b.get(key)

def time_in(name, unit):
    # a benchmark's real time per iteration in `unit` (ns, us, ms)
    b = runs.get(name)
    if b is None or b.get("error_occurred"):
        return None
    scale = {"ns": 1, "us": 1e3, "ms": 1e6, "s": 1e9}
    return b["real_time"] * scale[b["time_unit"]] / scale[unit]

from bench_format import fmt

def pct(x):
    return "n/a" if x is None else f"{100 * x:.1f}%"

peer = {}
if not peer_note:
    for line in open(os.path.join(tmp, "peer.txt")):
        for key in ("physics+spd", "physics_only"):
            if line.startswith(key + ":"):
                peer[key] = float(line.split()[1])
    user, system, wall = (float(v) for v in open(os.path.join(tmp, "peer_time")).read().split())
    peer["cpu_per_wall"] = (user + system) / wall if wall > 0 else 0
    if "physics+spd" not in peer:
        peer_note = "the seed's loop printed no timing: " + open(os.path.join(tmp, "peer.txt")).read()
seed_us = peer.get("physics+spd")

def vs_seed(controlled_us):
    if seed_us is None or not controlled_us:
        return "the seed's loop not measured"
    r = seed_us / controlled_us
    if r >= 1:
        return f"{r:.1f}x faster than the seed's dartpy loop ({fmt(controlled_us)} vs {fmt(seed_us)} µs)"
    return f"{1 / r:.1f}x slower than the seed's dartpy loop ({fmt(controlled_us)} vs {fmt(seed_us)} µs)"

rows = []
for engine, name in (("MuJoCo", "BM_BipedStandMujoco"), ("DART", "BM_BipedStandDart")):
    if name not in runs:
        continue
    step, ctl = get(name, "step_us"), get(name, "controlled_us")
    spd, ankle = get(name, "stable_pd_us"), get(name, "ankle_strategy_us")
    rows.append((f"S0 biped, 1 ms step, {engine}: bare / with SPD + ankle strategy",
                 f"{fmt(step)} / {fmt(ctl)} µs; controller {pct(get(name, 'controller_share'))} "
                 f"of the step (SPD {fmt(spd)} µs, ankle strategy {fmt(ankle)} µs); "
                 + vs_seed(ctl)))
qm, qd = "BM_SpdQueriesMujoco", "BM_SpdQueriesDart"
if qm in runs and qd in runs:
    parts = [f"{label} {fmt(get(qm, key))} / {fmt(get(qd, key))}" for label, key in
             (("positions + velocities", "state_us"), ("bias forces", "bias_us"),
              ("constraint forces", "constraint_us"), ("(M + Kd dt)⁻¹ x", "shifted_solve_us"),
              ("then the step", "step_us"))]
    rows.append(("S0 SPD's engine queries per step, MuJoCo / DART (µs)", "; ".join(parts)))
lqr, mj = time_in("BM_LqrCompute", "ns"), time_in("BM_MjStep", "us")
if lqr is not None and mj is not None:
    rows.append(("LQR controller per call vs `mj_step` (humanoid)",
                 f"{fmt(lqr)} ns vs {fmt(mj)} µs: {pct(lqr / (mj * 1e3))} of a step"))
design = time_in("BM_LqrDesign", "ms")
if design is not None:
    rows.append(("LQR design (set-point + FD linearisation + DARE), humanoid",
                 f"{fmt(design)} ms (set-point {fmt(get('BM_LqrDesign', 'setpoint_ms'))}, "
                 f"linearisation {fmt(get('BM_LqrDesign', 'linearize_ms'))}, "
                 f"DARE {fmt(get('BM_LqrDesign', 'dare_ms'))} ms)"))
sw = "BM_LqrPushSweep"
if get(sw, "cached_s") is not None:
    rows.append(("LQR push sweep, 8 points (1.5 s runs, 1 thread): models cached vs rebuilt",
                 f"{fmt(get(sw, 'cached_s'))} s vs {fmt(get(sw, 'rebuilt_s'))} s per sweep: "
                 f"{fmt(get(sw, 'rebuilt_over_cached'))}x; LQR designs "
                 f"{fmt(get(sw, 'cached_designs'))} vs {fmt(get(sw, 'rebuilt_designs'))}"))
for engine, name in (("MuJoCo", "BM_SimbiconWalkMujoco"), ("DART", "BM_SimbiconWalkDart")):
    if name in runs:
        rows.append((f"SIMBICON 2D walk at 1700 Hz, {engine}",
                     f"{fmt(get(name, 'rtf'))}x real time; controller "
                     f"{pct(get(name, 'controller_share'))} of the step"))
mb = lambda name: None if get(name, "bytes_per_second") is None else get(name, "bytes_per_second") / 1e6
if "BM_BvhParseMassWalk" in runs:
    rows.append(("BVH parsing (`mass_walk.bvh`, `cmu_131_01.bvh`); writing",
                 f"{fmt(mb('BM_BvhParseMassWalk'))} MB/s, {fmt(mb('BM_BvhParseCmu131'))} MB/s; "
                 f"{fmt(mb('BM_BvhFormatCmu131'))} MB/s"))

def tracked(name, tracker):
    return (f"tracker {fmt(get(name, tracker + '_us'))} µs, {pct(get(name, 'controller_share'))} "
            f"of a {fmt(get(name, 'controlled_us'))} µs step; "
            f"{fmt(get(name, 'realtime_factor'))}x real time")
if "BM_MocapFreeMujoco" in runs:
    rows.append(("Mocap free mode (`mocap_track` in free mode, balance layer), MuJoCo, 2 ms step",
                 tracked("BM_MocapFreeMujoco", "mocap_tracker")))
if "BM_MocapRetargetHumanoidMujoco" in runs:
    rows.append(("Mocap retargeting (`mocap_retarget`, humanoid.xml), MuJoCo, 2 ms step",
                 tracked("BM_MocapRetargetHumanoidMujoco", "mocap_retarget")))
for engine, name in (("MuJoCo", "BM_MocapRetargetFullbody1Mujoco"),
                     ("DART", "BM_MocapRetargetFullbody1Dart")):
    if name in runs:
        rows.append((f"Mocap retargeting on fullbody1, 1 ms step, {engine}",
                     tracked(name, "mocap_retarget")))

def planner(prefix):
    # BM_Planner*/<threads>/iterations:N: the runs on 1 and 2 threads
    found = {}
    for key in runs:
        if key.startswith(prefix + "/"):
            found[key.split("/")[1]] = key
    return found
for prefix, label in (("BM_PlannerBipedStand", "biped_stand_planner, MuJoCo, 1 ms step, 2 ms rollouts"),
                      ("BM_PlannerMocap", "mocap_track_planner, the synthetic walk, MuJoCo, 0.2 s"),
                      ("BM_PlannerTrackedWalk", "bvh track of the synthetic walk, MuJoCo, 1 s"),
                      ("BM_PlannerMocapRun", "bvh track of the synthetic run, MuJoCo, 1 s")):
    p = planner(prefix)
    if "1" in p and "2" in p:
        one, two = p["1"], p["2"]
        rows.append((f"Sampling planner ({label}): compute per simulated second, 1 / 2 threads "
                     "(wall; the run's own CPU time); "
                     "the model steps it took; the bare `mj_step` of the same character from the "
                     "states of the planned run; the physical limit (those steps as bare steps over "
                     "the threads) and the distance to it",
                     f"{fmt(get(one, 'compute_s_per_sim_s'))} / {fmt(get(two, 'compute_s_per_sim_s'))} s/s "
                     f"(CPU {fmt(get(one, 'cpu_s_per_sim_s'))} / {fmt(get(two, 'cpu_s_per_sim_s'))} s/s); "
                     f"{fmt(get(one, 'model_steps_per_sim_s'))} steps/s; bare step "
                     f"{fmt(get(one, 'step_us'))} µs (a rollout step {fmt(get(one, 'rollout_us'))} µs, "
                     f"the base policy's {fmt(get(one, 'controlled_us'))} µs); limit "
                     f"{fmt(get(one, 'limit_s_per_sim_s'))} / {fmt(get(two, 'limit_s_per_sim_s'))} s/s: "
                     f"{fmt(get(one, 'over_limit'))}x / {fmt(get(two, 'over_limit'))}x the limit"))

if "BM_BatchLoopOverhead" in runs:
    name = "BM_BatchLoopOverhead"
    rows.append(("Batch stepping vs bare engine stepping (planar SIMBICON model, 1 s runs, no "
                 "controllers; goal: 10% or less)",
                 f"{fmt(get(name, 'run_us'))} vs {fmt(get(name, 'bare_us'))} µs per step: "
                 f"overhead {pct(get(name, 'overhead'))}"))
batch_file = os.path.join(tmp, "batch.txt")
if os.path.exists(batch_file):
    b = dict(line.split() for line in open(batch_file) if line.strip())
    n = float(b["runs"])
    def rate(key):
        try:
            return n / float(b[key])
        except (KeyError, ValueError, ZeroDivisionError):
            return None
    one = rate("threads1")
    parts = [f"1 thread {fmt(one)} runs/s"]
    for key, label, workers in (("threads2", "2 threads", 2), ("mpi2", "2 MPI ranks", 2)):
        r = rate(key)
        if r is not None and one:
            parts.append(f"{label} {fmt(r)} runs/s ({pct(r / (workers * one))} efficiency)")
    rows.append(("Batch runs per second (144 runs of the planar SIMBICON walk, 4 s each, as a "
                 "sweep; goal: 90% efficiency)", "; ".join(parts)))

cpu = [get(n, "cpu_per_wall") for n in ("BM_BipedStandMujoco", "BM_BipedStandDart")]
cpu = [c for c in cpu if c is not None]
print(f"`make bench`, {context.get('date', '')}: {context.get('num_cpus', '?')} CPUs at "
      f"{context.get('mhz_per_cpu', '?')} MHz, load average "
      f"{', '.join(fmt(x, 2) for x in context.get('load_avg', [])) or 'n/a'}; CPU per wall "
      f"time {', '.join(fmt(c, 2) for c in cpu)} in the S0 runs"
      + (f", {fmt(peer['cpu_per_wall'], 2)} in the seed's loop" if 'cpu_per_wall' in peer else "")
      + ".")
if peer_note:
    print(f"\nNote: {peer_note}.")
print()
print("| benchmark | result |")
print("|---|---|")
for what, result in rows:
    print(f"| {what} | {result} |")
if seed_us is not None:
    print(f"\nThe seed's loop (dartpy, DART 6.12, 1 ms step, 3000 steps): {fmt(seed_us)} µs per step "
          f"with its SPD + ankle bands, {fmt(peer.get('physics_only'))} µs bare (the bare biped "
          f"falls, so that figure has other contacts).")
if json_out:
    with open(json_out, "w") as f:
        json.dump({"benchmarks": runs, "peer": peer, "context": context}, f, indent=1)
PY

# the peer of issue 19 in this same run: DART's atlas_simbicon example beside stance's Atlas walk
echo
bash "$root/bench/atlas_peer.sh" "$build" ${json_out:+--json "${json_out%.json}_atlas.json"}

# the tracking video's cost and the viewer's pace on the tracked walk (issue 42)
echo
bash "$root/bench/tracking_view.sh" "$build"
