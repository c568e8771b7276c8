//! The measurement system as it is: a Nikon Metrology K600-10 class
//! photogrammetry system (three linear CCD cameras tracking infra-red LEDs),
//! standing somewhere in the cell.
//!
//! **Frame.** The cameras measure in their own frame R_m, an unknown rigid
//! transform `x_meas_base` away from the robot base: the geometric campaign's
//! files hold poses in R_m, and the calibration must register R_m with the
//! robot, as the paper did (section 3.1) before expressing its later
//! measurements in R0. The twin's camera stands 3.4 m in front of the robot,
//! turned 155 deg about the vertical to face it and tilted 1.5 deg (a tripod
//! is never level).
//!
//! **Noise.** The K600-10's published single-point accuracy is 37 um (the
//! paper, section 3.1, from the manufacturer), read here as the RMS of the
//! 3D error of one LED: `s = 37 / sqrt(3) = 21.4 um` per axis. The tool
//! carries a target of `n = 3` LEDs ("three or more", section 3.1) on a
//! circle of radius `R = 60 mm` in the plane normal to the tool axis,
//! centred on the TCP. Two derivations of the target's noise exist; the
//! twin publishes both and uses the one that assumes nothing in its own
//! favour for each quantity:
//! - **position, used: `s` per axis (21.4 um).** A photogrammetry
//!   system's single-point error is mostly systematic (the cameras'
//!   calibration, refraction in the room's air, the LED's apparent
//!   centre), so the errors of three LEDs 100 mm apart are strongly
//!   correlated; their centroid is then no better than one LED. The
//!   independent-LED derivation, `s / sqrt(n)` = 12.3 um per axis
//!   ([`Photogrammetry::position_std_per_axis_independent_leds`]), holds
//!   only if the three errors were independent, which the source does not
//!   say; it is published, not used.
//! - **orientation, used: the rigid fit of independent LEDs.** A least-squares
//!   rigid fit of `n` points with independent isotropic noise `s` gives
//!   the rotation with covariance `s^2 (sum_i |r_i|^2 I - r_i r_i^T)^-1`
//!   (the small-rotation linearisation `dp_i = dphi x r_i` solved in least
//!   squares). For `n >= 3` points evenly spaced on a circle,
//!   `sum r_i r_i^T = (n R^2 / 2) diag(1, 1, 0)` in the target frame, so the
//!   matrix is `diag(n R^2 / 2, n R^2 / 2, n R^2)`: `s / (R sqrt(n / 2))`
//!   about the two in-plane axes (2.91e-4 rad, 0.0167 deg) and
//!   `s / (R sqrt(n))` about the tool axis (2.06e-4 rad, 0.0118 deg).
//!   Here independence is the pessimistic reading: errors common to the
//!   three LEDs shift the target without turning it.
//!
//! These standard deviations go into the files (orientation per base axis:
//! the in-plane value for x0 and y0, the axial one for z0, the tool pointing
//! down). The paper averages 100 samples per pose; the single-point accuracy
//! is mostly systematic over the 5 s of a pose, so the twin does not divide
//! it by 10.

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use rand::Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::Serialize;

use super::terms::TwinTerm;

/// A photogrammetry system and the LED target on the tool.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Photogrammetry {
    /// Pose of the robot base in the camera frame, `x_meas_base` (unknown
    /// to the calibration; identity when the term is off).
    pub x_meas_base: Isometry3<f64>,
    /// RMS 3D error of one LED (m; default 37e-6, the K600-10).
    pub single_point_accuracy_m: f64,
    /// Number of LEDs on the target (default 3).
    pub led_count: usize,
    /// Radius of the LED circle (m; default 0.06).
    pub led_radius_m: f64,
}

impl Default for Photogrammetry {
    fn default() -> Self {
        let rotation = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 155f64.to_radians())
            * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), 1.5f64.to_radians());
        Self {
            x_meas_base: Isometry3::from_parts(Translation3::new(3.4, 0.8, -0.35), rotation),
            single_point_accuracy_m: 37e-6,
            led_count: 3,
            led_radius_m: 0.06,
        }
    }
}

impl Photogrammetry {
    /// Standard deviation of one LED coordinate (m).
    pub fn led_std_per_axis(&self) -> f64 {
        self.single_point_accuracy_m / 3f64.sqrt()
    }

    /// Standard deviation of each coordinate of the target origin (m): one
    /// LED's, since the LEDs' errors are mostly systematic and so
    /// correlated over a small target (module docs, "Noise"); the value
    /// the twin's measurements draw and write.
    pub fn position_std_per_axis(&self) -> f64 {
        self.led_std_per_axis()
    }

    /// Standard deviation of each coordinate of the target origin (m) if
    /// the LEDs' errors were independent: `s / sqrt(n)`. Published beside
    /// [`Photogrammetry::position_std_per_axis`] as the optimistic
    /// derivation; no measurement uses it.
    pub fn position_std_per_axis_independent_leds(&self) -> f64 {
        self.led_std_per_axis() / (self.led_count.max(1) as f64).sqrt()
    }

    /// Standard deviations of the target rotation about its own x, y (in
    /// the LED plane) and z (the tool axis) (rad), from the rigid fit.
    pub fn orientation_std_target(&self) -> Vector3<f64> {
        let n = self.led_count.max(3) as f64;
        let s = self.led_std_per_axis();
        let in_plane = s / (self.led_radius_m * (n / 2.0).sqrt());
        let axial = s / (self.led_radius_m * n.sqrt());
        Vector3::new(in_plane, in_plane, axial)
    }

