//! Which part of an actuated coordinate's travel a set of poses covers.
//!
//! A prediction for a pose whose coordinate lies outside what the
//! identification poses covered is an extrapolation of the identified model
//! ([`crate::Calibration::outside_training_range`]), and a cyclic joint
//! error is identified only when the poses cover most of its period (the
//! joint-law module's `partial_period_mask`).
//!
//! Every term of the model is a `2 pi`-periodic function of a revolute
//! coordinate: the geometry, the gravity torques, the joint law and the
//! cyclic errors. A joint that turns more than once (the UR joints travel
//! `+/- 2 pi`) reaches the same arm pose at `q` and `q - 2 pi`, and the
//! model predicts the same error at both. What the poses cover of such a
//! coordinate is an arc of the circle: everything but the largest gap
//! between the angles, taken modulo the period. A training set with the
//! shoulder pan in `[-5.4, -3.1]` rad covers a validation pose at `1.0` rad
//! (`= 1.0 - 2 pi = -5.3` rad); the interval `(min, max)` on the line calls
//! it an extrapolation, and a set whose angles spread over `[-3.0, -2.6]`
//! and `[2.8, 3.1]` rad spans 6.1 rad on the line but 0.9 rad of the
//! circle. A prismatic or screw coordinate is not periodic: its coverage is
//! the interval from its smallest to its largest value.

use flexcal_kinematics::{ActuatedKind, Model};
use serde::{Deserialize, Serialize};

use crate::measurement::MeasurementSet;

/// The values of one coordinate that a set of poses covers: the interval
/// `[lo, hi]` for a non-periodic coordinate, the arc from `lo` to `hi`
/// (`hi - lo <= period`) on the circle of a periodic one.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CoordinateCoverage {
    /// Start of the covered interval or arc (rad or m): the smallest value,
    /// or for a periodic coordinate the angle after the largest gap, as one
    /// of the poses records it.
    pub lo: f64,
    /// End (rad or m): `lo` plus the covered length.
    pub hi: f64,
    /// The period (rad; `2 pi` for a revolute coordinate), `None` for a
    /// coordinate that is not periodic.
    pub period: Option<f64>,
}

impl CoordinateCoverage {
    /// Coverage of `values` (rad or m; the non-finite ones are ignored).
    /// With a `period` (rad, `> 0`) the arc of the circle they cover:
    /// everything but the largest gap between consecutive angles modulo the
    /// period. No finite value gives the empty coverage `lo > hi`.
    pub fn of(values: impl IntoIterator<Item = f64>, period: Option<f64>) -> Self {
        let values: Vec<f64> = values.into_iter().filter(|v| v.is_finite()).collect();
        let empty = Self {
            lo: f64::INFINITY,
            hi: f64::NEG_INFINITY,
            period,
        };
        let Some(&first) = values.first() else {
            return empty;
        };
        let Some(p) = period.filter(|p| *p > 0.0 && p.is_finite()) else {
            let (lo, hi) = values
                .iter()
                .fold((first, first), |(lo, hi), &v| (lo.min(v), hi.max(v)));
            return Self { lo, hi, period };
        };
        // (angle modulo the period, index of the value), sorted.
        let mut wrapped: Vec<(f64, usize)> = values
            .iter()
            .enumerate()
            .map(|(i, v)| (v.rem_euclid(p), i))
            .collect();
        wrapped.sort_by(|a, b| a.0.total_cmp(&b.0));
        // The gap after each angle; the last one wraps round to the first.
        let n = wrapped.len();
        let (mut start, mut largest) = (0, -1.0);
        for k in 0..n {
            let next = if k + 1 < n {
                wrapped[k + 1].0
            } else {
                wrapped[0].0 + p
            };
            let gap = next - wrapped[k].0;
            if gap > largest {
                largest = gap;
                start = (k + 1) % n;
            }
        }
        let lo = values[wrapped[start].1];
        Self {
            lo,
            hi: lo + (p - largest).max(0.0),
            period,
        }
    }

    /// Coverage of each actuated coordinate of `model` over the poses of
    /// `set`: an arc of the circle for a revolute coordinate, an interval
    /// for a prismatic or screw one.
    pub fn of_actuated(model: &Model, set: &MeasurementSet) -> Vec<Self> {
        let q: Vec<&[f64]> = set.configurations();
        Self::of_configurations(model, &q)
    }

