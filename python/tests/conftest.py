# shared by the pytest files: the source tree, the stance binary, a CLI run's outputs
import csv
import json
import os
import pathlib
import subprocess

import numpy as np
import pytest

SOURCE = pathlib.Path(__file__).resolve().parents[2]
SCENARIOS = SOURCE / "scenarios"


def stance_bin():
    path = os.environ.get("STANCE_BIN", str(SOURCE / "build" / "stance"))
    assert os.path.exists(path), f"the stance binary is not at {path} (set STANCE_BIN)"
    return path


def run_cli(*args):
    """stance with args: (exit code, stdout, stderr)"""
    p = subprocess.run([stance_bin(), *map(str, args)], capture_output=True, text=True)
    return p.returncode, p.stdout, p.stderr


def read_log_csv(path):
    with open(path) as f:
        rows = list(csv.reader(f))
    data = np.array(rows[1:], dtype=float)
    return {name: data[:, i] for i, name in enumerate(rows[0])}


def read_summary(folder):
    return json.loads((pathlib.Path(folder) / "summary.json").read_text())


WALL_CLOCK = ("realtime_factor", "wall_time_s", "compute_s_per_sim_s", "cpu_s_per_sim_s")


def without_wall_clock(d):
    """summary.json without the fields measured on the wall clock (as the library's own
    without_wall_clock leaves out)"""
    if not isinstance(d, dict):
        return d
    return {k: without_wall_clock(v) for k, v in d.items()
            if k not in WALL_CLOCK and not k.endswith("_time_ms")
            and not k.endswith("_ns_per_step")}


@pytest.fixture
def tmp(tmp_path):
    return tmp_path
