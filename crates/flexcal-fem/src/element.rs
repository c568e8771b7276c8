//! Element stiffness matrices and equivalent nodal loads, local and global.

use nalgebra::{Matrix3, Matrix6, SMatrix, SVector, Vector3};

use crate::error::{FemError, Result};
use crate::structure::{Beam, ElementId, Joint, NodeId, Section, Structure};

/// A 12 x 12 element matrix: rows and columns ordered
/// `[ux uy uz rx ry rz]` of node `i` then of node `j`.
pub type Matrix12 = SMatrix<f64, 12, 12>;

/// A 12-vector ordered as the rows of a [`Matrix12`].
pub type Vector12 = SVector<f64, 12>;

/// An element's stiffness in global axes together with its DOF map.
#[derive(Debug, Clone, PartialEq)]
pub struct ElementMatrix {
    /// The element's two nodes `[i, j]`.
    pub nodes: [NodeId; 2],
    /// Stiffness in global axes [N/m, N/rad, N.m/m, N.m/rad blocks].
    pub stiffness: Matrix12,
}

impl ElementMatrix {
    /// Global DOF index (`6 * node + dof`) of row `row` (0..12).
    pub fn global_dof(&self, row: usize) -> usize {
        6 * self.nodes[row / 6] + row % 6
    }
}

/// Relative tolerance below which a cross product is taken as parallel vectors.
const PARALLEL_TOLERANCE: f64 = 1e-9;

/// Rotation whose rows are the local axes x, y, z of a beam expressed in
/// global axes (so `local = R * global`): x along i->j, y = unit(vecxz x x),
/// z = x x y.
pub fn beam_rotation(structure: &Structure, beam: usize) -> Result<(Matrix3<f64>, f64)> {
    let b = structure.beam(beam)?;
    let label = || format!("beam '{}'", b.name);
    let (x, length) = unit_axis(structure, b.i, b.j, label)?;
    let y_raw = b.vecxz.cross(&x);
    let vecxz_norm = b.vecxz.norm();
    let y_norm = y_raw.norm();
    if y_norm.is_nan() || y_norm <= PARALLEL_TOLERANCE * vecxz_norm || vecxz_norm == 0.0 {
        return Err(FemError::DegenerateOrientation {
            element: label(),
            field: "vecxz",
            message: format!("{:?} is zero or parallel to the beam axis", b.vecxz),
        });
    }
    let y = y_raw / y_norm;
    let z = x.cross(&y);
    Ok((
        Matrix3::from_rows(&[x.transpose(), y.transpose(), z.transpose()]),
        length,
    ))
}

fn unit_axis(
    structure: &Structure,
    i: NodeId,
    j: NodeId,
    label: impl Fn() -> String,
) -> Result<(Vector3<f64>, f64)> {
    let p = structure.positions();
    let d = p[j] - p[i];
    let length = d.norm();
    let scale = p[i].norm().max(p[j].norm()).max(1.0);
    if length.is_nan() || length <= 1e-12 * scale {
        return Err(FemError::ZeroLength {
            element: label(),
            node_i: structure.node_name(i).to_string(),
            node_j: structure.node_name(j).to_string(),
            length,
        });
    }
    Ok((d / length, length))
}

