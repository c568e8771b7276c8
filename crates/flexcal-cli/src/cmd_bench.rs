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
    let width = report
        .operations
        .iter()
        .map(|t| t.name.len())
        .max()
        .unwrap_or(0);
    println!(
        "{:<width$} {:>14} {:>14} {:>8} {:>14}",
        "operation", "min ns/op", "median ns/op", "samples", "cpu ns/op"
    );
    for t in &report.operations {
        let cpu = t
            .cpu_ns_per_op
            .map_or_else(|| "-".to_string(), |ns| format!("{ns:.1}"));
        println!(
            "{:<width$} {:>14.1} {:>14.1} {:>8} {:>14}",
            t.name, t.min_ns, t.ns_per_op, t.samples, cpu
        );
    }
    match report.load_average {
        Some([one, five, fifteen]) => {
            let busy = if one > report.cores as f64 * 0.75 {
                " (busy: other work competes for the cores; medians above the minimum show it)"
            } else {
                ""
            };
            println!(
                "load average {one:.2} {five:.2} {fifteen:.2} on {} cores, {} compensation threads{busy}",
                report.cores, report.threads
            );
        }
        None => println!(
            "{} cores, {} compensation threads",
            report.cores, report.threads
        ),
    }
    Ok(())
}
