"""Shared fixtures of the flexcal Python suite.

The suite runs from `cargo test -p flexcal-py` (tests/pytest.rs builds the
package into a virtual environment and runs pytest), or by hand after
`pip install ./crates/flexcal-py`. Rust reference values come from the file
named by FLEXCAL_RUST_REFERENCE, which tests/pytest.rs writes; tests that
need it are skipped, with the reason, without it.
"""

import json
import os
import pathlib

import numpy as np
import pytest

import flexcal

REPOSITORY = pathlib.Path(__file__).resolve().parents[4]
IPA = REPOSITORY.parent / "shared" / "datasets" / "ipa-ur10"


@pytest.fixture(scope="session")
def ur10():
    return flexcal.Robot.builtin("ur10")


@pytest.fixture(scope="session")
def rust_reference():
    path = os.environ.get("FLEXCAL_RUST_REFERENCE")
    if not path or not pathlib.Path(path).exists():
        pytest.skip(
            "no Rust reference values: FLEXCAL_RUST_REFERENCE is unset "
            "(run through `cargo test -p flexcal-py --test pytest`)"
        )
    return json.loads(pathlib.Path(path).read_text())


def ipa_series(name, file):
    path = IPA / name / file
    if not path.exists():
        pytest.skip(f"IPA UR10 data absent ({path})")
    return path


def configurations(robot, n, seed):
    """n configurations drawn uniformly within the joint limits (rad, m)."""
    rng = np.random.default_rng(seed)
    limits = robot.joint_limits
    # The UR10's limits are +-2 pi: stay within one turn for readable values.
    low = np.maximum(limits[:, 0], -np.pi)
    high = np.minimum(limits[:, 1], np.pi)
    return rng.uniform(low, high, size=(n, robot.dof))
