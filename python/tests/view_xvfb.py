# stance.view on a simulation built in Python, with a Python controller, under xvfb-run
# (python.view_xvfb; needs a display, so it is not a test_*.py file run without one)
import stance
from conftest import SCENARIOS


class Counting(stance.Controller):
    def __init__(self):
        self.calls = 0

    def compute(self, engine, out):
        self.calls += 1


def test_view_runs_a_clone_with_its_python_controllers():
    sim = stance.load(str(SCENARIOS / "biped_stand.yaml"))
    counting = Counting()
    sim.add_controller(counting)
    sim.step(10)
    assert counting.calls == 10
    t = stance.view(sim, width=320, height=240, frames=40)
    # the viewer's physics thread stepped the clone, calling the Python controller
    assert t > sim.time
    assert counting.calls > 10
    assert abs(sim.time - 0.01) < 1e-12  # sim itself is not advanced
