"""Calibration from Python: a simulated UR10 whose truth is known, and the
IPA UR10 laser-tracker pair B -> C against the Rust library's report."""

import json

import numpy as np
import pytest
from conftest import configurations, ipa_series

import flexcal

# Error terms of the simulated robot (standard deviations): link lengths and
# offsets 0.3 mm, angles 0.03 deg, the order of the deltas identified on the
# real UR10 of the IPA data, series B (lengths 0.06-1.3 mm, angles 0.01-0.09
# deg, as examples/calibrate_ipa_ur10.py prints them); measurement noise
# 20 um per axis, the order of a laser tracker's uncertainty at 1-2 m.
LENGTH_ERROR = 0.3e-3
ANGLE_ERROR = np.radians(0.03)
NOISE = 20e-6


def simulated_ur10(ur10, seed):
    rng = np.random.default_rng(seed)
    sigma = np.array([LENGTH_ERROR if p.unit == "m" else ANGLE_ERROR for p in ur10.parameters])
    truth = ur10.nominal + rng.normal(0.0, sigma)
    return truth, rng


def measure(ur10, truth, q, rng):
    poses = ur10.fk(q, xi=truth)
    positions = poses[:, :3, 3] + rng.normal(0.0, NOISE, size=(len(q), 3))
    return positions


def test_calibrate_recovers_the_truth(ur10):
    truth, rng = simulated_ur10(ur10, seed=7)
    q = configurations(ur10, 200, seed=8)
    positions = measure(ur10, truth, q, rng)
    data = flexcal.MeasurementSet.from_arrays(
        q, positions, std=np.full((len(q), 3), NOISE), source="simulated ur10"
    )
    result = flexcal.calibrate(ur10, data, fixed_frame=True, fixed_target=True, select="none")
    assert result.converged, result.termination
    assert result.refused_trials == 0 and result.last_refusal is None
    # Residual at the noise level: RMS of a 3-D error of 20 um per axis.
    assert result.after.position_rms < 1.5 * np.sqrt(3) * NOISE
    assert result.before.position_rms > 10 * NOISE
    # Every identified parameter within 4 standard errors of what it stands
    # for: its truth plus the combination (C.1) of the absorbed unknowns'
    # errors (they stay at nominal; frame and target are exact here).
    names = ur10.parameter_names
    delta = dict(zip(names, truth - ur10.nominal))
    terms = result.combination_terms
    checked = 0
    for u in result.parameters:
        if u.status == "identified" and u.name in names:
            stands_for = truth[names.index(u.name)] + sum(
                k * delta.get(other, 0.0) for other, k in terms.get(u.name, [])
            )
            error = u.identified - stands_for
            assert abs(error) < 4 * u.standard_error, (u, error)
            checked += 1
    assert checked >= 15, result.non_identifiable
    # The calibrated robot predicts fresh configurations at the noise level.
    fresh = configurations(ur10, 100, seed=9)
    predicted = result.robot.fk(fresh)[:, :3, 3]
    actual = ur10.fk(fresh, xi=truth)[:, :3, 3]
    assert np.sqrt(np.mean(np.sum((predicted - actual) ** 2, axis=1))) < 2 * NOISE
    # The report has the JSON report's fields.
    report = json.loads(result.to_json())
    assert report["identification"]["rank"] == result.rank
    assert report["identification"]["non_identifiable"] == result.non_identifiable
    assert len(result.cost_history) == len(result.position_rms_history) > 1


def calibrated_with_a_test_set(ur10, seed, n_train, n_test):
    """A simulated UR10 calibrated (geometric, no selection) on `n_train`
    poses, another `n_test` measured poses of it, and the truth."""
    truth, rng = simulated_ur10(ur10, seed=seed)
    q = configurations(ur10, n_train, seed=seed + 1)
    train = flexcal.MeasurementSet.from_arrays(q, measure(ur10, truth, q, rng))
    q2 = configurations(ur10, n_test, seed=seed + 2)
    test = flexcal.MeasurementSet.from_arrays(q2, measure(ur10, truth, q2, rng))
    return flexcal.calibrate(ur10, train, select="none"), test, q, q2, truth


