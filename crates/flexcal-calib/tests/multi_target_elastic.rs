//! The elasto-geometric model with several targets: a two-armed tree robot
//! (a torso joint carrying two four-joint arms, `tests/data/two_arms.toml`)
//! with a marker on each hand, whose joints are linear springs under the
//! weights of both arms, and whose torso bearing tilts under the bending
//! moment of both arms. (The non-linear joint law with several targets is
//! checked against central differences in the crate's unit tests; with it
//! on every joint, the lost motion of a lightly loaded wrist joint,
//! `beta tanh(tau / 5 N.m)`, is a compliance `beta / 5 N.m` below 5 N.m and
//! takes the place of a compliance frozen beyond its standard-error limit:
//! which joint terms to identify is then a model choice.)
//!
//! The measurements are computed apart from the calibration code: joint
//! torques by virtual work at the commanded configuration, the joints
//! deflected by `c tau`, the torso's lateral rotation about its
//! frame's x axis under the moment of every weight it carries on the
//! deflected true geometry, inserted exactly into the chain of each hand.
//!
//! Sources of the truth:
//! - link masses: the mass table `tests/data/two_arms_masses.toml` (a
//!   collaborative arm's URDF inertials, said there);
//! - geometric errors, tracker placement, marker offsets and noise as in
//!   `tests/multi_target.rs` (uniform within +-0.3 mm and +-0.03 deg; the
//!   markers within +-1 mm; 0.02 mm per axis);
//! - joint compliances 10-20 urad/N.m: the UR10 truth of
//!   `tests/joint_terms.rs` (a collaborative arm's strain-wave joints,
//!   sources there);
//! - the torso's lateral compliance, 10 urad/N.m: of the order of its
//!   joints' torsional compliance, as `tests/lateral_compliance.rs` argues
//!   for a strain-wave unit's output bearing (an order of magnitude, not a
//!   measured value).

