# Ctrl-C from Python: SIGINT to a process running a long stance.run, stance.track or a batch of
# stance.track returns promptly with KeyboardInterrupt (the runs check Python's signal handlers
# every 50 ms), the run's files written as interrupted and a batch's finished clips kept. The
# runs would take far longer than the timeout without the check.
import json
import signal
import subprocess
import sys
import time

import pytest

from conftest import SCENARIOS, run_cli

TIMEOUT_S = 60


def start(code, *args):
    """a Python process running `code` with `args` as sys.argv[1:]; it prints 'started' first"""
    script = "import sys, stance\nprint('started', flush=True)\n" + code
    p = subprocess.Popen([sys.executable, "-c", script, *map(str, args)],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert p.stdout.readline().strip() == "started", p.stderr.read()
    return p


def interrupt(p):
    """SIGINT to p; its stdout and stderr once it has exited (fails if it has not in time)"""
    p.send_signal(signal.SIGINT)
    try:
        out, err = p.communicate(timeout=TIMEOUT_S)
    except subprocess.TimeoutExpired:
        p.kill()
        p.communicate()
        pytest.fail(f"no exit {TIMEOUT_S} s after SIGINT")
    assert "KeyboardInterrupt" in err, err
    assert "finished" not in out, out
    return out, err


def finished(folder):
    """a run's folder holds its summary.json, not marked interrupted"""
    path = folder / "summary.json"
    return path.exists() and not json.loads(path.read_text())["interrupted"]


@pytest.fixture
def walk(tmp_path):
    path = tmp_path / "walk.bvh"
    assert run_cli("bvh", "synth-walk", path)[0] == 0
    return path


def test_run_stops_on_sigint(tmp_path):
    # the scenario's own length made 1e5 s long (sim.run(duration) stops at the scenario's end)
    p = start("stance.load(sys.argv[1], duration=1e5, out=sys.argv[2]).run()\nprint('finished')",
              SCENARIOS / "biped_stand.yaml", tmp_path / "run")
    time.sleep(1.5)
    interrupt(p)
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert summary["interrupted"] and summary["sim_time"] < 1e5, summary


def test_track_stops_on_sigint(tmp_path, walk):
    p = start("stance.track(sys.argv[1], out=sys.argv[2], duration=1000, loop=True, threads=1)\n"
              "print('finished')", walk, tmp_path / "track")
    time.sleep(1.5)
    interrupt(p)
    summary = json.loads((tmp_path / "track" / "summary.json").read_text())
    assert summary["interrupted"] and summary["sim_time"] < 1000, summary


def test_track_batch_keeps_finished_clips_on_sigint(tmp_path, walk):
    clips = tmp_path / "clips"
    clips.mkdir()
    for name in ("a", "b"):
        (clips / f"{name}.bvh").write_text(walk.read_text())
    out = tmp_path / "batch"
    p = start("stance.track(sys.argv[1], out=sys.argv[2], jobs=1, threads=1, plot=False,\n"
              "             overrides={'planner.samples': 8, 'planner.horizon_s': 0.3})\n"
              "print('finished')", clips, out)
    # SIGINT as soon as the first clip has finished: the other has just begun
    done = []
    deadline = time.monotonic() + TIMEOUT_S
    while not done and time.monotonic() < deadline and p.poll() is None:
        done = [c for c in ("a", "b") if finished(out / c)]
        time.sleep(0.02)
    assert len(done) == 1, (done, p.poll())
    interrupt(p)
    kept = [c for c in ("a", "b") if finished(out / c)]
    assert kept == done, kept
    assert not (out / "results.csv").exists()
    # resume=True tracks the rest
    r = subprocess.run([sys.executable, "-c",
                        "import sys, stance\n"
                        "b = stance.track(sys.argv[1], out=sys.argv[2], jobs=1, threads=1,\n"
                        "    plot=False, resume=True,\n"
                        "    overrides={'planner.samples': 8, 'planner.horizon_s': 0.3})\n"
                        "print(b.resumed, b.summary['clips'])", str(clips), str(out)],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0 and r.stdout.split() == ["1", "2"], (r.stdout, r.stderr)
