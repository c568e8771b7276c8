"""Campaign planning from Python: flexcal.plan returns the plan."""

import numpy as np
import pytest

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
    with pytest.raises(flexcal.FlexcalError, match="orientation"):
        flexcal.plan(robot, [0.02], orientation_noise_deg=[0.0], **common)
