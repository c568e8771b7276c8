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


def urdf_link_pose(text_path, link, q_by_joint):
    """Pose of `link` in the root frame from the URDF alone: the product of
    each joint's origin (xyz, rpy) and motion, root first (NumPy)."""
    import xml.etree.ElementTree as ET

    root = ET.parse(text_path).getroot()
    joints = {j.find("child").get("link"): j for j in root.findall("joint")}

    def rpy(r, p, y):
        cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
        rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
        ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
        rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
        return rz @ ry @ rx

    chain = []
    while link in joints:
        chain.append(joints[link])
        link = joints[link].find("parent").get("link")
    x = np.eye(4)
    for j in reversed(chain):
        origin = j.find("origin")
        t = np.eye(4)
        if origin is not None:
            t[:3, 3] = [float(v) for v in origin.get("xyz", "0 0 0").split()]
            t[:3, :3] = rpy(*[float(v) for v in origin.get("rpy", "0 0 0").split()])
        motion = np.eye(4)
        if j.get("type") in ("revolute", "continuous"):
            axis = j.find("axis")
            a = np.array([float(v) for v in (axis.get("xyz") if axis is not None else "1 0 0").split()])
            a = a / np.linalg.norm(a)
            angle = q_by_joint[j.get("name")]
            k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
            motion[:3, :3] = np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k
        x = x @ t @ motion
    return x


def test_a_urdf_loads_with_its_tip_and_gives_its_links_by_name():
    path = KINEMATICS_DATA / "urdf" / "ur5e.urdf"
    robot = flexcal.Robot.load(str(path), tip="tool0")
    assert "wrist_2_link" in robot.frame_names and robot.frame_names[0] == "0"
    q = np.array([0.1, -1.2, 0.9, -0.4, 1.3, 0.5])
    wrist = robot.fk(q, frame="wrist_2_link")
    expected = urdf_link_pose(path, "wrist_2_link", dict(zip(robot.joint_names, q)))
    np.testing.assert_allclose(wrist, expected, rtol=0, atol=1e-12)
    # The same robot from its text, and the tip chosen elsewhere.
    again = flexcal.Robot.from_urdf_string(path.read_text(), tip="tool0")
    np.testing.assert_allclose(again.fk(q), robot.fk(q), rtol=0, atol=0)
    short = flexcal.Robot.load(str(path), tip="wrist_2_link")
    np.testing.assert_allclose(short.fk(q[:5]), wrist, rtol=0, atol=1e-12)
    with pytest.raises(flexcal.InputError, match="has no frame `wrist_9`"):
        robot.fk(q, frame="wrist_9")


def test_malformed_urdf_text_and_unknown_tips_are_named_errors():
    with pytest.raises(flexcal.FileError, match="<string>:3"):
        flexcal.Robot.from_urdf_string('<robot name="r">\n<link name="a"/>\n<joint name="j" type="revolute"/>\n</robot>')
    with pytest.raises(flexcal.KinematicsError, match="has no frame `tool0`"):
        flexcal.Robot.load("ur10", tip="tool0")
    with pytest.raises(flexcal.KinematicsError, match="only be chosen in a URDF"):
        flexcal.Robot.load("ur10", root="base")
    robot = flexcal.Robot.load("ur10", tip="5")
    ur10 = flexcal.Robot.builtin("ur10")
    q = np.array([0.1, -1.2, 0.9, -0.4, 1.3, 0.5])
    np.testing.assert_allclose(robot.fk(q), ur10.fk(q, frame="5"), rtol=0, atol=1e-15)
