#!/usr/bin/env python3
"""Independent forward-kinematics references for flexcal's SYMORO `.par` import.

Reads the `.par` files of crates/flexcal-kinematics/tests/data/symoro/ with
their values files, evaluates each entry as a Python expression (Pi and the
file's symbols), and composes the Khalil-Kleinfinger transforms
Rz(gamma) Tz(b) Rx(alpha) Tx(d) Rz(theta) Tz(r) from each frame's antecedent
with NumPy at seeded joint configurations, independently of flexcal's Rust
code.

- Serial chains and trees: every joint is actuated; the references give the
  pose of every leaf (a link frame that carries no other frame), and for a
  single leaf also at the top level as the end frame.
- Closed loops (NJ > NL): loop i joins the cut joint frame NL+i and the frame
  NJ+i, whose poses must coincide. The passive joints (Mu = 0) are solved for
  all loops at once by Gauss-Newton on the 12 pose-difference components of
  each loop (position and rotation matrix entries), with a central-difference
  Jacobian, starting from the values file's [home] configuration; the
  actuated joints are drawn around their home values so that the solution
  stays on the home branch. The references give the passive values too.

Writes one JSON file per robot under tests/data/symoro_reference/.

Usage (from the repository root; needs numpy): python3 scripts/par_reference.py
"""

import json
import math
import os
import re
import tomllib

import numpy as np

REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))
DATA = os.path.join(REPO, "crates", "flexcal-kinematics", "tests", "data")
CASES = [
    ("rx90", "rx90.par", "rx90_values.toml"),
    ("stanford", "stanford.par", "stanford_values.toml"),
    ("sr400", "sr400.par", "sr400_values.toml"),
    ("palletizer", "palletizer.par", "palletizer_values.toml"),
    ("eloise", "eloise.par", "eloise_values.toml"),
]
CONFIGURATIONS = 24
SEED = 20261124
# Half-width (rad, m) of the draw of actuated joints around home for closed loops.
LOOP_SPREAD = 0.4


def read_par(path):
    text = re.sub(r"\(\*.*?\*\)", "", open(path).read(), flags=re.S)
    table = {}
    for key, value in re.findall(r"(\w+)\s*=\s*(\{[^}]*\}|[^\n]+)", text):
        value = value.strip()
        if value.startswith("{"):
            table[key.lower()] = [v.strip() for v in value[1:-1].split(",")]
        else:
            table[key.lower()] = value
    return table


def rot(axis, a):
    c, s = math.cos(a), math.sin(a)
    m = np.eye(4)
    if axis == "x":
        m[1:3, 1:3] = [[c, -s], [s, c]]
    else:
        m[0:2, 0:2] = [[c, -s], [s, c]]
    return m


def trans(axis, v):
    m = np.eye(4)
    m["xyz".index(axis), 3] = v
    return m


