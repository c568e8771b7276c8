//! Elasto-geometrical compensation of tool paths (reference paper, sections
//! 2.3 and 4).
//!
//! A robot under a process load does not reach the pose it is commanded to:
//! the tool lands at `S = f(q, xi) + h(q, F)` (equations (39)-(40)), the
//! geometric model plus the elastic deflection under the wrench `F`, and for a
//! forming process `F` itself depends on where the tool actually is. This
//! crate holds the pieces of compensation that know nothing of a particular
//! robot:
//!
//! * [`process`]: process models giving the wrench on the tool as a function
//!   of the tool position: a constant wrench, and the clamped cantilever beam
//!   of the paper's forming experiment (section 4) in small-deflection
//!   (Euler-Bernoulli, `F = 3 E I w / a^3`) and large-deflection (elastica
//!   with the load following the deformed beam, solved by Newton with the
//!   exact Jacobian of the discretised elastica) theory, with optional
//!   friction; a material table;
//! * [`path`]: target path files (CSV) and the export of commanded paths to a
//!   KUKA KRL program;
//! * [`compensation`]: the elasto-geometrical model `S = f(q, xi) (+) h(q, W)`
//!   with any elastic model seen from the TCP
//!   ([`compensation::TcpDeflection`] of flexcal-elastic: the FE beam model,
//!   the fuzzy compliance model), the actual pose with robot and process
//!   solved together, and the commanded poses (fake poses) that bring the
//!   deflected robot onto the target: fixed-point iteration, Newton fallback,
//!   per-point predicted uncompensated error and residual; whole paths are
//!   tracked point to point (prediction from the previous points, correction
//!   with a stored Jacobian), which makes a 10 000-point path a matter of
//!   tens of milliseconds with a fuzzy model; long paths run in parallel
//!   threads sharing one model, each with its own workspace.
//!
//! ```
//! use flexcal_compensate::process::{BeamTheory, CantileverBeam, ProcessModel, ToolState};
//! use nalgebra::Vector3;
//! let beam = CantileverBeam::reference(BeamTheory::LargeDeflection);
//! // The tool 25 mm down at 385 mm from the clamp is pushed back by about 1 kN.
//! let w = beam.wrench_on_tool(&ToolState::at(Vector3::new(0.385, 0.0, -0.025))).unwrap();
//! assert!(w[2] > 900.0 && w[2] < 1200.0);
//! ```
//!
//! # Limitations
//! * The cantilever is a single-contact model: the tool touches the top
//!   surface at one point; the beam is inextensible and elastic (no
//!   plasticity), loaded in the x-z plane of the part frame only.
//! * Compensation is static: it corrects poses, not dynamics (no tracking
//!   error, no vibration).
//! * The compensated command is searched near the inverse geometric model of
//!   the target, on the same assembly and wrist branch.

pub mod compensation;
pub mod export;
pub mod path;
pub mod process;
