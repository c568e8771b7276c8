//! `flexcal twin`: the virtual robot's campaigns, written as the files a real
//! campaign would produce.

use std::path::PathBuf;

use flexcal::twin::geometric::{
    GeometricCampaignOptions, geometric_campaign, write_geometric_campaign,
};

/// Subcommands of `flexcal twin`.
#[derive(clap::Subcommand, Debug)]
pub enum TwinCommand {
    /// The virtual IR-663's geometric campaign: 27 identification + 16
    /// validation poses of box (59), photogrammetry noise, and the truth.
    Geometric(CampaignArgs),
    /// The virtual IR-663's elastic campaign: the 63-pose grid (65), loads of
    /// 300-1100 N along x and z, loaded and unloaded poses (8 files), and the truth.
    Elastic(CampaignArgs),
    /// The forming experiment (paper section 4, Figure 17) on the virtual
    /// IR-663: a 650 N tool plunges 25 mm into a clamped Al-5005 beam and
    /// travels 200 mm, commanded without and with compensation.
    Forming(FormingArgs),
}

/// Arguments of `flexcal twin forming`.
#[derive(clap::Args, Debug)]
pub struct FormingArgs {
    /// Output folder (created if missing).
    #[arg(long)]
    pub out: PathBuf,
    /// Seed of the measurement noise.
    #[arg(long, default_value_t = 17)]
    pub seed: u64,
    /// Calibrated robot description TOML (from `flexcal calibrate`) whose xi
    /// commands the robot; default the nominal xi.
    #[arg(long)]
    pub calibrated: Option<PathBuf>,
    /// The calibration's report (`flexcal calibrate --report` JSON): its
    /// identified measurement frame carries the part, located by the
    /// camera, into the calibrated robot's base. Without it the part's pose
    /// in the robot base is taken as known exactly.
    #[arg(long)]
    pub calibration_report: Option<PathBuf>,
    /// Identified Gamma (`flexcal identify stiffness --report` JSON) for the
    /// FE beam model; default the nominal Gamma.
    #[arg(long)]
    pub fe_report: Option<PathBuf>,
    /// Fuzzy compliance TOML (from `flexcal identify compliance`): also
    /// compensate with it.
    #[arg(long)]
    pub fuzzy: Option<PathBuf>,
}

fn run_forming_cmd(args: FormingArgs) -> anyhow::Result<()> {
    let config = flexcal::forming::FormingConfig {
        seed: args.seed,
        calibrated: args.calibrated,
        calibration_report: args.calibration_report,
        fe_report: args.fe_report,
        fuzzy: args.fuzzy,
    };
    let experiment = flexcal::forming::run_forming_experiment(&config)?;
    experiment.write(&args.out)?;
    print!("{}", experiment.summary_text(args.seed, &args.out));
    Ok(())
}

/// Arguments of `flexcal twin geometric` and `flexcal twin elastic`.
#[derive(clap::Args, Debug)]
pub struct CampaignArgs {
    /// Output folder (created if missing).
    #[arg(long)]
    pub out: PathBuf,
    /// Seed of every random draw of the campaign.
    #[arg(long, default_value_t = 663)]
    pub seed: u64,
}

fn run_elastic(args: CampaignArgs) -> anyhow::Result<()> {
    let options = flexcal::twin::elastic::ElasticCampaignOptions {
        seed: args.seed,
        ..Default::default()
    };
    let summary = flexcal::twin::elastic::write_elastic_campaign(&args.out, &options)?;
    print!("{}", summary.text(args.seed, &args.out));
    Ok(())
}

/// Runs `flexcal twin ...`.
pub fn run(command: TwinCommand) -> anyhow::Result<()> {
    match command {
        TwinCommand::Elastic(args) => run_elastic(args),
        TwinCommand::Forming(args) => run_forming_cmd(args),
        TwinCommand::Geometric(args) => {
            let options = GeometricCampaignOptions {
                seed: args.seed,
                ..GeometricCampaignOptions::default()
            };
            let campaign = geometric_campaign(&options)?;
            write_geometric_campaign(&campaign, &args.out)?;
            print!("{}", campaign.summary_text(args.seed, &args.out));
            Ok(())
        }
    }
}
