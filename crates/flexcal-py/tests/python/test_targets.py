"""Several targets per pose from Python: a two-armed tree robot (a torso
joint carrying two four-joint arms) with a marker on each hand, simulated
with a known truth through `Robot.fk(..., frame=...)`, calibrated by
`flexcal.calibrate` (which takes either kind of set), validated, written
and read back."""

import json

import numpy as np
import pytest
from conftest import REPOSITORY, configurations

import flexcal

DATA = REPOSITORY / "crates" / "flexcal-calib" / "tests" / "data"
# Error terms of the simulated robot and instrument, as in the Rust
# multi-target tests (tests/multi_target.rs): geometric errors of 0.3 mm and
# 0.03 deg (standard deviations here), markers within 1 mm of their nominal
# offsets, 20 um of noise per axis (a laser tracker at a few metres).
LENGTH_ERROR = 0.3e-3
ANGLE_ERROR = np.radians(0.03)
NOISE = 20e-6
OFFSET = np.array([0.030, 0.0, 0.040])
TARGETS = [("left", "LH", OFFSET), ("right", "RH", OFFSET)]


def target_set(targets, q, positions, **kwargs):
    """A MeasurementSet of several targets from arrays."""
    return flexcal.MeasurementSet.from_arrays(q, positions, targets=targets, **kwargs)


@pytest.fixture(scope="module")
def two_arms():
    return flexcal.Robot.from_toml(DATA / "two_arms.toml")


def rotation(axis, angle):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


class Truth:
    def __init__(self, robot, seed):
        self.rng = np.random.default_rng(seed)
        sigma = np.array(
            [LENGTH_ERROR if p.unit == "m" else ANGLE_ERROR for p in robot.parameters]
        )
        self.xi = robot.nominal + self.rng.normal(0.0, sigma)
        self.offsets = [OFFSET + self.rng.uniform(-1e-3, 1e-3, 3) for _ in TARGETS]
        self.frame_rotation = rotation([0.1, -0.2, 1.0], 2.4)
        self.frame_translation = np.array([2.5, -0.4, -0.9])

    def measure(self, robot, q, occlude=0.1):
        """Positions (n, 2, 3) in the tracker's frame; each marker hidden
        on about `occlude` of the poses (never both)."""
        n = len(q)
        positions = np.empty((n, len(TARGETS), 3))
        for t, (_, frame, _) in enumerate(TARGETS):
            hand = robot.fk(q, xi=self.xi, frame=frame)
            point = hand[:, :3, :3] @ self.offsets[t] + hand[:, :3, 3]
            positions[:, t] = point @ self.frame_rotation.T + self.frame_translation
        positions += self.rng.normal(0.0, NOISE, positions.shape)
        hidden = self.rng.random(n) < occlude
        which = self.rng.integers(0, len(TARGETS), n)
        positions[hidden, which[hidden]] = np.nan
        return positions


def test_fk_of_a_named_frame(two_arms):
    q = configurations(two_arms, 5, seed=1)
    end = two_arms.fk(q, frame="LH")
    # LH is the end frame and the robot has no tool: its pose is the TCP's.
    np.testing.assert_allclose(end, two_arms.fk(q), atol=1e-12)
    right = two_arms.fk(q, frame="RH", output="pose")
    np.testing.assert_allclose(right[0], two_arms.fk(q, frame="RH")[:, :3, 3], atol=1e-12)
    with pytest.raises(flexcal.InputError, match="no frame `XX`"):
        two_arms.fk(q, frame="XX")


