//! The twin's truth: every way the virtual IR-663 and its measurement
//! system differ from the models flexcal identifies, one module per term,
//! each with its magnitude, its source and a switch ([`TruthSwitches`]).
//!
//! | term | module | magnitude (default) | source |
//! |---|---|---|---|
//! | geometric errors | [`geometry`] | Appendix C, up to 0.78 mm / 0.04 deg | the paper |
//! | gravity | [`structure`], [`mechanics`], [`robot`] | steel links, 75 + 100 + 20 kg | the twin's own frame model (Timoshenko beams, its own solver) |
//! | drive non-linearity | [`drive`] | lost motion 1 arcmin with 1 arcmin hysteresis, K3/K1 ~ 2.5 | RV / strain-wave catalogues |
//! | transmission errors | [`transmission`] | 0.35 + 0.15 arcmin harmonics | reducer catalogues |
//! | measurement frame | [`measurement`] | 3.5 m, 155 deg away | the paper's registration step |
//! | measurement noise | [`measurement`] | 21.4 um per axis (LED errors correlated; 12.3 um if independent, not used), 0.017 / 0.012 deg | K600-10, 37 um |
//! | temperature drift (off) | [`temperature`] | 2 K x 11.7e-6 /K | steel handbook |
//! | bar modulus, thickness, clamp, tool tip, friction, payload | [`process`] | 70 GPa, +1 %, 1 t, 10 mm, mu 0.15, +0.5 % | Eurocode 9, EN 485-4, clamped-beam tests, tool sizes, friction tables, scale |
//!
//! The campaigns (the crate's `geometric`, `elastic` and `forming`
//! modules) use the same [`TwinRobot`] and [`Photogrammetry`], and publish
//! [`TwinTerms`] with their truth files.
//!
//! No term calls a function or reads a constant of the crates whose
//! models the twin tests (`flexcal_elastic`, `flexcal_compensate`,
//! `flexcal_calib`): the twin uses only the nominal geometry
//! (`flexcal_kinematics`) and the measurement and path file formats
//! (the test `the_twin_shares_no_model_code` lists every such import).

pub mod drive;
pub mod error;
pub mod geometry;
pub mod measurement;
pub mod mechanics;
pub mod process;
pub mod robot;
pub mod structure;
pub mod temperature;
pub mod terms;
pub mod transmission;

pub use error::TruthError;
pub use measurement::Photogrammetry;
pub use process::FormingTruth;
pub use robot::{TwinPose, TwinRobot, TwinWorkspace};
pub use terms::{TERM_NAMES, TruthSwitches, TwinTerm, TwinTerms};

/// Every term of the twin, with its switch: the robot's, the measurement
/// system's and the forming cell's.
pub fn twin_terms(robot: &TwinRobot, camera: &Photogrammetry, forming: &FormingTruth) -> TwinTerms {
    let s = robot.switches;
    let mut terms = robot.terms();
    terms.push(camera.frame_term(s.measurement_frame));
    terms.push(camera.noise_term(s.measurement_noise));
    terms.extend(forming.terms(&s));
    TwinTerms { terms }
}
