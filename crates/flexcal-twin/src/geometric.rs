//! The virtual IR-663's geometric campaign (section 3.2 of the reference
//! paper): the twin ([`TwinRobot`]) commanded to 27 identification and 16
//! validation poses of box (59), measured by its photogrammetry system
//! ([`Photogrammetry`]), written as flexcal measurement files.
//!
//! - Truth: every term of [`crate::truth`] that a geometric campaign meets:
//!   the geometric errors of Appendix C
//!   ([`IR663_TRUE_ERRORS`]), the
//!   robot's own weight through its FE structure, the drives' lost motion
//!   and hardening under that weight, the joints' transmission errors, and
//!   optionally a temperature drift over the campaign (the pose order is
//!   the measurement order).
//! - Poses: the 3 x 3 x 3 grid of box (59) (x 1.4-2.1, y -0.3-0.3,
//!   z 1.4-1.7 m) for identification and 16 seeded random points of the box
//!   for validation, the tool pointing down tilted by up to
//!   [`GeometricCampaignOptions::max_tilt`](crate::geometric::GeometricCampaignOptions::max_tilt) and turned at random about its axis;
//!   and a second validation set of 16 seeded random points **outside**
//!   box (59) ([`OUTSIDE_BOX`]: x 1.3-2.15, y -0.5-0.5, z 0.95-2.05 m, at
//!   least 0.1 m from the box), where the robot's own weight loads the
//!   joints differently from every identification pose, so that what the
//!   geometric model absorbed inside the box no longer holds; and a third,
//!   loaded validation set: 16 more seeded random points of box (59)
//!   measured with a payload hung at the TCP (by default the forming
//!   head, [`crate::forming::FORMING_HEAD_WEIGHT_N`]), a load no
//!   identification pose carried.
//!   The commanded q come from the nominal inverse model (as a controller
//!   would), the measured poses from the twin.
//! - Measurement system: the K600-10 class photogrammetry of
//!   [`crate::truth::measurement`]: poses in the camera frame, an unknown
//!   rigid transform away from the robot base (the calibration registers
//!   it), noise derived from the instrument's published accuracy and the
//!   LED target; the standard deviations are written into the files. The
//!   target is the TCP.

use std::path::Path;

use flexcal_calib::{Measurement, MeasurementSet};
use flexcal_kinematics::{
    Data, InverseOptions, InverseTarget, KinematicsError, Model, RobotDescription,
    actuated_from_joint_angles, inverse_pose,
};
use nalgebra::{Isometry3, UnitQuaternion, Vector3, Vector6};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

pub use crate::truth::geometry::{IR663_TRUE_ERRORS, ir663_true_params};
use crate::truth::{
    FormingTruth, Photogrammetry, TruthError, TruthSwitches, TwinRobot, TwinTerms, twin_terms,
};

/// The format's error (a measurement set that cannot be formed or
/// written) in words: the twin keeps no error type of the crates it tests.
fn format_error(e: impl std::fmt::Display) -> GeometricTwinError {
    GeometricTwinError::Format(e.to_string())
}

