//! flexcal-fem: static 3D frame finite elements, with condensation onto a node.
//!
//! This crate computes how a frame structure deflects under load and what
//! equivalent stiffness it offers at one node. It knows nothing of robots:
//! `flexcal-elastic` builds a robot's elastic model on top of it (a structure
//! whose nodes move with the joint configuration, re-assembled and condensed
//! onto the TCP for every configuration), following section 2.2.1 of
//! Marie, Courteille, Maurine (2013), "Elasto-geometrical modeling and
//! calibration of robot manipulators", Mechanism and Machine Theory 69.
//!
//! Elements:
//! * 3D beams, 12 x 12: Euler-Bernoulli, or Timoshenko in a bending plane
//!   whose shear area is given; local x from node i to node j,
//!   y = unit(vecxz x x), z = x x y; `Iy` about local y, `Iz` about local z
//!   (`Iz` governs deflection along local y); optional end releases condensed
//!   out at element level; own weight as consistent equivalent nodal loads.
//! * joints: diag(Ka, Kr, Kr, Kar, Krr, Krr) in a frame whose x is the joint
//!   axis, acting on the relative motion of two (normally coincident) nodes;
//! * axial springs along the line between two nodes;
//! * supports (fixed degrees of freedom) and nodal wrenches.
//!
//! Two levels of API:
//! * file level: [`StructureFile`] (TOML or JSON, see [`file`](mod@file)) ->
//!   [`FemModel`] -> [`FemModel::solve`] / [`FemModel::condense`], used by
//!   `flexcal fem solve` and `flexcal fem condense`;
//! * numeric level: a [`Structure`] with node indices whose nodes, joint
//!   frames and stiffness values can be changed, a [`Factorization`] built
//!   once per topology (the per-thread workspace) and refilled by
//!   [`assemble_and_factor`] without allocation; it solves further
//!   right-hand sides and gives K_eq, C_eq and F_eq. Element matrices and
//!   their DOF maps come from [`element_matrix`], joint-stiffness derivatives
//!   from [`joint_stiffness_derivative`] and [`joint_stiffness_sensitivity`].
//!
//! ```
//! use flexcal_fem::{Beam, LoadCase, Section, SolverOptions, Structure};
//! use flexcal_fem::{Factorization, assemble_and_factor, load_vector};
//! use nalgebra::{Vector3, Vector6};
//!
//! // A 1 m steel cantilever along x, clamped at "root", loaded at "tip".
//! let mut s = Structure::new();
//! let root = s.add_node("root", Vector3::zeros())?;
//! let tip = s.add_node("tip", Vector3::new(1.0, 0.0, 0.0))?;
//! s.set_support(root, [true; 6])?;
//! let section = Section {
//!     youngs_modulus: 210e9, shear_modulus: 81e9, area: 1e-3,
//!     iy: 2e-7, iz: 1e-7, torsion_constant: 3e-7,
//!     shear_area_y: None, shear_area_z: None,
//! };
//! s.add_beam(Beam { name: "b".into(), i: root, j: tip, section,
//!     vecxz: Vector3::z(), releases: [false; 12], mass_per_length: 0.0 })?;
//!
//! let mut fact = Factorization::new(&s, &SolverOptions::condensing_onto(tip))?;
//! assemble_and_factor(&s, &mut fact)?;
//! let mut case = LoadCase::new("tip load");
//! case.nodal_loads.push((tip, Vector6::new(0.0, -100.0, 0.0, 0.0, 0.0, 0.0)));
//! let u = fact.solve(&load_vector(&s, &case)?)?;
//! let expected = -100.0 * 1.0 / (3.0 * 210e9 * 1e-7); // P L^3 / (3 E Iz)
//! assert!((u[6 + 1] - expected).abs() < 1e-12);
//! // The condensed compliance gives the same tip deflection (13).
//! let c_eq = fact.c_eq()?;
//! assert!((c_eq[(1, 1)] * -100.0 - expected).abs() < 1e-12);
//! # Ok::<(), flexcal_fem::FemError>(())
//! ```
//!
//! # Equations (numbers of the reference paper)
//! * (14)-(15): nodal wrench `[f; m]` and displacement `[dP; dPhi]`, global
//!   degrees of freedom `[ux, uy, uz, rx, ry, rz]`.
//! * (16): 12 x 12 beam stiffness in local axes (the standard 3D frame
//!   element; Timoshenko shear parameter phi = 12 E I / (G Av L^2)).
//! * (17)-(18): joint stiffness `[[D, -D], [-D, D]]`, D = diag(Ka, Kr, Kr,
//!   Kar, Krr, Krr) in the joint frame.
//! * (19)-(20): rotation to global axes, `K = T^T K_local T`,
//!   `T = blockdiag(A, A, A, A)`.
//! * (21): assembly of the global stiffness K_G.
//! * (22), (60): supports remove the fixed rows and columns, giving K_C.
//! * (23): `K_C dS_C = F_C`, solved by Cholesky.
//! * (24)-(27), (62)-(63): condensation onto a node,
//!   `K_eq = K_EE - K_ER K_RR^{-1} K_RE`, `F_eq = F_E - K_ER K_RR^{-1} F_R`,
//!   by elimination (never an explicit inverse); (13): `C_eq = K_eq^{-1}`,
//!   by solving with the Cholesky factor of K_eq.
//! * Own weight: uniform load w = m g, equivalent loads w L / 2 and
//!   w L^2 / 12 (fixed-end forces, exact for both beam theories).
//!
//! # Limitations
//! * Linear statics only: small displacements, no geometric stiffness, no
//!   dynamics, no thermal loads, no distributed loads other than own weight,
//!   no loads along an element other than at nodes.
//! * Sections are uniform along a beam; no warping torsion, no shear centre
//!   offset, no rigid end zones.
//! * Supports fix degrees of freedom in global axes only (no inclined
//!   supports, no prescribed non-zero displacements).
//! * A joint between non-coincident nodes is a zero-length spring at their
//!   midpoint with rigid offsets; a beam is the better model for a real
//!   distance.
//! * The solver is a profile (skyline) Cholesky after a reverse
//!   Cuthill-McKee node ordering: excellent for chains and frames of a few
//!   thousand DOFs, not meant for large 3D solids. Singularity is detected by
//!   a pivot test (see [`SolverOptions::pivot_tolerance`]); a nearly singular
//!   but accepted structure gives accurate results only to about
//!   `1e-16 * condition number`.

#![deny(missing_docs)]

pub mod element;
pub mod error;
pub mod file;
pub mod solve;
pub mod structure;

pub use element::{
    ElementMatrix, Matrix12, Vector12, beam_local_stiffness, element_matrix,
    joint_stiffness_derivative,
};
pub use error::{Dof, FemError, Result};
pub use file::{
    CaseDisplacements, Condensation, FemModel, StructureFile, condensation_json, condensation_text,
    displacements_json, displacements_text,
};
pub use solve::{
    Factorization, SolverOptions, assemble_and_factor, global_stiffness_dense,
    joint_stiffness_sensitivity, load_vector, load_vector_into, reactions, solve_load_case,
};
pub use structure::{Beam, ElementId, Joint, LoadCase, NodeId, Section, Spring, Structure};
