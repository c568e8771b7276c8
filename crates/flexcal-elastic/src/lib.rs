//! # flexcal-elastic
//!
//! Elastic models of robots for flexcal: how far the tool centre point (TCP)
//! of a robot moves under a load, in any configuration, and which joint
//! stiffnesses explain measured deflections. A robot description
//! (flexcal-kinematics) plus an elastic description (nodes attached to robot
//! frames, beams with sections, joint springs, supports, masses) gives a
//! frame structure (flexcal-fem) placed by the forward model in configuration
//! q, assembled in the base frame and condensed onto the TCP.
//!
//! ```
//! use flexcal_elastic::description::ElasticDescription;
//! use flexcal_elastic::model::{ElasticData, ElasticModel, OwnWeight, tcp_condensation, tcp_deflection};
//! use flexcal_kinematics::{RobotDescription, actuated_from_joint_angles};
//! use nalgebra::Vector6;
//!
//! let robot = RobotDescription::builtin("ir663")?.build()?;
//! let model = ElasticModel::new(&robot, &ElasticDescription::builtin("ir663")?)?;
//! let mut data = ElasticData::new(&model)?; // one per thread
//! let xi = robot.nominal_params();
//! let gamma = model.nominal_gamma(); // Kar_12, Kr_12, Kar_18, Kr_18, Kr_33', Kr_99', Kr_1010'
//! let q = actuated_from_joint_angles(&robot, &[0.0, -0.5, 0.4, 0.8, 1.6, 0.0])?;
//! let tcp = tcp_condensation(&model, &mut data, &q, xi, &gamma)?; // C_eq, K_eq (27), (63)
//! let down = Vector6::new(0.0, 0.0, -1100.0, 0.0, 0.0, 0.0); // 1100 N dead weight [N; N.m]
//! let ds = tcp_deflection(&model, &mut data, &q, xi, &gamma, &down, OwnWeight::Excluded)?; // dS_E (28)
//! assert!(((tcp.c_eq * down) - ds).norm() < 1e-9 * ds.norm());
//! assert!(ds[2] < 0.0 && ds[2] > -5e-3); // a few millimetres down
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! ## Modules
//! - [`description`]: the elastic description (TOML, SI; node offsets in mm)
//!   and the built-in `ir663` of the paper's Figure 8.
//! - [`model`]: [`model::ElasticModel`] (validated, immutable),
//!   [`model::ElasticData`] (per-thread workspace) and the free functions
//!   [`model::tcp_condensation`], [`model::tcp_deflection`],
//!   [`model::tcp_deflection_log_derivatives`].
//! - [`campaign`]: deflection files (loaded and unloaded poses in flexcal's
//!   measurement CSV conventions) and the measured deflections.
//! - [`identify`]: stiffness identification in log space (differential
//!   evolution, then Levenberg-Marquardt) and the identifiability of Gamma by name.
//! - [`metrics`]: the per-load table of the paper's Table 5, for any
//!   elastic model (the fuzzy compliance model uses the same function).
//! - [`tcp`]: the elastic models seen from the TCP, as compensation
//!   evaluates them: the [`tcp::TcpDeflection`] trait (model shared by all
//!   threads, one workspace per thread), the FE beam model
//!   [`tcp::FeTcpModel`] and [`tcp::ConstantCompliance`].
//! - [`fuzzy_compliance`]: compliance components as Takagi-Sugeno models of
//!   joint coordinates, learnt jointly from deflections (equations (38), (70)).
//!
//! ## Equations (Marie, Courteille, Maurine 2013)
//! - Joint stiffness (17)-(18): diag(Ka, Kr, Kr, Kar, Krr, Krr) about the z
//!   axis of a robot frame; beams (16); rotation to base axes (19)-(20);
//!   assembly (21); supports (22), (60); `K_C dS_C = F_C` (23) -- all in
//!   flexcal-fem, fed with node positions from the forward model (42).
//! - Condensation onto the TCP (24)-(27), (62)-(63):
//!   `K_eq = K_EE - K_ER K_RR^-1 K_RE`, `F_eq = F_E - K_ER K_RR^-1 F_R`,
//!   `C_eq = K_eq^-1` (13), and the direct elastic model
//!   `dS_E = C_eq F_eq` (28), (64); own weight and point masses enter F_eq.
//! - Derivatives with respect to a stiffness k: `du/dk = -K^-1 (dK/dk) u`,
//!   exact (no finite differences); the identification works on ln k, so
//!   columns are `k du/dk`.
//! - Criterion (66)-(67): `C(Gamma) = 1/n_m sum_k |dP_meas - dP_model|^2`
//!   (positions; the least squares weights each coordinate by 1/sigma).
//! - Springs in series (68)-(69): `1/K_req = sum 1/K_i`. Serial springs
//!   give log-stiffness Jacobian columns `J_i = K_req^2 / K_i * dU/dK_req`,
//!   all parallel, with `J_i K_i` equal; parallel springs give `J_i / K_i`
//!   equal. [`identify::identify_stiffness`] finds such groups from the
//!   column-normalised Jacobian (structural rank) and reports the
//!   identifiable K_req by name instead of one arbitrary member of the
//!   infinite family of Table 3.
//!
//! ## The built-in IR-663 (`ir663`)
//! Nodes 0, 1, 2, 3, 3', 10, E, 8, 9, 9', 10' (node 0 clamped: a 60 x 60
//! K_C (61)); beams 0-1 (column), 2-3 (upper arm), 3'-10 and 10-E
//! (forearm; the wrist is rigid, so the beam runs straight to the TCP), 8-9
//! (crank), 9'-10' (coupler); joint springs 1-2, 1-8 (actuated: Kar and Kr
//! identified), 3-3', 9-9', 10-10' (passive: Kar = 0, Kr identified).
//! Values: Table 3 (design 1) read in N.mm/rad and N/mm (Kar_12 =
//! 1.72e6 N.m/rad); Ka = 1e12 N/m and Krr = 1e11 N.m/rad for the directions a
//! planar campaign cannot excite; link sections are steel boxes and tubes and
//! the wrist is a 120 kg mass at the TCP: plausible assumptions, documented in
//! [`description::ir663_sections`], not KUKA data.
//!
//! ## Performance
//! Placing (forward model), assembling, factoring and condensing the IR-663
//! model (60 DOF) onto the TCP, gravity F_eq included: 18.5 us per
//! configuration (goal 20 us; criterion, 2 shared cores,
//! `cargo bench -p flexcal-elastic --bench elastic`). The stiffness
//! identification places each configuration once and re-assembles only:
//! `flexcal identify stiffness` on the twin's 126 training deflections
//! (2 500 global-search evaluations, then Levenberg-Marquardt) takes about 3 s.
//!
//! ## Limitations
//! - Linear statics about the unloaded configuration (no geometric
//!   stiffness, no large displacements), as in the paper.
//! - Axial springs (e.g. actuator screws) are part of the structure but not
//!   of Gamma: flexcal-fem has no setter for a spring's stiffness yet. Beam
//!   section factors are not identifiable for the same reason.
//! - Only TCP positions enter the identification (the campaign files carry
//!   positions); orientations could be added as rows.
//! - A joint's radial stiffness is isotropic (Kr on both radial axes).
//! - The practical identifiability threshold (a factor-e change moving the
//!   fit by one standard deviation) is a convention, reported with the
//!   sensitivities so a user can judge.

#![deny(missing_docs)]

pub mod campaign;
pub mod description;
pub mod error;
pub mod fuzzy_compliance;
pub mod grid;
pub mod identify;
pub mod metrics;
pub mod model;
pub mod tcp;
pub mod workflow;

pub use error::{ElasticError, Result};