/// Errors of the geometric twin.
#[derive(Debug, thiserror::Error)]
pub enum GeometricTwinError {
    /// The robot model failed (naming the step).
    #[error("{step}: {source}")]
    Kinematics {
        /// What was being done.
        step: String,
        /// The model's error.
        #[source]
        source: KinematicsError,
    },
    /// A measurement set could not be formed or written (the format's
    /// message, naming the set or the file).
    #[error("{0}")]
    Format(String),
    /// A file could not be written.
    #[error(transparent)]
    Io(#[from] flexcal_io::IoError),
    /// The twin's truth failed.
    #[error(transparent)]
    Truth(Box<TruthError>),
    /// An option is out of range.
    #[error("invalid option `{name}`: {reason}")]
    InvalidOption {
        /// Option name.
        name: &'static str,
        /// What is wrong.
        reason: String,
    },
}

impl From<TruthError> for GeometricTwinError {
    fn from(e: TruthError) -> Self {
        Self::Truth(Box::new(e))
    }
}

/// Settings of [`geometric_campaign`].
#[derive(Debug, Clone, PartialEq)]
pub struct GeometricCampaignOptions {
    /// Seed of every random draw (pose jitter, tilts, noise).
    pub seed: u64,
    /// Number of random validation poses (default 16).
    pub n_validation: usize,
    /// Number of random validation poses outside box (59) (default 16).
    pub n_validation_outside: usize,
    /// Number of random validation poses of box (59) measured with the
    /// payload hung at the TCP (default 16).
    pub n_validation_loaded: usize,
    /// The loaded validation set's payload as weighed (N; default
    /// [`crate::forming::FORMING_HEAD_WEIGHT_N`], the forming head of the
    /// forming experiment), hung at the TCP: its centre of mass at the
    /// TCP. The twin's true weight differs by the scale's accuracy
    /// ([`crate::truth::FormingTruth::true_payload_n`]).
    pub payload_weighed_n: f64,
    /// Largest tilt of the tool axis away from vertical (rad; default 20 deg).
    pub max_tilt: f64,
    /// Which truth terms are on (default all but the temperature drift).
    pub switches: TruthSwitches,
    /// The measurement system (default the K600-10 class system of
    /// [`crate::truth::measurement`]).
    pub camera: Photogrammetry,
}

impl Default for GeometricCampaignOptions {
    fn default() -> Self {
        Self {
            seed: 663,
            n_validation: 16,
            n_validation_outside: 16,
            n_validation_loaded: 16,
            payload_weighed_n: crate::forming::FORMING_HEAD_WEIGHT_N,
            max_tilt: 20f64.to_radians(),
            switches: TruthSwitches::default(),
            camera: Photogrammetry::default(),
        }
    }
}

/// A generated campaign: the truth and the two measurement sets.
#[derive(Debug, Clone)]
pub struct GeometricCampaign {
    /// The nominal model.
    pub model: Model,
    /// True parameter vector xi (m, rad) at the start of the campaign.
    pub true_xi: Vec<f64>,
    /// The true robot as a description (mm, deg): the geometry only.
    pub true_description: RobotDescription,
    /// The true measurement frame `x_meas_base` (identity when the term is
    /// off).
    pub x_meas_base: Isometry3<f64>,
    /// The truth's terms.
    pub terms: TwinTerms,
    /// 27 poses of the 3 x 3 x 3 grid of box (59).
    pub identification: MeasurementSet,
    /// Random poses of box (59).
    pub validation: MeasurementSet,
    /// Random poses outside box (59), inside [`OUTSIDE_BOX`].
    pub validation_outside: MeasurementSet,
    /// Random poses of box (59) measured with the payload hung at the TCP
    /// (measured last: the payload is mounted after the other sets).
    pub validation_loaded: MeasurementSet,
    /// The payload of `validation_loaded` as weighed (N): what the user
    /// knows.
    pub payload_weighed_n: f64,
    /// The payload's true weight (N): what the twin hangs.
    pub payload_true_n: f64,
}

/// Box (59) of the paper, where the identification and the first
/// validation poses lie: `[x, y, z]` ranges (m).
pub const BOX_59: [[f64; 2]; 3] = [[1.4, 2.1], [-0.3, 0.3], [1.4, 1.7]];

/// The region the outside validation poses are drawn from: `[x, y, z]`
/// ranges (m), the reach of the elastic campaign's grid (65) widened
/// sideways; a draw closer than [`OUTSIDE_MARGIN`] to box (59) is drawn
/// again.
pub const OUTSIDE_BOX: [[f64; 2]; 3] = [[1.3, 2.15], [-0.5, 0.5], [0.95, 2.05]];

/// Smallest distance of an outside validation pose from box (59) (m).
pub const OUTSIDE_MARGIN: f64 = 0.1;

/// Distance (m) of `p` from box (59) (zero inside).
pub fn distance_from_box_59(p: &Vector3<f64>) -> f64 {
    let mut d2 = 0.0;
    for (k, [lo, hi]) in BOX_59.iter().enumerate() {
        let excess = (lo - p[k]).max(p[k] - hi).max(0.0);
        d2 += excess * excess;
    }
    f64::sqrt(d2)
}

impl GeometricCampaign {
    /// What `flexcal twin geometric` prints after
    /// [`write_geometric_campaign`] into `dir` (campaign of `seed`): the
    /// pose counts and files, then how to calibrate from them; lines ended
    /// by newlines.
    pub fn summary_text(&self, seed: u64, dir: &Path) -> String {
        format!(
            "virtual IR-663 geometric campaign (seed {seed}): {} identification + {} validation poses, \
             truth.toml and truth.json written to {dir}\n\
             measurements in the camera frame, which the calibration registers (target = TCP): calibrate with \
             `flexcal calibrate --robot ir663 --data {dir}/identification.csv --validate {dir}/validation.csv --fixed-target` \
             ({} more validation poses outside box (59) in {dir}/validation_outside.csv, \
             {} in box (59) with {:.0} N hung at the TCP in {dir}/validation_loaded.csv)\n",
            self.identification.len(),
            self.validation.len(),
            self.validation_outside.len(),
            self.validation_loaded.len(),
            self.payload_weighed_n,
            dir = dir.display()
        )
    }
}

/// Generates the geometric campaign of the virtual IR-663.
///
/// # Errors
/// Invalid noise levels, a target of box (59) the nominal inverse model
/// cannot reach (not expected with the built-in robot).
pub fn geometric_campaign(
    options: &GeometricCampaignOptions,
) -> Result<GeometricCampaign, GeometricTwinError> {
    if !(options.payload_weighed_n.is_finite() && options.payload_weighed_n >= 0.0) {
        return Err(GeometricTwinError::InvalidOption {
            name: "payload_weighed_n",
            reason: format!(
                "the loaded validation's payload must be finite and >= 0 N, found {}",
                options.payload_weighed_n
            ),
        });
    }
    if !(options.max_tilt.is_finite() && options.max_tilt >= 0.0) {
        return Err(GeometricTwinError::InvalidOption {
            name: "max_tilt",
            reason: format!("must be finite and >= 0, found {}", options.max_tilt),
        });
    }
    let camera = &options.camera;
    if !(camera.single_point_accuracy_m.is_finite()
        && camera.single_point_accuracy_m >= 0.0
        && camera.led_radius_m > 0.0
        && camera.led_count >= 3)
    {
        return Err(GeometricTwinError::InvalidOption {
            name: "camera",
            reason: format!(
                "need a finite accuracy >= 0, 3 or more LEDs and a positive LED radius, found {camera:?}"
            ),
        });
    }
    let kin = |step: &str| {
        let step = step.to_string();
        move |source| GeometricTwinError::Kinematics { step, source }
    };
    let twin = TwinRobot::new(options.switches)?;
    let model = twin.model().clone();
    let true_xi = twin.true_xi().to_vec();
    let true_description = model
        .description_with_params(&true_xi)
        .map_err(kin("true description"))?;
    let mut rng = ChaCha8Rng::seed_from_u64(options.seed);
    let steps = |[lo, hi]: [f64; 2]| [lo, 0.5 * (lo + hi), hi];
    // Serpentine order so each inverse solution seeds the next.
    let mut grid = Vec::new();
    for (i, x) in steps(BOX_59[0]).into_iter().enumerate() {
        for (j, y) in steps(BOX_59[1]).into_iter().enumerate() {
            let mut zs = steps(BOX_59[2]);
            if (i + j) % 2 == 1 {
                zs.reverse();
            }
            grid.extend(zs.iter().map(|&z| Vector3::new(x, y, z)));
        }
    }
    let random = box_points(&mut rng, options.n_validation);
    let outside = outside_points(options.seed, options.n_validation_outside);
    // Its own stream, so that the other sets do not depend on it.
    let mut loaded_rng = ChaCha8Rng::seed_from_u64(options.seed ^ LOADED_STREAM);
    let loaded = box_points(&mut loaded_rng, options.n_validation_loaded);
    // Identification then validation, in measurement order (the
    // temperature drift runs over all four sets).
    let total = (grid.len() + random.len() + outside.len() + loaded.len()).max(2) as f64 - 1.0;
    let unloaded = Vector6::zeros();
    // The noise has its own stream, so that the poses do not depend on
    // whether the noise is on.
    let mut noise_rng = ChaCha8Rng::seed_from_u64(options.seed ^ NOISE_STREAM);
    let identification = measure(
        &twin,
        &grid,
        0,
        total,
        options,
        &mut rng,
        &mut noise_rng,
        ("identification", &unloaded),
    )?;
    let validation = measure(
        &twin,
        &random,
        grid.len(),
        total,
        options,
        &mut rng,
        &mut noise_rng,
        ("validation", &unloaded),
    )?;
    // Its own pose stream, so that the other sets do not depend on it.
    let mut outside_rng = ChaCha8Rng::seed_from_u64(options.seed ^ OUTSIDE_STREAM);
    let validation_outside = measure(
        &twin,
        &outside,
        grid.len() + random.len(),
        total,
        options,
        &mut outside_rng,
        &mut noise_rng,
        ("validation_outside", &unloaded),
    )?;
    // The payload hangs at the TCP: its weight, base axes, no moment about
    // the TCP.
    let payload_true_n = FormingTruth::default()
        .true_payload_n(options.payload_weighed_n, options.switches.payload_error);
    let payload = Vector6::new(0.0, 0.0, -payload_true_n, 0.0, 0.0, 0.0);
    let validation_loaded = measure(
        &twin,
        &loaded,
        grid.len() + random.len() + outside.len(),
        total,
        options,
        &mut loaded_rng,
        &mut noise_rng,
        ("validation_loaded", &payload),
    )?;
    let x_meas_base = if options.switches.measurement_frame {
        options.camera.x_meas_base
    } else {
        Isometry3::identity()
    };
    let terms = twin_terms(&twin, &options.camera, &FormingTruth::default());
    Ok(GeometricCampaign {
        model,
        true_xi,
        true_description,
        x_meas_base,
        terms,
        identification,
        validation,
        validation_outside,
        validation_loaded,
        payload_weighed_n: options.payload_weighed_n,
        payload_true_n,
    })
}

/// Mixed into the seed of the noise stream.
const NOISE_STREAM: u64 = 0x6e6f_6973_6500;
/// Mixed into the seed of the outside validation poses' stream.
const OUTSIDE_STREAM: u64 = 0x6f75_7473_6964;
/// Mixed into the seed of the loaded validation poses' stream.
const LOADED_STREAM: u64 = 0x6c6f_6164_6564;

/// `n` seeded random points of box (59).
fn box_points(rng: &mut ChaCha8Rng, n: usize) -> Vec<Vector3<f64>> {
    (0..n)
        .map(|_| {
            Vector3::new(
                rng.random_range(BOX_59[0][0]..=BOX_59[0][1]),
                rng.random_range(BOX_59[1][0]..=BOX_59[1][1]),
                rng.random_range(BOX_59[2][0]..=BOX_59[2][1]),
            )
        })
        .collect()
}

/// `n` seeded points of [`OUTSIDE_BOX`] at least [`OUTSIDE_MARGIN`] from
/// box (59).
fn outside_points(seed: u64, n: usize) -> Vec<Vector3<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ OUTSIDE_STREAM ^ 1);
    let mut points = Vec::with_capacity(n);
    while points.len() < n {
        let p = Vector3::from_fn(|k, _| rng.random_range(OUTSIDE_BOX[k][0]..=OUTSIDE_BOX[k][1]));
        if distance_from_box_59(&p) >= OUTSIDE_MARGIN {
            points.push(p);
        }
    }
    points
}

