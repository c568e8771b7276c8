//! `flexcal fuzzy`: fit, evaluate and export zero-order Takagi-Sugeno models
//! (flexcal-fuzzy) from CSV data.

use std::path::PathBuf;

use flexcal_fuzzy::{
    Dataset, FuzzyError, FuzzyModel, FuzzyParams, SearchPhase, SearchProgress,
    StructureSearchParams,
};
use flexcal_io::{CsvOptions, CsvTable};

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

fn read_dataset(path: &PathBuf, inputs: &[&str], output: &str) -> anyhow::Result<Dataset> {
    let table = CsvTable::read(path, &CsvOptions::default())?;
    Dataset::from_csv(&table, inputs, output).map_err(|err| match err {
        // File errors already name the file, line and column.
        FuzzyError::Io(_) => anyhow::Error::new(err),
        other => anyhow::Error::new(other).context(path.display().to_string()),
    })
}

fn fit(args: FitArgs) -> anyhow::Result<()> {
    let inputs = crate::list_items(&args.inputs);
    if inputs.is_empty() {
        crate::usage_bail!("--inputs names no column");
    }
    let data = read_dataset(&args.data, &inputs, &args.output)?;
    let (train, test) = match &args.test_data {
        Some(path) => (data, read_dataset(path, &inputs, &args.output)?),
        None => data.split_random(args.test_fraction, args.seed)?,
    };
    let defaults = StructureSearchParams::default();
    let params = FuzzyParams {
        search: StructureSearchParams {
            max_rules: args.max_rules,
            placement: flexcal_optim::solis_wets::SolisWetsParams {
                seed: args.seed,
                ..defaults.placement.clone()
            },
            ..defaults
        },
        ridge: args.ridge,
        ..FuzzyParams::default()
    };
    let bar = if args.quiet {
        indicatif::ProgressBar::hidden()
    } else {
        indicatif::ProgressBar::new_spinner()
    };
    bar.set_style(
        indicatif::ProgressStyle::with_template("{spinner} [{elapsed}] {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
    );
    let mut on_progress = |p: &SearchProgress| {
        let doing = match p.phase {
            SearchPhase::Initial => "initial placement".to_string(),
            SearchPhase::Candidate { input, .. } => {
                format!("trying one more MF on '{}'", inputs[input])
            }
            SearchPhase::StepDone => "step done".to_string(),
        };
        bar.set_message(format!(
            "growth step {}, MFs {:?}, best test rmse {:.4e}, {} evaluations: {doing}",
            p.growth_step, p.memberships[0], p.best_test_error, p.evaluations
        ));
        bar.tick();
    };
    let fitted = params.fit(&train, &test, &mut on_progress);
    bar.finish_and_clear();
    let fitted = fitted?;
    fitted.model.save(&args.out)?;
    let report = &fitted.report;
    println!(
        "{} rules {:?}, {} training / {} test samples, train rmse {:.6e}, test rmse {:.6e}, test max |error| {:.6e} ({:?} after {} evaluations); wrote {}",
        fitted.model.structure().rule_count(),
        fitted.model.structure().membership_counts(),
        train.len(),
        test.len(),
        report.training.rmse,
        report.test.rmse,
        report.test.max_abs,
        report.search.termination,
        report.search.evaluations,
        args.out.display()
    );
    Ok(())
}

fn eval(args: EvalArgs) -> anyhow::Result<()> {
    let model = FuzzyModel::load(&args.model)?;
    let inputs: Vec<&str> = model.input_names().iter().map(String::as_str).collect();
    let data = read_dataset(&args.data, &inputs, model.output_name())?;
    let stats = model.error_stats(&data)?;
    if args.json {
        // The field order of `ErrorStats` is the documented key order.
        println!("{}", serde_json::to_string(&stats)?);
    } else {
        println!(
            "{} samples: rmse {:.6e}, mae {:.6e}, max |error| {:.6e} (output '{}')",
            stats.n,
            stats.rmse,
            stats.mae,
            stats.max_abs,
            model.output_name()
        );
    }
    Ok(())
}

fn export(args: ExportArgs) -> anyhow::Result<()> {
    let model = FuzzyModel::load(&args.model)?;
    let name = args
        .model
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| model.output_name().to_string());
    model.export_fis(&args.fis, &name)?;
    println!("wrote {}", args.fis.display());
    Ok(())
}
