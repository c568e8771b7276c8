//! The forward model of a serial chain precomputed for one parameter
//! vector ([`SerialChain`]).

use std::ops::{Add, Mul, Sub};

use nalgebra::{Isometry3, Matrix3, Matrix4, Rotation3, Translation3, UnitQuaternion, Vector3};

use crate::KinematicsError;
use crate::description::JointType;
use crate::error::check_vector;
use crate::model::{JointSource, Model};
use crate::pose::Pose;

/// Configurations the batch kernel evaluates together, one per lane of
/// [`Lanes`].
const LANES: usize = 2;

/// One quantity of [`LANES`] configurations: one SSE2 register on x86-64
/// (part of every x86-64 CPU, so no target-cpu flag is needed), NEON on
/// aarch64. Each operation is the IEEE operation of each lane, so a lane's
/// result is the bit-for-bit result of the same operations on `f64`.
type Lanes = wide::f64x2;

/// The bits of [`Lanes`], for the quadrant of the sine and cosine.
type LaneBits = wide::u64x2;

/// A number of the chain's arithmetic: `f64` for the constant parts and for
/// one configuration, or [`Lanes`] for the configurations evaluated
/// together (structure of arrays: each quantity of the [`LANES`]
/// configurations in one register). Both evaluate the same operations in
/// the same order, so that a lane's result is the `f64` result to the bit.
trait Scalar: Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> {
    /// The constant `value` in every lane.
    fn splat(value: f64) -> Self;
    /// `(sin x, cos x)` of each lane (see [`reduced_sin_cos`]).
    fn sin_cos(self) -> (Self, Self);
}

/// Within the range of [`reduced_sin_cos`]; false for NaN.
#[inline(always)]
fn in_range(x: &f64) -> bool {
    x.abs() < 1e5
}

impl Scalar for f64 {
    #[inline(always)]
    fn splat(value: f64) -> Self {
        value
    }

    #[inline(always)]
    fn sin_cos(self) -> (Self, Self) {
        if !in_range(&self) {
            return f64::sin_cos(self);
        }
        let (sin_r, cos_r, shifted) = reduced_sin_cos(self);
        // Quadrant k: (sin, cos) = (s, c), (c, -s), (-s, -c), (-c, s): odd
        // quadrants swap the two, bit 1 of k and of k + 1 give the signs.
        let k = shifted.to_bits();
        let swap = 0u64.wrapping_sub(k & 1);
        let (s, c) = (sin_r.to_bits(), cos_r.to_bits());
        let sin_bits = (s & !swap) | (c & swap);
        let cos_bits = (c & !swap) | (s & swap);
        (
            f64::from_bits(sin_bits ^ ((k & 2) << 62)),
            f64::from_bits(cos_bits ^ ((k.wrapping_add(1) & 2) << 62)),
        )
    }
}

impl Scalar for Lanes {
    #[inline(always)]
    fn splat(value: f64) -> Self {
        Lanes::splat(value)
    }

    /// The `f64` version lane by lane, the quadrant's bit operations on
    /// [`LaneBits`].
    #[inline(always)]
    fn sin_cos(self) -> (Self, Self) {
        let (sin_r, cos_r, shifted) = reduced_sin_cos(self);
        let k = shifted.to_bits();
        let one = LaneBits::splat(1);
        let two = LaneBits::splat(2);
        let swap = LaneBits::splat(0) - (k & one);
        let (s, c) = (sin_r.to_bits(), cos_r.to_bits());
        let sin_bits = (s & !swap) | (c & swap);
        let cos_bits = (c & !swap) | (s & swap);
        let sin = Lanes::from_bits(sin_bits ^ ((k & two) << 62));
        let cos = Lanes::from_bits(cos_bits ^ (((k + one) & two) << 62));
        let x_lanes = self.to_array();
        if x_lanes.iter().all(in_range) {
            return (sin, cos);
        }
        let (mut sin, mut cos) = (sin.to_array(), cos.to_array());
        for (l, x) in x_lanes.iter().enumerate() {
            if !in_range(x) {
                (sin[l], cos[l]) = f64::sin_cos(*x);
            }
        }
        (Lanes::new(sin), Lanes::new(cos))
    }
}

