//! Multi-target identification against a known truth: a two-armed tree
//! robot (a torso joint carrying two four-joint arms) with one marker per
//! hand, measured by a laser tracker standing away from the robot.
//!
//! The truth is the robot of `tests/data/two_arms.toml` with every
//! geometric parameter off by errors of the size the reference paper
//! identified on the IR-663 (Appendix C: fractions of a millimetre,
//! hundredths of a degree; here uniform within +-0.3 mm and +-0.03 deg),
//! the markers glued within +-1 mm of their nominal offsets, and the
//! tracker 2.5 m from the robot, turned. Noise: 0.02 mm per axis (Gaussian),
//! a laser tracker's repeatability at a few metres.

use flexcal_calib::{
    CHI2_3_95, Calibration, CalibrationOptions, FrameTreatment, MeasurementSet, Refit, Target,
    TargetObservation, TargetPose, UnknownStatus, calibrate, read_targets, rotation_from_vector,
    vector_from_rotation,
};
use flexcal_kinematics::{Data, Model, ParamKind, RobotDescription, forward_frame_pose};
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

const NOISE: f64 = 0.02e-3;

fn data_file(name: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

fn robot() -> Model {
    RobotDescription::from_toml_file(&data_file("two_arms.toml"))
        .unwrap()
        .build()
        .unwrap()
}

/// The simulated truth: robot parameters, tracker placement, marker offsets.
#[derive(Clone)]
struct Truth {
    xi: Vec<f64>,
    x_meas_base: Isometry3<f64>,
    offsets: Vec<Vector3<f64>>,
    /// Each marker's true orientation on its hand (identity unless a test
    /// measures orientations).
    rotations: Vec<UnitQuaternion<f64>>,
    /// Orientation noise per axis (rad); `None`: positions only.
    orientation_noise: Option<f64>,
}

fn truth(model: &Model, nominal_offsets: &[Vector3<f64>], rng: &mut ChaCha8Rng) -> Truth {
    let xi = model
        .nominal_params()
        .iter()
        .zip(model.params())
        .map(|(v, p)| match p.kind {
            ParamKind::Length => v + rng.random_range(-0.3e-3..0.3e-3),
            ParamKind::Angle => v + rng.random_range(-0.03f64..0.03).to_radians(),
        })
        .collect();
    let x_meas_base = Isometry3::from_parts(
        Translation3::new(2.5, -0.4, -0.9),
        rotation_from_vector(&Vector3::new(0.1, -0.2, 2.4)),
    );
    let offsets: Vec<Vector3<f64>> = nominal_offsets
        .iter()
        .map(|o| o + Vector3::from_fn(|_, _| rng.random_range(-1e-3..1e-3)))
        .collect();
    Truth {
        xi,
        x_meas_base,
        rotations: vec![UnitQuaternion::identity(); offsets.len()],
        offsets,
        orientation_noise: None,
    }
}

/// `poses` configurations drawn within the joint limits; each marker is
/// occluded on about one pose in ten (never both).
fn measure(
    model: &Model,
    truth: &Truth,
    targets: &[flexcal_calib::Target],
    poses: usize,
    rng: &mut ChaCha8Rng,
) -> MeasurementSet {
    let limits = model.actuated_limits().to_vec();
    measure_with(model, truth, targets, poses, rng, |rng| {
        limits
            .iter()
            .map(|&(lo, hi)| rng.random_range(lo..hi))
            .collect()
    })
}

/// The markers measured at `poses` configurations drawn by `draw`,
/// occluded as in [`measure`].
fn measure_with(
    model: &Model,
    truth: &Truth,
    targets: &[flexcal_calib::Target],
    poses: usize,
    rng: &mut ChaCha8Rng,
    mut draw: impl FnMut(&mut ChaCha8Rng) -> Vec<f64>,
) -> MeasurementSet {
    let noise = Normal::new(0.0, NOISE).unwrap();
    let mut data = Data::new(model);
    let frames: Vec<usize> = targets
        .iter()
        .map(|t| model.frame_index(&t.frame).unwrap())
        .collect();
    let poses = (0..poses)
        .map(|k| {
            let q = draw(rng);
            let hidden = if rng.random_range(0.0..1.0) < 0.2 {
                Some(rng.random_range(0..targets.len()))
            } else {
                None
            };
            let observations = (0..targets.len())
                .map(|t| {
                    if hidden == Some(t) {
                        return None;
                    }
                    let point = Isometry3::from_parts(
                        Translation3::from(truth.offsets[t]),
                        truth.rotations[t],
                    );
                    let x_base_target =
                        forward_frame_pose(model, &mut data, &q, &truth.xi, frames[t], &point)
                            .unwrap();
                    let x_meas_target = truth.x_meas_base * x_base_target;
                    let p = x_meas_target.translation.vector
                        + Vector3::from_fn(|_, _| noise.sample(rng));
                    let orientation = truth.orientation_noise.map(|sigma| {
                        let noise = Normal::new(0.0, sigma).unwrap();
                        let turn = Vector3::from_fn(|_, _| noise.sample(rng));
                        vector_from_rotation(
                            &(rotation_from_vector(&turn) * x_meas_target.rotation),
                        )
                    });
                    Some(TargetObservation {
                        orientation,
                        ..TargetObservation::new(p)
                    })
                })
                .collect();
            TargetPose::new(Some(format!("p{k}")), q, observations)
        })
        .collect();
    MeasurementSet::from_poses("simulated", targets.to_vec(), poses).unwrap()
}

/// The true value of every unknown of `calibration`, in its order: robot
/// parameters, measurement-frame increments on its starting frame, and the
/// offsets' increments on the nominal offsets of `targets`.
fn true_unknowns(
    calibration: &Calibration,
    truth: &Truth,
    targets: &[flexcal_calib::Target],
) -> Vec<f64> {
    let start = calibration.x_meas_base_initial;
    let mut x = truth.xi.clone();
    x.extend((truth.x_meas_base.translation.vector - start.translation.vector).iter());
    x.extend(vector_from_rotation(&(truth.x_meas_base.rotation * start.rotation.inverse())).iter());
    // Each target's offset, then its rotation where orientations are
    // measured.
    for (t, target) in targets.iter().enumerate() {
        let start = &calibration.targets_initial[t];
        if target.treatment == FrameTreatment::Identify {
            x.extend((truth.offsets[t] - start.offset).iter());
        } else {
            x.extend([0.0; 3]);
        }
        // Rotation unknowns where orientations are measured: increments on
        // the right of the start.
        if truth.orientation_noise.is_some() {
            x.extend(vector_from_rotation(&(start.rotation.inverse() * truth.rotations[t])).iter());
        }
    }
    x
}

/// The two-armed robot with a 6-DOF marker on each hand (glued within a
/// few degrees of the hand's axes; 0.02 mm, 0.005 deg per axis), seen at
/// 80 poses, and the identification options weighting them by that noise.
fn six_dof_markers() -> (
    Model,
    Vec<Target>,
    Truth,
    MeasurementSet,
    CalibrationOptions,
) {
    let model = robot();
    let targets = read_targets(&data_file("two_arms_targets.toml")).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(0x3664_6f66);
    let nominal: Vec<Vector3<f64>> = targets.iter().map(|t| t.offset).collect();
    let mut truth = truth(&model, &nominal, &mut rng);
    truth.rotations = (0..targets.len())
        .map(|_| rotation_from_vector(&Vector3::from_fn(|_, _| rng.random_range(-0.05..0.05))))
        .collect();
    truth.orientation_noise = Some(0.005f64.to_radians());
    let set = measure(&model, &truth, &targets, 80, &mut rng);
    let options = CalibrationOptions {
        default_position_std: NOISE,
        default_orientation_std: 0.005f64.to_radians(),
        weighting: flexcal_calib::Weighting::Uniform,
        ..CalibrationOptions::default()
    };
    (model, targets, truth, set, options)
}

/// Model selection by BIC counts the rows of the fit: six for each
/// observation of a 6-DOF marker (three for position, three for
/// orientation), as for one target whose orientations are fitted. The
/// chosen candidate's BIC is evaluated again here from the fit's cost and
/// identified unknowns.
#[test]
fn bic_counts_six_rows_per_oriented_observation_with_several_targets() {
    let (model, _, _, set, options) = six_dof_markers();
    let selection = flexcal_calib::SelectionOptions {
        method: flexcal_calib::SelectionMethod::Bic,
        ..Default::default()
    };
    let (fitted, report, _) =
        flexcal_calib::calibrate_selected(&model, &set, &options, &selection).unwrap();
    let report = report.expect("a BIC selection report");
    let chosen = report
        .candidates
        .iter()
        .find(|c| c.groups == report.chosen)
        .expect("the chosen candidate among the scored ones");
    let rows: usize = fitted
        .observation_errors
        .iter()
        .map(|e| if e.orientation_error.is_some() { 6 } else { 3 })
        .sum();
    assert_eq!(rows, 6 * set.n_observations());
    let n = rows as f64;
    let p = fitted
        .unknowns
        .iter()
        .filter(|u| u.status == UnknownStatus::Identified)
        .count() as f64;
    let expected = n * (2.0 * fitted.solve.cost / n).ln() + p * n.ln();
    let bic = chosen.bic.expect("scored by BIC");
    assert!(
        (bic - expected).abs() < 1e-6 * expected.abs().max(1.0),
        "BIC {bic} against {expected} for {rows} rows"
    );
}

/// Markers with orientations (a 6-DOF target on each hand: 0.02 mm, 0.005
/// deg per axis, a tracker with a 6-DOF probe): the identification fits
/// their rotations with the robot and recovers the truth within 3 standard
/// errors; it identifies what positions alone cannot: each marker's
/// rotation, standing for its hand's orientation (the hand frame's alpha
/// and theta and the last joint's theta offset, which no position sees
/// but in combination with the markers' offsets).
#[test]
fn six_dof_markers_on_both_hands_identify_what_positions_cannot() {
    let (model, targets, truth, set, options) = six_dof_markers();
    let six = calibrate(&model, &set, &options).unwrap();
    let x_true = true_unknowns(&six, &truth, &targets);
    assert_eq!(x_true.len(), six.unknowns.len());
    let checks = six.combination_check(&x_true);
    assert_eq!(checks.len(), six.rank());
    for (name, true_value, identified, se) in &checks {
        let se = se.unwrap_or_else(|| panic!("{name}: no standard error"));
        let z = (identified - true_value) / se;
        assert!(z.abs() < 3.0, "{name}: z = {z:.2}");
    }
    // The orientation errors are reported, target by target, at the noise.
    for errors in &six.per_target_after {
        let (_, rms, _) = errors
            .statistics
            .orientation_mean_rms_max
            .expect("orientation errors of a 6-DOF marker");
        assert!(
            rms < 3.0 * 0.005f64.to_radians(),
            "{}: {rms:e} rad",
            errors.target
        );
    }
    assert!(
        six.observation_errors
            .iter()
            .all(|e| e.orientation_error.is_some())
    );
    // Positions alone (the same poses, orientations left out).
    let positions = calibrate(
        &model,
        &set,
        &CalibrationOptions {
            use_orientation: Some(false),
            ..options.clone()
        },
    )
    .unwrap();
    let identified = |c: &Calibration| -> Vec<String> {
        c.unknowns
            .iter()
            .filter(|u| u.status == UnknownStatus::Identified)
            .map(|u| u.name.clone())
            .collect()
    };
    let by_positions = identified(&positions);
    let only_with_orientation: Vec<String> = identified(&six)
        .into_iter()
        .filter(|name| !by_positions.contains(name))
        .collect();
    println!("identified only with orientations: {only_with_orientation:?}");
    assert_eq!(
        only_with_orientation,
        [
            "target.left.rx",
            "target.left.ry",
            "target.left.rz",
            "target.right.rx",
            "target.right.ry",
            "target.right.rz",
        ]
    );
    // What they stand for: each hand's orientation, the hand frame's
    // alpha and theta and the last arm joint's theta offset, which no
    // marker position sees (positions leave them in combination with the
    // markers' positions only: `target.left.y_id = target.left.y - rL4 -
    // 0.290 alphaLH + ...`).
    for (marker, hand, last) in [("left", "LH", "L4"), ("right", "RH", "R4")] {
        let turned: Vec<&String> = six
            .combination_lines
            .iter()
            .filter(|l| l.starts_with(&format!("target.{marker}.r")))
            .collect();
        assert_eq!(turned.len(), 3, "{turned:?}");
        for parameter in [
            format!("alpha{hand}"),
            format!("theta{hand}"),
            format!("theta{last}"),
        ] {
            assert!(
                turned.iter().any(|l| l.contains(&parameter)),
                "{parameter}: {turned:?}"
            );
        }
    }
}

#[test]
fn two_markers_on_a_two_armed_tree_recover_the_truth_within_three_standard_errors() {
    let model = robot();
    let targets = read_targets(&data_file("two_arms_targets.toml")).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(0x7477_6f61);
    let nominal: Vec<Vector3<f64>> = targets.iter().map(|t| t.offset).collect();
    let truth = truth(&model, &nominal, &mut rng);
    let set = measure(&model, &truth, &targets, 80, &mut rng);
    let options = CalibrationOptions::default();
    let calibration = calibrate(&model, &set, &options).unwrap();

    // Every unknown, true value by name.
    let x_true = true_unknowns(&calibration, &truth, &targets);
    assert_eq!(x_true.len(), calibration.unknowns.len());
    let checks = calibration.combination_check(&x_true);
    assert_eq!(checks.len(), calibration.rank());
    let mut worst = (String::new(), 0.0f64);
    for (name, true_value, identified, se) in &checks {
        let se = se.unwrap_or_else(|| panic!("{name}: no standard error"));
        let z = (identified - true_value) / se;
        if z.abs() > worst.1.abs() {
            worst = (name.clone(), z);
        }
    }
    println!(
        "{} poses, {} observations: rank {} of {} unknowns, largest |error| / standard error {:.2} ({})",
        calibration.n_poses,
        calibration.n_observations,
        calibration.rank(),
        calibration.unknowns.len(),
        worst.1.abs(),
        worst.0
    );
    for (name, true_value, identified, se) in &checks {
        let se = se.unwrap();
        assert!(
            (identified - true_value).abs() < 3.0 * se,
            "{name}: identified {identified:e}, true combination {true_value:e}, standard error {se:e}"
        );
    }
    // The markers' offsets come out (each within 3 standard errors of the
    // truth along what the data identify): they moved from nominal by up to 1 mm.
    for stats in &calibration.per_target_after {
        println!(
            "target {} on {}: mean {:.4} mm, max {:.4} mm after (before: mean {:.3} mm)",
            stats.target,
            stats.frame,
            stats.statistics.position_mean * 1e3,
            stats.statistics.position_max * 1e3,
            calibration
                .per_target_before
                .iter()
                .find(|b| b.target == stats.target)
                .unwrap()
                .statistics
                .position_mean
                * 1e3
        );
        // Three axes of 0.02 mm noise: a mean error norm about 0.032 mm, less
        // what the fit absorbs.
        assert!(stats.statistics.position_mean < 0.04e-3, "{stats:?}");
        assert!(stats.statistics.position_max < 0.15e-3, "{stats:?}");
    }
    assert!(
        calibration.training_before.position_mean > 10.0 * calibration.training_after.position_mean
    );

    // Validation on other poses measured from the same tracker placement.
    let validation_set = measure(&model, &truth, &targets, 40, &mut rng);
    let validation = calibration
        .validate(&model, &validation_set, Refit::Nothing)
        .unwrap();
    for (before, after) in validation
        .per_target_before
        .iter()
        .zip(&validation.per_target_after)
    {
        println!(
            "validation, target {}: mean {:.3} -> {:.4} mm, max {:.3} -> {:.4} mm",
            after.target,
            before.statistics.position_mean * 1e3,
            after.statistics.position_mean * 1e3,
            before.statistics.position_max * 1e3,
            after.statistics.position_max * 1e3
        );
        assert!(after.statistics.position_mean < 0.05e-3, "{after:?}");
        assert!(before.statistics.position_mean > 5.0 * after.statistics.position_mean);
    }
}

#[test]
fn identifiability_names_what_two_markers_cannot_see() {
    let model = robot();
    let targets = read_targets(&data_file("two_arms_targets.toml")).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(0x626c_696e);
    let nominal: Vec<Vector3<f64>> = targets.iter().map(|t| t.offset).collect();
    let truth = truth(&model, &nominal, &mut rng);
    let set = measure(&model, &truth, &targets, 60, &mut rng);
    let calibration = calibrate(&model, &set, &CalibrationOptions::default()).unwrap();
    let status = |name: &str| {
        calibration
            .unknowns
            .iter()
            .find(|u| u.name == name)
            .unwrap_or_else(|| panic!("no unknown {name}"))
            .status
    };
    let notes = calibration.identifiability_notes().join("\n");
    println!("{notes}\n{}", calibration.combination_lines.join("\n"));
    for (marker, hand) in [("left", "LH"), ("right", "RH")] {
        // A marker's offset along its hand's z axis and the hand frame's r
        // move the marker the same way: one is identified, the other named.
        let z = format!("target.{marker}.z");
        let r = format!("r{hand}");
        assert_eq!(status(&z), UnknownStatus::Identified);
        assert_eq!(status(&r), UnknownStatus::NonIdentifiable);
        let combination = calibration
            .combinations
            .iter()
            .find(|c| c.name == z)
            .unwrap();
        let k = combination
            .terms
            .iter()
            .find(|(n, _)| *n == r)
            .map(|(_, k)| *k)
            .unwrap_or_else(|| panic!("{z} does not absorb {r}: {combination:?}"));
        assert!((k - 1.0).abs() < 1e-6, "{z} = {z} + {k} {r}");
        assert!(notes.contains(&format!("{r} (in ")), "{notes}");
    }
    // The torso's first frame is where the tracker's frame is: absorbed.
    assert_eq!(status("r1"), UnknownStatus::NonIdentifiable);
    assert!(notes.contains("r1 (in frame_"), "{notes}");

    // With the right marker never measured, nothing of the right arm is seen.
    let left_only: Vec<TargetPose> = set
        .poses()
        .iter()
        .filter(|p| p.observations[0].is_some())
        .map(|p| TargetPose {
            observations: vec![p.observations[0].clone()],
            ..p.clone()
        })
        .collect();
    let one = MeasurementSet::from_poses("left only", targets[..1].to_vec(), left_only).unwrap();
    let calibration = calibrate(&model, &one, &CalibrationOptions::default()).unwrap();
    let notes = calibration.identifiability_notes().join("\n");
    for p in model.params().iter().filter(|p| p.frame.starts_with('R')) {
        let u = calibration
            .unknowns
            .iter()
            .find(|u| u.name == p.name)
            .unwrap();
        assert_eq!(u.status, UnknownStatus::NoInfluence, "{}", p.name);
        assert!(notes.contains(&p.name), "{notes}");
    }
}

#[test]
fn a_target_on_a_frame_the_robot_lacks_is_a_named_error() {
    let model = robot();
    let mut targets = read_targets(&data_file("two_arms_targets.toml")).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let nominal: Vec<Vector3<f64>> = targets.iter().map(|t| t.offset).collect();
    let truth = truth(&model, &nominal, &mut rng);
    let set = measure(&model, &truth, &targets, 20, &mut rng);
    targets[1].frame = "RX".into();
    let err = calibrate(
        &model,
        &set.with_targets(targets).unwrap(),
        &CalibrationOptions::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("no frame `RX`") && err.contains("RH"), "{err}");
    let options = CalibrationOptions {
        use_orientation: Some(true),
        ..CalibrationOptions::default()
    };
    let err = calibrate(&model, &set, &options).unwrap_err().to_string();
    assert!(
        err.contains("orientation asked for but target `left` has none"),
        "{err}"
    );
}

#[test]
fn one_target_on_the_tcp_matches_the_one_target_identification() {
    use flexcal_calib::{Measurement, MeasurementSet, calibrate};
    use flexcal_kinematics::forward_pose;
    let model = RobotDescription::builtin("ur10").unwrap().build().unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(10);
    let truth: Vec<f64> = model
        .nominal_params()
        .iter()
        .map(|v| v + rng.random_range(-2e-4..2e-4))
        .collect();
    let x_meas_base = Isometry3::from_parts(
        Translation3::new(1.5, 0.2, -0.3),
        rotation_from_vector(&Vector3::new(0.0, 0.0, 0.7)),
    );
    let probe = Isometry3::translation(0.01, -0.02, 0.15);
    let noise = Normal::new(0.0, NOISE).unwrap();
    let mut data = Data::new(&model);
    let poses = (0..60)
        .map(|_| {
            let q: Vec<f64> = (0..6).map(|_| rng.random_range(-2.5..2.5)).collect();
            let x = forward_pose(&model, &mut data, &q, &truth).unwrap();
            let p = (x_meas_base * x * probe).translation.vector
                + Vector3::from_fn(|_, _| noise.sample(&mut rng));
            Measurement::new(q, p)
        })
        .collect();
    let mut set = MeasurementSet::new("ur10", poses).unwrap();
    set.set_nominal_target(Isometry3::translation(0.01, -0.02, 0.149));
    let options = CalibrationOptions::default();
    let single = calibrate(&model, &set, &options).unwrap();
    // The same poses, the target named: a set of (one) named target.
    let probe = Target {
        name: "probe".into(),
        ..set.targets()[0].clone()
    };
    let multi_set = MeasurementSet::from_poses("ur10", vec![probe], set.poses().to_vec()).unwrap();
    let multi = calibrate(&model, &multi_set, &options).unwrap();
    println!(
        "one target: {:.5} mm RMS, rank {}; as a target set: {:.5} mm RMS, rank {}",
        single.training_after.position_rms * 1e3,
        single.rank(),
        multi.training_after.position_rms * 1e3,
        multi.rank()
    );
    // The same model of the same data: the same fit, up to which of the
    // exactly dependent unknowns each leaves at nominal.
    let relative = (single.training_after.position_rms - multi.training_after.position_rms).abs()
        / single.training_after.position_rms;
    assert!(relative < 0.02, "{relative}");
    // The probe's identified position, in the end frame, agrees to well
    // within the noise.
    let multi_point = multi.targets[0].offset;
    let single_point = single.x_tcp_target().translation.vector;
    assert!(
        (multi_point - single_point).norm() < 0.02e-3,
        "{multi_point:?} vs {single_point:?}"
    );
    // The same predicted accuracy: at configurations spread over the
    // joints, the identification's uncertainty of the predicted position
    // and the 95 % bound agree pose by pose (the two fits leave different
    // exactly dependent unknowns at nominal, which changes no prediction).
    let grid: Vec<Vec<f64>> = (0..25)
        .map(|_| (0..6).map(|_| rng.random_range(-2.5..2.5)).collect())
        .collect();
    let one = single.predicted_accuracy(&model, &grid, None).unwrap();
    let several = multi.predicted_accuracy(&model, &grid, None).unwrap();
    assert_eq!(several.poses.len(), grid.len());
    let mut worst = (0.0f64, 0.0f64);
    for (a, b) in one.poses.iter().zip(&several.poses) {
        assert_eq!(
            (a.pose.as_str(), b.target.as_deref()),
            (b.pose.as_str(), Some("probe"))
        );
        let relative = |x: f64, y: f64| (x - y).abs() / x;
        worst.0 = worst
            .0
            .max(relative(a.model_uncertainty_mm, b.model_uncertainty_mm));
        worst.1 = worst.1.max(relative(a.bound_95_mm, b.bound_95_mm));
        for i in 0..3 {
            assert!(
                (a.position_mm[i] - b.position_mm[i]).abs() < 0.01,
                "{a:?}\n{b:?}"
            );
        }
    }
    println!(
        "one target: mean 95 % bound {:.5} mm; as a target set: {:.5} mm; largest relative difference, model uncertainty {:.3}, bound {:.3}",
        one.mean_bound_95_mm, several.mean_bound_95_mm, worst.0, worst.1
    );
    assert!(worst.0 < 0.05 && worst.1 < 0.02, "{worst:?}");
}

/// Predicted accuracy with two markers, where the model is the truth's
/// (geometry only, Gaussian noise): the split-half check of the predicted
/// positions finds the covariance right (ratio near 1), and the validation
/// observations' errors lie within their predicted 95 % bounds about 95 %
/// of the time. On a grid each configuration has one entry per marker, in
/// the file's order, and the CSV names the marker.
#[test]
fn predicted_bounds_of_two_markers_cover_their_validation_errors() {
    use flexcal_calib::{CrossCheck, SplitCheck};
    let model = robot();
    let targets = read_targets(&data_file("two_arms_targets.toml")).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(0x6163_6375);
    let nominal: Vec<Vector3<f64>> = targets.iter().map(|t| t.offset).collect();
    let truth = truth(&model, &nominal, &mut rng);
    let set = measure(&model, &truth, &targets, 160, &mut rng);
    let validation = measure(&model, &truth, &targets, 400, &mut rng);
    let options = CalibrationOptions::default();
    let calibration = calibrate(&model, &set, &options).unwrap();
    let split = SplitCheck::new(&model, &set, &options, &calibration).unwrap();
    let ratio = split.prediction_ratio.unwrap();
    let map = calibration
        .accuracy_coverage(&model, &validation, Some(&split))
        .unwrap();
    let coverage = map.coverage.unwrap();
    println!(
        "split-half ratio of the predicted positions {ratio:.3} (median over unknowns {:?}); {} observations, {:.1} % within their 95 % bound (mean bound {:.4} mm, residual scatter {:.4} mm per axis)",
        split.notes().first(),
        map.poses.len(),
        100.0 * coverage,
        map.mean_bound_95_mm,
        map.residual_scatter_mm
    );
    // A validation report of another set is refused by name.
    let report = calibration
        .validate(&model, &validation, Refit::Frames)
        .unwrap();
    let err = calibration
        .accuracy_coverage_of(&model, &set, &report, None)
        .unwrap_err()
        .to_string();
    assert!(err.contains("validation report of"), "{err}");
    // The target offsets are re-fitted for one target per pose only:
    // refused by the option's name.
    let err = calibration
        .validate(&model, &validation, Refit::FramesAndTarget)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("refit") && err.contains("one target per pose"),
        "{err}"
    );
    // Per-target figures: each target's observations counted once.
    let per_target: usize = report
        .per_target_after
        .iter()
        .map(|t| t.statistics.n_poses)
        .sum();
    assert_eq!(per_target, validation.n_observations());
    assert_eq!(report.per_target_after.len(), targets.len());
    // Every observation once, labelled by pose and marker.
    assert_eq!(map.poses.len(), validation.n_observations());
    assert!(map.poses.iter().all(|p| p.actual_error_mm.is_some()));
    assert!(map.poses.iter().all(|p| {
        targets
            .iter()
            .any(|t| Some(t.name.as_str()) == p.target.as_deref())
    }));
    // Independent errors and the truth's model: the halves differ as the
    // covariance says. With two splits of some sixty unknowns the ratio
    // stays within 0.5 - 2 by chance; a covariance off by its scale would
    // not.
    assert!((0.5..2.0).contains(&ratio), "{ratio}");
    // 95 % bounds: the share of 700-odd observations within them has a
    // binomial spread of 0.8 %; the frame fitted again on the validation
    // set takes a little of each error, so the share may sit above 95 %.
    assert!((0.92..0.985).contains(&coverage), "{coverage}");
    // The residual scatter is the noise's (0.02 mm per axis).
    assert!(
        (map.residual_scatter_mm - NOISE * 1e3).abs() < 0.1 * NOISE * 1e3,
        "{}",
        map.residual_scatter_mm
    );

    // The cross-series check: another campaign of the same robot agrees on
    // every unknown (|z| of a standard normal: median 0.67); a campaign of
    // a robot whose left forearm is 0.3 mm longer (about 100 standard
    // errors) is named for that length.
    let cross = CrossCheck::new(&model, &validation, &options, &calibration, Some(&split)).unwrap();
    let mut z: Vec<f64> = cross
        .unknowns
        .iter()
        .filter_map(|u| u.judged_z().map(f64::abs))
        .collect();
    z.sort_by(f64::total_cmp);
    println!(
        "cross-series check, same robot: median |z| {:.2}, largest {:.2}, over {} unknowns",
        z[z.len() / 2],
        z[z.len() - 1],
        z.len()
    );
    assert!(z.len() > 30 && z[z.len() / 2] < 1.2, "{z:?}");
    assert!(cross.disagreeing().count() <= 1, "{:?}", cross.notes());
    let mut changed = truth.clone();
    changed.xi[model.param_index("dL3").unwrap()] += 0.3e-3;
    let other = measure(&model, &changed, &targets, 200, &mut rng);
    let cross = CrossCheck::new(&model, &other, &options, &calibration, Some(&split)).unwrap();
    let named: Vec<&str> = cross.disagreeing().map(|u| u.name.as_str()).collect();
    println!("cross-series check, left forearm 0.3 mm longer: {named:?}");
    assert!(named.contains(&"dL3"), "{:?}", cross.notes());

    // A grid: one entry per configuration and marker.
    let grid: Vec<Vec<f64>> = set.poses()[..5].iter().map(|p| p.q.clone()).collect();
    let grid_map = calibration
        .predicted_accuracy(&model, &grid, Some(&split))
        .unwrap();
    assert_eq!(grid_map.poses.len(), 2 * grid.len());
    assert_eq!(grid_map.extrapolated_poses, 0);
    for (k, entry) in grid_map.poses.iter().enumerate() {
        assert_eq!(entry.pose, format!("row {}", k / 2 + 1));
        assert_eq!(entry.target.as_deref(), Some(targets[k % 2].name.as_str()));
        assert!(entry.actual_error_mm.is_none());
        assert!(entry.bound_95_mm >= CHI2_3_95.sqrt() * grid_map.residual_scatter_mm);
    }
    let csv = grid_map.to_csv_string();
    let mut lines = csv.lines();
    assert!(
        lines.next().unwrap().starts_with("pose,target,q1,"),
        "{csv}"
    );
    assert!(
        lines
            .next()
            .unwrap()
            .starts_with(&format!("row 1,{},", targets[0].name))
    );
    assert_eq!(csv.lines().count(), 1 + 2 * grid.len());
}

