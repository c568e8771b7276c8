//! `flexcal identify`: elastic identification from the deflection sets of
//! one load, validated on the others: `stiffness`, the parametric beam
//! model's stiffness parameters Gamma (section 3.3.1 of the reference
//! paper), and `compliance`, the fuzzy compliance model (section 3.3.2,
//! equations (38), (70)).

use std::path::PathBuf;

use anyhow::Context;
use flexcal::elastic::description::ElasticDescription;
use flexcal::elastic::workflow::{
    ComplianceReport, ComplianceStructure, ComplianceWorkflowOptions, StiffnessWorkflowOptions,
    identify_compliance_in_dir, identify_stiffness_in_dir,
};

use crate::robot_arg::load_model;

/// Subcommands of `flexcal identify`.
#[derive(clap::Subcommand, Debug)]
pub enum IdentifyCommand {
    /// Joint stiffness Gamma of a robot's beam model from measured TCP
    /// deflections: global search, Levenberg-Marquardt, identifiability by
    /// name, and the per-load table of the paper's Table 5.
    Stiffness(StiffnessArgs),
    /// Fuzzy compliance model (C_xx, C_xz, C_zx, C_zz of chosen joint
    /// coordinates) learnt jointly from measured TCP deflections, with the
    /// rule base of C_xx (Table 4) and the per-load table (Table 5).
    Compliance(ComplianceArgs),
}

/// Arguments of `flexcal identify stiffness`.
#[derive(clap::Args, Debug)]
pub struct StiffnessArgs {
    /// Robot: a built-in name or a robot file (.toml, .urdf, .par).
    #[arg(long)]
    pub robot: String,
    #[command(flatten)]
    pub robot_file: crate::robot_arg::RobotFileArgs,
    /// Elastic description: a built-in name (`ir663`) or a TOML file.
    #[arg(long)]
    pub elastic: String,
    /// Folder of deflection files (`*.csv`, one per load case).
    #[arg(long)]
    pub data: PathBuf,
    /// Load magnitude (N) whose sets train the model; the others validate it.
    #[arg(long, default_value_t = 900.0)]
    pub train_load: f64,
    /// Seed of the global search.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Objective evaluations of the global search (0: start from the nominal values).
    #[arg(long, default_value_t = 2500)]
    pub search_evaluations: usize,
    /// Write a JSON report here.
    #[arg(long)]
    pub report: Option<PathBuf>,
}

/// Runs `flexcal identify ...`.
pub fn run(command: IdentifyCommand) -> anyhow::Result<()> {
    match command {
        IdentifyCommand::Stiffness(args) => stiffness(args),
        IdentifyCommand::Compliance(args) => run_compliance(args),
    }
}

/// `--train-load` must be a positive load in N.
pub(crate) fn check_train_load(train_load: f64) -> anyhow::Result<()> {
    if !(train_load.is_finite() && train_load > 0.0) {
        crate::usage_bail!("--train-load must be a positive load in N, got {train_load}");
    }
    Ok(())
}

fn stiffness(args: StiffnessArgs) -> anyhow::Result<()> {
    check_train_load(args.train_load)?;
    println!(
        "identifying the stiffness parameters of '{}' on the {} N sets of {}, seed {}",
        args.elastic,
        args.train_load,
        args.data.display(),
        args.seed
    );
    let robot = load_model(&args.robot, &args.robot_file)?;
    let description = ElasticDescription::builtin_or_file(&args.elastic)
        .with_context(|| format!("elastic description '{}'", args.elastic))?;
    let options = StiffnessWorkflowOptions {
        train_load_n: args.train_load,
        seed: args.seed,
        search_evaluations: args.search_evaluations,
    };
    let outcome = identify_stiffness_in_dir(&robot, &description, &args.data, &options)
        .with_context(|| format!("elastic description '{}'", description.name))?;
    print!("{}", outcome.summary_text());
    if let Some(path) = &args.report {
        outcome.report.write(path)?;
        println!("report written to {}", path.display());
    }
    Ok(())
}

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
    check_train_load(args.train_load)?;
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
