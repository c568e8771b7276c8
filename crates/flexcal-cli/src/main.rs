//! The `flexcal` command-line tool: a thin layer over the flexcal crates.
//!
//! Arguments flow raw flags -> validated configuration -> the library call.
//! Errors from the libraries are typed; here they are printed with their whole
//! cause chain on one line and turned into a non-zero exit code.

use clap::{Parser, Subcommand};
use std::process::ExitCode;

// Each subcommand lives in its own module with a clap `Args`/`Subcommand`
// type and a `run` function returning `anyhow::Result<()>`.
mod cmd_bench;
mod cmd_calibrate;
mod cmd_compensate;
mod cmd_demo;
mod cmd_fem;
mod cmd_fk;
mod cmd_fuzzy;
mod cmd_identify;
mod cmd_plan;
mod cmd_poses;
mod cmd_robot;
mod cmd_twin;
mod robot_arg;

/// flexcal: elasto-geometrical calibration and compensation of industrial robots.
#[derive(Parser, Debug)]
#[command(name = "flexcal", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Run the reference study end to end on built-in data and write a report.
    Demo(cmd_demo::DemoArgs),
    /// Frame finite elements: solve a structure file or condense it onto a node.
    #[command(subcommand)]
    Fem(cmd_fem::FemCommand),
    /// Built-in robots and robot description files.
    #[command(subcommand)]
    Robot(cmd_robot::RobotCommand),
    /// Forward model: TCP poses (and passive joints) of configurations.
    Fk(cmd_fk::FkArgs),
    /// Inverse model: configurations reaching TCP poses.
    Ik(cmd_fk::IkArgs),
    /// Fuzzy models: fit from CSV data, evaluate, export to `.fis`.
    #[command(subcommand)]
    Fuzzy(cmd_fuzzy::FuzzyCommand),
    /// Time the core operations on this machine (ns per operation).
    Bench(cmd_bench::BenchArgs),
    /// Geometric calibration from measurements (identifiability, identification, validation).
    Calibrate(cmd_calibrate::CalibrateArgs),
    /// Measurement poses: choose a well-conditioned set from candidates.
    #[command(subcommand)]
    Poses(cmd_poses::PosesCommand),
    /// Virtual robots: write the files of the paper's campaigns.
    #[command(subcommand)]
    Twin(cmd_twin::TwinCommand),
    /// Elastic identification: stiffness of a robot's beam model from measured deflections.
    #[command(subcommand)]
    Identify(cmd_identify::IdentifyCommand),
    /// Compensation: the commanded path that makes the loaded robot follow a target path.
    Compensate(cmd_compensate::CompensateArgs),
    /// Plan a campaign before measuring: which poses, how many, and the accuracy they buy.
    Plan(cmd_plan::PlanArgs),
    // <wire: new subcommand variants go above this line>
}

/// A flag value that fails flexcal's own validation: the command exits with
/// code 2, like clap's own usage errors (failures of the work exit with 1).
#[derive(Debug)]
pub(crate) struct UsageError(pub String);

impl std::fmt::Display for UsageError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for UsageError {}

/// Returns a [`UsageError`] (exit code 2) with a formatted message.
macro_rules! usage_bail {
    ($($arg:tt)*) => {
        return Err(anyhow::Error::new(crate::UsageError(format!($($arg)*))))
    };
}
pub(crate) use usage_bail;

/// Whether an error is a usage error: a flag value flexcal rejects before
/// doing any work (exit code 2).
fn is_usage_error(err: &anyhow::Error) -> bool {
    err.chain().any(|cause| {
        cause.is::<UsageError>()
            || cause
                .downcast_ref::<flexcal::Error>()
                .is_some_and(flexcal::Error::is_usage)
    })
}

/// A spinner with the `indicatif` template `template` (hidden when `quiet`).
pub(crate) fn spinner(template: &str, quiet: bool) -> indicatif::ProgressBar {
    let bar = if quiet {
        indicatif::ProgressBar::hidden()
    } else {
        indicatif::ProgressBar::new_spinner()
    };
    bar.set_style(
        indicatif::ProgressStyle::with_template(template)
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
    );
    bar
}

/// The items of a comma-separated option, trimmed, empty ones dropped.
pub(crate) fn list_items(values: &[String]) -> Vec<String> {
    values
        .iter()
        .map(|s| s.trim().to_string())
        .filter(|s| !s.is_empty())
        .collect()
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Demo(args) => cmd_demo::run(args),
        Command::Fem(command) => cmd_fem::run(command),
        Command::Robot(command) => cmd_robot::run(command),
        Command::Fk(args) => cmd_fk::run_fk(args),
        Command::Ik(args) => cmd_fk::run_ik(args),
        Command::Fuzzy(command) => cmd_fuzzy::run(command),
        Command::Bench(args) => cmd_bench::run(args),
        Command::Calibrate(args) => cmd_calibrate::run(args),
        Command::Poses(command) => cmd_poses::run(command),
        Command::Twin(command) => cmd_twin::run(command),
        Command::Identify(command) => cmd_identify::run(command),
        Command::Compensate(args) => cmd_compensate::run(args),
        Command::Plan(args) => cmd_plan::run(args),
        // <wire: new match arms go above this line>
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {}", flexcal::cause_chain_line(err.chain()));
            if is_usage_error(&err) {
                ExitCode::from(2)
            } else {
                ExitCode::FAILURE
            }
        }
    }
}
