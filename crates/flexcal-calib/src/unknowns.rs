//! What an identification says of each unknown: its estimate and status
//! ([`UnknownEstimate`], [`UnknownStatus`]) and, for one left out, the
//! combination (C.1) an identified one stands for ([`Combination`]).

use crate::significance::ScaleJudgement;
use crate::unknown_kind::UnknownKind;

/// What became of one unknown.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum UnknownStatus {
    /// Identified (in the base set).
    Identified,
    /// Fixed by the user or by the frame treatment.
    Fixed,
    /// Not identifiable from these poses (beyond the numerical rank); kept at
    /// its starting value, its effect absorbed by the identified combinations.
    NonIdentifiable,
    /// Identifiable in principle but its standard error would exceed the
    /// limit of [`crate::CalibrationOptions`]; kept at its starting value.
    PoorlyIdentifiable,
    /// Has no influence on what is measured (e.g. target rotation without
    /// measured orientation); kept at its starting value.
    NoInfluence,
    /// Held at its physical bound (a compliance at zero, a joint law's
    /// hardening at its monotone floor,
    /// [`crate::joint_law::monotone_hardening_floor`]): the
    /// unconstrained fit put it beyond, by more than its standard error
    /// ([`UnknownEstimate::judgement`] keeps what the fit gave).
    AtBound,
}

impl UnknownStatus {
    /// The status as reports and files write it (`identified`, `fixed`,
    /// `non-identifiable`, `poorly-identifiable`, `no-influence`,
    /// `at-bound`).
    pub fn name(self) -> &'static str {
        match self {
            UnknownStatus::Identified => "identified",
            UnknownStatus::Fixed => "fixed",
            UnknownStatus::NonIdentifiable => "non-identifiable",
            UnknownStatus::PoorlyIdentifiable => "poorly-identifiable",
            UnknownStatus::NoInfluence => "no-influence",
            UnknownStatus::AtBound => "at-bound",
        }
    }
}

/// One unknown of the identification, by name.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct UnknownEstimate {
    /// Name (`d3`, `frame_rx`, `target_z`, `compliance_2`, ...).
    pub name: String,
    /// Length (m), angle (rad), compliance (rad/N.m or m/N), mass (kg) or
    /// first moment (kg.m).
    pub kind: UnknownKind,
    /// Starting (nominal) value, in the unit of `kind` (0 for the frame
    /// increments).
    pub initial: f64,
    /// Identified value, in the unit of `kind`.
    pub value: f64,
    /// Standard error, in the unit of `kind`, when identified.
    pub standard_error: Option<f64>,
    /// When identified: its standard error divided by the one that as many
    /// poses drawn uniformly over the robot's joint ranges (revolute joints
    /// over their limits, prismatic ones over the identification range)
    /// would give with the same noise (dimensionless; 1 = as well determined
    /// as by a spread design, 10 = ten times worse). Poses clustered in a small region
    /// determine many parameters only in combinations that hold there: a
    /// large ratio warns that predictions elsewhere are extrapolations even
    /// when the standard error itself is small.
    pub spread_ratio: Option<f64>,
    /// What became of it.
    pub status: UnknownStatus,
    /// For a compliance: the fit that judged it on its own scale (value,
    /// standard error, outcome), also when it was left out or held at its
    /// bound ([`crate::significance`]); `None` for the other unknowns.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub judgement: Option<ScaleJudgement>,
}

/// `name_id = name + sum_k coefficient_k * other_k`: what an identified
/// unknown stands for when others are not identified (the paper's (C.1)).
/// Coefficients are in physical units (m per m, m per rad, ...).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Combination {
    /// The identified unknown.
    pub name: String,
    /// `(absorbed unknown, coefficient)`, largest magnitude first.
    pub terms: Vec<(String, f64)>,
}

impl Combination {
    /// `d4_id = d4 + 0.82 d9 - r8p`; empty when no coefficient reaches `threshold`.
    pub fn to_text(&self, threshold: f64) -> String {
        let mut line = format!("{}_id = {}", self.name, self.name);
        let mut any = false;
        for (other, k) in &self.terms {
            if k.abs() < threshold {
                continue;
            }
            any = true;
            let sign = if *k < 0.0 { '-' } else { '+' };
            if (k.abs() - 1.0).abs() < 5e-4 {
                line.push_str(&format!(" {sign} {other}"));
            } else {
                line.push_str(&format!(" {sign} {:.3} {other}", k.abs()));
            }
        }
        if any { line } else { String::new() }
    }
}