    /// Coverage of each actuated coordinate of `model` over the
    /// configurations `q` (rad or m, each of `model`'s actuated count), as
    /// [`CoordinateCoverage::of_actuated`].
    pub fn of_configurations(model: &Model, q: &[&[f64]]) -> Vec<Self> {
        model
            .actuated_kinds()
            .iter()
            .enumerate()
            .map(|(i, kind)| {
                let period = (*kind == ActuatedKind::Revolute).then_some(std::f64::consts::TAU);
                Self::of(q.iter().map(|q| q[i]), period)
            })
            .collect()
    }

    /// Covered length (rad or m; 0 for one value, negative when empty).
    pub fn length(&self) -> f64 {
        self.hi - self.lo
    }

    /// How far `q` (rad or m) lies outside the covered interval or arc
    /// (same unit; 0 inside, infinite for an empty coverage): for a
    /// periodic coordinate the shorter way round to either end of the arc.
    pub fn distance_outside(&self, q: f64) -> f64 {
        if self.lo.partial_cmp(&self.hi).is_none_or(|o| o.is_gt()) {
            return f64::INFINITY;
        }
        match self.period.filter(|p| *p > 0.0 && p.is_finite()) {
            None => (self.lo - q).max(q - self.hi).max(0.0),
            Some(p) => {
                let ahead = (q - self.lo).rem_euclid(p);
                if ahead <= self.length() {
                    0.0
                } else {
                    (ahead - self.length()).min(p - ahead)
                }
            }
        }
    }

    /// Whether `q` (rad or m) lies in the covered interval or arc, allowing
    /// `margin` (same unit) beyond either end.
    pub fn contains(&self, q: f64, margin: f64) -> bool {
        if self.lo.partial_cmp(&self.hi).is_none_or(|o| o.is_gt()) {
            return false;
        }
        match self.period.filter(|p| *p > 0.0 && p.is_finite()) {
            None => q >= self.lo - margin && q <= self.hi + margin,
            Some(p) => {
                // Distance along the circle from the start of the arc, and
                // back from it for the margin before the start.
                let ahead = (q - self.lo).rem_euclid(p);
                ahead <= self.length() + margin || p - ahead <= margin
            }
        }
    }
}

/// Indices of the coordinates at which `q` (rad or m) lies outside
/// `ranges` (by more than 1e-9; a revolute coordinate a whole number of
/// turns away from a covered angle is inside): where a prediction is an
/// extrapolation from the poses that `ranges` cover.
pub(crate) fn outside<'a>(
    ranges: &'a [CoordinateCoverage],
    q: &'a [f64],
) -> impl Iterator<Item = usize> + 'a {
    const MARGIN: f64 = 1e-9;
    ranges
        .iter()
        .zip(q)
        .enumerate()
        .filter(|(_, (range, q))| !range.contains(**q, MARGIN))
        .map(|(i, _)| i)
}

