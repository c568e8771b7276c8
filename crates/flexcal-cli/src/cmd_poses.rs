//! `flexcal poses select`: choose measurement poses from a candidate pool.

use std::path::PathBuf;

use flexcal_calib::{read_configurations, select_calibration_poses};
use flexcal_optim::ObservabilityIndex;

use crate::robot_arg::load_model;

/// Observability index to maximise.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum IndexKind {
    /// Product of the singular values (D-optimality).
    O1,
    /// Inverse condition number.
    O2,
    /// Minimum singular value.
    O3,
    /// Noise amplification index.
    O4,
    /// Inverse sum of inverse singular values.
    O5,
}

/// Subcommands of `flexcal poses`.
#[derive(clap::Subcommand, Debug)]
pub enum PosesCommand {
    /// Select N poses maximising an observability index (greedy + exchange).
    Select(SelectArgs),
}

/// Arguments of `flexcal poses select`.
#[derive(clap::Args, Debug)]
pub struct SelectArgs {
    /// Robot: a built-in name or a description file (.toml).
    #[arg(long)]
    pub robot: String,
    /// Candidate configurations: CSV with columns q1..qn (rad, m).
    #[arg(long)]
    pub candidates: PathBuf,
    /// Number of poses to select.
    #[arg(long)]
    pub count: usize,
    /// Index to maximise.
    #[arg(long, value_enum, default_value = "o1")]
    pub index: IndexKind,
    /// Count measured orientations too (6 rows per pose instead of 3).
    #[arg(long)]
    pub orientation: bool,
    /// Parameters left out (kept at nominal), comma-separated.
    #[arg(long, value_delimiter = ',')]
    pub fix: Vec<String>,
    /// Write the selected configurations (q1..qn) to this CSV file.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// Runs `flexcal poses ...`.
pub fn run(command: PosesCommand) -> anyhow::Result<()> {
    let PosesCommand::Select(args) = command;
    let model = load_model(&args.robot)?;
    let candidates = read_configurations(&args.candidates)?;
    let index = match args.index {
        IndexKind::O1 => ObservabilityIndex::O1,
        IndexKind::O2 => ObservabilityIndex::O2,
        IndexKind::O3 => ObservabilityIndex::O3,
        IndexKind::O4 => ObservabilityIndex::O4,
        IndexKind::O5 => ObservabilityIndex::O5,
    };
    let result = select_calibration_poses(
        &model,
        &candidates,
        args.count,
        index,
        args.orientation,
        &args.fix,
    )?;
    let s = &result.selection;
    println!(
        "selected {} of {} candidates over {} identifiable parameters ({} exchanges, {} evaluations)",
        s.selected.len(),
        candidates.len(),
        result.parameters.len(),
        s.exchanges,
        s.evaluations
    );
    println!(
        "O1 {:.4e}  O2 {:.4e}  O3 {:.4e}  O4 {:.4e}  O5 {:.4e}",
        s.indices.o1, s.indices.o2, s.indices.o3, s.indices.o4, s.indices.o5
    );
    println!(
        "selected candidates (0-based rows): {}",
        s.selected
            .iter()
            .map(|i| i.to_string())
            .collect::<Vec<_>>()
            .join(" ")
    );
    if let Some(out) = &args.out {
        let header: Vec<String> = (1..=model.n_actuated()).map(|i| format!("q{i}")).collect();
        let header: Vec<&str> = header.iter().map(String::as_str).collect();
        let text =
            flexcal_io::format_csv(&header, s.selected.iter().map(|&i| candidates[i].clone()));
        flexcal_io::write_atomic(out, text)?;
        println!("selected configurations written to {}", out.display());
    }
    Ok(())
}
