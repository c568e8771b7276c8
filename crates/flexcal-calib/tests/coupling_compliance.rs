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
use flexcal_kinematics::{Data, Model, PointLoad, actuated_forces_into, forward_frames};
use nalgebra::{Isometry3, Point3, UnitQuaternion, Vector3};
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
    // The group works with every deflection: the one step, the
    // equilibrium (the entries in its Newton system) and auto.
    for deflection in [
        flexcal_calib::Deflection::OneStep,
        flexcal_calib::Deflection::equilibrium(),
        flexcal_calib::Deflection::auto(),
    ] {
        let mut both = table(GROUP).unwrap();
        both.deflection = deflection;
        assert!(
            problem(&model, &set, &both).is_ok(),
            "{}",
            deflection.name()
        );
    }
}

/// Soft joints (100-400 urad/N.m), cross terms of both signs, a payload
/// identified on the left hand (its columns change through the cross
/// terms), every lateral compliance on; with the one step and with the
/// equilibrium (the cross terms in its Newton system, the columns by the
/// implicit function theorem).
#[test]
fn the_coupling_columns_match_central_differences() {
    let model = robot();
    let set = poses(&model, 5, 3);
    for deflection in [
        flexcal_calib::Deflection::OneStep,
        flexcal_calib::Deflection::equilibrium(),
    ] {
        let mut gravity = table(&format!(
            "{GROUP}\n[[payload]]\nname = \"left\"\nframe = \"LH\"\nmass_kg = 1.5\ncenter_mm = [10.0, -20.0, 60.0]\n"
        ))
        .unwrap();
        gravity.deflection = deflection;
        coupling_columns_match(&model, &set, &gravity);
    }
}

