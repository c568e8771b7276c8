//! `flexcal calibrate --config` and `--save-config` end to end: a command
//! line saved as a campaign file re-runs to the same report, the re-saved
//! file is the same, a report's embedded campaign re-runs to the same
//! figures, flags override the file; bad campaign files are one-line
//! errors naming the file and the key. The IPA UR10 C -> B calibration
//! through a campaign file when the data is present (skips with a message
//! otherwise).

use std::io::Write as _;
use std::path::{Path, PathBuf};

mod common;
use common::{flexcal, stderr, stdout};

fn path(dir: &Path, name: &str) -> String {
    dir.join(name).display().to_string()
}

fn read_json(path: impl AsRef<Path>) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// Runs `flexcal` and requires success.
fn ok(args: &[&str]) -> String {
    let out = flexcal(args);
    assert!(
        out.status.success(),
        "{args:?}\n{}\n{}",
        stdout(&out),
        stderr(&out)
    );
    stdout(&out)
}

/// The report without its `config` section: the figures.
fn figures(mut report: serde_json::Value) -> serde_json::Value {
    report.as_object_mut().unwrap().remove("config");
    report
}

#[test]
fn saved_command_line_and_report_re_run_to_the_same_figures() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    ok(&[
        "twin",
        "geometric",
        "--out",
        &d.display().to_string(),
        "--seed",
        "7",
    ]);
    let campaign = path(d, "sub/campaign.toml");
    let report = path(d, "report.json");
    let html = path(d, "report.html");
    let first = ok(&[
        "calibrate",
        "--robot",
        "ir663",
        "--data",
        &path(d, "identification.csv"),
        "--validate",
        &path(d, "validation.csv"),
        "--fixed-target",
        "--exclude",
        "identification-3,identification-5",
        "--max-se-angle-deg",
        "0.3",
        "--out",
        &path(d, "calibrated.toml"),
        "--report",
        &report,
        "--html",
        &html,
        "--save-config",
        &campaign,
    ]);
    assert!(first.contains("campaign written to"), "{first}");
    // Paths relative to the campaign file's folder.
    let saved = std::fs::read_to_string(&campaign).unwrap();
    let table: toml::Table = toml::from_str(&saved).unwrap();
    assert_eq!(table["robot"]["name"].as_str(), Some("ir663"), "{saved}");
    assert_eq!(
        table["data"]["files"][0].as_str(),
        Some("../identification.csv"),
        "{saved}"
    );
    assert_eq!(
        table["validation"]["file"].as_str(),
        Some("../validation.csv")
    );
    assert_eq!(table["model"]["fixed_target"].as_bool(), Some(true));
    assert_eq!(table["model"]["max_se_angle_deg"].as_float(), Some(0.3));
    assert_eq!(table["outputs"]["report"].as_str(), Some("../report.json"));
    let first_report = std::fs::read_to_string(&report).unwrap();
    let json: serde_json::Value = serde_json::from_str(&first_report).unwrap();
    // The report carries the campaign, paths relative to the report.
    let config = &json["config"];
    assert_eq!(config["data"]["files"][0], "identification.csv", "{config}");
    assert_eq!(config["data"]["exclude"][1], "identification-5", "{config}");
    assert_eq!(config["outputs"]["report"], "report.json", "{config}");
    let page = std::fs::read_to_string(&html).unwrap();
    assert!(
        page.contains("Configuration") && page.contains("files = [&quot;identification.csv&quot;]"),
        "the page shows the campaign's TOML"
    );

    // --config re-runs it: the very same report (the campaign included),
    // and the file saved again is the same file.
    let again = path(d, "sub/again.toml");
    let second = ok(&["calibrate", "--config", &campaign, "--save-config", &again]);
    assert_eq!(std::fs::read_to_string(&report).unwrap(), first_report);
    assert_eq!(std::fs::read_to_string(&again).unwrap(), saved);
    let tail = |s: &str| {
        s.lines()
            .filter(|l| l.contains("after"))
            .collect::<Vec<_>>()
            .join("\n")
    };
    assert_eq!(tail(&second), tail(&first), "the printed figures");

    // The report's embedded campaign re-runs to the same figures; a flag
    // overrides the file's output.
    let from_report = path(d, "from-report.json");
    ok(&["calibrate", "--config", &report, "--report", &from_report]);
    let rerun = read_json(&from_report);
    assert_eq!(rerun["config"]["outputs"]["report"], "from-report.json");
    assert_eq!(figures(rerun), figures(json.clone()));

    // Flags given with --config win over the file's values.
    let gn = path(d, "gn.json");
    ok(&[
        "calibrate",
        "--config",
        &campaign,
        "--method",
        "gn",
        "--exclude",
        "identification-4",
        "--report",
        &gn,
    ]);
    let gn = read_json(&gn);
    assert_eq!(gn["config"]["model"]["method"], "gn");
    assert_eq!(
        gn["config"]["data"]["exclude"],
        serde_json::json!(["identification-4"])
    );
    assert_eq!(
        gn["config"]["model"]["fixed_target"], true,
        "kept from the file"
    );
}

/// A campaign file `DIR/name` with `text`; returns its path.
fn write(dir: &Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::create_dir_all(p.parent().unwrap()).unwrap();
    std::fs::write(&p, text).unwrap();
    p.display().to_string()
}

