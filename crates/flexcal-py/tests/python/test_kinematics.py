"""Forward model and Jacobians: against the Rust library's values and
against finite differences."""

import numpy as np
import pytest
from conftest import configurations

import flexcal


def test_builtin_robots_and_parameters(ur10):
    assert "ur10" in flexcal.Robot.builtin_names()
    assert ur10.dof == 6
    parameters = ur10.parameters
    assert len(parameters) == len(ur10.nominal) == 24
    assert {p.unit for p in parameters} == {"m", "rad"}
    by_name = {p.name: p for p in parameters}
    # Published UR10 DH values (flexcal-kinematics docs): a2 = -612 mm is KK d3.
    assert by_name["d3"].unit == "m"
    assert by_name["d3"].nominal == pytest.approx(-0.612)
    assert "beta3" in by_name and by_name["beta3"].unit == "rad"
    assert [p.index for p in parameters] == list(range(24))


def check_against_rust(rust_reference, key, evaluate, shape):
    """`evaluate` on the reference configurations, batched and one at a
    time, equals the Rust library's values under `key` to 1e-12."""
    q = np.array(rust_reference["q"])
    expected = np.array(rust_reference[key])
    got = evaluate(q)
    assert got.shape == (len(q), *shape)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)
    np.testing.assert_allclose(evaluate(q[3]), expected[3], rtol=0, atol=1e-12)


def test_fk_matches_rust(ur10, rust_reference):
    check_against_rust(rust_reference, "fk", ur10.fk, (4, 4))


def test_parameter_jacobian_matches_rust(ur10, rust_reference):
    check_against_rust(rust_reference, "parameter_jacobian", ur10.parameter_jacobian, (6, 24))


def test_batched_fk_is_threads_independent(ur10):
    q = configurations(ur10, 40_000, seed=1)
    one = ur10.fk(q, threads=1)
    many = ur10.fk(q, threads=4)
    np.testing.assert_array_equal(one, many)
    positions, quaternions = ur10.fk(q[:100], output="pose")
    np.testing.assert_allclose(positions, one[:100, :3, 3], atol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(quaternions, axis=1), 1.0, atol=1e-12)
    # flexcal's files put the scalar first; the keyword chooses.
    _, scalar_first = ur10.fk(q[:100], output="pose", quaternion="wxyz")
    np.testing.assert_array_equal(scalar_first, quaternions[:, [3, 0, 1, 2]])
    # The rotation the quaternion stands for is the matrix's (scalar first:
    # w = cos(angle / 2), R = ... from the standard formula).
    w, x, y, z = scalar_first[0]
    r = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )
    np.testing.assert_allclose(r, one[0, :3, :3], atol=1e-12)
    with pytest.raises(flexcal.InputError, match="quaternion"):
        ur10.fk(q[:2], output="pose", quaternion="zyxw")


def rotation_vector(r):
    """Rotation vector (rad) of a rotation matrix, small angles."""
    angle = np.arccos(np.clip((np.trace(r) - 1) / 2, -1, 1))
    if angle < 1e-12:
        return np.zeros(3)
    w = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
    return w * angle / (2 * np.sin(angle))


def pose_difference(plus, minus):
    """[dp; dphi] with R_plus = exp([dphi]x) R_minus."""
    dp = plus[:3, 3] - minus[:3, 3]
    dphi = rotation_vector(plus[:3, :3] @ minus[:3, :3].T)
    return np.concatenate([dp, dphi])


def test_parameter_jacobian_against_finite_differences(ur10):
    xi = ur10.nominal
    for q in configurations(ur10, 5, seed=2):
        analytic = ur10.parameter_jacobian(q)
        h = 1e-6
        numeric = np.empty_like(analytic)
        for j in range(len(xi)):
            step = np.zeros_like(xi)
            step[j] = h
            numeric[:, j] = pose_difference(
                ur10.fk(q, xi=xi + step), ur10.fk(q, xi=xi - step)
            ) / (2 * h)
        np.testing.assert_allclose(analytic, numeric, rtol=0, atol=1e-7)


def test_joint_jacobian_against_finite_differences(ur10):
    for q in configurations(ur10, 5, seed=3):
        analytic = ur10.jacobian(q)
        assert analytic.shape == (6, 6)
        h = 1e-6
        numeric = np.empty_like(analytic)
        for k in range(6):
            step = np.zeros(6)
            step[k] = h
            numeric[:, k] = pose_difference(ur10.fk(q + step), ur10.fk(q - step)) / (2 * h)
        np.testing.assert_allclose(analytic, numeric, rtol=0, atol=1e-7)
    batch = configurations(ur10, 3, seed=3)
    assert ur10.jacobian(batch).shape == (3, 6, 6)


def test_inverse_model_returns_to_the_pose(ur10):
    q = np.array([0.3, -1.1, 1.2, -0.6, 1.4, 0.2])
    pose = ur10.fk(q)
    solution = ur10.ik(pose, seed=q + 0.05)
    np.testing.assert_allclose(ur10.fk(solution), pose, atol=1e-9)


def test_unreachable_pose_is_named(ur10):
    pose = np.eye(4)
    pose[0, 3] = 5.0  # 5 m away: the UR10 reaches 1.3 m
    with pytest.raises(flexcal.UnreachableError, match="unreachable"):
        ur10.ik(pose, seed=np.zeros(6))


def test_toml_round_trip(ur10, tmp_path):
    path = tmp_path / "ur10.toml"
    path.write_text(ur10.to_toml())
    again = flexcal.Robot.from_toml(path)
    np.testing.assert_allclose(again.nominal, ur10.nominal, atol=1e-12)
    q = configurations(ur10, 10, seed=4)
    np.testing.assert_allclose(again.fk(q), ur10.fk(q), atol=1e-12)


def test_fk_reads_non_contiguous_arrays(ur10):
    q = configurations(ur10, 50, seed=5)
    expected = ur10.fk(q)
    np.testing.assert_array_equal(ur10.fk(np.asfortranarray(q)), expected)
    np.testing.assert_array_equal(ur10.fk(q[::2]), expected[::2])
    np.testing.assert_array_equal(ur10.fk(q.T.copy().T), expected)