/// A rigid transform as three rotation columns and a translation, with the
/// products written out (3 x 3 and 3 x 4 sizes do not gain from a generic
/// product); `T` is `f64`, or [`Lanes`] for several transforms at once.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Rigid<T = f64> {
    /// Columns of the rotation: `columns[c][row]`.
    columns: [[T; 3]; 3],
    /// Translation (m).
    p: [T; 3],
}

impl Rigid {
    const IDENTITY: Rigid = Rigid {
        columns: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        p: [0.0; 3],
    };

    fn from_pose(pose: &Pose) -> Rigid {
        let m = &pose.r.data.0;
        Rigid {
            columns: *m,
            p: [pose.p.x, pose.p.y, pose.p.z],
        }
    }

    /// The same transform in every lane.
    #[inline(always)]
    fn splat<T: Scalar>(&self) -> Rigid<T> {
        Rigid {
            columns: self.columns.map(|c| c.map(T::splat)),
            p: self.p.map(T::splat),
        }
    }
}

impl<T: Scalar> Rigid<T> {
    /// `self.rotation * v`.
    #[inline(always)]
    fn rotate(&self, v: &[T; 3]) -> [T; 3] {
        let a = &self.columns;
        [
            a[0][0] * v[0] + a[1][0] * v[1] + a[2][0] * v[2],
            a[0][1] * v[0] + a[1][1] * v[1] + a[2][1] * v[2],
            a[0][2] * v[0] + a[1][2] * v[1] + a[2][2] * v[2],
        ]
    }

    /// `self * other`.
    #[inline(always)]
    fn then(&self, other: &Rigid<T>) -> Rigid<T> {
        let t = self.rotate(&other.p);
        Rigid {
            columns: [
                self.rotate(&other.columns[0]),
                self.rotate(&other.columns[1]),
                self.rotate(&other.columns[2]),
            ],
            p: [self.p[0] + t[0], self.p[1] + t[1], self.p[2] + t[2]],
        }
    }

    /// `self * Rz(theta) Tz(r)` with `(sin, cos)` of theta: only the first
    /// two columns mix, and the translation moves along the third.
    #[inline(always)]
    fn then_joint(&self, sin: T, cos: T, r: T) -> Rigid<T> {
        let [c0, c1, c2] = &self.columns;
        Rigid {
            columns: [
                [
                    cos * c0[0] + sin * c1[0],
                    cos * c0[1] + sin * c1[1],
                    cos * c0[2] + sin * c1[2],
                ],
                [
                    cos * c1[0] - sin * c0[0],
                    cos * c1[1] - sin * c0[1],
                    cos * c1[2] - sin * c0[2],
                ],
                *c2,
            ],
            p: [
                self.p[0] + r * c2[0],
                self.p[1] + r * c2[1],
                self.p[2] + r * c2[2],
            ],
        }
    }

    /// The row-major homogeneous 4 x 4 matrix (translation in m) of one
    /// lane, which `get` reads from each value, into `out` (16 values).
    #[inline(always)]
    fn write_matrix(&self, get: impl Fn(T) -> f64, out: &mut [f64]) {
        let [c0, c1, c2] = self.columns;
        let p = self.p;
        out.copy_from_slice(&[
            get(c0[0]),
            get(c1[0]),
            get(c2[0]),
            get(p[0]), //
            get(c0[1]),
            get(c1[1]),
            get(c2[1]),
            get(p[1]), //
            get(c0[2]),
            get(c1[2]),
            get(c2[2]),
            get(p[2]), //
            0.0,
            0.0,
            0.0,
            1.0,
        ]);
    }
}

