//! `flexcal identify compliance`: the fuzzy compliance model of a robot
//! (section 3.3.2 of the reference paper, equations (38), (70)), learnt from
//! the deflection sets of one load and validated on the others.

use std::path::PathBuf;

use flexcal::elastic::workflow::{
    ComplianceReport, ComplianceStructure, ComplianceWorkflowOptions, identify_compliance_in_dir,
};

use crate::robot_arg::load_model;

/// Arguments of `flexcal identify compliance`.
#[derive(clap::Args, Debug)]
pub struct ComplianceArgs {
    /// Folder of deflection files (`*.csv`, one per load case).
    #[arg(long)]
    pub data: PathBuf,
    /// Model inputs, comma-separated: actuated coordinates (`theta1`,
    /// `r2p`) or joint angles of slider-crank joints (`theta2`, `theta8`).
    #[arg(long, default_value = "theta2,theta8", value_delimiter = ',')]
    pub inputs: Vec<String>,
    /// Robot: a built-in name or a robot file (.toml, .urdf, .par) (turns the files'
    /// actuated coordinates into the inputs).
    #[arg(long, default_value = "ir663")]
    pub robot: String,
    #[command(flatten)]
    pub robot_file: crate::robot_arg::RobotFileArgs,
    /// Load magnitude (N) whose sets train the model; the others validate it.
    #[arg(long, default_value_t = 900.0)]
    pub train_load: f64,
    /// Fraction of the training configurations held out to choose the
    /// structure (0.286: 36 of the paper's 126).
    #[arg(long, default_value_t = 0.286)]
    pub test_fraction: f64,
    /// Seed of the train/test split.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Rule budget of each component model (the paper's 4 x 3 = 12).
    #[arg(long, default_value_t = 12)]
    pub max_rules: usize,
    /// Give each component its own partition grid instead of one shared grid.
    #[arg(long)]
    pub separate_structures: bool,
    /// Save the fitted model (TOML, SI units) here.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Write a JSON report here.
    #[arg(long)]
    pub report: Option<PathBuf>,
}

/// Runs `flexcal identify compliance`.
pub fn run_compliance(args: ComplianceArgs) -> anyhow::Result<()> {
    super::check_train_load(args.train_load)?;
    let robot = load_model(&args.robot, &args.robot_file)?;
    let options = ComplianceWorkflowOptions {
        inputs: args.inputs.clone(),
        train_load_n: args.train_load,
        test_fraction: args.test_fraction,
        seed: args.seed,
        max_rules: args.max_rules,
        structure: if args.separate_structures {
            ComplianceStructure::Separate
        } else {
            ComplianceStructure::Shared
        },
    };
    let outcome = identify_compliance_in_dir(&robot, &args.data, &options)?;
    print!("{}", outcome.summary_text(&options));
    if let Some(path) = &args.out {
        outcome.fitted.compliance.write(path)?;
        println!("model written to {}", path.display());
    }
    if let Some(path) = &args.report {
        ComplianceReport::new(robot.name(), &options, &outcome).write(path)?;
        println!("report written to {}", path.display());
    }
    Ok(())
}