/// Each coordinate (named by `names`, in order) at which some of
/// `configurations` lie outside `ranges`, with the fraction of the
/// configurations that do (in (0, 1]); coordinates that none leaves are
/// not listed.
pub(crate) fn extrapolated_coordinates<'a>(
    names: &[String],
    ranges: &[CoordinateCoverage],
    configurations: impl Iterator<Item = &'a [f64]>,
) -> Vec<(String, f64)> {
    let mut counts = vec![0usize; ranges.len()];
    let mut n = 0usize;
    for q in configurations {
        n += 1;
        for i in outside(ranges, q) {
            counts[i] += 1;
        }
    }
    names
        .iter()
        .zip(counts)
        .filter(|(_, count)| *count > 0)
        .map(|(name, count)| (name.clone(), count as f64 / n.max(1) as f64))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use std::f64::consts::PI;

    #[test]
    fn an_interval_for_a_coordinate_that_is_not_periodic() {
        let c = CoordinateCoverage::of([0.3, -0.2, 0.1], None);
        assert_eq!((c.lo, c.hi), (-0.2, 0.3));
        assert!(c.contains(-0.2, 0.0) && c.contains(0.0, 0.0));
        assert!(!c.contains(0.31, 0.0) && c.contains(0.31, 0.02));
        // Two turns further is outside: a prismatic coordinate has no period.
        assert!(!c.contains(4.0 * PI, 0.0));
    }

    #[test]
    fn an_arc_for_a_revolute_coordinate() {
        // The shoulder pan of a series recorded at -5.38 .. -3.15 rad.
        let c = CoordinateCoverage::of([-5.38, -4.0, -3.15], Some(2.0 * PI));
        assert_eq!(c.lo, -5.38);
        assert!((c.length() - 2.23).abs() < 1e-12);
        // The same arm poses recorded a turn later are inside.
        assert!(c.contains(-5.38 + 2.0 * PI, 1e-9));
        assert!(c.contains(1.0, 0.0));
        assert!(!c.contains(0.0, 0.0) && !c.contains(-3.0, 0.0));
        // Two clusters either side of +/- pi cover 0.88 rad of the circle,
        // not the 6.1 rad between their extremes.
        let c = CoordinateCoverage::of([-3.0, -2.6, 2.8, 3.1], Some(2.0 * PI));
        assert_eq!(c.lo, 2.8);
        assert!((c.length() - (2.0 * PI - 5.4)).abs() < 1e-12, "{c:?}");
        assert!(c.contains(PI, 0.0) && !c.contains(0.0, 0.0));
        // The margin reaches back before the start of the arc.
        assert!(c.contains(c.lo - 0.01, 0.02) && !c.contains(c.lo - 0.03, 0.02));
    }

    #[test]
    fn no_value_covers_nothing_and_one_value_covers_a_point() {
        let none = CoordinateCoverage::of([f64::NAN], Some(2.0 * PI));
        assert!(none.length() < 0.0 && !none.contains(0.0, 1.0));
        let one = CoordinateCoverage::of([1.0], Some(2.0 * PI));
        assert_eq!(one.length(), 0.0);
        assert!(one.contains(1.0 + 2.0 * PI, 1e-9) && !one.contains(1.1, 0.0));
    }

    /// Seeded property: the distance outside is zero exactly where the
    /// coverage contains the value, and the smallest margin that makes
    /// `contains` true.
    #[test]
    fn the_distance_outside_is_the_margin_that_contains() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(29);
        for _ in 0..500 {
            let values: Vec<f64> = (0..rng.random_range(1..12))
                .map(|_| rng.random_range(-4.0..4.0))
                .collect();
            let period = rng.random_bool(0.5).then_some(2.0 * PI);
            let c = CoordinateCoverage::of(values.iter().copied(), period);
            let q = rng.random_range(-12.0..12.0);
            let d = c.distance_outside(q);
            assert!(d >= 0.0 && d.is_finite(), "{c:?} {q} {d}");
            assert_eq!(d == 0.0, c.contains(q, 0.0), "{c:?} {q} {d}");
            assert!(c.contains(q, d + 1e-9), "{c:?} {q} {d}");
            if d > 1e-6 {
                assert!(!c.contains(q, d - 1e-6), "{c:?} {q} {d}");
            }
        }
        assert!(CoordinateCoverage::of([f64::NAN], None).distance_outside(0.0) > 1e300);
    }

    /// Seeded property: every value lies in its own coverage, whichever turn
    /// it is recorded in; the arc is no longer than the interval on the line
    /// and no longer than the period; a point in the largest gap is outside.
    #[test]
    fn every_value_is_covered_and_the_gap_is_not() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(17);
        for _ in 0..500 {
            let n = rng.random_range(1..40);
            let centre = rng.random_range(-10.0..10.0);
            let spread = rng.random_range(0.0..8.0);
            let values: Vec<f64> = (0..n)
                .map(|_| centre + rng.random_range(-spread..=spread))
                .collect();
            let line = CoordinateCoverage::of(values.iter().copied(), None);
            let arc = CoordinateCoverage::of(values.iter().copied(), Some(2.0 * PI));
            assert!(arc.length() <= line.length() + 1e-12);
            assert!(arc.length() >= 0.0 && arc.length() < 2.0 * PI);
            for &v in &values {
                let turns = f64::from(rng.random_range(-2..=2_i32));
                assert!(arc.contains(v + turns * 2.0 * PI, 1e-9), "{v} {arc:?}");
                assert!(line.contains(v, 0.0));
            }
            // The middle of the gap after the arc is outside it.
            if arc.length() < 2.0 * PI - 1e-6 {
                let gap_middle = arc.hi + 0.5 * (2.0 * PI - arc.length());
                assert!(!arc.contains(gap_middle, 0.0), "{arc:?}");
            }
        }
    }
}