use flexcal_calib::{
    Calibration, CalibrationOptions, GravityCompliance, LateralCompliance, MeasurementSet, Refit,
    SelectionOptions, TargetObservation, TargetPose, TermGroup, UnknownStatus, calibrate,
    calibrate_selected, read_targets, rotation_from_vector, vector_from_rotation,
};
use flexcal_kinematics::{Data, Model, PointLoad, RobotDescription, actuated_forces_into};
use nalgebra::{Isometry3, Translation3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

mod common;

const NOISE: f64 = 0.02e-3;

/// The torque over which the lost motion is taken up (N.m): the library's
/// default, written here apart from it.
const LOST_MOTION_TORQUE: f64 = 5.0;

fn data_file(name: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

/// The simulated robot: geometry, joints, tracker and markers.
struct Truth {
    xi: Vec<f64>,
    compliance: Vec<f64>,
    /// Hardening (1/rad) and lost motion (rad) of each joint's spring.
    hardening: Vec<f64>,
    lost_motion: Vec<f64>,
    /// Lateral compliance about x of each actuated joint (rad/N.m).
    lateral: Vec<f64>,
    x_meas_base: Isometry3<f64>,
    offsets: Vec<Vector3<f64>>,
}

/// `law`: the left shoulder (`thetaL1`) hardens (400 1/rad) with a lost
/// motion of 0.1 mrad; otherwise every spring is linear.
fn truth(
    model: &Model,
    nominal_offsets: &[Vector3<f64>],
    law: bool,
    rng: &mut ChaCha8Rng,
) -> Truth {
    let xi = common::perturbed_geometry(model, rng, 0.3e-3, 0.03f64.to_radians());
    let names = model.actuated_names();
    let by_joint = |f: &dyn Fn(&str) -> f64| names.iter().map(|n| f(n)).collect::<Vec<f64>>();
    Truth {
        xi,
        // The torso turns about the vertical: gravity does not load it, and
        // its compliance stays at the table's start.
        compliance: by_joint(&|n| match &n[n.len() - 1..] {
            "1" => 10e-6,
            "2" => 15e-6,
            _ => 20e-6,
        }),
        hardening: by_joint(&|n| if law && n == "thetaL1" { 400.0 } else { 0.0 }),
        lost_motion: by_joint(&|n| if law && n == "thetaL1" { 1e-4 } else { 0.0 }),
        lateral: by_joint(&|n| if n == "theta1" { 10e-6 } else { 0.0 }),
        x_meas_base: Isometry3::from_parts(
            Translation3::new(2.5, -0.4, -0.9),
            rotation_from_vector(&Vector3::new(0.1, -0.2, 2.4)),
        ),
        offsets: nominal_offsets
            .iter()
            .map(|o| o + Vector3::from_fn(|_, _| rng.random_range(-1e-3..1e-3)))
            .collect(),
    }
}

/// `n` poses within the joint limits, both markers seen.
fn measure(
    model: &Model,
    gravity: &GravityCompliance,
    truth: &Truth,
    targets: &[flexcal_calib::Target],
    n: usize,
    rng: &mut ChaCha8Rng,
) -> MeasurementSet {
    let noise = Normal::new(0.0, NOISE).unwrap();
    let mut data = Data::new(model);
    let links = common::link_loads(model, gravity);
    let end = model.end_frame();
    let payload_force = gravity.gravity * gravity.payload_mass;
    let frames: Vec<usize> = targets
        .iter()
        .map(|t| model.frame_index(&t.frame).unwrap())
        .collect();
    let poses = (0..n)
        .map(|k| {
            let q: Vec<f64> = model
                .actuated_limits()
                .iter()
                .map(|&(lo, hi)| rng.random_range(lo..hi))
                .collect();
            // Torques at the commanded configuration on the nominal
            // geometry: the links, and the payload at its centre on the
            // end frame (this robot has no tool transform).
            let mut loads = links.clone();
            loads.push(PointLoad {
                frame: end,
                point: gravity.payload_center,
                force: payload_force,
            });
            let mut tau = vec![0.0; model.n_actuated()];
            actuated_forces_into(
                model,
                &mut data,
                &q,
                model.nominal_params(),
                &loads,
                &mut tau,
            )
            .unwrap();
            let deflected: Vec<f64> = (0..q.len())
                .map(|i| {
                    q[i] + common::spring_deflection(
                        tau[i],
                        truth.compliance[i],
                        truth.hardening[i],
                    ) + truth.lost_motion[i] * (tau[i] / LOST_MOTION_TORQUE).tanh()
                })
                .collect();
            flexcal_kinematics::forward_frames(model, &mut data, &deflected, &truth.xi).unwrap();
            // Lateral rotations on the deflected true robot: Rx(delta_j)
            // inserted after frame j moves every frame after it, x' =
            // T_j Rx T_j^-1 x, the innermost joint applied last.
            let lateral: Vec<(usize, Isometry3<f64>)> = (0..q.len())
                .rev()
                .filter(|&j| truth.lateral[j] != 0.0)
                .map(|j| {
                    let f = model.actuated_frame(j).unwrap();
                    let turn = common::lateral_turn(model, &data, &loads, f, truth.lateral[j]);
                    (f, turn)
                })
                .collect();
            let observations = (0..targets.len())
                .map(|t| {
                    let mut x =
                        data.frame_pose(frames[t]).unwrap() * Translation3::from(truth.offsets[t]);
                    for (f, motion) in &lateral {
                        if model.moves_with(frames[t], *f) {
                            x = motion * x;
                        }
                    }
                    let p = (truth.x_meas_base * x).translation.vector
                        + Vector3::from_fn(|_, _| noise.sample(rng));
                    Some(TargetObservation::new(p))
                })
                .collect();
            TargetPose::new(Some(format!("p{k}")), q, observations)
        })
        .collect();
    MeasurementSet::from_poses("simulated, elastic", targets.to_vec(), poses).unwrap()
}

/// The true value of every unknown of `calibration` by name.
fn true_unknowns(
    calibration: &Calibration,
    model: &Model,
    gravity: &GravityCompliance,
    truth: &Truth,
    targets: &[flexcal_calib::Target],
) -> Vec<f64> {
    let start = calibration.x_meas_base_initial;
    let frame_translation = truth.x_meas_base.translation.vector - start.translation.vector;
    let frame_rotation =
        vector_from_rotation(&(truth.x_meas_base.rotation * start.rotation.inverse()));
    let joint = |name: &str, prefix: &str, suffix: &str| {
        let joint = name.strip_prefix(prefix)?.strip_suffix(suffix)?;
        model.actuated_names().iter().position(|n| n == joint)
    };
    calibration
        .unknowns
        .iter()
        .map(|u| {
            let name = u.name.as_str();
            if let Some(j) = model.params().iter().position(|p| p.name == name) {
                return truth.xi[j];
            }
            let axes = ["x", "y", "z", "rx", "ry", "rz"];
            if let Some(a) = name.strip_prefix("frame_") {
                let a = axes.iter().position(|x| *x == a).unwrap();
                return if a < 3 {
                    frame_translation[a]
                } else {
                    frame_rotation[a - 3]
                };
            }
            for (t, target) in targets.iter().enumerate() {
                for (a, axis) in ["x", "y", "z"].iter().enumerate() {
                    if name == format!("target.{}.{axis}", target.name) {
                        return truth.offsets[t][a] - target.offset[a];
                    }
                    // Positions alone leave the markers' rotations at zero.
                    if name == format!("target.{}.r{axis}", target.name) {
                        return 0.0;
                    }
                }
            }
            if let Some(i) = joint(name, "compliance_", "") {
                return truth.compliance[i];
            }
            if let Some(i) = joint(name, "lateral_compliance_", "_x") {
                return truth.lateral[i];
            }
            if let Some(i) = joint(name, "hardening_", "") {
                return truth.hardening[i];
            }
            if let Some(i) = joint(name, "lost_motion_", "") {
                return truth.lost_motion[i];
            }
            if name.starts_with("cyclic_") {
                return 0.0;
            }
            match name {
                "payload_mass" => gravity.payload_mass,
                "payload_mx" => gravity.payload_mass * gravity.payload_center.x,
                "payload_my" => gravity.payload_mass * gravity.payload_center.y,
                "payload_mz" => gravity.payload_mass * gravity.payload_center.z,
                _ => panic!("no truth for {name}"),
            }
        })
        .collect()
}

/// Every identified unknown of `calibration` within 3 standard errors of
/// the true value of what it stands for (`x_true`, by the calibration's
/// combinations); the unknowns `named` identified. Prints the worst ratio
/// and the named unknowns against their truth.
fn assert_truth_within_three_standard_errors(
    calibration: &Calibration,
    x_true: &[f64],
    named: &[&str],
) {
    let checks = calibration.combination_check(x_true);
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
        "{} observations: {} of {} unknowns identified, largest |error| / standard error {:.2} ({})",
        calibration.n_observations,
        calibration.rank(),
        calibration.unknowns.len(),
        worst.1.abs(),
        worst.0
    );
    for name in named {
        let j = calibration
            .unknowns
            .iter()
            .position(|u| u.name == *name)
            .unwrap();
        let u = &calibration.unknowns[j];
        let (unit, scale) = u.kind.display_unit();
        println!(
            "{name}: {:.4} +- {:.4} {unit} (truth {:.4})",
            u.value * scale,
            u.standard_error.unwrap_or(f64::NAN) * scale,
            x_true[j] * scale
        );
        assert_eq!(u.status, UnknownStatus::Identified, "{name}");
    }
    for (name, true_value, identified, se) in &checks {
        let se = se.unwrap();
        assert!(
            (identified - true_value).abs() < 3.0 * se,
            "{name}: identified {identified:e}, true combination {true_value:e}, standard error {se:e}"
        );
    }
}

#[test]
fn markers_on_both_hands_recover_the_joint_springs_and_the_torso_tilt() {
    let model = RobotDescription::from_toml_file(&data_file("two_arms.toml"))
        .unwrap()
        .build()
        .unwrap();
    let targets = read_targets(&data_file("two_arms_targets.toml")).unwrap();
    let gravity = GravityCompliance::from_toml_file(&data_file("two_arms_masses.toml")).unwrap();
    assert_eq!(gravity.lateral, LateralCompliance::AboutX);
    let mut rng = ChaCha8Rng::seed_from_u64(0x656c_6173);
    let nominal: Vec<Vector3<f64>> = targets.iter().map(|t| t.offset).collect();
    let truth = truth(&model, &nominal, false, &mut rng);
    let training = measure(&model, &gravity, &truth, &targets, 300, &mut rng);
    let validation_set = measure(&model, &gravity, &truth, &targets, 150, &mut rng);

    let elastic_options = CalibrationOptions {
        gravity: Some(gravity.clone()),
        ..CalibrationOptions::default()
    };
    let calibration = calibrate(&model, &training, &elastic_options).unwrap();
    let x_true = true_unknowns(&calibration, &model, &gravity, &truth, &targets);
    assert_truth_within_three_standard_errors(
        &calibration,
        &x_true,
        &[
            "compliance_thetaL1",
            "compliance_thetaR2",
            "lateral_compliance_theta1_x",
        ],
    );
    // The torso's compliance has no influence: gravity does not load a
    // vertical axis.
    let torso = calibration
        .unknowns
        .iter()
        .find(|u| u.name == "compliance_theta1")
        .unwrap();
    assert_ne!(torso.status, UnknownStatus::Identified);

    // Validation on other poses: the elasto-geometric model reaches the
    // noise (three axes of 0.02 mm: a mean error norm of about 0.032 mm);
    // the geometric one, identified on the same poses, does not.
    let geometric = calibrate(&model, &training, &CalibrationOptions::default()).unwrap();
    let elastic_validation = calibration
        .validate(&model, &validation_set, Refit::Nothing)
        .unwrap();
    let geometric_validation = geometric
        .validate(&model, &validation_set, Refit::Nothing)
        .unwrap();
    for (e, g) in elastic_validation
        .per_target_after
        .iter()
        .zip(&geometric_validation.per_target_after)
    {
        println!(
            "validation, target {}: mean / max {:.4} / {:.4} mm elasto-geometric, {:.4} / {:.4} mm geometric",
            e.target,
            e.statistics.position_mean * 1e3,
            e.statistics.position_max * 1e3,
            g.statistics.position_mean * 1e3,
            g.statistics.position_max * 1e3
        );
        assert!(e.statistics.position_mean < 0.036e-3, "{e:?}");
        assert!(g.statistics.position_mean > 2.0 * e.statistics.position_mean);
    }
}

/// Model selection with two markers: cross-validation over clusters of
/// poses (both markers of a pose in the same fold) chooses, from every
/// group (offsets, compliances, payload, the joint law, the lateral
/// compliances, cyclic errors), a model with the shoulder's law and the
/// torso's tilt of the truth, whose identified terms lie within 3 standard
/// errors of what they stand for, and which validates at the noise.
#[test]
fn selection_with_two_markers_keeps_the_shoulder_law_and_the_torso_tilt() {
    let model = RobotDescription::from_toml_file(&data_file("two_arms.toml"))
        .unwrap()
        .build()
        .unwrap();
    let targets = read_targets(&data_file("two_arms_targets.toml")).unwrap();
    let gravity = GravityCompliance::from_toml_file(&data_file("two_arms_masses.toml")).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(0x7365_6c65);
    let nominal: Vec<Vector3<f64>> = targets.iter().map(|t| t.offset).collect();
    let truth = truth(&model, &nominal, true, &mut rng);
    let training = measure(&model, &gravity, &truth, &targets, 300, &mut rng);
    let validation_set = measure(&model, &gravity, &truth, &targets, 150, &mut rng);
    let options = CalibrationOptions {
        gravity: Some(gravity.clone()),
        ..CalibrationOptions::default()
    };
    let (calibration, report, _) =
        calibrate_selected(&model, &training, &options, &SelectionOptions::default()).unwrap();
    let report = report.unwrap();
    for line in report.lines() {
        println!("{line}");
    }
    for group in [
        TermGroup::Compliances,
        TermGroup::JointLaw,
        TermGroup::LateralCompliances,
    ] {
        assert!(report.chosen.contains(&group), "{:?}", report.chosen);
    }
    let x_true = true_unknowns(&calibration, &model, &gravity, &truth, &targets);
    assert_truth_within_three_standard_errors(
        &calibration,
        &x_true,
        &[
            "compliance_thetaL1",
            "hardening_thetaL1",
            "lost_motion_thetaL1",
            "lateral_compliance_theta1_x",
        ],
    );
    let validation = calibration
        .validate(&model, &validation_set, Refit::Nothing)
        .unwrap();
    for e in &validation.per_target_after {
        println!(
            "validation, target {}: mean / max {:.4} / {:.4} mm",
            e.target,
            e.statistics.position_mean * 1e3,
            e.statistics.position_max * 1e3
        );
        assert!(e.statistics.position_mean < 0.036e-3, "{e:?}");
    }
    // The predicted 95 % bounds of the selected model (its compliances,
    // law and lateral terms among the columns) hold for the validation
    // observations about 95 % of the time: some 280 observations, a
    // binomial spread of 1.3 %.
    let map = calibration
        .accuracy_coverage(&model, &validation_set, None)
        .unwrap();
    let coverage = map.coverage.unwrap();
    println!(
        "validation: {:.1} % of {} observations within their 95 % bounds (mean bound {:.4} mm)",
        100.0 * coverage,
        map.poses.len(),
        map.mean_bound_95_mm
    );
    assert!((0.88..0.99).contains(&coverage), "{coverage}");
}
