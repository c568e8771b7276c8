//! `flexcal identify`: elastic identification. For now `stiffness`: the
//! parametric beam model's stiffness parameters Gamma (section 3.3.1).

use std::path::PathBuf;

use anyhow::Context;
use flexcal_elastic::campaign::read_campaign_dir;
use flexcal_elastic::description::ElasticDescription;
use flexcal_elastic::identify::{
    StiffnessIdentificationOptions, identify_stiffness, residual_samples,
};
use flexcal_elastic::metrics::per_load_metrics;
use flexcal_elastic::model::ElasticModel;
use serde_json::json;

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
    /// Robot: a built-in name or a description TOML file.
    #[arg(long)]
    pub robot: String,
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

/// Splits a campaign's sets into the items of the training sets (those whose
/// load is `train_load` N, within 0.5 N) and the items of every set, with the
/// names of the training sets. `items` turns one set into what is fitted.
pub fn split_by_load<T>(
    sets: &[flexcal_elastic::campaign::DeflectionSet],
    train_load: f64,
    data: &std::path::Path,
    items: impl Fn(&flexcal_elastic::campaign::DeflectionSet) -> anyhow::Result<Vec<T>>,
) -> anyhow::Result<(Vec<T>, Vec<T>, Vec<String>)>
where
    T: Clone,
{
    let mut train = Vec::new();
    let mut all = Vec::new();
    let mut train_sets = Vec::new();
    for set in sets {
        let set_items = items(set)?;
        if (set.load_n() - train_load).abs() <= 0.5 {
            train.extend(set_items.iter().cloned());
            train_sets.push(set.name.clone());
        }
        all.extend(set_items);
    }
    if train.is_empty() {
        let loads: Vec<String> = sets
            .iter()
            .map(|s| format!("{} ({:.0} N)", s.name, s.load_n()))
            .collect();
        anyhow::bail!(
            "no deflection set in {} has the training load {} N (sets: {})",
            data.display(),
            train_load,
            loads.join(", ")
        );
    }
    Ok((train, all, train_sets))
}

/// Everything `identify stiffness` computes, for printing or for the demo.
pub struct StiffnessOutcome {
    /// The robot's geometric model.
    pub robot: flexcal_kinematics::Model,
    /// The elastic model that was identified.
    pub model: ElasticModel,
    /// The identified Gamma with the solver and identifiability reports.
    pub fitted: flexcal_elastic::identify::IdentifiedStiffness,
    /// Names of the training sets.
    pub train_sets: Vec<String>,
    /// Residuals of the identified model on every set (Table 5).
    pub table: flexcal_elastic::metrics::LoadMetricsTable,
    /// RMS norm of the deflection noise stated in the files (mm).
    pub noise_floor_mm: f64,
    /// The JSON report.
    pub report: serde_json::Value,
}

