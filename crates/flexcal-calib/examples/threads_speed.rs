//! One identification on one thread and on two
//! ([`CalibrationOptions::threads`]), alternately, for the elasto-geometric
//! cases of the calibration benchmark (`benches/calib.rs`): the two-armed
//! robot (300 poses, two markers), the compliant torso (400 poses) and, when
//! the IPA UR10 data is present, series C (2 773 poses). Per call: the wall
//! time, the process's CPU time (every thread) and the calling thread's CPU
//! time (the scheduler's run times, `/proc/.../schedstat`, Linux), which
//! leaves out the other thread's share of the evaluations. With
//! a free core for the second thread the wall time comes close to the
//! calling thread's CPU time; on a machine busier than its cores only the
//! CPU times compare. The compliant torso also with the equilibrium
//! deflection (a tenth of the calls). Fails unless both counts identify the same
//! parameters to the bit.
//!
//! `cargo run --release -p flexcal-calib --example threads_speed [-- REPEATS]`

use std::path::PathBuf;
use std::time::Instant;

use flexcal_calib::{CalibrationOptions, GravityCompliance, MeasurementSet, calibrate};
use flexcal_kinematics::Model;

#[path = "support/cpu_time.rs"]
mod cpu_time;
#[path = "support/series_c.rs"]
mod series_c;
#[path = "../benches/support/target_set.rs"]
mod target_set;
use cpu_time::{load_average, process_run_seconds, thread_run_seconds};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let repeats: usize = std::env::args()
        .nth(1)
        .map(|s| s.parse())
        .transpose()?
        .unwrap_or(20)
        .max(1);
    let data = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    // The benchmark's several-target cases.
    for (robot, poses, compliance, noise) in [
        ("two_arms", 300, 0.0, 20e-6),
        ("compliant_torso", 400, 250e-6, 0.5e-3),
    ] {
        let gravity =
            GravityCompliance::from_toml_file(&data.join(format!("{robot}_masses.toml")))?;
        let (model, set) = target_set::target_set(robot, &gravity, poses, compliance, noise);
        let options = CalibrationOptions {
            gravity: Some(gravity),
            ..CalibrationOptions::default()
        };
        compare(
            &format!("{robot}_{poses}_poses"),
            &model,
            &set,
            &options,
            repeats,
        )?;
        if compliance > 0.0 {
            // The deflection as the static equilibrium, fewer calls.
            let mut equilibrium = options.clone();
            if let Some(gravity) = equilibrium.gravity.as_mut() {
                gravity.deflection = flexcal_calib::Deflection::equilibrium();
            }
            let case = format!("{robot}_{poses}_poses_equilibrium");
            compare(&case, &model, &set, &equilibrium, repeats.div_ceil(10))?;
        }
    }
    let Some((model, set, options)) = series_c::series_c("series C skipped")? else {
        return Ok(());
    };
    compare("ur10_series_c_2773_poses", &model, &set, &options, repeats)
}

/// `repeats` identifications of `set` under `options` on one thread and on
/// two, alternately: wall, process CPU and calling thread's CPU time per
/// call (ms).
fn compare(
    case: &str,
    model: &Model,
    set: &MeasurementSet,
    options: &CalibrationOptions,
    repeats: usize,
) -> Result<(), Box<dyn std::error::Error>> {
    let counts = [1, 2];
    // Per thread count: wall, process CPU, calling thread's CPU (s).
    let mut totals = [[0.0_f64; 3]; 2];
    let mut results: [Option<Vec<f64>>; 2] = [None, None];
    let load = load_average();
    for _ in 0..repeats {
        for (c, &threads) in counts.iter().enumerate() {
            let options = CalibrationOptions {
                threads: Some(threads),
                ..options.clone()
            };
            let (cpu, own, wall) = (process_run_seconds(), thread_run_seconds(), Instant::now());
            let calibration = calibrate(model, set, &options)?;
            totals[c][0] += wall.elapsed().as_secs_f64();
            totals[c][1] += process_run_seconds()
                .zip(cpu)
                .map_or(f64::NAN, |(b, a)| b - a);
            totals[c][2] += thread_run_seconds()
                .zip(own)
                .map_or(f64::NAN, |(b, a)| b - a);
            results[c] = Some(calibration.xi);
        }
    }
    if results[0] != results[1] {
        return Err(format!("{case}: one and two threads identified different parameters").into());
    }
    for (c, threads) in counts.iter().enumerate() {
        let [wall, cpu, own] = totals[c].map(|t| 1e3 * t / repeats as f64);
        println!(
            "{case}, {threads} thread(s): wall {wall:.1} ms, process CPU {cpu:.1} ms, calling thread's CPU {own:.1} ms per call ({repeats} calls; load {load} -> {})",
            load_average()
        );
    }
    Ok(())
}
