"""Bad input raises a named exception with a one-line message, never a crash."""

import numpy as np
import pytest

import flexcal


def test_unknown_robot(ur10):
    with pytest.raises(flexcal.UnknownRobotError, match="unknown built-in robot `ur11`"):
        flexcal.Robot.builtin("ur11")
    assert issubclass(flexcal.UnknownRobotError, flexcal.FlexcalError)
    with pytest.raises(flexcal.UnknownRobotError, match="unknown robot 'ur11'"):
        flexcal.Robot.load("ur11")
    assert flexcal.Robot.load("ur10").name == ur10.name


@pytest.mark.parametrize(
    "q",
    [np.zeros(5), np.zeros((3, 7)), np.zeros((2, 3, 6)), np.zeros(0)],
)
def test_wrong_shapes(ur10, q):
    with pytest.raises(flexcal.ShapeError, match=r"q: expected shape \(6,\) or \(n, 6\)"):
        ur10.fk(q)
    with pytest.raises(flexcal.ShapeError):
        ur10.parameter_jacobian(q)


def test_nan_is_named_with_its_index(ur10):
    q = np.zeros((4, 6))
    q[2, 3] = np.nan
    with pytest.raises(flexcal.NotFiniteError, match=r"q\[2, 3\] is NaN"):
        ur10.fk(q)
    with pytest.raises(flexcal.NotFiniteError, match=r"xi\[0\]"):
        xi = ur10.nominal.copy()
        xi[0] = np.inf
        ur10.fk(np.zeros(6), xi=xi)


def test_bad_measurement_arrays():
    q = np.zeros((10, 6))
    with pytest.raises(flexcal.ShapeError, match=r"positions: expected shape \(10, 3\)"):
        flexcal.MeasurementSet.from_arrays(q, np.zeros((9, 3)))
    positions = np.zeros((10, 3))
    positions[4, 1] = np.nan
    with pytest.raises(flexcal.NotFiniteError, match=r"positions\[4, 1\]"):
        flexcal.MeasurementSet.from_arrays(q, positions)
    with pytest.raises(flexcal.MeasurementError, match="standard deviations"):
        flexcal.MeasurementSet.from_arrays(q, np.zeros((10, 3)), std=np.zeros((10, 3)))


def test_unknown_parameter_name(ur10):
    rng = np.random.default_rng(0)
    q = rng.uniform(-1, 1, size=(30, 6))
    data = flexcal.MeasurementSet.from_arrays(q, ur10.fk(q)[:, :3, 3])
    with pytest.raises(flexcal.UnknownParameterError, match="unknown parameter `d33`"):
        flexcal.calibrate(ur10, data, fix=["d33"])


def test_robot_and_data_disagree():
    puma = flexcal.Robot.builtin("puma560")
    data = flexcal.MeasurementSet.from_arrays(np.zeros((30, 5)), np.zeros((30, 3)))
    with pytest.raises(flexcal.MeasurementError):
        flexcal.calibrate(puma, data)


def test_bad_options(ur10):
    data = flexcal.MeasurementSet.from_arrays(np.zeros((30, 6)), np.zeros((30, 3)))
    with pytest.raises(flexcal.InputError, match="model: expected"):
        flexcal.calibrate(ur10, data, model="elastic")
    with pytest.raises(flexcal.InputError, match="output: expected"):
        ur10.fk(np.zeros(6), output="euler")
    with pytest.raises(flexcal.InputError, match="format: expected"):
        flexcal.MeasurementSet.read_csv("x.csv", format="excel")
    with pytest.raises(flexcal.InputError, match="not a rigid transform"):
        ur10.ik(np.ones((4, 4)), seed=np.zeros(6))


def test_missing_files(tmp_path):
    with pytest.raises(flexcal.FileError):
        flexcal.Robot.from_toml(tmp_path / "absent.toml")
    with pytest.raises(flexcal.FileError):
        flexcal.MeasurementSet.read_csv(tmp_path / "absent.csv")
    with pytest.raises(flexcal.StructureError):
        flexcal.Structure.from_file(tmp_path / "absent.toml")


@pytest.mark.parametrize(
    "bad, holds",
    [
        (np.array([["0.1"] * 6]), "strings"),
        ([["a", "b", "c", "d", "e", "f"]], "strings"),
        (np.array([b"1"] * 6), "strings"),
        (np.zeros(6) + 0.5j, "complex numbers"),
        ([0.1, 0.2, 0.3, 0.4, 0.5, 1j], "complex numbers"),
    ],
)
def test_strings_and_complex_arrays_are_refused_by_name(ur10, bad, holds):
    with pytest.raises(flexcal.ArrayTypeError) as error:
        ur10.fk(bad)
    assert isinstance(error.value, flexcal.InputError)
    assert isinstance(error.value, TypeError)
    message = str(error.value)
    assert f"an array of {holds}" in message and "real numbers are expected" in message, message
    # The argument's name, in the note tracebacks show (Python 3.11+).
    if hasattr(error.value, "__notes__"):
        assert any("'q'" in note for note in error.value.__notes__), error.value.__notes__


def test_the_array_check_names_each_argument(ur10):
    q = np.zeros(6)
    with pytest.raises(flexcal.ArrayTypeError) as error:
        ur10.fk(q, xi=ur10.nominal.astype(complex))
    if hasattr(error.value, "__notes__"):
        assert any("'xi'" in note for note in error.value.__notes__), error.value.__notes__
    # Real arrays of any real dtype, lists and scalars still convert.
    np.testing.assert_allclose(ur10.fk([0, 0, 0, 0, 0, 0]), ur10.fk(np.zeros(6, dtype=np.float32)))
    np.testing.assert_allclose(ur10.fk(np.zeros(6, dtype=int)), ur10.fk(q))
