//! `flexcal fuzzy fit`, `eval --json` and `export`, end to end on a CSV file.

mod common;
use common::{command as flexcal, run};

/// A smooth function of two inputs on a seeded-free regular grid (the grid
/// itself is the data; no random draw is involved).
fn write_csv(path: &std::path::Path, points: usize, offset: f64) {
    let mut text = String::from("a,b,extra,y\n");
    for i in 0..points {
        for j in 0..points {
            let a = -1.0 + 2.0 * (i as f64 + offset) / points as f64;
            let b = 2.0 * (j as f64 + offset) / points as f64;
            let y = (1.5 * a).sin() * (1.0 + 0.5 * b * b);
            text.push_str(&format!("{a},{b},7,{y}\n"));
        }
    }
    std::fs::write(path, text).unwrap();
}

#[test]
fn fit_eval_export_end_to_end() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("train.csv");
    let check = dir.path().join("check.csv");
    let model = dir.path().join("model.toml");
    let fis = dir.path().join("model.fis");
    write_csv(&data, 15, 0.0);
    write_csv(&check, 7, 0.37);

    run(flexcal()
        .args(["fuzzy", "fit", "--data"])
        .arg(&data)
        .args([
            "--inputs",
            "a,b",
            "--output",
            "y",
            "--test-fraction",
            "0.3",
            "--max-rules",
            "30",
        ])
        .args(["--seed", "3", "--quiet", "--out"])
        .arg(&model));
    assert!(model.exists());

    let out = run(flexcal()
        .args(["fuzzy", "eval", "--model"])
        .arg(&model)
        .arg("--data")
        .arg(&check)
        .arg("--json"));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let object = json.as_object().unwrap();
    let mut keys: Vec<&str> = object.keys().map(String::as_str).collect();
    keys.sort_unstable();
    assert_eq!(keys, ["mae", "max_abs", "n", "rmse"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.trim_start().starts_with("{\"rmse\":"), "{text}");
    assert_eq!(object["n"].as_u64(), Some(49));
    let rmse = object["rmse"].as_f64().unwrap();
    let mae = object["mae"].as_f64().unwrap();
    let max_abs = object["max_abs"].as_f64().unwrap();
    assert!(mae <= rmse && rmse <= max_abs, "{text}");
    // The function spans about 3 units: a fitted model does far better.
    assert!(rmse < 0.05, "{text}");

    run(flexcal()
        .args(["fuzzy", "export", "--model"])
        .arg(&model)
        .arg("--fis")
        .arg(&fis));
    let fis_text = std::fs::read_to_string(&fis).unwrap();
    let from_fis = flexcal::fuzzy::FuzzyModel::from_fis_str(&fis_text).unwrap();
    let from_toml = flexcal::fuzzy::FuzzyModel::read(&model).unwrap();
    assert_eq!(from_fis, from_toml);
}

#[test]
fn bad_arguments_give_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("d.csv");
    write_csv(&data, 4, 0.0);
    let run = |inputs: &str| {
        let out = flexcal()
            .args(["fuzzy", "fit", "--data"])
            .arg(&data)
            .args(["--inputs", inputs, "--output", "y", "--quiet", "--out"])
            .arg(dir.path().join("m.toml"))
            .output()
            .unwrap();
        assert!(!out.status.success());
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    let err = run("a,nope");
    assert!(
        err.contains("missing column 'nope'") && err.contains("d.csv"),
        "{err}"
    );
    let err = run("a,extra");
    assert!(err.contains("'extra' is constant"), "{err}");
    assert!(!dir.path().join("m.toml").exists());
}
