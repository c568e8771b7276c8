//! Small pose displacements and differences, `[linear; angular]`.

use nalgebra::{Isometry3, SVector, Translation3, UnitQuaternion, Vector3, Vector6};

/// Applies a small displacement `[dp; dphi]` to a pose: translation added,
/// rotation `exp([dphi]x) R`.
pub fn displace(x: &Isometry3<f64>, d: &Vector6<f64>) -> Isometry3<f64> {
    let dp = Vector3::new(d[0], d[1], d[2]);
    let dphi = Vector3::new(d[3], d[4], d[5]);
    Isometry3::from_parts(
        Translation3::from(x.translation.vector + dp),
        UnitQuaternion::from_scaled_axis(dphi) * x.rotation,
    )
}

/// Pose difference `[p_a - p_b; phi]` with `R_a = exp([phi]x) R_b`.
pub fn pose_difference(a: &Isometry3<f64>, b: &Isometry3<f64>) -> Vector6<f64> {
    let dp = a.translation.vector - b.translation.vector;
    let phi = (a.rotation * b.rotation.inverse()).scaled_axis();
    Vector6::new(dp.x, dp.y, dp.z, phi.x, phi.y, phi.z)
}

/// Size of the position part of an error vector (m).
pub fn position_norm(e: &SVector<f64, 6>) -> f64 {
    e.fixed_rows::<3>(0).norm()
}

/// Distance between two poses along a path: position change (m) plus
/// rotation (rad) counted as 1 m per radian. Only ratios of such distances
/// are used (to place the points for extrapolation), so the weighting of
/// rotation merely needs to be of the robot's size.
pub(crate) fn path_distance(a: &Isometry3<f64>, b: &Isometry3<f64>) -> f64 {
    let d = pose_difference(a, b);
    d.fixed_rows::<3>(0).norm() + d.fixed_rows::<3>(3).norm()
}
