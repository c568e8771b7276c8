"""Compensation of a path given as arrays, through the facade's workflow."""

import numpy as np
import pytest

import flexcal


def part_frame():
    x = np.eye(4)
    x[:3, 3] = [1.2, 0.0, 1.45]  # the part 1.2 m ahead, 1.45 m up (m)
    return x


def test_compensated_path_leaves_only_the_residual():
    robot = flexcal.Robot.builtin("ir663")
    points = np.array([[0.56, 0.0, 0.0], [0.57, 0.0, 0.0], [0.58, 0.0, 0.0]])
    path = flexcal.compensate_path(
        robot,
        points,
        part_frame(),
        elastic="fe:ir663",
        process="cantilever:585,50,14,al-5005",
        payload=[0.0, 0.0, -920.0, 0.0, 0.0, 0.0],
    )
    assert len(path) == 3
    assert path.q.shape == (3, robot.dof)
    assert path.poses.shape == (3, 4, 4)
    # The loads deflect the robot; the compensation takes up all but the
    # iteration's remainder (the model is the one compensated for).
    assert path.max_predicted_deviation > 1e-5
    assert path.max_residual < 1e-3 * path.max_predicted_deviation
    np.testing.assert_allclose(
        np.linalg.norm(path.predicted_error[:, :3], axis=1).max(), path.max_predicted_deviation
    )
    # The commanded poses are the robot's forward model at the commanded q.
    np.testing.assert_allclose(robot.fk(path.q), path.poses, atol=1e-9)
    assert path.to_csv().count("\n") == 4


def test_compensation_bad_input():
    robot = flexcal.Robot.builtin("ir663")
    with pytest.raises(flexcal.ShapeError, match=r"points: expected shape \(n, 3\)"):
        flexcal.compensate_path(robot, np.zeros((3, 2)), part_frame(), "fe:ir663", "constant:0,0,0,0,0,0")
    with pytest.raises(flexcal.InputError, match="elastic"):
        flexcal.compensate_path(robot, np.zeros((3, 3)), part_frame(), "spring", "constant:0,0,0,0,0,0")
