//! The forming cell of the paper's section 4 (Figure 17) on the virtual
//! IR-663: the twin plays the cell, the user's side (commands, models,
//! compensation) lives in the facade's study.
//!
//! A clamped Al-5005 bar (585 x 50 x 14 mm) is bent elastically by the
//! tool: the tool plunges 25 mm near the free end, then travels 200 mm along
//! the bar towards the clamp, with a dead weight on the end-effector. The
//! bar pushes back according to where the tool actually is, so the twin
//! solves its robot and its bar together for every command
//! ([`TwinCell::run_path`]): its robot ([`TwinRobot`]: Appendix C
//! geometry, its own weight through its own structure, the drives' lost
//! motion with memory and hardening, transmission errors) under the dead
//! weight and the bar's push, the bar with the twin's own mechanics, clamp,
//! tool tip and friction ([`crate::truth::process`]), until the tool's
//! position and the bar's push agree. The camera then measures the TCP
//! (in its own frame), and the part's reference points
//! ([`TwinCell::locate_part`]), from which a user locates the part.
//!
//! The twin never sees the user's models: it takes commanded actuated
//! coordinates and returns what its camera measures.

use flexcal_compensate::path::PathPoint;
use flexcal_kinematics::forward_pose;
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3, Vector6};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::Serialize;

use crate::truth::process::{BAR_LENGTH_M, BAR_WIDTH_M, Contact};
use crate::truth::{
    FormingTruth, Photogrammetry, TruthError, TruthSwitches, TwinRobot, TwinTerms, TwinWorkspace,
    twin_terms,
};

/// The forming head's weight as weighed (N): a 66 kg head, unlike every
/// load of the elastic campaign (300, 600, 900 and 1100 N). The forming
/// experiment hangs it at the TCP as its dead weight, and the geometric
/// campaign's loaded validation set carries it (its option
/// `payload_weighed_n`).
pub const FORMING_HEAD_WEIGHT_N: f64 = 650.0;

/// Settings of the forming experiment.
#[derive(Debug, Clone, PartialEq)]
pub struct FormingOptions {
    /// Seed of the measurement noise.
    pub seed: u64,
    /// Dead weight on the end-effector as weighed (N) (default 650: a
    /// 66 kg forming head, unlike every load of the elastic campaign, 300,
    /// 600, 900 and 1100 N; the paper's 920 N sits next to the 900 N the
    /// fuzzy model is trained on); the twin's true weight differs by the
    /// scale's accuracy.
    pub dead_weight_n: f64,
    /// Plunge depth at the free end (m) (paper: 0.025).
    pub plunge_m: f64,
    /// Travel along the bar towards the clamp (m) (paper: 0.200).
    pub travel_m: f64,
    /// Distance between path points (m) (default 0.005).
    pub step_m: f64,
    /// Where the plunge starts, from the free end towards the clamp (m)
    /// (default 0.005: a tool exactly at the edge would slide off the bent bar).
    pub edge_margin_m: f64,
    /// Pose of the part frame (clamp at its origin, bar along +x, top surface
    /// at z = 0) in the robot base frame: where the part truly is.
    pub x_base_part: Isometry3<f64>,
}

impl Default for FormingOptions {
    fn default() -> Self {
        Self {
            seed: 17,
            dead_weight_n: FORMING_HEAD_WEIGHT_N,
            plunge_m: 0.025,
            travel_m: 0.200,
            step_m: 0.005,
            edge_margin_m: 0.005,
            // The bar lies along the base x axis in the plane y = 0, clamped at
            // x = 1.2 m, top surface 1.45 m above the base: the tool then works
            // at x 1.58-1.78 m, z 1.425-1.45 m, inside both the geometric
            // calibration's box (59) and the elastic campaign's grid (65), where
            // the identified models hold.
            x_base_part: Isometry3::translation(1.2, 0.0, 1.45),
        }
    }
}

/// The target path in the part frame: the plunge, then the travel, tool
/// pointing down (its z axis along -z_p), the TCP at the tool tip's lowest
/// point.
pub fn forming_path(options: &FormingOptions) -> Vec<PathPoint> {
    let down = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), std::f64::consts::PI);
    let x0 = BAR_LENGTH_M - options.edge_margin_m;
    let mut points = Vec::new();
    let plunge_steps = (options.plunge_m / options.step_m).round().max(1.0) as usize;
    for i in 0..=plunge_steps {
        let z = -options.plunge_m * i as f64 / plunge_steps as f64;
        points.push((x0, z));
    }
    let travel_steps = (options.travel_m / options.step_m).round().max(1.0) as usize;
    for i in 1..=travel_steps {
        let x = x0 - options.travel_m * i as f64 / travel_steps as f64;
        points.push((x, -options.plunge_m));
    }
    points
        .into_iter()
        .enumerate()
        .map(|(k, (x, z))| PathPoint {
            line: k + 2,
            x_part_tcp: Isometry3::from_parts(Translation3::new(x, 0.0, z), down),
        })
        .collect()
}

