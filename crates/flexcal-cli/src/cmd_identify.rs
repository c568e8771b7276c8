//! `flexcal identify`: elastic identification. For now `stiffness`: the
//! parametric beam model's stiffness parameters Gamma (section 3.3.1).

use std::path::PathBuf;

use anyhow::Context;
use flexcal::elastic::description::ElasticDescription;
use flexcal::elastic::workflow::{StiffnessWorkflowOptions, identify_stiffness_in_dir};

use crate::robot_arg::load_model;

#[path = "cmd_identify_compliance.rs"]
pub mod compliance;

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
    Compliance(compliance::ComplianceArgs),
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
        IdentifyCommand::Compliance(args) => compliance::run_compliance(args),
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