/// Stiffness of a 3D beam in its local axes, before end releases: the
/// Euler-Bernoulli element, or Timoshenko in a bending plane whose shear area
/// is given (shear parameter phi = 12 E I / (G Av L^2)).
pub fn beam_local_stiffness(section: &Section, length: f64) -> Matrix12 {
    let mut k = Matrix12::zeros();
    let mut set = |a: usize, b: usize, value: f64| {
        k[(a, b)] = value;
        k[(b, a)] = value;
    };
    let l = length;
    let axial = section.youngs_modulus * section.area / l;
    let torsion = section.shear_modulus * section.torsion_constant / l;
    set(0, 0, axial);
    set(6, 6, axial);
    set(0, 6, -axial);
    set(3, 3, torsion);
    set(9, 9, torsion);
    set(3, 9, -torsion);

    let phi = |inertia: f64, shear_area: Option<f64>| match shear_area {
        Some(av) => 12.0 * section.youngs_modulus * inertia / (section.shear_modulus * av * l * l),
        None => 0.0,
    };
    // Bending in the local x-y plane: deflection v, rotation rz = dv/dx.
    // Bending in the local x-z plane: deflection w, rotation ry = -dw/dx,
    // hence the opposite sign of the translation-rotation couplings.
    for (translation, rotation, inertia, shear_area, sign) in [
        (1usize, 5usize, section.iz, section.shear_area_y, 1.0),
        (2, 4, section.iy, section.shear_area_z, -1.0),
    ] {
        let ph = phi(inertia, shear_area);
        let c = section.youngs_modulus * inertia / ((1.0 + ph) * l * l * l);
        let (t1, r1, t2, r2) = (translation, rotation, translation + 6, rotation + 6);
        set(t1, t1, 12.0 * c);
        set(t2, t2, 12.0 * c);
        set(t1, t2, -12.0 * c);
        set(t1, r1, sign * 6.0 * l * c);
        set(t1, r2, sign * 6.0 * l * c);
        set(t2, r1, -sign * 6.0 * l * c);
        set(t2, r2, -sign * 6.0 * l * c);
        set(r1, r1, (4.0 + ph) * l * l * c);
        set(r2, r2, (4.0 + ph) * l * l * c);
        set(r1, r2, (2.0 - ph) * l * l * c);
    }
    k
}

/// Condenses released local degrees of freedom out of a local element
/// stiffness and its local load vector (static condensation, one released
/// degree of freedom at a time). Released rows and columns end up zero.
///
/// A released degree of freedom whose remaining stiffness vanishes (both ends
/// of the same direction released) carries nothing and is simply dropped.
pub fn condense_releases(k: &mut Matrix12, f: Option<&mut Vector12>, releases: &[bool; 12]) {
    let scale = (0..12).map(|d| k[(d, d)].abs()).fold(0.0, f64::max);
    let mut f = f;
    for r in (0..12).filter(|&r| releases[r]) {
        let pivot = k[(r, r)];
        if pivot > 1e-12 * scale {
            let column: Vector12 = k.column(r).into_owned();
            for a in 0..12 {
                if a == r || column[a] == 0.0 {
                    continue;
                }
                let factor = column[a] / pivot;
                for b in 0..12 {
                    k[(a, b)] -= factor * column[b];
                }
                if let Some(f) = f.as_deref_mut() {
                    f[a] -= factor * f[r];
                }
            }
        }
        k.row_mut(r).fill(0.0);
        k.column_mut(r).fill(0.0);
        if let Some(f) = f.as_deref_mut() {
            f[r] = 0.0;
        }
    }
}

/// `T^T K T` for `T = blockdiag(R, R, R, R)`, block by block.
fn rotate_to_global(local: &Matrix12, rotation: &Matrix3<f64>) -> Matrix12 {
    let mut global = Matrix12::zeros();
    let rt = rotation.transpose();
    for a in 0..4 {
        for b in 0..4 {
            let block: Matrix3<f64> = local.fixed_view::<3, 3>(3 * a, 3 * b).into_owned();
            global
                .fixed_view_mut::<3, 3>(3 * a, 3 * b)
                .copy_from(&(rt * block * rotation));
        }
    }
    global
}

/// Global stiffness of beam `beam` (paper equations (19)-(20)), releases applied.
pub fn beam_stiffness(structure: &Structure, beam: usize) -> Result<Matrix12> {
    let b: &Beam = structure.beam(beam)?;
    let (rotation, length) = beam_rotation(structure, beam)?;
    let mut k = beam_local_stiffness(&b.section, length);
    if b.releases.iter().any(|&r| r) {
        condense_releases(&mut k, None, &b.releases);
    }
    Ok(rotate_to_global(&k, &rotation))
}