/// The sine and cosine of x reduced to [-pi/4, pi/4], and x 2/pi + 1.5 *
/// 2^52, whose low bits are the quadrant, from which [`Scalar::sin_cos`]
/// gets `(sin x, cos x)` within about one unit in the last place for |x| <
/// 1e5 (std's `sin_cos` beyond, and for NaN): Cody-Waite reduction by pi/2
/// and fdlibm's minimax polynomials (Sun Microsystems' `k_sin.c` and
/// `k_cos.c` coefficients), the quadrant applied by bit masks. Inlined,
/// the six of a chain overlap with each other and with the products, where
/// std's are opaque library calls one value at a time.
#[inline(always)]
fn reduced_sin_cos<T: Scalar>(x: T) -> (T, T, T) {
    // pi/2 in two parts: the first 33 bits (so n * PIO2_HI is exact for
    // |n| < 2^20) and the rest (to 2e-21).
    const PIO2_HI: f64 = 1.570_796_326_734_125_6;
    const PIO2_LO: f64 = 6.077_100_506_506_192e-11;
    const S: [f64; 6] = [
        -1.666_666_666_666_663_2e-1,
        8.333_333_333_322_49e-3,
        -1.984_126_982_985_795e-4,
        2.755_731_370_707_007e-6,
        -2.505_076_025_340_686_3e-8,
        1.589_690_995_211_55e-10,
    ];
    const C: [f64; 6] = [
        4.166_666_666_666_66e-2,
        -1.388_888_888_887_411e-3,
        2.480_158_728_947_673e-5,
        -2.755_731_435_139_066_3e-7,
        2.087_572_321_298_175e-9,
        -1.135_964_755_778_819_5e-11,
    ];
    // Nearest integer n to x 2/pi by adding and removing 1.5 * 2^52 (exact
    // for |x 2/pi| < 2^51): `round` is a library call on baseline x86-64.
    // The sum's low mantissa bits are n modulo 4 (the quadrant), read
    // without a float-to-integer conversion, which SSE2 lacks for 64 bits.
    const SHIFT: f64 = 6_755_399_441_055_744.0;
    let c = T::splat;
    let shifted = x * c(std::f64::consts::FRAC_2_PI) + c(SHIFT);
    let n = shifted - c(SHIFT);
    let r = (x - n * c(PIO2_HI)) - n * c(PIO2_LO);
    let z = r * r;
    let sin_r = r + r
        * z
        * (c(S[0]) + z * (c(S[1]) + z * (c(S[2]) + z * (c(S[3]) + z * (c(S[4]) + z * c(S[5]))))));
    let cos_r = c(1.0) - c(0.5) * z
        + z * z
            * (c(C[0])
                + z * (c(C[1]) + z * (c(C[2]) + z * (c(C[3]) + z * (c(C[4]) + z * c(C[5]))))));
    (sin_r, cos_r, shifted)
}

/// How a joint of the chain moves with its actuated coordinate.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Motion {
    /// `Rz(theta + q) Tz(r)`: theta, r constant (rad, m).
    Revolute { theta: f64, r: f64 },
    /// `Rz(theta) Tz(r + q)`: sin and cos of the constant theta, r (m).
    Prismatic { sin: f64, cos: f64, r: f64 },
}

/// One actuated joint: the constant transform from the previous joint's
/// frame (or R0) to this joint's `Rz Tz`, and the motion itself.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Joint {
    before: Rigid,
    q_index: usize,
    motion: Motion,
}

impl Joint {
    /// Previous joint's frame (or R0) to this joint's frame when its
    /// actuated coordinate is `value` (rad or m, one per lane).
    #[inline(always)]
    fn local<T: Scalar>(&self, value: T) -> Rigid<T> {
        let before = self.before.splat::<T>();
        match self.motion {
            Motion::Revolute { theta, r } => {
                let (sin, cos) = (T::splat(theta) + value).sin_cos();
                before.then_joint(sin, cos, T::splat(r))
            }
            Motion::Prismatic { sin, cos, r } => {
                before.then_joint(T::splat(sin), T::splat(cos), T::splat(r) + value)
            }
        }
    }
}