def test_validation_on_another_set(ur10):
    result, test, _, _, _ = calibrated_with_a_test_set(ur10, 11, 120, 60)
    validation = result.validate(test)
    assert validation.after.position_mean < validation.before.position_mean / 5
    assert validation.position_errors.shape == (60,)
    assert validation.error_vectors.shape == (60, 3)
    report = json.loads(result.to_json(validation))
    assert report["validation"]["position_mean_mm"] == pytest.approx(
        validation.after.position_mean * 1e3
    )


def compare_reports(python, rust):
    """The figures of two calibration reports agree (same code, same data)."""
    for part in ["identification", "validation"]:
        for key in ["n_poses", "position_mean_mm", "position_rms_mm", "position_max_mm"]:
            assert python[part][key] == pytest.approx(rust[part][key], rel=1e-9), (part, key)
            assert python[part]["before"][key] == pytest.approx(
                rust[part]["before"][key], rel=1e-9
            ), (part, "before", key)
    ident_p, ident_r = python["identification"], rust["identification"]
    for key in ["rank", "n_unknowns", "n_free", "non_identifiable", "poorly_identifiable"]:
        assert ident_p[key] == ident_r[key], key
    for p, r in zip(ident_p["parameters"], ident_r["parameters"]):
        assert p["name"] == r["name"] and p["status"] == r["status"]
        assert p["identified"] == pytest.approx(r["identified"], rel=1e-9, abs=1e-12), p["name"]


def test_ipa_b_to_c_gives_the_rust_figures(rust_reference):
    series_b = ipa_series("Series_B", "measurements_joint_configurations.csv")
    series_c = ipa_series("Series_C", "measurements_random_poses.csv")
    if "ipa_b_to_c" not in rust_reference:
        pytest.skip("the Rust reference has no IPA B -> C report (data absent for it)")
    ur10 = flexcal.Robot.builtin("ur10")
    train = flexcal.MeasurementSet.read_csv(series_b, format="ipa")
    test = flexcal.MeasurementSet.read_csv(series_c, format="ipa")
    # The defaults of `flexcal calibrate`: cross-validated model selection.
    result = flexcal.calibrate(ur10, train)
    assert result.selection is not None and result.selection.method == "cv"
    validation = result.validate(test)
    python = json.loads(result.to_json(validation))
    compare_reports(python, rust_reference["ipa_b_to_c"])
    assert python["selection"]["chosen"] == rust_reference["ipa_b_to_c"]["selection"]["chosen"]
    print(
        f"IPA B -> C from Python: validation mean {validation.after.position_mean * 1e3:.3f} mm, "
        f"max {validation.after.position_max * 1e3:.3f} mm"
    )


def test_elasto_geometric_on_a_simulated_set_runs(ur10):
    truth, rng = simulated_ur10(ur10, seed=21)
    q = configurations(ur10, 80, seed=22)
    data = flexcal.MeasurementSet.from_arrays(q, measure(ur10, truth, q, rng))
    result = flexcal.calibrate(ur10, data, model="elasto-geometric")
    assert result.model == "elasto-geometric"
    assert any(u.name.startswith("compliance_") for u in result.parameters)
    # Gravity never loads joint 1 (vertical axis): its compliance moves nothing.
    status = {u.name: u.status for u in result.parameters}
    assert status["compliance_theta1"] == "no-influence"
    assert result.torque_ranges["theta1"] == pytest.approx((0.0, 0.0), abs=1e-9)
    # The shoulder carries tens of N.m; each span is ordered and named.
    assert list(result.torque_ranges) == ur10.joint_names
    lo, hi = result.torque_ranges["theta2"]
    assert lo <= hi and max(abs(lo), abs(hi)) > 20.0
    # A revolute coordinate's coverage is an arc of the circle containing
    # every training angle, whichever turn it was recorded in.
    for j, name in enumerate(ur10.joint_names):
        start, end = result.actuated_ranges[name]
        assert 0.0 <= end - start < 2.0 * np.pi
        ahead = np.mod(q[:, j] - start, 2.0 * np.pi)
        assert np.all(ahead <= end - start + 1e-9), name
    geometric = flexcal.calibrate(ur10, data, select="none")
    assert geometric.torque_ranges == {}


