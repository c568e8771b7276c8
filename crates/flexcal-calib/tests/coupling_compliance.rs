//! The compliance of a coupled joint group as a symmetric matrix
//! (`[[coupling_compliance]]` in the mass table, `flexcal_calib::coupling`):
//! the mass table reads and writes it, bad groups are named errors, the
//! new unknowns' Jacobian columns (and the payload columns they change)
//! match central differences, and a table without the entry, or with its
//! entries at zero, predicts what it always did. The recovery of a
//! mechanism's cross terms from simulated measurements is in
//! `tests/compliant_torso.rs` (its truth).

use std::borrow::Cow;

use flexcal_calib::{
    CouplingGroup, ErrorModel, FrameStarts, GravityCompliance, JointTerms, MeasurementSet,
    TargetObservation, TargetPose, UnknownKind, read_targets,
};
use flexcal_kinematics::Model;
use nalgebra::{Isometry3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

mod common;

use common::{compliant_torso as robot, data_file};

/// The compliant torso's mass table with `extra` TOML appended.
fn table(extra: &str) -> Result<GravityCompliance, flexcal_calib::CalibError> {
    let text = std::fs::read_to_string(data_file("compliant_torso_masses.toml")).unwrap();
    GravityCompliance::from_toml_str(&format!("{text}\n{extra}"), "masses")
}

const GROUP: &str = "[[coupling_compliance]]\njoints = [\"T2\", \"T3\", \"T4\"]\n";

/// `n` poses over the joint limits, both markers seen (observations at
/// zero: the Jacobian and predictions do not depend on them).
fn poses(model: &Model, n: usize, seed: u64) -> MeasurementSet {
    let targets = read_targets(&data_file("compliant_torso_targets.toml")).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let poses = (0..n)
        .map(|_| TargetPose {
            pose_id: None,
            q: model
                .actuated_limits()
                .iter()
                .map(|&(lo, hi)| rng.random_range(lo..hi))
                .collect(),
            observations: vec![Some(TargetObservation::new(Vector3::zeros())); targets.len()],
            wrench: None,
            temperature_c: None,
        })
        .collect();
    MeasurementSet::from_poses("poses", targets, poses).unwrap()
}

fn problem<'a>(
    model: &'a Model,
    set: &'a MeasurementSet,
    gravity: &GravityCompliance,
) -> Result<ErrorModel<'a>, flexcal_calib::CalibError> {
    let starts = FrameStarts::nominal(set, Isometry3::identity(), None)?;
    ErrorModel::new(model, Cow::Borrowed(set), &starts)?
        .with_elastic(Some(gravity), &JointTerms::default())
}

#[test]
fn the_mass_table_reads_and_writes_the_groups() {
    let gravity = table(GROUP).unwrap();
    assert_eq!(
        gravity.coupling,
        vec![CouplingGroup {
            joints: ["T2", "T3", "T4"].map(String::from).to_vec()
        }]
    );
    let model = robot();
    let names = gravity.elastic_unknown_names(&model);
    let tail: Vec<&str> = names[names.len() - 3..]
        .iter()
        .map(String::as_str)
        .collect();
    assert_eq!(
        tail,
        [
            "coupling_compliance_T2_T3",
            "coupling_compliance_T2_T4",
            "coupling_compliance_T3_T4"
        ]
    );
    // They start at zero, after the lateral compliances.
    let x0 = gravity.initial_unknowns(&model);
    assert_eq!(x0.len(), names.len());
    assert!(x0[x0.len() - 3..].iter().all(|v| *v == 0.0));
    let text = gravity.to_toml_string().unwrap();
    let back = GravityCompliance::from_toml_str(&text, "round trip").unwrap();
    assert_eq!(back, gravity, "{text}");
    // A table without the entry writes none.
    let plain = table("").unwrap();
    assert!(!plain.to_toml_string().unwrap().contains("coupling"));
}

