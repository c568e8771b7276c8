//! `flexcal fem`: solve or condense a frame structure file (TOML or JSON).

use std::path::PathBuf;

use anyhow::Context;
use flexcal::fem::{Dof, FemError, FemModel, condensation_json, displacements_json};

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

fn load(file: &PathBuf) -> anyhow::Result<FemModel> {
    FemModel::read(file).map_err(|err| match err {
        // These already name the file.
        FemError::Parse { .. } | FemError::Io(_) | FemError::UnknownExtension { .. } => {
            anyhow::Error::new(err)
        }
        other => anyhow::Error::new(other).context(file.display().to_string()),
    })
}

fn solve(args: SolveArgs) -> anyhow::Result<()> {
    let model = load(&args.file)?;
    let cases = model
        .solve()
        .with_context(|| args.file.display().to_string())?;
    if args.json {
        println!("{}", displacements_json(&model.structure, &cases));
        return Ok(());
    }
    let names = model.structure.node_names();
    let width = names.iter().map(String::len).max().unwrap_or(4).max(4);
    for case in &cases {
        println!(
            "load case '{}': displacements [m] and rotations [rad], global axes",
            case.name
        );
        print!("{:<width$}", "node");
        for dof in Dof::ALL {
            print!(" {:>24}", dof.name());
        }
        println!();
        for (name, u) in names.iter().zip(&case.nodes) {
            print!("{name:<width$}");
            for value in u.iter() {
                print!(" {value:>24e}");
            }
            println!();
        }
        println!();
    }
    Ok(())
}

fn print_matrix(title: &str, m: &flexcal::nalgebra::Matrix6<f64>) {
    println!("{title}");
    for r in 0..6 {
        print!("  {:<3}", Dof::from_index(r).name());
        for c in 0..6 {
            print!(" {:>24e}", m[(r, c)]);
        }
        println!();
    }
}

fn condense(args: CondenseArgs) -> anyhow::Result<()> {
    let model = load(&args.file)?;
    let condensed = model
        .condense(&args.node)
        .with_context(|| args.file.display().to_string())?;
    if args.json {
        println!("{}", condensation_json(&condensed));
        return Ok(());
    }
    println!(
        "condensation onto node '{}', global axes, order [ux uy uz rx ry rz]",
        args.node
    );
    print_matrix("K_eq [N/m, N/rad; N.m/m, N.m/rad]:", &condensed.k_eq);
    print_matrix(
        "C_eq = K_eq^-1 [m/N, m/(N.m); rad/N, rad/(N.m)]:",
        &condensed.c_eq,
    );
    println!("F_eq [N, N.m] per load case:");
    for (name, f) in &condensed.f_eq {
        print!("  {name}:");
        for value in f.iter() {
            print!(" {value:e}");
        }
        println!();
    }
    Ok(())
}