def test_markers_on_both_hands_recover_the_truth(two_arms, tmp_path):
    truth = Truth(two_arms, seed=11)
    q = configurations(two_arms, 120, seed=12)
    positions = truth.measure(two_arms, q)
    data = target_set(TARGETS, q, positions, source="two arms")
    assert len(data) == 120 and data.target_names == ["left", "right"]
    assert data.n_observations == int(np.sum(~np.isnan(positions[:, :, 0])))
    result = flexcal.calibrate(two_arms, data, select="none", split_check=True)
    assert result.model == "geometric" and result.selection is None
    # Independent noise and the truth's model: the halves differ as the
    # covariance says (two splits of some sixty unknowns: within 0.5 - 2).
    assert 0.5 < result.split_check.prediction_ratio < 2.0, result.split_check.notes
    # At the noise: three axes of 20 um give a mean error norm of 32 um.
    assert result.after.position_mean < 1.3 * 1.6 * NOISE, result.after
    assert result.before.position_mean > 5 * result.after.position_mean
    assert set(result.per_target_after) == {"left", "right"}
    # Every identified robot parameter within 4 standard errors of what it
    # stands for (its truth plus the absorbed parameters' errors).
    names = two_arms.parameter_names
    delta = dict(zip(names, truth.xi - two_arms.nominal))
    terms = result.combination_terms
    checked = 0
    for u in result.parameters:
        if u.status == "identified" and u.name in names:
            stands_for = truth.xi[names.index(u.name)] + sum(
                k * delta.get(other, 0.0) for other, k in terms.get(u.name, [])
            )
            assert abs(u.identified - stands_for) < 4 * u.standard_error, u
            checked += 1
    assert checked > 20
    # What two markers cannot see is named.
    assert any("exactly dependent on others" in note and "(in " in note for note in result.notes), result.notes
    # The markers' offsets: within 4 standard errors of the truth where
    # identified.
    offsets = result.target_offsets
    sigma = result.standard_errors
    for t, (name, _, _) in enumerate(TARGETS):
        for a, axis in enumerate("xyz"):
            key = f"target.{name}.{axis}"
            if key in sigma and not terms.get(key):
                assert abs(offsets[name][a] - truth.offsets[t][a]) < 4 * sigma[key], key

    # Validation on other poses, the tracker's frame fitted again.
    q_other = configurations(two_arms, 40, seed=13)
    other = target_set(
        TARGETS, q_other, truth.measure(two_arms, q_other)
    )
    validation = result.validate(other)
    assert validation.frame_refitted
    labels, errors = validation.observation_errors
    assert len(labels) == other.n_observations and errors.shape == (other.n_observations, 3)
    assert labels[0][1] in ("left", "right")
    np.testing.assert_allclose(
        np.linalg.norm(errors, axis=1).max(), validation.after.position_max, rtol=1e-12
    )
    assert result.observation_errors[1].shape == (data.n_observations, 3)
    assert validation.after.position_mean < 1.3 * 1.6 * NOISE, validation.after
    assert validation.before.position_mean > 5 * validation.after.position_mean
    # Predicted 95 % bounds: the truth's model and Gaussian noise, so the
    # validation errors lie within them about 95 % of the time (72-odd
    # observations: a binomial spread of 2.6 %).
    accuracy = result.accuracy_coverage(other)
    assert accuracy.inflation == max(1.0, result.split_check.prediction_ratio)
    assert accuracy.targets == [name for _, name in labels]
    np.testing.assert_allclose(accuracy.actual_error, np.linalg.norm(errors, axis=1), rtol=1e-12)
    assert 0.85 <= accuracy.coverage <= 1.0, accuracy
    # The same robot measured again: no identified value differs beyond
    # 3 combined errors (each raised to its split error), but perhaps one
    # by chance among some sixty.
    cross = result.cross_check(other)
    assert len(cross.disagreeing) <= 1, cross.notes
    assert cross.z_split and set(cross.z_split) <= set(cross.z)
    # At configurations: one entry per configuration and marker.
    grid = result.predicted_accuracy(q_other[:4])
    assert grid.targets == ["left", "right"] * 4
    assert np.all(np.isnan(grid.actual_error))
    assert np.all(grid.bound_95 >= np.sqrt(7.8147) * grid.residual_scatter * (1 - 1e-12))
    assert grid.to_csv().startswith("pose,target,q1,")
    report = json.loads(result.to_json(validation))
    assert report["calibration"]["n_poses"] == 120
    assert report["validation"]["after"]["position_mean"] == pytest.approx(
        validation.after.position_mean
    )

    # Written and read back with a targets description: the same poses.
    description = tmp_path / "targets.toml"
    description.write_text(
        "".join(
            f'[[target]]\nname = "{name}"\nframe = "{frame}"\noffset_mm = [30.0, 0.0, 40.0]\n\n'
            for name, frame, _ in TARGETS
        )
    )
    path = tmp_path / "markers.csv"
    data.write_csv(path)
    back = flexcal.MeasurementSet.read_csv(path, targets=description)
    np.testing.assert_allclose(back.q, data.q, atol=1e-9)
    np.testing.assert_array_equal(np.isnan(back.positions), np.isnan(data.positions))
    np.testing.assert_allclose(back.positions, data.positions, atol=1e-9, equal_nan=True)


