"""Campaign planning from Python: flexcal.plan returns the plan."""

import json

import numpy as np
import pytest

from conftest import REPOSITORY

import flexcal

BOX = np.radians(
    [[-90, 90], [-125, -35], [30, 125], [-140, 30], [30, 150], [-170, 170]]
)


def test_plan_returns_the_poses_curve_and_prediction():
    robot = flexcal.Robot.builtin("ur10")
    rng = np.random.default_rng(4)
    candidates = rng.uniform(BOX[:, 0], BOX[:, 1], size=(50, 6))
    region = rng.uniform(BOX[:, 0], BOX[:, 1], size=(20, 6))
    plan = flexcal.plan(
        robot, [0.02], candidates=candidates, region=region, poses=15, max_poses=30
    )
    assert plan["count"] == 15
    q = np.array(plan["configurations"])
    assert q.shape == (15, 6)
    # The planned poses are rows of the candidates, each once.
    rows = plan["selected"]
    assert len(set(rows)) == 15
    np.testing.assert_allclose(q, candidates[rows])
    # More poses never raise the predicted mean bound.
    means = [p["accuracy"]["mean_bound_95_mm"] for p in plan["curve"]]
    assert all(b <= a * (1 + 1e-9) for a, b in zip(means, means[1:]))
    assert plan["knee"] in [p["poses"] for p in plan["curve"]]
    bounds = [p["bound_95_mm"] for p in plan["prediction"]["map"]["poses"]]
    assert len(bounds) == 20
    # The instrument's own 95 % radius is the floor of every bound.
    assert min(bounds) > np.sqrt(7.8147) * 0.02
    assert isinstance(plan["prediction"]["identifiability_notes"], list)


def test_bad_plans_raise_named_errors():
    robot = flexcal.Robot.builtin("ur10")
    with pytest.raises(flexcal.FlexcalError, match="noise along x"):
        flexcal.plan(robot, [0.0], joint_box=BOX, candidate_count=20, region_count=5)
    with pytest.raises(flexcal.FlexcalError, match="31 poses asked for, but only 30"):
        flexcal.plan(robot, [0.02], joint_box=BOX, candidate_count=30, region_count=5, poses=31)
    with pytest.raises(flexcal.ShapeError):
        flexcal.plan(robot, [0.02], candidates=np.zeros((4, 5)))


def test_full_poses_never_predict_worse_than_positions():
    """`orientation_noise_deg` plans full poses: the orientation rows add
    information, so the predicted mean bound at every count of the curve
    is no wider than with positions alone; the instrument is in the plan."""
    robot = flexcal.Robot.builtin("ur10")
    rng = np.random.default_rng(5)
    candidates = rng.uniform(BOX[:, 0], BOX[:, 1], size=(40, 6))
    region = rng.uniform(BOX[:, 0], BOX[:, 1], size=(15, 6))
    common = dict(candidates=candidates, region=region, poses=20, max_poses=25)
    positions = flexcal.plan(robot, [0.02], **common)
    full = flexcal.plan(robot, [0.02], orientation_noise_deg=[0.01], **common)
    assert full["instrument"]["orientation_noise_deg"] == [0.01, 0.01, 0.01]
    assert positions["instrument"].get("orientation_noise_deg") is None
    by_count = {p["poses"]: p["accuracy"]["mean_bound_95_mm"] for p in positions["curve"]}
    compared = 0
    for p in full["curve"]:
        if p["poses"] in by_count:
            assert p["accuracy"]["mean_bound_95_mm"] <= by_count[p["poses"]] * (1 + 1e-9)
            compared += 1
    assert compared > 5
    with pytest.raises(flexcal.InputError, match="orientation_noise_deg: one value or three"):
        flexcal.plan(robot, [0.02], orientation_noise_deg=[0.01, 0.02], **common)
    # The frame's uncertainty counted: on the same poses (every candidate
    # planned), every bound at least as wide as with the frame registered
    # again, and some wider.
    every = dict(candidates=candidates[:25], region=region, poses=25, max_poses=25)
    registered = flexcal.plan(robot, [0.02], **every)
    kept = flexcal.plan(robot, [0.02], frame_uncertainty="as-identified", **every)
    assert kept["instrument"]["frame"] == "as-identified"
    assert registered["instrument"]["frame"] == "registered"
    wide = [p["bound_95_mm"] for p in kept["prediction"]["map"]["poses"]]
    narrow = [p["bound_95_mm"] for p in registered["prediction"]["map"]["poses"]]
    assert len(wide) == len(narrow) == 15
    assert all(a >= b * (1 - 1e-9) for a, b in zip(wide, narrow))
    assert any(a > b * 1.001 for a, b in zip(wide, narrow))
    with pytest.raises(flexcal.InputError, match="frame_uncertainty: `sideways`"):
        flexcal.plan(robot, [0.02], frame_uncertainty="sideways", **common)
    with pytest.raises(flexcal.FlexcalError, match="orientation"):
        flexcal.plan(robot, [0.02], orientation_noise_deg=[0.0], **common)