#[allow(clippy::too_many_arguments)]
fn measure(
    twin: &TwinRobot,
    points: &[Vector3<f64>],
    first_index: usize,
    last_index: f64,
    options: &GeometricCampaignOptions,
    rng: &mut ChaCha8Rng,
    noise_rng: &mut ChaCha8Rng,
    (name, wrench_base): (&str, &Vector6<f64>),
) -> Result<MeasurementSet, GeometricTwinError> {
    let kin = |step: String| move |source| GeometricTwinError::Kinematics { step, source };
    let model = twin.model();
    let mut data = Data::new(model);
    let mut workspace = twin.workspace()?;
    let nominal = model.nominal_params();
    let start = actuated_from_joint_angles(model, &[0.0, -0.5, 0.4, 0.8, 1.6, 0.0])
        .map_err(kin("start configuration".into()))?;
    let inverse = InverseOptions {
        target: InverseTarget::PositionAndToolAxis,
        ..InverseOptions::default()
    };
    let switches = options.switches;
    let mut camera = options.camera.clone();
    if !switches.measurement_frame {
        camera.x_meas_base = Isometry3::identity();
    }
    let position_std = camera.position_std_per_axis();
    let orientation_std = camera.orientation_std_target();
    let down = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), std::f64::consts::PI);
    let mut seed = start.clone();
    let mut measurements = Vec::with_capacity(points.len());
    for (k, p) in points.iter().enumerate() {
        let tilt_axis = rng.random_range(0.0..std::f64::consts::TAU);
        let tilt = options.max_tilt * rng.random_range(0.0f64..=1.0).sqrt();
        let tilt_rotation = UnitQuaternion::from_scaled_axis(
            Vector3::new(tilt_axis.cos(), tilt_axis.sin(), 0.0) * tilt,
        );
        let target = Isometry3::from_parts((*p).into(), tilt_rotation * down);
        // A random turn about the tool axis: theta7 is free with this target.
        let mut seed_k = seed.clone();
        seed_k[5] = rng.random_range(-2.5..2.5);
        let solution = match inverse_pose(model, &mut data, &target, &seed_k, nominal, &inverse) {
            Ok(s) => s,
            Err(_) => {
                seed_k[..5].copy_from_slice(&start[..5]);
                inverse_pose(model, &mut data, &target, &seed_k, nominal, &inverse)
                    .map_err(kin(format!("{name} pose {k} at {p:?} m")))?
            }
        };
        seed = solution.q.clone();
        let fraction = (first_index + k) as f64 / last_index;
        let reached = twin.pose(&mut workspace, &solution.q, wrench_base, fraction)?;
        let x_meas_tcp = camera.measure(
            &reached.x_base_tcp,
            switches.measurement_noise,
            false,
            noise_rng,
        );
        let mut m = Measurement::new(solution.q, x_meas_tcp.translation.vector);
        m.pose_id = Some(format!("{name}-{}", k + 1));
        m.orientation = Some(x_meas_tcp.rotation.scaled_axis());
        m.position_std = Some(Vector3::repeat(position_std.max(f64::MIN_POSITIVE)));
        m.orientation_std = Some(orientation_std.map(|s| s.max(f64::MIN_POSITIVE)));
        measurements.push(m);
    }
    MeasurementSet::new(name, measurements).map_err(format_error)
}

