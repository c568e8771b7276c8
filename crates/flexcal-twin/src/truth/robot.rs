//! The virtual IR-663 itself: how the true robot moves when commanded.
//!
//! For commanded actuated coordinates `q` and an external wrench `W` at the
//! TCP, the twin
//! 1. turns every joint by its transmission error
//!    ([`transmission`](super::transmission)): `theta <- theta + e(theta)`;
//! 2. solves its own structure ([`structure`](super::structure), with the
//!    twin's own mechanics, [`mechanics`](super::mechanics)) in that
//!    configuration, on the true geometry (warmed by the temperature drift
//!    when on), under its own weight and `W`: TCP deflection `u` and the
//!    forces in the ball screws of joints 2 and 8;
//! 3. lets each screw drive yield further by its non-linear law with
//!    memory ([`drive`](super::drive)) under the joint torque `T = F h`
//!    (screw force times lever arm): the screw lengthens by
//!    `h theta_drive(T, history)`; the workspace keeps each drive's
//!    position in its play, set by the direction the joint was last driven
//!    in (the sign of the change of its actuated coordinate since the last
//!    command) and by the torques met since;
//! 4. places the TCP with the true forward model at the actuated
//!    coordinates so reached, displaced by `u`.
//!
//! Every term has a switch ([`TruthSwitches`]); with all off this is the
//! nominal rigid robot.

use flexcal_kinematics::{
    Data, Model, ParamKind, RobotDescription, actuated_from_joint_angles, forward_pose,
    joint_angles_from_actuated,
};
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3, Vector6};

use super::drive::DriveLaw;
use super::error::TruthError;
use super::geometry::{GeometricErrors, ir663_true_params};
use super::structure::{TwinStructure, crank, screw_lever_arm, twin_structure};
use super::temperature::TemperatureDrift;
use super::terms::{TruthSwitches, TwinTerm};
use super::transmission::TransmissionErrors;

/// A screw-driven joint of the twin.
#[derive(Debug, Clone)]
struct ScrewDrive {
    /// Index of the screw among the FE structure's springs.
    spring: usize,
    /// Index of the screw length among the actuated coordinates.
    actuated: usize,
    /// Index of the joint angle among the joint angles.
    joint: usize,
    /// Crank geometry `(l1, l3, kappa, lambda)` (m, rad).
    crank: (f64, f64, f64, f64),
}

/// The virtual IR-663 (see the module documentation). Immutable; each thread
/// owns a [`TwinWorkspace`].
#[derive(Debug, Clone)]
pub struct TwinRobot {
    model: Model,
    true_xi: Vec<f64>,
    structure: TwinStructure,
    screws: Vec<ScrewDrive>,
    /// The drive law of joints 2 and 8.
    pub drive: DriveLaw,
    /// The transmission errors.
    pub transmission: TransmissionErrors,
    /// The temperature drift.
    pub temperature: TemperatureDrift,
    /// Which terms are on.
    pub switches: TruthSwitches,
}

/// Per-thread workspace of a [`TwinRobot`].
#[derive(Debug, Clone)]
pub struct TwinWorkspace {
    kinematics: Data,
    /// Each screw drive's position in its play (rad).
    lost_motion: [f64; 2],
    /// The last command, whose change gives the direction of approach.
    last_q: Option<Vec<f64>>,
}

impl TwinWorkspace {
    /// Each screw drive's position in its play (rad), joints 2 and 8:
    /// the drives' memory.
    pub fn lost_motion(&self) -> [f64; 2] {
        self.lost_motion
    }
}

/// What the twin did for one command.
#[derive(Debug, Clone, PartialEq)]
pub struct TwinPose {
    /// The pose the TCP actually reached, in R0.
    pub x_base_tcp: Isometry3<f64>,
    /// The actuated coordinates actually reached (transmission errors and
    /// drive yield included) (rad, m).
    pub q_reached: Vec<f64>,
    /// Elastic TCP displacement of the FE structure `[dp; dphi]` (m, rad).
    pub structure_deflection: Vector6<f64>,
    /// Axial forces in the screws of joints 2 and 8 (N, tension > 0).
    pub screw_forces_n: [f64; 2],
    /// Torques of joints 2 and 8 through their screws (N.m).
    pub joint_torques_nm: [f64; 2],
}

