//! Campaign planning checked on the virtual IR-663
//! ([`flexcal::plan::twin_check`]): plans of 15, 27, 50 and 100 poses of
//! box (59), measuring positions only and then full poses, each
//! calibrated on the twin's measurements of the planned poses (the same
//! kind) and validated over the region against the plan's predicted 95 %
//! bounds; then 27 planned full poses against 20 random draws and the
//! O1-selected set. Prints the docs' tables (docs/planning.md).
//!
//! `cargo run --release -p flexcal --example plan_validation [SEED]`

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let seed: u64 = std::env::args().nth(1).map_or(Ok(3), |s| s.parse())?;
    let check = flexcal::plan::twin_check::twin_plan_check(seed, &[15, 27, 50, 100], 27, 20)?;
    print!("{}", check.to_markdown());
    Ok(())
}
