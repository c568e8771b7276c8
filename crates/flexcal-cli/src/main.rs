//! The `flexcal` command-line tool: a thin layer over the flexcal crates.
//!
//! Arguments flow raw flags -> validated configuration -> the library call.
//! Errors from the libraries are typed; here they are printed with their whole
//! cause chain on one line and turned into a non-zero exit code.

use clap::{Parser, Subcommand};
use std::process::ExitCode;

// Each subcommand lives in its own module with a clap `Args`/`Subcommand`
// type and a `run` function returning `anyhow::Result<()>`.
mod cmd_demo;

/// flexcal: elasto-geometrical calibration and compensation of industrial robots.
#[derive(Parser, Debug)]
#[command(name = "flexcal", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Run the reference study end to end on built-in data and write a report.
    Demo(cmd_demo::DemoArgs),
    // <wire: new subcommand variants go above this line>
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Demo(args) => cmd_demo::run(args),
        // <wire: new match arms go above this line>
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            let chain: Vec<String> = err.chain().map(|c| c.to_string()).collect();
            eprintln!("error: {}", chain.join(": "));
            ExitCode::FAILURE
        }
    }
}
