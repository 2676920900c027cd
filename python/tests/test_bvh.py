# stance.read_bvh and stance.track against the CLI: the exact parse of a small file, the measures
# `stance bvh info` prints, and `stance bvh track`'s files and metrics for the same clip
import csv
import json
import math
import pathlib

import numpy as np
import pytest

import stance
from conftest import read_log_csv, read_summary, run_cli, without_wall_clock


def leg_block(side, knee_channels):
    """a BVH leg, hip and knee, with the knee's rotation channels; 90 file units long"""
    x = 10 if side == "Left" else -10
    return f"""\tJOINT {side}UpLeg
\t{{
\t\tOFFSET {x} -5 0
\t\tCHANNELS 3 Zrotation Xrotation Yrotation
\t\tJOINT {side}Leg
\t\t{{
\t\t\tOFFSET 0 -45 0
\t\t\tCHANNELS 3 {knee_channels}
\t\t\tEnd Site
\t\t\t{{
\t\t\t\tOFFSET 0 -45 0
\t\t\t}}
\t\t}}
\t}}
"""


# a standing skeleton 145 file units tall (cm: the legs drop 95 below the hips), three frames
SMALL_BVH = ("""HIERARCHY
ROOT Hips
{
\tOFFSET 0 0 0
\tCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
""" + leg_block("Left", "Xrotation Yrotation Zrotation")
             + leg_block("Right", "Zrotation Xrotation Yrotation") + """\tJOINT Spine
\t{
\t\tOFFSET 0 10 0
\t\tCHANNELS 3 Zrotation Xrotation Yrotation
\t\tEnd Site
\t\t{
\t\t\tOFFSET 0 40 0
\t\t}
\t}
}
MOTION
Frames: 3
Frame Time: 0.04
""")
ROWS = [
    [1.5, 95, -2.25, 0, 0, 0, 0, 10, 0, -5, 0, 0, 0, -10, 0, 0, 5, 0, 0.5, 0, 0],
    [3.5, 95.25, -2, 0, 0, 90, 0, 5, 0, 0, 0, 0, 0, -5, 0, 0, 2.5, 0, 0, 1, 0],
    [5.5, 95, -1.75, 0, 0, 0, 0, 0, 0, 5, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0],
]
NAMES = ["Hips", "LeftUpLeg", "LeftLeg", "RightUpLeg", "RightLeg", "Spine"]
ROTATION_CHANNELS = ["Zrotation", "Xrotation", "Yrotation"]


@pytest.fixture
def small_bvh(tmp):
    path = tmp / "small.bvh"
    path.write_text(SMALL_BVH + "".join(" ".join(str(v) for v in r) + "\n" for r in ROWS))
    return path


@pytest.fixture
def walk_bvh(tmp):
    """the synthetic walk, 67 frames (1.1 s)"""
    path = tmp / "walk.bvh"
    rc, _, err = run_cli("bvh", "synth-walk", path)
    assert rc == 0, err
    return path


def test_read_bvh_parses_the_skeleton_channels_and_frames_exactly(small_bvh):
    clip = stance.read_bvh(small_bvh)  # a pathlib.Path
    assert clip.source == str(small_bvh)
    assert (clip.frame_count, clip.channel_count, len(clip)) == (3, 21, 3)
    assert clip.frame_time == 0.04
    assert clip.duration == pytest.approx(0.12, abs=1e-15)
    assert clip.joint_names == NAMES
    assert [j.parent for j in clip.joints] == [-1, 0, 1, 0, 3, 0]
    assert [j.first_column for j in clip.joints] == [0, 6, 9, 12, 15, 18]
    assert clip.joints[0].channels == ["Xposition", "Yposition", "Zposition"] + ROTATION_CHANNELS
    assert clip.joints[2].channels == ["Xrotation", "Yrotation", "Zrotation"]
    assert [j.rotation_order for j in clip.joints] == ["ZXY", "ZXY", "XYZ", "ZXY", "ZXY", "ZXY"]
    np.testing.assert_array_equal(clip.joints[1].offset, [10, -5, 0])
    assert [j.has_end_site for j in clip.joints] == [False, False, True, False, True, True]
    np.testing.assert_array_equal(clip.joints[5].end_site_offset, [0, 40, 0])
    assert clip.channel_names[:7] == ["Hips.Xposition", "Hips.Yposition", "Hips.Zposition",
                                      "Hips.Zrotation", "Hips.Xrotation", "Hips.Yrotation",
                                      "LeftUpLeg.Zrotation"]
    assert clip.channel_names[9] == "LeftLeg.Xrotation" and len(clip.channel_names) == 21
    # the rows as read, and as translations and rotations per joint
    assert clip.frames.dtype == np.float64 and not clip.frames.flags.writeable
    np.testing.assert_array_equal(clip.frames, np.array(ROWS, dtype=float))
    assert clip.translations.shape == (3, 6, 3) and clip.rotations.shape == (3, 6, 4)
    np.testing.assert_array_equal(clip.translations[:, 0], np.array(ROWS)[:, :3])
    np.testing.assert_array_equal(clip.translations[2, 1:],
                                  [j.offset for j in clip.joints[1:]])
    half = math.sqrt(0.5)
    np.testing.assert_allclose(clip.rotations[1, 0], [half, 0, half, 0], atol=1e-15)  # Y 90
    np.testing.assert_allclose(clip.rotations[2, 0], [1, 0, 0, 0], atol=1e-15)
    s, c = math.sin(math.radians(5)), math.cos(math.radians(5))
    np.testing.assert_allclose(clip.rotations[0, 3], [c, -s, 0, 0], atol=1e-15)  # X -10
    # standing: the end sites span 145 cm; units from the 95 cm legs
    assert clip.units == "centimeters" and clip.scale_to_meters == 0.01
    assert clip.up_axis == "y" and clip.first_motion_frame == 0
    assert clip.standing_height_m == pytest.approx(1.45, abs=1e-12)
    assert clip.leg_m == pytest.approx(0.95, abs=1e-12)
    assert clip.warnings == []


