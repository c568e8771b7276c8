//! # flexcal-kinematics
//!
//! Geometry of robots for flexcal: robots described in Khalil-Kleinfinger
//! (KK) notation — serial arms, trees, closed loops cut at a joint, passive
//! joints, linear joint couplings (theta6 = -theta5), slider-crank (ball
//! screw) actuators, Hayati beta angles for nearly parallel axes — with their
//! exact forward model, inverse model, and exact joint and parameter
//! Jacobians. Everything else in flexcal (calibration, elastic models,
//! compensation) stands on this crate.
//!
//! ```
//! use flexcal_kinematics::{Data, RobotDescription, forward_pose, param_jacobian};
//!
//! let model = RobotDescription::builtin("ur10")?.build()?; // validated once, then frozen
//! let mut data = Data::new(&model);                          // one per thread
//! let xi = model.nominal_params().to_vec();
//! let q = [0.1, -1.2, 1.0, -0.5, 1.3, 0.2];
//! let x_base_tcp = forward_pose(&model, &mut data, &q, &xi)?;
//! let (_, jac) = param_jacobian(&model, &mut data, &q, &xi)?; // 6 x n_params
//! assert_eq!(jac.ncols(), model.n_params());
//! assert!(x_base_tcp.translation.vector.norm() < 2.0);
//! # Ok::<(), flexcal_kinematics::KinematicsError>(())
//! ```
//!
//! ## Conventions
//! - SI inside (m, rad); description files use mm and degrees in fields
//!   named with their unit (`d_mm`, `alpha_deg`).
//! - Poses are named by frames: `x_base_tcp` is the TCP in the robot base
//!   frame R0. The tool transform (end frame to TCP) is part of the forward
//!   model; the base transform (cell R-1 to R0, [`Model::base`]) is not.
//! - Jacobian rows are `[linear; angular]` in R0, the linear part at the TCP
//!   point; the angular part is the small rotation vector phi with
//!   `R(x + dx) = exp([dphi]x) R(x)`.
//! - [`Model`] is immutable; [`Data`] is a per-thread workspace; algorithms
//!   are free functions `algorithm(&model, &mut data, inputs)`.
//!
//! ## Equations (Marie, Courteille, Maurine 2013)
//! - Frame transform (41):
//!   `a(i)T_i = rot(z,gamma) trans(z,b) rot(x,alpha) trans(x,d) rot(y,beta) rot(z,theta) trans(z,r)`;
//!   the Hayati angle beta (rotation about y) is placed after `trans(x,d)`
//!   and before `rot(z,theta)`, and exists only where declared.
//! - Forward model (1), (4), (42): product of the frame transforms along the
//!   path from R0 to the end frame, then the tool transform.
//! - Couplings (43) (theta6 = -theta5 and any linear combination), loop
//!   closure (44) (cut-joint frames coincide; planar or full constraint),
//!   slider cranks (45)-(46), relation V of Appendix A written with the
//!   squared screw length: `theta = lambda - kappa + branch * acos((l1^2 + l3^2 - r'^2)/(2 l1 l3))`.
//! - The pose and parameter Jacobian of a point on any frame, not only the
//!   TCP ([`forward_frame_pose`], [`frame_param_jacobian`]): (49)-(52) along
//!   the path from R0 to that frame (a hand of a tree, a link of a chain).
//! - Parameter Jacobian (49)-(52) and Appendix B, with the derivatives of
//!   (51): slider cranks (a2..e2) analytically, passive loop joints (a3..e3)
//!   by implicit differentiation of the closure.
//! - Inverse model (6): damped least squares within the joint limits.
//! - Sensitivity indices (55)-(58).
//!
//! ## Robot description files
//! A description is TOML with lengths in mm and angles in degrees (see
//! [`RobotDescription`], [`FrameDescription`]). A frame names its antecedent
//! a(i) (`"0"` is the base R0), its joint kind sigma, whether it is actuated
//! (mu), the quantities of (41), optional limits, and how its joint is driven:
//! directly, by a `slider_crank`, by a linear coupling `coupled_to`, or
//! passively by a `[[loop]]` whose two `cut` frames must coincide. `same_as`
//! and `plus` tie quantities across frames (coaxial joints 2 and 8 of the
//! IR-663; its `r = r4 + d10`). The parameter vector xi is listed by name in
//! `parameters`, or follows the default rule documented on
//! [`RobotDescription::parameters`]. Parameter names are quantity + frame
//! name: `alpha2`, `d3`, `beta3`, `theta1` (joint offset), `r2p` (screw length
//! offset r'), `kappa8`, `lambda8`, `l18`, `l38`.
//!
//! ## Robots from other formats, and back
//! Besides flexcal's TOML, robots come from `.urdf` files
//! ([`ImportedRobot::read_urdf`]: a root-to-tip path converted into KK frames that reproduce the
//! file's poses exactly, modified DH with Hayati beta for parallel axes,
//! mimic joints as couplings; [`ImportOptions`] chooses the tip and root;
//! the module [`urdf`] reads the file itself) or SYMORO `.par` files
//! ([`ImportedRobot::read_par`]: symbols from a values file, cut-joint
//! loops); the facade crate `flexcal` picks the reader by extension. [`ImportedRobot`] adds the URDF's
//! link masses ([`LinkMass`]). [`export_robot`] writes a robot at any xi as
//! URDF (read back and checked), a modified-DH table ([`MdhTable`]) or TOML;
//! what a format cannot hold is refused by name
//! ([`KinematicsError::Inexpressible`]). User guide: `docs/robots.md`.
//!
//! ## Built-in robots
//! [`builtin_robot_names`]: `ur10`, `ir663`, `puma560` (see
//! [`RobotDescription::builtin`]); each writes to TOML and loads back identically.
//! - `ur10`: the published nominal standard DH values (d1 = 127.3, a2 = -612,
//!   a3 = -572.3, d4 = 163.941, d5 = 115.7, d6 = 92.2 mm) rewritten in KK form
//!   (KK alpha_i, d_i = DH alpha_(i-1), a_(i-1); r_i = DH d_i); base = DH base
//!   frame, end frame 6 = DH flange, tool identity. Joints 2-4 are parallel:
//!   xi has beta3 and beta4 in place of r3 and r4 (24 parameters). Checked
//!   against the controller's poses of the IPA UR10 dataset (0.09-0.10 mm mean,
//!   0.45 mm max over series B, C, D; `tests/ur10_controller_poses.rs`).
//! - `puma560`: Craig's modified-DH PUMA 560 with the values distributed in
//!   Corke's Robotics Toolbox (a2 = 431.8, d3 = 150.05, a3 = 20.3, d4 = 431.8
//!   mm) and a fixed flange frame E 56.25 mm along z6; beta3 replaces r3.
//! - `ir663`: the paper's KUKA IR-663, Table 1 with the Table 2 values (mm:
//!   r1 = 885, d3 = 1047, r4 = 1760, d9 = 473, d10 = 400, d11 = 1212, rE = 244),
//!   frame 4 with `r = r4 + d10`, joints 2 and 8 coaxial, the four-bar cut at
//!   joint 10 (planar closure, closed form plus Newton polish), theta6 = -theta5,
//!   and q = \[theta1, r'2, r'8, theta4, theta5, theta7\] (47). xi holds
//!   exactly the 43 parameters of (48)/(53) in the order of Appendix B.
//!   The paper does not publish the slider cranks; the values chosen are
//!   joint 2: l1 = 350 mm, l3 = 850 mm, kappa = 10 deg, lambda = -102 deg,
//!   screw 640-1140 mm (joint angle -69 to 28 deg); joint 8: l1 = 300 mm,
//!   l3 = 800 mm, kappa = 5 deg, lambda = -55 deg, screw 560-1040 mm (joint
//!   angle -30 to 77 deg). The loop closes (residual below 1e-9 m) wherever
//!   the angle between the upper arm (frame 2's x axis) and the crank
//!   (frame 8's x axis) keeps joints 3 and 9 between d11 - d10 and d11 + d10
//!   apart; the assembly branch is the one with the coupler alongside the
//!   upper arm (loop `branch = -1`). With the tool pointing down, the box (59)
//!   (x 1.4-2.1, y -0.3-0.3, z 1.4-1.7 m) is reached with joint 2 in about
//!   \[-47, -1\] deg, and the plane y = 0 of box (65) (x 1.25-2.25, z
//!   0.85-2.15 m) with joint 2 in about \[-60, 14\] deg and joint 8 in about
//!   \[-2, 46\] deg, except below the line joining (x 1.25, z 1.245 m) and
//!   (x 1.35, z 0.965 m): there the elbow would have to fold below 32 deg,
//!   which Table 2's lengths forbid (joints 2/8 and 10 are never closer than
//!   d11 - d9 = 739 mm, crank and coupler then in line, joint 9 at -180 deg),
//!   so the wrist centre stays at least 1.388 m from the shoulder (tested in
//!   `tests/closed_loops.rs`; 3 points of the 7 x 9 grid).
//!
//! ## Performance
//! [`Data`] caches the constant part of every frame transform keyed on xi,
//! so repeated calls with the same xi only evaluate the joint rotations; no
//! call allocates on a serial chain. Closed loops use small dynamic matrices
//! (their Newton steps and implicit derivatives allocate). For many
//! configurations of a serial chain at one xi, [`SerialChain`] multiplies
//! out the constant parts once and evaluates only the joints, two
//! configurations at a time in SIMD registers in its batch call
//! ([`SerialChain::matrices_into`]). Figures:
//! `cargo bench -p flexcal-kinematics`.
//!
//! ## Limitations
//! - A planar loop constraint closes the in-plane components only: errors
//!   out of the loop's plane are assumed taken up by the mechanism's
//!   clearances, as the paper's planar relation U does.
//! - The loop solver follows the assembly by continuation along the
//!   straight line in q from the previous configuration (or the home
//!   configuration), so it keeps the branch it starts on but cannot go
//!   around a dead point that line crosses; the four-bar closed form keeps
//!   a declared assembly branch.
//! - The inverse model is local (nearest solution to the seed), not an
//!   enumeration of all branches.
//! - The IR-663 slider-crank geometry is a plausible choice, not KUKA's.
//! - Linear couplings may only follow actuated or coupled joints (not passive
//!   loop joints); a loop's passive joints may depend on earlier loops.
//! - Parameter names follow `quantity + frame name`; frame names ending in
//!   digits can make two names collide (frame `1` `l3` and frame `13` `l`):
//!   choose frame names accordingly.