/// Writes a campaign into `dir`: `identification.csv`, `validation.csv`,
/// `validation_outside.csv`
/// (flexcal's measurement format, poses in the camera frame), `truth.toml`
/// (the true robot geometry) and `truth.json` (`{"robot": "ir663", "xi":
/// {name: value}, "units": ...}` with lengths in mm and angles in deg, the
/// errors from nominal, the true measurement frame and the truth's terms).
///
/// # Errors
/// Files that cannot be written.
pub fn write_geometric_campaign(
    campaign: &GeometricCampaign,
    dir: &Path,
) -> Result<(), GeometricTwinError> {
    for (set, file) in [
        (&campaign.identification, "identification.csv"),
        (&campaign.validation, "validation.csv"),
        (&campaign.validation_outside, "validation_outside.csv"),
        (&campaign.validation_loaded, "validation_loaded.csv"),
    ] {
        set.write_csv(&dir.join(file)).map_err(format_error)?;
    }
    flexcal_io::write_atomic(
        dir.join("truth.toml"),
        campaign.true_description.to_toml_string(),
    )?;
    let mut xi = serde_json::Map::new();
    let mut errors = serde_json::Map::new();
    for (j, p) in campaign.model.params().iter().enumerate() {
        let scale = match p.kind {
            flexcal_kinematics::ParamKind::Length => 1e3,
            flexcal_kinematics::ParamKind::Angle => 180.0 / std::f64::consts::PI,
        };
        xi.insert(p.name.clone(), (campaign.true_xi[j] * scale).into());
        errors.insert(
            p.name.clone(),
            ((campaign.true_xi[j] - campaign.model.nominal_params()[j]) * scale).into(),
        );
    }
    let json = serde_json::json!({
        "robot": campaign.model.name(),
        "units": "lengths in mm, angles in deg",
        "xi": xi,
        "errors_from_nominal": errors,
        "measurement_frame": {
            "x_meas_base_translation_mm": (campaign.x_meas_base.translation.vector * 1e3).as_slice(),
            "x_meas_base_rotation_vector_deg": campaign.x_meas_base.rotation.scaled_axis().map(f64::to_degrees).as_slice(),
        },
        "target": "TCP",
        "validation_loaded_payload": {
            "weighed_n": campaign.payload_weighed_n,
            "true_n": campaign.payload_true_n,
            "center": "TCP",
        },
        "terms": campaign.terms,
    });
    let text = serde_json::to_string_pretty(&json).unwrap_or_default();
    flexcal_io::write_atomic(dir.join("truth.json"), text)?;
    Ok(())
}