def test_two_stations_of_markers_each_with_its_frame(two_arms):
    """The same robot measured from two placements of the tracker: one
    identification, a frame per station, the second placement's pose
    relative to the first recovered."""
    truth = Truth(two_arms, seed=31)
    q = configurations(two_arms, 60, seed=32)
    first = target_set(TARGETS, q, truth.measure(two_arms, q), source="a")
    placed = (truth.frame_rotation, truth.frame_translation)
    truth.frame_rotation = rotation([0.0, 0.1, 1.0], -1.2) @ truth.frame_rotation
    truth.frame_translation = np.array([-1.8, 2.2, -0.7])
    q2 = configurations(two_arms, 60, seed=33)
    second = target_set(TARGETS, q2, truth.measure(two_arms, q2), source="b")
    data = flexcal.MeasurementSet.pooled([first, second])
    assert data.station_names == ["a", "b"] and data.station_of == [0] * 60 + [1] * 60
    result = flexcal.calibrate(two_arms, data, select="none", hold_out_stations=True)
    assert result.after.position_mean < 1.3 * 1.6 * NOISE, result.after
    # Each placement predicted by the robot calibrated on the other.
    held = result.station_hold_out
    assert [h[0] for h in held] == ["a", "b"]
    for _, chosen, before, after in held:
        assert chosen is None and after.position_mean < 1.3 * 1.6 * NOISE < before.position_mean
    (name_a, frame_a), (name_b, frame_b) = result.station_frames
    assert (name_a, name_b) == ("a", "b")
    np.testing.assert_allclose(frame_a, result.measurement_frame)
    relative = frame_b @ np.linalg.inv(frame_a)
    def pose(rotation_m, translation):
        m = np.eye(4)
        m[:3, :3], m[:3, 3] = rotation_m, translation
        return m
    true_relative = pose(truth.frame_rotation, truth.frame_translation) @ np.linalg.inv(pose(*placed))
    # A tracker's noise of 20 um over 120 poses: within 0.1 mm and 0.1 mrad.
    np.testing.assert_allclose(relative[:3, 3], true_relative[:3, 3], atol=0.1e-3)
    np.testing.assert_allclose(relative[:3, :3], true_relative[:3, :3], atol=0.1e-3)


