//! How the elasto-geometric model computes the elastic deflection: one
//! linear step on the commanded configuration (the default), the static
//! equilibrium on the deflected one, or the equilibrium when the one step
//! would bias the compliances (the equilibrium module says how it is
//! solved). A setting of the mass table ([`crate::GravityCompliance`]),
//! apart from the solver so that the loading's description does not
//! depend on it.

use serde::{Deserialize, Serialize};

use crate::error::CalibError;

/// Default tolerance of the equilibrium iteration: the largest change of a
/// joint deflection between two iterations at which it stops (rad for a
/// revolute coordinate, m for a prismatic one): 1e-9 rad moves a point 1 m
/// away by 1 nm.
pub const DEFAULT_EQUILIBRIUM_TOLERANCE: f64 = 1e-9;

/// Default iteration cap of the equilibrium's Newton iterations: linear
/// springs take two (the first solves, the second confirms), the
/// stiffening law a few more.
pub const DEFAULT_EQUILIBRIUM_ITERATIONS: usize = 100;

/// Default share of [`Deflection::Auto`]: the equilibrium is switched on
/// when the one step's deflection changes a joint's gravity torque by
/// more than 5 % of that joint's torque span over the poses. The one step
/// errs on a joint's deflection by its compliance times that change, so
/// the identified compliance, which is read from the deflection's span, is
/// biased by about that share; 5 % is the size of a well-determined
/// compliance's standard error on the campaigns of the docs (3-10 %), the
/// point where the bias stops hiding inside the statistical uncertainty.
pub const DEFAULT_AUTO_SHARE: f64 = 0.05;

/// How the elasto-geometric model computes the elastic deflection (module
/// docs): [`crate::GravityCompliance::deflection`].
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
pub enum Deflection {
    /// One linear step on the commanded configuration (default; the
    /// published figures): `dq = f(tau(q))`.
    #[default]
    OneStep,
    /// The static equilibrium `dq = f(tau(q) + K dq)`, Newton's method until
    /// no step moves a joint deflection by more than `tolerance_rad` (rad or m,
    /// `> 0`; default [`DEFAULT_EQUILIBRIUM_TOLERANCE`]), at most
    /// `max_iterations` times (`>= 1`; default
    /// [`DEFAULT_EQUILIBRIUM_ITERATIONS`]).
    Equilibrium {
        /// Largest change of a joint deflection at which the iteration
        /// stops (rad or m).
        tolerance_rad: f64,
        /// Iteration cap.
        max_iterations: usize,
    },
    /// The one step, then the equilibrium (default tolerance and cap) when
    /// the one step's deflection changes a joint's torque by more than
    /// `share` of its span over the poses (in `(0, 1]`; default
    /// [`DEFAULT_AUTO_SHARE`]).
    Auto {
        /// Share of a joint's torque span (dimensionless).
        share: f64,
    },
}

impl Deflection {
    /// The equilibrium with the default tolerance and iteration cap.
    pub fn equilibrium() -> Self {
        Self::Equilibrium {
            tolerance_rad: DEFAULT_EQUILIBRIUM_TOLERANCE,
            max_iterations: DEFAULT_EQUILIBRIUM_ITERATIONS,
        }
    }

    /// [`Deflection::Auto`] with [`DEFAULT_AUTO_SHARE`].
    pub fn auto() -> Self {
        Self::Auto {
            share: DEFAULT_AUTO_SHARE,
        }
    }

    /// Whether this is the default one step.
    pub fn is_one_step(&self) -> bool {
        *self == Self::OneStep
    }

    /// `one-step`, `equilibrium` or `auto`.
    pub fn name(&self) -> &'static str {
        match self {
            Self::OneStep => "one-step",
            Self::Equilibrium { .. } => "equilibrium",
            Self::Auto { .. } => "auto",
        }
    }

    /// Checks the values.
    ///
    /// # Errors
    /// [`CalibError::InvalidOption`] (`deflection`) naming a tolerance
    /// that is not finite and `> 0`, a cap of zero, a share outside
    /// `(0, 1]`.
    pub fn check(&self) -> Result<(), CalibError> {
        let invalid = |reason: String| {
            Err(CalibError::InvalidOption {
                name: "deflection",
                reason,
            })
        };
        match *self {
            Self::OneStep => Ok(()),
            Self::Equilibrium {
                tolerance_rad,
                max_iterations,
            } => {
                if !(tolerance_rad.is_finite() && tolerance_rad > 0.0) {
                    invalid(format!(
                        "equilibrium tolerance must be finite and > 0 rad, found {tolerance_rad}"
                    ))
                } else if max_iterations == 0 {
                    invalid("equilibrium max_iterations must be at least 1".into())
                } else {
                    Ok(())
                }
            }
            Self::Auto { share } => {
                if share.is_finite() && share > 0.0 && share <= 1.0 {
                    Ok(())
                } else {
                    invalid(format!(
                        "auto share must be in (0, 1] (a share of each joint's torque span), found {share}"
                    ))
                }
            }
        }
    }

    /// The tolerance and cap the model iterates with, `None` for the one
    /// step (and for [`Deflection::Auto`], whose first fit is the one step).
    pub(crate) fn iteration(&self) -> Option<(f64, usize)> {
        match *self {
            Self::Equilibrium {
                tolerance_rad,
                max_iterations,
            } => Some((tolerance_rad, max_iterations)),
            _ => None,
        }
    }
}

impl std::str::FromStr for Deflection {
    type Err = String;
    /// `one-step`, `equilibrium` (default tolerance and cap) or `auto`
    /// (default share).
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "one-step" => Ok(Self::OneStep),
            "equilibrium" => Ok(Self::equilibrium()),
            "auto" => Ok(Self::auto()),
            other => Err(format!("`{other}`: expected one-step, equilibrium or auto")),
        }
    }
}
