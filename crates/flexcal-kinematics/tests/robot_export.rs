//! Export round trips: a robot (nominal or with identified parameters)
//! exported to URDF and read back reproduces its poses to 1e-9 m, both when
//! flexcal's importer reads it and when `scripts/urdf_reference.py`
//! evaluates the committed exports independently; loops are refused by name.

use std::path::PathBuf;

use flexcal_kinematics::{
    Data, ExportFormat, ExportOptions, ImportOptions, ImportedRobot, KinematicsError, Model,
    RobotDescription, export_robot, forward_pose, urdf::UrdfRobot,
};
use nalgebra::Matrix3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn data_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data")
}

/// A calibrated-like parameter vector: nominal plus errors of the size
/// calibration finds on industrial arms (up to 1 mm and 1 mrad, uniform).
fn perturbed(model: &Model, seed: u64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    model
        .nominal_params()
        .iter()
        .map(|v| v + rng.random_range(-1e-3..1e-3))
        .collect()
}

fn read_back(text: &str) -> Model {
    let robot = UrdfRobot::parse(text, "export").unwrap();
    let options = ImportOptions {
        root: Some("frame_0".into()),
        tip: Some("tcp".into()),
        values: None,
    };
    ImportedRobot::from_urdf(&robot, &options)
        .unwrap()
        .description
        .build()
        .unwrap()
}

/// Largest TCP position and orientation difference over seeded configurations.
fn compare(model: &Model, xi: &[f64], other: &Model) -> (f64, f64) {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let (mut data, mut other_data) = (Data::new(model), Data::new(other));
    let other_xi = other.nominal_params().to_vec();
    let (mut dp, mut da) = (0.0f64, 0.0f64);
    for _ in 0..200 {
        let q: Vec<f64> = model
            .actuated_limits()
            .iter()
            .map(|&(lo, hi)| rng.random_range(lo.max(-7.0)..hi.min(7.0)))
            .collect();
        let q_other: Vec<f64> = other
            .actuated_names()
            .iter()
            .map(|n| q[model.actuated_names().iter().position(|m| m == n).unwrap()])
            .collect();
        let x = forward_pose(model, &mut data, &q, xi).unwrap();
        let y = forward_pose(other, &mut other_data, &q_other, &other_xi).unwrap();
        dp = dp.max((x.translation.vector - y.translation.vector).norm());
        da = da.max(x.rotation.angle_to(&y.rotation));
    }
    (dp, da)
}

#[test]
fn builtin_robots_survive_urdf_export_and_import() {
    for name in ["ur10", "puma560"] {
        let model = RobotDescription::builtin(name).unwrap().build().unwrap();
        for xi in [model.nominal_params().to_vec(), perturbed(&model, 11)] {
            let export =
                export_robot(&model, &xi, ExportFormat::Urdf, &ExportOptions::default()).unwrap();
            let back = read_back(&export.text);
            let (dp, da) = compare(&model, &xi, &back);
            println!(
                "{name}: URDF round trip {dp:.2e} m, {da:.2e} rad (export's own check {:.2e})",
                export.max_deviation_m.unwrap()
            );
            assert!(dp < 1e-9 && da < 1e-9, "{name}: {dp:.3e} m, {da:.3e} rad");
            assert!(export.max_deviation_m.unwrap() < 1e-9);
            assert!(!export.dropped.is_empty());
        }
    }
}

#[test]
fn toml_export_reads_back_identically_and_the_dh_table_keeps_beta() {
    let model = RobotDescription::builtin("ur10").unwrap().build().unwrap();
    let xi = perturbed(&model, 3);
    let toml = export_robot(&model, &xi, ExportFormat::Toml, &ExportOptions::default()).unwrap();
    assert!(toml.max_deviation_m.unwrap() < 1e-12);
    let csv = export_robot(&model, &xi, ExportFormat::MdhCsv, &ExportOptions::default()).unwrap();
    let lines: Vec<&str> = csv.text.lines().collect();
    assert_eq!(lines.len(), 7);
    assert!(lines[0].contains("beta_deg"));
    // Frame 3 uses Hayati beta (its value in column 9), frame 1 does not.
    let beta3: f64 = lines[3].split(',').nth(8).unwrap().parse().unwrap();
    let index = model.param_index("beta3").unwrap();
    assert!((beta3 - xi[index].to_degrees()).abs() < 1e-12);
    assert_eq!(lines[1].split(',').nth(8).unwrap(), "");
    let markdown = export_robot(
        &model,
        &xi,
        ExportFormat::MdhMarkdown,
        &ExportOptions::default(),
    )
    .unwrap();
    assert!(markdown.text.contains("| 3 | 2 | 0 | theta3 |"));
    assert!(markdown.text.contains("Tool (frame 6 to TCP)"));
}

