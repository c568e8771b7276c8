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
