//! Joint error terms beyond linear joint springs: a non-linear joint
//! stiffness law (hardening with a lost-motion zone about zero torque) and
//! cyclic (non-geometric) joint errors, each with a switch
//! ([`JointTerms`]) and exact derivatives.
//!
//! ## Non-linear joint stiffness
//! A strain-wave (harmonic drive) or cycloidal gear is softest about zero
//! torque and stiffens as the load grows (gear manufacturers publish a
//! piecewise-linear torque-torsion curve whose slope grows with the torque),
//! and a gear with play turns by a lost motion before its teeth carry the
//! load. Joint i deflects by
//!
//! `dq_i = e_i + beta_i tanh(tau_i / tau_lm)`
//!
//! where `tau_i` is its generalised gravity force ([`crate::gravity`]), the
//! lost motion `beta_i` (rad) is taken up over the torque width `tau_lm`
//! ([`JointLaw::lost_motion_torque`], fixed, N.m), and the elastic part
//! `e_i` is the equilibrium of a hardening spring,
//!
//! `tau_s(e) = (e / c_i) (1 + eta_i |e|) = tau_i`,
//!
//! with the compliance at zero torque `c_i` (rad/N.m, the `compliance_<j>`
//! unknown of the linear model) and the hardening `eta_i` (1/rad: the
//! tangent stiffness `1/c_i (1 + 2 eta_i |e|)` doubles at a deflection of
//! `1 / (2 eta_i)`). The equilibrium is solved exactly (it is a quadratic
//! in `|e|`): `e = 2 c tau / (1 + s)`, `s = sqrt(1 + 4 eta c |tau|)`, which
//! a Newton iteration on `tau_s(e) = tau` converges to (a test checks);
//! the derivatives follow from the implicit function theorem,
//! `de/dtau = c / s`, `de/dc = tau / s`, `de/deta = -e |e| / s`. With
//! `eta = beta = 0` the law is the linear spring `dq = c tau`. A softening
//! `eta < 0` whose spring would yield (`1 + 4 eta c |tau| < S_MIN^2`) is
//! held at the yield slope (the derivatives are those of that branch).
//!
//! ## Bounds
//! The law must be monotone: a spring that turned back under a growing
//! load is not a spring. Its tangent stiffness is `s / c`, so the law is
//! monotone over the poses' torques when the hardening is at least
//! [`monotone_hardening_floor`] of the joint's compliance and largest
//! gravity torque (with the starting payload). A fit below it is held
//! there and the rest fitted again; the report gives the hardening the
//! status at-bound, as for a negative compliance held at zero
//! (the compliance judgement, `significance`).
//!
//! Identifiability: the lost motion is seen only where the torque changes
//! sign within the poses; where it keeps one sign `tanh` is constant and
//! `beta_i` is a joint offset, which the identifiability analysis then
//! reports as not identifiable (and the offset absorbs it).
//!
//! ## Cyclic joint errors
//! An encoder mounted off-centre, or a gear whose pitch circle runs out,
//! reads a joint angle off by a periodic function of the angle itself.
//! Each revolute joint i may get the first and second harmonics
//!
//! `dq_i += a1_i sin q_i + b1_i cos q_i + a2_i sin 2q_i + b2_i cos 2q_i`
//!
//! (rad; unknowns `cyclic_<j>_sin1`, `_cos1`, `_sin2`, `_cos2`), with `q_i`
//! the commanded (encoder) coordinate; the constant term is the joint
//! offset `theta`. A harmonic is identified only when the poses span its
//! period ([`partial_period_mask`]): over part of a period it is a smooth
//! curve that geometry imitates, and what it predicts for the rest of the
//! turn has no data behind it (on the IPA UR10 series, whose joints each
//! span about 2.2-4.4 rad in B, such terms passed cross-validation and
//! then missed the other series by millimetres). They are selected or
//! rejected by the data (model selection, `calibrate --select`).

use flexcal_kinematics::{ActuatedKind, Model};
use serde::{Deserialize, Serialize};

/// Default torque width of the lost-motion zone (N.m): a few per cent of
/// the gravity torque of a mid-size arm's shoulder, about where the gear
/// catalogues' first stiffness segment ends for gears of that size.
pub const DEFAULT_LOST_MOTION_TORQUE: f64 = 5.0;

/// Smallest `s = sqrt(1 + 4 eta c |tau|)` of a softening spring: below it
/// the spring would yield, and the law is held at this slope.
pub const S_MIN: f64 = 0.2;