    /// Measures the pose `x_base_tcp`: the camera's reading of the target
    /// (`x_meas_tcp` with noise when `noise`), in the camera frame when
    /// `registered_in_base` is false, else carried back into R0 with the
    /// frame (as the paper's later campaigns are).
    pub fn measure(
        &self,
        x_base_tcp: &Isometry3<f64>,
        noise: bool,
        registered_in_base: bool,
        rng: &mut impl Rng,
    ) -> Isometry3<f64> {
        let mut x_meas_tcp = self.x_meas_base * x_base_tcp;
        if noise {
            let sp = self.position_std_per_axis();
            let so = self.orientation_std_target();
            let mut draw = || -> f64 { StandardNormal.sample(rng) };
            let dp = Vector3::new(draw() * sp, draw() * sp, draw() * sp);
            let dphi = Vector3::new(draw() * so.x, draw() * so.y, draw() * so.z);
            // Orientation noise in the target frame (right-multiplied).
            x_meas_tcp = Isometry3::from_parts(
                Translation3::from(x_meas_tcp.translation.vector + dp),
                x_meas_tcp.rotation * UnitQuaternion::from_scaled_axis(dphi),
            );
        }
        if registered_in_base {
            self.x_meas_base.inverse() * x_meas_tcp
        } else {
            x_meas_tcp
        }
    }

    /// The measurement-frame term as published.
    pub fn frame_term(&self, enabled: bool) -> TwinTerm {
        let t = self.x_meas_base.translation.vector;
        TwinTerm {
            name: "measurement_frame".into(),
            magnitude: format!(
                "camera frame {:.2} m from the base ({:.2}, {:.2}, {:.2} m), turned {:.1} deg; the geometric calibration registers it",
                t.norm(),
                t.x,
                t.y,
                t.z,
                self.x_meas_base.rotation.angle().to_degrees()
            ),
            source: "the paper's section 3.1: the K600-10 frame is registered to the robot base before the later campaigns".into(),
            enabled,
        }
    }

    /// The noise term as published.
    pub fn noise_term(&self, enabled: bool) -> TwinTerm {
        let so = self.orientation_std_target();
        TwinTerm {
            name: "measurement_noise".into(),
            magnitude: format!(
                "{:.1} um per axis on the target origin ({:.0} um single-point accuracy, the {} LEDs' errors taken as correlated; {:.1} um if they were independent, not used); orientation {:.4} deg about the in-plane axes and {:.4} deg about the tool axis, derived from the LED spread ({:.0} mm radius)",
                self.position_std_per_axis() * 1e6,
                self.single_point_accuracy_m * 1e6,
                self.led_count,
                self.position_std_per_axis_independent_leds() * 1e6,
                so.x.to_degrees(),
                so.z.to_degrees(),
                self.led_radius_m * 1e3
            ),
            source: "Nikon Metrology K600-10 single-point accuracy 37 um (the paper, section 3.1); orientation from the least-squares rigid fit of the LEDs (flexcal_twin::truth::measurement)".into(),
            enabled,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn the_position_noise_is_one_leds_and_the_independent_derivation_divides_by_root_n() {
        let p = Photogrammetry::default();
        let s = 37e-6 / 3f64.sqrt();
        assert!((p.position_std_per_axis() - s).abs() < 1e-15);
        assert!((p.position_std_per_axis_independent_leds() - s / 3f64.sqrt()).abs() < 1e-15);
    }

    #[test]
    fn orientation_noise_matches_a_rigid_fit_of_noisy_leds() {
        // Fit the rotation of 3 noisy LEDs many times: the spread of the
        // fitted small rotation is what the formula says.
        let p = Photogrammetry::default();
        let n = p.led_count;
        let r = p.led_radius_m;
        let leds: Vec<Vector3<f64>> = (0..n)
            .map(|i| {
                let a = std::f64::consts::TAU * i as f64 / n as f64;
                Vector3::new(r * a.cos(), r * a.sin(), 0.0)
            })
            .collect();
        let mut info = nalgebra::Matrix3::zeros();
        for l in &leds {
            info += nalgebra::Matrix3::identity() * l.norm_squared() - l * l.transpose();
        }
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let s = p.led_std_per_axis();
        let mut sum_sq = Vector3::zeros();
        let trials = 20000;
        for _ in 0..trials {
            // Small-rotation least squares: info dphi = sum r_i x dp_i.
            let mut rhs = Vector3::zeros();
            let noise: Vec<Vector3<f64>> = (0..n)
                .map(|_| {
                    Vector3::from_fn(|_, _| {
                        let z: f64 = StandardNormal.sample(&mut rng);
                        z * s
                    })
                })
                .collect();
            let mean = noise.iter().sum::<Vector3<f64>>() / n as f64;
            for (l, e) in leds.iter().zip(&noise) {
                rhs += l.cross(&(e - mean));
            }
            let dphi = info.lu().solve(&rhs).unwrap();
            sum_sq += dphi.component_mul(&dphi);
        }
        let rms = (sum_sq / trials as f64).map(f64::sqrt);
        let expected = p.orientation_std_target();
        for k in 0..3 {
            assert!(
                (rms[k] / expected[k] - 1.0).abs() < 0.03,
                "{rms} vs {expected}"
            );
        }
    }
}