#[test]
fn the_ir663_loop_is_named_as_what_urdf_cannot_express() {
    let model = RobotDescription::builtin("ir663").unwrap().build().unwrap();
    let e = export_robot(
        &model,
        model.nominal_params(),
        ExportFormat::Urdf,
        &ExportOptions::default(),
    )
    .unwrap_err();
    match &e {
        KinematicsError::Inexpressible { what, .. } => {
            assert!(what.contains("four-bar"), "{e}");
        }
        other => panic!("expected Inexpressible, got {other}"),
    }
}

#[test]
fn a_tolerance_below_the_rounding_of_the_export_refuses_it() {
    let model = RobotDescription::builtin("puma560")
        .unwrap()
        .build()
        .unwrap();
    let xi = perturbed(&model, 5);
    let options = ExportOptions {
        tolerance_m: 0.0,
        ..ExportOptions::default()
    };
    // The URDF read back differs from the model by rounding (about 1e-16 m):
    // a zero tolerance must refuse it, by name.
    match export_robot(&model, &xi, ExportFormat::Urdf, &options) {
        Err(KinematicsError::ExportLoss { loss, .. }) => assert!(loss > 0.0 && loss < 1e-12),
        Ok(export) => assert_eq!(export.max_deviation_m, Some(0.0)),
        Err(other) => panic!("expected ExportLoss, got {other}"),
    }
}

/// The committed exports of calibrated-like robots, evaluated independently
/// by `scripts/urdf_reference.py`: the model at its parameters gives the
/// script's poses. Set FLEXCAL_BLESS=1 to rewrite the exports (then rerun
/// the script).
#[test]
fn exported_urdfs_match_the_independent_evaluator() {
    for (name, seed) in [("ur10", 11u64), ("puma560", 13)] {
        let model = RobotDescription::builtin(name).unwrap().build().unwrap();
        let xi = perturbed(&model, seed);
        let export =
            export_robot(&model, &xi, ExportFormat::Urdf, &ExportOptions::default()).unwrap();
        let path = data_dir().join(format!("urdf/exported_{name}.urdf"));
        if std::env::var_os("FLEXCAL_BLESS").is_some() {
            std::fs::write(&path, &export.text).unwrap();
        }
        let committed = std::fs::read_to_string(&path).unwrap();
        assert_eq!(
            committed,
            export.text,
            "{}: stale, rerun with FLEXCAL_BLESS=1",
            path.display()
        );
        let reference_path = data_dir().join(format!("urdf_reference/exported_{name}.json"));
        let reference: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&reference_path).unwrap()).unwrap();
        let joints: Vec<&str> = reference["joints"]
            .as_array()
            .unwrap()
            .iter()
            .map(|j| j.as_str().unwrap())
            .collect();
        let mut data = Data::new(&model);
        let (mut dp, mut da) = (0.0f64, 0.0f64);
        for configuration in reference["configurations"].as_array().unwrap() {
            let values = configuration["q"].as_array().unwrap();
            let q: Vec<f64> = model
                .actuated_names()
                .iter()
                .map(|n| {
                    values[joints.iter().position(|j| j == n).unwrap()]
                        .as_f64()
                        .unwrap()
                })
                .collect();
            let x = forward_pose(&model, &mut data, &q, &xi).unwrap();
            for k in 0..3 {
                let e = x.translation.vector[k] - configuration["position_m"][k].as_f64().unwrap();
                dp = dp.max(e.abs());
            }
            let rows = &configuration["rotation"];
            let r_ref = Matrix3::from_fn(|i, j| rows[i][j].as_f64().unwrap());
            let e = (x.rotation.to_rotation_matrix().matrix() - r_ref)
                .abs()
                .max();
            da = da.max(e);
        }
        println!(
            "{name}: calibrated export vs independent evaluator {dp:.2e} m, {da:.2e} (rotation entries)"
        );
        assert!(dp < 1e-9 && da < 1e-9, "{name}: {dp:.3e} m, {da:.3e}");
    }
}

