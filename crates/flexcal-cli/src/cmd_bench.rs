//! `flexcal bench`: times the core operations on this machine, so a user can
//! see whether model-based compensation fits a controller cycle. The timing
//! and its statistics are [`flexcal::bench`]; this command only prints.

/// Arguments of `flexcal bench`.
#[derive(clap::Args, Debug)]
pub struct BenchArgs {
    /// Print JSON (`{"operations": [{"name", "ns_per_op", "min_ns", "samples",
    /// "cpu_ns_per_op", "iterations"}], "threads", "cores", "load_average"}`;
    /// `ns_per_op` is the median over the samples, `cpu_ns_per_op` the
    /// processor time the timing thread received).
    #[arg(long)]
    pub json: bool,
    /// Time budget per operation (ms).
    #[arg(long, default_value_t = 300)]
    pub budget_ms: u64,
}

/// Runs `flexcal bench`.
pub fn run(args: BenchArgs) -> anyhow::Result<()> {
    let report = flexcal::bench::run(&flexcal::bench::BenchOptions {
        budget_ms: args.budget_ms,
    })?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
        return Ok(());
    }
    print!("{}", report.table_text());
    Ok(())
}
