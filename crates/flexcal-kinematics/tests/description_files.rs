//! Robot description files: round trips, errors with lines, validation.

use flexcal_kinematics::{
    Data, KinematicsError, RobotDescription, builtin_robot_names, forward_pose,
};

#[test]
fn every_builtin_round_trips_through_toml_text_and_file() {
    let dir = tempfile::tempdir().unwrap();
    for name in builtin_robot_names() {
        let description = RobotDescription::builtin(name).unwrap();
        let text = description.to_toml_string();
        let back = RobotDescription::from_toml_str(&text, "memory").unwrap();
        assert_eq!(back, description, "{name}");
        let path = dir.path().join(format!("{name}.toml"));
        flexcal_io::write_atomic(&path, text.as_bytes()).unwrap();
        let from_file = RobotDescription::from_toml_file(&path).unwrap();
        assert_eq!(from_file, description, "{name}");
        let model = from_file.build().unwrap();
        assert_eq!(model.name(), *name);
    }
}

#[test]
fn unknown_builtin_is_an_error_listing_the_known_names() {
    let err = RobotDescription::builtin("r2d2").unwrap_err();
    assert!(matches!(err, KinematicsError::UnknownRobot { .. }));
    assert!(err.to_string().contains("ur10"));
}

#[test]
fn malformed_toml_reports_the_line() {
    let text = "name = \"x\"\n\n[[frame]]\nname = \"1\"\njoint = \"revolute\"\nd_mm = oops\n";
    match RobotDescription::from_toml_str(text, "robot.toml") {
        Err(KinematicsError::Toml {
            source_name, line, ..
        }) => {
            assert_eq!(source_name, "robot.toml");
            assert_eq!(line, 6);
        }
        other => panic!("expected a TOML error, got {other:?}"),
    }
    let text = "name = \"x\"\n[[frame]]\nname = \"1\"\njoint = \"spherical\"\n";
    match RobotDescription::from_toml_str(text, "robot.toml") {
        Err(KinematicsError::Toml { line, .. }) => assert_eq!(line, 4),
        other => panic!("expected a TOML error, got {other:?}"),
    }
}

#[test]
fn hand_written_description_builds_and_moves() {
    let text = r#"
name = "two-link"
[[frame]]
name = "1"
joint = "revolute"
actuated = true
limits_deg = [-170, 170]
[[frame]]
name = "2"
antecedent = "1"
joint = "revolute"
actuated = true
d_mm = 400
[[frame]]
name = "E"
antecedent = "2"
joint = "fixed"
d_mm = 300
"#;
    let model = RobotDescription::from_toml_str(text, "two-link.toml")
        .unwrap()
        .build()
        .unwrap();
    assert_eq!(model.n_actuated(), 2);
    let names: Vec<&str> = model.params().iter().map(|p| p.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "alpha1", "d1", "theta1", "r1", "alpha2", "d2", "theta2", "r2", "alphaE", "dE",
            "thetaE", "rE"
        ]
    );
    let mut data = Data::new(&model);
    let xi = model.nominal_params().to_vec();
    let x = forward_pose(&model, &mut data, &[std::f64::consts::FRAC_PI_2, 0.0], &xi).unwrap();
    // Planar arm: 0.4 m along y after the first quarter turn, then 0.3 m more.
    assert!((x.translation.vector - nalgebra::Vector3::new(0.0, 0.7, 0.0)).norm() < 1e-12);
    // What moves with each joint: a frame and those after it, never before.
    let [f1, f2, fe] = ["1", "2", "E"].map(|n| model.frame_index(n).unwrap());
    assert!(model.moves_with(fe, f1) && model.moves_with(fe, f2) && model.moves_with(f2, f2));
    assert!(!model.moves_with(f1, f2) && !model.moves_with(f2, fe));
}

#[test]
fn inconsistent_descriptions_are_named_errors() {
    let mut d = RobotDescription::builtin("ur10").unwrap();
    d.frames[2].antecedent = "nowhere".into();
    let err = d.build().unwrap_err();
    assert!(err.to_string().contains("nowhere"), "{err}");

    let mut d = RobotDescription::builtin("ur10").unwrap();
    d.parameters = Some(vec!["alpha1".into(), "zeta9".into()]);
    assert!(d.build().unwrap_err().to_string().contains("zeta9"));

    let mut d = RobotDescription::builtin("ur10").unwrap();
    d.frames[3].actuated = false;
    assert!(d.build().unwrap_err().to_string().contains("`4`"));
}

#[test]
fn calibrated_parameters_are_written_back() {
    for name in builtin_robot_names() {
        let model = RobotDescription::builtin(name).unwrap().build().unwrap();
        let xi: Vec<f64> = model
            .nominal_params()
            .iter()
            .enumerate()
            .map(|(j, v)| v + 1e-4 * (j as f64 + 1.0))
            .collect();
        let calibrated = model.description_with_params(&xi).unwrap();
        let text = calibrated.to_toml_string();
        let reloaded = RobotDescription::from_toml_str(&text, "calibrated")
            .unwrap()
            .build()
            .unwrap();
        for (a, b) in reloaded.nominal_params().iter().zip(&xi) {
            assert!((a - b).abs() < 1e-12, "{name}: {a} vs {b}");
        }
    }
}