def test_the_plan_leaves_out_what_the_instrument_cannot_see():
    """A reach box and a line of sight: every planned pose's TCP lies in
    the box and faces the instrument within the angle (checked here with
    the robot's own forward kinematics), and the plan counts the rest."""
    robot = flexcal.Robot.builtin("ur10")
    rng = np.random.default_rng(6)
    candidates = rng.uniform(BOX[:, 0], BOX[:, 1], size=(100, 6))
    region = rng.uniform(BOX[:, 0], BOX[:, 1], size=(15, 6))
    box = [[-2000.0, 2000.0], [-2000.0, 2000.0], [-200.0, 2000.0]]
    at, angle = np.array([2500.0, 0.0, 500.0]), 110.0
    plan = flexcal.plan(
        robot, [0.02], candidates=candidates, region=region, poses=15, max_poses=20,
        reach_box_mm=box, sight_from_mm=list(at), max_incidence_deg=angle,
    )
    left_out = plan["outside_reach_box"] + plan["facing_away"]
    assert plan["candidates"] + left_out == 100
    assert left_out > 0
    for q in plan["configurations"]:
        pose = np.asarray(robot.fk(np.asarray(q)))
        p, z = pose[:3, 3] * 1e3, pose[:3, 2]
        assert all(lo <= v <= hi for v, (lo, hi) in zip(p, box))
        cos = z @ (at - p) / np.linalg.norm(at - p)
        assert cos >= np.cos(np.radians(angle)) - 1e-12
    with pytest.raises(flexcal.InputError, match="give both"):
        flexcal.plan(robot, [0.02], candidates=candidates, region=region, sight_from_mm=[0, 0, 0])
    with pytest.raises(flexcal.FlexcalError, match="sees none of the 100 candidates"):
        flexcal.plan(
            robot, [0.02], candidates=candidates, region=region,
            reach_box_mm=[[5000, 6000], [0, 1], [0, 1]],
        )


def test_plan_with_a_target_on_each_hand(tmp_path):
    """`targets`, the description `calibrate` reads: each hand of the
    two-armed robot is predicted over the region, its statistics those of
    its own bounds; a target on a frame the robot lacks is named."""
    data = REPOSITORY / "crates" / "flexcal-calib" / "tests" / "data"
    robot = flexcal.Robot.from_toml(data / "two_arms.toml")
    targets = data / "two_arms_targets.toml"
    plan = flexcal.plan(
        robot,
        [0.02],
        targets=targets,
        candidate_count=60,
        region_count=20,
        poses=20,
        max_poses=25,
    )
    assert [t["name"] for t in plan["targets"]] == ["left", "right"]
    per_target = plan["prediction"]["per_target"]
    assert [t["target"] for t in per_target] == ["left", "right"]
    for own in per_target:
        bounds = [
            p["bound_95_mm"]
            for p in plan["prediction"]["map"]["poses"]
            if p["target"] == own["target"]
        ]
        assert len(bounds) == 20
        assert own["accuracy"]["mean_bound_95_mm"] == pytest.approx(np.mean(bounds), rel=1e-12)
        assert own["accuracy"]["max_bound_95_mm"] == pytest.approx(max(bounds), rel=1e-12)
    wrong = tmp_path / "wrong.toml"
    wrong.write_text(targets.read_text().replace('"RH"', '"RX"'))
    with pytest.raises(flexcal.FlexcalError, match="no frame `RX`"):
        flexcal.plan(robot, [0.02], targets=wrong, candidate_count=30, region_count=5)


def test_plan_with_an_earlier_calibration_as_prior(tmp_path):
    """`prior=` reads an earlier calibration's report (`to_json` of a
    calibration with `split_check=True`): its residual scatter floors the
    noise, its split-half ratio raises the identification part, and every
    region point's bound is the root sum of squares of its parts. A
    report without the split-half check is refused by name."""
    robot = flexcal.Robot.builtin("ur10")
    rng = np.random.default_rng(6)
    q = rng.uniform(BOX[:, 0], BOX[:, 1], size=(60, 6))
    positions = robot.fk(q)[:, :3, 3] + rng.normal(0.0, 0.1e-3, size=(60, 3))
    data = flexcal.MeasurementSet.from_arrays(q, positions)
    earlier = flexcal.calibrate(robot, data, select="none", split_check=True)
    report = json.loads(earlier.to_json())
    prior = tmp_path / "prior.json"
    prior.write_text(json.dumps(report))
    scatter_mm = report["identification"]["residual_scatter_mm"]
    ratio = report["split_check"]["prediction_ratio"]
    common = dict(joint_box=BOX, candidate_count=40, region_count=15, poses=20, max_poses=20)
    plan = flexcal.plan(robot, [scatter_mm / 4], prior=str(prior), **common)
    used = plan["prior"]
    assert used["floor_mm"] == pytest.approx([scatter_mm] * 3, rel=1e-12)
    assert used["inflation"] == pytest.approx(max(ratio, 1.0), rel=1e-12)
    chi = np.sqrt(7.814727903251178)
    for point in plan["prediction"]["map"]["poses"]:
        parts = point["parts"]
        assert parts["scatter_mm"] == pytest.approx(chi * scatter_mm)
        assert parts["extrapolation_mm"] == 0.0  # no --extrapolation growth
        root = np.hypot(parts["scatter_mm"], parts["parameters_mm"])
        assert point["bound_95_mm"] == pytest.approx(root)
    del report["split_check"]
    prior.write_text(json.dumps(report))
    with pytest.raises(flexcal.FlexcalError, match="calibrate the prior with --split-check"):
        flexcal.plan(robot, [0.02], prior=str(prior), **common)