/// The non-linear joint stiffness law (see the module docs): unknowns
/// `hardening_<j>` (1/rad) and `lost_motion_<j>` (rad) per actuated
/// coordinate, on top of the compliances of the elasto-geometric model.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct JointLaw {
    /// Torque over which the lost motion is taken up (N.m; default
    /// [`DEFAULT_LOST_MOTION_TORQUE`]; `> 0`): at this torque `tanh` is at
    /// 76 % of the lost motion.
    pub lost_motion_torque: f64,
}

impl Default for JointLaw {
    fn default() -> Self {
        Self {
            lost_motion_torque: DEFAULT_LOST_MOTION_TORQUE,
        }
    }
}

/// Which joint error terms the identification adds to the robot's geometry
/// (and, for the law, to its joint compliances).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct JointTerms {
    /// The non-linear stiffness law (default `None`: linear springs). Needs
    /// the elasto-geometric model ([`crate::CalibrationOptions::gravity`]).
    pub law: Option<JointLaw>,
    /// First and second harmonics of each revolute joint's angle (default
    /// false).
    pub cyclic: bool,
}

impl JointTerms {
    /// Whether any term is on.
    pub fn any(&self) -> bool {
        self.law.is_some() || self.cyclic
    }

    /// Names of the unknowns these terms add, in order: `hardening_<j>` and
    /// `lost_motion_<j>` for every actuated coordinate (law), then
    /// `cyclic_<j>_sin1, _cos1, _sin2, _cos2` for every revolute one.
    pub fn unknown_names(&self, model: &Model) -> Vec<String> {
        let mut names = Vec::new();
        if self.law.is_some() {
            for prefix in ["hardening_", "lost_motion_"] {
                names.extend(
                    model
                        .actuated_names()
                        .iter()
                        .map(|n| format!("{prefix}{n}")),
                );
            }
        }
        if self.cyclic {
            for i in cyclic_joints(model) {
                let n = &model.actuated_names()[i];
                for h in CYCLIC_SUFFIXES {
                    names.push(format!("cyclic_{n}_{h}"));
                }
            }
        }
        names
    }
}

/// Suffixes of the four cyclic unknowns of a joint.
pub const CYCLIC_SUFFIXES: [&str; 4] = ["sin1", "cos1", "sin2", "cos2"];

/// The actuated coordinates that get cyclic errors: the revolute ones.
pub fn cyclic_joints(model: &Model) -> Vec<usize> {
    model
        .actuated_kinds()
        .iter()
        .enumerate()
        .filter(|(_, k)| matches!(k, ActuatedKind::Revolute))
        .map(|(i, _)| i)
        .collect()
}

/// Share of a harmonic's period the poses must span for its amplitudes to
/// be identified (a full turn sampled by finitely many poses spans a little
/// less than the turn).
pub const PERIOD_COVERAGE: f64 = 0.9;

/// For each unknown named in `names`: whether it is a cyclic error of a
/// joint whose coordinates in `set` do not cover [`PERIOD_COVERAGE`] of
/// the harmonic's period (a full turn for the first harmonic, half a turn
/// for the second), taken as an arc of the period's circle.
pub fn partial_period_mask(
    model: &Model,
    set: &crate::measurement::MeasurementSet,
    names: &[String],
) -> Vec<bool> {
    let q: Vec<&[f64]> = set.configurations();
    partial_period_mask_of(model, &q, names)
}

/// [`partial_period_mask`] over the configurations `q` of any set of poses.
pub(crate) fn partial_period_mask_of(model: &Model, q: &[&[f64]], names: &[String]) -> Vec<bool> {
    // The arc of the harmonic's period the angles cover (see
    // [`crate::coverage`]): a joint turning more than once may span a
    // period on the line and still leave most of the circle unseen.
    let covered = |i: usize, period: f64| {
        crate::coverage::CoordinateCoverage::of(q.iter().map(|q| q[i]), Some(period)).length()
    };
    let turn = 2.0 * std::f64::consts::PI;
    names
        .iter()
        .map(|name| {
            let Some(rest) = name.strip_prefix("cyclic_") else {
                return false;
            };
            model.actuated_names().iter().enumerate().any(|(i, joint)| {
                let Some(suffix) = rest
                    .strip_prefix(joint.as_str())
                    .and_then(|r| r.strip_prefix('_'))
                else {
                    return false;
                };
                let period = if suffix.ends_with('1') {
                    turn
                } else {
                    turn / 2.0
                };
                CYCLIC_SUFFIXES.contains(&suffix) && covered(i, period) < PERIOD_COVERAGE * period
            })
        })
        .collect()
}