#[test]
fn bad_groups_are_named_errors() {
    let model = robot();
    let set = poses(&model, 2, 1);
    // Caught when the table is read: a joint twice, a group of one.
    for (group, expect) in [
        ("[\"T2\", \"T4\", \"T2\"]", "joint `T2` is listed twice"),
        ("[\"T4\"]", "give the passive joint and one or more drives"),
    ] {
        let error = table(&format!("[[coupling_compliance]]\njoints = {group}\n"))
            .unwrap_err()
            .to_string();
        assert!(error.contains(expect), "{error}");
        assert!(error.contains("masses"), "{error}");
    }
    // Caught when the table meets the robot.
    for (group, expect) in [
        ("[\"T2\", \"T9\"]", "no frame `T9`"),
        ("[\"T2\", \"T3\"]", "no passive joint"),
        (
            "[\"L1\", \"T4\"]",
            "joint `L1` is not a drive `T4` is coupled to",
        ),
        (
            "[\"T1\", \"T4\"]",
            "joint `T1` is not a drive `T4` is coupled to",
        ),
    ] {
        let gravity = table(&format!("[[coupling_compliance]]\njoints = {group}\n")).unwrap();
        let error = problem(&model, &set, &gravity).err().unwrap().to_string();
        assert!(
            error.contains(expect) && error.contains("coupling_compliance"),
            "{group}: {error}"
        );
    }
    // The same entry twice.
    let twice = table(&format!("{GROUP}\n{GROUP}")).unwrap();
    let error = problem(&model, &set, &twice).err().unwrap().to_string();
    assert!(error.contains("given by two groups"), "{error}");
    // A passive joint without its own spring (the matrix's diagonal).
    let mut springless = table(GROUP).unwrap();
    springless.springs.retain(|s| s.frame != "T4");
    let error = problem(&model, &set, &springless)
        .err()
        .unwrap()
        .to_string();
    assert!(
        error.contains("`T4` needs its own spring") && error.contains("axes = [\"z\"]"),
        "{error}"
    );
    // The equilibrium is not built for the group's cross terms: asking for
    // both is refused by name, whichever way the table asks.
    for deflection in [
        flexcal_calib::Deflection::equilibrium(),
        flexcal_calib::Deflection::auto(),
    ] {
        let mut both = table(GROUP).unwrap();
        both.deflection = deflection;
        let error = problem(&model, &set, &both).err().unwrap().to_string();
        assert!(
            error.contains("coupling compliance group") && error.contains(deflection.name()),
            "{error}"
        );
    }
    let mut one_step = table(GROUP).unwrap();
    one_step.deflection = flexcal_calib::Deflection::OneStep;
    assert!(problem(&model, &set, &one_step).is_ok());
}

#[test]
fn the_coupling_columns_match_central_differences() {
    // Soft joints (100-400 urad/N.m), cross terms of both signs, a payload
    // identified on the left hand (its columns change through the cross
    // terms), every lateral compliance on.
    let model = robot();
    let set = poses(&model, 5, 3);
    let gravity = table(&format!(
        "{GROUP}\n[[payload]]\nname = \"left\"\nframe = \"LH\"\nmass_kg = 1.5\ncenter_mm = [10.0, -20.0, 60.0]\n"
    ))
    .unwrap();
    let problem = problem(&model, &set, &gravity).unwrap();
    let kinds = problem.kinds();
    let eo = problem.elastic_offset().unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let mut x = problem.initial_unknowns();
    for v in x[model.n_params()..eo].iter_mut() {
        *v = rng.random_range(-0.05..0.05);
    }
    for (j, name) in problem.names().iter().enumerate().skip(eo) {
        x[j] = match kinds[j] {
            _ if name.starts_with("coupling_compliance_") => rng.random_range(-60e-6..60e-6),
            UnknownKind::Compliance => rng.random_range(100e-6..400e-6),
            UnknownKind::Mass | UnknownKind::FirstMoment => x[j] + rng.random_range(-0.1..0.1),
            _ => x[j],
        };
    }
    let step = |j: usize| match kinds[j] {
        UnknownKind::Compliance => 1e-9,
        UnknownKind::Mass | UnknownKind::FirstMoment => 1e-5,
        _ => 1e-6,
    };
    let jac = common::assert_jacobian_matches("coupling", &problem, &x, &step, &|column, _| {
        1e-5 * column.iter().fold(1e-12, |a: f64, v| a.max(v.abs())) + 1e-9
    });
    // The columns are not empty: each cross term moves the markers.
    for (j, name) in problem.names().iter().enumerate() {
        if name.starts_with("coupling_compliance_") {
            let largest = (0..jac.nrows()).fold(0.0_f64, |a, i| a.max(jac[(i, j)].abs()));
            assert!(
                largest > 1.0,
                "{name}: largest entry {largest} m per rad/N.m"
            );
        }
    }
}

#[test]
fn without_the_entry_or_at_zero_the_model_predicts_as_before() {
    let model = robot();
    let set = poses(&model, 4, 5);
    let plain = table("").unwrap();
    let coupled = table(GROUP).unwrap();
    let a = problem(&model, &set, &plain).unwrap();
    let b = problem(&model, &set, &coupled).unwrap();
    assert_eq!(b.names().len(), a.names().len() + 3);
    let mut x = a.initial_unknowns();
    let eo = a.elastic_offset().unwrap();
    for v in &mut x[eo..] {
        if *v == 0.0 {
            *v = 50e-6;
        }
    }
    let mut y = x.clone();
    y.extend([0.0; 3]);
    let (pa, pb) = (a.predict(&x).unwrap(), b.predict(&y).unwrap());
    for (p, q) in pa.iter().zip(&pb) {
        assert!((p.translation.vector - q.translation.vector).norm() < 1e-15);
    }
    // A cross term moves them.
    *y.last_mut().unwrap() = -80e-6;
    let moved = b.predict(&y).unwrap();
    let largest = pa
        .iter()
        .zip(&moved)
        .map(|(p, q)| (p.translation.vector - q.translation.vector).norm())
        .fold(0.0, f64::max);
    assert!(largest > 1e-4, "largest move {largest} m");
}