/// The spread reference with two markers: poses spread over every joint's
/// range determine each identified robot parameter about as well as the
/// reference does (ratio below 10); poses that hold the left elbow within
/// +-0.05 rad see some of the left arm's parameters only in combinations
/// that hold near that elbow angle, and the notes name them, while the
/// right arm stays determined.
#[test]
fn poses_that_hold_an_elbow_still_are_named_by_the_spread_ratio() {
    let model = robot();
    let targets = read_targets(&data_file("two_arms_targets.toml")).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(0x7370_7264);
    let nominal: Vec<Vector3<f64>> = targets.iter().map(|t| t.offset).collect();
    let truth = truth(&model, &nominal, &mut rng);
    let options = CalibrationOptions::default();
    let ratios = |calibration: &Calibration, prefix: &str| -> Vec<(String, f64)> {
        calibration
            .unknowns
            .iter()
            .take(model.n_params())
            .filter(|u| u.name.contains(prefix))
            .filter_map(|u| u.spread_ratio.map(|r| (u.name.clone(), r)))
            .collect()
    };
    let spread_set = measure(&model, &truth, &targets, 120, &mut rng);
    let spread = calibrate(&model, &spread_set, &options).unwrap();
    let all = ratios(&spread, "");
    assert!(all.len() > 20, "{all:?}");
    let largest = all.iter().map(|(_, r)| *r).fold(0.0, f64::max);
    println!(
        "spread poses: largest spread ratio {largest:.1} over {} parameters",
        all.len()
    );
    assert!(largest < 10.0, "{all:?}");
    // The left elbow (the left arm's third joint) held within +-0.05 rad.
    let elbow = model
        .actuated_names()
        .iter()
        .position(|n| n == "thetaL3")
        .unwrap();
    let limits = model.actuated_limits().to_vec();
    let held_set = measure_with(&model, &truth, &targets, 120, &mut rng, |rng| {
        limits
            .iter()
            .enumerate()
            .map(|(i, &(lo, hi))| {
                if i == elbow {
                    rng.random_range(-0.05..0.05)
                } else {
                    rng.random_range(lo..hi)
                }
            })
            .collect()
    });
    let held = calibrate(&model, &held_set, &options).unwrap();
    let left = ratios(&held, "L");
    let right = ratios(&held, "R");
    println!("left elbow held: left arm {left:?}; right arm {right:?}");
    assert!(left.iter().any(|(_, r)| *r > 10.0), "{left:?}");
    assert!(right.iter().all(|(_, r)| *r < 10.0), "{right:?}");
    let notes = held.identifiability_notes();
    let note = notes
        .iter()
        .find(|n| n.starts_with("determined more than 10 times less precisely"))
        .unwrap_or_else(|| panic!("{notes:#?}"));
    assert!(note.contains("L"), "{note}");
    // Validated on the spread poses, the held robot is told where it
    // extrapolates: the left elbow, on every spread pose outside the held
    // poses' range of it.
    let validation = held.validate(&model, &spread_set, Refit::Frames).unwrap();
    let (lo, hi) = held_set
        .poses()
        .iter()
        .map(|p| p.q[elbow])
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    let outside = spread_set
        .poses()
        .iter()
        .filter(|p| p.q[elbow] < lo || p.q[elbow] > hi)
        .count();
    println!(
        "validation on spread poses, outside the held poses' range: {:?}",
        validation.extrapolated_coordinates
    );
    let (name, share) = validation
        .extrapolated_coordinates
        .iter()
        .cloned()
        .fold((String::new(), 0.0), |a, b| if b.1 > a.1 { b } else { a });
    assert_eq!(name, "thetaL3");
    assert!(outside > 100, "{outside}");
    assert!((share - outside as f64 / 120.0).abs() < 1e-12, "{share}");
}

