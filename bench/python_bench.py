#!/usr/bin/env python3
"""The Python module's benchmark (not a test): the S0 biped loop, side by side in one run.

  - the seed's loop in dartpy (../shared/peers/dartpy_biped_spd.py, SPD + ankle bands);
  - the same Python controller (examples/python/biped_tutorial.py's SeedSpd) in stance's loop
    on its MuJoCo and DART engines, with the time inside compute() measured per call;
  - stance's C++ controllers (stable_pd + ankle_strategy) driven from Python (sim.run()),
    alone and with an empty Python controller added: what calling Python once per step costs.

Each figure is the fastest of three runs, all in one process run. Prints a markdown table with
the ratios to the dartpy loop. Run with Debian's python3:

    PYTHONPATH=build/python /usr/bin/python3 bench/python_bench.py [STEPS]
"""
import os
import pathlib
import platform
import re
import subprocess
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "examples" / "python"))

import stance  # noqa: E402
from biped_tutorial import SCENARIO, SeedSpd  # noqa: E402

STEPS = int(sys.argv[1]) if len(sys.argv) > 1 else 3000
PEER = ROOT.parent / "shared" / "peers" / "dartpy_biped_spd.py"


class Timed:
    """wraps a controller and adds up the wall time inside its compute()"""

    def __init__(self, inner):
        self.inner, self.seconds, self.calls = inner, 0.0, 0

    def reset(self, engine):
        self.inner.reset(engine)

    def compute(self, engine, out):
        t0 = time.perf_counter()
        self.inner.compute(engine, out)
        self.seconds += time.perf_counter() - t0
        self.calls += 1


class Empty:
    def reset(self, engine):
        pass

    def compute(self, engine, out):
        pass


ROUNDS = 3  # each figure is the fastest of this many runs: the machine is shared


def per_step(engine, controller=None, cpp=False):
    """(s per step of sim.run(), the controller's s per call or None, the result): the fastest
    of ROUNDS runs"""
    runs = [per_step_once(engine, controller() if controller else None, cpp)
            for _ in range(ROUNDS)]
    return min(runs, key=lambda r: r[0])


def per_step_once(engine, controller=None, cpp=False):
    duration = STEPS * 0.001
    if cpp:
        sim = stance.load(str(SCENARIO), engine=engine, duration=duration)
    else:
        sim = stance.load(str(SCENARIO), engine=engine, duration=duration,
                          overrides={"controllers": []})
    timed = None
    if controller is not None:
        timed = Timed(controller)
        sim.add_controller(timed)
    t0 = time.perf_counter()
    r = sim.run()
    wall = time.perf_counter() - t0
    return wall / r.steps, (timed.seconds / timed.calls if timed else None), r


def dartpy_loop():
    if not PEER.exists():
        return None
    return min(dartpy_once() for _ in range(ROUNDS))


def dartpy_once():
    p = subprocess.run(["/usr/bin/python3", str(PEER), "dart://sample/skel/fullbody1.skel",
                        str(STEPS)], capture_output=True, text=True, env={
                            **os.environ, "PYTHONPATH": ""})
    m = re.search(r"physics\+spd: ([0-9.]+) us/step", p.stdout)
    return float(m.group(1)) * 1e-6 if m else None


def us(x):
    return f"{x * 1e6:.1f} µs"


def main():
    load = os.getloadavg()
    print(f"> `bench/python_bench.py {STEPS}`, {time.strftime('%Y-%m-%dT%H:%M:%S%z')}: "
          f"{os.cpu_count()} CPUs, load average {load[0]:.2f}, {load[1]:.2f}, {load[2]:.2f}; "
          f"Python {platform.python_version()}")
    print()
    seed = dartpy_loop()
    rows = []
    for engine in ("mujoco", "dart"):
        py, ctrl, r = per_step(engine, SeedSpd)
        assert not r.fell, f"the Python-controlled biped fell on {engine}"
        cpp, _, rc = per_step(engine, cpp=True)
        # the C++ controllers plus a Python controller that does nothing: the cost of calling
        # Python once per step (the GIL, the engine and out wrappers, the call)
        empty, call, _ = per_step(engine, Empty, cpp=True)
        rows.append((engine, py, ctrl, cpp, empty, call))
    print("| loop (S0 biped, 1 ms step, SPD + ankle bands) | per step | vs the dartpy loop |")
    print("|---|---|---|")
    if seed:
        print(f"| the seed's loop in dartpy (DART 6.12) | {us(seed)} | 1.00x |")
    for engine, py, ctrl, cpp, empty, call in rows:
        ratio = f"{seed / py:.2f}x faster" if seed else "—"
        print(f"| Python controller on stance's {engine} engine | {us(py)} (compute() "
              f"{us(ctrl)}) | {ratio} |")
    for engine, py, ctrl, cpp, empty, call in rows:
        ratio = f"{seed / cpp:.2f}x faster" if seed else "—"
        print(f"| C++ stable_pd + ankle_strategy on {engine}, run from Python | {us(cpp)} | "
              f"{ratio} |")
    for engine, py, ctrl, cpp, empty, call in rows:
        print(f"| {engine}: the C++ controllers plus an empty Python controller | {us(empty)} "
              f"({(empty - cpp) * 1e6:+.1f} µs per step; inside the empty compute() {us(call)}) | — |")
    if not seed:
        print("\n(the dartpy loop was skipped: ../shared/peers is absent)")


if __name__ == "__main__":
    main()
