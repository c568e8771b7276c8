#!/usr/bin/env python3
"""Independent forward-kinematics references for flexcal's URDF import.

For each case (a URDF file, a root link, a tip link) this script evaluates
the URDF at seeded joint configurations twice, independently of flexcal's
Rust code:

* with a NumPy evaluator written from the URDF specification (ROS wiki
  "urdf/XML/joint"): child = parent * origin(xyz, rpy = Rz Ry Rx) *
  motion(normalised axis, value); mimic joints take
  multiplier * leader + offset;
* with pinocchio (PyPI wheel `pin`), when it is installed: the URDF is
  loaded without mimic relations, every joint is set to its value (mimic
  followers computed as above) and the frame Jacobian's columns of the
  followers are added, times their multiplier, to their leader's.

The two must agree to 1e-12; the references written are the NumPy ones, and
each file records which evaluators produced and checked it.

Output: one JSON file per case under
crates/flexcal-kinematics/tests/data/urdf_reference/, holding the
independent joints (the robot's actuated coordinates, by URDF name), and per
configuration the joint values (rad, m), the tip position (m), rotation
matrix and the 6 x n frame Jacobian (rows [linear at the tip; angular], in
the root frame).

Usage (from the repository root; needs numpy, optionally pin):
    python3 scripts/urdf_reference.py
The public URDF files are read in place from ../shared/robots/urdf/.
"""

import json
import math
import os
import sys
import xml.etree.ElementTree as ET

import numpy as np

REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))
SHARED = os.path.abspath(os.path.join(REPO, "..", "shared", "robots", "urdf"))
DATA = os.path.join(REPO, "crates", "flexcal-kinematics", "tests", "data")
OUT = os.path.join(DATA, "urdf_reference")
CONFIGURATIONS = 24
SEED = 20261124

# (case name, location ("shared" or "repo"), file, root or None, tip or None)
CASES = [
    ("ur10", "shared", "ur10_robot.urdf", None, "tool0"),
    ("ur5", "shared", "ur5_robot.urdf", None, "tool0"),
    ("panda_hand", "shared", "panda.urdf", None, "panda_hand_tcp"),
    ("panda_right_finger", "shared", "panda.urdf", None, "panda_rightfinger"),
    ("xarm7", "shared", "xarm7.urdf", None, None),
    ("z1", "shared", "z1.urdf", None, "gripperMover"),
    ("edge_cases", "repo", "edge_cases.urdf", None, "tip"),
    ("edge_cases_branch", "repo", "edge_cases.urdf", "base_plate", "side_tip"),
    ("prismatic_first", "repo", "prismatic_first.urdf", None, None),
    ("kr16_like", "repo", "kr16_like.urdf", None, None),
    ("irb2400_like", "repo", "irb2400_like.urdf", None, None),
    ("irb6640_like", "repo", "irb6640_like.urdf", None, "tool0"),
    ("irb6640_like_rod", "repo", "irb6640_like.urdf", None, "rod_end"),
    ("continuous_mimic", "repo", "continuous_mimic.urdf", None, "tip"),
    # Calibrated-like exports written by flexcal (tests/robot_export.rs).
    ("exported_ur10", "repo", "exported_ur10.urdf", "frame_0", "tcp"),
    ("exported_puma560", "repo", "exported_puma560.urdf", "frame_0", "tcp"),
    # A UR5e from the published DH table (the shared folder holds only the UR5).
    ("ur5e", "repo", "ur5e.urdf", None, "tool0"),
]


def vec3(text, default):
    if text is None:
        return np.array(default, dtype=float)
    parts = text.split()
    assert len(parts) == 3, text
    return np.array([float(p) for p in parts])


def rpy_matrix(rpy):
    r, p, y = rpy
    rx = np.array([[1, 0, 0], [0, math.cos(r), -math.sin(r)], [0, math.sin(r), math.cos(r)]])
    ry = np.array([[math.cos(p), 0, math.sin(p)], [0, 1, 0], [-math.sin(p), 0, math.cos(p)]])
    rz = np.array([[math.cos(y), -math.sin(y), 0], [math.sin(y), math.cos(y), 0], [0, 0, 1]])
    return rz @ ry @ rx


