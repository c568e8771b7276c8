//! Non-linear drive stiffness of joints 2 and 8: a lost-motion zone about
//! zero torque and a stiffness that grows with torque, as gear reducers
//! behave (strain-wave and RV gears).
//!
//! The twin's FE structure carries the linear part of each drive (the ball
//! screw as an axial spring between its pivots, see
//! [`structure`](super::structure)); in series with it, each drive turns its
//! joint by the extra angle
//!
//! ```text
//! theta(T) = sign(T) [ theta_lm / 2 * min(|T| / T_lm, 1)
//!                      + (T_h / K1) ln(1 + |T| / T_h) ]
//! ```
//!
//! for the joint torque `T` (N.m):
//! - lost motion: within `|T| < T_lm` the joint turns through `+-theta_lm / 2`
//!   almost freely. Reducer catalogues define lost motion as the rotation
//!   over +-3 % of the rated torque and give about 1 arcmin for the sizes
//!   that drive the main axes of 100-kg-class robots (Nabtesco RV-E series:
//!   lost motion 1 arcmin at +-3 % rated torque; Harmonic Drive CSF/CSG:
//!   hysteresis loss about 1 arcmin). The twin takes `theta_lm = 1 arcmin`
//!   and `T_lm = 3 %` of a rated torque of 8 kN.m (about twice the largest
//!   gravity torque of joints 2 and 8 on the grid (65)), i.e. 240 N.m;
//! - hardening: the tangent stiffness beyond the lost motion is
//!   `K1 (1 + |T| / T_h)`. Harmonic Drive catalogues give the torsional
//!   stiffness in three segments with `K3 / K1` about 2 to 3, the third
//!   segment starting near 30 % of the rated torque; `T_h = 1600 N.m` makes
//!   the stiffness 2.5 K1 at 2.4 kN.m (30 % of 8 kN.m). `K1 = 1e7 N.m/rad`
//!   is of the order of the torsional rigidity Nabtesco gives for RV-E
//!   reducers of a few kN.m (about 2000 N.m/arcmin, 7e6 N.m/rad, for the
//!   3 kN.m size).
//!
//! A joint loaded by gravity sits beyond its lost motion; an external load
//! that reverses the torque crosses it, and loads of 300 to 1100 N meet
//! different tangent stiffnesses: the response is not proportional to the
//! load, which no linear model identified by flexcal contains.

use serde::Serialize;

use super::terms::TwinTerm;

const ARCMIN: f64 = std::f64::consts::PI / (180.0 * 60.0);

/// The torque-rotation law of one drive (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DriveLaw {
    /// Total lost motion `theta_lm` (rad; default 1 arcmin).
    pub lost_motion_rad: f64,
    /// Torque over which the lost motion is taken up, `T_lm` (N.m; default
    /// 240 = 3 % of 8 kN.m).
    pub lost_motion_torque_nm: f64,
    /// Stiffness at small torque beyond the lost motion, `K1` (N.m/rad;
    /// default 1e7).
    pub initial_stiffness_nm_rad: f64,
    /// Torque at which the tangent stiffness has doubled, `T_h` (N.m;
    /// default 1600).
    pub hardening_torque_nm: f64,
}

impl Default for DriveLaw {
    fn default() -> Self {
        Self {
            lost_motion_rad: ARCMIN,
            lost_motion_torque_nm: 240.0,
            initial_stiffness_nm_rad: 1e7,
            hardening_torque_nm: 1600.0,
        }
    }
}

impl DriveLaw {
    /// Extra joint rotation (rad) under the joint torque `torque_nm` (N.m).
    pub fn rotation(&self, torque_nm: f64) -> f64 {
        let t = torque_nm.abs();
        let lost = 0.5 * self.lost_motion_rad * (t / self.lost_motion_torque_nm).min(1.0);
        let elastic = self.hardening_torque_nm / self.initial_stiffness_nm_rad
            * (t / self.hardening_torque_nm).ln_1p();
        torque_nm.signum() * (lost + elastic)
    }

    /// Tangent stiffness `dT / dtheta` (N.m/rad) at `torque_nm`.
    pub fn tangent_stiffness(&self, torque_nm: f64) -> f64 {
        let t = torque_nm.abs();
        let elastic = 1.0 / (self.initial_stiffness_nm_rad * (1.0 + t / self.hardening_torque_nm));
        let lost = if t < self.lost_motion_torque_nm {
            0.5 * self.lost_motion_rad / self.lost_motion_torque_nm
        } else {
            0.0
        };
        1.0 / (elastic + lost)
    }

    /// The term as published.
    pub fn term(&self, enabled: bool) -> TwinTerm {
        TwinTerm {
            name: "drive_nonlinearity".into(),
            magnitude: format!(
                "joints 2 and 8: lost motion {:.2} arcmin over +-{:.0} N.m, then stiffness {:.1e} N.m/rad growing as (1 + |T| / {:.0} N.m), in series with the ball screws",
                self.lost_motion_rad / ARCMIN,
                self.lost_motion_torque_nm,
                self.initial_stiffness_nm_rad,
                self.hardening_torque_nm
            ),
            source: "gear-reducer catalogues: Nabtesco RV-E (lost motion 1 arcmin at +-3 % rated torque, torsional rigidity about 2000 N.m/arcmin for the 3 kN.m size), Harmonic Drive CSF/CSG (three-segment torsional stiffness, K3/K1 about 2-3); rated torque 8 kN.m, about twice the largest gravity torque of joints 2 and 8".into(),
            enabled,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_law_is_odd_monotonic_and_hardens() {
        let law = DriveLaw::default();
        let mut last = f64::NEG_INFINITY;
        for k in -100..=100 {
            let t = 50.0 * k as f64;
            let r = law.rotation(t);
            assert!((r + law.rotation(-t)).abs() < 1e-15);
            assert!(r > last || k == -100);
            last = r;
        }
        // Soft inside the lost motion, stiffer and stiffer beyond it.
        assert!(law.tangent_stiffness(100.0) < 0.5 * law.tangent_stiffness(300.0));
        // (1 + 3000 / 1600) / (1 + 300 / 1600) = 2.42.
        assert!(law.tangent_stiffness(3000.0) > 2.4 * law.tangent_stiffness(300.0));
        // Tangent stiffness against central differences.
        for t in [500.0, 2000.0, -4000.0] {
            let h = 1e-3;
            let fd = 2.0 * h / (law.rotation(t + h) - law.rotation(t - h));
            assert!((fd / law.tangent_stiffness(t) - 1.0).abs() < 1e-6, "{t}");
        }
        // The lost motion is taken up at T_lm.
        let at = law.rotation(law.lost_motion_torque_nm)
            - law.hardening_torque_nm / law.initial_stiffness_nm_rad
                * (law.lost_motion_torque_nm / law.hardening_torque_nm).ln_1p();
        assert!((at - 0.5 * law.lost_motion_rad).abs() < 1e-15);
    }
}