/// Rotation whose rows are the joint's local axes in global axes: x along
/// the axis, y from `local_y` (orthogonalised) or any perpendicular.
pub fn joint_rotation(joint: &Joint) -> Result<Matrix3<f64>> {
    let label = || format!("joint '{}'", joint.name);
    let axis_norm = joint.axis.norm();
    if axis_norm.is_nan() || axis_norm <= 0.0 {
        return Err(FemError::DegenerateOrientation {
            element: label(),
            field: "axis",
            message: "zero vector".to_string(),
        });
    }
    let x = joint.axis / axis_norm;
    let y_raw = match joint.local_y {
        Some(y) => {
            let y_perp = y - x * x.dot(&y);
            let perp_norm = y_perp.norm();
            if perp_norm.is_nan() || perp_norm <= PARALLEL_TOLERANCE * y.norm() || y.norm() == 0.0 {
                return Err(FemError::DegenerateOrientation {
                    element: label(),
                    field: "local_y",
                    message: format!("{y:?} is zero or parallel to the joint axis"),
                });
            }
            y_perp
        }
        None => {
            // The global axis least aligned with x gives a well-conditioned
            // perpendicular.
            let i = x.iamin();
            let mut e = Vector3::zeros();
            e[i] = 1.0;
            e - x * x.dot(&e)
        }
    };
    let y = y_raw.normalize();
    let z = x.cross(&y);
    Ok(Matrix3::from_rows(&[
        x.transpose(),
        y.transpose(),
        z.transpose(),
    ]))
}

/// Global stiffness of a joint whose stiffness values are `stiffness` (so
/// that a derivative with respect to one value is this matrix with a unit
/// entry). Equations (17)-(18) with rigid offsets to the midpoint.
fn joint_stiffness_with(
    structure: &Structure,
    joint: &Joint,
    stiffness: &[f64; 6],
) -> Result<Matrix12> {
    let rotation = joint_rotation(joint)?;
    let rt = rotation.transpose();
    let translational = rt
        * Matrix3::from_diagonal(&Vector3::new(stiffness[0], stiffness[1], stiffness[2]))
        * rotation;
    let rotational = rt
        * Matrix3::from_diagonal(&Vector3::new(stiffness[3], stiffness[4], stiffness[5]))
        * rotation;
    let mut d = Matrix6::zeros();
    d.fixed_view_mut::<3, 3>(0, 0).copy_from(&translational);
    d.fixed_view_mut::<3, 3>(3, 3).copy_from(&rotational);

    let p = structure.positions();
    let mut k = Matrix12::zeros();
    if p[joint.i] == p[joint.j] {
        // The usual case, coincident nodes: equation (17) as printed.
        k.fixed_view_mut::<6, 6>(0, 0).copy_from(&d);
        k.fixed_view_mut::<6, 6>(6, 6).copy_from(&d);
        k.fixed_view_mut::<6, 6>(0, 6).copy_from(&(-d));
        k.fixed_view_mut::<6, 6>(6, 0).copy_from(&(-d));
        return Ok(k);
    }
    let midpoint = (p[joint.i] + p[joint.j]) * 0.5;
    // Spring-point displacement of node n: u_n + theta_n x (m - p_n),
    // i.e. E_n = [I, -skew(m - p_n); 0, I].
    let offset_map = |node: NodeId| {
        let mut e = Matrix6::identity();
        let d = midpoint - p[node];
        e.fixed_view_mut::<3, 3>(0, 3)
            .copy_from(&(-d.cross_matrix()));
        e
    };
    let (ei, ej) = (offset_map(joint.i), offset_map(joint.j));
    k.fixed_view_mut::<6, 6>(0, 0)
        .copy_from(&(ei.transpose() * d * ei));
    k.fixed_view_mut::<6, 6>(6, 6)
        .copy_from(&(ej.transpose() * d * ej));
    let kij = -(ei.transpose() * d * ej);
    k.fixed_view_mut::<6, 6>(0, 6).copy_from(&kij);
    k.fixed_view_mut::<6, 6>(6, 0).copy_from(&kij.transpose());
    Ok(k)
}

/// Global stiffness of joint `joint`.
pub fn joint_stiffness(structure: &Structure, joint: usize) -> Result<Matrix12> {
    let j = structure.joint(joint)?;
    joint_stiffness_with(structure, j, &j.stiffness)
}

