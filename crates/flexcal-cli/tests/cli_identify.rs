//! `flexcal twin elastic` then `flexcal identify stiffness`, end to end, and
//! bad input.

mod common;
use common::{identify_stiffness, read_json, run, stderr, stdout, twin_elastic};

#[test]
fn twin_elastic_then_identify_stiffness() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("elastic");
    twin_elastic(&data, 4);
    let report = dir.path().join("report.json");
    let out = run(identify_stiffness("ir663", &data)
        .args(["--train-load", "900", "--search-evaluations", "700"])
        .arg("--report")
        .arg(&report));
    let stdout = stdout(&out);
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
    let json = read_json(&report);
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
    let header = "pose_id,q1,q2,q3,q4,q5,q6,x_mm,y_mm,z_mm,fx_n,fy_n,fz_n,mx_nm,my_nm,mz_nm\n";
    let file = dir.path().join("set.csv");
    // Each case: the set file, the elastic description, what the one-line
    // error must name.
    let cases = [
        // No data at the training load.
        (
            "0,0,0.9,0.9,0.9,1.3,0,1500,0,1000,0,0,0,0,0,0\n\
             0,0,0.9,0.9,0.9,1.3,0,1500,0,999,0,0,-300,0,0,0\n",
            "ir663",
            vec!["training load 900"],
        ),
        // A malformed number names file, line and column.
        (
            "0,0,0.9,0.9,0.9,1.3,0,1500,0,abc,0,0,0,0,0,0\n",
            "ir663",
            vec!["set.csv:2", "z_mm"],
        ),
        // Unknown elastic description.
        (
            "0,0,0.9,0.9,0.9,1.3,0,1500,0,1000,0,0,0,0,0,0\n",
            "nope.toml",
            vec!["nope.toml"],
        ),
    ];
    for (rows, elastic, expected) in cases {
        std::fs::write(&file, format!("{header}{rows}")).unwrap();
        let out = identify_stiffness(elastic, dir.path())
            .args(["--train-load", "900"])
            .output()
            .unwrap();
        let err = stderr(&out);
        assert!(!out.status.success(), "{elastic}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
        for what in expected {
            assert!(err.contains(what), "{what}: {err}");
        }
    }
}
