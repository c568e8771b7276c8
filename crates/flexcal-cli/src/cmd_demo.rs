//! `flexcal demo`: the reference study on the virtual robot.

use std::path::PathBuf;

/// Arguments of `flexcal demo`.
#[derive(clap::Args, Debug)]
pub struct DemoArgs {
    /// Output folder.
    #[arg(long, default_value = "flexcal-demo")]
    pub out: PathBuf,
    /// Seed of every random draw (measurement noise, data splits, searches).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

/// Runs the demo.
pub fn run(args: DemoArgs) -> anyhow::Result<()> {
    println!(
        "flexcal demo (seed {}, output {}): no step is built yet.",
        args.seed,
        args.out.display()
    );
    Ok(())
}
