//! Non-linear drive stiffness of joints 2 and 8: a lost-motion zone about
//! zero torque and a stiffness that grows with torque, as gear reducers
//! behave (strain-wave and RV gears).
//!
//! The twin's FE structure carries the linear part of each drive (the ball
//! screw as an axial spring between its pivots, see
//! [`structure`](super::structure)); in series with it, each drive turns its
//! joint by an extra angle, for the joint torque `T` (N.m) and the state of its lost motion `l`:
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
//!   3 kN.m size);
//! - memory (hysteresis): the lost motion is the play of the gear mesh,
//!   held by the mesh's friction. Where the joint sits inside its play
//!   depends on the direction it was last loaded from: a generalised play
//!   operator keeps the state `l` inside the band
//!   `[L(T - T_f), L(T + T_f)]` (`L(T) = theta_lm / 2 clamp(T / T_lm, -1,
//!   1)`), moving only when an edge of the band pushes it. With
//!   `T_f = T_lm` the rotation at zero torque differs by the whole lost
//!   motion (1 arcmin) between a joint unloaded from above and one
//!   unloaded from below: the catalogues' hysteresis loss (Harmonic Drive
//!   CSF/CSG: hysteresis loss at most 1 arcmin for ratios of 80 and up;
//!   Nabtesco RV-E: backlash at most 1 arcmin). A joint that has just been
//!   driven sits on the flank it was driven against (`l = +-theta_lm / 2`
//!   in the direction of motion, [`DriveLaw::approach`]), then the band of
//!   its torque clamps it.
//!
//! So the rotation is
//!
//! ```text
//! theta = l + sign(T) (T_h / K1) ln(1 + |T| / T_h)
//! ```
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
    /// Friction torque of the mesh that holds the lost motion, `T_f` (N.m;
    /// default 240 = `T_lm`: the whole lost motion as hysteresis loss).
    pub friction_torque_nm: f64,
}

impl Default for DriveLaw {
    fn default() -> Self {
        Self {
            lost_motion_rad: ARCMIN,
            lost_motion_torque_nm: 240.0,
            initial_stiffness_nm_rad: 1e7,
            hardening_torque_nm: 1600.0,
            friction_torque_nm: 240.0,
        }
    }
}

impl DriveLaw {
    /// The lost motion taken up without friction at `torque_nm`, `L(T)`
    /// (rad).
    fn play(&self, torque_nm: f64) -> f64 {
        0.5 * self.lost_motion_rad * (torque_nm / self.lost_motion_torque_nm).clamp(-1.0, 1.0)
    }

    /// The elastic part of the rotation (rad) at `torque_nm` (N.m).
    pub fn elastic_rotation(&self, torque_nm: f64) -> f64 {
        let t = torque_nm.abs();
        torque_nm.signum() * self.hardening_torque_nm / self.initial_stiffness_nm_rad
            * (t / self.hardening_torque_nm).ln_1p()
    }

    /// Extra joint rotation (rad) under the joint torque `torque_nm` (N.m),
    /// updating `lost_motion` (rad), the state of the play (see the module
    /// documentation).
    pub fn rotation(&self, torque_nm: f64, lost_motion: &mut f64) -> f64 {
        let lo = self.play(torque_nm - self.friction_torque_nm);
        let hi = self.play(torque_nm + self.friction_torque_nm);
        *lost_motion = lost_motion.clamp(lo, hi);
        *lost_motion + self.elastic_rotation(torque_nm)
    }

    /// The state of the play after the joint was driven in the direction
    /// of `direction` (its sign; 0 leaves the state as it is).
    pub fn approach(&self, direction: f64, lost_motion: &mut f64) {
        if direction != 0.0 {
            *lost_motion = 0.5 * self.lost_motion_rad * direction.signum();
        }
    }

    /// The term as published.
    pub fn term(&self, enabled: bool) -> TwinTerm {
        TwinTerm {
            name: "drive_nonlinearity".into(),
            magnitude: format!(
                "joints 2 and 8: lost motion {:.2} arcmin over +-{:.0} N.m held by {:.0} N.m of mesh friction (hysteresis: the position in the play depends on the direction last loaded or driven from), then stiffness {:.1e} N.m/rad growing as (1 + |T| / {:.0} N.m), in series with the ball screws",
                self.lost_motion_rad / ARCMIN,
                self.lost_motion_torque_nm,
                self.friction_torque_nm,
                self.initial_stiffness_nm_rad,
                self.hardening_torque_nm
            ),
            source: "gear-reducer catalogues: Nabtesco RV-E (lost motion 1 arcmin at +-3 % rated torque, backlash 1 arcmin; torsional rigidity about 2000 N.m/arcmin for the 3 kN.m size), Harmonic Drive CSF/CSG (three-segment torsional stiffness, K3/K1 about 2-3, hysteresis loss at most 1 arcmin); rated torque 8 kN.m, about twice the largest gravity torque of joints 2 and 8".into(),
            enabled,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn loading_is_monotonic_and_hardens() {
        let law = DriveLaw::default();
        let mut state = 0.0;
        let mut last = f64::NEG_INFINITY;
        for k in -100..=100 {
            let r = law.rotation(50.0 * k as f64, &mut state);
            assert!(r > last, "{k}");
            last = r;
        }
        // Tangent stiffness of the elastic part K1 (1 + |T| / T_h), by central differences.
        for t in [500.0, 2000.0, -4000.0] {
            let h = 1e-3;
            let fd = 2.0 * h / (law.elastic_rotation(t + h) - law.elastic_rotation(t - h));
            let expected = law.initial_stiffness_nm_rad * (1.0 + t.abs() / law.hardening_torque_nm);
            assert!((fd / expected - 1.0).abs() < 1e-6, "{t}");
        }
    }

    #[test]
    fn the_rotation_at_a_torque_depends_on_the_direction_it_was_loaded_from() {
        let law = DriveLaw::default();
        let (mut from_above, mut from_below) = (0.0, 0.0);
        law.rotation(3000.0, &mut from_above);
        law.rotation(-3000.0, &mut from_below);
        // Unloaded to zero torque: the whole lost motion apart (the hysteresis loss).
        let a = law.rotation(0.0, &mut from_above);
        let b = law.rotation(0.0, &mut from_below);
        assert!((a - b - law.lost_motion_rad).abs() < 1e-15, "{a} {b}");
        // Beyond T_lm + T_f both sit on the same flank: no memory left.
        let a = law.rotation(600.0, &mut from_above);
        let b = law.rotation(600.0, &mut from_below);
        assert!((a - b).abs() < 1e-15);
        // A joint driven downwards sits on the lower flank until a torque
        // of more than T_f - T_lm upwards pushes it up.
        let mut driven = 0.0;
        law.approach(-1.0, &mut driven);
        assert_eq!(driven, -0.5 * law.lost_motion_rad);
        let r = law.rotation(-100.0, &mut driven);
        assert!((r - (-0.5 * law.lost_motion_rad + law.elastic_rotation(-100.0))).abs() < 1e-15);
        // 100 N.m the other way pushes it up to L(100 - T_f).
        let r = law.rotation(100.0, &mut driven);
        let expected = 0.5 * law.lost_motion_rad * (100.0 - 240.0) / 240.0;
        assert!(
            (r - expected - law.elastic_rotation(100.0)).abs() < 1e-15,
            "{r}"
        );
    }
}
