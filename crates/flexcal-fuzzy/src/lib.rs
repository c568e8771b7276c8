//! flexcal-fuzzy: zero-order Takagi-Sugeno fuzzy models with strong
//! triangular partitions, learned from data.
//!
//! flexcal uses them to model the compliance of a robot from measurements
//! when no parametric stiffness model is wanted (section 2.2.2 of the
//! reference paper, S. Marie, E. Courteille, P. Maurine, Mechanism and
//! Machine Theory 69 (2013) 13-43). The crate itself knows nothing of
//! robots: it maps `n` named real inputs to one real output.
//!
//! # Example
//! ```
//! use flexcal_fuzzy::{Dataset, FuzzyModel, FuzzyParams};
//! // y = a * b sampled on a 6 x 6 grid; a multilinear function is exact.
//! let (mut a, mut b, mut y) = (vec![], vec![], vec![]);
//! for i in 0..6 {
//!     for j in 0..6 {
//!         a.push(i as f64);
//!         b.push(j as f64 * 0.5);
//!         y.push(i as f64 * j as f64 * 0.5);
//!     }
//! }
//! let data = Dataset::new(vec!["a".into(), "b".into()], "y".into(), &[a, b], y)?;
//! let (train, test) = data.split_random(0.25, 42)?;
//! let fit = FuzzyParams::default().fit(&train, &test, &mut |_progress| {})?;
//! assert!(fit.report.test.max_abs < 1e-3);
//! let y = fit.model.evaluate(&[2.5, 1.25])?;
//! assert!((y - 3.125).abs() < 1e-3);
//! let text = fit.model.to_toml_string();
//! assert_eq!(FuzzyModel::from_toml_str(&text, "inline")?, fit.model);
//! # Ok::<(), flexcal_fuzzy::FuzzyError>(())
//! ```
//!
//! # The model (equations of the reference paper)
//! - Strong partition of input `x_j` (33): `sum_k mu_{A_j^k}(x_j) = 1`,
//!   triangular membership functions defined by their modal values
//!   `c_{j,1} < ... < c_{j,m_j}` (34) ([`Partition`]).
//! - Rules on the full grid (35): `if x_1 is A_1^{k_1} and ... then y = b^i`,
//!   numbered with the last input varying fastest, as in Table 4
//!   ([`FuzzyStructure`]).
//! - Firing strength by the product (37): `alpha_i(x) = prod_j mu(x_j)`
//!   ([`FuzzyStructure::activations`]).
//! - Output as weighted average (36):
//!   `y = sum_i alpha_i b^i / sum_i alpha_i` ([`FuzzyModel::evaluate`]).
//!   With strong partitions and the product the strengths sum to one and
//!   (36) is the multilinear interpolation of the conclusions over the grid
//!   of modal values: it is evaluated that way, touching the `2^n` rules of
//!   the cell holding `x`, not all `N`.
//! - Several outputs observed through linear combinations, as the
//!   compliance `d = C(theta) F` of (38) and (70): one model per output,
//!   fitted jointly ([`FuzzyParams::fit_joint`], [`fit_joint_conclusions`],
//!   or a caller's own system built from [`RuleActivations`] with
//!   [`NormalEquations`]).
//!
//! # Learning (section 2.2.2, steps i-iii)
//! 1. Start with `m_j = 2` evenly spaced membership functions per input
//!    spanning the training range; conclusions initialised by rapid
//!    prototyping, each the membership-weighted mean of the outputs its
//!    rule covers ([`rapid_prototyping`]).
//! 2. Conclusions: the output is linear in them, so they are solved
//!    exactly by least squares, ridge-regularised towards the
//!    rapid-prototyping values (relative weight [`FuzzyParams::ridge`],
//!    default 1e-6) so that rules with little data stay sensible. The
//!    paper's gradient descent is available
//!    ([`ConclusionMethod::GradientDescent`]).
//! 3. Interior modal values placed by Solis-Wets random search
//!    ([`flexcal_optim::solis_wets`]) minimising the training RMSE, kept
//!    ordered with a minimum gap (default 2 % of the input's range), the
//!    outermost ones fixed at the training range.
//! 4. Structure growth: each input in turn receives one more membership
//!    function (splitting its widest interval, then placement again); the
//!    one giving the lowest test RMSE is kept; growth stops when the test
//!    error stops improving or the rule budget is reached
//!    ([`search_structure`], generic over a caller's fitting closure).
//!
//! Parameters ([`FuzzyParams`], [`StructureSearchParams`]):
//!
//! | setting | default | meaning |
//! |---|---|---|
//! | `search.max_rules` | 64 | rule budget per model (capped by the training samples) |
//! | `search.min_gap_fraction` | 0.02 | minimum gap between modal values / input range |
//! | `search.placement` | 200 evaluations, step 0.2 | Solis-Wets settings and seed |
//! | `search.patience` | 1 | growth steps without improvement before stopping |
//! | `search.min_relative_improvement` | 1e-3 | what counts as an improvement |
//! | `ridge` | 1e-6 | relative pull of conclusions towards their prior |
//! | `conclusions` | least squares | or gradient descent |
//!
//! # Measured accuracy (tests in `tests/learning.rs`, seeded)
//! | function | data | structure found | test RMSE |
//! |---|---|---|---|
//! | multilinear, 2 and 3 inputs | 60 / 30 samples | 2 x 2 (x 2) | < 1e-10 (ridge 0) |
//! | 2-D sinc `sin(x)/x sin(y)/y` on [-10, 10]^2 | 600 / 200 random | 7 x 7 | 0.017 (max 0.09) |
//! | Mackey-Glass (tau 17), x(t+6) from 4 lags | 500 / 200 | 4 x 3 x 3 x 2 | 0.0063 (output std 0.23) |
//! | joint: two models seen through `f1 c1 + f2 c2` | 600 / 200 rows | 13 x 4, 5 x 4 | 7e-4; models within 3.3e-3 |
//!
//! Evaluation speed is measured by `cargo bench -p flexcal-fuzzy` (a
//! 4 x 3 model, batch evaluation).
//!
//! # Files
//! [`FuzzyModel::write`] / [`FuzzyModel::read`] use a small TOML format
//! (input names and modal values, output name, conclusions);
//! [`FuzzyModel::write_fis`] writes the `.fis` text format of classic fuzzy
//! logic toolboxes (`sugeno`, `prod`, `wtaver`, `trimf` inputs, `constant`
//! outputs), which [`FuzzyModel::from_fis_str`] reads back.
//!
//! # Limitations
//! - Inputs beyond the outermost modal values are clamped to them: the
//!   model extrapolates as a constant, never linearly. A `.fis` toolbox may
//!   not clamp; give it inputs inside the ranges.
//! - Zero-order models with full grids only: the number of rules grows as
//!   the product of the `m_j`, so more than 4 or 5 inputs is impractical;
//!   at most [`MAX_INPUTS`] inputs.
//! - The structure search is greedy and the placement a local random
//!   search: results depend on the seed and are not a global optimum. The
//!   test set chooses the structure, so its error is optimistic; keep a
//!   third set for an unbiased figure.
//! - Conclusions are solved through normal equations (Cholesky): adequate
//!   for the well-conditioned interpolation bases met here (the report
//!   gives a lower bound of the condition number), not for nearly
//!   collinear designs, where a QR solve would be better.

#![deny(missing_docs)]

mod data;
mod error;
mod files;
mod learn;
mod model;
mod partition;

pub use data::Dataset;
pub use error::{FuzzyError, PartitionError};
pub use files::MODEL_FORMAT;
pub use learn::{
    ConclusionMethod, ConclusionReport, FitReport, FuzzyFit, FuzzyParams, GrowthStep,
    GrowthTermination, JointFit, LinearCombinationSet, NormalEquations, SearchPhase,
    SearchProgress, StructureScore, StructureSearchParams, StructureSearchReport, fit_conclusions,
    fit_joint_conclusions, joint_error_stats, rapid_prototyping, search_structure,
};
pub use model::{ErrorStats, FuzzyModel};
pub use partition::{FuzzyStructure, MAX_INPUTS, Partition, RuleActivations};
