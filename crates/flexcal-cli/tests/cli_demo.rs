//! `flexcal demo` end to end: the files it promises, the summary's keys, a
//! self-contained report, and figures equal to those of the individual
//! commands run on the demo's own files.

mod common;
use common::{flexcal, identify_compliance, identify_stiffness, read_json, run};

#[test]
fn demo_writes_its_folder_and_matches_the_individual_commands() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("demo");
    let out_str = out.to_str().unwrap();
    let o = flexcal(&["demo", "--out", out_str, "--seed", "7"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for file in [
        "summary.json",
        "report.html",
        "geometric/identification.csv",
        "geometric/validation.csv",
        "geometric/truth.toml",
        "geometric/calibrated.toml",
        "geometric/report.json",
        "elastic/elastic_z_1100N.csv",
        "elastic/stiffness_report.json",
        "elastic/fuzzy_compliance.toml",
        "forming/target_path.csv",
        "forming/forming_result.json",
    ] {
        assert!(out.join(file).is_file(), "missing {file}");
    }
    let summary = read_json(&out.join("summary.json"));
    assert_eq!(summary["seed"], 7);
    assert!(summary["runtime_s"].as_f64().unwrap() > 0.0);
    let g = &summary["geometric"];
    for key in [
        "rank",
        "parameters",
        "non_identifiable",
        "validation_before",
        "validation_after",
    ] {
        assert!(!g[key].is_null(), "geometric.{key} missing");
    }
    for key in [
        "position_mean_mm",
        "position_max_mm",
        "orientation_mean_deg",
        "orientation_max_deg",
    ] {
        assert!(
            g["validation_after"][key].as_f64().unwrap().is_finite(),
            "{key}"
        );
    }
    assert_eq!(g["parameters"], 43);
    // Calibration helps a lot on the twin.
    let before = g["validation_before"]["position_mean_mm"].as_f64().unwrap();
    let after = g["validation_after"]["position_mean_mm"].as_f64().unwrap();
    assert!(after < 0.2 * before, "{before} -> {after}");

    let e = &summary["elastic"];
    for model in ["parametric", "fuzzy"] {
        for load in ["300", "600", "900", "1100"] {
            for key in ["rms_mm", "max_norm_mm", "max_x_mm", "max_z_mm"] {
                let v = e[model][load][key].as_f64();
                assert!(
                    v.is_some_and(|v| v.is_finite() && v >= 0.0),
                    "elastic.{model}.{load}.{key}"
                );
            }
        }
        assert!(e[model]["all"]["rms_mm"].as_f64().unwrap() > 0.0);
    }
    assert!(
        e["stiffness_non_identifiable"]
            .as_array()
            .is_some_and(|a| !a.is_empty())
    );
    let f = &summary["forming"];
    let before = f["uncompensated_contact_mm"].as_f64().unwrap();
    let compensations = f["compensations"].as_array().unwrap();
    assert_eq!(
        compensations.len(),
        2,
        "fuzzy and FE beam model side by side"
    );
    for c in compensations {
        let after = c["max_deviation_contact_mm"].as_f64().unwrap();
        assert!(before > 0.4 && after < before, "{before} -> {after}");
        assert!(c["improvement_contact_percent"].as_f64().unwrap() > 50.0);
    }

    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.matches("<svg").count() >= 8);
    assert!(!html.contains("<script src") && !html.contains("<link") && !html.contains("<img"));

    // The same step with the individual command, on the demo's own files.
    let geo = out.join("geometric");
    let report = dir.path().join("again.json");
    let o = flexcal(&[
        "calibrate",
        "--robot",
        "ir663",
        "--data",
        geo.join("identification.csv").to_str().unwrap(),
        "--validate",
        geo.join("validation.csv").to_str().unwrap(),
        "--fixed-target",
        "--report",
        report.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let again = read_json(&report);
    let demo_report = read_json(&geo.join("report.json"));
    assert_eq!(again["validation"], demo_report["validation"]);
    assert_eq!(again["identification"], demo_report["identification"]);

    // The elastic steps, with the individual commands on the demo's files.
    let elastic_dir = out.join("elastic");
    let compare = |per_load: &serde_json::Value, table5: &serde_json::Value| {
        for row in per_load["rows"].as_array().unwrap() {
            let load = format!("{:.0}", row["load_n"].as_f64().unwrap());
            for (ours, theirs) in [
                ("rms_mm", "rms_mm"),
                ("max_norm_mm", "max_norm_mm"),
                ("max_abs_x_mm", "max_x_mm"),
                ("max_abs_z_mm", "max_z_mm"),
            ] {
                assert_eq!(row[ours], table5[&load][theirs], "load {load}, {ours}");
            }
        }
        assert_eq!(per_load["overall_rms_mm"], table5["all"]["rms_mm"]);
    };
    // Both identifications on the demo's own campaign, with its seed.
    let identifications = [
        (
            "stiffness",
            identify_stiffness("ir663", &elastic_dir),
            "parametric",
        ),
        ("compliance", identify_compliance(&elastic_dir), "fuzzy"),
    ];
    for (name, mut command, in_summary) in identifications {
        let report = dir.path().join(format!("{name}.json"));
        run(command
            .args(["--train-load", "900", "--seed", "7", "--report"])
            .arg(&report));
        compare(
            &read_json(&report)["per_load"],
            &summary["elastic"][in_summary],
        );
    }
}

#[test]
fn demo_is_deterministic_for_a_seed() {
    let dir = tempfile::tempdir().unwrap();
    let run = |name: &str| {
        let out = dir.path().join(name);
        let o = flexcal(&["demo", "--out", out.to_str().unwrap(), "--seed", "3"]);
        assert!(o.status.success());
        let mut v = read_json(&out.join("summary.json"));
        v["runtime_s"] = serde_json::Value::Null;
        v
    };
    assert_eq!(run("a"), run("b"));
}
