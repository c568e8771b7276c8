"""Robots from URDF files: the imported model against the independent
references that `scripts/urdf_reference.py` wrote for the Rust test suite
(NumPy from the URDF specification, checked against pinocchio)."""

import json
import pathlib

import numpy as np
import pytest

import flexcal

KINEMATICS_DATA = pathlib.Path(__file__).resolve().parents[3] / "flexcal-kinematics" / "tests" / "data"


@pytest.mark.parametrize("case", ["kr16_like", "irb2400_like", "prismatic_first"])
def test_urdf_robot_matches_the_independent_reference(case):
    reference = json.loads((KINEMATICS_DATA / "urdf_reference" / f"{case}.json").read_text())
    robot = flexcal.Robot.from_urdf(
        KINEMATICS_DATA / "urdf" / reference["file"], tip=reference["tip"], root=reference["root"]
    )
    # The reference orders q as the URDF's joints; the robot by its own actuated names.
    order = [reference["joints"].index(name) for name in robot.joint_names]
    q = np.array([[c["q"][i] for i in order] for c in reference["configurations"]])
    poses = robot.fk(q)
    positions = np.array([c["position_m"] for c in reference["configurations"]])
    rotations = np.array([c["rotation"] for c in reference["configurations"]])
    np.testing.assert_allclose(poses[:, :3, 3], positions, rtol=0, atol=1e-9)
    np.testing.assert_allclose(poses[:, :3, :3], rotations, rtol=0, atol=1e-9)


def test_urdf_errors_are_named(tmp_path):
    bad = tmp_path / "bad.urdf"
    bad.write_text('<robot name="r">\n  <link name="a"/>\n  <joint name="j" type="revolute">\n</robot>\n')
    with pytest.raises(flexcal.FlexcalError, match="bad.urdf"):
        flexcal.Robot.from_urdf(bad)
    with pytest.raises(flexcal.FlexcalError, match="tip"):
        flexcal.Robot.from_urdf(KINEMATICS_DATA / "urdf" / "kr16_like.urdf", tip="no_such_link")
