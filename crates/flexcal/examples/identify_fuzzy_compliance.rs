//! Identify a fuzzy compliance model (C_xx, C_xz, C_zx, C_zz of the joint
//! angles theta2, theta8; the reference paper's section 3.3.2) from a
//! directory of deflection files, one per load case.
//!
//! Run with `cargo run -p flexcal --example identify_fuzzy_compliance`.

use std::error::Error;
use std::path::Path;

use flexcal::elastic::workflow::{
    ComplianceOutcome, ComplianceWorkflowOptions, identify_compliance_in_dir,
};

/// Trains on the 900 N sets of `dir`, evaluates on every set (Table 5).
pub fn identify_fuzzy_compliance(dir: &Path) -> Result<ComplianceOutcome, Box<dyn Error>> {
    let robot = flexcal::load_robot("ir663")?;
    let options = ComplianceWorkflowOptions::default();
    let outcome = identify_compliance_in_dir(&robot, dir, &options)?;
    // The same summary `flexcal identify compliance` prints: the structure,
    // the rule base of C_xx (Table 4), the per-load residuals (Table 5).
    print!("{}", outcome.summary_text(&options));
    Ok(outcome)
}

/// Writes the virtual robot's deflection campaign into `dir`.
pub fn write_campaign(dir: &Path) -> Result<(), Box<dyn Error>> {
    flexcal::twin::elastic::write_elastic_campaign(dir, &Default::default())?;
    Ok(())
}

#[allow(dead_code)]
fn main() -> Result<(), Box<dyn Error>> {
    let dir = tempfile::tempdir()?;
    write_campaign(dir.path())?;
    identify_fuzzy_compliance(dir.path())?;
    Ok(())
}