impl TwinRobot {
    /// The twin with the given switches.
    ///
    /// # Errors
    /// Never for the built-in robot (the error types are those of the
    /// descriptions).
    pub fn new(switches: TruthSwitches) -> Result<Self, TruthError> {
        let kin = |step: &str| {
            let step = step.to_string();
            move |source| TruthError::Kinematics { step, source }
        };
        let description = RobotDescription::builtin("ir663").map_err(kin("built-in ir663"))?;
        let model = description.build().map_err(kin("built-in ir663"))?;
        let true_xi = if switches.geometric_errors {
            ir663_true_params(&model)?
        } else {
            model.nominal_params().to_vec()
        };
        let structure = twin_structure(&description);
        let mut screws = Vec::new();
        for (frame, actuated, joint) in [("2", "r2p", 1), ("8", "r8p", 2)] {
            let missing = |what: String| TruthError::NotTheIr663 {
                robot: model.name().to_string(),
                missing: what,
            };
            let spring = structure
                .screws
                .iter()
                .position(|s| s.name == format!("screw{frame}"))
                .ok_or_else(|| missing(format!("screw{frame}")))?;
            let actuated = model
                .actuated_names()
                .iter()
                .position(|n| n == actuated)
                .ok_or_else(|| missing(actuated.to_string()))?;
            let (l1, l3, kappa, lambda) = crank(&description, frame);
            screws.push(ScrewDrive {
                spring,
                actuated,
                joint,
                crank: (
                    l1 * 1e-3,
                    l3 * 1e-3,
                    kappa.to_radians(),
                    lambda.to_radians(),
                ),
            });
        }
        Ok(Self {
            model,
            true_xi,
            structure,
            screws,
            drive: DriveLaw::default(),
            transmission: TransmissionErrors::default(),
            temperature: TemperatureDrift::default(),
            switches,
        })
    }

    /// The nominal kinematic model (what the robot's controller knows).
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// The true geometric parameters (m, rad), at the start of a campaign.
    pub fn true_xi(&self) -> &[f64] {
        &self.true_xi
    }

    /// The twin's own structure.
    pub fn structure(&self) -> &TwinStructure {
        &self.structure
    }

    /// A workspace for this twin, its drives in the middle of their play.
    ///
    /// # Errors
    /// Never (kept for workspaces that may fail).
    pub fn workspace(&self) -> Result<TwinWorkspace, TruthError> {
        Ok(TwinWorkspace {
            kinematics: Data::new(&self.model),
            lost_motion: [0.0; 2],
            last_q: None,
        })
    }

    /// The robot's terms as published (geometry, gravity, drives,
    /// transmission, temperature).
    pub fn terms(&self) -> Vec<TwinTerm> {
        let s = &self.switches;
        vec![
            GeometricErrors.term(s.geometric_errors),
            TwinTerm {
                name: "gravity".into(),
                magnitude: format!(
                    "own weight through the twin's own structure (Timoshenko beams, its own solver) in every campaign: steel links, {:.0} kg of wrist motors behind the elbow, {:.0} kg wrist, {:.0} kg tool; ball screws of joints 2 and 8 as configuration-dependent springs ({:.1e} and {:.1e} N/m)",
                    super::structure::WRIST_MOTORS_MASS_KG,
                    super::structure::WRIST_MASS_KG,
                    super::structure::TOOL_MASS_KG,
                    super::structure::SCREW_2_STIFFNESS,
                    super::structure::SCREW_8_STIFFNESS
                ),
                source: "the twin's own frame model and mechanics (flexcal_twin::truth::structure, flexcal_twin::truth::mechanics): plausible steel sections and masses of a 120-kg-class arm; screw stiffness from the paper's measured deflections under 1100 N vertical (1.6-2.5 mm, section 3.3.1); with its own structure and drives the twin deflects 0.6-2.1 mm".into(),
                enabled: s.gravity,
            },
            self.drive.term(s.drive_nonlinearity),
            self.transmission.term(s.transmission_errors),
            self.temperature.term(s.temperature_drift),
        ]
    }

