//! Campaign files: every setting written and read back (TOML, paths
//! relative to the file, in a folder beside the data), the campaign a
//! report embeds read back, and the run of a campaign equal to the run of
//! the calibration configuration it stands for.

use std::path::{Path, PathBuf};

use flexcal::calib::SelectionMethod;
use flexcal::calibration::{MeasurementFormat, run_calibration};
use flexcal::campaign::{
    Campaign, ChecksSection, DataSection, ModelKind, ModelSection, OutputsSection, RobotSection,
    SolverKind, ValidationSection, WeightsKind,
};

fn touch(dir: &Path, name: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::create_dir_all(p.parent().unwrap()).unwrap();
    std::fs::write(&p, "").unwrap();
    p
}

/// A campaign with every field set, its files under `dir`.
fn full(dir: &Path) -> Campaign {
    Campaign {
        robot: RobotSection {
            name: None,
            file: Some(touch(dir, "robots/arm.urdf")),
            tip: Some("tool0".into()),
            root: Some("base_link".into()),
            values: Some(touch(dir, "robots/values.toml")),
        },
        data: DataSection {
            files: vec![touch(dir, "data/s1.csv"), touch(dir, "data/s2.csv")],
            format: MeasurementFormat::Ipa,
            exclude: vec!["line 534".into(), "s2:line 7".into()],
            targets: Some(touch(dir, "data/targets.toml")),
        },
        validation: Some(ValidationSection {
            file: touch(dir, "data/v.csv"),
            exclude: vec!["line 9".into()],
            refit_target: true,
        }),
        model: ModelSection {
            kind: ModelKind::ElastoGeometric,
            masses: Some(touch(dir, "masses.toml")),
            deflection: None,
            method: SolverKind::Gn,
            weights: Some(WeightsKind::Uniform),
            orientation: Some(true),
            fix: vec!["d2".into()],
            defer: vec!["theta1".into(), "r1".into()],
            fixed_frame: true,
            fixed_target: true,
            target_mm: Some([1.5, -2.0, 300.25]),
            select: Some(SelectionMethod::Bic),
            select_on: Some(flexcal::calib::SelectOn::Extrapolation),
            every_extrapolation_score: true,
            strict: true,
            max_se_length_mm: Some(4.0),
            max_se_angle_deg: Some(0.2),
            max_se_compliance_urad_per_nm: Some(900.0),
            min_compliance_z: Some(3.0),
            min_torque_share: Some(0.1),
            noise_mm: Some(0.02),
            noise_deg: Some(0.001),
        },
        checks: ChecksSection {
            split: true,
            hold_out_stations: true,
            cross: true,
            residual_model: vec!["theta2".into(), "theta3".into()],
            accuracy_map: Some(touch(dir, "grid.csv")),
            extrapolation: true,
        },
        outputs: OutputsSection {
            calibrated_robot: Some(dir.join("out/calibrated.toml")),
            report: Some(dir.join("out/report.json")),
            html: Some(dir.join("out/report.html")),
            residuals: Some(dir.join("out/residuals.csv")),
        },
        source: None,
    }
}

#[test]
fn every_setting_round_trips_through_a_file_with_relative_paths() {
    let dir = tempfile::tempdir().unwrap();
    let campaign = full(dir.path());
    let file = dir.path().join("campaigns/full.toml");
    campaign.write(&file).unwrap();
    let text = std::fs::read_to_string(&file).unwrap();
    assert!(text.contains("file = \"../robots/arm.urdf\""), "{text}");
    assert!(text.contains("\"../data/s2.csv\""), "{text}");
    assert!(!text.contains(&dir.path().display().to_string()), "{text}");
    let read = Campaign::read(&file).unwrap();
    assert_eq!(read.source.as_deref(), Some(file.as_path()));
    // The paths resolve to the same files (written `campaigns/../x`).
    let canonical = |c: &Campaign| {
        let mut c = c.clone();
        c.source = None;
        c.relative_to(Path::new("/"))
    };
    assert_eq!(canonical(&read), canonical(&campaign));
    // Written again from what was read: the same file.
    read.write(&file).unwrap();
    assert_eq!(std::fs::read_to_string(&file).unwrap(), text);
}

#[test]
fn a_report_s_embedded_campaign_reads_back() {
    let dir = tempfile::tempdir().unwrap();
    let campaign = full(dir.path());
    let report = dir.path().join("out/report.json");
    let config = serde_json::to_value(campaign.relative_to(report.parent().unwrap())).unwrap();
    assert_eq!(config["data"]["files"][0], "../data/s1.csv");
    let json = serde_json::json!({ "identification": {}, "config": config });
    std::fs::create_dir_all(report.parent().unwrap()).unwrap();
    std::fs::write(&report, json.to_string()).unwrap();
    let read = Campaign::from_report(&report).unwrap();
    assert_eq!(
        read.relative_to(Path::new("/")),
        campaign.relative_to(Path::new("/"))
    );
}