def test_a_marker_recording_fault_is_named_and_left_out(two_arms):
    """One marker's reading 2 mm off at one pose, against 20 um of noise:
    the data checks name that observation, and the set without its pose
    calibrates at the noise."""
    truth = Truth(two_arms, seed=41)
    q = configurations(two_arms, 80, seed=42)
    positions = truth.measure(two_arms, q, occlude=0.0)
    positions[17, 1, 2] += 2e-3
    data = target_set(TARGETS, q, positions)
    assert data.labels[:2] == ["#0", "#1"]
    result = flexcal.calibrate(two_arms, data, select="none")
    checks = result.data_checks
    assert len(checks) == 1 and "1 observation" in checks[0] and "right at #17" in checks[0], checks
    kept = data.excluding(["#17"])
    assert len(kept) == 79 and "#17" not in kept.labels and kept.labels[17] == "#18"
    # Or only the faulty marker's reading, as the data checks name it.
    marker = data.excluding(["right at #17"])
    assert len(marker) == 80 and marker.n_observations == 159
    assert np.isnan(marker.positions[17, 1]).all() and not np.isnan(marker.positions[17, 0]).any()
    assert flexcal.calibrate(two_arms, marker, select="none").data_checks == []
    clean = flexcal.calibrate(two_arms, kept, select="none")
    assert clean.data_checks == []
    assert clean.after.position_mean < 1.3 * 1.6 * NOISE < result.after.position_mean, (
        clean.after,
        result.after,
    )
    # The validation's checks: the same fault in another set.
    q_other = configurations(two_arms, 40, seed=43)
    other_positions = truth.measure(two_arms, q_other, occlude=0.0)
    other_positions[5, 0, 0] -= 2e-3
    other = target_set(TARGETS, q_other, other_positions)
    validation = clean.validate(other)
    checks = validation.data_checks
    assert len(checks) == 1 and "left at #5" in checks[0], checks
    # Where the validation poses leave the identification poses' ranges:
    # counted here from the coordinates.
    lo, hi = kept.q.min(axis=0), kept.q.max(axis=0)
    outside = ((other.q < lo) | (other.q > hi)).mean(axis=0)
    names = two_arms.joint_names
    expected = {names[i]: f for i, f in enumerate(outside) if f > 0}
    assert expected, "40 random poses against 79: some coordinate should leave the range"
    got = dict(validation.extrapolated_coordinates)
    assert got.keys() == expected.keys(), (got, expected)
    for name, f in expected.items():
        assert got[name] == pytest.approx(f, abs=1e-12), name
    with pytest.raises(flexcal.InputError, match="no pose `#80`"):
        data.excluding(["#80"])


def test_the_elasto_geometric_model_with_two_markers(two_arms, tmp_path):
    # The joints of the simulated robot are rigid: every compliance is
    # either left out (its value not told apart from zero) or comes out
    # at zero within 4 standard errors.
    truth = Truth(two_arms, seed=21)
    q = configurations(two_arms, 150, seed=22)
    data = target_set(TARGETS, q, truth.measure(two_arms, q))
    # Compliances the poses do not determine stay at their start: start
    # them at this rigid truth's zero (a start of 10 urad/N.m would put a
    # sag the robot does not have into every prediction, which the
    # determined compliances would then absorb).
    masses = tmp_path / "rigid_start.toml"
    masses.write_text(
        (DATA / "two_arms_masses.toml")
        .read_text()
        .replace("initial_compliance_urad_per_nm = 10.0", "initial_compliance_urad_per_nm = 0.0")
    )
    result = flexcal.calibrate(
        two_arms,
        data,
        model="elasto-geometric",
        masses=masses,
        select="none",
    )
    assert result.model == "elasto-geometric"
    compliances = [
        u
        for u in result.parameters
        if u.name.startswith(("compliance_", "lateral_compliance_")) and u.status == "identified"
    ]
    for u in compliances:
        assert u.unit == "rad/N.m"
        assert abs(u.identified) < 4 * u.standard_error, u
    # The torso turns about the vertical: gravity does not load it.
    torso = next(u for u in result.parameters if u.name == "compliance_theta1")
    assert torso.status != "identified"
    assert result.torque_ranges["theta1"] == pytest.approx((0.0, 0.0), abs=1e-9)
    low, high = result.torque_ranges["thetaL1"]
    assert low < -10 and high > 10, (low, high)  # N.m, both signs
    assert any("compliance_theta1 (torque range" in n and "too little gravity torque" in n for n in result.notes), result.notes
    # The shoulders are loaded: what the data say of their compliances is
    # told in the notes, kept or left out.
    assert any("compliance_thetaL1" in n for n in result.notes), result.notes
    # Cross-validation on the same poses drops the compliances.
    selected = flexcal.calibrate(
        two_arms, data, model="elasto-geometric", masses=DATA / "two_arms_masses.toml"
    )
    assert selected.selection is not None and selected.selection.method == "cv"
    assert "compliances" not in selected.selection.chosen, selected.selection.lines()


