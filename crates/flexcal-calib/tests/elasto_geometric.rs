//! The elasto-geometric error model (joint compliances under gravity):
//! exact Jacobian against central differences, identification of known
//! compliances on a simulated UR10, the mass-table file.

use flexcal_calib::{
    CalibError, CalibrationOptions, ErrorModel, GravityCompliance, JointTerms, MeasurementSet,
    UnknownKind, UnknownStatus, Weighting, calibrate, rotation_from_vector,
};
use flexcal_kinematics::{Model, RobotDescription};
use nalgebra::{Isometry3, Translation3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

mod common;

fn ur10() -> Model {
    RobotDescription::builtin("ur10").unwrap().build().unwrap()
}

/// The true robot of the simulations: geometric errors, joint compliances,
/// a payload.
struct Truth {
    xi: Vec<f64>,
    compliance: Vec<f64>,
    payload_mass: f64,
    payload_center: Vector3<f64>,
}

/// Measurements of `truth` deflected by gravity (linear joint springs:
/// `q + C tau`), Gaussian noise `noise` (m) per axis.
fn simulate(
    model: &Model,
    gravity: &GravityCompliance,
    truth: &Truth,
    frame: &Isometry3<f64>,
    n: usize,
    noise: f64,
    seed: u64,
) -> MeasurementSet {
    let simulation = common::GravitySimulation {
        model,
        gravity,
        xi: &truth.xi,
        payload: (truth.payload_mass, truth.payload_center),
        frame: *frame,
        noise,
    };
    simulation.measure(
        n,
        seed,
        "simulated ur10 under gravity",
        common::ur10_configuration,
        |q, tau| {
            q.iter()
                .zip(tau)
                .zip(&truth.compliance)
                .map(|((q, t), c)| q + c * t)
                .collect()
        },
    )
}

fn truth(model: &Model, seed: u64) -> Truth {
    Truth {
        xi: common::perturbed_geometry(model, &mut ChaCha8Rng::seed_from_u64(seed), 5e-4, 1e-3),
        compliance: vec![0.0, 14e-6, 9e-6, 20e-6, 15e-6, 10e-6],
        payload_mass: 1.4,
        payload_center: Vector3::new(0.01, -0.02, 0.12),
    }
}

#[test]
fn elastic_columns_match_central_differences() {
    let model = ur10();
    let gravity = GravityCompliance::ur10_urdf(&model).unwrap();
    let (frame, target) = common::generic_frame_and_target();
    let set = simulate(&model, &gravity, &truth(&model, 1), &frame, 5, 0.0, 2);
    let set = common::with_orientation(&set);
    let problem = ErrorModel::one_target(&model, &set, true, frame, target)
        .unwrap()
        .with_elastic(Some(&gravity), &JointTerms::default())
        .unwrap();
    let kinds = problem.kinds();
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let mut x = problem.initial_unknowns();
    let eo = problem.elastic_offset().unwrap();
    for v in x[model.n_params()..eo].iter_mut() {
        *v = rng.random_range(-0.05..0.05);
    }
    for (v, kind) in x[eo..].iter_mut().zip(&kinds[eo..]) {
        *v += match kind {
            UnknownKind::Compliance => rng.random_range(0.0..2e-5),
            _ => rng.random_range(-0.1..0.1),
        };
    }
    // Steps in proportion to each kind's scale.
    let step = |j: usize| match kinds[j] {
        UnknownKind::Compliance => 1e-9,
        UnknownKind::Mass | UnknownKind::FirstMoment => 1e-5,
        _ => 1e-6,
    };
    let jac =
        common::assert_jacobian_matches("ur10 under gravity", &problem, &x, &step, &|column, _| {
            1e-5 * column.iter().fold(1e-12, |a: f64, v| a.max(v.abs())) + 1e-9
        });
    let m = jac.nrows();
    // The compliance columns are not trivially zero.
    let c2 = problem
        .names()
        .iter()
        .position(|n| n == "compliance_theta2")
        .unwrap();
    assert!((0..m).any(|i| jac[(i, c2)].abs() > 1.0));
}

#[test]
fn identifies_known_joint_compliances_of_a_simulated_ur10() {
    let model = ur10();
    let gravity = GravityCompliance::ur10_urdf(&model).unwrap();
    let truth = truth(&model, 7);
    let frame = Isometry3::from_parts(
        Translation3::new(0.4, -3.2, 0.1),
        rotation_from_vector(&Vector3::new(0.0, 0.05, 1.5)),
    );
    let noise = 20e-6;
    let train = simulate(&model, &gravity, &truth, &frame, 600, noise, 11);
    let validation = simulate(&model, &gravity, &truth, &frame, 300, noise, 12);
    let mut options = CalibrationOptions::for_model(&model);
    options.weighting = Weighting::Uniform;
    options.default_position_std = noise;
    options.target = flexcal_calib::FrameTreatment::Fixed;
    let geometric = calibrate(&model, &train, &options).unwrap();
    options.gravity = Some(gravity.clone());
    let elastic = calibrate(&model, &train, &options).unwrap();
    assert!(elastic.solve.termination.is_converged());
    // Figure 7 data: one entry per iterate, the last one the final fit.
    assert_eq!(elastic.residual_history.len(), elastic.cost_history.len());
    let last = elastic.residual_history.last().unwrap();
    assert!(
        (last.position_rms - elastic.training_after.position_rms).abs()
            < 1e-9 * elastic.training_after.position_rms,
        "{last:?} vs {:?}",
        elastic.training_after
    );
    assert!(elastic.residual_history[0].position_rms > 10.0 * last.position_rms);
    let status = |name: &str| {
        elastic
            .unknowns
            .iter()
            .find(|u| u.name == name)
            .unwrap()
            .clone()
    };
    // Joint 1's axis is vertical: gravity never loads it, its compliance
    // moves nothing.
    assert_eq!(
        status("compliance_theta1").status,
        UnknownStatus::NoInfluence
    );
    // The heavily loaded joints are identified, within 3 standard errors.
    for (name, true_value) in [
        ("compliance_theta2", truth.compliance[1]),
        ("compliance_theta3", truth.compliance[2]),
    ] {
        common::assert_recovered(&elastic, name, true_value);
    }
    // The wrist's compliances are judged on their own scale: each one
    // kept lies within 3 standard errors of the truth, and each one left
    // out carries the fit that judged it (its value under 2 standard
    // errors).
    for (j, name) in [
        "compliance_theta4",
        "compliance_theta5",
        "compliance_theta6",
    ]
    .iter()
    .enumerate()
    {
        let u = status(name);
        match u.status {
            UnknownStatus::Identified => {
                let se = u.standard_error.unwrap();
                assert!(
                    (u.value - truth.compliance[3 + j]).abs() < 3.0 * se,
                    "{name}: {} +/- {se}",
                    u.value
                );
                assert!(
                    u.value.abs().max(u.initial.abs()) >= 2.0 * se,
                    "{name} kept below z = 2"
                );
            }
            UnknownStatus::PoorlyIdentifiable => match u.judgement {
                Some(judged) => assert!(
                    judged.value.abs().max(u.initial.abs()) < 2.0 * judged.standard_error,
                    "{name}"
                ),
                // Left at its start before any fit: a barely loaded joint.
                None => {
                    let span = elastic.torque_ranges[3 + j];
                    let largest = elastic
                        .torque_ranges
                        .iter()
                        .map(|r| r.lo.abs().max(r.hi.abs()))
                        .fold(0.0, f64::max);
                    assert!(
                        span.lo.abs().max(span.hi.abs())
                            < flexcal_calib::significance::MIN_TORQUE_SHARE * largest,
                        "{name}"
                    );
                }
            },
            // Exactly dependent on others, or (a joint gravity never
            // loads) moving nothing at all.
            other => assert!(
                matches!(
                    other,
                    UnknownStatus::NonIdentifiable | UnknownStatus::NoInfluence
                ),
                "{name}: {other:?}"
            ),
        }
    }
    // Every sentence about the compliances tells the torque or the reason.
    let notes = elastic.identifiability_notes();
    let joint_note = notes
        .iter()
        .find(|n| n.starts_with("joint compliances"))
        .expect("a note on the joint compliances");
    assert!(
        joint_note
            .contains("compliance_theta1 (torque range +/-0.0 N.m: too little gravity torque)"),
        "{joint_note}"
    );
    // The torques the compliances were identified over: the span of each
    // joint's gravity torque over the training poses, named in the notes.
    assert!(geometric.torque_ranges.is_empty());
    let torques = gravity.joint_torques(&model, &train).unwrap();
    assert_eq!(elastic.torque_ranges.len(), model.n_actuated());
    for (i, span) in elastic.torque_ranges.iter().enumerate() {
        let (lo, hi) = torques
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), t| {
                (a.min(t[i]), b.max(t[i]))
            });
        assert_eq!((span.lo, span.hi, span.period), (lo, hi, None));
    }
    let span = elastic.torque_ranges[1];
    let expected = format!(
        "%; torque {:.1} to {:.1} N.m)",
        (span.lo * 10.0).round() / 10.0 + 0.0,
        (span.hi * 10.0).round() / 10.0 + 0.0
    );
    assert!(
        elastic
            .identifiability_notes()
            .iter()
            .any(|n| n.contains(&expected)),
        "{:?}",
        elastic.identifiability_notes()
    );
    // Validated on other poses: down to the noise, and well below what
    // geometry alone reaches.
    let e = elastic.validate(&model, &validation, false).unwrap();
    let g = geometric.validate(&model, &validation, false).unwrap();
    let noise_mean = noise * (8.0 / std::f64::consts::PI).sqrt();
    assert!(
        e.after.position_mean < 1.3 * noise_mean,
        "elasto-geometric {:?}",
        e.after
    );
    assert!(
        g.after.position_mean > 2.0 * e.after.position_mean,
        "geometric {:?} vs elasto-geometric {:?}",
        g.after,
        e.after
    );
}