/// The forward model `x_base_tcp(q)` of a serial chain at one parameter
/// vector xi, with every constant part of the frame transforms (41)
/// multiplied out: the fast path for many configurations at fixed xi.
/// Immutable; `Send + Sync`.
///
/// [`forward_pose`](crate::forward_pose) handles every robot flexcal
/// describes (trees, closed loops, couplings, slider cranks) and keeps every
/// frame's pose in a [`Data`](crate::Data) for the Jacobians that follow.
/// When only the TCP pose of a serial chain is wanted, at many
/// configurations and one xi, most of that work is constant: a
/// [`SerialChain`] multiplies out, once, everything of the frame transforms
/// (41) that does not depend on q (fixed frames and the tool transform
/// included), so that each call evaluates only the joints' `Rz(theta)
/// Tz(r)` and one 3 x 4 product per joint, with sine and cosine evaluated
/// inline (agreeing with std's to 4e-16). The batch call
/// [`SerialChain::matrices_into`] evaluates two configurations at once,
/// each quantity of the two in one SIMD register (SSE2 on any x86-64, NEON
/// on aarch64, through the `wide` crate), with the same operations in the
/// same order as one configuration, so that it gives
/// [`SerialChain::matrix`]'s results to the bit. It does not allocate,
/// keeps no state between calls and is shared by threads as is.
///
/// ```
/// use flexcal_kinematics::{Data, RobotDescription, SerialChain, forward_pose};
///
/// let model = RobotDescription::builtin("ur10")?.build()?;
/// let xi = model.nominal_params();
/// let chain = SerialChain::new(&model, xi)?;
/// let q = [0.1, -1.2, 1.0, -0.5, 1.3, 0.2];
/// let x_base_tcp = chain.matrix(&q)?; // homogeneous 4 x 4, m
/// let reference = forward_pose(&model, &mut Data::new(&model), &q, xi)?.to_homogeneous();
/// assert!((x_base_tcp - reference).abs().max() < 1e-12);
/// # Ok::<(), flexcal_kinematics::KinematicsError>(())
/// ```
///
/// Limitations: robots with closed loops, and robots whose TCP path holds a
/// coupled or slider-crank joint, are refused
/// ([`KinematicsError::NotSerial`]); use [`forward_pose`](crate::forward_pose)
/// for them. The chain is built for one xi: a new xi needs a new chain
/// (building one costs about as much as a few forward calls).
#[derive(Debug, Clone, PartialEq)]
pub struct SerialChain {
    n_actuated: usize,
    joints: Vec<Joint>,
    /// Last joint's frame (or R0) to the TCP; `None` when it is the identity.
    tail: Option<Rigid>,
}

impl SerialChain {
    /// The chain of `model` from R0 to its TCP at parameters `xi` (m, rad;
    /// length [`Model::n_params`]). Refuses, by name, a robot with closed
    /// loops or with a coupled or slider-crank joint on the TCP path
    /// ([`KinematicsError::NotSerial`]), and a wrong-length or non-finite xi.
    pub fn new(model: &Model, xi: &[f64]) -> Result<Self, KinematicsError> {
        check_vector("xi", xi, model.n_params())?;
        if let Some(l) = model.loops.first() {
            return Err(KinematicsError::NotSerial {
                robot: model.name.clone(),
                reason: format!("it has the closed loop `{}`", l.name),
            });
        }
        let mut joints = Vec::new();
        // Constant transform accumulated since the last actuated joint.
        let mut pending = Rigid::IDENTITY;
        for &f in &model.tcp_path {
            let frame = &model.frames[f];
            let part = frame.constant_part(xi);
            pending = pending.then(&Rigid::from_pose(&part.pre));
            match (frame.source, frame.joint) {
                (JointSource::Fixed, _) | (_, JointType::Fixed) => {
                    let (sin, cos) = part.theta.sin_cos();
                    pending = pending.then_joint(sin, cos, part.r);
                }
                (JointSource::Actuated(q_index), joint) => {
                    let motion = if joint == JointType::Prismatic {
                        let (sin, cos) = part.theta.sin_cos();
                        Motion::Prismatic {
                            sin,
                            cos,
                            r: part.r,
                        }
                    } else {
                        Motion::Revolute {
                            theta: part.theta,
                            r: part.r,
                        }
                    };
                    joints.push(Joint {
                        before: pending,
                        q_index,
                        motion,
                    });
                    pending = Rigid::IDENTITY;
                }
                _ => {
                    return Err(KinematicsError::NotSerial {
                        robot: model.name.clone(),
                        reason: format!(
                            "the joint of frame `{}` on the path to the TCP is not driven directly by an actuated coordinate",
                            frame.name
                        ),
                    });
                }
            }
        }
        pending = pending.then(&Rigid::from_pose(&model.tool_pose));
        let tail = (pending != Rigid::IDENTITY).then_some(pending);
        Ok(SerialChain {
            n_actuated: model.n_actuated(),
            joints,
            tail,
        })
    }

