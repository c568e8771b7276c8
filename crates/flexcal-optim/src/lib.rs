//! Robot-agnostic numerics of flexcal: nonlinear least squares, identifiability,
//! observability and derivative-free global search.
//!
//! flexcal identifies a robot's geometric errors and stiffness from measurements.
//! Both identifications are least-squares problems in a few tens of parameters and
//! thousands of residual rows; this crate solves them and says how well the data
//! determine each parameter. It knows nothing of robots: the calibration crates
//! implement [`Residuals`] and [`Jacobian`] for their models.
//!
//! - [`GaussNewton`] and [`LevenbergMarquardt`]: each step is solved by
//!   column-pivoted QR (faer, sequential) of the weighted, column-scaled Jacobian;
//!   columns beyond the numerical rank are not updated; the [`SolveReport`] gives the
//!   termination reason, cost history, rank, singular values, condition number,
//!   covariance and standard errors.
//! - [`analyze_identifiability`]: numerical rank, base set (with priorities), the
//!   linear combinations the identified parameters stand for, and why each
//!   non-identifiable parameter is so.
//! - [`observability_indices`] and [`select_poses`]: indices O1-O5 and a greedy +
//!   exchange choice of measurement poses.
//! - [`DifferentialEvolution`]: seeded global search for initial values.
//!
//! # Example
//! ```
//! use faer::MatMut;
//! use flexcal_optim::{Jacobian, LevenbergMarquardt, ProblemError, ProblemSetup, Residuals};
//!
//! /// Distances from an unknown point `p` (m) to three known beacons.
//! struct Trilateration { beacons: [[f64; 2]; 3], ranges: [f64; 3] }
//!
//! impl Residuals for Trilateration {
//!     fn n_residuals(&self) -> usize { 3 }
//!     fn n_params(&self) -> usize { 2 }
//!     fn residuals(&self, p: &[f64], out: &mut [f64]) -> Result<(), ProblemError> {
//!         for k in 0..3 {
//!             let [bx, by] = self.beacons[k];
//!             out[k] = ((p[0] - bx).hypot(p[1] - by)) - self.ranges[k];
//!         }
//!         Ok(())
//!     }
//!     fn parameter_name(&self, j: usize) -> String { ["x", "y"][j].into() }
//! }
//!
//! impl Jacobian for Trilateration {
//!     fn jacobian(&self, p: &[f64], mut out: MatMut<'_, f64>) -> Result<(), ProblemError> {
//!         for k in 0..3 {
//!             let [bx, by] = self.beacons[k];
//!             let d = (p[0] - bx).hypot(p[1] - by);
//!             out[(k, 0)] = (p[0] - bx) / d;
//!             out[(k, 1)] = (p[1] - by) / d;
//!         }
//!         Ok(())
//!     }
//! }
//!
//! let beacons = [[0.0, 0.0], [2.0, 0.0], [0.0, 2.0]];
//! let truth = [0.7_f64, 1.1_f64];
//! let ranges = beacons.map(|[bx, by]| (truth[0] - bx).hypot(truth[1] - by));
//! let problem = Trilateration { beacons, ranges };
//! let report = LevenbergMarquardt::params()
//!     .check()?
//!     .solve(&problem, &[1.0, 1.0], &ProblemSetup::default(), &mut ())?;
//! assert!(report.termination.is_converged());
//! assert!((report.x[0] - 0.7).abs() < 1e-9 && (report.x[1] - 1.1).abs() < 1e-9);
//! println!("{:?} after {} iterations, rank {} of {}, cond {:.2e}",
//!          report.termination, report.iterations, report.rank, report.n_free,
//!          report.condition_number);
//! # Ok::<(), flexcal_optim::OptimError>(())
//! ```
//!
//! # Equations
//! Numbers in parentheses are those of the reference paper (Marie, Courteille,
//! Maurine, Mechanism and Machine Theory 69, 2013).
//! - Linear error model and global Jacobian, (7)-(10): `dS^G = J^G dxi`. The
//!   calibration crates build `J^G`; here it is the Jacobian of [`Jacobian`].
//! - Least-squares identification of the base parameters, (11): `dxi^B = (J^B)^+ dS^B`.
//!   The pseudo-inverse is never formed: with `W J S^-1 P = Q R` (row weights `W`,
//!   column scales `S`, pivoting `P`) and numerical rank `r` (the leading `|R_kk|` above
//!   `rank_tolerance * |R_00|`), the step is the basic solution
//!   `dz_B = -R11^-1 (Q^T W r)_1..r`, `dz_N = 0`, `dx = S^-1 P dz`. A column once
//!   found beyond the rank stays fixed for the rest of the solve, so that of two
//!   collinear parameters the same one is always updated. For tall Jacobians the
//!   factorisation is done in two stages (blocked QR `Q0 R0`, then pivoted QR of
//!   `R0`), which gives the same pivots at a fraction of the cost.
//! - Iterative re-linearisation, (12) and section 2.1.5: [`GaussNewton`] repeats that
//!   step, re-evaluating the Jacobian at each iterate (with step halving when the full
//!   step raises the cost). [`LevenbergMarquardt`] instead solves
//!   `min ||[R11; sqrt(lambda) I] dz_B + [(Q^T W r)_1..r; 0]||` by a small QR, with
//!   Nielsen's update `lambda <- lambda max(1/3, 1 - (2 rho - 1)^3)` on success and
//!   `lambda <- lambda nu, nu <- 2 nu` on failure, `rho` being actual over predicted
//!   decrease.
//! - Covariance: `Cov(x_B) = sigma^2 S_B^-1 R11^-1 R11^-T S_B^-1`, from triangular
//!   solves, with `sigma^2 = SSR / (m - r)` (relative weights) or 1 (absolute weights).
//! - Linear combinations, (C.1): `xi_B^id = xi_B + K xi_N`, `K = R11^-1 R12` in
//!   physical units ([`IdentifiabilityReport::combination_matrix`]), following Khalil &
//!   Gautier (1991).
//! - Stiffness identification, criterion (67): `C(Gamma) = 1/n_m sum_k (E_k)^2` is
//!   `2/n_m` times the cost minimised here, and [`DifferentialEvolution`] replaces the
//!   paper's genetic algorithm for finding a starting point (section 3.3.1).
//! - Observability indices O1-O5 ([`ObservabilityIndices`]): Borm & Menq (1991),
//!   Driels & Pathre (1990), Nahvi, Hollerbach & Hayward (1994), Nahvi & Hollerbach
//!   (1996), Sun & Hollerbach (2008).
//!
//! # References
//! - J. J. Moré, The Levenberg-Marquardt algorithm: implementation and theory,
//!   Numerical Analysis, Lecture Notes in Mathematics 630 (1978) 105-116.
//! - H. B. Nielsen, Damping parameter in Marquardt's method, IMM-REP-1999-05, DTU (1999).
//! - W. Khalil, M. Gautier, C. Enguehard, Identifiable parameters and optimum
//!   configurations for robot calibration, Robotica 9 (1991) 63-70.
//! - Y. Sun, J. M. Hollerbach, Observability index selection for robot calibration,
//!   ICRA 2008, 831-836.
//! - R. Storn, K. Price, Differential evolution, J. Global Optimization 11 (1997) 341-359.
//!
//! # Limitations
//! - Dense only: the Jacobian is stored as an `m x n` matrix (8 300 x 40 takes 2.7 MB;
//!   two such buffers live during a solve). No sparse or matrix-free variant.
//! - No bounds on parameters in the least-squares solvers (use [`ProblemSetup::fixed`]
//!   or reparametrise); [`DifferentialEvolution`] is the only bounded method.
//! - The rank decision is as good as the tolerance: with finite-difference Jacobians
//!   raise [`SolverOptions::rank_tolerance`] to about `1e-6`. Near-collinear (not
//!   exactly collinear) columns give combinations that hold only approximately.
//! - The covariance is the linearised one at the solution; it ignores model error and
//!   is meaningless when the fit is poor. Parameters beyond the rank get none.
//! - Pose selection costs one SVD per candidate swap; pools of a few hundred poses are
//!   fine, tens of thousands are not. The selected set is a local optimum.
//! - Everything runs on one thread; evaluation of the objective in
//!   [`DifferentialEvolution`] is sequential.

mod cancel;
pub mod differential_evolution;
pub mod error;
pub mod identifiability;
pub mod least_squares;
pub mod observability;
pub mod problem;
mod qr;
pub mod solis_wets;

pub use cancel::CancelToken;
pub use differential_evolution::*;
pub use error::{OptimError, ProblemError};
pub use identifiability::*;
pub use least_squares::*;
pub use observability::*;
pub use problem::*;