/// A measurement file of the nominal UR10 at `n` configurations: the
/// target at the flange, seen from a tracker moved by (1, -0.2, 0.1) m.
fn ur10_measurements(path: &Path, n: usize) {
    let model = flexcal::load_robot("ur10").unwrap();
    let mut data = flexcal::kinematics::Data::new(&model);
    let xi = model.nominal_params().to_vec();
    let mut csv = String::from("q1,q2,q3,q4,q5,q6,x_mm,y_mm,z_mm\n");
    for k in 0..n {
        let t = k as f64;
        let q = [
            (0.37 * t).sin() * 2.5,
            -1.5 + (0.53 * t).sin(),
            (0.29 * t).cos() * 2.0,
            (0.71 * t).sin() * 2.0,
            0.8 + (0.43 * t).sin(),
            (0.61 * t).cos() * 2.5,
        ];
        let p = flexcal::kinematics::forward_pose(&model, &mut data, &q, &xi)
            .unwrap()
            .translation
            .vector;
        let cells: Vec<String> = q.iter().map(|v| v.to_string()).collect();
        csv.push_str(&format!(
            "{},{},{},{}\n",
            cells.join(","),
            (p.x + 1.0) * 1e3,
            (p.y - 0.2) * 1e3,
            (p.z + 0.1) * 1e3
        ));
    }
    std::fs::write(path, csv).unwrap();
}

#[test]
fn a_campaign_runs_the_calibration_it_stands_for() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("train.csv");
    ur10_measurements(&data, 40);
    let campaign = Campaign::from_toml_str(
        "[robot]\nname = \"ur10\"\n[data]\nfiles = [\"train.csv\"]\n[model]\nfix = [\"d2\"]\nmax_se_length_mm = 3.0\n",
        Path::new("inline.toml"),
    )
    .unwrap();
    // Paths are as written until resolved by Campaign::read.
    let campaign = Campaign {
        data: DataSection {
            files: vec![data.clone()],
            ..campaign.data
        },
        ..campaign
    };
    let run = campaign.run().unwrap();
    let run = &run.result;
    assert!(!run.several_targets(), "one target per pose");
    // The same calibration from the library's configuration, built by hand.
    let model = flexcal::load_robot("ur10").unwrap();
    let mut options = flexcal::calib::CalibrationOptions::for_model(&model);
    options.fixed = vec!["d2".into()];
    options.max_standard_error_length = 3e-3;
    let direct = run_calibration(
        &model,
        &flexcal::calibration::CalibrationConfig::new(&data, options),
    )
    .unwrap();
    assert_eq!(
        serde_json::to_string(&run.report(&model)).unwrap(),
        serde_json::to_string(&direct.report(&model)).unwrap()
    );
    let fixed = run
        .calibration
        .unknowns
        .iter()
        .find(|u| u.name == "d2")
        .unwrap();
    assert_eq!(fixed.value, fixed.initial, "d2 kept at nominal");
}

#[test]
fn settings_out_of_range_name_the_file_and_key() {
    let model = flexcal::load_robot("ur10").unwrap();
    let parse = |model_table: &str| {
        Campaign::from_toml_str(
            &format!(
                "[robot]\nname = \"ur10\"\n[data]\nfiles = [\"a.csv\"]\n[model]\n{model_table}\n"
            ),
            Path::new("c.toml"),
        )
        .unwrap()
    };
    for (table, key) in [
        ("noise_mm = 0.0", "model.noise_mm"),
        ("noise_deg = 0.1", "model.noise_deg"),
        ("min_compliance_z = -1.0", "model.min_compliance_z"),
        ("target_mm = [1.0, nan, 2.0]", "model.target_mm"),
        ("masses = \"m.toml\"", "model.masses"),
    ] {
        let err = parse(table)
            .calibration_config(&model)
            .unwrap_err()
            .to_string();
        assert!(
            err.starts_with(&format!("c.toml: {key}: ")),
            "{table}: {err}"
        );
    }
    // The cross-series check without a validation set.
    let mut campaign = parse("");
    campaign.checks.cross = true;
    let err = campaign.calibration_config(&model).unwrap_err().to_string();
    assert!(
        err.starts_with("c.toml: checks.cross: needs a validation set"),
        "{err}"
    );
    // Format own with orientation = true.
    let err = parse("orientation = true")
        .calibration_config(&model)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("model.orientation") && err.contains("ipa"),
        "{err}"
    );
}

/// The full example of docs/file-formats.md parses, every key in it known.
#[test]
fn the_documented_example_parses() {
    let doc = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/file-formats.md"),
    )
    .unwrap();
    let section = &doc[doc.find("## Campaign file").expect("the section")..];
    let start = section.find("```toml\n").expect("its example") + "```toml\n".len();
    let example = &section[start..start + section[start..].find("```").unwrap()];
    let campaign = Campaign::from_toml_str(example, Path::new("file-formats.md")).unwrap();
    assert_eq!(campaign.robot.name.as_deref(), Some("ur10"));
    assert_eq!(campaign.data.format, MeasurementFormat::Ipa);
    assert_eq!(campaign.model.orientation, Some(false));
    assert!(campaign.checks.split);
    assert_eq!(
        campaign.outputs.report.as_deref(),
        Some(Path::new("out/report.json"))
    );
}