/// Derivative of joint `joint`'s global stiffness matrix with respect to its
/// stiffness value number `component` (0..6, order of [`Joint::stiffness`]).
/// The matrix is linear in each value, so this is exact; with it,
/// du/dk = -K^{-1} (dK/dk) u.
pub fn joint_stiffness_derivative(
    structure: &Structure,
    joint: usize,
    component: usize,
) -> Result<Matrix12> {
    let j = structure.joint(joint)?;
    if component >= 6 {
        return Err(crate::error::invalid(
            &format!("joint '{}'", j.name),
            "stiffness",
            format!("component {component} out of range 0..6"),
        ));
    }
    let mut unit = [0.0; 6];
    unit[component] = 1.0;
    joint_stiffness_with(structure, j, &unit)
}

/// Global stiffness of axial spring `spring`: k e e^T on the translations.
pub fn spring_stiffness(structure: &Structure, spring: usize) -> Result<Matrix12> {
    let s = structure.spring(spring)?;
    let (e, _) = unit_axis(structure, s.i, s.j, || format!("spring '{}'", s.name))?;
    let block = e * e.transpose() * s.k;
    let mut k = Matrix12::zeros();
    k.fixed_view_mut::<3, 3>(0, 0).copy_from(&block);
    k.fixed_view_mut::<3, 3>(6, 6).copy_from(&block);
    k.fixed_view_mut::<3, 3>(0, 6).copy_from(&(-block));
    k.fixed_view_mut::<3, 3>(6, 0).copy_from(&(-block));
    Ok(k)
}

/// Global stiffness matrix and DOF map of any element.
pub fn element_matrix(structure: &Structure, element: ElementId) -> Result<ElementMatrix> {
    let stiffness = match element {
        ElementId::Beam(b) => beam_stiffness(structure, b)?,
        ElementId::Joint(j) => joint_stiffness(structure, j)?,
        ElementId::Spring(s) => spring_stiffness(structure, s)?,
    };
    let (i, j) = structure.element_nodes(element);
    Ok(ElementMatrix {
        nodes: [i, j],
        stiffness,
    })
}

/// Consistent equivalent nodal loads of a beam's own weight under `gravity`
/// (m/s^2), global axes (`[node i wrench; node j wrench]`, N and N.m).
///
/// With w = mass_per_length * gravity in local axes: axial w_x L / 2 per end;
/// transverse w L / 2 per end with end moments +-w L^2 / 12 (the fixed-end
/// forces of a uniform load, exact for both Euler-Bernoulli and Timoshenko
/// beams). Releases condense these loads like the stiffness.
pub fn beam_weight_loads(
    structure: &Structure,
    beam: usize,
    gravity: &Vector3<f64>,
) -> Result<Vector12> {
    let b = structure.beam(beam)?;
    if b.mass_per_length == 0.0 || gravity.iter().all(|&g| g == 0.0) {
        return Ok(Vector12::zeros());
    }
    let (rotation, l) = beam_rotation(structure, beam)?;
    let w = rotation * (gravity * b.mass_per_length);
    let mut f = Vector12::zeros();
    f[0] = w.x * l / 2.0;
    f[6] = w.x * l / 2.0;
    f[1] = w.y * l / 2.0;
    f[7] = w.y * l / 2.0;
    f[5] = w.y * l * l / 12.0;
    f[11] = -w.y * l * l / 12.0;
    f[2] = w.z * l / 2.0;
    f[8] = w.z * l / 2.0;
    // ry = -dw/dx flips the sign of the z-load end moments.
    f[4] = -w.z * l * l / 12.0;
    f[10] = w.z * l * l / 12.0;
    if b.releases.iter().any(|&r| r) {
        let mut k = beam_local_stiffness(&b.section, l);
        condense_releases(&mut k, Some(&mut f), &b.releases);
    }
    let mut global = Vector12::zeros();
    let rt = rotation.transpose();
    for a in 0..4 {
        let part: Vector3<f64> = f.fixed_rows::<3>(3 * a).into_owned();
        global.fixed_rows_mut::<3>(3 * a).copy_from(&(rt * part));
    }
    Ok(global)
}
