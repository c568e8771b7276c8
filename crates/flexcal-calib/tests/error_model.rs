//! The stacked error model: exact Jacobian against central differences,
//! identification of a simulated serial robot with free frames, masks.

use flexcal_calib::{
    CalibError, CalibrationOptions, ErrorModel, FrameTreatment, Measurement, MeasurementSet, Refit,
    TCP_TARGET, UnknownStatus, calibrate, rotation_from_vector, vector_from_rotation,
};
use flexcal_kinematics::{Data, Model, RobotDescription, forward_pose};
use nalgebra::{Isometry3, Point3, Translation3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

mod common;

use faer::Mat;

fn random_q(rng: &mut ChaCha8Rng, n: usize) -> Vec<f64> {
    (0..n).map(|_| rng.random_range(-2.0..2.0)).collect()
}

/// Simulated measurements of `truth` seen from `x_meas_base` with target `x_tcp_target`.
fn simulate(
    model: &Model,
    truth: &[f64],
    x_meas_base: &Isometry3<f64>,
    x_tcp_target: &Isometry3<f64>,
    n: usize,
    orientation: bool,
    seed: u64,
) -> MeasurementSet {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut data = Data::new(model);
    let measurements = (0..n)
        .map(|_| {
            let q = random_q(&mut rng, model.n_actuated());
            let x = x_meas_base * forward_pose(model, &mut data, &q, truth).unwrap() * x_tcp_target;
            let mut m = Measurement::new(q, x.translation.vector);
            if orientation {
                m.orientation = Some(vector_from_rotation(&x.rotation));
            }
            m
        })
        .collect();
    MeasurementSet::new("simulated", measurements).unwrap()
}

#[test]
fn jacobian_matches_central_differences() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    for robot in ["ur10", "ir663"] {
        let model = RobotDescription::builtin(robot).unwrap().build().unwrap();
        let (frame, target) = common::generic_frame_and_target();
        let set = if robot == "ir663" {
            // Configurations the four-bar can close: around the working start.
            let start = flexcal_kinematics::actuated_from_joint_angles(
                &model,
                &[0.0, -0.5, 0.4, 0.8, 1.6, 0.0],
            )
            .unwrap();
            let mut data = Data::new(&model);
            let ms = (0..4)
                .map(|k| {
                    let mut q = start.clone();
                    q[0] += 0.1 * k as f64;
                    q[3] += 0.2 * k as f64;
                    q[5] -= 0.3 * k as f64;
                    let x = frame
                        * forward_pose(&model, &mut data, &q, model.nominal_params()).unwrap();
                    let mut m =
                        Measurement::new(q, x.translation.vector + Vector3::new(1e-3, 0.0, -2e-3));
                    m.orientation = Some(vector_from_rotation(&x.rotation) * 1.01);
                    m
                })
                .collect();
            MeasurementSet::new("ir663", ms).unwrap()
        } else {
            simulate(&model, model.nominal_params(), &frame, &target, 4, true, 3)
        };
        let problem = ErrorModel::one_target(&model, &set, true, frame, target).unwrap();
        let mut x = problem.initial_unknowns();
        // Away from zero so the frame Jacobians' exp-map terms are exercised.
        for v in x[model.n_params()..].iter_mut() {
            *v = rng.random_range(-0.05..0.05);
        }
        common::assert_jacobian_matches(robot, &problem, &x, &|_| 1e-6, &|_, fd| {
            1e-6 * (1.0 + fd.abs())
        });
    }
}

