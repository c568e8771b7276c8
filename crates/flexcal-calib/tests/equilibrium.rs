//! The elastic deflection as the static equilibrium
//! ([`flexcal_calib::equilibrium`]) on the compliant two-armed torso of
//! `tests/data/compliant_torso.toml`: exact derivatives, agreement with an
//! exact fixed point written here, a named error when it cannot converge,
//! the option's checks and its mass-table form.

use std::borrow::Cow;

use flexcal_calib::{
    CalibError, Deflection, ErrorModel, FrameStarts, GravityCompliance, JointLaw, JointTerms,
    LateralCompliance, MeasurementSet, Payload, TargetObservation, TargetPose, UnknownKind,
    read_targets,
};
use flexcal_kinematics::{Data, Model, RobotDescription, actuated_forces_into};
use nalgebra::{Isometry3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

mod common;

fn data_file(name: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

fn robot() -> Model {
    RobotDescription::from_toml_file(&data_file("compliant_torso.toml"))
        .unwrap()
        .build()
        .unwrap()
}

fn masses() -> GravityCompliance {
    GravityCompliance::from_toml_file(&data_file("compliant_torso_masses.toml")).unwrap()
}

/// `n` poses drawn uniformly over the joint limits, both markers seen at
/// arbitrary positions (the Jacobian does not depend on them).
fn poses(model: &Model, n: usize, seed: u64) -> MeasurementSet {
    let targets = read_targets(&data_file("compliant_torso_targets.toml")).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let poses = (0..n)
        .map(|k| TargetPose {
            pose_id: Some(format!("p{k}")),
            q: model
                .actuated_limits()
                .iter()
                .map(|&(lo, hi)| rng.random_range(lo..hi))
                .collect(),
            observations: (0..targets.len())
                .map(|_| {
                    Some(TargetObservation::new(Vector3::from_fn(|_, _| {
                        rng.random_range(-1.0..1.0)
                    })))
                })
                .collect(),
            wrench: None,
            temperature_c: None,
        })
        .collect();
    MeasurementSet::from_poses("equilibrium", targets, poses).unwrap()
}

fn problem<'a>(
    model: &'a Model,
    set: &'a MeasurementSet,
    gravity: &GravityCompliance,
    terms: &JointTerms,
) -> ErrorModel<'a> {
    let starts = FrameStarts::nominal(set, Isometry3::identity(), None).unwrap();
    ErrorModel::new(model, Cow::Borrowed(set), &starts)
        .unwrap()
        .with_elastic(Some(gravity), terms)
        .unwrap()
}

/// A soft robot's unknowns: compliances 100-400 urad/N.m about the joints,
/// 20-50 about the lateral axes and springs, payloads of a few kg, the
/// law's hardening, small frame and geometry increments.
fn soft_unknowns(model: &Model, problem: &ErrorModel<'_>, seed: u64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let kinds = problem.kinds();
    let lateral = problem.lateral_offset().unwrap_or(usize::MAX);
    let mut x = problem.initial_unknowns();
    for v in x[model.n_params()..problem.frames_end()].iter_mut() {
        *v = rng.random_range(-0.02..0.02);
    }
    for (j, v) in x.iter_mut().enumerate().skip(problem.frames_end()) {
        *v = match kinds[j] {
            UnknownKind::Compliance if j >= lateral => rng.random_range(20e-6..50e-6),
            UnknownKind::Compliance => rng.random_range(100e-6..400e-6),
            UnknownKind::Mass => rng.random_range(1.0..3.0),
            UnknownKind::FirstMoment => rng.random_range(-0.1..0.1),
            UnknownKind::Hardening => rng.random_range(0.0..300.0),
            _ => rng.random_range(-2e-4..2e-4),
        };
    }
    x
}

/// Every elastic term with the equilibrium: joint compliances (the
/// coupled torso included), lateral compliances about x and the springs
/// of the table, the table's payload and one identified on each hand, and
/// the stiffening law. Each column against central differences at a soft
/// robot's unknowns.
#[test]
fn equilibrium_columns_match_central_differences() {
    let model = robot();
    let set = poses(&model, 5, 0xE0);
    let mut gravity = masses();
    gravity.deflection = Deflection::equilibrium();
    gravity.lateral = LateralCompliance::AboutX;
    gravity.payloads = ["LH", "RH"]
        .iter()
        .map(|frame| Payload {
            name: frame.to_lowercase(),
            frame: frame.to_string(),
            mass: 1.0,
            center: Vector3::new(0.0, 0.0, 0.05),
            identify: true,
        })
        .collect();
    for terms in [
        JointTerms::default(),
        JointTerms {
            law: Some(JointLaw::default()),
            cyclic: false,
        },
    ] {
        let problem = problem(&model, &set, &gravity, &terms);
        let kinds = problem.kinds();
        let x = soft_unknowns(&model, &problem, 0xE1);
        let step = |j: usize| match kinds[j] {
            UnknownKind::Compliance => 1e-7,
            UnknownKind::Hardening => 1e-2,
            UnknownKind::Mass | UnknownKind::FirstMoment => 1e-5,
            _ => 1e-7,
        };
        common::assert_jacobian_matches(
            &format!("equilibrium, law {}", terms.law.is_some()),
            &problem,
            &x,
            &step,
            &|column, _| 1e-5 * column.iter().fold(1e-12, |a: f64, v| a.max(v.abs())) + 1e-9,
        );
    }
}