/// Identifies the stiffness parameters from the files named by `args`
/// (the code path of `flexcal identify stiffness`, without printing).
pub fn identify_stiffness_from_files(args: &StiffnessArgs) -> anyhow::Result<StiffnessOutcome> {
    if !(args.train_load.is_finite() && args.train_load > 0.0) {
        anyhow::bail!(
            "--train-load must be a positive load in N, got {}",
            args.train_load
        );
    }
    let robot = load_model(&args.robot)?;
    let description = ElasticDescription::builtin_or_file(&args.elastic)
        .with_context(|| format!("elastic description '{}'", args.elastic))?;
    let model = ElasticModel::new(&robot, &description)
        .with_context(|| format!("elastic description '{}'", description.name))?;
    let sets = read_campaign_dir(&args.data, robot.n_actuated())?;
    let (train, all, train_sets) = split_by_load(&sets, args.train_load, &args.data, |set| {
        Ok(set.measurements.clone())
    })?;
    let xi = robot.nominal_params().to_vec();
    let options = StiffnessIdentificationOptions {
        seed: args.seed,
        global_search_evaluations: args.search_evaluations,
        ..StiffnessIdentificationOptions::default()
    };
    let fitted = identify_stiffness(&model, &train, &xi, &options)?;
    let samples = residual_samples(&model, &all, &xi, &fitted.gamma)?;
    let table = per_load_metrics(&samples);
    // What a perfect model would still show: the RMS norm of the measurement
    // noise of the deflections.
    let noise_floor_mm =
        (all.iter().map(|m| m.sigma.norm_squared()).sum::<f64>() / all.len() as f64).sqrt() * 1e3;
    let s = &fitted.solve;
    let report = json!({
        "robot": robot.name(),
        "elastic": description.name,
        "train_load_n": args.train_load,
        "train_sets": train_sets,
        "seed": args.seed,
        "parameters": fitted.names.iter().enumerate().map(|(j, n)| json!({
            "name": n,
            "value": fitted.gamma[j],
            "unit": fitted.units[j],
            "after_global_search": fitted.gamma_global_search[j],
            "sensitivity_sigma_per_ln": fitted.identifiability.sensitivity[j],
        })).collect::<Vec<_>>(),
        "identifiability": fitted.identifiability,
        "identifiability_text": fitted.identifiability.describe(),
        "solver": {
            "termination": format!("{:?}", s.termination),
            "iterations": s.iterations,
            "residual_evaluations": s.residual_evaluations,
            "jacobian_evaluations": s.jacobian_evaluations,
            "rank": s.rank,
            "n_free": s.n_free,
            "singular_values": s.singular_values,
            "condition_number": if s.condition_number.is_finite() { json!(s.condition_number) } else { json!(null) },
            "cost_history": s.cost_history,
        },
        "global_search": {
            "evaluations": fitted.global_search_evaluations,
            "best_value": if fitted.global_search_value.is_finite() { json!(fitted.global_search_value) } else { json!(null) },
        },
        "criterion_mm2": fitted.criterion_mm2,
        "per_load": table,
        "noise_floor_rms_mm": noise_floor_mm,
    });
    Ok(StiffnessOutcome {
        robot,
        model,
        fitted,
        train_sets,
        table,
        noise_floor_mm,
        report,
    })
}

fn stiffness(args: StiffnessArgs) -> anyhow::Result<()> {
    println!(
        "identifying the stiffness parameters of '{}' on the {} N sets of {}, seed {}",
        args.elastic,
        args.train_load,
        args.data.display(),
        args.seed
    );
    let outcome = identify_stiffness_from_files(&args)?;
    let fitted = &outcome.fitted;
    let s = &fitted.solve;
    println!("training sets: {}", outcome.train_sets.join(", "));
    println!(
        "global search: {} evaluations, best mean squared weighted residual {:.4e}",
        fitted.global_search_evaluations, fitted.global_search_value
    );
    println!(
        "Levenberg-Marquardt: {:?} after {} iterations ({} residual evaluations), rank {} of {} free, cond {:.3e}",
        s.termination, s.iterations, s.residual_evaluations, s.rank, s.n_free, s.condition_number
    );
    println!(
        "criterion (67) C(Gamma) = {:.5} mm^2 on the training sets",
        fitted.criterion_mm2
    );
    println!("identified Gamma:");
    for (j, name) in fitted.names.iter().enumerate() {
        let sens = fitted.identifiability.sensitivity[j];
        println!(
            "  {name:<10} {:>12.4e} {:<8} (sensitivity {:.3e} sigma per ln unit)",
            fitted.gamma[j], fitted.units[j], sens
        );
    }
    println!("identifiability:");
    for line in fitted.identifiability.describe() {
        println!("  {line}");
    }
    println!(
        "residuals of the identified model, per load (both directions pooled; train load {} N):",
        args.train_load
    );
    println!("{}", outcome.table);
    println!(
        "noise floor (RMS norm of the deflection noise, from the files' standard deviations): {:.4} mm",
        outcome.noise_floor_mm
    );
    if let Some(path) = &args.report {
        flexcal_io::write_atomic(path, serde_json::to_string_pretty(&outcome.report)?)?;
        println!("report written to {}", path.display());
    }
    Ok(())
}
