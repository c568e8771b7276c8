//! What the instrument can see: a reach box and a line of sight, applied
//! to the candidate poses before a plan chooses among them.
//!
//! A laser tracker measures a reflector only while the reflector faces it
//! (within the reflector's acceptance half-angle) and stands within the
//! tracker's range; a camera sees its targets only inside its measuring
//! volume and within the LEDs' viewing angle. A pose the instrument cannot
//! see is a pose the campaign cannot measure: with several targets a
//! candidate keeps the targets the instrument sees, and the plan leaves out
//! a candidate where it sees none, saying how many and why
//! ([`SightFilter`]).
//!
//! Both tests are taken on the nominal robot at each candidate, for each
//! of the plan's targets (one at the TCP or a given offset, or those of a
//! targets description), in the robot's base frame: the instrument's placement is what the user plans,
//! before the measurement frame exists.

use nalgebra::{Isometry3, Vector3};
use serde::{Deserialize, Serialize};

use crate::{Error, Result};

/// A line of sight from the instrument to the target.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LineOfSight {
    /// The instrument's position in the robot's base frame (mm).
    pub position_mm: [f64; 3],
    /// Largest angle between the target's z axis (its facing direction:
    /// the tool axis for a target at the TCP) and the direction from the
    /// target to the instrument (deg, in (0, 180]): the reflector's
    /// acceptance half-angle, the LEDs' viewing half-angle.
    pub max_incidence_deg: f64,
}

/// Where the instrument can measure the target, in the robot's base frame.
/// Every test left `None` passes.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Sight {
    /// The box the target must lie in (mm): `[[x_lo, x_hi], [y_lo, y_hi],
    /// [z_lo, z_hi]]`, e.g. a camera's measuring volume, or the part of the
    /// cell within the tracker's range.
    #[serde(default)]
    pub reach_box_mm: Option<[[f64; 2]; 3]>,
    /// The target must face the instrument.
    #[serde(default)]
    pub line_of_sight: Option<LineOfSight>,
}

/// Why the instrument cannot see a target.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum OutOfSight {
    /// The target lies outside the reach box along `axis` (0 x, 1 y, 2 z)
    /// at `value_mm` (mm).
    OutsideBox {
        /// The axis (0 x, 1 y, 2 z).
        axis: usize,
        /// The target's coordinate along it (mm).
        value_mm: f64,
    },
    /// The target faces away from the instrument by `angle_deg` (deg).
    FacingAway {
        /// The angle between its z axis and the line to the instrument (deg).
        angle_deg: f64,
    },
}

/// The candidates the instrument sees, and which of their targets.
#[derive(Debug, Clone, PartialEq)]
pub struct SightFilter {
    /// The rows of the candidates kept, those where the instrument sees
    /// at least one target (0-based, increasing).
    pub kept: Vec<usize>,
    /// For each kept candidate, whether the instrument sees each target
    /// (in the order of the targets).
    pub seen: Vec<Vec<bool>>,
    /// Number of candidates offered.
    pub offered: usize,
    /// Number of (candidate, target) observations out of sight because the
    /// target lies outside the reach box (with one target: candidates).
    pub outside_box: usize,
    /// Number of (candidate, target) observations out of sight because the
    /// target faces away from the instrument (inside the box, or without
    /// one).
    pub facing_away: usize,
}

impl SightFilter {
    /// Number of candidates left out: those where the instrument sees no
    /// target.
    pub fn left_out(&self) -> usize {
        self.offered - self.kept.len()
    }
}

const AXES: [&str; 3] = ["x", "y", "z"];