#[test]
fn identifies_a_serial_robot_with_unknown_frames_exactly() {
    let model = RobotDescription::builtin("ur10").unwrap().build().unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    let truth = common::perturbed_geometry(&model, &mut rng, 1e-3, 2e-3);
    let frame = Isometry3::from_parts(
        Translation3::new(0.4, -3.2, 0.1),
        rotation_from_vector(&Vector3::new(0.0, 0.1, 1.5)),
    );
    let target = Isometry3::from_parts(Translation3::new(0.0, 0.001, 0.109), Default::default());
    let set = simulate(&model, &truth, &frame, &target, 60, false, 5);
    let validation = simulate(&model, &truth, &frame, &target, 30, false, 6);
    let mut options = CalibrationOptions::for_model(&model);
    options.target_value = Some(Isometry3::from_parts(
        Translation3::new(0.0, 0.0, 0.108),
        Default::default(),
    ));
    let calibration = calibrate(&model, &set, &options).unwrap();
    assert!(
        calibration.solve.termination.is_converged(),
        "{:?}",
        calibration.solve.termination
    );
    assert!(
        calibration.training_after.position_max < 1e-9,
        "{:?}",
        calibration.training_after
    );
    assert!(calibration.training_before.position_mean > 1e-4);
    // The base-frame parameters are taken by the measurement frame.
    let non_identifiable = calibration.non_identifiable();
    assert!(
        non_identifiable.contains(&"theta1") && non_identifiable.contains(&"r1"),
        "{non_identifiable:?}"
    );
    let report = calibration.validate(&model, &validation, false).unwrap();
    assert!(report.after.position_max < 1e-8, "{:?}", report.after);
    assert!(report.before.position_mean > 1e-4);
    // One target per pose is the case of one target named `tcp`: its
    // figures are the whole set's, every observation labelled.
    assert_eq!(report.per_target_after.len(), 1);
    assert_eq!(report.per_target_after[0].target, TCP_TARGET);
    assert_eq!(report.per_target_after[0].statistics, report.after);
    assert_eq!(report.per_target_before[0].statistics, report.before);
    assert_eq!(report.observation_errors.len(), validation.n_observations());
    assert!(report.frame_refitted);
    // The validation set was measured from the identification's frame:
    // kept as identified, it fits as exactly as the re-fitted one.
    let same = calibration
        .validate(&model, &validation, Refit::Nothing)
        .unwrap();
    assert!(!same.frame_refitted);
    assert_eq!(same.measurement_frame, calibration.x_meas_base);
    assert!(same.after.position_max < 1e-8, "{:?}", same.after);
    assert!(same.before.position_mean > 1e-4);
    // Gauss-Newton reaches the same fit.
    options.method = flexcal_calib::Method::GaussNewton;
    let gn = calibrate(&model, &set, &options).unwrap();
    assert!(gn.training_after.position_max < 1e-9);
    // The calibrated description loads back and predicts the same poses.
    let description = calibration.description(&model).unwrap();
    let text = description.to_toml_string();
    let reloaded = RobotDescription::from_toml_str(&text, "calibrated.toml")
        .unwrap()
        .build()
        .unwrap();
    let mut d1 = Data::new(&model);
    let mut d2 = Data::new(&reloaded);
    for m in validation.measurements() {
        let a = forward_pose(&model, &mut d1, &m.q, &calibration.xi).unwrap();
        let b = forward_pose(&reloaded, &mut d2, &m.q, reloaded.nominal_params()).unwrap();
        assert!((a.translation.vector - b.translation.vector).norm() < 1e-9);
        let p = calibration.x_meas_base * b * calibration.x_tcp_target() * Point3::origin();
        assert!((p.coords - m.position).norm() < 1e-8);
    }
}

#[test]
fn fixed_parameters_keep_their_values_and_orientation_is_used() {
    let model = RobotDescription::builtin("puma560")
        .unwrap()
        .build()
        .unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(8);
    let truth = common::perturbed_geometry(&model, &mut rng, 5e-4, 1e-3);
    let set = simulate(
        &model,
        &truth,
        &Isometry3::identity(),
        &Isometry3::identity(),
        25,
        true,
        9,
    );
    let mut options = CalibrationOptions::for_model(&model);
    options.measurement_frame = FrameTreatment::Fixed;
    options.target = FrameTreatment::Fixed;
    options.fixed = vec!["d3".into()];
    let calibration = calibrate(&model, &set, &options).unwrap();
    let d3 = calibration
        .unknowns
        .iter()
        .find(|u| u.name == "d3")
        .unwrap();
    assert_eq!(d3.status, UnknownStatus::Fixed);
    assert_eq!(d3.value, d3.initial);
    assert!(
        calibration
            .training_after
            .orientation_mean_rms_max
            .is_some()
    );
    // Without d3 the fit cannot be exact, but it must improve on the nominal robot.
    assert!(calibration.training_after.position_mean < calibration.training_before.position_mean);
}

