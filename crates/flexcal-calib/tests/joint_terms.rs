//! The joint terms beyond linear springs (the non-linear stiffness law and
//! cyclic joint errors): exact Jacobian against central differences, and
//! identification of known terms on a simulated UR10 whose measurements
//! are computed independently of the calibration code (the spring
//! equilibrium by Newton's method, the gravity torques by virtual work).

use flexcal_calib::{
    CalibrationOptions, ErrorModel, FrameTreatment, GravityCompliance, JointLaw, JointTerms,
    MeasurementSet, UnknownStatus, Weighting, calibrate, rotation_from_vector,
};
use flexcal_kinematics::{Model, RobotDescription};
use nalgebra::{Isometry3, Translation3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;

mod common;

fn ur10() -> Model {
    RobotDescription::builtin("ur10").unwrap().build().unwrap()
}

/// The simulated robot's joints: compliance (rad/N.m), hardening (1/rad),
/// lost motion (rad), cyclic amplitudes `[sin q, cos q, sin 2q, cos 2q]`
/// (rad), per joint.
struct Joints {
    compliance: [f64; 6],
    hardening: [f64; 6],
    lost_motion: [f64; 6],
    cyclic: [[f64; 4]; 6],
}

/// Sources of the magnitudes: a UR10's joint-2 compliance of 10-15
/// urad/N.m (the IPA series identify 9-15); strain-wave gear catalogues
/// give a stiffness rising about threefold from the first to the last
/// torque segment, i.e. a hardening of a few hundred 1/rad at the
/// milliradian deflections of the shoulder; a lost motion of 0.1 mrad
/// (20 arcsec, a typical catalogue value) on the shoulder and elbow;
/// encoder eccentricity errors of 10-50 urad (a few arcsec), on the base
/// and wrist-1 joints (drawn over a full turn).
fn joints() -> Joints {
    Joints {
        compliance: [0.0, 13e-6, 10e-6, 20e-6, 15e-6, 10e-6],
        hardening: [0.0, 400.0, 0.0, 0.0, 0.0, 0.0],
        lost_motion: [0.0, 1e-4, 0.0, 0.0, 0.0, 0.0],
        cyclic: [
            [4e-5, -3e-5, 0.0, 0.0],
            [0.0; 4],
            [0.0; 4],
            [0.0, 0.0, 2e-5, 0.0],
            [0.0; 4],
            [0.0; 4],
        ],
    }
}

/// Measurements of a UR10 whose joints follow `joints` under gravity (the
/// spring equilibrium by Newton's method), with the payload of `gravity`;
/// Gaussian noise `noise` (m) per axis.
#[allow(clippy::too_many_arguments)]
fn simulate(
    model: &Model,
    gravity: &GravityCompliance,
    xi: &[f64],
    joints: &Joints,
    frame: &Isometry3<f64>,
    n: usize,
    noise: f64,
    seed: u64,
) -> MeasurementSet {
    let simulation = common::GravitySimulation {
        model,
        gravity,
        xi,
        payload: (gravity.payload_mass, gravity.payload_center),
        frame: *frame,
        noise,
    };
    let lost_motion_torque = JointLaw::default().lost_motion_torque;
    simulation.measure(
        n,
        seed,
        "simulated ur10, non-linear joints",
        |rng| {
            // Joints 1 and 4 over a full turn: cyclic errors are identified
            // only over their period.
            let mut q = common::ur10_configuration(rng);
            q[0] = rng.random_range(-PI..PI);
            q[3] = rng.random_range(-PI..PI);
            q
        },
        |q, tau| {
            (0..6)
                .map(|i| {
                    let [a1, b1, a2, b2] = joints.cyclic[i];
                    q[i] + common::spring_deflection(
                        tau[i],
                        joints.compliance[i],
                        joints.hardening[i],
                    ) + joints.lost_motion[i] * (tau[i] / lost_motion_torque).tanh()
                        + a1 * q[i].sin()
                        + b1 * q[i].cos()
                        + a2 * (2.0 * q[i]).sin()
                        + b2 * (2.0 * q[i]).cos()
                })
                .collect()
        },
    )
}

#[test]
fn joint_term_columns_match_central_differences() {
    let model = ur10();
    let gravity = GravityCompliance::ur10_urdf(&model).unwrap();
    let (frame, target) = common::generic_frame_and_target();
    let set = simulate(
        &model,
        &gravity,
        model.nominal_params(),
        &joints(),
        &frame,
        6,
        0.0,
        2,
    );
    let set = common::with_orientation(&set);
    let terms = JointTerms {
        law: Some(JointLaw::default()),
        cyclic: true,
    };
    let problem = ErrorModel::one_target(&model, &set, true, frame, target)
        .unwrap()
        .with_elastic(Some(&gravity), &terms)
        .unwrap();
    let kinds = problem.kinds();
    assert_eq!(kinds.len(), problem.n_unknowns());
    let (_, jac) = common::assert_elastic_jacobian_matches(
        "ur10, non-linear joints and cyclic errors",
        &model,
        &problem,
        5,
    );
    // The new columns are not trivially zero.
    for name in [
        "hardening_theta2",
        "lost_motion_theta2",
        "cyclic_theta4_cos2",
    ] {
        let j = problem.names().iter().position(|n| n == name).unwrap();
        assert!(
            (0..jac.nrows()).any(|i| jac[(i, j)].abs() > 1e-9),
            "{name} column is zero"
        );
    }
}

#[test]
fn the_law_needs_gravity_and_bad_widths_are_named() {
    let model = ur10();
    let (frame, _) = common::generic_frame_and_target();
    let gravity = GravityCompliance::ur10_urdf(&model).unwrap();
    let set = simulate(
        &model,
        &gravity,
        model.nominal_params(),
        &joints(),
        &frame,
        40,
        0.0,
        3,
    );
    let mut options = CalibrationOptions::for_model(&model);
    options.joint_terms.law = Some(JointLaw::default());
    let error = calibrate(&model, &set, &options).unwrap_err().to_string();
    assert!(error.contains("gravity"), "{error}");
    options.gravity = Some(gravity);
    options.joint_terms.law = Some(JointLaw {
        lost_motion_torque: 0.0,
    });
    let error = calibrate(&model, &set, &options).unwrap_err().to_string();
    assert!(error.contains("lost_motion_torque"), "{error}");
}

#[test]
fn identifies_a_hardening_joint_lost_motion_and_cyclic_errors() {
    let model = ur10();
    let gravity = GravityCompliance::ur10_urdf(&model).unwrap();
    let xi = common::perturbed_geometry(&model, &mut ChaCha8Rng::seed_from_u64(17), 5e-4, 1e-3);
    let frame = Isometry3::from_parts(
        Translation3::new(0.4, -3.2, 0.1),
        rotation_from_vector(&Vector3::new(0.0, 0.05, 1.5)),
    );
    let noise = 20e-6;
    let truth = joints();
    let train = simulate(&model, &gravity, &xi, &truth, &frame, 1500, noise, 21);
    let validation = simulate(&model, &gravity, &xi, &truth, &frame, 400, noise, 22);
    let mut options = CalibrationOptions::for_model(&model);
    options.weighting = Weighting::Uniform;
    options.default_position_std = noise;
    options.target = FrameTreatment::Fixed;
    options.measurement_frame = FrameTreatment::Identify;
    options.gravity = Some(GravityCompliance {
        // The payload is known here: what is tested is the joints.
        ..gravity.clone()
    });
    options.fixed = flexcal_calib::PAYLOAD_PARAMETER_NAMES
        .iter()
        .map(|s| s.to_string())
        .collect();
    let linear = calibrate(&model, &train, &options).unwrap();
    options.joint_terms = JointTerms {
        law: Some(JointLaw::default()),
        cyclic: true,
    };
    let rich = calibrate(&model, &train, &options).unwrap();
    assert!(rich.solve.termination.is_converged());
    // The truth by name; unknowns left at their starting values stand in
    // the identified combinations (C.1) with their true deviation.
    let names = ["theta1", "theta2", "theta3", "theta4", "theta5", "theta6"];
    let true_value = |name: &str, start: f64| -> f64 {
        if let Some(j) = model.param_index(name) {
            return xi[j];
        }
        for (i, joint) in names.iter().enumerate() {
            if name == format!("compliance_{joint}") {
                return truth.compliance[i];
            }
            if name == format!("hardening_{joint}") {
                return truth.hardening[i];
            }
            if name == format!("lost_motion_{joint}") {
                return truth.lost_motion[i];
            }
            for (h, suffix) in ["sin1", "cos1", "sin2", "cos2"].iter().enumerate() {
                if name == format!("cyclic_{joint}_{suffix}") {
                    return truth.cyclic[i][h];
                }
            }
        }
        start
    };
    let truth_vector: Vec<f64> = rich
        .unknowns
        .iter()
        .map(|u| {
            if u.name.starts_with("frame_") {
                u.value
            } else {
                true_value(&u.name, u.initial)
            }
        })
        .collect();
    let mut checked = 0;
    for (name, true_combination, value, se) in rich.combination_check(&truth_vector) {
        let joint_term = ["compliance_", "hardening_", "lost_motion_", "cyclic_"]
            .iter()
            .any(|p| name.starts_with(p));
        if !joint_term {
            continue;
        }
        let se = se.unwrap();
        assert!(
            (value - true_combination).abs() < 3.0 * se,
            "{name}: identified {value} +/- {se}, true combination {true_combination}"
        );
        checked += 1;
    }
    // The terms of the truth are identified (not frozen).
    for name in [
        "hardening_theta2",
        "lost_motion_theta2",
        "cyclic_theta1_sin1",
        "cyclic_theta1_cos1",
        "cyclic_theta4_sin2",
        "compliance_theta2",
        "compliance_theta3",
    ] {
        let u = rich.unknowns.iter().find(|u| u.name == name).unwrap();
        assert_eq!(u.status, UnknownStatus::Identified, "{name}");
    }
    assert!(checked >= 15, "{checked} joint terms checked");
    // Validation reaches the noise; linear springs without cyclic terms do not.
    let noise_mean = noise * (8.0 / std::f64::consts::PI).sqrt();
    let r = rich.validate(&model, &validation, false).unwrap();
    let l = linear.validate(&model, &validation, false).unwrap();
    eprintln!(
        "validation mean: rich {:.4} mm, linear {:.4} mm (noise {:.4} mm)",
        r.after.position_mean * 1e3,
        l.after.position_mean * 1e3,
        noise_mean * 1e3
    );
    assert!(r.after.position_mean < 1.2 * noise_mean, "{:?}", r.after);
    assert!(l.after.position_mean > 1.5 * r.after.position_mean);
}

/// Model selection on a simulated UR10 whose joint 2 hardens and has lost
/// motion, without cyclic errors: cross-validation (and BIC) keep the
/// compliances and the law, reject the cyclic terms, and the chosen model
/// recovers the hardening and reaches the noise on other poses.
#[test]
fn selection_keeps_the_law_of_a_hardening_joint_and_rejects_absent_terms() {
    use flexcal_calib::{SelectionMethod, SelectionOptions, TermGroup, select_model};
    let model = ur10();
    let gravity = GravityCompliance::ur10_urdf(&model).unwrap();
    let xi = common::perturbed_geometry(&model, &mut ChaCha8Rng::seed_from_u64(31), 5e-4, 1e-3);
    let truth = Joints {
        cyclic: [[0.0; 4]; 6],
        ..joints()
    };
    let (frame, _) = common::generic_frame_and_target();
    let noise = 20e-6;
    let train = simulate(&model, &gravity, &xi, &truth, &frame, 600, noise, 41);
    let validation = simulate(&model, &gravity, &xi, &truth, &frame, 300, noise, 42);
    let mut richest = CalibrationOptions::for_model(&model);
    richest.weighting = Weighting::Uniform;
    richest.default_position_std = noise;
    richest.target = FrameTreatment::Fixed;
    richest.gravity = Some(gravity.clone());
    richest.fixed = flexcal_calib::PAYLOAD_PARAMETER_NAMES
        .iter()
        .map(|s| s.to_string())
        .collect();
    richest.joint_terms.law = Some(JointLaw::default());
    for method in [SelectionMethod::CrossValidation, SelectionMethod::Bic] {
        let selection = SelectionOptions {
            method,
            ..SelectionOptions::default()
        };
        let (report, chosen) = select_model(&model, &train, &richest, &selection).unwrap();
        for line in report.lines() {
            eprintln!("{line}");
        }
        assert!(
            report.chosen.contains(&TermGroup::Compliances),
            "{method:?}"
        );
        assert!(report.chosen.contains(&TermGroup::JointLaw), "{method:?}");
        assert!(
            !report.chosen.contains(&TermGroup::CyclicErrors),
            "{method:?}"
        );
        // Every candidate scored is in the report, the chosen one among them.
        assert!(report.candidates.iter().any(|c| c.groups == report.chosen));
        let calibration = calibrate(&model, &train, &chosen).unwrap();
        let u = calibration
            .unknowns
            .iter()
            .find(|u| u.name == "hardening_theta2")
            .unwrap();
        let se = u.standard_error.unwrap();
        assert!(
            (u.value - truth.hardening[1]).abs() < 3.0 * se,
            "hardening {} +/- {se}",
            u.value
        );
        let noise_mean = noise * (8.0 / std::f64::consts::PI).sqrt();
        let r = calibration.validate(&model, &validation, false).unwrap();
        assert!(r.after.position_mean < 1.2 * noise_mean, "{:?}", r.after);
    }
}

/// Predicted accuracy on a simulated UR10 identified with the model of its
/// truth: the 95 % bounds cover about 95 % of other measured poses, and the
/// grid form gives the same bounds as the measured form at the same poses.
#[test]
fn predicted_95_percent_bounds_cover_about_95_percent_of_new_poses() {
    let model = ur10();
    let gravity = GravityCompliance::ur10_urdf(&model).unwrap();
    let (frame, _) = common::generic_frame_and_target();
    let noise = 30e-6;
    let xi = model.nominal_params().to_vec();
    let truth = joints();
    let train = simulate(&model, &gravity, &xi, &truth, &frame, 500, noise, 51);
    let validation = simulate(&model, &gravity, &xi, &truth, &frame, 1000, noise, 52);
    let mut options = CalibrationOptions::for_model(&model);
    options.weighting = Weighting::Uniform;
    options.default_position_std = noise;
    options.target = FrameTreatment::Fixed;
    options.gravity = Some(gravity);
    options.fixed = flexcal_calib::PAYLOAD_PARAMETER_NAMES
        .iter()
        .map(|s| s.to_string())
        .collect();
    options.joint_terms = JointTerms {
        law: Some(JointLaw::default()),
        cyclic: true,
    };
    let calibration = calibrate(&model, &train, &options).unwrap();
    let map = calibration
        .accuracy_coverage(&model, &validation, None)
        .unwrap();
    let coverage = map.coverage.unwrap();
    eprintln!(
        "coverage {:.3}, mean bound {:.4} mm, scatter {:.4} mm",
        coverage, map.mean_bound_95_mm, map.residual_scatter_mm
    );
    // 1000 poses: the share's standard error is 0.7 %.
    assert!((0.92..=0.98).contains(&coverage), "{coverage}");
    // The scatter is the noise, per axis.
    assert!((map.residual_scatter_mm / (noise * 1e3) - 1.0).abs() < 0.1);
    let configurations: Vec<Vec<f64>> = validation
        .measurements()
        .iter()
        .map(|m| m.q.clone())
        .collect();
    let grid = calibration
        .predicted_accuracy(&model, &configurations, None)
        .unwrap();
    for (a, b) in grid.poses.iter().zip(&map.poses) {
        assert!((a.bound_95_mm - b.bound_95_mm).abs() < 1e-9);
        assert!(a.model_uncertainty_mm > 0.0 && a.model_uncertainty_mm < a.bound_95_mm);
    }
    let csv = grid.to_csv_string();
    assert_eq!(csv.lines().count(), 1 + configurations.len());
    assert!(csv.starts_with("pose,q1,q2,q3,q4,q5,q6,model_uncertainty_mm,bound_95_mm"));
    assert!(
        csv.lines()
            .next()
            .unwrap()
            .ends_with(",outside_training_range")
    );

    // Extrapolation is flagged per pose, as the validation counts it per
    // coordinate; a pose beyond the training range of joint 2 names it.
    let report = calibration.validate(&model, &validation, false).unwrap();
    let flagged = |name: &str| {
        map.poses
            .iter()
            .filter(|p| p.outside_training_range.iter().any(|n| n == name))
            .count()
    };
    for (name, fraction) in &report.extrapolated_coordinates {
        assert_eq!(
            flagged(name),
            (fraction * validation.len() as f64).round() as usize,
            "{name}"
        );
    }
    assert_eq!(
        map.extrapolated_poses,
        map.poses
            .iter()
            .filter(|p| !p.outside_training_range.is_empty())
            .count()
    );
    let (lo, hi) = (
        calibration.actuated_ranges[1].lo,
        calibration.actuated_ranges[1].hi,
    );
    let mut inside = configurations[0].clone();
    for (q, range) in inside.iter_mut().zip(&calibration.actuated_ranges) {
        *q = 0.5 * (range.lo + range.hi);
    }
    let mut beyond = inside.clone();
    beyond[1] = hi + 0.1 * (hi - lo);
    // The same arm pose a turn further on every joint is no extrapolation:
    // the model predicts the same bound there.
    let turned: Vec<f64> = inside.iter().map(|q| q + std::f64::consts::TAU).collect();
    let two = calibration
        .predicted_accuracy(&model, &[inside, beyond, turned], None)
        .unwrap();
    assert!(two.poses[0].outside_training_range.is_empty());
    assert!(two.poses[2].outside_training_range.is_empty());
    assert!((two.poses[2].bound_95_mm - two.poses[0].bound_95_mm).abs() < 1e-9);
    assert_eq!(
        two.poses[1].outside_training_range,
        vec![model.actuated_names()[1].clone()]
    );
    assert_eq!(two.extrapolated_poses, 1);
    assert!(
        two.to_csv_string()
            .lines()
            .nth(2)
            .unwrap()
            .ends_with(&format!(",{}", model.actuated_names()[1]))
    );
}

/// The payload is a group of its own: on a simulated UR10 carrying 3 kg at
/// 0.15 m where its mass table says 1 kg at 0.1 m (a tool changed after the
/// table was written), cross-validation keeps the payload and the chosen
/// model recovers its mass within 3 standard errors, while the model
/// without it stays far from the noise. When the table's payload is the
/// truth, the payload identified (if selection keeps it) is the table's
/// within 3 standard errors, and both models reach the noise.
#[test]
fn selection_identifies_a_wrong_payload_and_leaves_a_known_one_alone() {
    use flexcal_calib::{SelectionMethod, SelectionOptions, TermGroup, select_model};
    let model = ur10();
    let table = GravityCompliance::ur10_urdf(&model).unwrap();
    let xi = common::perturbed_geometry(&model, &mut ChaCha8Rng::seed_from_u64(33), 5e-4, 1e-3);
    // Linear joints: what is tested is the payload.
    let truth = Joints {
        hardening: [0.0; 6],
        lost_motion: [0.0; 6],
        cyclic: [[0.0; 4]; 6],
        ..joints()
    };
    let (frame, _) = common::generic_frame_and_target();
    let noise = 20e-6;
    let mut options = CalibrationOptions::for_model(&model);
    options.weighting = Weighting::Uniform;
    options.default_position_std = noise;
    options.target = FrameTreatment::Fixed;
    options.gravity = Some(table.clone());
    let selection = SelectionOptions {
        method: SelectionMethod::CrossValidation,
        groups: Some(vec![
            TermGroup::JointOffsets,
            TermGroup::AxisTilts,
            TermGroup::Compliances,
            TermGroup::Payload,
        ]),
        ..SelectionOptions::default()
    };
    let noise_mean = noise * (8.0 / PI).sqrt();
    for (mass, center_z) in [(3.0, 0.15), (table.payload_mass, table.payload_center.z)] {
        let mut carried = table.clone();
        carried.payload_mass = mass;
        carried.payload_center.z = center_z;
        let train = simulate(&model, &carried, &xi, &truth, &frame, 600, noise, 43);
        let validation = simulate(&model, &carried, &xi, &truth, &frame, 300, noise, 44);
        let (report, chosen) = select_model(&model, &train, &options, &selection).unwrap();
        for line in report.lines() {
            eprintln!("payload {mass} kg: {line}");
        }
        assert!(report.chosen.contains(&TermGroup::Compliances), "{mass} kg");
        let calibration = calibrate(&model, &train, &chosen).unwrap();
        let mut without = chosen.clone();
        without
            .fixed
            .extend(flexcal_calib::PAYLOAD_PARAMETER_NAMES.map(String::from));
        let table_payload = calibrate(&model, &train, &without).unwrap();
        let error = |c: &flexcal_calib::Calibration| {
            c.validate(&model, &validation, false)
                .unwrap()
                .after
                .position_mean
        };
        let (chosen_error, table_error) = (error(&calibration), error(&table_payload));
        eprintln!(
            "payload {mass} kg: validation mean {:.4} mm chosen, {:.4} mm with the table's payload (noise {:.4} mm)",
            chosen_error * 1e3,
            table_error * 1e3,
            noise_mean * 1e3
        );
        assert!(chosen_error < 1.2 * noise_mean, "{mass} kg: {chosen_error}");
        let u = calibration
            .unknowns
            .iter()
            .find(|u| u.name == "payload_mass")
            .unwrap();
        if report.chosen.contains(&TermGroup::Payload) {
            assert_eq!(u.status, UnknownStatus::Identified);
            let se = u.standard_error.unwrap();
            eprintln!("payload mass {:.3} +/- {se:.3} kg (truth {mass})", u.value);
            assert!((u.value - mass).abs() < 3.0 * se, "{} +/- {se}", u.value);
        } else {
            assert_eq!(u.value, mass);
        }
        if mass == table.payload_mass {
            assert!(table_error < 1.2 * noise_mean, "{table_error}");
        } else {
            assert!(report.chosen.contains(&TermGroup::Payload));
            assert!(table_error > 1.5 * noise_mean, "{table_error}");
        }
    }
}