impl Sight {
    /// Checks the sight: each box range finite with `lo < hi`, the
    /// instrument's position finite, the angle in (0, 180] deg.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming the field and what is wrong.
    pub fn check(&self) -> Result<()> {
        let invalid = |parameter: &str, message: String| Error::InvalidParameter {
            parameter: parameter.into(),
            message,
        };
        for (axis, [lo, hi]) in AXES.iter().zip(self.reach_box_mm.into_iter().flatten()) {
            if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                return Err(invalid(
                    "reach_box_mm",
                    format!(
                        "the range along {axis} must be finite with lo < hi, found {lo}:{hi} mm (an empty box)"
                    ),
                ));
            }
        }
        if let Some(los) = &self.line_of_sight {
            if los.position_mm.iter().any(|v| !v.is_finite()) {
                return Err(invalid(
                    "line_of_sight.position_mm",
                    format!(
                        "the instrument's position must be finite, found {:?} mm",
                        los.position_mm
                    ),
                ));
            }
            let a = los.max_incidence_deg;
            if !(a.is_finite() && a > 0.0 && a <= 180.0) {
                return Err(invalid(
                    "line_of_sight.max_incidence_deg",
                    format!("must be in (0, 180] deg, found {a}"),
                ));
            }
        }
        Ok(())
    }

    /// Whether the instrument sees a target at `x_base_target` (its pose in
    /// the base frame, m): `None` when it does, else the first test it
    /// fails (the box, then the line of sight).
    pub fn sees(&self, x_base_target: &Isometry3<f64>) -> Option<OutOfSight> {
        let p = x_base_target.translation.vector * 1e3;
        for (axis, [lo, hi]) in self.reach_box_mm.into_iter().flatten().enumerate() {
            if p[axis] < lo || p[axis] > hi {
                return Some(OutOfSight::OutsideBox {
                    axis,
                    value_mm: p[axis],
                });
            }
        }
        let los = self.line_of_sight?;
        let to_instrument = Vector3::from(los.position_mm) - p;
        let facing = x_base_target.rotation * Vector3::z();
        // A target at the instrument itself: no direction to face; it is seen.
        let angle_deg = facing.angle(&to_instrument).to_degrees();
        (to_instrument.norm() > 0.0 && angle_deg > los.max_incidence_deg)
            .then_some(OutOfSight::FacingAway { angle_deg })
    }

    /// Which targets the instrument sees at each candidate, from
    /// `x_base_targets`: the pose of every target (its z axis the
    /// direction it faces) in the base frame of the nominal robot, one
    /// entry per candidate, one per target
    /// ([`crate::calib::start::target_poses`]). A candidate where it sees
    /// no target is left out.
    ///
    /// # Errors
    /// [`Sight::check`]'s; [`Error::InvalidParameter`] (`candidates`) when
    /// the instrument sees none of them, saying how many observations
    /// failed which test.
    pub fn filter(&self, x_base_targets: &[Vec<Isometry3<f64>>]) -> Result<SightFilter> {
        self.check()?;
        let mut filter = SightFilter {
            kept: Vec::new(),
            seen: Vec::new(),
            offered: x_base_targets.len(),
            outside_box: 0,
            facing_away: 0,
        };
        for (k, targets) in x_base_targets.iter().enumerate() {
            let seen: Vec<bool> = targets
                .iter()
                .map(|x| match self.sees(x) {
                    None => true,
                    Some(OutOfSight::OutsideBox { .. }) => {
                        filter.outside_box += 1;
                        false
                    }
                    Some(OutOfSight::FacingAway { .. }) => {
                        filter.facing_away += 1;
                        false
                    }
                })
                .collect();
            if seen.contains(&true) {
                filter.kept.push(k);
                filter.seen.push(seen);
            }
        }
        if filter.kept.is_empty() {
            return Err(Error::InvalidParameter {
                parameter: "candidates".into(),
                message: format!(
                    "the instrument sees none of the {} candidates: {}",
                    filter.offered,
                    filter.describe()
                ),
            });
        }
        Ok(filter)
    }
}

impl SightFilter {
    /// `k outside the reach box, j facing away from the instrument`
    /// (observations of a target at a candidate).
    pub fn describe(&self) -> String {
        format!(
            "{} outside the reach box, {} facing away from the instrument",
            self.outside_box, self.facing_away
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Translation3, UnitQuaternion};

    fn at(x_mm: [f64; 3], facing: Vector3<f64>) -> Isometry3<f64> {
        let rotation = UnitQuaternion::rotation_between(&Vector3::z(), &facing)
            .unwrap_or_else(|| UnitQuaternion::from_euler_angles(std::f64::consts::PI, 0.0, 0.0));
        Isometry3::from_parts(Translation3::from(Vector3::from(x_mm) * 1e-3), rotation)
    }

    #[test]
    fn the_box_and_the_line_of_sight_decide_by_their_own_geometry() {
        let sight = Sight {
            reach_box_mm: Some([[-500.0, 500.0], [-500.0, 500.0], [0.0, 1000.0]]),
            line_of_sight: Some(LineOfSight {
                position_mm: [2000.0, 0.0, 500.0],
                max_incidence_deg: 30.0,
            }),
        };
        sight.check().unwrap();
        // Facing the instrument straight on.
        assert_eq!(sight.sees(&at([0.0, 0.0, 500.0], Vector3::x())), None);
        // Outside the box along y, whatever it faces.
        assert_eq!(
            sight.sees(&at([0.0, 600.0, 500.0], Vector3::x())),
            Some(OutOfSight::OutsideBox {
                axis: 1,
                value_mm: 600.0
            })
        );
        // Tilted 40 deg away from the line to the instrument (in the x-z plane).
        let tilted = Vector3::new(40f64.to_radians().cos(), 0.0, 40f64.to_radians().sin());
        match sight.sees(&at([0.0, 0.0, 500.0], tilted)) {
            Some(OutOfSight::FacingAway { angle_deg }) => assert!((angle_deg - 40.0).abs() < 1e-9),
            other => panic!("expected facing away, got {other:?}"),
        }
        // 20 deg is within the 30 deg half-angle.
        let within = Vector3::new(20f64.to_radians().cos(), 0.0, 20f64.to_radians().sin());
        assert_eq!(sight.sees(&at([0.0, 0.0, 500.0], within)), None);
    }

    #[test]
    fn a_sight_that_cannot_see_anything_is_refused_by_name() {
        let empty = Sight {
            reach_box_mm: Some([[0.0, 1.0], [5.0, 5.0], [0.0, 1.0]]),
            line_of_sight: None,
        };
        let e = empty.check().unwrap_err().to_string();
        assert!(e.contains("reach_box_mm") && e.contains("along y"), "{e}");
        let angle = Sight {
            reach_box_mm: None,
            line_of_sight: Some(LineOfSight {
                position_mm: [0.0; 3],
                max_incidence_deg: 0.0,
            }),
        };
        let e = angle.check().unwrap_err().to_string();
        assert!(e.contains("max_incidence_deg"), "{e}");
        let nan = Sight {
            reach_box_mm: None,
            line_of_sight: Some(LineOfSight {
                position_mm: [0.0, f64::NAN, 0.0],
                max_incidence_deg: 30.0,
            }),
        };
        assert!(nan.check().unwrap_err().to_string().contains("position_mm"));
    }
}