/// Two stations: the tracker measured the two-armed robot from one place,
/// then from another 4 m away and turned (a second placement to see the
/// markers the first could not). One identification fits the robot, the
/// markers' offsets and a measurement frame per station: every identified
/// combination within 3 standard errors of the truth, the second
/// station's frame relative to the first's as placed, and the pooled
/// model predicts a third campaign from the first station at the noise.
#[test]
fn two_stations_each_with_its_frame_recover_the_truth() {
    let model = robot();
    let targets = read_targets(&data_file("two_arms_targets.toml")).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(0x7374_6174);
    let nominal: Vec<Vector3<f64>> = targets.iter().map(|t| t.offset).collect();
    let truth = truth(&model, &nominal, &mut rng);
    let mut moved = truth.clone();
    moved.x_meas_base = Isometry3::from_parts(
        Translation3::new(-1.8, 2.2, -0.7),
        rotation_from_vector(&Vector3::new(-0.05, 0.1, -1.2)),
    );
    let first = measure(&model, &truth, &targets, 60, &mut rng);
    let second = measure(&model, &moved, &targets, 60, &mut rng);
    let set = MeasurementSet::pooled(&[first, second]).unwrap();
    assert_eq!(set.n_stations(), 2);
    assert_eq!(set.poses()[60].pose_id.as_deref(), Some("s2:p0"));
    let options = CalibrationOptions::default();
    let calibration = calibrate(&model, &set, &options).unwrap();
    assert_eq!(calibration.station_frames.len(), 1);
    // The truth of every unknown but the second frame's increments (its
    // start is a registration not kept), which no robot combination holds.
    let mut x_true = true_unknowns(&calibration, &truth, &targets);
    let s2: Vec<usize> = (0..calibration.unknowns.len())
        .filter(|&j| calibration.unknowns[j].name.starts_with("frame_s2_"))
        .collect();
    assert_eq!(s2.len(), 6);
    for &j in &s2 {
        x_true.insert(j, calibration.unknowns[j].value);
    }
    x_true.truncate(calibration.unknowns.len());
    let mut worst = 0.0f64;
    for (name, true_value, identified, se) in calibration.combination_check(&x_true) {
        if name.starts_with("frame_s2_") {
            continue;
        }
        let z = (identified - true_value) / se.unwrap();
        worst = worst.max(z.abs());
        assert!(z.abs() < 3.0, "{name}: z {z:.2}");
    }
    // The base parameters the frames absorb are the same in both, so the
    // second frame relative to the first is the placements' relative pose.
    let relative = calibration.station_frames[0] * calibration.x_meas_base.inverse();
    let true_relative = moved.x_meas_base * truth.x_meas_base.inverse();
    let dt = (relative.translation.vector - true_relative.translation.vector).norm();
    let dr = relative.rotation.angle_to(&true_relative.rotation);
    println!(
        "two stations, {} observations: rank {} of {}, largest |z| {worst:.2}; second frame relative to the first off by {:.4} mm, {:.2} urad",
        calibration.n_observations,
        calibration.rank(),
        calibration.unknowns.len(),
        dt * 1e3,
        dr * 1e6
    );
    // Within 3 standard errors of the two frames, taken as independent
    // (their common base-parameter part cancels in the relative pose, which
    // only makes this bound looser): the rotations' and, for the
    // translation, the first frame's rotation carried over its distance.
    let se = |prefix: &str| -> f64 {
        calibration
            .unknowns
            .iter()
            .filter(|u| u.name.starts_with(prefix))
            .map(|u| u.standard_error.unwrap_or(0.0).powi(2))
            .sum::<f64>()
    };
    let se_rotation = (se("frame_r") + se("frame_s2_r")).sqrt();
    let se_translation = (se("frame_x")
        + se("frame_y")
        + se("frame_z")
        + se("frame_s2_x")
        + se("frame_s2_y")
        + se("frame_s2_z")
        + (se_rotation * calibration.x_meas_base.translation.vector.norm()).powi(2))
    .sqrt();
    println!(
        "relative pose bounds (3 standard errors): {:.4} mm, {:.2} urad",
        3e3 * se_translation,
        3e6 * se_rotation
    );
    assert!(
        dt < 3.0 * se_translation && dr < 3.0 * se_rotation,
        "{dt:e} m, {dr:e} rad"
    );
    // A third campaign from the first placement, the frame kept: at the
    // noise (mean norm of three axes of 0.02 mm: 0.032 mm).
    let third = measure(&model, &truth, &targets, 40, &mut rng);
    let validation = calibration
        .validate(&model, &third, Refit::Nothing)
        .unwrap();
    assert!(
        validation.after.position_mean < 0.045e-3,
        "{:?}",
        validation.after
    );
    // Each station held out: the robot calibrated on the other placement
    // predicts it at the noise, its frame fitted again.
    let none = flexcal_calib::SelectionOptions {
        method: flexcal_calib::SelectionMethod::None,
        ..Default::default()
    };
    let held = flexcal_calib::hold_out_stations(&model, &set, &options, &none).unwrap();
    assert_eq!(held.len(), 2);
    for h in &held {
        println!(
            "station {} held out: mean {:.4} mm ({:.3} mm with the nominal robot)",
            h.station,
            h.after.position_mean * 1e3,
            h.before.position_mean * 1e3
        );
        assert!(h.after.position_mean < 0.045e-3, "{h:?}");
    }
    // The pooled set's CSV keeps the stations.
    let text = set.to_csv_string();
    assert!(text.lines().next().unwrap().ends_with(",station"), "{text}");
    let back = MeasurementSet::from_targets_csv_str(&text, "back", &targets).unwrap();
    assert_eq!(back.n_stations(), 2);
    assert_eq!(back.station_of(60), 1);
    assert_eq!(back.station_names(), set.station_names());
}