@pytest.mark.parametrize("select", ["cv", "bic"])
def test_model_selection_reports_what_it_chose(ur10, select):
    truth, rng = simulated_ur10(ur10, seed=41)
    q = configurations(ur10, 150, seed=42)
    data = flexcal.MeasurementSet.from_arrays(q, measure(ur10, truth, q, rng))
    result = flexcal.calibrate(ur10, data, select=select)
    selection = result.selection
    assert selection is not None and selection.method == select
    assert len(selection.candidates) >= 2 and selection.why
    labels = {c.label for c in selection.candidates}
    assert (" + ".join(selection.chosen) or "base") in labels
    for c in selection.candidates:
        if c.failure is None:
            scored = c.cv_mean_error if select == "cv" else c.bic
            assert scored is not None and np.isfinite(scored), c
    if select == "cv":
        assert sum(selection.fold_sizes) == len(data)
        # SI at this boundary: held-out errors of a few tenths of a mm at most.
        assert all(0 < c.cv_mean_error < 5e-3 for c in selection.candidates if c.failure is None)
    # The final identification is the chosen model: a group left out keeps
    # its parameters at nominal (fixed), a group chosen identifies some.
    status = {u.name: u.status for u in result.parameters}
    for group, prefix in [("offsets", "theta"), ("tilts", "beta")]:
        members = [status[n] for n in ur10.parameter_names if n.startswith(prefix)]
        if group in selection.chosen:
            assert any(s != "fixed" for s in members), (group, members)
        else:
            assert all(s == "fixed" for s in members), (group, members)
    # The command line's text and the JSON report carry the same selection.
    assert selection.lines()[-1].endswith(" + ".join(selection.chosen) or "base")
    report = json.loads(result.to_json())
    assert report["selection"]["reasons"] == selection.why
    if select == "cv":
        # The ordinary scores chose: the model with every group has its
        # extrapolating score; every candidate has one on request.
        assert selection.candidates[0].extrapolation_mean_error is not None
        every = flexcal.calibrate(ur10, data, select="cv", every_extrapolation_score=True)
        assert all(
            c.extrapolation_mean_error is not None
            for c in every.selection.candidates
            if c.failure is None
        )
        assert every.selection.chosen == selection.chosen


def test_without_selection_there_is_no_report(ur10):
    q = configurations(ur10, 40, seed=43)
    data = flexcal.MeasurementSet.from_arrays(q, ur10.fk(q)[:, :3, 3])
    assert flexcal.calibrate(ur10, data).selection is None
    with pytest.raises(flexcal.InputError, match='select: expected "cv", "bic" or "none"'):
        flexcal.calibrate(ur10, data, select="aic")


