//! Small rotation-group helpers and the closed-form rigid registration.

use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};

use crate::error::CalibError;

/// Skew-symmetric matrix `[v]x` with `[v]x w = v x w`.
pub(crate) fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// Rotation `exp([phi]x)` of a rotation vector (rad).
pub fn rotation_from_vector(phi: &Vector3<f64>) -> UnitQuaternion<f64> {
    UnitQuaternion::from_scaled_axis(*phi)
}

/// Rotation vector (rad, angle in `[0, pi]`) of a rotation: the logarithm map.
pub fn vector_from_rotation(r: &UnitQuaternion<f64>) -> Vector3<f64> {
    r.scaled_axis()
}

/// Left Jacobian of SO(3): `exp(phi + dphi) = exp([J_l(phi) dphi]x) exp(phi)` to first order.
pub(crate) fn left_jacobian(phi: &Vector3<f64>) -> Matrix3<f64> {
    let theta = phi.norm();
    let k = skew(phi);
    let (a, b) = if theta < 1e-5 {
        // Taylor series: the closed form loses all digits near zero.
        (
            0.5 - theta * theta / 24.0,
            1.0 / 6.0 - theta * theta / 120.0,
        )
    } else {
        let t2 = theta * theta;
        (
            (1.0 - theta.cos()) / t2,
            (theta - theta.sin()) / (t2 * theta),
        )
    };
    Matrix3::identity() + a * k + b * k * k
}

/// Inverse of [`left_jacobian`].
pub(crate) fn left_jacobian_inverse(phi: &Vector3<f64>) -> Matrix3<f64> {
    let theta = phi.norm();
    let k = skew(phi);
    let c = if theta < 1e-5 {
        1.0 / 12.0 + theta * theta / 720.0
    } else {
        1.0 / (theta * theta) - (1.0 + theta.cos()) / (2.0 * theta * theta.sin())
    };
    Matrix3::identity() - 0.5 * k + c * k * k
}

/// Rigid transform `x_a_b` minimising `sum_i |x_a_b * p_b[i] - p_a[i]|^2`
/// (Kabsch / Horn, by SVD of the cross-covariance, reflection excluded).
///
/// # Errors
/// [`CalibError::DegenerateRegistration`] when the lengths differ, fewer than
/// three points are given, or the points are collinear (the rotation about
/// their line is then undetermined).
pub fn register_points(
    p_a: &[Vector3<f64>],
    p_b: &[Vector3<f64>],
) -> Result<Isometry3<f64>, CalibError> {
    if p_a.len() != p_b.len() || p_a.len() < 3 {
        return Err(CalibError::DegenerateRegistration {
            what: format!(
                "{} and {} points given; at least 3 pairs are needed",
                p_a.len(),
                p_b.len()
            ),
        });
    }
    let n = p_a.len() as f64;
    let ca = p_a.iter().sum::<Vector3<f64>>() / n;
    let cb = p_b.iter().sum::<Vector3<f64>>() / n;
    let mut h = Matrix3::zeros();
    for (a, b) in p_a.iter().zip(p_b) {
        h += (b - cb) * (a - ca).transpose();
    }
    let svd = h.svd(true, true);
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
        return Err(CalibError::DegenerateRegistration {
            what: "SVD of the cross-covariance failed".into(),
        });
    };
    let mut s = svd.singular_values;
    s.as_mut_slice()
        .sort_by(|x, y| y.partial_cmp(x).unwrap_or(std::cmp::Ordering::Equal));
    if s[0] <= 0.0 || s[1] <= 1e-9 * s[0] {
        return Err(CalibError::DegenerateRegistration {
            what: "the measured points are collinear or coincide".into(),
        });
    }
    // H = sum b a^T = U S V^T gives R = V diag(1, 1, d) U^T, d excluding reflections.
    let d = (v_t.transpose() * u.transpose()).determinant().signum();
    let r = v_t.transpose() * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * u.transpose();
    let rotation = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r));
    let t = ca - rotation * cb;
    Ok(Isometry3::from_parts(Translation3::from(t), rotation))
}

