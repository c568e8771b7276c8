//! `flexcal poses select`: choose measurement poses from a candidate pool.

use std::path::PathBuf;

use flexcal::optim::ObservabilityIndex;
use flexcal::pose_file::configurations_to_csv;
use flexcal::pose_selection::{PoseSelectionConfig, select_poses};

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
    /// Robot: a built-in name or a robot file (.toml, .urdf, .par).
    #[arg(long)]
    pub robot: String,
    #[command(flatten)]
    pub robot_file: crate::robot_arg::RobotFileArgs,
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
    let model = load_model(&args.robot, &args.robot_file)?;
    let config = PoseSelectionConfig {
        index: match args.index {
            IndexKind::O1 => ObservabilityIndex::O1,
            IndexKind::O2 => ObservabilityIndex::O2,
            IndexKind::O3 => ObservabilityIndex::O3,
            IndexKind::O4 => ObservabilityIndex::O4,
            IndexKind::O5 => ObservabilityIndex::O5,
        },
        use_orientation: args.orientation,
        fixed: args.fix,
        ..PoseSelectionConfig::new(args.candidates, args.count)
    };
    let run = select_poses(&model, &config)?;
    print!("{}", run.summary_text());
    if let Some(out) = &args.out {
        let text = configurations_to_csv(model.n_actuated(), &run.selected());
        flexcal::io::write_atomic(out, text)?;
        println!("selected configurations written to {}", out.display());
    }
    Ok(())
}
