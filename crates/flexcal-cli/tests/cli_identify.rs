//! `flexcal twin elastic` then `flexcal identify stiffness`, end to end, and
//! bad input.

mod common;
use common::command as flexcal;

#[test]
fn twin_elastic_then_identify_stiffness() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("elastic");
    let out = flexcal()
        .args(["twin", "elastic", "--out"])
        .arg(&data)
        .args(["--seed", "4"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report = dir.path().join("report.json");
    let out = flexcal()
        .args([
            "identify",
            "stiffness",
            "--robot",
            "ir663",
            "--elastic",
            "ir663",
            "--data",
        ])
        .arg(&data)
        .args([
            "--train-load",
            "900",
            "--search-evaluations",
            "700",
            "--report",
        ])
        .arg(&report)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("springs in series"), "{stdout}");
    assert!(
        stdout.contains("Kr_12, Kr_33'") && stdout.contains("Kr_18, Kr_99', Kr_1010'"),
        "{stdout}"
    );
    for load in ["300", "600", "900", "1100", "all"] {
        assert!(
            stdout.lines().any(|l| l.trim_start().starts_with(load)),
            "{load}: {stdout}"
        );
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let rows = json["per_load"]["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 4);
    let overall = json["per_load"]["overall_rms_mm"].as_f64().unwrap();
    // The parametric model cannot follow the screws: well above the noise
    // floor (about 0.05 mm) but far below the deflections (about 2 mm).
    assert!((0.05..0.3).contains(&overall), "{overall}");
    assert_eq!(json["identifiability"]["structural_rank"].as_u64(), Some(4));
}

#[test]
fn identify_stiffness_reports_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    // No data at the training load.
    let file = dir.path().join("set.csv");
    std::fs::write(
        &file,
        "pose_id,q1,q2,q3,q4,q5,q6,x_mm,y_mm,z_mm,fx_n,fy_n,fz_n,mx_nm,my_nm,mz_nm\n\
         0,0,0.9,0.9,0.9,1.3,0,1500,0,1000,0,0,0,0,0,0\n\
         0,0,0.9,0.9,0.9,1.3,0,1500,0,999,0,0,-300,0,0,0\n",
    )
    .unwrap();
    let out = flexcal()
        .args([
            "identify",
            "stiffness",
            "--robot",
            "ir663",
            "--elastic",
            "ir663",
            "--data",
        ])
        .arg(dir.path())
        .args(["--train-load", "900"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("training load 900"), "{err}");

    // A malformed number names file, line and column.
    std::fs::write(
        &file,
        "pose_id,q1,q2,q3,q4,q5,q6,x_mm,y_mm,z_mm,fx_n,fy_n,fz_n,mx_nm,my_nm,mz_nm\n\
         0,0,0.9,0.9,0.9,1.3,0,1500,0,abc,0,0,0,0,0,0\n",
    )
    .unwrap();
    let out = flexcal()
        .args([
            "identify",
            "stiffness",
            "--robot",
            "ir663",
            "--elastic",
            "ir663",
            "--data",
        ])
        .arg(dir.path())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("set.csv:2") && err.contains("z_mm"),
        "{err}"
    );

    // Unknown elastic description.
    let out = flexcal()
        .args([
            "identify",
            "stiffness",
            "--robot",
            "ir663",
            "--elastic",
            "nope.toml",
            "--data",
        ])
        .arg(dir.path())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("nope.toml"), "{err}");
}