#![deny(missing_docs)]

mod builtin;
mod description;
mod error;
mod export;
mod forward;
mod import;
mod inverse;
mod model;
mod pose;
mod sensitivity;
mod serial;
mod symoro;
pub mod urdf;

pub use builtin::builtin_robot_names;
pub use description::{
    CouplingTerm, FrameDescription, JointType, LinkDescription, LoopConstraint, LoopDescription,
    LoopSolver, RobotDescription, SliderCrankDescription, TransformDescription, rpy_from_rotation,
};
pub use error::{KinematicsError, LoopSingularity};
pub use export::{ExportFormat, ExportOptions, MdhRow, MdhTable, RobotExport, export_robot};
pub use forward::{
    Data, PointLoad, actuated_forces_into, forward_frame_pose, forward_frames, forward_named_pose,
    forward_pose, frame_param_and_joint_jacobians_into, frame_param_jacobian,
    frame_param_jacobian_into, frame_points_jacobians_into, joint_jacobian, joint_jacobian_into,
    param_and_joint_jacobians_into, param_jacobian, param_jacobian_into,
};
pub use import::{ImportOptions, ImportedRobot, LinkMass};
pub use inverse::{InverseOptions, InverseSolution, InverseTarget, inverse_pose};
pub use model::{ActuatedKind, Model, ParamInfo, ParamKind, Quantity};
pub use sensitivity::{
    SensitivityTable, actuated_from_joint_angles, joint_angles_from_actuated, sensitivity_indices,
};
pub use serial::SerialChain;