/// The exact equilibrium of the joint springs, written here apart from
/// the library: `dq = C tau(q + dq)` with the torques re-evaluated on the
/// deflected robot at every iteration, to 1e-14 rad.
fn exact_deflection(model: &Model, gravity: &GravityCompliance, c: &[f64], q: &[f64]) -> Vec<f64> {
    let loads = common::link_loads(model, gravity);
    let mut data = Data::new(model);
    let mut dq = vec![0.0; q.len()];
    let mut tau = vec![0.0; q.len()];
    for _ in 0..200 {
        let moved: Vec<f64> = q.iter().zip(&dq).map(|(a, b)| a + b).collect();
        actuated_forces_into(
            model,
            &mut data,
            &moved,
            model.nominal_params(),
            &loads,
            &mut tau,
        )
        .unwrap();
        let next: Vec<f64> = tau.iter().zip(c).map(|(t, c)| t * c).collect();
        let change = next
            .iter()
            .zip(&dq)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        dq = next;
        if change < 1e-14 {
            return dq;
        }
    }
    panic!("the exact equilibrium did not converge");
}

/// With joint compliances of 100-400 urad/N.m the one step misplaces the
/// markers by up to millimetres against the exact equilibrium; the
/// library's equilibrium (torques to first order in the deflection) comes
/// within a small share of that.
#[test]
fn the_equilibrium_agrees_with_the_exact_fixed_point() {
    let model = robot();
    let set = poses(&model, 40, 0xE2);
    let mut gravity = masses();
    gravity.lateral = LateralCompliance::Off;
    gravity.springs.clear();
    let one_step = problem(&model, &set, &gravity, &JointTerms::default());
    let mut x = one_step.initial_unknowns();
    let eo = one_step.elastic_offset().unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(0xE3);
    let c: Vec<f64> = (0..model.n_actuated())
        .map(|_| rng.random_range(100e-6..400e-6))
        .collect();
    x[eo..eo + c.len()].copy_from_slice(&c);
    let predicted_one_step = one_step.predict(&x).unwrap();
    gravity.deflection = Deflection::equilibrium();
    let equilibrium = problem(&model, &set, &gravity, &JointTerms::default());
    let predicted_equilibrium = equilibrium.predict(&x).unwrap();
    let mut data = Data::new(&model);
    let [one_step_error, equilibrium_error] = common::largest_errors(
        &one_step,
        [&predicted_one_step, &predicted_equilibrium],
        |k, t| {
            let q = &set.poses()[k].q;
            let dq = exact_deflection(&model, &gravity, &c, q);
            let moved: Vec<f64> = q.iter().zip(&dq).map(|(a, b)| a + b).collect();
            flexcal_kinematics::forward_frames(&model, &mut data, &moved, model.nominal_params())
                .unwrap();
            let target = &set.targets()[t];
            let frame = model.frame_index(&target.frame).unwrap();
            (data.frame_pose(frame).unwrap() * target.pose())
                .translation
                .vector
        },
    );
    common::equilibrium_beats_one_step(
        "against the exact equilibrium",
        one_step_error,
        equilibrium_error,
    );
}

