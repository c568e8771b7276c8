#!/usr/bin/env python3
"""Independent forward-kinematics references for flexcal's SYMORO `.par` import.

Reads the serial `.par` files of crates/flexcal-kinematics/tests/data/symoro/
with their values files, evaluates each entry as a Python expression (Pi and
the file's symbols), and composes the Khalil-Kleinfinger transforms
Rz(gamma) Tz(b) Rx(alpha) Tx(d) Rz(theta) Tz(r) with NumPy at seeded joint
configurations, independently of flexcal's Rust code. Writes one JSON file
per robot under tests/data/symoro_reference/: the joint variables, and per
configuration the joint values (rad, m), the end frame's position (m) and
rotation matrix in R0.

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
CASES = [("rx90", "rx90.par", "rx90_values.toml"), ("stanford", "stanford.par", "stanford_values.toml")]
CONFIGURATIONS = 24
SEED = 20261124


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


def main():
    rng = np.random.default_rng(SEED)
    out_dir = os.path.join(DATA, "symoro_reference")
    os.makedirs(out_dir, exist_ok=True)
    for name, par, values in CASES:
        table = read_par(os.path.join(DATA, "symoro", par))
        symbols = tomllib.load(open(os.path.join(DATA, "symoro", values), "rb"))
        n = int(table["nf"])
        sigma = [int(s) for s in table["sigma"]]
        variables = []
        for j in range(n):
            entry = table["theta"][j] if sigma[j] == 0 else table["r"][j]
            names = [w for w in re.findall(r"[A-Za-z_]\w*", entry) if w != "Pi" and w not in symbols]
            variables.append(names[0] if names else None)
        joints = [v for v in variables if v]
        records = []
        for k in range(CONFIGURATIONS):
            q = {v: (0.0 if k == 0 else (rng.uniform(-0.5, 0.8) if sigma[variables.index(v)] == 1 else rng.uniform(-math.pi, math.pi))) for v in joints}
            env = dict(symbols, Pi=math.pi, **q)
            t = np.eye(4)
            for j in range(n):
                value = {key: float(eval(table.get(key, ["0"] * n)[j], {"__builtins__": {}}, env))
                         for key in ("gamma", "b", "alpha", "d", "theta", "r")}
                t = t @ rot("z", value["gamma"]) @ trans("z", value["b"]) @ rot("x", value["alpha"]) \
                    @ trans("x", value["d"]) @ rot("z", value["theta"]) @ trans("z", value["r"])
            records.append({"q": [q[v] for v in joints], "position_m": t[:3, 3].tolist(), "rotation": t[:3, :3].tolist()})
        with open(os.path.join(out_dir, f"{name}.json"), "w") as f:
            json.dump({"case": name, "par": par, "values": values, "joints": joints, "evaluators": ["numpy (KK transforms)"], "configurations": records}, f, indent=1)
            f.write("\n")
        print(f"{name}: {len(joints)} joints, {len(records)} configurations")


if __name__ == "__main__":
    main()