def test_predicted_accuracy_covers_new_poses_and_names_extrapolation(ur10):
    result, test, q, q2, truth = calibrated_with_a_test_set(ur10, 21, 200, 400)
    checked = result.accuracy_coverage(test)
    # A model that is the truth's, with Gaussian noise: about 95 % of new
    # poses within their bound (400 poses: the share's standard error is 1.1 %).
    assert 0.90 <= checked.coverage <= 0.99, checked
    assert checked.bound_95.shape == (400,)
    assert np.all(checked.actual_error >= 0.0)
    assert checked.residual_scatter == pytest.approx(NOISE, rel=0.15)
    assert checked.inflation == 1.0
    # The same bounds from the configurations alone, without measurements.
    grid = result.predicted_accuracy(q2)
    np.testing.assert_allclose(grid.bound_95, checked.bound_95, rtol=1e-9)
    assert np.all(np.isnan(grid.actual_error))
    assert grid.coverage is None
    assert np.all(grid.model_uncertainty < grid.bound_95)
    assert grid.positions.shape == (400, 3)
    # The calibrated target positions are the robot's up to the base frame,
    # which the data fix only together with the measurement frame: the
    # distances between them are the true robot's.
    tool = ur10.fk(q2[:50], xi=truth)[:, :3, 3]

    def distances(p):
        return np.linalg.norm(p[:, None, :] - p[None, :, :], axis=2)

    assert np.max(np.abs(distances(grid.positions[:50]) - distances(tool))) < 0.2e-3
    # A configuration beyond the training range of joint 2 is named. The
    # model is 2 pi-periodic in a revolute joint, so the training range is
    # the arc of the circle the angles cover: the largest gap between them
    # modulo 2 pi is what they have not seen.
    angles = np.sort(np.mod(q[:, 1], 2.0 * np.pi))
    gaps = np.diff(np.append(angles, angles[0] + 2.0 * np.pi))
    widest = int(np.argmax(gaps))
    beyond = q2[0].copy()
    beyond[1] = angles[widest] + 0.5 * gaps[widest]
    one = result.predicted_accuracy(beyond)
    others = set(grid.outside_training_range[0]) - {ur10.joint_names[1]}
    assert set(one.outside_training_range[0]) == others | {ur10.joint_names[1]}
    # The same arm pose a turn later on every joint is the same prediction.
    turned = result.predicted_accuracy(q2[0] + 2.0 * np.pi)
    assert turned.outside_training_range[0] == grid.outside_training_range[0]
    assert turned.bound_95[0] == pytest.approx(grid.bound_95[0], rel=1e-9)
    assert one.extrapolated_poses == 1
    assert one.to_csv().splitlines()[0].endswith(",outside_training_range")
    with pytest.raises(flexcal.ShapeError, match="q"):
        result.predicted_accuracy(np.zeros((3, 5)))


def test_the_split_half_check_raises_the_bounds_where_the_arm_drifts(ur10):
    """A campaign during which the upper arm grows by 0.1 mm (0.6 m of
    aluminium warming by 7 K, at 23e-6 1/K), which the model lacks: the
    halves in file order disagree beyond the standard errors, and every
    predicted bound grows by the check's prediction ratio in its model
    part (bound^2 = 7.815 (ratio^2 tr/3 + s^2))."""
    truth, rng = simulated_ur10(ur10, seed=31)
    q = configurations(ur10, 200, seed=32)
    d3 = ur10.parameter_names.index("d3")
    positions = np.empty((len(q), 3))
    for chunk in np.array_split(np.arange(len(q)), 10):
        warm = truth.copy()
        warm[d3] -= 0.1e-3 * chunk[0] / len(q)
        positions[chunk] = measure(ur10, warm, q[chunk], rng)
    data = flexcal.MeasurementSet.from_arrays(q, positions)
    plain = flexcal.calibrate(ur10, data, select="none")
    checked = flexcal.calibrate(ur10, data, select="none", split_check=True)
    assert plain.split_check is None
    split = checked.split_check
    # Independent errors give about 1 (two splits: within 0.5 - 1.5 by chance).
    assert split.prediction_ratio > 1.5, split.notes
    assert split.ratios["d3"] > 2.5, split.ratios
    assert split.split_errors["d3"] > 10e-6, split.split_errors
    assert set(split.standard_errors) == set(split.ratios)
    assert any("understated" in note for note in split.notes), split.notes
    q2 = configurations(ur10, 50, seed=33)
    before = plain.predicted_accuracy(q2)
    after = checked.predicted_accuracy(q2)
    assert after.inflation == pytest.approx(split.prediction_ratio)
    np.testing.assert_allclose(
        after.bound_95**2 - before.bound_95**2,
        7.814727903 * (split.prediction_ratio**2 - 1) * before.model_uncertainty**2 / 3,
        rtol=1e-6,
    )


