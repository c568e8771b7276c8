//! Compensate a tool path with each elastic model: the FE beam model with
//! the stiffness identified from a deflection campaign, and the fuzzy
//! compliance model learnt from the same campaign. The process is a
//! clamped aluminium beam formed by the tool, with a 920 N dead weight.
//!
//! Run with `cargo run -p flexcal --example compensate_path`.

use std::error::Error;
use std::path::Path;

use flexcal::compensation::{
    CommandedPath, CompensationSetup, ElasticSpec, PathExport, ProcessSpec, compensate_path_file,
    default_start_joints, load_elastic, pose_mm_deg,
};
use flexcal::elastic::description::ElasticDescription;
use flexcal::elastic::workflow::{
    ComplianceWorkflowOptions, StiffnessWorkflowOptions, identify_compliance_in_dir,
    identify_stiffness_in_dir,
};

/// Identifies both elastic models on the campaign in `campaign`, then
/// compensates the path file `path` with each; returns (FE, fuzzy).
pub fn compensate_with_each_model(
    campaign: &Path,
    path: &Path,
    out: &Path,
) -> Result<(CommandedPath, CommandedPath), Box<dyn Error>> {
    let robot = flexcal::load_robot("ir663")?;
    let xi = robot.nominal_params().to_vec();
    let stiffness = identify_stiffness_in_dir(
        &robot,
        &ElasticDescription::builtin("ir663")?,
        campaign,
        &StiffnessWorkflowOptions::default(),
    )?;
    stiffness.report.write(out.join("stiffness_report.json"))?;
    let compliance =
        identify_compliance_in_dir(&robot, campaign, &ComplianceWorkflowOptions::default())?;
    compliance
        .fitted
        .compliance
        .write(out.join("compliance.toml"))?;
    let setup = CompensationSetup {
        x_base_part: pose_mm_deg(&[1200.0, 0.0, 1450.0, 0.0, 0.0, 0.0]),
        payload_base: nalgebra::Vector6::new(0.0, 0.0, -920.0, 0.0, 0.0, 0.0),
        start_joints: default_start_joints(&robot),
    };
    let process: ProcessSpec = "cantilever:585,50,14,al-5005".parse()?;
    let run = |spec: ElasticSpec| -> Result<CommandedPath, Box<dyn Error>> {
        let elastic = load_elastic(&spec, &robot, &xi)?;
        let commanded = compensate_path_file(
            &robot,
            xi.clone(),
            elastic.as_ref(),
            process.as_process(),
            &setup,
            path,
        )?;
        println!(
            "{}: max predicted deviation {:.3} mm, max residual {:.1e} mm",
            commanded.elastic,
            commanded.max_predicted_deviation_m() * 1e3,
            commanded.max_residual_m() * 1e3
        );
        Ok(commanded)
    };
    let fe = run(ElasticSpec::Fe {
        description: "ir663".into(),
        gamma_report: Some(out.join("stiffness_report.json")),
    })?;
    let fuzzy = run(ElasticSpec::Fuzzy(out.join("compliance.toml")))?;
    fe.write(&robot, &out.join("commanded_fe.csv"), &[])?;
    // The fuzzy model's path also as a KRL program for the controller.
    let krl = [(PathExport::Krl, out.join("commanded_fuzzy.src"))];
    for line in fuzzy.write(&robot, &out.join("commanded_fuzzy.csv"), &krl)? {
        println!("{line}");
    }
    Ok((fe, fuzzy))
}

/// Writes the virtual robot's deflection campaign into `dir/elastic` and a
/// short forming path (mm, part frame) into `dir/path.csv`.
pub fn write_inputs(dir: &Path) -> Result<(), Box<dyn Error>> {
    flexcal::twin::elastic::write_elastic_campaign(dir.join("elastic"), &Default::default())?;
    std::fs::write(
        dir.join("path.csv"),
        "x_mm,y_mm,z_mm\n580,0,0\n580,0,-10\n560,0,-10\n540,0,-10\n",
    )?;
    Ok(())
}

#[allow(dead_code)]
fn main() -> Result<(), Box<dyn Error>> {
    let dir = tempfile::tempdir()?;
    write_inputs(dir.path())?;
    compensate_with_each_model(
        &dir.path().join("elastic"),
        &dir.path().join("path.csv"),
        dir.path(),
    )?;
    Ok(())
}
