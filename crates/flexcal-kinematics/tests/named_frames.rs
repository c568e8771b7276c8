//! Frames by name: an imported URDF keeps its links' names
//! (`forward_named_pose(.., "wrist_2_link", ..)` against a product of the
//! file's joint transforms written here, 1e-12), `.par` frames their
//! numbers, and a description's tip can be moved to any of them
//! (`RobotDescription::with_tip`); unknown names are named errors.

use std::collections::HashMap;
use std::path::PathBuf;

use flexcal_kinematics::urdf::{UrdfJointKind, UrdfRobot};
use flexcal_kinematics::{
    Data, ImportOptions, ImportedRobot, KinematicsError, RobotDescription, forward_frames,
    forward_named_pose, forward_pose,
};
use nalgebra::{Isometry3, Translation3, Unit, UnitQuaternion};

fn data_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data")
}

/// Pose of `link` in the root frame: the product of the joints' origins and
/// motions from the root down, joint values by joint name (URDF semantics).
fn urdf_link_pose(robot: &UrdfRobot, link: &str, q: &HashMap<&str, f64>) -> Isometry3<f64> {
    let mut chain = Vec::new();
    let mut l = link;
    while let Some(j) = robot.parent_joint(l) {
        chain.push(j);
        l = j.parent.as_str();
    }
    chain.iter().rev().fold(Isometry3::identity(), |x, j| {
        let value = q.get(j.name.as_str()).copied().unwrap_or(0.0);
        let axis = Unit::new_normalize(j.axis);
        let motion = match j.kind {
            UrdfJointKind::Revolute | UrdfJointKind::Continuous => Isometry3::from_parts(
                Translation3::identity(),
                UnitQuaternion::from_axis_angle(&axis, value),
            ),
            UrdfJointKind::Prismatic => Isometry3::from_parts(
                Translation3::from(axis.into_inner() * value),
                UnitQuaternion::identity(),
            ),
            _ => Isometry3::identity(),
        };
        x * j.origin * motion
    })
}

#[test]
fn urdf_links_keep_their_names_and_poses() {
    let path = data_dir().join("urdf/ur5e.urdf");
    let robot = UrdfRobot::read(&path).unwrap();
    let imported = ImportedRobot::read_urdf(&path, &ImportOptions::default()).unwrap();
    let model = imported.description.build().unwrap();
    let names = model.named_frames();
    for link in [
        "base_link",
        "shoulder_link",
        "wrist_1_link",
        "wrist_2_link",
        "tool0",
    ] {
        assert!(names.iter().any(|n| n == link), "{link} in {names:?}");
    }
    assert_eq!(names[0], "0");
    let xi = model.nominal_params().to_vec();
    let mut data = Data::new(&model);
    let mut worst = 0.0f64;
    for k in 0..12 {
        let q: Vec<f64> = (0..6)
            .map(|j| ((k * 7 + j * 3) as f64 * 0.37).sin() * 2.5)
            .collect();
        let by_joint: HashMap<&str, f64> = model
            .actuated_names()
            .iter()
            .map(String::as_str)
            .zip(q.iter().copied())
            .collect();
        for link in robot.links.iter().map(|l| l.name.as_str()) {
            let x = forward_named_pose(&model, &mut data, link, &q, &xi).unwrap();
            let expected = urdf_link_pose(&robot, link, &by_joint);
            let d = (x.translation.vector - expected.translation.vector)
                .amax()
                .max(
                    (x.rotation.to_rotation_matrix().matrix()
                        - expected.rotation.to_rotation_matrix().matrix())
                    .amax(),
                );
            worst = worst.max(d);
        }
        // The tip link is the TCP.
        let tcp = forward_pose(&model, &mut data, &q, &xi).unwrap();
        let tool0 = forward_named_pose(&model, &mut data, "tool0", &q, &xi).unwrap();
        assert!((tcp.translation.vector - tool0.translation.vector).amax() < 1e-15);
    }
    assert!(worst < 1e-12, "{worst:e}");
    match forward_named_pose(&model, &mut data, "wrist_9_link", &[0.0; 6], &xi) {
        Err(KinematicsError::UnknownFrame { name, known, .. }) => {
            assert_eq!(name, "wrist_9_link");
            assert!(
                known.contains("wrist_2_link") && known.starts_with("0, 1, 2"),
                "{known}"
            );
        }
        other => panic!("expected UnknownFrame, got {other:?}"),
    }
    // The links survive the description's TOML.
    let text = imported.description.to_toml_string();
    let back = RobotDescription::from_toml_str(&text, "ur5e.toml").unwrap();
    assert_eq!(back, imported.description);
}

#[test]
fn par_frames_are_named_by_their_numbers() {
    let options = ImportOptions {
        values: Some(data_dir().join("symoro/excavator_values.toml")),
        ..ImportOptions::default()
    };
    let model = ImportedRobot::read_par(&data_dir().join("symoro/excavator.par"), &options)
        .unwrap()
        .description
        .build()
        .unwrap();
    let names = model.named_frames();
    assert_eq!(names.len(), 13);
    assert_eq!(names[12], "12");
    let xi = model.nominal_params().to_vec();
    let q = [0.2, 0.95, 1.5];
    let mut data = Data::new(&model);
    forward_frames(&model, &mut data, &q, &xi).unwrap();
    let frame_11 = data.frame_pose(model.frame_index("11").unwrap()).unwrap();
    let named = forward_named_pose(&model, &mut data, "11", &q, &xi).unwrap();
    assert_eq!(named, frame_11);
}

#[test]
fn a_tip_is_honoured_by_frame_or_link_name_or_refused_by_name() {
    let path = data_dir().join("urdf/ur5e.urdf");
    let description = ImportedRobot::read_urdf(&path, &ImportOptions::default())
        .unwrap()
        .description;
    let model = description.build().unwrap();
    let xi = model.nominal_params().to_vec();
    let q = [0.3, -1.1, 0.9, -0.4, 1.2, 0.5];
    let mut data = Data::new(&model);
    for tip in ["wrist_2_link", "4", "tool0"] {
        let moved = description.with_tip(tip).unwrap().build().unwrap();
        let mut moved_data = Data::new(&moved);
        let tcp = forward_pose(&moved, &mut moved_data, &q, moved.nominal_params()).unwrap();
        let named = forward_named_pose(&model, &mut data, tip, &q, &xi).unwrap();
        assert!(
            (tcp.translation.vector - named.translation.vector).amax() < 1e-12
                && tcp.rotation.angle_to(&named.rotation) < 1e-12,
            "{tip}"
        );
    }
    let ur10 = RobotDescription::builtin("ur10").unwrap();
    match ur10.with_tip("tool0") {
        Err(KinematicsError::UnknownFrame { robot, name, known }) => {
            assert_eq!((&*robot, name.as_str()), ("ur10", "tool0"));
            assert_eq!(known, "1, 2, 3, 4, 5, 6");
        }
        other => panic!("expected UnknownFrame, got {other:?}"),
    }
    assert_eq!(ur10.with_tip("6").unwrap(), ur10);
}