def test_the_cross_series_check_names_what_changed_between_campaigns(ur10):
    """Two campaigns of the same simulated UR10 agree on every identified
    unknown (|z| of a standard normal: median 0.67); a campaign after the
    upper arm was exchanged for one 0.3 mm longer (over 100 combined
    standard errors) is named for d3."""
    result, same, _, _, truth = calibrated_with_a_test_set(ur10, 41, 200, 200)
    check = result.cross_check(same)
    z = np.abs(np.array(list(check.z.values())))
    assert len(z) >= 15 and np.median(z) < 1.2, check.notes
    assert len(check.disagreeing) <= 1, check.notes
    assert check.other_poses == 200
    assert set(check.values) == set(check.z) and not check.z_split
    rng = np.random.default_rng(42)
    longer = truth.copy()
    longer[ur10.parameter_names.index("d3")] -= 0.3e-3
    q = configurations(ur10, 200, seed=43)
    other = flexcal.MeasurementSet.from_arrays(q, measure(ur10, longer, q, rng))
    check = result.cross_check(other)
    assert "d3" in check.disagreeing, check.notes
    assert check.other_values["d3"] - check.values["d3"] == pytest.approx(-0.3e-3, abs=0.05e-3)


def test_two_stations_are_pooled_with_a_frame_each(ur10):
    """A robot seen from two tracker placements: the pooled calibration
    finds both frames, and the motion between the placements exactly."""
    truth, rng = simulated_ur10(ur10, seed=41)

    def placement(angle, offset):
        c, s = np.cos(angle), np.sin(angle)
        frame = np.eye(4)
        frame[:2, :2] = [[c, -s], [s, c]]
        frame[:3, 3] = offset
        return frame

    frames = [placement(0.3, [3.0, -0.2, 0.1]), placement(-2.0, [-2.5, 1.5, -0.3])]
    sets = []
    for k, frame in enumerate(frames):
        q = configurations(ur10, 80, seed=42 + k)
        local = measure(ur10, truth, q, rng)
        seen = local @ frame[:3, :3].T + frame[:3, 3]
        sets.append(flexcal.MeasurementSet.from_arrays(q, seen, source=f"station {k + 1}"))
    pooled = flexcal.MeasurementSet.pooled(sets)
    assert pooled.station_names == ["station 1", "station 2"]
    assert pooled.station_of == [0] * 80 + [1] * 80
    assert pooled.labels[80] == "s2:#0"
    result = flexcal.calibrate(
        ur10, pooled, fixed_target=True, select="none", hold_out_stations=True
    )
    assert result.after.position_rms < 1.5 * np.sqrt(3) * NOISE
    names = [name for name, _ in result.station_frames]
    assert names == ["station 1", "station 2"]
    assert [(name, e.n_poses) for name, e in result.station_errors] == [
        ("station 1", 80),
        ("station 2", 80),
    ]
    assert max(e.position_rms for _, e in result.station_errors) < 1.5 * np.sqrt(3) * NOISE
    (_, first), (_, second) = result.station_frames
    np.testing.assert_array_equal(first, result.measurement_frame)
    # The base errors the frames absorb cancel in the motion between them.
    identified = second @ np.linalg.inv(first)
    true_motion = frames[1] @ np.linalg.inv(frames[0])
    assert np.abs(identified[:3, 3] - true_motion[:3, 3]).max() < 1e-4
    assert np.abs(identified[:3, :3] - true_motion[:3, :3]).max() < 1e-4
    # Each station held out: the robot identified on the other predicts it
    # to the noise.
    held = result.station_hold_out
    assert [name for name, *_ in held] == ["station 1", "station 2"]
    for _, chosen, before, after in held:
        assert chosen is None
        assert after.n_poses == 80
        assert after.position_rms < 2 * np.sqrt(3) * NOISE < before.position_rms
    assert len(json.loads(result.to_json())["station_hold_out"]) == 2
    # Treated as one station the same poses cannot be fitted.
    one = flexcal.MeasurementSet.from_arrays(pooled.q, pooled.positions)
    wrong = flexcal.calibrate(ur10, one, fixed_target=True, select="none")
    assert wrong.after.position_rms > 0.1


def test_sets_of_different_formats_are_not_pooled():
    ipa = flexcal.MeasurementSet.read_csv(
        ipa_series("Series_C", "measurements_random_poses.csv"), format="ipa"
    )
    own = flexcal.MeasurementSet.from_arrays(ipa.q[:10], ipa.positions[:10])
    with pytest.raises(flexcal.InputError, match="same format"):
        flexcal.MeasurementSet.pooled([ipa, own])
