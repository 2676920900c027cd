# every path argument takes a str or a pathlib.Path
import re

import numpy as np

import stance
from conftest import SCENARIOS, SOURCE, read_summary

# the parameters that name files or folders, in every function and method of the module
PATH_PARAMETERS = {"path", "out", "csv_path", "png_path", "clip", "map", "model"}


def native_signatures():
    """(name, {parameter: type}) from each native function's and method's signature line"""
    for name in dir(stance._stance):
        obj = getattr(stance._stance, name)
        members = [obj] + [getattr(obj, m) for m in dir(obj) if not m.startswith("__")] \
            if isinstance(obj, type) else [obj]
        for f in members:
            m = re.match(r"^(\w+)\((.*)\) ->", (getattr(f, "__doc__", None) or "").split("\n")[0])
            if m:
                params = re.split(r",\s*(?![^\[]*\])", m.group(2))
                yield m.group(1), dict(p.split(" = ")[0].split(": ", 1) for p in params
                                       if ": " in p)


def test_every_path_parameter_takes_a_path_like():
    seen = 0
    for name, params in native_signatures():
        for p, t in params.items():
            if p in PATH_PARAMETERS and not (name == "track" and p == "clip"):
                assert "os.PathLike" in t, f"{name}({p}: {t})"
                seen += 1
    assert seen >= 10


def test_scenarios_engines_and_state_files_take_a_path(tmp):
    sim = stance.load(SCENARIOS / "pd_hold.yaml", duration=0.2, out=tmp / "run")
    r = sim.run()
    assert read_summary(tmp / "run") == r.summary
    sim.write_state(tmp / "end.state")
    again = stance.load(SCENARIOS / "pd_hold.yaml", duration=0.2)
    again.read_state(tmp / "end.state")
    np.testing.assert_array_equal(again.engine.q, sim.engine.q)
    assert stance.run(SCENARIOS / "pd_hold.yaml", duration=0.1).sim_time > 0
    engine = stance.Engine.load(SOURCE / "models" / "arm3.xml")
    assert engine.nv > 0