def test_bad_multi_target_input_is_a_named_error(two_arms):
    q = configurations(two_arms, 4, seed=31)
    good = np.zeros((4, 2, 3))
    with pytest.raises(flexcal.ShapeError, match=r"positions: expected shape \(4, 2, 3\)"):
        target_set(TARGETS, q, np.zeros((4, 3)))
    partly = good.copy()
    partly[1, 0, 2] = np.nan
    with pytest.raises(flexcal.NotFiniteError, match=r"positions\[1, 0\] \(target `left`\)"):
        target_set(TARGETS, q, partly)
    with pytest.raises(flexcal.InputError, match="no target named `middle`"):
        target_set(TARGETS, q, good, fixed=["middle"])
    never = good.copy()
    never[:, 1] = np.nan
    with pytest.raises(flexcal.MeasurementError, match="target `right` is observed on no pose"):
        target_set(TARGETS, q, never)
    data = target_set(
        [("left", "LH", OFFSET), ("right", "XX", OFFSET)], q, good
    )
    with pytest.raises(flexcal.MeasurementError, match="no frame `XX`"):
        flexcal.calibrate(two_arms, data, select="none")
    # The one-target and several-target keywords of the one constructor.
    with pytest.raises(flexcal.InputError, match="std: not available with targets"):
        target_set(TARGETS, q, good, std=np.full((4, 3), 1e-5))
    with pytest.raises(flexcal.InputError, match="fixed: `left` given without targets"):
        flexcal.MeasurementSet.from_arrays(q, good[:, 0], fixed=["left"])
    with pytest.raises(flexcal.InputError, match="format: \"ipa\" has no per-target columns"):
        flexcal.MeasurementSet.read_csv("markers.csv", format="ipa", targets="targets.toml")
    with pytest.raises(flexcal.InputError, match="select"):
        flexcal.calibrate(two_arms, data, select="maybe")


def rotation_vector(r):
    """The rotation vector (rad) of the rotation matrices `r` (..., 3, 3)."""
    angle = np.arccos(np.clip((np.trace(r, axis1=-2, axis2=-1) - 1) / 2, -1, 1))
    axis = np.stack(
        [r[..., 2, 1] - r[..., 1, 2], r[..., 0, 2] - r[..., 2, 0], r[..., 1, 0] - r[..., 0, 1]],
        axis=-1,
    )
    scale = np.where(angle > 1e-12, angle / (2 * np.sin(np.maximum(angle, 1e-12))), 0.5)
    return axis * scale[..., None]


def test_orientations_of_several_targets_are_fitted(two_arms):
    """Markers with orientations (a 6-DOF target on each hand, 0.005 deg
    per axis): their rotations are identified and their orientation errors
    reported, at the noise."""
    truth = Truth(two_arms, seed=21)
    q = configurations(two_arms, 80, seed=22)
    positions = truth.measure(two_arms, q, occlude=0.0)
    turns = np.empty_like(positions)
    sigma = np.radians(0.005)
    for t, (_, frame, _) in enumerate(TARGETS):
        hand = truth.frame_rotation @ two_arms.fk(q, xi=truth.xi, frame=frame)[:, :3, :3]
        turns[:, t] = rotation_vector(hand) + truth.rng.normal(0.0, sigma, (len(q), 3))
    data = target_set(TARGETS, q, positions, orientations=turns)
    result = flexcal.calibrate(two_arms, data, select="none")
    status = {u.name: u.status for u in result.parameters}
    for name, _, _ in TARGETS:
        for axis in ("rx", "ry", "rz"):
            assert status[f"target.{name}.{axis}"] == "identified"
    for name, errors in result.per_target_after.items():
        assert errors.orientation_rms is not None and errors.orientation_rms < 3 * sigma, name
    # Positions alone: the markers' rotations are not unknowns at all.
    positions_only = flexcal.calibrate(
        two_arms, target_set(TARGETS, q, positions), select="none"
    )
    assert not any(u.name.startswith("target.left.r") for u in positions_only.parameters)
    with pytest.raises(flexcal.ShapeError, match="orientations"):
        target_set(TARGETS, q, positions, orientations=turns[:, :1])