/// Errors of the forming experiment.
#[derive(Debug, thiserror::Error)]
pub enum FormingError {
    /// A path point could not be executed.
    #[error("forming path point {point}: {source}")]
    Point {
        /// 0-based point index.
        point: usize,
        /// Why.
        source: Box<TruthError>,
    },
    /// The twin's truth failed.
    #[error(transparent)]
    Truth(Box<TruthError>),
    /// An option is out of range.
    #[error("invalid forming option: {0}")]
    InvalidOption(String),
}

impl From<TruthError> for FormingError {
    fn from(e: TruthError) -> Self {
        Self::Truth(Box::new(e))
    }
}

/// What the cell did with one commanded path.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ExecutedPath {
    /// The TCP as the camera measured it, in the camera frame (m).
    pub measured_camera_m: Vec<Vector3<f64>>,
    /// The truth: the TCP in the true part frame (m).
    pub true_part_m: Vec<Vector3<f64>>,
    /// The truth: the bar's normal push on the tool at each point (N; 0
    /// without contact).
    pub contact_normal_n: Vec<f64>,
}

/// A reference point of the part: its place on the drawing and where the
/// camera measured it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PartPoint {
    /// On the drawing, in the part frame (m).
    pub nominal_part_m: Vector3<f64>,
    /// As measured, in the camera frame (m).
    pub measured_camera_m: Vector3<f64>,
}

/// The forming cell as it is: the true robot, bar, contact and dead
/// weight, and the measurement system.
pub struct TwinCell {
    /// The true robot.
    pub robot: TwinRobot,
    /// The forming truth terms.
    pub forming: FormingTruth,
    /// The measurement system.
    pub camera: Photogrammetry,
}

/// Mixed into the seed of the part location's noise.
const PART_STREAM: u64 = 0x7061_7274;

impl TwinCell {
    /// The cell with the given truth switches.
    ///
    /// # Errors
    /// As [`TwinRobot::new`].
    pub fn new(switches: TruthSwitches) -> Result<Self, TruthError> {
        Ok(Self {
            robot: TwinRobot::new(switches)?,
            forming: FormingTruth::default(),
            camera: Photogrammetry::default(),
        })
    }

    /// The truth's terms.
    pub fn terms(&self) -> TwinTerms {
        twin_terms(&self.robot, &self.camera, &self.forming)
    }

    fn camera(&self) -> Photogrammetry {
        let mut camera = self.camera.clone();
        if !self.robot.switches.measurement_frame {
            camera.x_meas_base = Isometry3::identity();
        }
        camera
    }

    /// The part's six reference points (the bar's top corners at the clamp
    /// and at the free end, the clamp block's top corners) measured by the
    /// camera, each with the single-point accuracy of one LED probe (21 um
    /// per axis), the noise seeded by `options.seed`: what a user fits the
    /// part's pose to.
    pub fn locate_part(&self, options: &FormingOptions) -> Vec<PartPoint> {
        let camera = self.camera();
        let noise = self.robot.switches.measurement_noise;
        let mut rng = ChaCha8Rng::seed_from_u64(options.seed ^ PART_STREAM);
        let s = camera.led_std_per_axis();
        let half = 0.5 * BAR_WIDTH_M;
        [
            Vector3::new(0.0, -half, 0.0),
            Vector3::new(0.0, half, 0.0),
            Vector3::new(BAR_LENGTH_M, -half, 0.0),
            Vector3::new(BAR_LENGTH_M, half, 0.0),
            Vector3::new(-0.04, -0.06, 0.03),
            Vector3::new(-0.04, 0.06, 0.03),
        ]
        .into_iter()
        .map(|p| {
            let mut measured = (camera.x_meas_base * options.x_base_part)
                .transform_point(&p.into())
                .coords;
            if noise {
                for a in 0..3 {
                    let z: f64 = StandardNormal.sample(&mut rng);
                    measured[a] += z * s;
                }
            }
            PartPoint {
                nominal_part_m: p,
                measured_camera_m: measured,
            }
        })
        .collect()
    }

