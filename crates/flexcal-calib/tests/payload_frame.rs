//! A payload on a named frame (a load carried by a link, a tool changer on
//! one hand of a two-armed robot) against an independent evaluation: the
//! same mass entered as one more link of the mass table. Its gravity
//! torques, and the deflected positions the elasto-geometric model
//! predicts with lateral compliances, must be the same.

use std::borrow::Cow;

use flexcal_calib::{
    ErrorModel, FrameStarts, GravityCompliance, JointTerms, LateralCompliance, Measurement,
    MeasurementSet, Payload, PointMass, TargetObservation, TargetPose,
};
use flexcal_kinematics::{Model, RobotDescription};
use nalgebra::{Isometry3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn data_file(name: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

fn two_arms() -> (Model, GravityCompliance) {
    let model = RobotDescription::from_toml_file(&data_file("two_arms.toml"))
        .unwrap()
        .build()
        .unwrap();
    let gravity = GravityCompliance::from_toml_file(&data_file("two_arms_masses.toml")).unwrap();
    (model, gravity)
}

/// The table with its payload (2.5 kg on `R3` at `c`), and the same mass
/// as a link of a table without payload.
fn tables(gravity: &GravityCompliance) -> (GravityCompliance, GravityCompliance) {
    let center = Vector3::new(0.03, -0.02, 0.11);
    let payload = GravityCompliance {
        payload_mass: 2.5,
        payload_center: center,
        payload_frame: Some("R3".into()),
        lateral: LateralCompliance::AboutX,
        ..gravity.clone()
    };
    let mut masses = gravity.masses.clone();
    masses.push(PointMass {
        name: "changer".into(),
        frame: "R3".into(),
        mass: 2.5,
        center,
    });
    let link = GravityCompliance {
        masses,
        payload_mass: 0.0,
        payload_center: Vector3::zeros(),
        payload_frame: None,
        lateral: LateralCompliance::AboutX,
        ..gravity.clone()
    };
    (payload, link)
}

fn configurations(model: &Model, n: usize) -> Vec<Vec<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(0x7061_796c);
    (0..n)
        .map(|_| {
            model
                .actuated_limits()
                .iter()
                .map(|&(lo, hi)| rng.random_range(lo..hi))
                .collect()
        })
        .collect()
}

#[test]
fn a_payload_on_a_link_loads_the_joints_as_that_link_would() {
    let (model, gravity) = two_arms();
    let (payload, link) = tables(&gravity);
    let set = MeasurementSet::new(
        "poses",
        configurations(&model, 20)
            .into_iter()
            .map(|q| Measurement::new(q, Vector3::zeros()))
            .collect(),
    )
    .unwrap();
    let a = payload.joint_torques(&model, &set).unwrap();
    let b = link.joint_torques(&model, &set).unwrap();
    let mut largest: f64 = 0.0;
    for (a, b) in a.iter().zip(&b) {
        for (x, y) in a.iter().zip(b) {
            assert!((x - y).abs() < 1e-9 * (1.0 + y.abs()), "{x} vs {y}");
            largest = largest.max(y.abs());
        }
    }
    assert!(largest > 10.0, "the torques are loaded: {largest} N.m");
    // The left arm's joints carry none of it: the same torques as without
    // any payload.
    let without = GravityCompliance {
        payload_mass: 0.0,
        ..gravity
    }
    .joint_torques(&model, &set)
    .unwrap();
    let left = model
        .actuated_names()
        .iter()
        .position(|n| n == "thetaL1")
        .unwrap();
    for (a, w) in a.iter().zip(&without) {
        assert!((a[left] - w[left]).abs() < 1e-9);
    }
}

#[test]
fn a_payload_on_a_link_deflects_both_hands_as_that_link_would() {
    let (model, gravity) = two_arms();
    let (payload, link) = tables(&gravity);
    let targets = flexcal_calib::read_targets(&data_file("two_arms_targets.toml")).unwrap();
    let poses = configurations(&model, 12)
        .into_iter()
        .map(|q| {
            TargetPose::new(
                None,
                q,
                vec![Some(TargetObservation::new(Vector3::zeros())); targets.len()],
            )
        })
        .collect();
    let set = MeasurementSet::from_poses("poses", targets, poses).unwrap();
    let starts = FrameStarts::nominal(&set, Isometry3::identity(), None).unwrap();
    let predict = |table: &GravityCompliance| {
        let problem = ErrorModel::new(&model, Cow::Borrowed(&set), &starts)
            .unwrap()
            .with_elastic(Some(table), &JointTerms::default())
            .unwrap();
        // Soft joints and lateral springs: deflections of millimetres.
        let mut x = problem.initial_unknowns();
        let eo = problem.elastic_offset().unwrap();
        x[eo..eo + model.n_actuated()].fill(200e-6);
        let lo = problem.lateral_offset().unwrap();
        for v in &mut x[lo..] {
            *v = 50e-6;
        }
        problem.predict(&x).unwrap()
    };
    let (a, b) = (predict(&payload), predict(&link));
    let rigid = {
        let problem = ErrorModel::new(&model, Cow::Borrowed(&set), &starts).unwrap();
        problem.predict(&problem.initial_unknowns()).unwrap()
    };
    let mut sag: f64 = 0.0;
    for ((a, b), r) in a.iter().zip(&b).zip(&rigid) {
        assert!((a.translation.vector - b.translation.vector).norm() < 1e-12);
        sag = sag.max((a.translation.vector - r.translation.vector).norm());
    }
    assert!(sag > 1e-3, "deflections of millimetres: {sag} m");
}

#[test]
fn a_payload_on_an_unknown_frame_is_a_named_error() {
    let (model, gravity) = two_arms();
    let bad = GravityCompliance {
        payload_frame: Some("R9".into()),
        ..gravity
    };
    let set = MeasurementSet::new(
        "poses",
        vec![Measurement::new(
            vec![0.0; model.n_actuated()],
            Vector3::zeros(),
        )],
    )
    .unwrap();
    let error = bad.joint_torques(&model, &set).unwrap_err().to_string();
    assert!(
        error.contains("payload frame `R9`") && error.contains("RH"),
        "{error}"
    );
    // The mass table file names it, and writes it back.
    let text = format!("payload_frame = \"R3\"\n{}", gravity_text());
    let table = GravityCompliance::from_toml_str(&text, "table.toml").unwrap();
    assert_eq!(table.payload_frame.as_deref(), Some("R3"));
    let again =
        GravityCompliance::from_toml_str(&table.to_toml_string().unwrap(), "again").unwrap();
    assert_eq!(again, table);
}

fn gravity_text() -> String {
    std::fs::read_to_string(data_file("two_arms_masses.toml")).unwrap()
}

fn poses(model: &Model, n: usize) -> MeasurementSet {
    MeasurementSet::new(
        "poses",
        configurations(model, n)
            .into_iter()
            .map(|q| Measurement::new(q, Vector3::zeros()))
            .collect(),
    )
    .unwrap()
}

/// A further payload on `frame`: 2.5 kg at `(30, -20, 110)` mm.
fn further(name: &str, frame: &str, identify: bool) -> Payload {
    Payload {
        name: name.into(),
        frame: frame.into(),
        mass: 2.5,
        center: Vector3::new(0.03, -0.02, 0.11),
        identify,
    }
}

#[test]
fn further_payloads_identified_or_known_load_the_joints_as_links_would() {
    // Against the same masses entered as links: an identified further
    // payload on the right arm (its starting value loads the joints) and a
    // known one on the left hand's TCP, on top of the table's own payload.
    let (model, gravity) = two_arms();
    let (_, link) = tables(&gravity);
    let known_tcp = Payload {
        mass: 1.2,
        center: Vector3::new(0.0, 0.01, 0.04),
        ..further("tool", "tcp", false)
    };
    let several = GravityCompliance {
        payloads: vec![further("changer", "R3", true), known_tcp.clone()],
        ..gravity.clone()
    };
    let mut masses = link.masses.clone();
    let tcp = model.tool() * nalgebra::Point3::from(known_tcp.center);
    masses.push(PointMass {
        name: "tool".into(),
        frame: model.frame_names()[model.end_frame()].clone(),
        mass: known_tcp.mass,
        center: tcp.coords,
    });
    let as_links = GravityCompliance {
        masses,
        ..gravity.clone()
    };
    let set = poses(&model, 20);
    let a = several.joint_torques(&model, &set).unwrap();
    let b = as_links.joint_torques(&model, &set).unwrap();
    for (a, b) in a.iter().zip(&b) {
        for (x, y) in a.iter().zip(b) {
            assert!((x - y).abs() < 1e-9 * (1.0 + y.abs()), "{x} vs {y}");
        }
    }
    // The identified one has its four unknowns, after the table's payload;
    // the known one has none.
    let names = several.elastic_unknown_names(&model);
    let at = names.iter().position(|n| n == "payload_mz").unwrap();
    assert_eq!(
        names[at + 1..at + 5],
        [
            "payload_changer_mass",
            "payload_changer_mx",
            "payload_changer_my",
            "payload_changer_mz"
        ]
    );
    assert!(!names.iter().any(|n| n.starts_with("payload_tool")));
    assert_eq!(several.initial_unknowns(&model).len(), names.len());
    assert_eq!(
        several.initial_unknowns(&model)[at + 1..at + 5],
        [2.5, 2.5 * 0.03, 2.5 * -0.02, 2.5 * 0.11]
    );
    assert_eq!(several.payload_unknown_names()[4..], names[at + 1..at + 5]);
}

#[test]
fn further_payloads_round_trip_through_the_mass_table_and_bad_ones_are_named() {
    let (model, gravity) = two_arms();
    let text = format!(
        "{}\n[[payload]]\nname = \"left\"\nframe = \"LH\"\nmass_kg = 1.5\ncenter_mm = [0.0, 10.0, 80.0]\n\
         \n[[payload]]\nname = \"right-tool\"\nframe = \"tcp\"\nmass_kg = 0.4\ncenter_mm = [0.0, 0.0, 30.0]\nidentify = false\n",
        gravity_text()
    );
    let table = GravityCompliance::from_toml_str(&text, "table.toml").unwrap();
    assert_eq!(table.payloads.len(), 2);
    assert!(table.payloads[0].identify && !table.payloads[1].identify);
    assert!((table.payloads[0].center - Vector3::new(0.0, 0.01, 0.08)).norm() < 1e-15);
    let again =
        GravityCompliance::from_toml_str(&table.to_toml_string().unwrap(), "again").unwrap();
    assert_eq!(again, table);
    // A table without payload entries writes none (the existing format).
    assert!(!gravity.to_toml_string().unwrap().contains("[[payload]]"));
    // Bad entries in the file, by name.
    for (entry, expected) in [
        (
            "name = \"a b\"\nframe = \"LH\"\nmass_kg = 1.0\ncenter_mm = [0.0, 0.0, 0.0]",
            "payload `a b`: a name",
        ),
        (
            "name = \"n\"\nframe = \"LH\"\nmass_kg = nan\ncenter_mm = [0.0, 0.0, 0.0]",
            "payload `n`: mass",
        ),
        (
            "name = \"n\"\nframe = \"LH\"\nmass_kg = -1.0\ncenter_mm = [0.0, 0.0, 0.0]\nidentify = false",
            "payload `n`: a known mass",
        ),
        (
            "name = \"n\"\nmass_kg = 1.0\ncenter_mm = [0.0, 0.0, 0.0]",
            "frame",
        ),
    ] {
        let text = format!("{}\n[[payload]]\n{entry}\n", gravity_text());
        let error = GravityCompliance::from_toml_str(&text, "table.toml")
            .unwrap_err()
            .to_string();
        assert!(
            error.contains("table.toml") && error.contains(expected),
            "{entry}: {error}"
        );
    }
    let twice = format!(
        "{}\n[[payload]]\nname = \"n\"\nframe = \"LH\"\nmass_kg = 1.0\ncenter_mm = [0.0, 0.0, 0.0]\n\
         \n[[payload]]\nname = \"n\"\nframe = \"RH\"\nmass_kg = 1.0\ncenter_mm = [0.0, 0.0, 0.0]\n",
        gravity_text()
    );
    let error = GravityCompliance::from_toml_str(&twice, "table.toml")
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("payload `n`: the name is given twice"),
        "{error}"
    );
    // A frame the robot lacks, identified or known, is named with the
    // payload.
    for identify in [true, false] {
        let bad = GravityCompliance {
            payloads: vec![further("hand", "R9", identify)],
            ..gravity.clone()
        };
        let error = bad
            .joint_torques(&model, &poses(&model, 1))
            .unwrap_err()
            .to_string();
        assert!(
            error.contains("payload `hand`") && error.contains("no frame `R9`"),
            "{error}"
        );
    }
}