def test_the_old_names_are_deprecated_aliases(two_arms):
    """`calibrate_targets`, `TargetCalibrationResult` and
    `TargetValidationResult` still work for one release, and say so."""
    truth = Truth(two_arms, seed=31)
    q = configurations(two_arms, 40, seed=32)
    data = target_set(TARGETS, q, truth.measure(two_arms, q))
    with pytest.warns(DeprecationWarning, match="flexcal.calibrate takes a MeasurementSet of several targets"):
        old = flexcal.calibrate_targets(two_arms, data, select="none")
    new = flexcal.calibrate(two_arms, data, select="none")
    assert type(new) is flexcal.CalibrationResult
    with pytest.warns(DeprecationWarning, match="returns a CalibrationResult for either kind"):
        alias = flexcal.TargetCalibrationResult
    assert alias is flexcal.CalibrationResult
    with pytest.warns(DeprecationWarning, match="returns a ValidationResult for either kind"):
        validation_alias = flexcal.TargetValidationResult
    assert validation_alias is flexcal.ValidationResult
    with pytest.warns(DeprecationWarning, match="MeasurementSet.from_arrays and MeasurementSet.read_csv take targets="):
        set_alias = flexcal.TargetMeasurementSet
    old_set = set_alias.from_arrays(TARGETS, q, truth.measure(two_arms, q), fixed=["left"])
    assert type(old_set) is flexcal.MeasurementSet and old_set.format == "targets"
    assert old_set.target_names == ["left", "right"]
    assert type(set_alias.pooled([old_set, old_set])) is flexcal.MeasurementSet
    assert old.identified == new.identified
    with pytest.raises(AttributeError, match="no attribute 'NoSuchName'"):
        flexcal.NoSuchName


def test_one_result_for_either_kind_of_set(two_arms):
    """One target per pose and several give the same class; its per-target
    figures name `tcp` for the one target; its checks refuse a set of the
    other kind, and the one-target keywords are refused with several
    targets, each by name."""
    truth = Truth(two_arms, seed=41)
    q = configurations(two_arms, 60, seed=42)
    positions = truth.measure(two_arms, q, occlude=0.0)
    several = target_set(TARGETS, q, positions)
    # The left marker alone, as a one-target set: its "TCP" is the hand
    # frame only when the robot's end frame is LH, so compare the kinds of
    # result, not the figures.
    one = flexcal.MeasurementSet.from_arrays(q, positions[:, 0])
    by_several = flexcal.calibrate(two_arms, several, select="none")
    by_one = flexcal.calibrate(two_arms, one, select="none")
    assert type(by_several) is type(by_one) is flexcal.CalibrationResult
    assert set(by_one.per_target_after) == {"tcp"}
    assert set(by_one.target_offsets) == {"tcp"}
    assert set(by_several.target_offsets) == {"left", "right"}
    labels, errors = by_one.observation_errors
    assert errors.shape == (60, 3) and {t for _, t in labels} == {"tcp"}
    assert np.allclose(np.linalg.norm(errors, axis=1), by_one.position_errors)
    assert by_several.position_errors.shape == (120,)
    assert "2 targets" in repr(by_several) and "targets" not in repr(by_one)
    # Checks take a set of the kind the result was identified from.
    with pytest.raises(flexcal.InputError, match="other: a set of one target, but .* several targets"):
        by_several.validate(one)
    with pytest.raises(flexcal.InputError, match="other: a set with targets, but .* one target"):
        by_one.accuracy_coverage(several)
    with pytest.raises(flexcal.InputError, match="other: expected a MeasurementSet, got"):
        by_one.cross_check(q)
    # One validation class: per-target figures for several targets, `tcp`
    # for one.
    validated = by_several.validate(several)
    assert type(validated) is type(by_one.validate(one)) is flexcal.ValidationResult
    assert set(validated.per_target_after) == {"left", "right"}
    assert set(by_one.validate(one).per_target_after) == {"tcp"}
    assert validated.frame_refitted
    with pytest.raises(flexcal.InputError, match="refit_target: not available with several targets"):
        by_several.validate(several, refit_target=True)
    with pytest.raises(flexcal.InputError, match="refit_frame: a set of one target per pose"):
        by_one.validate(one, refit_frame=False)
    with pytest.raises(flexcal.InputError, match="validation: expected the ValidationResult"):
        by_several.to_json(validation=by_one.validate(one))
    # The one-target keywords, by name.
    with pytest.raises(flexcal.InputError, match="fixed_target: not available with several targets"):
        flexcal.calibrate(two_arms, several, fixed_target=True)
    with pytest.raises(flexcal.InputError, match="target: not available with several targets"):
        flexcal.calibrate(two_arms, several, target=[0.0, 0.0, 0.1])
    with pytest.raises(flexcal.InputError, match="data: expected a MeasurementSet, got list"):
        flexcal.calibrate(two_arms, [1, 2, 3])