/// `[sin q, cos q, sin 2q, cos 2q]`: the derivatives of the cyclic error of
/// a joint at angle `q` by its four amplitudes.
pub fn cyclic_basis(q: f64) -> [f64; 4] {
    let (s, c) = q.sin_cos();
    [s, c, 2.0 * s * c, c * c - s * s]
}

/// The cyclic error (rad) of a joint at angle `q` with amplitudes
/// `[a1, b1, a2, b2]` (rad).
pub fn cyclic_error(q: f64, amplitudes: &[f64]) -> f64 {
    cyclic_basis(q)
        .iter()
        .zip(amplitudes)
        .map(|(b, a)| a * b)
        .sum()
}

/// The lowest hardening (1/rad) at which the law of a joint of
/// compliance `compliance` (rad/N.m) stays on its own branch up to the
/// torque `largest_torque` (N.m): `s = sqrt(1 + 4 eta c |tau|) >= S_MIN`,
/// so that the torque-deflection curve is monotone with a tangent
/// stiffness at least [`S_MIN`] times the zero-torque one (the tangent
/// stiffness of the law is `s / c`). `None` when the compliance or the
/// torque is not positive (no softening is then bounded).
///
/// A fit that puts a hardening below it softens the joint until it
/// yields within the poses' torques: the identification holds it at this
/// bound ([`crate::UnknownStatus::AtBound`], module docs "Bounds").
pub fn monotone_hardening_floor(compliance: f64, largest_torque: f64) -> Option<f64> {
    (compliance > 0.0 && largest_torque > 0.0)
        .then(|| (S_MIN * S_MIN - 1.0) / (4.0 * compliance * largest_torque))
}

/// The deflection of one joint under the law and its exact derivatives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointDeflection {
    /// `dq = e + beta tanh(tau / tau_lm)` (rad).
    pub deflection: f64,
    /// `d dq / d tau` (rad/N.m).
    pub by_torque: f64,
    /// `d dq / d c` (N.m).
    pub by_compliance: f64,
    /// `d dq / d eta` (rad^2).
    pub by_hardening: f64,
    /// `d dq / d beta` (dimensionless).
    pub by_lost_motion: f64,
}