#[test]
fn mass_tables_round_trip_and_bad_ones_are_named() {
    let model = ur10();
    let table = GravityCompliance::ur10_urdf(&model).unwrap();
    let text = table.to_toml_string().unwrap();
    let back = GravityCompliance::from_toml_str(&text, "ur10.toml").unwrap();
    assert_eq!(back.masses.len(), table.masses.len());
    for (a, b) in back.masses.iter().zip(&table.masses) {
        assert_eq!(a.name, b.name);
        assert_eq!(a.frame, b.frame);
        assert!((a.mass - b.mass).abs() < 1e-12);
        assert!((a.center - b.center).norm() < 1e-12);
    }
    assert!((back.initial_compliance - table.initial_compliance).abs() < 1e-18);
    assert!((back.payload_center - table.payload_center).norm() < 1e-12);
    assert!((back.gravity - table.gravity).norm() < 1e-12);

    let bad_field = "payload_mass_kg = 1.0\npayload_center_mm = [0.0, 0.0, 100.0]\ninitial_compliance_urad_per_nm = 1.0\n\n[[mass]]\nname = \"arm\"\nframe = \"2\"\nmass_kg = 3.0\ncentre_mm = [0.0, 0.0, 0.0]\n";
    let err = GravityCompliance::from_toml_str(bad_field, "masses.toml").unwrap_err();
    let message = err.to_string();
    assert!(
        message.starts_with("masses.toml:") && message.contains("centre_mm"),
        "{message}"
    );
    let negative = text.replacen("mass_kg = 12.93", "mass_kg = -12.93", 1);
    assert_ne!(negative, text);
    let err = GravityCompliance::from_toml_str(&negative, "neg.toml").unwrap_err();
    assert!(err.to_string().contains("upper arm"), "{err}");
    // A mass on a frame the robot does not have is named when used.
    let mut missing = table.clone();
    missing.masses[1].frame = "7".into();
    let set = simulate(
        &model,
        &table,
        &truth(&model, 1),
        &Isometry3::identity(),
        30,
        0.0,
        1,
    );
    let mut options = CalibrationOptions::for_model(&model);
    options.gravity = Some(missing);
    match calibrate(&model, &set, &options) {
        Err(CalibError::InvalidOption { reason, .. }) => {
            assert!(
                reason.contains("upper arm") && reason.contains("`7`"),
                "{reason}"
            )
        }
        other => panic!("expected an invalid mass table, got {other:?}"),
    }
    // Only ur10 has a built-in table.
    let ir663 = RobotDescription::builtin("ir663").unwrap().build().unwrap();
    assert!(GravityCompliance::builtin(&ir663).is_err());
}