/// The rotation nearest (in the chordal, Frobenius sense) to the rotations
/// `r_k`: the projection of their sum onto SO(3) by SVD. For rotations
/// scattered by small errors about one rotation, that rotation.
///
/// # Errors
/// [`CalibError::DegenerateRegistration`] when no rotation is given or the
/// sum is degenerate (rotations spread over every direction).
pub fn mean_rotation(rotations: &[UnitQuaternion<f64>]) -> Result<UnitQuaternion<f64>, CalibError> {
    let sum: Matrix3<f64> = rotations
        .iter()
        .map(|r| r.to_rotation_matrix().into_inner())
        .sum();
    let svd = sum.svd(true, true);
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
        return Err(CalibError::DegenerateRegistration {
            what: "SVD of the sum of rotations failed".into(),
        });
    };
    let smallest = svd.singular_values.min();
    if rotations.is_empty() || smallest <= 1e-9 * rotations.len() as f64 {
        return Err(CalibError::DegenerateRegistration {
            what: format!(
                "the {} measured orientations do not scatter about one rotation",
                rotations.len()
            ),
        });
    }
    let d = (u * v_t).determinant().signum();
    let r = u * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * v_t;
    Ok(UnitQuaternion::from_rotation_matrix(
        &Rotation3::from_matrix_unchecked(r),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn mean_rotation_recovers_the_rotation_errors_scatter_about() {
        let mut rng = ChaCha8Rng::seed_from_u64(12);
        let center = rotation_from_vector(&Vector3::new(0.4, -1.1, 2.5));
        let scattered: Vec<UnitQuaternion<f64>> = (0..200)
            .map(|_| {
                let e = Vector3::from_fn(|_, _| rng.random_range(-1e-3..1e-3));
                center * rotation_from_vector(&e)
            })
            .collect();
        let mean = mean_rotation(&scattered).unwrap();
        // Uniform errors of +-1 mrad per axis over 200 draws: the mean is
        // off by about 0.6 mrad / sqrt(200) per axis.
        assert!((mean.inverse() * center).angle() < 2e-4);
        assert!(mean_rotation(&[]).is_err());
        // The identity and the half turns about x, y and z sum to zero.
        let half = |axis: Vector3<f64>| rotation_from_vector(&(axis * std::f64::consts::PI));
        let opposite = [
            UnitQuaternion::identity(),
            half(Vector3::x()),
            half(Vector3::y()),
            half(Vector3::z()),
        ];
        assert!(mean_rotation(&opposite).is_err());
    }

    #[test]
    fn left_jacobian_matches_finite_differences() {
        let phi = Vector3::new(0.3, -0.7, 0.2);
        let jl = left_jacobian(&phi);
        let h = 1e-6;
        for j in 0..3 {
            let mut e = Vector3::zeros();
            e[j] = h;
            let plus = rotation_from_vector(&(phi + e));
            let minus = rotation_from_vector(&(phi - e));
            // omega with exp(omega) R(phi) = R(phi + dphi).
            let w = vector_from_rotation(&(plus * minus.inverse())) / (2.0 * h);
            for i in 0..3 {
                assert!((w[i] - jl[(i, j)]).abs() < 1e-8, "{i},{j}");
            }
        }
        let product = left_jacobian_inverse(&phi) * jl;
        assert!((product - Matrix3::identity()).norm() < 1e-12);
        let small = Vector3::new(1e-7, 2e-7, -1e-7);
        assert!(
            (left_jacobian_inverse(&small) * left_jacobian(&small) - Matrix3::identity()).norm()
                < 1e-12
        );
    }

    #[test]
    fn registration_recovers_a_rigid_transform() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let truth = Isometry3::from_parts(
            Translation3::new(1.0, -3.2, 0.4),
            rotation_from_vector(&Vector3::new(0.2, 2.5, -0.4)),
        );
        let p_b: Vec<Vector3<f64>> = (0..20)
            .map(|_| Vector3::new(rng.random(), rng.random(), rng.random()))
            .collect();
        let p_a: Vec<Vector3<f64>> = p_b
            .iter()
            .map(|p| truth * nalgebra::Point3::from(*p))
            .map(|p| p.coords)
            .collect();
        let x = register_points(&p_a, &p_b).unwrap();
        assert!((x.translation.vector - truth.translation.vector).norm() < 1e-12);
        assert!(x.rotation.angle_to(&truth.rotation) < 1e-12);
        let line: Vec<Vector3<f64>> = (0..5).map(|i| Vector3::new(i as f64, 0.0, 0.0)).collect();
        assert!(matches!(
            register_points(&line, &line),
            Err(CalibError::DegenerateRegistration { .. })
        ));
    }
}