/// Deflection of a joint of compliance `c` (rad/N.m), hardening `eta`
/// (1/rad) and lost motion `beta` (rad) under the torque `tau` (N.m), the
/// lost motion taken up over `lost_motion_torque` (N.m, `> 0`): the
/// equilibrium of the module docs, solved exactly, with its derivatives.
pub fn joint_deflection(
    tau: f64,
    c: f64,
    eta: f64,
    beta: f64,
    lost_motion_torque: f64,
) -> JointDeflection {
    let d = 1.0 + 4.0 * eta * c * tau.abs();
    let (e, by_torque, by_compliance, by_hardening) = if d >= S_MIN * S_MIN {
        let s = d.sqrt();
        let e = 2.0 * c * tau / (1.0 + s);
        (e, c / s, tau / s, -e * e.abs() / s)
    } else {
        // A yielding softening spring: the law held at the yield slope.
        let k = 2.0 / (1.0 + S_MIN);
        (k * c * tau, k * c, k * tau, 0.0)
    };
    let t = (tau / lost_motion_torque).tanh();
    JointDeflection {
        deflection: e + beta * t,
        by_torque: by_torque + beta * (1.0 - t * t) / lost_motion_torque,
        by_compliance,
        by_hardening,
        by_lost_motion: t,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The spring torque `(e / c)(1 + eta |e|)` at the returned elastic part
    /// equals the load, and Newton's iteration on it reaches the same `e`.
    #[test]
    fn the_deflection_is_the_spring_equilibrium() {
        for &(tau, c, eta) in &[
            (120.0, 12e-6, 800.0),
            (-300.0, 9e-6, 2500.0),
            (3.0, 20e-6, 0.0),
            (-50.0, 15e-6, -200.0),
        ] {
            let d = joint_deflection(tau, c, eta, 0.0, 5.0);
            let e = d.deflection;
            let spring = (e / c) * (1.0 + eta * e.abs());
            assert!(
                (spring - tau).abs() <= 1e-9 * tau.abs(),
                "{spring} vs {tau}"
            );
            let mut newton = c * tau;
            for _ in 0..50 {
                let g = (newton / c) * (1.0 + eta * newton.abs()) - tau;
                let slope = (1.0 + 2.0 * eta * newton.abs()) / c;
                newton -= g / slope;
            }
            assert!((newton - e).abs() <= 1e-12 * e.abs().max(1e-12));
        }
    }

    /// At the floor the law is monotone up to the largest torque, with a
    /// tangent stiffness of `S_MIN / c` there; below it the spring yields
    /// within the torques (the held branch).
    #[test]
    fn the_monotone_floor_keeps_the_law_on_its_branch() {
        for &(c, largest) in &[(12e-6, 120.0), (300e-6, 25.0), (1e-7, 3000.0)] {
            let floor = monotone_hardening_floor(c, largest).unwrap();
            assert!(floor < 0.0);
            let n = 400;
            let mut previous = f64::NEG_INFINITY;
            for k in 0..=n {
                let tau = largest * (2.0 * k as f64 / n as f64 - 1.0);
                let d = joint_deflection(tau, c, floor, 0.0, 5.0);
                assert!(d.deflection > previous, "not monotone at {tau} N.m");
                previous = d.deflection;
                // The tangent stiffness: the inverse of d dq / d tau.
                assert!(c / d.by_torque >= S_MIN - 1e-12);
            }
            let edge = joint_deflection((1.0 - 1e-9) * largest, c, floor, 0.0, 5.0);
            assert!((edge.by_torque - c / S_MIN).abs() < 1e-6 * c / S_MIN);
            // Below the floor, the largest torque is past the yield.
            let below = 1.0 + 4.0 * (1.5 * floor) * c * largest;
            assert!(below < S_MIN * S_MIN);
        }
        assert_eq!(monotone_hardening_floor(0.0, 10.0), None);
        assert_eq!(monotone_hardening_floor(1e-5, 0.0), None);
    }

    /// Every derivative against central finite differences.
    #[test]
    fn derivatives_match_finite_differences() {
        let (tau_lm, cases) = (
            5.0,
            [
                (120.0, 12e-6, 800.0, 2e-4),
                (-4.0, 9e-6, 2500.0, -1e-4),
                (0.5, 20e-6, 0.0, 3e-4),
                (-50.0, 15e-6, -200.0, 1e-5),
            ],
        );
        for (tau, c, eta, beta) in cases {
            let f = |tau: f64, c: f64, eta: f64, beta: f64| {
                joint_deflection(tau, c, eta, beta, tau_lm).deflection
            };
            let d = joint_deflection(tau, c, eta, beta, tau_lm);
            let check = |analytic: f64, plus: f64, minus: f64, h: f64| {
                let numeric = (plus - minus) / (2.0 * h);
                assert!(
                    (analytic - numeric).abs() <= 1e-6 * analytic.abs().max(numeric.abs()) + 1e-15,
                    "{analytic} vs {numeric}"
                );
            };
            let h = 1e-4 * tau.abs().max(1.0);
            check(
                d.by_torque,
                f(tau + h, c, eta, beta),
                f(tau - h, c, eta, beta),
                h,
            );
            let h = 1e-4 * c;
            check(
                d.by_compliance,
                f(tau, c + h, eta, beta),
                f(tau, c - h, eta, beta),
                h,
            );
            let h = 1e-3 * eta.abs().max(10.0);
            check(
                d.by_hardening,
                f(tau, c, eta + h, beta),
                f(tau, c, eta - h, beta),
                h,
            );
            let h = 1e-6;
            check(
                d.by_lost_motion,
                f(tau, c, eta, beta + h),
                f(tau, c, eta, beta - h),
                h,
            );
        }
    }

    #[test]
    fn zero_law_is_the_linear_spring_and_zero_load_no_deflection() {
        let d = joint_deflection(200.0, 10e-6, 0.0, 0.0, 5.0);
        assert!((d.deflection - 2e-3).abs() < 1e-15);
        assert_eq!(
            joint_deflection(0.0, 10e-6, 900.0, 3e-4, 5.0).deflection,
            0.0
        );
    }

    #[test]
    fn cyclic_basis_is_the_two_harmonics() {
        let q = 0.7f64;
        let b = cyclic_basis(q);
        let expected = [q.sin(), q.cos(), (2.0 * q).sin(), (2.0 * q).cos()];
        for (a, e) in b.iter().zip(expected) {
            assert!((a - e).abs() < 1e-15);
        }
        assert!(
            (cyclic_error(q, &[1.0, 0.0, 0.0, 2.0]) - (q.sin() + 2.0 * (2.0 * q).cos())).abs()
                < 1e-15
        );
    }
}