#[test]
fn bad_requests_are_typed_errors() {
    let model = RobotDescription::builtin("ur10").unwrap().build().unwrap();
    let set = simulate(
        &model,
        model.nominal_params(),
        &Isometry3::identity(),
        &Isometry3::identity(),
        5,
        false,
        1,
    );
    let options = CalibrationOptions::for_model(&model);
    assert!(matches!(
        calibrate(&model, &set, &options),
        Err(CalibError::TooFewPoses { .. })
    ));
    let mut unknown = options.clone();
    unknown.fixed = vec!["d99".into()];
    assert!(matches!(
        calibrate(&model, &set, &unknown),
        Err(CalibError::UnknownParameter { .. })
    ));
    let big = simulate(
        &model,
        model.nominal_params(),
        &Isometry3::identity(),
        &Isometry3::identity(),
        40,
        false,
        2,
    );
    let mut strict = options.clone();
    strict.require_full_rank = true;
    match calibrate(&model, &big, &strict) {
        Err(CalibError::RankDeficient {
            non_identifiable, ..
        }) => assert!(!non_identifiable.is_empty()),
        other => panic!("expected RankDeficient, got {other:?}"),
    }
    let puma = RobotDescription::builtin("puma560")
        .unwrap()
        .build()
        .unwrap();
    let short = MeasurementSet::new(
        "short",
        vec![Measurement::new(vec![0.0; 5], Vector3::zeros())],
    )
    .unwrap();
    assert!(matches!(
        calibrate(&puma, &short, &options),
        Err(CalibError::ActuatedCountMismatch { .. })
    ));
}

#[test]
fn pose_selection_beats_an_arbitrary_subset() {
    use flexcal_calib::select_calibration_poses;
    use flexcal_optim::ObservabilityIndex;
    let model = RobotDescription::builtin("puma560")
        .unwrap()
        .build()
        .unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(31);
    let pool: Vec<Vec<f64>> = (0..40)
        .map(|_| random_q(&mut rng, model.n_actuated()))
        .collect();
    let chosen =
        select_calibration_poses(&model, &pool, 12, ObservabilityIndex::O1, false, &[]).unwrap();
    assert_eq!(chosen.selection.selected.len(), 12);
    assert!(chosen.selection.indices.o1 >= chosen.selection.greedy_value * (1.0 - 1e-12));
    // O1 ranks subsets the same under any column scaling (it scales by a
    // constant), so compare with unscaled columns of the base parameters.
    let columns: Vec<usize> = chosen
        .parameters
        .iter()
        .map(|n| model.param_index(n).unwrap())
        .collect();
    let o1 = |rows: &[usize]| {
        let mut data = Data::new(&model);
        let mut stacked = Mat::<f64>::zeros(3 * rows.len(), columns.len());
        for (k, &r) in rows.iter().enumerate() {
            let (_, jac) = flexcal_kinematics::param_jacobian(
                &model,
                &mut data,
                &pool[r],
                model.nominal_params(),
            )
            .unwrap();
            for i in 0..3 {
                for (c, &j) in columns.iter().enumerate() {
                    stacked[(3 * k + i, c)] = jac[(i, j)];
                }
            }
        }
        flexcal_optim::observability_indices(
            stacked.as_ref(),
            &flexcal_optim::ColumnScaling::Identity,
        )
        .unwrap()
        .o1
    };
    let first: Vec<usize> = (0..12).collect();
    let last: Vec<usize> = (28..40).collect();
    let selected = o1(&chosen.selection.selected);
    assert!(
        selected >= o1(&first) && selected >= o1(&last),
        "{selected} vs {} and {}",
        o1(&first),
        o1(&last)
    );
    let bad = vec![vec![0.0; 3]];
    assert!(select_calibration_poses(&model, &bad, 1, ObservabilityIndex::O1, false, &[]).is_err());
}