def test_read_bvh_measures_as_bvh_info_does(walk_bvh):
    clip = stance.read_bvh(str(walk_bvh))
    rc, out, err = run_cli("bvh", "info", walk_bvh, "--json")
    assert rc == 0, err
    info = json.loads(out)
    for key in ("root_body", "root_carriers", "legs"):  # the tracker's view, not the clip's
        del info[key]
    assert clip.info == info
    character = info["character"]
    assert clip.standing_height_m == character["standing_height_m"]
    assert 1.0 < clip.standing_height_m < 2.3
    assert clip.mean_speed_mps == character["mean_speed_mps"] > 0.5
    assert clip.peak_speed_mps == character["peak_speed_mps"]
    assert clip.facing_deg == character["facing_deg"]
    assert clip.travel_deg == character["travel_deg"]
    assert clip.heading_axes == character["heading_axes"]


def test_track_gives_the_cli_files_and_metrics(tmp, walk_bvh):
    rc, _, err = run_cli("bvh", "track", walk_bvh, "--out", tmp / "cli", "--quiet")
    assert rc == 0, err
    r = stance.track(walk_bvh, out=tmp / "py")
    assert r.out == str(tmp / "py")
    cli = read_summary(tmp / "cli")
    assert without_wall_clock(r.summary) == without_wall_clock(cli)
    assert without_wall_clock(read_summary(tmp / "py")) == without_wall_clock(cli)
    assert r.metrics == r.summary["metrics"]
    mocap = cli["metrics"]["mocap"]
    assert r.success is mocap["success"] is True and r.fell is False and r.fall_time is None
    assert r.g_mpjpe_m == mocap["mean_body_position_error_m"] < 0.1
    assert r.sim_time == pytest.approx(1.1, abs=0.02)
    # the log as log.csv has it; the tracked motion as tracked.bvh, byte for byte
    log = read_log_csv(tmp / "cli" / "log.csv")
    assert list(r.log) == list(log)
    for name, column in log.items():
        np.testing.assert_allclose(r.log[name], column, rtol=1e-8, atol=1e-6, err_msg=name)
    tracked = (tmp / "cli" / "tracked.bvh").read_bytes()
    assert (tmp / "py" / "tracked.bvh").read_bytes() == tracked
    assert r.tracked.joint_names == stance.read_bvh(walk_bvh).joint_names
    np.testing.assert_array_equal(r.tracked.frames,
                                  stance.read_bvh(tmp / "cli" / "tracked.bvh").frames)


def test_track_without_out_keeps_no_files_and_takes_a_clip(walk_bvh):
    r = stance.track(stance.read_bvh(walk_bvh), duration=0.1, overrides={"controllers.0.kp": 300})
    assert r.out is None
    assert r.tracked.frame_count >= 6
    assert not pathlib.Path(r.tracked.source).parent.exists()
    assert r.sim_time == pytest.approx(0.1, abs=1e-9) and r.fell is False


def test_a_missing_or_bad_clip_raises_input_error_and_writes_nothing(tmp, walk_bvh):
    missing = tmp / "missing.bvh"
    with pytest.raises(stance.InputError, match="missing.bvh: cannot open"):
        stance.read_bvh(missing)
    with pytest.raises(stance.InputError, match="missing.bvh"):
        stance.track(missing, out=tmp / "o")
    with pytest.raises(stance.InputError, match="--first-frame|not a range"):
        stance.track(walk_bvh, out=tmp / "o", first_frame=500)
    assert not (tmp / "o").exists()
    with pytest.raises(TypeError, match="expected a path"):
        stance.track(42)


def test_track_of_many_clips_gives_the_cli_batch_table(tmp, walk_bvh):
    run_bvh = tmp / "run.bvh"
    assert run_cli("bvh", "synth-run", run_bvh)[0] == 0
    rc, out, err = run_cli("bvh", "track", walk_bvh, run_bvh, "--out", tmp / "cli",
                           "--duration", 0.3, "--no-plot", "--quiet")
    assert rc == 0, err
    b = stance.track([walk_bvh, str(run_bvh)], out=tmp / "py", duration=0.3, plot=False)
    assert b.out == str(tmp / "py") and b.clips == [str(walk_bvh), str(run_bvh)]
    assert b.summary["line"] in out
    assert (b.summary["clips"], b.summary["succeeded"], b.summary["errors"]) == (2, 2, 0)
    # results.csv's columns, the wall-clock and CPU-time ones aside (the CSV has 9 digits)
    with open(tmp / "cli" / "results.csv") as f:
        rows = list(csv.DictReader(f))
    assert list(b.rows) == list(rows[0])
    assert b.rows["clip"] == [r["clip"] for r in rows] == ["walk", "run"]
    assert b.rows["error"] == ["", ""]
    for name in set(rows[0]) - {"clip", "error", "compute_s_per_sim_s", "cpu_s_per_sim_s"}:
        np.testing.assert_allclose(b.rows[name], [float(r[name]) for r in rows], rtol=1e-8,
                                   err_msg=name)
    for clip in ("walk", "run"):
        assert without_wall_clock(read_summary(tmp / "py" / clip)) == \
            without_wall_clock(read_summary(tmp / "cli" / clip))
    with pytest.raises(stance.InputError, match="need out"):
        stance.track([walk_bvh, run_bvh])