/// The twin's terms that a geometric campaign meets besides the geometric
/// errors and the camera frame: what no geometric model contains.
pub const NON_GEOMETRIC_TERMS: [&str; 3] = ["gravity", "drive_nonlinearity", "transmission_errors"];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distance_from_box_59_is_zero_inside_and_euclidean_outside() {
        assert_eq!(distance_from_box_59(&Vector3::new(1.5, 0.0, 1.5)), 0.0);
        // 0.3 beyond x and 0.4 below z: a corner distance of 0.5.
        let d = distance_from_box_59(&Vector3::new(2.4, 0.1, 1.0));
        assert!((d - 0.5).abs() < 1e-12, "{d}");
    }

    #[test]
    fn outside_poses_lie_in_their_region_and_clear_of_box_59() {
        for seed in [1, 2, 3] {
            let points = outside_points(seed, 40);
            assert_eq!(points.len(), 40);
            for p in &points {
                assert!(distance_from_box_59(p) >= OUTSIDE_MARGIN, "{p:?}");
                for (k, [lo, hi]) in OUTSIDE_BOX.iter().enumerate() {
                    assert!((*lo..=*hi).contains(&p[k]), "{p:?}");
                }
            }
            assert_eq!(points, outside_points(seed, 40), "seeded");
        }
    }

    #[test]
    fn the_payload_lowers_every_loaded_pose_and_changes_nothing_else() {
        // Noise-free, camera frame at the base: the measured positions are
        // the TCP's in the base frame.
        let switches = TruthSwitches {
            measurement_noise: false,
            measurement_frame: false,
            ..TruthSwitches::default()
        };
        let options = |payload_weighed_n| GeometricCampaignOptions {
            seed: 3,
            n_validation: 2,
            n_validation_outside: 2,
            n_validation_loaded: 6,
            payload_weighed_n,
            switches,
            ..GeometricCampaignOptions::default()
        };
        let loaded = geometric_campaign(&options(650.0)).unwrap();
        let bare = geometric_campaign(&options(0.0)).unwrap();
        assert_eq!(loaded.payload_weighed_n, 650.0);
        assert!((loaded.payload_true_n - 650.0 * 1.005).abs() < 1e-9);
        assert_eq!(loaded.identification, bare.identification);
        assert_eq!(loaded.validation_outside, bare.validation_outside);
        for (a, b) in loaded
            .validation_loaded
            .measurements()
            .iter()
            .zip(bare.validation_loaded.measurements())
        {
            assert_eq!(a.q, b.q, "same commanded poses");
            // In box (59), up to the twin's errors from nominal (1-2 mm).
            assert!(distance_from_box_59(&b.position) < 5e-3, "{:?}", b.position);
            // A weight hung at the TCP lowers it: by more than the
            // camera's noise (21 um), by less than the twin's deflection
            // under 1100 N (2.2 mm at most over grid (65)).
            let dz = a.position.z - b.position.z;
            assert!((-2.2e-3..-21e-6).contains(&dz), "{dz}");
        }
        let e = geometric_campaign(&options(f64::NAN))
            .unwrap_err()
            .to_string();
        assert!(e.contains("payload_weighed_n"), "{e}");
    }
}