/// Orientations measured, the probe turned by a quarter turn about the tool
/// axis against the nominal offset it starts from (as the IPA T-Mac is
/// against its nominal transform): the target's orientation is registered
/// from the data first, and the identification reaches the exact fit. A
/// fixed target keeps its nominal orientation.
#[test]
fn target_orientation_starts_where_the_data_put_it() {
    let model = RobotDescription::builtin("ur10").unwrap().build().unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(31);
    let truth = common::perturbed_geometry(&model, &mut rng, 0.5e-3, 1e-3);
    let (frame, _) = common::generic_frame_and_target();
    let quarter = |sign: f64| {
        Isometry3::from_parts(
            Translation3::new(0.0, 0.0, 0.109),
            rotation_from_vector(&Vector3::new(0.0, 0.0, sign * std::f64::consts::FRAC_PI_2)),
        )
    };
    let set = simulate(&model, &truth, &frame, &quarter(-1.0), 60, true, 8);
    let mut options = CalibrationOptions::for_model(&model);
    options.use_orientation = Some(true);
    let mut nominal_set = set.clone();
    nominal_set.set_nominal_target(quarter(1.0));
    let calibration = calibrate(&model, &nominal_set, &options).unwrap();
    assert!(
        calibration.training_after.position_max < 1e-9
            && calibration
                .training_after
                .orientation_mean_rms_max
                .unwrap()
                .2
                < 1e-9,
        "{:?}",
        calibration.training_after
    );
    // The right quarter turn; what is left of it (0.15 mrad) is a turn
    // about the tool axis, which theta6 takes (their sum is what the
    // poses identify).
    let off = calibration.x_tcp_target().rotation.inverse() * quarter(-1.0).rotation;
    assert!(
        off.angle() < 1e-3,
        "target orientation off by {} rad",
        off.angle()
    );
    let axis = off.axis().unwrap();
    assert!(axis.z.abs() > 1.0 - 1e-6, "{axis:?}");
    // Fixed, the target stays at the nominal turn and the fit cannot close.
    options.target = FrameTreatment::Fixed;
    let fixed = calibrate(&model, &nominal_set, &options).unwrap();
    assert_eq!(fixed.x_tcp_target().rotation, quarter(1.0).rotation);
    assert!(fixed.training_after.orientation_mean_rms_max.unwrap().0 > 1.0);
}

/// A tool offset the user did not give (the target starts at the flange,
/// 11 cm from where it is): the frames are fitted by the exact rank before
/// the noise level is taken, so the poor start's residuals do not pass for
/// noise, and the calibration identifies as much as when the offset is
/// given.
#[test]
fn a_tool_offset_not_given_is_found_from_the_flange() {
    let model = RobotDescription::builtin("ur10").unwrap().build().unwrap();
    let (frame, target) = common::generic_frame_and_target();
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    let truth = common::perturbed_geometry(&model, &mut rng, 5e-4, 1e-3);
    let mut set = simulate(&model, &truth, &frame, &target, 30, false, 22);
    let noise = rand_distr::Normal::new(0.0, 20e-6).unwrap();
    let measurements: Vec<Measurement> = set
        .measurements()
        .into_iter()
        .map(|mut m| {
            m.position +=
                Vector3::from_fn(|_, _| rand_distr::Distribution::sample(&noise, &mut rng));
            m
        })
        .collect();
    set = MeasurementSet::new("simulated", measurements).unwrap();
    let given = calibrate(
        &model,
        &set,
        &CalibrationOptions {
            target_value: Some(target),
            ..CalibrationOptions::default()
        },
    )
    .unwrap();
    let found = calibrate(&model, &set, &CalibrationOptions::default()).unwrap();
    println!(
        "tool offset given: rank {}, {:.4} mm RMS; not given: rank {}, {:.4} mm RMS",
        given.rank(),
        given.training_after.position_rms * 1e3,
        found.rank(),
        found.training_after.position_rms * 1e3
    );
    assert_eq!(found.rank(), given.rank());
    // Three axes of 0.02 mm noise, less what the fit absorbs.
    assert!(
        found.training_after.position_rms < 0.04e-3,
        "{:?}",
        found.training_after
    );
    let offset = found.x_tcp_target().translation.vector;
    assert!(
        (offset - given.x_tcp_target().translation.vector).norm() < 1e-6,
        "{offset}"
    );
}