    /// The true geometric parameters at campaign progress `fraction` (0 at
    /// the first pose, 1 at the last): lengths grown by the temperature
    /// drift when it is on.
    pub fn xi_at(&self, fraction: f64) -> Vec<f64> {
        let mut xi = self.true_xi.clone();
        if self.switches.temperature_drift {
            let scale = self.temperature.length_scale(fraction);
            for (x, p) in xi.iter_mut().zip(self.model.params()) {
                if p.kind == ParamKind::Length {
                    *x *= scale;
                }
            }
        }
        xi
    }

    /// Commands `q` (actuated coordinates, rad and m) with the external
    /// wrench `wrench_base` `[f; m]` (N, N.m, base axes) at the TCP, at
    /// campaign progress `fraction` (for the temperature drift; 0 when
    /// irrelevant): the pose the true robot reaches.
    ///
    /// # Errors
    /// A configuration the true geometry cannot assemble, a singular
    /// structure.
    pub fn pose(
        &self,
        ws: &mut TwinWorkspace,
        q: &[f64],
        wrench_base: &Vector6<f64>,
        fraction: f64,
    ) -> Result<TwinPose, TruthError> {
        let kin = |step: &'static str| {
            move |source| TruthError::Kinematics {
                step: format!("{step} at q = {q:?}"),
                source,
            }
        };
        if q.len() != self.model.n_actuated() || !q.iter().all(|v| v.is_finite()) {
            return Err(TruthError::Invalid {
                name: "q",
                reason: format!(
                    "need {} finite actuated coordinates, got {q:?}",
                    self.model.n_actuated()
                ),
            });
        }
        let xi = self.xi_at(fraction);
        let mut theta = joint_angles_from_actuated(&self.model, q).map_err(kin("joint angles"))?;
        let mut q_reached = q.to_vec();
        if self.switches.transmission_errors {
            for (j, t) in theta.iter_mut().enumerate() {
                *t += self.transmission.error(j, *t);
            }
            q_reached = actuated_from_joint_angles(&self.model, &theta)
                .map_err(kin("transmission errors"))?;
        }
        if self.switches.temperature_drift {
            // The screws grow with the links: the commanded nut position
            // gives a longer screw, and the whole arm grows alike.
            let scale = self.temperature.length_scale(fraction);
            for screw in &self.screws {
                q_reached[screw.actuated] *= scale;
            }
        }
        let approach: Vec<f64> = match &ws.last_q {
            Some(last) => self
                .screws
                .iter()
                .map(|s| q[s.actuated] - last[s.actuated])
                .collect(),
            None => vec![0.0; self.screws.len()],
        };
        ws.last_q = Some(q.to_vec());
        let loaded = self.switches.gravity || wrench_base.iter().any(|w| *w != 0.0);
        let mut deflection = Vector6::zeros();
        let mut forces = [0.0; 2];
        let mut torques = [0.0; 2];
        if loaded || self.switches.drive_nonlinearity {
            let frame = self
                .structure
                .frame(&self.model, &mut ws.kinematics, &q_reached, &xi)?;
            let solution = self
                .structure
                .solve(&frame, wrench_base, self.switches.gravity)?;
            deflection = solution.tcp;
            for (k, screw) in self.screws.iter().enumerate() {
                forces[k] = self.structure.screws[screw.spring].stiffness_n_m
                    * solution.screw_elongations[screw.spring];
                let (l1, l3, kappa, lambda) = screw.crank;
                let h = screw_lever_arm(l1, l3, kappa, lambda, theta[screw.joint]);
                torques[k] = forces[k] * h;
                if self.switches.drive_nonlinearity {
                    self.drive.approach(approach[k], &mut ws.lost_motion[k]);
                    q_reached[screw.actuated] +=
                        h * self.drive.rotation(torques[k], &mut ws.lost_motion[k]);
                }
            }
        }
        let rigid = forward_pose(&self.model, &mut ws.kinematics, &q_reached, &xi)
            .map_err(kin("true forward model"))?;
        let x_base_tcp = Isometry3::from_parts(
            Translation3::from(rigid.translation.vector + deflection.fixed_rows::<3>(0)),
            UnitQuaternion::from_scaled_axis(Vector3::new(
                deflection[3],
                deflection[4],
                deflection[5],
            )) * rigid.rotation,
        );
        Ok(TwinPose {
            x_base_tcp,
            q_reached,
            structure_deflection: deflection,
            screw_forces_n: forces,
            joint_torques_nm: torques,
        })
    }
}
