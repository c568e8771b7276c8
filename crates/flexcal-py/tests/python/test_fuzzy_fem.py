"""Fuzzy models and frame structures from Python."""

import pathlib

import numpy as np
import pytest

import flexcal

FEM_EXAMPLES = pathlib.Path(__file__).resolve().parents[3] / "flexcal-fem" / "examples"


def test_fuzzy_model_fits_a_smooth_function():
    rng = np.random.default_rng(5)
    x = rng.uniform(-1, 1, size=(400, 2))
    y = np.sin(2 * x[:, 0]) + 0.5 * x[:, 1] ** 2
    model = flexcal.FuzzyModel.fit(x, y, input_names=["a", "b"], seed=3)
    assert model.input_names == ["a", "b"]
    assert model.n_rules == len(model.conclusions) >= 4
    fresh = rng.uniform(-0.9, 0.9, size=(200, 2))
    truth = np.sin(2 * fresh[:, 0]) + 0.5 * fresh[:, 1] ** 2
    predicted = model.predict(fresh)
    assert predicted.shape == (200,)
    rmse = np.sqrt(np.mean((predicted - truth) ** 2))
    # A constant predictor leaves the spread of y; the model far less.
    assert rmse < 0.2 * np.std(truth)
    assert float(model.predict(fresh[0])) == pytest.approx(predicted[0])
    assert "[System]" in model.to_fis("demo")


def test_fuzzy_bad_input():
    with pytest.raises(flexcal.ShapeError):
        flexcal.FuzzyModel.fit(np.zeros((10, 2)), np.zeros(9))
    x = np.zeros((10, 2))
    x[3, 0] = np.nan
    with pytest.raises(flexcal.NotFiniteError, match=r"x\[3, 0\]"):
        flexcal.FuzzyModel.fit(x, np.zeros(10))


def test_structure_condensation_reproduces_the_solution():
    path = FEM_EXAMPLES / "cantilever.toml"
    if not path.exists():
        pytest.skip(f"example structure absent ({path})")
    structure = flexcal.Structure.from_file(path)
    assert structure.node_names[-1] == "tip" or "tip" in structure.node_names
    solution = structure.solve()
    condensed = structure.condense("tip")
    tip = structure.node_names.index("tip")
    k_eq, c_eq = condensed["k_eq"], condensed["c_eq"]
    np.testing.assert_allclose(k_eq, k_eq.T, rtol=1e-9, atol=1e-6 * np.abs(k_eq).max())
    np.testing.assert_allclose(k_eq @ c_eq, np.eye(6), atol=1e-8)
    for case in structure.load_cases:
        # The condensed model at the tip gives the full model's tip displacement.
        u_tip = c_eq @ condensed["f_eq"][case]
        np.testing.assert_allclose(u_tip, solution[case][tip], rtol=1e-8, atol=1e-12)
    with pytest.raises(flexcal.StructureError, match="nowhere"):
        structure.condense("nowhere")
