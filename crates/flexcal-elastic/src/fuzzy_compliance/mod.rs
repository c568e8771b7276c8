//! Fuzzy compliance model of a robot: the components of the TCP compliance
//! matrix as zero-order Takagi-Sugeno models of chosen joint coordinates,
//! learnt from measured deflections under known loads (section 2.2.2 and
//! section 3.3.2 of the reference paper, S. Marie, E. Courteille,
//! P. Maurine, Mechanism and Machine Theory 69 (2013) 13-43).
//!
//! # Equations
//! - (38): `dS = C(q) F`: the TCP's elastic displacement is the compliance
//!   matrix of the configuration applied to the TCP wrench. Each modelled
//!   component `C_dw` (displacement axis `d`, wrench axis `w`) is one
//!   single-output fuzzy model ([`flexcal_fuzzy::FuzzyModel`], equations
//!   (33)-(37)) of the chosen inputs; components not modelled are zero.
//! - (70): in the vertical plane of the IR-663,
//!   `dx = C_xx(theta2, theta8) fx + C_xz fz`,
//!   `dz = C_zx fx + C_zz fz` ([`ComplianceComponent::plane_xz`]).
//!
//! A measured displacement is linear in the conclusions of every component
//! model, so all of them are fitted jointly by least squares
//! ([`flexcal_fuzzy::fit_joint_conclusions`]): a horizontal load informs
//! `C_xx` and `C_zx`, a vertical one `C_xz` and `C_zz`. The membership
//! functions are placed by Solis-Wets and the structure grown within a rule
//! budget, choosing by the error on a test set of configurations
//! ([`flexcal_fuzzy::search_structure`]); by default the four models share
//! one partition grid, as in the paper's Table 4 (4 x 3 = 12 rules).
//!
//! # Units
//! Inputs are SI (rad for angles, m for screw lengths and prismatic
//! joints); conclusions are SI (m/N for a force-to-translation component).
//! The fit itself works in mm and kN so that the conclusions are of order
//! one; [`FuzzyCompliance::rule_base_table`] prints degrees and mm/kN like
//! Table 4.
//!
//! # Example
//! ```
//! use flexcal_elastic::fuzzy_compliance::{
//!     ComplianceComponent, ComplianceFitParams, ComplianceSample, InputSpec, identify_compliance,
//! };
//! use nalgebra::{Vector3, Vector6};
//! // A synthetic plane robot whose compliance varies with two joint angles.
//! let c_xx = |a: f64, b: f64| 1.0e-6 * (1.0 + 0.3 * a + 0.2 * a * b);
//! let c_zz = |a: f64, b: f64| 0.8e-6 * (1.0 + 0.1 * b);
//! let mut samples = Vec::new();
//! for i in 0..8 {
//!     for j in 0..8 {
//!         let (a, b) = (-0.4 + 0.1 * i as f64, 0.5 + 0.08 * j as f64);
//!         for (fx, fz) in [(900.0, 0.0), (0.0, -900.0)] {
//!             samples.push(ComplianceSample {
//!                 pose_id: (8 * i + j) as u64,
//!                 inputs: vec![a, b],
//!                 wrench: Vector6::new(fx, 0.0, fz, 0.0, 0.0, 0.0),
//!                 deflection: Vector3::new(c_xx(a, b) * fx, 0.0, c_zz(a, b) * fz),
//!                 sigma: Vector3::zeros(),
//!             });
//!         }
//!     }
//! }
//! let inputs = vec![InputSpec::radians("theta2"), InputSpec::radians("theta8")];
//! let fit = identify_compliance(
//!     &inputs,
//!     &ComplianceComponent::plane_xz(),
//!     &samples,
//!     &ComplianceFitParams::default(),
//!     &mut |_| {},
//! )?;
//! let c = fit.compliance.compliance_matrix(&[0.05, 0.7])?;
//! assert!((c[(0, 0)] - c_xx(0.05, 0.7)).abs() < 1e-9);
//! assert!(c[(0, 2)].abs() < 1e-9);
//! # Ok::<(), flexcal_elastic::fuzzy_compliance::FuzzyComplianceError>(())
//! ```
//!
//! # Measured accuracy (seeded tests)
//! - A bilinear compliance (noise-free) is reproduced to rounding
//!   (1e-15 m/N) anywhere inside the training range
//!   (`tests/fuzzy_compliance.rs`).
//! - A smooth, non-multilinear compliance of 0.25 to 2 mm/kN with 30 um
//!   noise per deflection component, trained at 900 N on the 7 x 9 grid:
//!   the compliance is within 0.1 mm/kN of the truth and the RMS residual on
//!   300, 600 and 1100 N is within 1.2 times the noise floor.
//! - The twin's elastic campaign (`flexcal twin elastic --seed 7`, split
//!   seed 1, the paper's 90 / 36 protocol; `tests/cli_compliance.rs` in
//!   flexcal-cli): a shared 3 x 3 grid (the search stopped there within the
//!   12-rule budget); RMS of the in-plane residual norm 0.043, 0.042, 0.047,
//!   0.059 mm at 300, 600, 900, 1100 N, 0.048 mm overall, against a noise
//!   floor of 0.042 mm (21 um per coordinate: 1.14 times the floor); the
//!   parametric beam model identified on the same files gives 0.049, 0.064,
//!   0.093, 0.105 mm, 0.081 mm overall, in the same plane.
//!
//! # Speed
//! `cargo bench -p flexcal-elastic --bench fuzzy_compliance` (shared
//! 2-core machine): the four components identified jointly from 126
//! deflections (63 configurations x 2 loads, search up to 12 rules) in
//! 50 ms; the displacement of one configuration (four 2-input models) in
//! 170 ns.
//!
//! # Limitations
//! - Zero-order models: the compliance is piecewise multilinear in the
//!   inputs and constant beyond the outermost modal values (inputs are
//!   clamped); a configuration outside the training range gets the
//!   compliance of the nearest edge.
//! - Only translational displacement axes can be fitted (the measurement
//!   files hold TCP positions); rotational components can be held by a
//!   model built by hand but not identified.
//! - Linearity in the load is assumed (equation (70)); a nonlinear
//!   load-deflection behaviour shows up as residuals growing with load.
//! - The test set chooses the structure, so its error is optimistic;
//!   validate on loads that were not used (the paper's protocol).

mod components;
mod error;
mod file;
mod identify;
mod inputs;
mod model;
mod robot;
mod samples;

pub use components::{Axis, ComplianceComponent, InputSpec, InputUnit};
pub use error::{FuzzyComplianceError, Result};
pub use file::COMPLIANCE_FORMAT;
pub use identify::{
    ComplianceFitParams, ComplianceFitReport, FittedCompliance, identify_compliance,
};
pub use inputs::{InputSource, RobotInputs};
pub use model::FuzzyCompliance;
pub use robot::{RobotFuzzyCompliance, RobotFuzzyWorkspace};
pub use samples::{ComplianceSample, compliance_samples, noise_floor_rms};
