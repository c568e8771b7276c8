//! Campaign planning checked on the virtual IR-663
//! ([`flexcal::plan::twin_check`]): plans of 15, 27, 50 and 100 poses of
//! box (59), measuring positions only and then full poses, each
//! calibrated on the twin's measurements of the planned poses (the same
//! kind) and validated over the region against the plan's predicted 95 %
//! bounds; then 27 planned full poses against 20 random draws and the
//! O1-selected set. Prints the docs' tables (docs/planning.md).
//!
//! `cargo run --release -p flexcal --example plan_validation [SEED]`
//!
//! `... plan_validation SEED terms N` instead checks N full poses with
//! the twin's terms turned off one at a time
//! ([`flexcal::plan::twin_check::twin_term_check`]): where the misses come
//! from.
//!
//! `... plan_validation SEED draws N [DRAWS [frame]]` checks N planned
//! full poses on the twin's geometric errors alone (`frame`: and its
//! camera frame), the camera's noise drawn DRAWS times (default 50) on the
//! same poses and truth
//! ([`flexcal::plan::noise_check::twin_noise_check`]): the predicted
//! bounds' coverage as a mean over draws, and the estimation's own error
//! against the predicted one.

use flexcal::plan::noise_check::twin_noise_check;
use flexcal::plan::twin_check::{TWIN_TERMS, switches_without, twin_term_check};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let seed: u64 = args.get(1).map_or(Ok(3), |s| s.parse())?;
    if args.get(2).map(String::as_str) == Some("draws") {
        let n: usize = args.get(3).map_or(Ok(15), |s| s.parse())?;
        let draws: usize = args.get(4).map_or(Ok(50), |s| s.parse())?;
        let camera_frame = args.get(5).map(String::as_str) == Some("frame");
        print!(
            "{}",
            twin_noise_check(seed, n, draws, camera_frame)?.to_markdown()
        );
        return Ok(());
    }
    if args.get(2).map(String::as_str) == Some("terms") {
        let n: usize = args.get(3).map_or(Ok(15), |s| s.parse())?;
        println!(
            "| seed | N | terms off | predicted mean bound (mm) | coverage | predicted / achieved mean error | achieved mean error (mm) | misses outside a range / inside every range |"
        );
        println!("|---|---|---|---|---|---|---|---|");
        for term in ["none"].into_iter().chain(TWIN_TERMS).chain(["all"]) {
            let c = twin_term_check(seed, n, true, switches_without(term)?)?;
            let Some(p) = c.predicted else {
                println!(
                    "| {seed} | {n} | {term} | refused: {} |",
                    c.refused.unwrap_or_default()
                );
                continue;
            };
            let (outside, inside) = c
                .misses
                .as_ref()
                .map_or((0, 0), |m| (m.explained(), m.inside.misses));
            println!(
                "| {seed} | {n} | {term} | {:.4} | {:.0} % | {:.2} | {:.4} | {outside} / {inside} |",
                p.mean_bound_95_mm,
                100.0 * c.coverage,
                p.predicted_mean_error_mm / c.achieved_mean_error_mm,
                c.achieved_mean_error_mm
            );
        }
        return Ok(());
    }
    let check = flexcal::plan::twin_check::twin_plan_check(seed, &[15, 27, 50, 100], 27, 20)?;
    print!("{}", check.to_markdown());
    Ok(())
}