    /// Number of actuated coordinates: the length of q.
    pub fn n_actuated(&self) -> usize {
        self.n_actuated
    }

    /// `x_base_tcp` with actuated coordinate `j` equal to `q(j)` (one value
    /// per lane), unchecked.
    #[inline(always)]
    fn evaluate<T: Scalar>(&self, q: impl Fn(usize) -> T) -> Rigid<T> {
        let mut joints = self.joints.iter();
        // The first joint's transform is the start: no product.
        let mut x = joints.next().map_or(Rigid::IDENTITY.splat(), |joint| {
            joint.local(q(joint.q_index))
        });
        for joint in joints {
            x = x.then(&joint.local(q(joint.q_index)));
        }
        self.tail.map_or(x, |tail| x.then(&tail.splat()))
    }

    fn checked(&self, q: &[f64]) -> Result<Rigid, KinematicsError> {
        check_vector("q", q, self.n_actuated)?;
        Ok(self.evaluate_one(q))
    }

    /// `x_base_tcp` at one configuration `q`, unchecked: the batch
    /// kernel's operations on `f64`, so that it is a batch's result to the
    /// bit.
    #[inline]
    fn evaluate_one(&self, q: &[f64]) -> Rigid {
        self.evaluate(|j| q[j])
    }

    /// `x_base_tcp` at `q` (rad, m; length [`SerialChain::n_actuated`]) as a
    /// homogeneous 4 x 4 matrix (translation in m): the same transform as
    /// [`forward_pose`](crate::forward_pose) at this chain's xi, to rounding.
    pub fn matrix(&self, q: &[f64]) -> Result<Matrix4<f64>, KinematicsError> {
        let mut rows = [0.0; 16];
        self.checked(q)?.write_matrix(|v| v, &mut rows);
        Ok(Matrix4::from_row_slice(&rows))
    }

