//! Lateral joint compliances (rotations of a joint's outboard structure
//! about its frame's x axis under the gravity moment, `crate::gravity`):
//! exact Jacobian against central differences, and identification of known
//! terms by model selection on a simulated UR10 and a simulated KR-16-class
//! arm whose measurements are computed independently of the calibration
//! code: joint torques by virtual work, the spring equilibrium by Newton's
//! method, the lateral moments on the true deflected geometry, and the
//! lateral rotations inserted exactly into the chain.
//!
//! Noise: laser-tracker class, 20 um per axis. Leica's AT960 data sheet
//! gives a maximum permissible error of +-(15 um + 6 um/m) for a 3D point,
//! 33 um at the 3 m of these simulated trackers, with typical errors half
//! the MPE; 20 um per axis is the figure the other simulated campaigns of
//! these tests use.

use flexcal_calib::{
    CalibrationOptions, ErrorModel, FrameTreatment, GravityCompliance, JointLaw, JointTerms,
    LateralCompliance, Measurement, MeasurementSet, SelectionMethod, SelectionOptions, TermGroup,
    UnknownStatus, Weighting, calibrate, rotation_from_vector, select_model,
};
use flexcal_kinematics::{
    Data, ImportOptions, ImportedRobot, Model, PointLoad, RobotDescription, actuated_forces_into,
    forward_pose,
};
use nalgebra::{Isometry3, Translation3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use std::f64::consts::PI;
use std::path::PathBuf;

mod common;

/// Per-joint truth: compliance (rad/N.m), hardening (1/rad), lost motion
/// (rad), lateral compliance about the joint frame's x axis (rad/N.m).
#[derive(Debug, Clone)]
struct Joints {
    compliance: [f64; 6],
    hardening: [f64; 6],
    lost_motion: [f64; 6],
    lateral: [f64; 6],
}

fn ur10() -> Model {
    RobotDescription::builtin("ur10").unwrap().build().unwrap()
}

/// The KR-16-class arm and its mass table from the URDF's inertials
/// (`tests/data/kr16_like_masses.urdf`, whose comment gives the sources),
/// with the rated payload of the KR 16, 16 kg, 0.1 m along the flange's z.
fn kr16() -> (Model, GravityCompliance) {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/kr16_like_masses.urdf");
    let imported = ImportedRobot::read_urdf(&path, &ImportOptions::default()).unwrap();
    let model = imported.description.build().unwrap();
    let mut gravity = GravityCompliance::from_link_masses(&model, &imported.masses).unwrap();
    gravity.payload_mass = 16.0;
    gravity.payload_center = Vector3::new(0.0, 0.0, 0.1);
    gravity.initial_compliance = 2e-6;
    (model, gravity)
}

/// UR10 truth. The joint compliances, hardening and lost motion are those
/// of `tests/joint_terms.rs` (sources there: the IPA series' 9-15 urad/N.m
/// for joint 2, strain-wave catalogues' threefold stiffening, 20 arcsec of
/// lost motion). The lateral compliance of joint 2 (the shoulder's tilt
/// about the upper arm's line) is taken equal to its torsional one, 13
/// urad/N.m: a strain-wave unit's output cross-roller bearing is specified
/// by a moment stiffness of the same order as the gear's torsional
/// stiffness (an assumption of the order of magnitude, not a measured
/// value).
fn ur10_truth() -> Joints {
    Joints {
        compliance: [0.0, 13e-6, 10e-6, 20e-6, 15e-6, 10e-6],
        hardening: [0.0, 400.0, 0.0, 0.0, 0.0, 0.0],
        lost_motion: [0.0, 1e-4, 0.0, 0.0, 0.0, 0.0],
        lateral: [0.0, 13e-6, 0.0, 0.0, 0.0, 0.0],
    }
}

/// KR-16-class truth. Joint compliances of 0.5-1 urad/N.m for the main
/// axes and 5 urad/N.m for the wrist: the order of the joint stiffnesses
/// identified on heavy KUKA arms (about 1e6 N.m/rad for the main axes,
/// Dumas, Caro, Garnier, Furet 2011, "Joint stiffness identification of
/// six-revolute industrial serial robots", RCIM 27(4), on a KR 240, scaled
/// for a lighter arm). Joint 2 hardens (the existing law: a cycloidal
/// gear's torque-torsion curve stiffens with the load, as a strain-wave
/// gear's does) with a lost motion of 0.1 mrad (RV-gear catalogues give a
/// lost motion of about 1 arcmin = 0.3 mrad at most). Lateral: the base
/// bearing (joint 1) tilts about its x axis with the joint's own order of
/// compliance, 1 urad/N.m.
fn kr16_truth() -> Joints {
    Joints {
        compliance: [0.0, 0.5e-6, 1e-6, 5e-6, 5e-6, 5e-6],
        hardening: [0.0, 300.0, 0.0, 0.0, 0.0, 0.0],
        lost_motion: [0.0, 1e-4, 0.0, 0.0, 0.0, 0.0],
        lateral: [1e-6, 0.0, 0.0, 0.0, 0.0, 0.0],
    }
}

/// Measurements of a robot whose joints follow `joints` under the weights
/// of `gravity` (its links and its payload start as the true payload):
/// torques by virtual work at the commanded configuration, joints at the
/// spring equilibrium, then each lateral rotation `Rx(delta_j)` inserted
/// exactly after joint j's frame, with the moment about its x axis summed
/// over the weights it carries on the deflected true geometry. Gaussian
/// noise `noise` (m) per axis.
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
    draw: &dyn Fn(&mut ChaCha8Rng) -> Vec<f64>,
) -> MeasurementSet {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let normal = Normal::new(0.0, noise.max(1e-300)).unwrap();
    let mut data = Data::new(model);
    let links = common::link_loads(model, gravity);
    let payload_force = gravity.gravity * gravity.payload_mass;
    let lost_motion_torque = JointLaw::default().lost_motion_torque;
    let measurements = (0..n)
        .map(|_| {
            let q = draw(&mut rng);
            // Torques at the commanded configuration: the links, and the
            // payload at its centre in the TCP frame.
            let x_tcp = forward_pose(model, &mut data, &q, model.nominal_params()).unwrap();
            let mut loads = links.clone();
            let end = model.end_frame();
            let x_end = data.frame_pose(end).unwrap();
            loads.push(PointLoad {
                frame: end,
                point: (x_end.inverse() * (x_tcp * nalgebra::Point3::from(gravity.payload_center)))
                    .coords,
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
            let deflected: Vec<f64> = (0..6)
                .map(|i| {
                    q[i] + common::spring_deflection(
                        tau[i],
                        joints.compliance[i],
                        joints.hardening[i],
                    ) + joints.lost_motion[i] * (tau[i] / lost_motion_torque).tanh()
                })
                .collect();
            let x = forward_pose(model, &mut data, &deflected, xi).unwrap();
            // Lateral rotations on the deflected true robot: inserting
            // Rx(delta_j) after frame j is x = prod_j (T_j Rx(delta_j) T_j^-1) x,
            // joint 1 leftmost, every T_j of the robot without them.
            // The payload is a load on the end frame (its point there is
            // the tool transform's, the same on the deflected robot).
            let mut moved = x;
            for j in (0..6).rev() {
                if joints.lateral[j] == 0.0 {
                    continue;
                }
                let f = model.actuated_frame(j).unwrap();
                moved = common::lateral_turn(model, &data, &loads, f, joints.lateral[j]) * moved;
            }
            let p = (frame * moved).translation.vector
                + Vector3::from_fn(|_, _| {
                    if noise > 0.0 {
                        normal.sample(&mut rng)
                    } else {
                        0.0
                    }
                });
            Measurement::new(q, p)
        })
        .collect();
    MeasurementSet::new("simulated, lateral compliance", measurements).unwrap()
}

fn ur10_draw(rng: &mut ChaCha8Rng) -> Vec<f64> {
    let mut q = common::ur10_configuration(rng);
    q[0] = rng.random_range(-PI..PI);
    q[3] = rng.random_range(-PI..PI);
    q
}

/// A KR-16-class configuration within the URDF's limits, arm above the
/// floor: A2 from -2.4 to 0.3 rad, A3 from -2.0 to 1.5, A5 within +-2.0.
fn kr16_draw(rng: &mut ChaCha8Rng) -> Vec<f64> {
    vec![
        rng.random_range(-PI..PI),
        rng.random_range(-2.4..0.3),
        rng.random_range(-2.0..1.5),
        rng.random_range(-PI..PI),
        rng.random_range(-2.0..2.0),
        rng.random_range(-PI..PI),
    ]
}

/// A robot, its mass table, its truth and its configuration draw.
type Case<'a> = (
    &'a str,
    &'a Model,
    GravityCompliance,
    Joints,
    &'a dyn Fn(&mut ChaCha8Rng) -> Vec<f64>,
);

fn lateral_on(gravity: &GravityCompliance) -> GravityCompliance {
    GravityCompliance {
        lateral: LateralCompliance::AboutX,
        ..gravity.clone()
    }
}

/// Every column (geometry, frames, compliances, payload, lateral
/// compliances, the law, cyclic errors; positions and orientations) against
/// central differences, at unknowns away from the start so that the
/// lateral rotations and their coupling with the payload are not zero.
#[test]
fn lateral_columns_match_central_differences() {
    let (kr16_model, kr16_gravity) = kr16();
    let ur10_model = ur10();
    let ur10_gravity = GravityCompliance::ur10_urdf(&ur10_model).unwrap();
    let cases: [Case<'_>; 2] = [
        ("ur10", &ur10_model, ur10_gravity, ur10_truth(), &ur10_draw),
        ("kr16", &kr16_model, kr16_gravity, kr16_truth(), &kr16_draw),
    ];
    for (label, model, gravity, truth, draw) in cases {
        let (frame, target) = common::generic_frame_and_target();
        let gravity = lateral_on(&gravity);
        let set = simulate(
            model,
            &gravity,
            model.nominal_params(),
            &truth,
            &frame,
            6,
            0.0,
            2,
            draw,
        );
        let set = common::with_orientation(&set);
        let terms = JointTerms {
            law: Some(JointLaw::default()),
            cyclic: true,
        };
        let problem = ErrorModel::one_target(model, &set, true, frame, target)
            .unwrap()
            .with_elastic(Some(&gravity), &terms)
            .unwrap();
        let kinds = problem.kinds();
        assert_eq!(kinds.len(), problem.n_unknowns());
        let lo = problem.lateral_offset().unwrap();
        assert!(problem.names()[lo].starts_with("lateral_compliance_"));
        assert!(
            problem.names()[lo..]
                .iter()
                .filter(|n| n.starts_with("lateral_"))
                .count()
                == 6
        );
        let (x, jac) = common::assert_elastic_jacobian_matches(label, model, &problem, 5);
        let eo = problem.elastic_offset().unwrap();
        // The lateral columns are not trivially zero.
        let nonzero = (lo..lo + 6)
            .filter(|&j| (0..jac.nrows()).any(|i| jac[(i, j)].abs() > 1e-6))
            .count();
        assert!(nonzero >= 4, "{label}: {nonzero} lateral columns non-zero");
        // The prediction with zero lateral compliances is the model without them.
        let plain = ErrorModel::one_target(model, &set, true, frame, target)
            .unwrap()
            .with_elastic(
                Some(&GravityCompliance {
                    lateral: LateralCompliance::Off,
                    ..gravity.clone()
                }),
                &JointTerms::default(),
            )
            .unwrap();
        let mut x_plain = problem.initial_unknowns()[..plain.n_unknowns()].to_vec();
        x_plain[..eo].copy_from_slice(&x[..eo]);
        let mut x_zero = problem.initial_unknowns();
        x_zero[..eo].copy_from_slice(&x[..eo]);
        let a = plain.predict(&x_plain).unwrap();
        let b = problem.predict(&x_zero).unwrap();
        assert_eq!(a.len(), set.len());
        for (a, b) in a.iter().zip(&b) {
            assert!((a.translation.vector - b.translation.vector).norm() < 1e-12);
        }
    }
}

/// The identification and the truth compared: every joint term (the
/// compliances, the law, the lateral compliances) within 3 standard errors
/// of the truth (of the true combination, for unknowns left at their start
/// that the identified ones stand for).
fn check_within_three_standard_errors(
    label: &str,
    model: &Model,
    calibration: &flexcal_calib::Calibration,
    xi: &[f64],
    truth: &Joints,
) -> usize {
    let true_value = |name: &str, start: f64| -> f64 {
        if let Some(j) = model.param_index(name) {
            return xi[j];
        }
        for (i, joint) in model.actuated_names().iter().enumerate() {
            if name == format!("compliance_{joint}") {
                return truth.compliance[i];
            }
            if name == format!("hardening_{joint}") {
                return truth.hardening[i];
            }
            if name == format!("lost_motion_{joint}") {
                return truth.lost_motion[i];
            }
            if name == format!("lateral_compliance_{joint}_x") {
                return truth.lateral[i];
            }
        }
        start
    };
    let truth_vector: Vec<f64> = calibration
        .unknowns
        .iter()
        .map(|u| {
            if u.name.starts_with("frame_") || u.name.starts_with("target_") {
                u.value
            } else {
                true_value(&u.name, u.initial)
            }
        })
        .collect();
    let mut checked = 0;
    for (name, true_combination, value, se) in calibration.combination_check(&truth_vector) {
        let term = [
            "compliance_",
            "hardening_",
            "lost_motion_",
            "lateral_compliance_",
        ]
        .iter()
        .any(|p| name.starts_with(p));
        if !term {
            continue;
        }
        let se = se.unwrap();
        eprintln!("{label}: {name} {value:.4e} +/- {se:.2e}, truth {true_combination:.4e}");
        assert!(
            (value - true_combination).abs() < 3.0 * se,
            "{label}: {name}: identified {value} +/- {se}, true combination {true_combination}"
        );
        checked += 1;
    }
    checked
}

/// Selection by 5-fold cross-validation over joint-space clusters from the
/// richest model (every group, the lateral compliances of every revolute
/// joint among them) on a simulated robot with a hardening joint and a
/// lateral compliance: the chosen model keeps the compliances, the law and
/// the lateral compliances, recovers the truth within 3 standard errors,
/// and reaches the noise on other poses, which the model without the
/// lateral compliances does not.
#[allow(clippy::too_many_arguments)]
fn selection_recovers_lateral_and_law(
    label: &str,
    model: &Model,
    gravity: &GravityCompliance,
    truth: &Joints,
    draw: &dyn Fn(&mut ChaCha8Rng) -> Vec<f64>,
    lateral_name: &str,
    seed: u64,
) {
    let xi = common::perturbed_geometry(model, &mut ChaCha8Rng::seed_from_u64(seed), 5e-4, 1e-3);
    let frame = Isometry3::from_parts(
        Translation3::new(0.4, -3.2, 0.1),
        rotation_from_vector(&Vector3::new(0.0, 0.05, 1.5)),
    );
    let noise = 20e-6;
    let train = simulate(
        model,
        gravity,
        &xi,
        truth,
        &frame,
        600,
        noise,
        seed + 1,
        draw,
    );
    let validation = simulate(
        model,
        gravity,
        &xi,
        truth,
        &frame,
        300,
        noise,
        seed + 2,
        draw,
    );
    let mut richest = CalibrationOptions::for_model(model);
    richest.weighting = Weighting::Uniform;
    richest.default_position_std = noise;
    richest.target = FrameTreatment::Fixed;
    richest.gravity = Some(lateral_on(gravity));
    // The payload is known here: what is tested is the joints.
    richest.fixed = flexcal_calib::PAYLOAD_PARAMETER_NAMES
        .iter()
        .map(|s| s.to_string())
        .collect();
    richest.joint_terms.law = Some(JointLaw::default());
    let selection = SelectionOptions {
        method: SelectionMethod::CrossValidation,
        ..SelectionOptions::default()
    };
    let (report, chosen) = select_model(model, &train, &richest, &selection).unwrap();
    for line in report.lines() {
        eprintln!("{label}: {line}");
    }
    for group in [
        TermGroup::Compliances,
        TermGroup::JointLaw,
        TermGroup::LateralCompliances,
    ] {
        assert!(report.chosen.contains(&group), "{label}: {group:?} dropped");
    }
    let calibration = calibrate(model, &train, &chosen).unwrap();
    assert!(calibration.solve.termination.is_converged());
    for name in [lateral_name, "hardening_"] {
        let u = calibration
            .unknowns
            .iter()
            .find(|u| u.name.starts_with(name) && u.status == UnknownStatus::Identified);
        assert!(u.is_some(), "{label}: no {name}* identified");
    }
    let checked = check_within_three_standard_errors(label, model, &calibration, &xi, truth);
    assert!(checked >= 8, "{label}: {checked} terms checked");
    // The same model without the lateral compliances, for comparison.
    let mut without = chosen.clone();
    if let Some(g) = without.gravity.as_mut() {
        g.lateral = LateralCompliance::Off;
    }
    let plain = calibrate(model, &train, &without).unwrap();
    let noise_mean = noise * (8.0 / PI).sqrt();
    let r = calibration.validate(model, &validation, false).unwrap();
    let p = plain.validate(model, &validation, false).unwrap();
    eprintln!(
        "{label}: validation mean: selected {:.4} mm, without lateral {:.4} mm (noise {:.4} mm)",
        r.after.position_mean * 1e3,
        p.after.position_mean * 1e3,
        noise_mean * 1e3
    );
    assert!(
        r.after.position_mean < 1.2 * noise_mean,
        "{label}: {:?}",
        r.after
    );
    assert!(p.after.position_mean > r.after.position_mean, "{label}");
}

#[test]
fn ur10_selection_keeps_the_law_and_the_lateral_compliance() {
    let model = ur10();
    let gravity = GravityCompliance::ur10_urdf(&model).unwrap();
    selection_recovers_lateral_and_law(
        "ur10",
        &model,
        &gravity,
        &ur10_truth(),
        &ur10_draw,
        "lateral_compliance_theta2_x",
        61,
    );
}

#[test]
fn kr16_class_selection_keeps_the_law_and_the_lateral_compliance() {
    let (model, gravity) = kr16();
    let name = format!("lateral_compliance_{}_x", model.actuated_names()[0]);
    selection_recovers_lateral_and_law(
        "kr16",
        &model,
        &gravity,
        &kr16_truth(),
        &kr16_draw,
        &name,
        71,
    );
}

#[test]
fn lateral_names_switch_and_mass_table_round_trip() {
    let model = ur10();
    let gravity = GravityCompliance::ur10_urdf(&model).unwrap();
    assert!(gravity.lateral_unknown_names(&model).is_empty());
    let on = lateral_on(&gravity);
    let names = on.lateral_unknown_names(&model);
    assert_eq!(names.len(), 6);
    assert_eq!(names[1], "lateral_compliance_theta2_x");
    assert_eq!(
        on.initial_unknowns(&model).len(),
        on.elastic_unknown_names(&model).len()
    );
    let text = on.to_toml_string().unwrap();
    assert!(text.contains("lateral = \"about-x\""), "{text}");
    let back = GravityCompliance::from_toml_str(&text, "round trip").unwrap();
    assert_eq!(back.lateral, LateralCompliance::AboutX);
    let off = GravityCompliance::from_toml_str(&gravity.to_toml_string().unwrap(), "off").unwrap();
    assert_eq!(off.lateral, LateralCompliance::Off);
    assert_eq!(
        "x".parse::<LateralCompliance>(),
        Ok(LateralCompliance::AboutX)
    );
    assert!("y".parse::<LateralCompliance>().is_err());
}

/// Springs on named frames (a base on a pivot, a link about its y axis):
/// their columns against central differences, their names, the mass
/// table round trip, and the frames they cannot go on named.
#[test]
fn springs_on_named_frames_match_central_differences_and_bad_ones_are_named() {
    let model = ur10();
    let mut gravity = GravityCompliance::ur10_urdf(&model).unwrap();
    gravity.springs = vec![
        flexcal_calib::Spring {
            frame: "1".into(),
            axis: flexcal_calib::FrameAxis::X,
            pivot: Vector3::new(0.0, 0.0, -0.1),
        },
        flexcal_calib::Spring {
            frame: "3".into(),
            axis: flexcal_calib::FrameAxis::Y,
            pivot: Vector3::zeros(),
        },
    ];
    let names = gravity.lateral_unknown_names(&model);
    assert_eq!(
        names,
        ["lateral_compliance_1_x", "lateral_compliance_3_y"].map(String::from)
    );
    let (frame, target) = common::generic_frame_and_target();
    let set = simulate(
        &model,
        &gravity,
        model.nominal_params(),
        &ur10_truth(),
        &frame,
        6,
        0.0,
        2,
        &ur10_draw,
    );
    let set = common::with_orientation(&set);
    let problem = ErrorModel::one_target(&model, &set, true, frame, target)
        .unwrap()
        .with_elastic(
            Some(&gravity),
            &JointTerms {
                law: Some(JointLaw::default()),
                cyclic: false,
            },
        )
        .unwrap();
    let lo = problem.lateral_offset().unwrap();
    assert_eq!(problem.names()[lo..lo + 2], names[..]);
    let (_, jac) = common::assert_elastic_jacobian_matches("ur10 springs", &model, &problem, 5);
    for j in lo..lo + 2 {
        assert!(
            (0..jac.nrows()).any(|i| jac[(i, j)].abs() > 1e-6),
            "{} column is zero",
            problem.names()[j]
        );
    }
    // The mass table keeps them.
    let text = gravity.to_toml_string().unwrap();
    let back = GravityCompliance::from_toml_str(&text, "round trip").unwrap();
    assert_eq!(back.springs, gravity.springs, "{text}");
    // A frame the robot does not have, and one that carries nothing.
    let mut bad = gravity.clone();
    bad.springs[0].frame = "elbow".into();
    let error = ErrorModel::one_target(&model, &set, true, frame, target)
        .unwrap()
        .with_elastic(Some(&bad), &JointTerms::default())
        .err()
        .expect("an unknown frame")
        .to_string();
    assert!(
        error.contains("`elbow`") && error.contains("no such frame"),
        "{error}"
    );
    let two_arms = RobotDescription::from_toml_file(
        &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/two_arms.toml"),
    )
    .unwrap()
    .build()
    .unwrap();
    let table = "payload_mass_kg = 0.0\npayload_center_mm = [0.0, 0.0, 0.0]\ninitial_compliance_urad_per_nm = 10.0\n\n[[mass]]\nname = \"left forearm\"\nframe = \"L3\"\nmass_kg = 3.0\ncenter_mm = [0.0, 0.0, 0.0]\n\n[[spring]]\nframe = \"R2\"\naxes = [\"x\"]\n";
    let lonely = GravityCompliance::from_toml_str(table, "lonely.toml").unwrap();
    let q = vec![0.1; two_arms.n_actuated()];
    let set =
        MeasurementSet::new("one pose", vec![Measurement::new(q, Vector3::zeros()); 3]).unwrap();
    let error = ErrorModel::one_target(&two_arms, &set, false, frame, target)
        .unwrap()
        .with_elastic(Some(&lonely), &JointTerms::default())
        .err()
        .expect("a spring that carries nothing")
        .to_string();
    assert!(
        error.contains("`R2`") && error.contains("carries no weight"),
        "{error}"
    );
    // A spring's axes must be named.
    let error = GravityCompliance::from_toml_str(&table.replace("[\"x\"]", "[\"w\"]"), "t.toml")
        .unwrap_err()
        .to_string();
    assert!(error.contains("t.toml"), "{error}");
}