def homogeneous(rotation, translation):
    t = np.eye(4)
    t[:3, :3] = rotation
    t[:3, 3] = translation
    return t


def axis_rotation(axis, angle):
    """Rodrigues' formula for a unit axis."""
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * (k @ k)


class Joint:
    def __init__(self, element):
        self.name = element.get("name")
        self.kind = element.get("type")
        self.parent = element.find("parent").get("link")
        self.child = element.find("child").get("link")
        origin = element.find("origin")
        xyz = vec3(origin.get("xyz") if origin is not None else None, [0, 0, 0])
        rpy = vec3(origin.get("rpy") if origin is not None else None, [0, 0, 0])
        self.origin = homogeneous(rpy_matrix(rpy), xyz)
        axis = element.find("axis")
        a = vec3(axis.get("xyz") if axis is not None else None, [1, 0, 0])
        self.axis = a / np.linalg.norm(a) if self.kind != "fixed" else a
        limit = element.find("limit")
        self.limits = None
        if limit is not None and self.kind in ("revolute", "prismatic"):
            lower = float(limit.get("lower", "0"))
            upper = float(limit.get("upper", "0"))
            if lower < upper:
                self.limits = (lower, upper)
        mimic = element.find("mimic")
        self.mimic = None
        if mimic is not None:
            self.mimic = (
                mimic.get("joint"),
                float(mimic.get("multiplier", "1")),
                float(mimic.get("offset", "0")),
            )

    def motion(self, value):
        if self.kind in ("revolute", "continuous"):
            return homogeneous(axis_rotation(self.axis, value), np.zeros(3))
        if self.kind == "prismatic":
            return homogeneous(np.eye(3), self.axis * value)
        return np.eye(4)


class Urdf:
    def __init__(self, path):
        root = ET.parse(path).getroot()
        self.joints = {}
        for element in root.findall("joint"):
            j = Joint(element)
            self.joints[j.name] = j
        self.parent_joint = {j.child: j for j in self.joints.values()}
        links = [l.get("name") for l in root.findall("link")]
        self.root = [l for l in links if l not in self.parent_joint][0]
        children = {j.parent for j in self.joints.values()}
        self.leaves = [l for l in links if l not in children]

    def path(self, root, tip):
        joints = []
        link = tip
        while link != root:
            j = self.parent_joint[link]
            joints.append(j)
            link = j.parent
        return list(reversed(joints))

    def leader(self, joint):
        """First non-mimic leader of a joint: (name, multiplier, offset)."""
        multiplier, offset, j = 1.0, 0.0, joint
        while j.mimic is not None:
            name, m, o = j.mimic
            offset += multiplier * o
            multiplier *= m
            j = self.joints[name]
        return j.name, multiplier, offset

    def independent(self, path):
        names = []
        for j in path:
            if j.kind == "fixed":
                continue
            leader = self.leader(j)[0]
            if leader not in names:
                names.append(leader)
        return names

    def value(self, joint, q):
        leader, multiplier, offset = self.leader(joint)
        return multiplier * q[leader] + offset

    def above_root(self, root):
        """Pose of `root` in the tree root's frame at zero (fixed joints only matter)."""
        t = np.eye(4)
        for j in self.path(self.root, root):
            t = t @ j.origin @ j.motion(0.0)
        return t

    def evaluate(self, root, tip, q):
        path = self.path(root, tip)
        t = np.eye(4)
        columns = {name: np.zeros(6) for name in self.independent(path)}
        axes = []
        for j in path:
            t = t @ j.origin
            if j.kind != "fixed":
                axes.append((j, t[:3, :3] @ j.axis, t[:3, 3].copy()))
            t = t @ j.motion(self.value(j, q) if j.kind != "fixed" else 0.0)
        tip_position = t[:3, 3]
        for j, w, p in axes:
            leader, multiplier, _ = self.leader(j)
            if j.kind == "prismatic":
                column = np.concatenate([w, np.zeros(3)])
            else:
                column = np.concatenate([np.cross(w, tip_position - p), w])
            columns[leader] += multiplier * column
        return t, columns


