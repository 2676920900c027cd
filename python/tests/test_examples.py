# the Python examples run and check their own results (exit 0 and their OK line)
import os
import subprocess
import sys

from conftest import SOURCE


def run_example(name, *args):
    p = subprocess.run([sys.executable, str(SOURCE / "examples" / "python" / name), *args],
                       capture_output=True, text=True, env=os.environ.copy())
    print(p.stdout, p.stderr)
    return p


def test_biped_tutorial_stands_on_both_engines():
    p = run_example("biped_tutorial.py", "--duration", "5")
    assert p.returncode == 0
    assert "OK: the biped stands 5 s on every engine, pushed or not" in p.stdout


def test_lqr_one_leg_holds_10_s(tmp_path):
    p = run_example("lqr_one_leg.py", "--out", str(tmp_path))
    assert p.returncode == 0
    assert "OK: the LQR designed step by step in Python holds the humanoid 10 s" in p.stdout
    assert (tmp_path / "force_offset.png").stat().st_size > 1000