    /// The robot and the bar in equilibrium at command `q`: the pose the
    /// robot reaches under the dead weight `weight_n` (N) and the bar's
    /// push, and that push. The drives' memory in `ws` is updated once the
    /// equilibrium is found.
    fn equilibrium(
        &self,
        ws: &mut TwinWorkspace,
        q: &[f64],
        weight_n: f64,
        motion_part: &Vector3<f64>,
        x_base_part: &Isometry3<f64>,
    ) -> Result<(Isometry3<f64>, Contact), TruthError> {
        let switches = self.robot.switches;
        let x_part_base = x_base_part.inverse();
        let radius = if switches.tool_radius {
            self.forming.tool_radius_m
        } else {
            0.0
        };
        let mut push_base = Vector3::zeros();
        let mut moment_base = Vector3::zeros();
        for _ in 0..100 {
            let mut trial = ws.clone();
            let force = push_base + Vector3::new(0.0, 0.0, -weight_n);
            let wrench = Vector6::new(
                force.x,
                force.y,
                force.z,
                moment_base.x,
                moment_base.y,
                moment_base.z,
            );
            let pose = self.robot.pose(&mut trial, q, &wrench, 0.0)?.x_base_tcp;
            let tcp = x_part_base * pose;
            let tool_axis = tcp.rotation * Vector3::z();
            let centre = tcp.translation.vector - tool_axis * radius;
            let contact = self.forming.contact(&switches, &centre, motion_part)?;
            let next = x_base_part.rotation * contact.force_part_n;
            // The push acts where the tip touches, not at the TCP.
            let normal = Vector3::new(contact.slope_rad.sin(), 0.0, contact.slope_rad.cos());
            let touch = centre - normal * radius - tcp.translation.vector;
            let next_moment = (x_base_part.rotation * touch).cross(&next);
            let converged = (next - push_base).norm() < 1e-6;
            push_base = next;
            moment_base = next_moment;
            if converged {
                *ws = trial;
                return Ok((pose, contact));
            }
        }
        Err(TruthError::Invalid {
            name: "forming",
            reason: format!("the robot and the bar found no equilibrium at q = {q:?}"),
        })
    }

    /// Executes the commanded path `commands` (actuated coordinates, one
    /// per point, in order) with the dead weight weighed as
    /// `options.dead_weight_n`: the robot starts with its drives in the
    /// middle of their play, each command is solved with the bar
    /// ([`crate::truth::process`]) and measured by the camera (noise
    /// seeded by `options.seed` and `stream`, one stream per path).
    ///
    /// # Errors
    /// [`FormingError`] naming the point that failed.
    pub fn run_path(
        &self,
        commands: &[Vec<f64>],
        options: &FormingOptions,
        stream: u64,
    ) -> Result<ExecutedPath, FormingError> {
        if !(options.dead_weight_n.is_finite() && options.dead_weight_n >= 0.0) {
            return Err(FormingError::InvalidOption(format!(
                "dead_weight_n must be finite and >= 0, found {}",
                options.dead_weight_n
            )));
        }
        let switches = self.robot.switches;
        let weight = self
            .forming
            .true_payload_n(options.dead_weight_n, switches.payload_error);
        let camera = self.camera();
        let mut rng = ChaCha8Rng::seed_from_u64(options.seed ^ stream.rotate_left(32));
        let mut ws = self.robot.workspace()?;
        let model = self.robot.model();
        let x_part_base = options.x_base_part.inverse();
        let mut previous: Option<Vector3<f64>> = None;
        let mut out = ExecutedPath {
            measured_camera_m: Vec::with_capacity(commands.len()),
            true_part_m: Vec::with_capacity(commands.len()),
            contact_normal_n: Vec::with_capacity(commands.len()),
        };
        let mut kinematics = flexcal_kinematics::Data::new(model);
        for (k, q) in commands.iter().enumerate() {
            let point = |source: TruthError| FormingError::Point {
                point: k,
                source: Box::new(source),
            };
            // The tool's motion along the bar since the last point, from the
            // rigid true robot (the friction's direction only).
            let rigid = forward_pose(model, &mut kinematics, q, self.robot.true_xi()).map_err(
                |source| {
                    point(TruthError::Kinematics {
                        step: "rigid pose".into(),
                        source,
                    })
                },
            )?;
            let rigid_part = x_part_base
                .transform_point(&rigid.translation.vector.into())
                .coords;
            let motion = previous.map_or_else(Vector3::zeros, |p| rigid_part - p);
            previous = Some(rigid_part);
            let (pose, contact) = self
                .equilibrium(&mut ws, q, weight, &motion, &options.x_base_part)
                .map_err(point)?;
            let measured = camera.measure(&pose, switches.measurement_noise, false, &mut rng);
            out.measured_camera_m.push(measured.translation.vector);
            out.true_part_m.push(
                x_part_base
                    .transform_point(&pose.translation.vector.into())
                    .coords,
            );
            out.contact_normal_n.push(contact.normal_n);
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_path_plunges_then_travels_towards_the_clamp() {
        let options = FormingOptions::default();
        let path = forming_path(&options);
        assert_eq!(path.len(), 6 + 40);
        let first = path[0].x_part_tcp.translation.vector;
        let plunged = path[5].x_part_tcp.translation.vector;
        let last = path.last().unwrap().x_part_tcp.translation.vector;
        assert!((first.x - 0.580).abs() < 1e-12 && first.z == 0.0);
        assert!((plunged.z + 0.025).abs() < 1e-12);
        assert!((last.x - 0.380).abs() < 1e-12 && (last.z + 0.025).abs() < 1e-12);
    }
}