def test_extrapolation_widens_bounds_outside_the_training_range_only(two_arms):
    """`extrapolation=True` measures the error growth per joint and adds it
    outside the training ranges: inside every range the bounds are those
    without it, outside they are at least as wide."""
    truth = Truth(two_arms, seed=51)
    q = configurations(two_arms, 80, seed=52)
    data = target_set(TARGETS, q, truth.measure(two_arms, q))
    plain = flexcal.calibrate(two_arms, data, select="none")
    grown = flexcal.calibrate(two_arms, data, select="none", extrapolation=True)
    assert plain.extrapolation_growth is None and plain.extrapolation_notes == []
    growth = grown.extrapolation_growth
    assert set(growth) == set(grown.actuated_ranges)
    assert all(g >= 0.0 for g in growth.values())
    inside = q[:5]
    # Equal but for the round-off of summing the bound's parts anew.
    assert np.allclose(
        plain.predicted_accuracy(inside).bound_95,
        grown.predicted_accuracy(inside).bound_95,
        rtol=1e-12,
        atol=0.0,
    )
    lo = np.array([r[0] for r in grown.actuated_ranges.values()])
    outside = np.tile(lo - 0.3, (3, 1))
    assert np.all(
        grown.predicted_accuracy(outside).bound_95 >= plain.predicted_accuracy(outside).bound_95
    )


def test_a_campaign_with_several_targets_runs_as_calibrate_does(two_arms, tmp_path):
    """`Campaign.run` takes a campaign with a targets description and gives
    what `flexcal.calibrate` gives on the same file."""
    truth = Truth(two_arms, seed=61)
    q = configurations(two_arms, 50, seed=62)
    data = target_set(TARGETS, q, truth.measure(two_arms, q))
    data.write_csv(tmp_path / "markers.csv")
    (tmp_path / "c.toml").write_text(
        f"""
[robot]
file = "{(DATA / "two_arms.toml").as_posix()}"

[data]
files = ["markers.csv"]
targets = "{(DATA / "two_arms_targets.toml").as_posix()}"

[model]
select = "none"
"""
    )
    result = flexcal.Campaign.read(tmp_path / "c.toml").run(write_outputs=False)
    read = flexcal.MeasurementSet.read_csv(tmp_path / "markers.csv", targets=DATA / "two_arms_targets.toml")
    direct = flexcal.calibrate(two_arms, read, select="none")
    assert set(result.target_offsets) == {"left", "right"}
    assert result.identified == direct.identified
    assert json.loads(result.to_json())["summary"]
