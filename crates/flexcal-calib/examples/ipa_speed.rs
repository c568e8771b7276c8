//! CPU time, beside wall time and the load average, of the two slow calls
//! of the calibration benchmark (`benches/calib.rs`) on IPA series C
//! (2 773 poses, positions only): the identification of the richer model
//! (joint compliances under gravity and the payload, the non-linear joint
//! law, cyclic errors) and its model selection by 5-fold cross-validation.
//! On a shared machine criterion's wall time grows with the other jobs;
//! the process's CPU time (user + system, every thread, from
//! `/proc/self/stat`, Linux) does much less. Prints what was identified and
//! chosen, so that a faster build can be checked to give the same answer.
//!
//! `cargo run --release -p flexcal-calib --example ipa_speed [-- calibrate|select [REPEATS]]`

use std::time::Instant;

use flexcal_calib::{JointLaw, JointTerms, SelectionOptions, calibrate, select_model};

#[path = "support/cpu_time.rs"]
mod cpu_time;
#[path = "support/series_c.rs"]
mod series_c;
use cpu_time::{cpu_seconds, load_average};
use series_c::series_c;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let Some((model, set, mut options)) = series_c("nothing to do")? else {
        return Ok(());
    };
    // The benchmark's richer model.
    options.joint_terms = JointTerms {
        law: Some(JointLaw::default()),
        cyclic: true,
    };
    let what = std::env::args().nth(1).unwrap_or_default();
    let repeats: usize = std::env::args()
        .nth(2)
        .map(|s| s.parse())
        .transpose()?
        .unwrap_or(5)
        .max(1);
    let per_call = |cpu: Option<f64>, calls: usize| {
        cpu.map_or("unknown".into(), |c| format!("{:.3} s", c / calls as f64))
    };
    if what != "select" {
        let (cpu, wall) = (cpu_seconds(), Instant::now());
        let mut last = None;
        for _ in 0..repeats {
            last = Some(calibrate(&model, &set, &options)?);
        }
        let elapsed = wall.elapsed().as_secs_f64() / repeats as f64;
        let cpu = cpu_seconds().zip(cpu).map(|(b, a)| b - a);
        let calibration = last.expect("at least one call");
        println!(
            "identification, law and cyclic: wall {elapsed:.3} s, CPU {} per call ({repeats} calls; load {}); {} solver iterations in all, {} unknowns identified, cost {:.6e}",
            per_call(cpu, repeats),
            load_average(),
            calibration.cost_history.len(),
            calibration.rank(),
            calibration.solve.cost
        );
    }
    if what != "calibrate" {
        let (cpu, wall) = (cpu_seconds(), Instant::now());
        let (report, _) = select_model(&model, &set, &options, &SelectionOptions::default())?;
        let elapsed = wall.elapsed().as_secs_f64();
        let cpu = cpu_seconds().zip(cpu).map(|(b, a)| b - a);
        println!(
            "cross-validated selection: wall {elapsed:.2} s, CPU {} (load {}); {} candidates",
            per_call(cpu, 1),
            load_average(),
            report.candidates.len()
        );
        for line in report.lines() {
            println!("{line}");
        }
    }
    Ok(())
}
