//! `flexcal identify compliance` end to end on the twin's elastic campaign
//! (the paper's protocol), against the parametric model of
//! `flexcal identify stiffness` on the same files, and on bad input.

use flexcal::elastic::campaign::{DeflectionMeasurement, read_campaign_dir};
use flexcal::elastic::description::ElasticDescription;
use flexcal::elastic::fuzzy_compliance::FuzzyCompliance;
use flexcal::elastic::identify::residual_samples;
use flexcal::elastic::metrics::per_load_metrics;
use flexcal::elastic::model::ElasticModel;
use flexcal::kinematics::RobotDescription;

mod common;
use common::{identify_compliance, identify_stiffness, read_json, run, stderr, twin_elastic};

/// Per-load RMS (mm) rows of a report's `per_load` table, by load.
fn rms_by_load(table: &serde_json::Value) -> Vec<(f64, f64)> {
    table["rows"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| (r["load_n"].as_f64().unwrap(), r["rms_mm"].as_f64().unwrap()))
        .collect()
}

#[test]
fn fuzzy_compliance_beats_the_parametric_model_on_the_twin_campaign() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("campaign");
    twin_elastic(&data, 7);

    let report = dir.path().join("fuzzy.json");
    let model_path = dir.path().join("compliance.toml");
    let out = run(identify_compliance(&data)
        .args(["--inputs", "theta2,theta8", "--train-load", "900"])
        .args(["--test-fraction", "0.286", "--seed", "1", "--report"])
        .arg(&report)
        .arg("--out")
        .arg(&model_path));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("rule base of C_xx"), "{stdout}");
    let fuzzy = read_json(&report);
    // The paper's split: 126 deflections of 900 N, 90 training / 36 test.
    assert_eq!(fuzzy["training_configurations"].as_u64(), Some(45));
    assert_eq!(fuzzy["test_configurations"].as_u64(), Some(18));
    let rules = fuzzy["components"][0]["conclusions"]
        .as_array()
        .unwrap()
        .len();
    assert!((4..=12).contains(&rules), "{rules} rules");
    let fuzzy_rows = rms_by_load(&fuzzy["per_load"]);
    assert_eq!(fuzzy_rows.len(), 4, "{fuzzy_rows:?}");
    let overall = fuzzy["per_load"]["overall_rms_mm"].as_f64().unwrap();
    let floor = fuzzy["noise_floor_mm"].as_f64().unwrap();
    // The twin's instrument noise sigma per coordinate: sigma sqrt(2) per
    // deflection component (loaded minus unloaded), 2 sigma for the
    // in-plane norm.
    let sigma_mm = flexcal::twin::truth::Photogrammetry::default().position_std_per_axis() * 1e3;
    assert!(
        (floor - 2.0 * sigma_mm).abs() < 1e-3,
        "floor {floor} mm, sigma {sigma_mm} mm"
    );
    // The twin's truth holds more than any fuzzy model of two joint angles
    // can carry (docs/demo.md): the residual stays above the noise floor.
    assert!(overall > floor, "fuzzy RMS {overall} mm, floor {floor} mm");
    // The saved model loads back and is the one that was reported.
    let model = FuzzyCompliance::read(&model_path).unwrap();
    assert_eq!(model.models().len(), 4);
    assert_eq!(model.models()[0].conclusions().len(), rules);

    // The parametric beam model identified on the same 900 N sets.
    let parametric_report = dir.path().join("parametric.json");
    run(identify_stiffness("ir663", &data)
        .args(["--train-load", "900", "--report"])
        .arg(&parametric_report));
    let parametric = read_json(&parametric_report);
    let gamma: Vec<f64> = parametric["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["value"].as_f64().unwrap())
        .collect();
    // Judge both in the x-z plane, where the fuzzy model lives.
    let robot = RobotDescription::builtin("ir663").unwrap().build().unwrap();
    let elastic =
        ElasticModel::new(&robot, &ElasticDescription::builtin("ir663").unwrap()).unwrap();
    let measurements: Vec<DeflectionMeasurement> = read_campaign_dir(&data, robot.n_actuated())
        .unwrap()
        .into_iter()
        .flat_map(|s| s.measurements)
        .collect();
    let mut samples =
        residual_samples(&elastic, &measurements, robot.nominal_params(), &gamma).unwrap();
    samples.iter_mut().for_each(|s| s.residual.y = 0.0);
    let parametric_table = per_load_metrics(&samples);
    println!("fuzzy (x-z plane):\n{:#?}", fuzzy["per_load"]);
    println!("parametric (x-z plane):\n{parametric_table}");
    for ((load, fuzzy_rms), row) in fuzzy_rows.iter().zip(&parametric_table.rows) {
        assert_eq!(*load, row.load_n);
        assert!(
            *fuzzy_rms < row.rms_mm,
            "{load} N: fuzzy {fuzzy_rms} mm, parametric {} mm",
            row.rms_mm
        );
    }
    assert!(overall < parametric_table.overall_rms_mm);
}

#[test]
fn bad_arguments_give_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    // A tiny campaign: three poses loaded along x and along -z at 900 N.
    let mut text =
        String::from("pose_id,q1,q2,q3,q4,q5,q6,x_mm,y_mm,z_mm,fx_n,fy_n,fz_n,mx_nm,my_nm,mz_nm\n");
    // Screw lengths near the twin's first grid pose (r'2 0.838 m, r'8 0.936 m).
    for (id, r2) in [(0, 0.83), (1, 0.84), (2, 0.85)] {
        let q = format!("0,{r2},0.936,0.965,1.349,0");
        text.push_str(&format!("{id},{q},1500,0,1200,0,0,0,0,0,0\n"));
        text.push_str(&format!("{id},{q},1500.9,0,1200.1,900,0,0,0,0,0\n"));
    }
    std::fs::write(dir.path().join("elastic_x_0900N.csv"), &text).unwrap();

    // Each case: further arguments, what the error must name (`a|b`: either).
    let cases: [(&[&str], &[&str]); 3] = [
        (&["--inputs", "theta2,theta9"], &["'theta9'", "theta8"]),
        (&["--train-load", "600"], &["600", "elastic_x_0900N"]),
        // Only horizontal loads on three configurations: C_xz is not determined.
        (&[], &["fz|fewer than"]),
    ];
    for (args, expected) in cases {
        let out = identify_compliance(dir.path()).args(args).output().unwrap();
        let err = stderr(&out);
        assert!(!out.status.success(), "{args:?}: {err}");
        for what in expected {
            let named = what.split('|').any(|w| err.contains(w));
            assert!(named, "{args:?} {what}: {err}");
        }
    }
}