fn coupling_columns_match(model: &Model, set: &MeasurementSet, gravity: &GravityCompliance) {
    let problem = problem(model, set, gravity).unwrap();
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
    // Central differences of step h carry the predictions' rounding
    // divided by h: about 2e-16 m / 1e-9 = 2e-7 m per rad/N.m for a
    // compliance, a few 1e-5 of a column. The equilibrium's predictions
    // (a Newton solve more) round a little more than the one step's, so
    // its columns take the steps of `tests/equilibrium.rs`.
    let one_step = gravity.deflection.is_one_step();
    let step = |j: usize| match kinds[j] {
        UnknownKind::Compliance if one_step => 1e-9,
        UnknownKind::Compliance => 1e-7,
        UnknownKind::Mass | UnknownKind::FirstMoment => 1e-5,
        _ if one_step => 1e-6,
        _ => 1e-7,
    };
    let label = format!("coupling, {}", gravity.deflection.name());
    let jac = common::assert_jacobian_matches(&label, &problem, &x, &step, &|column, _| {
        1e-5 * column.iter().fold(1e-12, |a: f64, v| a.max(v.abs())) + 1e-9
    });
    // The columns are not empty: each cross term moves the markers.
    for (j, name) in problem.names().iter().enumerate() {
        if name.starts_with("coupling_compliance_") {
            let largest = (0..jac.nrows()).fold(0.0_f64, |a, i| a.max(jac[(i, j)].abs()));
            assert!(
                largest > 1.0,
                "{label}: {name}: largest entry {largest} m per rad/N.m"
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

/// The gravity moment (N.m) about frame `f`'s z axis, through its origin,
/// of every load that moves with the frame, on the geometry the last
/// forward pass left in `data`.
fn moment_about_z(model: &Model, data: &Data, loads: &[PointLoad], f: usize) -> f64 {
    let t_f = data.frame_pose(f).unwrap();
    let axis = t_f.rotation * Vector3::z();
    let origin = t_f.translation.vector;
    loads
        .iter()
        .filter(|l| model.moves_with(l.frame, f))
        .map(|load| {
            let p = data.frame_pose(load.frame).unwrap() * Point3::from(load.point);
            axis.dot(&(p.coords - origin).cross(&load.force))
        })
        .sum()
}

/// A coupled group's compliances: the drives' own, the passive joint's
/// own (about its z axis), and the cross terms (rad/N.m).
struct Group {
    drives: Vec<f64>,
    passive: f64,
    t2_t3: f64,
    t2_t4: f64,
    t3_t4: f64,
}

/// The exact static equilibrium of the joint springs and the coupled
/// group (T2, T3, T4), written here apart from the library: the drives
/// turn by `dq = C tau + X [tau_T2, tau_T3, M_T4]` and the passive joint
/// by `delta = c_p M_T4 + c_T2_T4 tau_T2 + c_T3_T4 tau_T3`, with the
/// torques re-evaluated on the deflected robot at every iteration until
/// nothing moves by 1e-14 rad. The passive rotation turns the markers as
/// the library's lateral springs do, and its own lever arm does not load
/// the torques (crate docs' Limitations: what this test checks is the
/// Newton system of the joint deflections with the group's entries).
/// Returns the marker positions of pose `q` (m), one per target.
fn exact_coupled_markers(
    model: &Model,
    set: &MeasurementSet,
    loads: &[PointLoad],
    group: &Group,
    q: &[f64],
) -> Vec<Vector3<f64>> {
    let mut data = Data::new(model);
    let t4 = model.frame_index("T4").unwrap();
    let drive = |name: &str| common::actuated_index(model, name);
    let (i2, i3) = (drive("thetaT2"), drive("thetaT3"));
    let mut dq = vec![0.0; q.len()];
    let mut tau = vec![0.0; q.len()];
    let mut moved = q.to_vec();
    for _ in 0..200 {
        moved = q.iter().zip(&dq).map(|(a, b)| a + b).collect();
        actuated_forces_into(
            model,
            &mut data,
            &moved,
            model.nominal_params(),
            loads,
            &mut tau,
        )
        .unwrap();
        forward_frames(model, &mut data, &moved, model.nominal_params()).unwrap();
        let m4 = moment_about_z(model, &data, loads, t4);
        let mut next: Vec<f64> = tau.iter().zip(&group.drives).map(|(t, c)| t * c).collect();
        next[i2] += group.t2_t3 * tau[i3] + group.t2_t4 * m4;
        next[i3] += group.t2_t3 * tau[i2] + group.t3_t4 * m4;
        let change = next
            .iter()
            .zip(&dq)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        dq = next;
        if change < 1e-14 {
            let delta = group.passive * m4 + group.t2_t4 * tau[i2] + group.t3_t4 * tau[i3];
            // The passive rotation as the library's lateral springs turn
            // the structure (crate docs' Limitations): about the axis on
            // the commanded configuration, `p' = R(delta z) p - delta z x o`.
            let mut commanded = Data::new(model);
            forward_frames(model, &mut commanded, q, model.nominal_params()).unwrap();
            let t_f = commanded.frame_pose(t4).unwrap();
            let axis = nalgebra::Unit::new_normalize(t_f.rotation * Vector3::z());
            let origin = t_f.translation.vector;
            let turn = UnitQuaternion::from_axis_angle(&axis, delta);
            return set
                .targets()
                .iter()
                .map(|target| {
                    let frame = model.frame_index(&target.frame).unwrap();
                    let marker = (data.frame_pose(frame).unwrap() * target.pose())
                        .translation
                        .vector;
                    if model.moves_with(frame, t4) {
                        turn * marker - delta * axis.cross(&origin)
                    } else {
                        marker
                    }
                })
                .collect();
        }
    }
    panic!("the exact coupled equilibrium did not converge at {moved:?}");
}

/// The equilibrium with a coupling group against its exact fixed point:
/// joint compliances of 100-400 urad/N.m, the passive joint's 200 and
/// cross terms of both signs (a mechanism's, as in
/// `tests/compliant_torso.rs`). The one step misplaces the markers by
/// millimetres; the library's equilibrium (torques to first order in the
/// deflection, the group's entries in its Newton system) comes within a
/// small share of that.
#[test]
fn the_equilibrium_with_a_group_agrees_with_its_exact_fixed_point() {
    let model = robot();
    let set = poses(&model, 40, 0xC0);
    let mut gravity = table(GROUP).unwrap();
    gravity.lateral = flexcal_calib::LateralCompliance::Off;
    gravity.springs.retain(|s| s.frame == "T4");
    let one_step = problem(&model, &set, &gravity).unwrap();
    gravity.deflection = flexcal_calib::Deflection::equilibrium();
    let equilibrium = problem(&model, &set, &gravity).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(0xC1);
    let group = Group {
        drives: (0..model.n_actuated())
            .map(|_| rng.random_range(100e-6..400e-6))
            .collect(),
        passive: 200e-6,
        t2_t3: 20e-6,
        t2_t4: -40e-6,
        t3_t4: -80e-6,
    };
    let names = one_step.names();
    let index = |name: &str| names.iter().position(|n| n == name).unwrap();
    let mut x = one_step.initial_unknowns();
    let eo = one_step.elastic_offset().unwrap();
    x[eo..eo + group.drives.len()].copy_from_slice(&group.drives);
    x[index("lateral_compliance_T4_z")] = group.passive;
    x[index("coupling_compliance_T2_T3")] = group.t2_t3;
    x[index("coupling_compliance_T2_T4")] = group.t2_t4;
    x[index("coupling_compliance_T3_T4")] = group.t3_t4;
    let (predicted_one_step, predicted_equilibrium) = (
        one_step.predict(&x).unwrap(),
        equilibrium.predict(&x).unwrap(),
    );
    let loads = common::link_loads(&model, &gravity);
    let exact: Vec<Vec<Vector3<f64>>> = set
        .poses()
        .iter()
        .map(|pose| exact_coupled_markers(&model, &set, &loads, &group, &pose.q))
        .collect();
    let [one_step_error, equilibrium_error] = common::largest_errors(
        &one_step,
        [&predicted_one_step, &predicted_equilibrium],
        |k, t| exact[k][t],
    );
    common::equilibrium_beats_one_step(
        "coupled group against its exact equilibrium",
        one_step_error,
        equilibrium_error,
    );
}