def sample(urdf, names, rng, k):
    q = {}
    for name in names:
        j = urdf.joints[name]
        if k == 0:
            q[name] = 0.0
        elif j.kind == "continuous":
            q[name] = rng.uniform(-2 * math.pi, 2 * math.pi)
        elif j.limits is not None:
            q[name] = rng.uniform(*j.limits)
        elif j.kind == "prismatic":
            q[name] = rng.uniform(-0.5, 0.5)
        else:
            q[name] = rng.uniform(-math.pi, math.pi)
    return q


def pinocchio_check(path, urdf, root, tip, configurations):
    """Largest difference between pinocchio and the NumPy evaluator."""
    try:
        import pinocchio as pin
    except ImportError:
        return None
    model = pin.buildModelFromUrdf(path)
    data = model.createData()
    frame = model.getFrameId(tip, pin.FrameType.BODY)
    worst = 0.0
    for q_named, t_ref, columns in configurations:
        q = pin.neutral(model)
        for i in range(1, model.njoints):
            name = model.names[i]
            leader, multiplier, offset = urdf.leader(urdf.joints[name])
            value = multiplier * q_named[leader] + offset if leader in q_named else 0.0
            idx = model.joints[i].idx_q
            if model.joints[i].nq == 2:
                q[idx] = math.cos(value)
                q[idx + 1] = math.sin(value)
            else:
                q[idx] = value
        pin.forwardKinematics(model, data, q)
        pin.updateFramePlacements(model, data)
        placement = data.oMf[frame]
        worst = max(worst, np.abs(placement.translation - t_ref[:3, 3]).max())
        worst = max(worst, np.abs(placement.rotation - t_ref[:3, :3]).max())
        jacobian = pin.computeFrameJacobian(model, data, q, frame, pin.LOCAL_WORLD_ALIGNED)
        combined = {name: np.zeros(6) for name in columns}
        for i in range(1, model.njoints):
            name = model.names[i]
            j = urdf.joints[name]
            leader, multiplier, _ = urdf.leader(j)
            if leader in combined:
                combined[leader] += multiplier * jacobian[:, model.joints[i].idx_v]
        for name in columns:
            worst = max(worst, np.abs(combined[name] - columns[name]).max())
    return worst, pin.__version__


def main():
    os.makedirs(OUT, exist_ok=True)
    rng = np.random.default_rng(SEED)
    for name, location, file, root, tip in CASES:
        base = SHARED if location == "shared" else os.path.join(DATA, "urdf")
        path = os.path.join(base, file)
        if not os.path.exists(path):
            print(f"{name}: {path} absent, skipped", file=sys.stderr)
            continue
        urdf = Urdf(path)
        root_link = root or urdf.root
        if tip is None:
            below = [l for l in urdf.leaves if l != root_link]
            assert len(below) == 1, (name, below)
            tip = below[0]
        path_joints = urdf.path(root_link, tip)
        names = urdf.independent(path_joints)
        x_tree_root = urdf.above_root(root_link)
        configurations = []
        records = []
        for k in range(CONFIGURATIONS):
            q = sample(urdf, names, rng, k)
            t, columns = urdf.evaluate(root_link, tip, q)
            configurations.append((q, x_tree_root @ t, {
                n: np.concatenate([x_tree_root[:3, :3] @ c[:3], x_tree_root[:3, :3] @ c[3:]])
                for n, c in columns.items()
            }))
            records.append({
                "q": [q[n] for n in names],
                "position_m": t[:3, 3].tolist(),
                "rotation": t[:3, :3].tolist(),
                "jacobian": np.column_stack([columns[n] for n in names]).tolist(),
            })
        evaluators = ["numpy (URDF specification)"]
        check = pinocchio_check(path, urdf, root_link, tip, configurations)
        if check is not None:
            worst, version = check
            assert worst < 1e-12, f"{name}: pinocchio and numpy differ by {worst:.3e}"
            evaluators.append(f"pinocchio {version} (agrees to {worst:.1e})")
        document = {
            "case": name,
            "location": location,
            "file": file,
            "root": root_link,
            "tip": tip,
            "joints": names,
            "evaluators": evaluators,
            "configurations": records,
        }
        with open(os.path.join(OUT, f"{name}.json"), "w") as out:
            json.dump(document, out, indent=1)
            out.write("\n")
        print(f"{name}: {len(names)} joints, {len(records)} configurations, {'; '.join(evaluators)}")


if __name__ == "__main__":
    main()
