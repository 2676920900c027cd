# scenarios from Python against the CLI: the same summary and log, the same errors
import threading

import numpy as np
import pytest

import stance
from conftest import (SCENARIOS, read_log_csv, read_summary, run_cli, without_wall_clock)


@pytest.mark.parametrize("engine", ["mujoco", "dart"])
def test_run_gives_the_cli_summary_and_log(tmp, engine):
    path = SCENARIOS / "biped_stand.yaml"
    rc, _, err = run_cli("run", path, "--engine", engine, "--duration", 1.5, "--quiet",
                         "--set", "controllers.0.kp=500", "--out", tmp)
    assert rc == 0, err
    r = stance.run(str(path), engine=engine, duration=1.5, overrides={"controllers.0.kp": 500})
    cli = read_summary(tmp)
    assert without_wall_clock(r.summary) == without_wall_clock(cli)
    assert r.fell is False and r.fall_time is None
    assert r.metrics == r.summary["metrics"]
    assert r.summary["steps"] == 1500
    # the log: log.csv's columns, its rows at full precision (the CSV has 9 digits)
    log = read_log_csv(tmp / "log.csv")
    assert list(r.log) == list(log)
    for name, column in log.items():
        assert r.log[name].dtype == np.float64
        np.testing.assert_allclose(r.log[name], column, rtol=1e-8, atol=1e-6, err_msg=name)


def test_out_folder_writes_the_files_stance_run_writes(tmp):
    path = SCENARIOS / "pd_hold.yaml"
    sim = stance.load(str(path), duration=0.5, out=str(tmp))
    r = sim.run()
    assert read_summary(tmp) == r.summary
    assert (tmp / "log.csv").exists()


def test_run_in_pieces_ends_where_one_run_ends():
    path = str(SCENARIOS / "pd_hold.yaml")
    whole = stance.load(path, duration=1.0)
    rw = whole.run()
    pieces = stance.load(path, duration=1.0)
    first = pieces.run(duration=0.4)
    assert first.sim_time == pytest.approx(0.4, abs=1e-9)
    pieces.step(100)
    assert pieces.time == pytest.approx(0.5, abs=1e-9)
    rest = pieces.run()
    assert rest.sim_time == rw.sim_time
    assert without_wall_clock(rest.metrics) == without_wall_clock(rw.metrics)
    np.testing.assert_array_equal(whole.engine.q, pieces.engine.q)


def test_bad_input_raises_input_error_with_the_cli_message(tmp):
    bad = tmp / "bad.yaml"
    bad.write_text(f"name: bad\nmodel: {SCENARIOS.parent / 'models' / 'arm3.xml'}\n"
                   "duration: 1\ncontrollers:\n  - type: hold_pose_pd\n    kq: 10\n")
    rc, _, err = run_cli("run", bad, "--quiet", "--out", tmp / "o")
    assert rc == 2
    with pytest.raises(stance.InputError) as e:
        stance.load(str(bad))
    assert f"{bad}:6:" in str(e.value)
    assert err.strip() == "error: " + str(e.value)
    assert isinstance(e.value, ValueError)


def test_bad_override_and_engine_name_the_parameter():
    path = str(SCENARIOS / "pd_hold.yaml")
    with pytest.raises(stance.InputError) as e:
        stance.load(path, overrides={"controllers.0.kp": -5})
    assert str(e.value) == (f"{path}: (from --set) parameter 'controllers[0].kp': -5 is outside "
                            "[0, inf]")
    with pytest.raises(stance.InputError, match="expected mujoco or dart, found 'bullet'"):
        stance.load(path, engine="bullet")
    with pytest.raises(stance.InputError, match="nope"):
        stance.load(path, pushes=["nope,1,0,0,0,1"])


def test_a_python_entry_from_the_cli_is_a_located_exit_2(tmp):
    y = tmp / "py.yaml"
    y.write_text(f"name: py\nmodel: {SCENARIOS.parent / 'models' / 'arm3.xml'}\n"
                 "duration: 0.1\ncontrollers:\n  - type: python\n    module: pd_controllers\n"
                 "    class: JointPd\n")
    rc, _, err = run_cli("run", y, "--quiet", "--out", tmp / "o")
    assert rc == 2
    assert err.strip() == (f"error: {y}:5: controllers[0]: type 'python' is resolved only when "
                           "the scenario is loaded from Python (stance.load)")


def test_divergence_raises_divergence_error_as_the_cli_exits_3(tmp):
    # plain PD at stable PD's gains diverges on DART (README: exit code 3)
    path = SCENARIOS / "biped_stand.yaml"
    rc, _, err = run_cli("run", path, "--engine", "dart", "--set", "controllers.0.type=pd",
                         "--quiet", "--out", tmp)
    assert rc == 3, err
    with pytest.raises(stance.DivergenceError) as e:
        stance.run(str(path), engine="dart", overrides={"controllers.0.type": "pd"})
    assert isinstance(e.value, RuntimeError)
    assert e.value.result.diverged
    assert without_wall_clock(e.value.result.summary) == without_wall_clock(read_summary(tmp))
    assert str(e.value) == "simulation diverged: " + e.value.result.divergence


def test_save_restore_continues_bit_for_bit():
    sim = stance.load(str(SCENARIOS / "biped_stand.yaml"), engine="mujoco")
    sim.step(200)
    state = sim.save()
    sim.step(300)
    q1, t1 = sim.engine.q.copy(), sim.time
    sim.restore(state)
    assert sim.time == pytest.approx(0.2)
    sim.step(300)
    assert sim.time == t1
    np.testing.assert_array_equal(sim.engine.q, q1)
    clone = sim.clone()
    np.testing.assert_array_equal(clone.engine.q, sim.engine.q)


