//! Inverted or non-finite joint limits in a robot file are named errors
//! with the file, the line and the joint (URDF `<limit>`, TOML
//! `limits_deg` / `limits_mm`); a `.par` file holds no limits.

use flexcal_kinematics::{ImportOptions, ImportedRobot, RobotDescription};

fn urdf(limit: &str) -> String {
    format!(
        r#"<robot name="r">
  <link name="a"/>
  <link name="b"/>
  <joint name="shoulder" type="revolute">
    <parent link="a"/><child link="b"/>
    {limit}
  </joint>
</robot>
"#
    )
}

fn read_urdf(text: &str) -> Result<ImportedRobot, String> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("arm.urdf");
    std::fs::write(&path, text).unwrap();
    ImportedRobot::read_urdf(&path, &ImportOptions::default()).map_err(|e| {
        e.to_string()
            .replace(&path.display().to_string(), "arm.urdf")
    })
}

#[test]
fn inverted_and_non_finite_urdf_limits_name_the_joint_and_line() {
    let e = read_urdf(&urdf(
        r#"<limit lower="1" upper="-1" effort="1" velocity="1"/>"#,
    ))
    .unwrap_err();
    assert_eq!(
        e,
        "arm.urdf:6: joint `shoulder`: inverted limits, lower = 1 is above upper = -1"
    );
    let e = read_urdf(&urdf(r#"<limit lower="nan" upper="1"/>"#)).unwrap_err();
    assert_eq!(e, "arm.urdf:6: <limit> lower=\"nan\" is not finite");
    let e = read_urdf(&urdf(r#"<limit lower="-1" upper="inf"/>"#)).unwrap_err();
    assert_eq!(e, "arm.urdf:6: <limit> upper=\"inf\" is not finite");
    // A continuous joint's <limit> with effort and velocity only is no range.
    let ok =
        read_urdf(&urdf(r#"<limit effort="1" velocity="1"/>"#).replace("revolute", "continuous"));
    assert!(ok.is_ok(), "{ok:?}");
    // Ordered limits are kept.
    let ok = read_urdf(&urdf(
        r#"<limit lower="-1" upper="1" effort="1" velocity="1"/>"#,
    ))
    .unwrap();
    let limits = ok.description.frames[0].limits_deg.unwrap();
    assert!(
        (limits[0] + 1f64.to_degrees()).abs() < 1e-12
            && (limits[1] - 1f64.to_degrees()).abs() < 1e-12
    );
}

const TOML: &str = r#"name = "two"

[[frame]]
name = "1"
joint = "revolute"
actuated = true
limits_deg = [-170, 170]

[[frame]]
name = "2"
antecedent = "1"
joint = "prismatic"
actuated = true
d_mm = 400
LIMITS
"#;

#[test]
fn inverted_and_non_finite_toml_limits_name_the_frame_and_line() {
    for (limits, expected) in [
        (
            "limits_mm = [100, -100]",
            "two.toml:15: frame `2`: limits_mm = [100, -100] is inverted (min above max)",
        ),
        (
            "limits_mm = [nan, 100]",
            "two.toml:15: frame `2`: limits_mm = [NaN, 100] is not finite",
        ),
        (
            "limits_mm = [0, inf]",
            "two.toml:15: frame `2`: limits_mm = [0, inf] is not finite",
        ),
    ] {
        let e = RobotDescription::from_toml_str(&TOML.replace("LIMITS", limits), "two.toml")
            .unwrap_err();
        assert_eq!(e.to_string(), expected);
    }
    let ok = RobotDescription::from_toml_str(
        &TOML.replace("LIMITS", "limits_mm = [0, 300]"),
        "two.toml",
    )
    .unwrap();
    assert_eq!(ok.frames[1].limits_mm, Some([0.0, 300.0]));
    ok.build().unwrap();
}
