//! `flexcal demo`: the reference study on the virtual IR-663
//! ([`flexcal::study::run_study`]), written as the files a real campaign
//! produces, a `summary.json` and a self-contained `report.html`.

use std::path::PathBuf;
use std::time::{Duration, Instant};

use flexcal::study::{StudyObserver, StudyOptions, run_study, write_study};
use indicatif::ProgressBar;

/// Arguments of `flexcal demo`.
#[derive(clap::Args, Debug)]
pub struct DemoArgs {
    /// Output folder (created if missing; files in it are replaced atomically).
    #[arg(long, default_value = "flexcal-demo")]
    pub out: PathBuf,
    /// Seed of every random draw (measurement noise, pose jitter, data splits, searches).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

/// A spinner per step, its result line when it ends.
#[derive(Default)]
struct Spinners {
    bar: Option<ProgressBar>,
}

impl StudyObserver for Spinners {
    fn started(&mut self, what: &str) {
        let bar = crate::spinner("{spinner} {msg} [{elapsed}]", false);
        bar.enable_steady_tick(Duration::from_millis(120));
        bar.set_message(what.to_string());
        self.bar = Some(bar);
    }
    fn stage(&mut self, what: &str) {
        if let Some(bar) = &self.bar {
            bar.set_message(what.to_string());
        }
    }
    fn finished(&mut self, line: &str) {
        if let Some(bar) = self.bar.take() {
            bar.finish_and_clear();
        }
        println!("{line}");
    }
}

/// Runs the demo.
pub fn run(args: DemoArgs) -> anyhow::Result<()> {
    let start = Instant::now();
    println!(
        "flexcal demo: the reference study on the virtual IR-663 (seed {}), writing to {}",
        args.seed,
        args.out.display()
    );
    let options = StudyOptions {
        out: args.out,
        seed: args.seed,
    };
    let study = run_study(&options, &mut Spinners::default())?;
    let figures = write_study(&study)?;
    println!(
        "wrote {}/summary.json and {}/report.html ({} figures) in {:.1} s",
        options.out.display(),
        options.out.display(),
        figures,
        start.elapsed().as_secs_f64()
    );
    Ok(())
}