def test_sweep_returns_arrays_matching_single_runs():
    path = str(SCENARIOS / "pd_hold.yaml")
    s = stance.sweep(path, "controllers.0.kp", [20, 80], duration=0.5, threads=2)
    assert s["value"].tolist() == [20.0, 80.0]
    assert s["fell"].dtype == np.bool_ and s["sim_time"].dtype == np.float64
    for i, kp in enumerate([20, 80]):
        r = stance.run(path, duration=0.5, overrides={"controllers.0.kp": kp})
        assert s["metrics"][i] == without_wall_clock(r.metrics)


def test_run_releases_the_gil():
    # a Python thread counts while another thread is inside a long sim.run(): it sees the
    # simulated time strictly between the run's start and end, which it could not if the run
    # held the GIL (reading the engine's clock from another thread is a benign race here)
    sim = stance.load(str(SCENARIOS / "biped_stand.yaml"), engine="mujoco", duration=3.0)
    engine = sim.engine
    inside = [0]
    seen = set()
    stop = threading.Event()
    started = threading.Event()

    def counter():
        started.set()
        while not stop.is_set():
            t = engine.time
            if 0.0 < t < 3.0:
                inside[0] += 1
                seen.add(t)

    worker = threading.Thread(target=lambda: sim.run())
    t = threading.Thread(target=counter)
    t.start()
    started.wait()
    worker.start()
    worker.join()
    stop.set()
    t.join()
    assert sim.time == pytest.approx(3.0)
    assert inside[0] > 10
    assert len(seen) > 10


@pytest.mark.parametrize("method", ["cem", "cmaes"])
def test_tune_returns_the_cli_table(tmp, method):
    path = SCENARIOS / "biped_stand.yaml"
    args = dict(params=["controllers.0.kp=20:1000:log", "controllers.0.kd=2:100:log"],
                neighbours=["controllers.0.kp*=0.8,controllers.0.kd*=0.8"], budget=4,
                population=2, duration=0.5, threads=2, metric="com_displacement_m",
                overrides={"controllers.0.kp": 40, "controllers.0.kd": 4}, method=method)
    rc, _, err = run_cli("tune", path, "--param", args["params"][0], "--param", args["params"][1],
                         "--neighbour", args["neighbours"][0], "--set", "controllers.0.kp=40",
                         "--set", "controllers.0.kd=4", "--budget", 4, "--population", 2,
                         "--duration", 0.5, "--threads", 2, "--metric", "com_displacement_m",
                         "--method", method, "--out", tmp)
    assert rc == 0, err
    t = stance.tune(str(path), **args)
    table = np.genfromtxt(tmp / "tune.csv", delimiter=",", names=True)
    assert t["values"].shape == (4, 2) and t["values"].dtype == np.float64
    np.testing.assert_array_equal(t["values"][0], [40, 4])
    np.testing.assert_allclose(t["values"][:, 0], table["controllers0kp"], rtol=1e-12)
    np.testing.assert_allclose(t["robust_score"], table["robust_score"], rtol=1e-8)  # 9 digits
    np.testing.assert_array_equal(t["generation"], table["generation"])
    assert len(t["best_sets"]) == 2


def test_robustness_returns_the_cli_map(tmp):
    # a small map (2 directions, 1 phase of standing) from Python and from the CLI: the same
    # thresholds, outcomes and summary
    path = SCENARIOS / "biped_stand.yaml"
    opts = dict(body="h_pelvis", directions=2, phases=1, max_force=300.0, tolerance=10.0,
                at=1.0, duration=2.5, threads=2, engine="mujoco")
    rc, _, err = run_cli("robustness", path, "--body", "h_pelvis", "--directions", 2, "--phases",
                         1, "--max", 300, "--tolerance", 10, "--at", 1.0, "--duration", 2.5,
                         "--threads", 2, "--engine", "mujoco", "--no-plot", "--quiet",
                         "--out", tmp)
    assert rc == 0, err
    m = stance.robustness(str(path), **opts)
    assert m["threshold"].shape == (2, 1) and m["threshold"].dtype == np.float64
    assert m["outcome"].dtype == np.int32 and m["angle_deg"].tolist() == [0.0, 180.0]
    table = np.genfromtxt(tmp / "thresholds.csv", delimiter=",", names=True)
    np.testing.assert_allclose(m["threshold"][:, 0], table["threshold_n"], rtol=1e-8)
    np.testing.assert_array_equal(m["outcome"][:, 0], table["outcome_at_threshold"])
    assert 0 < m["threshold"].min() < 300
    # every trial at the threshold survived and the bracket above it fell
    t = m["trials"]
    for d in range(2):
        mine = (t["direction"] == d)
        ok = np.isin(t["outcome"][mine], [0, 3])
        assert t["force"][mine][ok].max() == m["threshold"][d, 0]
        assert t["force"][mine][~ok].min() == m["fell_at"][d, 0]
    assert m["summary"] == read_summary(tmp)


def test_robustness_bad_body_is_an_input_error():
    with pytest.raises(stance.InputError, match="no_such_body"):
        stance.robustness(str(SCENARIOS / "biped_stand.yaml"), body="no_such_body",
                          directions=2, phases=1)