/// The six joint origins of a UR kinematics YAML, read line by line here
/// (`  joint:` then `    key: value`), in file order: [x, y, z, roll, pitch, yaw].
fn read_ur_yaml(text: &str) -> Vec<(String, [f64; 6])> {
    let keys = ["x", "y", "z", "roll", "pitch", "yaw"];
    let mut joints: Vec<(String, [f64; 6])> = Vec::new();
    for line in text.lines().filter(|l| !l.trim_start().starts_with('#')) {
        let (key, value) = line.split_once(':').unwrap();
        match (line.starts_with("    "), line.starts_with("  ")) {
            (true, _) => {
                let k = keys.iter().position(|k| *k == key.trim()).unwrap();
                joints.last_mut().unwrap().1[k] = value.trim().parse().unwrap();
            }
            (false, true) => joints.push((key.trim().to_string(), [f64::NAN; 6])),
            _ => assert_eq!(line, "kinematics:"),
        }
    }
    joints
}

#[test]
fn ur_kinematics_yaml_round_trips_through_a_urdf_and_refuses_other_arms() {
    let model = RobotDescription::builtin("ur10").unwrap().build().unwrap();
    let xi = perturbed(&model, 21);
    let export = export_robot(
        &model,
        &xi,
        ExportFormat::UrKinematicsYaml,
        &ExportOptions::default(),
    )
    .unwrap();
    let joints = read_ur_yaml(&export.text);
    let names: Vec<&str> = joints.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(
        names,
        [
            "shoulder",
            "upper_arm",
            "forearm",
            "wrist_1",
            "wrist_2",
            "wrist_3"
        ]
    );
    // The URDF the file stands for, written here: each joint about its z axis.
    let mut urdf = String::from("<robot name=\"yaml\">\n  <link name=\"l0\"/>\n");
    for (k, (name, v)) in joints.iter().enumerate() {
        assert!(v.iter().all(|x| x.is_finite()), "{name}");
        urdf.push_str(&format!(
            "  <link name=\"l{}\"/>\n  <joint name=\"{name}\" type=\"revolute\"><parent link=\"l{k}\"/><child link=\"l{}\"/>\
             <origin xyz=\"{} {} {}\" rpy=\"{} {} {}\"/><axis xyz=\"0 0 1\"/><limit lower=\"-7\" upper=\"7\" effort=\"0\" velocity=\"0\"/></joint>\n",
            k + 1, k + 1, v[0], v[1], v[2], v[3], v[4], v[5]
        ));
    }
    urdf.push_str("</robot>\n");
    let robot = flexcal_kinematics::urdf::UrdfRobot::parse(&urdf, "yaml.urdf").unwrap();
    let read = ImportedRobot::from_urdf(&robot, &ImportOptions::default())
        .unwrap()
        .description
        .build()
        .unwrap();
    let mut worst = 0.0f64;
    let (mut a, mut b) = (Data::new(&model), Data::new(&read));
    for k in 0..64 {
        let q: Vec<f64> = (0..6)
            .map(|j| ((k * 5 + j * 11) as f64 * 0.29).sin() * 3.0)
            .collect();
        let x = forward_pose(&model, &mut a, &q, &xi).unwrap();
        let y = forward_pose(&read, &mut b, &q, read.nominal_params()).unwrap();
        worst = worst
            .max((x.translation.vector - y.translation.vector).amax())
            .max(x.rotation.angle_to(&y.rotation));
    }
    assert!(worst < 1e-12, "{worst:e}");
    assert!(export.max_deviation_m.unwrap() < 1e-12);
    // A four-bar loop has no place in it, by name.
    let ir663 = RobotDescription::builtin("ir663").unwrap().build().unwrap();
    match export_robot(
        &ir663,
        ir663.nominal_params(),
        ExportFormat::UrKinematicsYaml,
        &ExportOptions::default(),
    ) {
        Err(KinematicsError::Inexpressible { format, what }) => {
            assert_eq!(format, "UR kinematics YAML");
            assert!(what.contains("closed loop"), "{what}");
        }
        other => panic!("expected Inexpressible, got {other:?}"),
    }
    // The PUMA 560's flange frame goes with the tool, which the file drops.
    let puma = RobotDescription::builtin("puma560")
        .unwrap()
        .build()
        .unwrap();
    let export = export_robot(
        &puma,
        puma.nominal_params(),
        ExportFormat::UrKinematicsYaml,
        &ExportOptions::default(),
    )
    .unwrap();
    assert!(export.dropped[0].contains("fixed frames after the sixth joint"));
}