#[test]
fn bad_campaign_files_are_named_errors() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir_all(d.join("sub")).unwrap();
    std::fs::write(d.join("sub/data.csv"), "q1,q2,q3,q4,q5,q6,x_mm,y_mm,z_mm\n").unwrap();
    let good = "[robot]\nname = \"ur10\"\n\n[data]\nfiles = [\"data.csv\"]\n";
    let cases: &[(&str, String, &[&str])] = &[
        (
            "unknown key",
            format!("{good}\n[model]\nmetod = \"gn\"\n"),
            &["c.toml:8", "model.metod", "unknown field `metod`"],
        ),
        (
            "unknown table",
            format!("{good}\n[modle]\nkind = \"geometric\"\n"),
            &["c.toml:7", "unknown field `modle`"],
        ),
        (
            "wrong type",
            format!("{good}\n[model]\nstrict = \"yes\"\n"),
            &["c.toml:8", "model.strict", "invalid type"],
        ),
        (
            "unknown value",
            format!("{good}\n[model]\nmethod = \"newton\"\n"),
            &["c.toml:8", "model.method", "newton"],
        ),
        (
            "missing data file",
            "[robot]\nname = \"ur10\"\n[data]\nfiles = [\"data.csv\", \"nope.csv\"]\n".into(),
            &["c.toml", "data.files[1]", "`nope.csv` names no file"],
        ),
        (
            "a relative path that leaves nothing",
            "[robot]\nname = \"ur10\"\n[data]\nfiles = [\"sub/..\"]\n".into(),
            &["c.toml", "data.files[0]", "leaves no file name"],
        ),
        (
            "an empty path",
            "[robot]\nname = \"ur10\"\n[data]\nfiles = [\"\"]\n".into(),
            &["c.toml", "data.files[0]", "leaves no file name"],
        ),
        (
            "a folder",
            "[robot]\nname = \"ur10\"\n[data]\nfiles = [\"..\"]\n".into(),
            &["c.toml", "data.files[0]", "is a folder"],
        ),
        (
            "missing validation file",
            format!("{good}\n[validation]\nfile = \"v.csv\"\n"),
            &["c.toml", "validation.file", "`v.csv` names no file"],
        ),
        (
            "no data table",
            "[robot]\nname = \"ur10\"\n".into(),
            &["c.toml", "missing field `data`"],
        ),
        (
            "no robot",
            "[robot]\n[data]\nfiles = [\"data.csv\"]\n".into(),
            &["c.toml", "robot", "no robot"],
        ),
        (
            "unknown built-in robot",
            "[robot]\nname = \"ur99\"\n[data]\nfiles = [\"data.csv\"]\n".into(),
            &["c.toml", "robot.name", "ur99"],
        ),
        (
            "a value out of range",
            format!("{good}\n[model]\nmin_torque_share = 1.5\n"),
            &["c.toml", "model.min_torque_share", "must be in [0, 1)"],
        ),
    ];
    for (what, text, expected) in cases {
        let file = write(d, "sub/c.toml", text);
        let out = flexcal(&["calibrate", "--config", &file]);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(2), "{what}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{what}: one line: {err}");
        for e in *expected {
            assert!(err.contains(e), "{what}: `{e}` in {err}");
        }
    }
    // A report without a campaign.
    let report = write(d, "old.json", "{\"identification\": {}}");
    let out = flexcal(&["calibrate", "--config", &report]);
    let err = stderr(&out);
    assert!(
        err.contains("old.json: config: the report carries no campaign"),
        "{err}"
    );
    // Neither --robot nor --config.
    let out = flexcal(&["calibrate", "--data", &path(d, "sub/data.csv")]);
    assert_eq!(out.status.code(), Some(2));
    assert!(stderr(&out).contains("--robot"), "{}", stderr(&out));
}

fn ipa(series: &str, file: &str) -> Option<PathBuf> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/datasets/ipa-ur10")
        .join(series)
        .join(file);
    if path.exists() {
        return Some(path);
    }
    let _ = writeln!(
        std::io::stderr(),
        "SKIPPED: IPA UR10 data absent ({})",
        path.display()
    );
    None
}

/// The IPA UR10 calibration on series C validated on series B, from the
/// command line and again from its saved campaign file: the same report.
#[test]
fn ipa_c_to_b_campaign_reproduces_the_report() {
    let (Some(c), Some(b)) = (
        ipa("Series_C", "measurements_random_poses.csv"),
        ipa("Series_B", "measurements_joint_configurations.csv"),
    ) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let campaign = path(d, "ipa-c-to-b.toml");
    let report = path(d, "report.json");
    let first = ok(&[
        "calibrate",
        "--robot",
        "ur10",
        "--format",
        "ipa",
        "--data",
        &c.display().to_string(),
        "--validate",
        &b.display().to_string(),
        "--report",
        &report,
        "--save-config",
        &campaign,
    ]);
    let first_report = std::fs::read_to_string(&report).unwrap();
    let again = path(d, "again.toml");
    let second = ok(&["calibrate", "--config", &campaign, "--save-config", &again]);
    assert_eq!(std::fs::read_to_string(&report).unwrap(), first_report);
    assert_eq!(
        std::fs::read_to_string(&again).unwrap(),
        std::fs::read_to_string(&campaign).unwrap()
    );
    let after = |s: &str| {
        s.lines()
            .filter(|l| l.contains(" after "))
            .collect::<Vec<_>>()
            .join("\n")
    };
    assert_eq!(after(&second), after(&first));
    let json = read_json(&report);
    let v = &json["validation"];
    let _ = writeln!(
        std::io::stderr(),
        "IPA C -> B through a campaign file: validation after mean {} / rms {} / max {} mm",
        v["position_mean_mm"],
        v["position_rms_mm"],
        v["position_max_mm"]
    );
}