class Robot:
    def __init__(self, par, values):
        self.table = read_par(os.path.join(DATA, "symoro", par))
        values = tomllib.load(open(os.path.join(DATA, "symoro", values), "rb"))
        self.home = values.pop("home", {})
        self.symbols = values
        t = self.table
        self.nl, self.nj, self.nf = int(t["nl"]), int(t["nj"]), int(t["nf"])
        self.ant = [int(a) for a in t["ant"]]
        self.sigma = [int(s) for s in t["sigma"]]
        self.mu = [int(m) for m in t.get("mu", ["1"] * self.nf)]
        self.variables = []
        for j in range(self.nf):
            entry = t["theta"][j] if self.sigma[j] == 0 else t["r"][j] if self.sigma[j] == 1 else "0"
            names = [w for w in re.findall(r"[A-Za-z_]\w*", entry) if w != "Pi" and w not in self.symbols]
            self.variables.append(names[0] if names else None)
        self.actuated = [v for j, v in enumerate(self.variables) if v and self.mu[j] == 1]
        self.passive = [v for j, v in enumerate(self.variables) if v and self.mu[j] == 0]
        # Leaves: link frames that carry no other frame (links holding a cut joint are no leaves).
        self.leaves = [k for k in range(1, self.nl + 1) if k not in self.ant]

    def frames(self, q):
        """Pose (4x4) of every frame 0..NF in R0 for the joint values q (dict)."""
        env = dict(self.symbols, Pi=math.pi, **q)
        poses = [np.eye(4)] + [None] * self.nf
        for j in range(self.nf):
            value = {key: float(eval(self.table.get(key, ["0"] * self.nf)[j], {"__builtins__": {}}, env))
                     for key in ("gamma", "b", "alpha", "d", "theta", "r")}
            local = rot("z", value["gamma"]) @ trans("z", value["b"]) @ rot("x", value["alpha"]) \
                @ trans("x", value["d"]) @ rot("z", value["theta"]) @ trans("z", value["r"])
            poses[j + 1] = poses[self.ant[j]] @ local
        return poses

    def closure(self, q):
        poses = self.frames(q)
        e = []
        for i in range(1, self.nj - self.nl + 1):
            a, b = poses[self.nl + i], poses[self.nj + i]
            e.extend((a[:3, :] - b[:3, :]).ravel())
        return np.array(e)

    def assemble(self, actuated):
        """Passive joint values closing every loop, by Gauss-Newton from home."""
        x = np.array([self.home[v] for v in self.passive], dtype=float)
        q = dict(actuated)
        h = 1e-6
        for _ in range(100):
            q.update(zip(self.passive, x))
            e = self.closure(q)
            jac = np.empty((len(e), len(x)))
            for c, v in enumerate(self.passive):
                plus, minus = dict(q), dict(q)
                plus[v] += h
                minus[v] -= h
                jac[:, c] = (self.closure(plus) - self.closure(minus)) / (2 * h)
            step = np.linalg.lstsq(jac, -e, rcond=None)[0]
            x += step
            if np.abs(step).max() < 1e-15:
                break
        q.update(zip(self.passive, x))
        residual = np.abs(self.closure(q)).max()
        assert residual < 1e-13, f"loops do not close: {residual:.2e}"
        return q


def pose_record(t):
    return {"position_m": t[:3, 3].tolist(), "rotation": t[:3, :3].tolist()}


def main():
    rng = np.random.default_rng(SEED)
    out_dir = os.path.join(DATA, "symoro_reference")
    os.makedirs(out_dir, exist_ok=True)
    for name, par, values in CASES:
        robot = Robot(par, values)
        joints = robot.actuated
        loops = robot.nj > robot.nl
        records = []
        for k in range(CONFIGURATIONS):
            if loops:
                q = {v: robot.home[v] + (0.0 if k == 0 else rng.uniform(-LOOP_SPREAD, LOOP_SPREAD)) for v in joints}
                q = robot.assemble(q)
            else:
                q = {v: (0.0 if k == 0 else (rng.uniform(-0.5, 0.8) if robot.sigma[robot.variables.index(v)] == 1 else rng.uniform(-math.pi, math.pi))) for v in joints}
            poses = robot.frames(q)
            record = {"q": [q[v] for v in joints]}
            if len(robot.leaves) == 1:
                record.update(pose_record(poses[robot.leaves[0]]))
            if len(robot.leaves) > 1 or loops:
                record["leaves"] = {str(leaf): pose_record(poses[leaf]) for leaf in robot.leaves}
            if loops:
                record["passive"] = {v: q[v] for v in robot.passive}
            records.append(record)
        reference = {"case": name, "par": par, "values": values, "joints": joints}
        if len(robot.leaves) > 1 or loops:
            reference["leaves"] = [str(leaf) for leaf in robot.leaves]
        if loops:
            reference["passive"] = {v: str(robot.variables.index(v) + 1) for v in robot.passive}
        reference["evaluators"] = ["numpy (KK transforms)" + (", Gauss-Newton loop closure from home" if loops else "")]
        reference["configurations"] = records
        with open(os.path.join(out_dir, f"{name}.json"), "w") as f:
            json.dump(reference, f, indent=1)
            f.write("\n")
        print(f"{name}: {len(joints)} actuated joints, {len(robot.passive)} passive, leaves {robot.leaves}, {len(records)} configurations")


if __name__ == "__main__":
    main()