/// The joint torques of the mass table are the work rates of the weights:
/// `tau_i = sum_k F_k . d p_k / d q_i` over the links' centres of mass and
/// the payload's, against central differences of `sum_k F_k . p_k(q)` on
/// the nominal geometry; and a bad mass table is named.
#[test]
fn joint_torques_are_the_work_rates_of_the_weights() {
    use flexcal_kinematics::{Data, forward_frame_pose, forward_pose};
    let model = ur10();
    let gravity = GravityCompliance::ur10_urdf(&model).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let configurations: Vec<Vec<f64>> = (0..20)
        .map(|_| common::ur10_configuration(&mut rng))
        .collect();
    let set = MeasurementSet::new(
        "torques",
        configurations
            .iter()
            .map(|q| flexcal_calib::Measurement::new(q.clone(), Vector3::zeros()))
            .collect(),
    )
    .unwrap();
    let torques = gravity.joint_torques(&model, &set).unwrap();
    assert_eq!(torques.len(), set.len());
    let xi = model.nominal_params().to_vec();
    let mut data = Data::new(&model);
    let mut work = |q: &[f64]| -> f64 {
        let mut w = 0.0;
        for m in &gravity.masses {
            let frame = model.frame_index(&m.frame).unwrap();
            let point = Isometry3::from_parts(Translation3::from(m.center), Default::default());
            let p = forward_frame_pose(&model, &mut data, q, &xi, frame, &point).unwrap();
            w += (gravity.gravity * m.mass).dot(&p.translation.vector);
        }
        let tcp = forward_pose(&model, &mut data, q, &xi).unwrap();
        let payload = tcp * nalgebra::Point3::from(gravity.payload_center);
        w + (gravity.gravity * gravity.payload_mass).dot(&payload.coords)
    };
    let h = 1e-6;
    for (q, tau) in configurations.iter().zip(&torques) {
        for i in 0..model.n_actuated() {
            let (mut plus, mut minus) = (q.clone(), q.clone());
            plus[i] += h;
            minus[i] -= h;
            let fd = (work(&plus) - work(&minus)) / (2.0 * h);
            assert!(
                (tau[i] - fd).abs() < 1e-6 * (1.0 + fd.abs()),
                "joint {i}: {} vs {fd}",
                tau[i]
            );
        }
    }
    // The shoulder of a UR10 holding its arm out carries tens of N.m.
    assert!(torques.iter().any(|t| t[1].abs() > 50.0));
    let mut bad = gravity.clone();
    bad.masses[0].frame = "no_such_frame".into();
    let err = bad.joint_torques(&model, &set).unwrap_err().to_string();
    assert!(err.contains("no_such_frame"), "{err}");
}
