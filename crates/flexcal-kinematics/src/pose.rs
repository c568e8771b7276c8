//! The rigid transform used inside the algorithms.

use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};

/// Rigid transform as a rotation matrix and a translation: cheaper to compose
/// than a quaternion when axes are read back for the Jacobians.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Pose {
    pub r: Matrix3<f64>,
    pub p: Vector3<f64>,
}

impl Pose {
    pub const IDENTITY: Pose = Pose {
        r: Matrix3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0),
        p: Vector3::new(0.0, 0.0, 0.0),
    };

    #[inline]
    pub fn compose(&self, other: &Pose) -> Pose {
        Pose {
            r: self.r * other.r,
            p: self.p + self.r * other.p,
        }
    }

    pub fn from_isometry(x: &Isometry3<f64>) -> Pose {
        Pose {
            r: *x.rotation.to_rotation_matrix().matrix(),
            p: x.translation.vector,
        }
    }

    pub fn to_isometry(self) -> Isometry3<f64> {
        let rotation =
            UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(self.r));
        Isometry3::from_parts(Translation3::from(self.p), rotation)
    }
}