/// Validation treats the measurement frame the same way for several
/// targets as for one: a frame the identification kept fixed stays fixed;
/// a frame re-fitted on a validation set measured from the same placement
/// comes back to the true one within what the noise allows (the re-fit
/// starts from a closed-form registration of the set's own poses); and the
/// offset of a set's single named target may be re-fitted with it.
#[test]
fn validation_keeps_a_fixed_frame_and_refits_a_free_one_with_several_targets() {
    let model = robot();
    let targets = read_targets(&data_file("two_arms_targets.toml")).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(0x6672_616d);
    let nominal: Vec<Vector3<f64>> = targets.iter().map(|t| t.offset).collect();
    let truth = truth(&model, &nominal, &mut rng);
    let set = measure(&model, &truth, &targets, 80, &mut rng);
    let validation = measure(&model, &truth, &targets, 40, &mut rng);

    // The frame known and kept: validation keeps it, whatever is asked.
    let fixed = CalibrationOptions {
        measurement_frame: FrameTreatment::Fixed,
        measurement_frame_value: Some(truth.x_meas_base),
        ..CalibrationOptions::default()
    };
    let calibration = calibrate(&model, &set, &fixed).unwrap();
    let report = calibration
        .validate(&model, &validation, Refit::Frames)
        .unwrap();
    assert!(!report.frame_refitted, "{}", report.frame_note);
    assert!(report.frame_note.contains("fixed"), "{}", report.frame_note);
    assert_eq!(report.measurement_frame, truth.x_meas_base);

    // The frame identified, then re-fitted on the validation set.
    let calibration = calibrate(&model, &set, &CalibrationOptions::default()).unwrap();
    let report = calibration
        .validate(&model, &validation, Refit::Frames)
        .unwrap();
    assert!(report.frame_refitted, "{}", report.frame_note);
    // Measured from the placement the calibration identified its frame
    // at: the re-fit finds that frame again, to what 0.02 mm noise on 80
    // observations allows (micrometres at the robot).
    let moved = calibration.x_meas_base.inverse() * report.measurement_frame;
    assert!(
        moved.translation.vector.norm() < 0.05e-3,
        "re-fitted frame {moved:?} off the identified one"
    );
    assert!(moved.rotation.angle() < 2e-5, "{moved:?}");
    // The re-fit is a least-squares optimum: the frame the calibration
    // identified is no better on the validation set.
    let kept = calibration
        .validate(&model, &validation, Refit::Nothing)
        .unwrap();
    let ssr = |r: &flexcal_calib::ValidationReport| -> f64 {
        r.after_per_pose.iter().map(|e| e.position.powi(2)).sum()
    };
    assert!(ssr(&report) <= ssr(&kept) * (1.0 + 1e-9));

    // One named target: its offset is re-fitted with the frame when asked.
    let left = vec![targets[0].clone()];
    let one = |set: &MeasurementSet| -> MeasurementSet {
        let poses = set
            .poses()
            .iter()
            .filter(|p| p.observations[0].is_some())
            .map(|p| {
                TargetPose::new(
                    p.pose_id.clone(),
                    p.q.clone(),
                    vec![p.observations[0].clone()],
                )
            })
            .collect();
        MeasurementSet::from_poses("left marker", left.clone(), poses).unwrap()
    };
    let calibration = calibrate(&model, &one(&set), &CalibrationOptions::default()).unwrap();
    let frames = calibration
        .validate(&model, &one(&validation), Refit::Frames)
        .unwrap();
    let with_target = calibration
        .validate(&model, &one(&validation), Refit::FramesAndTarget)
        .unwrap();
    assert!(
        with_target
            .frame_note
            .contains("and target offset re-fitted")
    );
    assert!(ssr(&with_target) <= ssr(&frames) * (1.0 + 1e-9));
}
