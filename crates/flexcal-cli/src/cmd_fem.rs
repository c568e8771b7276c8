//! `flexcal fem`: solve or condense a frame structure file (TOML or JSON).

use std::path::PathBuf;

use anyhow::Context;
use flexcal::fem::{
    FemModel, condensation_json, condensation_text, displacements_json, displacements_text,
};

/// Subcommands of `flexcal fem`.
#[derive(clap::Subcommand, Debug)]
pub enum FemCommand {
    /// Displacements [m, rad] of every node for every load case.
    Solve(SolveArgs),
    /// Equivalent stiffness K_eq, compliance C_eq and wrench F_eq at one node.
    Condense(CondenseArgs),
}

/// Arguments of `flexcal fem solve`.
#[derive(clap::Args, Debug)]
pub struct SolveArgs {
    /// Structure file (.toml or .json).
    pub file: PathBuf,
    /// Print `{"load_cases": {"<case>": {"<node>": [ux, uy, uz, rx, ry, rz]}}}`.
    #[arg(long)]
    pub json: bool,
}

/// Arguments of `flexcal fem condense`.
#[derive(clap::Args, Debug)]
pub struct CondenseArgs {
    /// Structure file (.toml or .json).
    pub file: PathBuf,
    /// Name of the node to condense onto.
    #[arg(long)]
    pub node: String,
    /// Print `{"K_eq": 6x6, "C_eq": 6x6, "F_eq": {"<case>": [6 values]}}`.
    #[arg(long)]
    pub json: bool,
}

/// Runs `flexcal fem ...`.
pub fn run(command: FemCommand) -> anyhow::Result<()> {
    match command {
        FemCommand::Solve(args) => solve(args),
        FemCommand::Condense(args) => condense(args),
    }
}

fn solve(args: SolveArgs) -> anyhow::Result<()> {
    let model = FemModel::read(&args.file)?;
    let cases = model
        .solve()
        .with_context(|| args.file.display().to_string())?;
    if args.json {
        println!("{}", displacements_json(&model.structure, &cases));
    } else {
        print!("{}", displacements_text(&model.structure, &cases));
    }
    Ok(())
}

fn condense(args: CondenseArgs) -> anyhow::Result<()> {
    let model = FemModel::read(&args.file)?;
    let condensed = model
        .condense(&args.node)
        .with_context(|| args.file.display().to_string())?;
    if args.json {
        println!("{}", condensation_json(&condensed));
    } else {
        print!("{}", condensation_text(&condensed, &args.node));
    }
    Ok(())
}