/// Springs far softer than gravity's stiffness have no stable
/// equilibrium: the model names the pose instead of returning a buckled
/// deflection; an iteration cap too low is named too.
#[test]
fn springs_too_soft_for_their_load_are_a_named_error() {
    let model = robot();
    let set = poses(&model, 3, 0xE4);
    let mut gravity = masses();
    gravity.deflection = Deflection::Equilibrium {
        tolerance_rad: 1e-9,
        max_iterations: 50,
    };
    let soft = problem(&model, &set, &gravity, &JointTerms::default());
    let mut x = soft.initial_unknowns();
    let eo = soft.elastic_offset().unwrap();
    x[eo..eo + model.n_actuated()].fill(0.2);
    match soft.predict(&x) {
        Err(error @ CalibError::EquilibriumNotConverged { pose, unstable, .. }) => {
            assert!(unstable, "{error}");
            assert!(pose < 3);
            assert!(error.to_string().contains("unstable"), "{error}");
        }
        other => panic!("expected EquilibriumNotConverged, got {other:?}"),
    }
    // An iteration cap too low for the stiffening law is named too.
    let mut gravity = masses();
    gravity.deflection = Deflection::Equilibrium {
        tolerance_rad: 1e-12,
        max_iterations: 1,
    };
    let terms = JointTerms {
        law: Some(JointLaw::default()),
        cyclic: false,
    };
    let capped = problem(&model, &set, &gravity, &terms);
    let x = soft_unknowns(&model, &capped, 0xE6);
    match capped.predict(&x) {
        Err(
            error @ CalibError::EquilibriumNotConverged {
                iterations,
                unstable,
                ..
            },
        ) => {
            assert_eq!(iterations, 1);
            assert!(!unstable);
            assert!(error.to_string().contains("did not converge"), "{error}");
        }
        other => panic!("expected EquilibriumNotConverged, got {other:?}"),
    }
}

#[test]
fn deflection_options_are_checked_and_read_from_the_mass_table() {
    for bad in [
        Deflection::Equilibrium {
            tolerance_rad: 0.0,
            max_iterations: 10,
        },
        Deflection::Equilibrium {
            tolerance_rad: f64::NAN,
            max_iterations: 10,
        },
        Deflection::Equilibrium {
            tolerance_rad: 1e-9,
            max_iterations: 0,
        },
        Deflection::Auto { share: 0.0 },
        Deflection::Auto { share: 1.5 },
    ] {
        let message = bad.check().unwrap_err().to_string();
        assert!(message.contains("deflection"), "{message}");
    }
    assert_eq!(
        "equilibrium".parse::<Deflection>().unwrap(),
        Deflection::equilibrium()
    );
    assert_eq!("auto".parse::<Deflection>().unwrap(), Deflection::auto());
    assert!("two-steps".parse::<Deflection>().is_err());
    // The table's [deflection] round-trips; a table without it is the one
    // step.
    let mut gravity = masses();
    assert_eq!(gravity.deflection, Deflection::OneStep);
    gravity.deflection = Deflection::Auto { share: 0.1 };
    let text = gravity.to_toml_string().unwrap();
    let back = GravityCompliance::from_toml_str(&text, "round trip").unwrap();
    assert_eq!(back, gravity);
    let bad = format!("{text}\n").replace("share = 0.1", "share = 0.1\nsteps = 2");
    let message = GravityCompliance::from_toml_str(&bad, "masses.toml")
        .unwrap_err()
        .to_string();
    assert!(message.contains("masses.toml"), "{message}");
    // A bad value is refused when the table meets a robot.
    let model = robot();
    let set = poses(&model, 2, 0xE5);
    gravity.deflection = Deflection::Auto { share: -1.0 };
    let starts = FrameStarts::nominal(&set, Isometry3::identity(), None).unwrap();
    let refused = ErrorModel::new(&model, Cow::Borrowed(&set), &starts)
        .unwrap()
        .with_elastic(Some(&gravity), &JointTerms::default());
    assert!(refused.is_err());
}

/// Regression: with the stiffening law, the fixed-point iteration stalled
/// (1.3e-9 rad) and Newton's full steps diverged at an optimiser's trial
/// point on folds of IPA series B, stopping the fit; Newton's method with
/// backtracking fits the whole series and each fold of a 5-fold split.
#[test]
fn the_law_with_the_equilibrium_fits_ipa_series_b_and_its_folds() {
    let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/datasets/ipa-ur10/Series_B/measurements_joint_configurations.csv");
    if !file.exists() {
        eprintln!("IPA UR10 data absent ({}): skipped", file.display());
        return;
    }
    let model = RobotDescription::builtin("ur10").unwrap().build().unwrap();
    let set = flexcal_calib::MeasurementSet::read_ipa(&file).unwrap();
    let mut options = flexcal_calib::CalibrationOptions::for_model(&model);
    options.use_orientation = Some(false);
    options.weighting = flexcal_calib::Weighting::Uniform;
    let mut gravity = GravityCompliance::ur10_urdf(&model).unwrap();
    gravity.deflection = Deflection::equilibrium();
    options.gravity = Some(gravity);
    options.joint_terms = JointTerms {
        law: Some(JointLaw::default()),
        cyclic: true,
    };
    flexcal_calib::calibrate(&model, &set, &options).unwrap();
    for k in 0..5 {
        let kept: Vec<usize> = (0..set.len()).filter(|i| i % 5 != k).collect();
        let fold = set.subset(&kept).unwrap();
        if let Err(e) = flexcal_calib::calibrate(&model, &fold, &options) {
            panic!("fold {k}: {e}");
        }
    }
}