    /// `x_base_tcp` at `q` as a rotation and translation (m): the result of
    /// [`forward_pose`](crate::forward_pose) at this chain's xi, to rounding.
    pub fn pose(&self, q: &[f64]) -> Result<Isometry3<f64>, KinematicsError> {
        let x = self.checked(q)?;
        let [c0, c1, c2] = x.columns;
        let r = Matrix3::from_columns(&[Vector3::from(c0), Vector3::from(c1), Vector3::from(c2)]);
        let rotation = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r));
        Ok(Isometry3::from_parts(
            Translation3::from(Vector3::from(x.p)),
            rotation,
        ))
    }

    /// `x_base_tcp` of every row of `q` (row-major, n rows of
    /// [`SerialChain::n_actuated`] values, rad and m) written into `out` as n
    /// row-major homogeneous 4 x 4 matrices (16 values per row, m): the
    /// results of [`SerialChain::matrix`] to the bit. Lengths are checked,
    /// and every value of `q` must be finite (the first that is not is named
    /// by its row and column; `out` is then left as it was).
    ///
    /// Configurations are evaluated two at a time in structure-of-arrays
    /// form (each quantity of the two in one SSE2 register on x86-64), and
    /// an odd last row alone.
    pub fn matrices_into(&self, q: &[f64], out: &mut [f64]) -> Result<(), KinematicsError> {
        let n = out.len() / 16;
        if out.len() != 16 * n {
            return Err(KinematicsError::WrongLength {
                what: "output (16 values per configuration)".into(),
                expected: 16 * (n + 1),
                found: out.len(),
            });
        }
        let width = self.n_actuated;
        if q.len() != n * width {
            return Err(KinematicsError::WrongLength {
                what: format!("q ({n} rows of {width} values, one per output matrix)"),
                expected: n * width,
                found: q.len(),
            });
        }
        if let Some(flat) = q.iter().position(|v| !v.is_finite()) {
            return Err(KinematicsError::NotFinite {
                what: format!("q[{}, {}]", flat / width, flat % width),
            });
        }
        let mut groups = out.chunks_exact_mut(16 * LANES);
        for (g, group) in (&mut groups).enumerate() {
            let q_group = &q[g * LANES * width..(g + 1) * LANES * width];
            let x = self.evaluate(|j| Lanes::new(std::array::from_fn(|l| q_group[l * width + j])));
            for (l, matrix) in group.chunks_exact_mut(16).enumerate() {
                x.write_matrix(|v| v.as_array()[l], matrix);
            }
        }
        let first = n - n % LANES;
        for (k, matrix) in groups.into_remainder().chunks_exact_mut(16).enumerate() {
            let q_row = &q[(first + k) * width..(first + k + 1) * width];
            self.evaluate_one(q_row).write_matrix(|v| v, matrix);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::{LANES, Lanes, Scalar};

    fn sin_cos(x: f64) -> (f64, f64) {
        Scalar::sin_cos(x)
    }

    #[test]
    fn sin_cos_agrees_with_std_to_rounding() {
        let quarter = std::f64::consts::FRAC_PI_4;
        let mut worst = 0.0f64;
        // A fine sweep over +-50 rad and the quadrant boundaries k pi/4.
        let sweep = (-500_000..=500_000).map(|i| i as f64 * 1e-4);
        let boundaries = (-64..=64).flat_map(|k| {
            let x = k as f64 * quarter;
            [x, x.next_up(), x.next_down()]
        });
        for x in sweep
            .chain(boundaries)
            .chain([0.0, -0.0, 1e4 + 0.3, -99_999.0])
        {
            let (s, c) = sin_cos(x);
            let (s_ref, c_ref) = x.sin_cos();
            worst = worst.max((s - s_ref).abs()).max((c - c_ref).abs());
        }
        assert!(worst < 4e-16, "largest difference {worst:e}");
        // Outside the reduction's range, and NaN, std's result.
        assert_eq!(sin_cos(3e7), 3e7f64.sin_cos());
        assert!(sin_cos(f64::NAN).0.is_nan());
    }

    #[test]
    fn each_lane_gives_its_own_value_s_result_to_the_bit() {
        let inputs = [
            0.3,
            -2.9,
            1e5,
            -3e7,
            f64::NAN,
            f64::INFINITY,
            std::f64::consts::FRAC_PI_4.next_up(),
            -0.0,
        ];
        let same = |a: f64, b: f64| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan());
        for group in inputs.windows(LANES) {
            // The trait's: wide's own inherent `sin_cos` is another approximation.
            let (s, c) = Scalar::sin_cos(Lanes::new(std::array::from_fn(|l| group[l])));
            for (l, &x) in group.iter().enumerate() {
                let (s1, c1) = sin_cos(x);
                assert!(
                    same(s.as_array()[l], s1) && same(c.as_array()[l], c1),
                    "{x}"
                );
            }
        }
    }
}
