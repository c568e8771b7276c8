//! `flexcal fuzzy`: fit, evaluate and export zero-order Takagi-Sugeno models
//! (flexcal-fuzzy) from CSV data.

use std::path::PathBuf;

use flexcal::fuzzy::SearchProgress;
use flexcal::fuzzy_csv::{CsvFitConfig, TestSet, evaluate_csv, export_fis, fit_csv, progress_line};

/// Subcommands of `flexcal fuzzy`.
#[derive(clap::Subcommand, Debug)]
pub enum FuzzyCommand {
    /// Learn a model (structure, modal values, conclusions) from a CSV file.
    Fit(FitArgs),
    /// Error statistics of a model on a CSV file holding its inputs and output.
    Eval(EvalArgs),
    /// Write a model in the `.fis` text format of classic fuzzy toolboxes.
    Export(ExportArgs),
}

/// Arguments of `flexcal fuzzy fit`.
#[derive(clap::Args, Debug)]
pub struct FitArgs {
    /// Training data: CSV with a header naming the columns.
    #[arg(long)]
    pub data: PathBuf,
    /// Input columns, comma-separated (e.g. `theta2,theta8`).
    #[arg(long, value_delimiter = ',', required = true)]
    pub inputs: Vec<String>,
    /// Output column.
    #[arg(long)]
    pub output: String,
    /// Test data (same columns); by default a random part of --data is held out.
    #[arg(long, conflicts_with = "test_fraction")]
    pub test_data: Option<PathBuf>,
    /// Fraction of --data held out as the test set when --test-data is absent.
    #[arg(long, default_value_t = 0.25)]
    pub test_fraction: f64,
    /// Largest number of rules (default 64).
    #[arg(long, default_value_t = 64)]
    pub max_rules: usize,
    /// Seed of the split and of the modal-value search.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Relative ridge weight towards the rapid-prototyping conclusions.
    #[arg(long, default_value_t = 1e-6)]
    pub ridge: f64,
    /// Model file to write (TOML).
    #[arg(long)]
    pub out: PathBuf,
    /// Do not show the progress bar.
    #[arg(long)]
    pub quiet: bool,
}

/// Arguments of `flexcal fuzzy eval`.
#[derive(clap::Args, Debug)]
pub struct EvalArgs {
    /// Model file (TOML, from `flexcal fuzzy fit`).
    #[arg(long)]
    pub model: PathBuf,
    /// CSV with the model's input columns and its output column.
    #[arg(long)]
    pub data: PathBuf,
    /// Print exactly `{"rmse": .., "mae": .., "max_abs": .., "n": ..}`.
    #[arg(long)]
    pub json: bool,
}

/// Arguments of `flexcal fuzzy export`.
#[derive(clap::Args, Debug)]
pub struct ExportArgs {
    /// Model file (TOML, from `flexcal fuzzy fit`).
    #[arg(long)]
    pub model: PathBuf,
    /// `.fis` file to write.
    #[arg(long)]
    pub fis: PathBuf,
}

/// Runs `flexcal fuzzy ...`.
pub fn run(command: FuzzyCommand) -> anyhow::Result<()> {
    match command {
        FuzzyCommand::Fit(args) => fit(args),
        FuzzyCommand::Eval(args) => eval(args),
        FuzzyCommand::Export(args) => export(args),
    }
}

fn fit(args: FitArgs) -> anyhow::Result<()> {
    let inputs = crate::list_items(&args.inputs);
    if inputs.is_empty() {
        crate::usage_bail!("--inputs names no column");
    }
    let config = CsvFitConfig {
        test: match args.test_data {
            Some(path) => TestSet::File(path),
            None => TestSet::HeldOut(args.test_fraction),
        },
        max_rules: args.max_rules,
        seed: args.seed,
        ridge: args.ridge,
        ..CsvFitConfig::new(&args.data, inputs, &args.output)
    };
    let bar = crate::spinner("{spinner} [{elapsed}] {msg}", args.quiet);
    let mut on_progress = |p: &SearchProgress| {
        bar.set_message(progress_line(p, &config.inputs));
        bar.tick();
    };
    let fitted = fit_csv(&config, &mut on_progress);
    bar.finish_and_clear();
    let fitted = fitted?;
    fitted.fit.model.write(&args.out)?;
    println!("{}; wrote {}", fitted.summary_line(), args.out.display());
    Ok(())
}

fn eval(args: EvalArgs) -> anyhow::Result<()> {
    let evaluation = evaluate_csv(&args.model, &args.data)?;
    if args.json {
        // The field order of `ErrorStats` is the documented key order.
        println!("{}", serde_json::to_string(&evaluation.stats)?);
    } else {
        println!("{}", evaluation.summary_line());
    }
    Ok(())
}

fn export(args: ExportArgs) -> anyhow::Result<()> {
    export_fis(&args.model, &args.fis)?;
    println!("wrote {}", args.fis.display());
    Ok(())
}
