//! The twin's own structural mechanics: a linear 3D frame of Timoshenko
//! beams, six-component joint springs and axial springs, written for the
//! twin alone. It shares no code with the models flexcal identifies
//! (`flexcal_fem`'s elements, assembly and solver, `flexcal_elastic`'s
//! robot models) and uses another formulation, so that the twin's truth
//! and the identified beam model agree only as far as the physics does.
//!
//! ## Formulation: force-based (flexibility) beam elements
//! A beam from node `i` to node `j` (length `L`, local axes `x` along the
//! beam, `y`, `z` the principal axes of its section) is written through its
//! exact cantilever flexibility: clamped at `i`, loaded at `j` by
//! `[Fx Fy Fz Mx My Mz]` (local), the tip of a Timoshenko beam moves by
//!
//! ```text
//! ux = Fx L / (E A)                       rx = Mx L / (G J)
//! uy = Fy (L^3 / (3 E Iz) + L / (G Asy)) + Mz L^2 / (2 E Iz)
//! uz = Fz (L^3 / (3 E Iy) + L / (G Asz)) - My L^2 / (2 E Iy)
//! ry = -Fz L^2 / (2 E Iy) + My L / (E Iy)
//! rz =  Fy L^2 / (2 E Iz) + Mz L / (E Iz)
//! ```
//!
//! (Timoshenko and Gere, *Mechanics of Materials*; the shear terms with the
//! shear areas `Asy`, `Asz`). The deformation of `j` relative to the rigid
//! motion of `i` is `d = B u_e` with `B = [-I, [r]x, I, 0; 0, -I, 0, I]`
//! (`r = x_j - x_i`, global axes), so the element stiffness is
//! `K_e = B^T F^-1 B` with `F` the flexibility above rotated to global
//! axes: no shape functions, no local 12 x 12 matrix. A uniform load `w`
//! (N/m, e.g. the beam's weight) enters through its fixed-end forces,
//! `w L / 2` at each end and `+-(L^2 / 12) e_x x w`, which makes the nodal
//! displacements exact for prismatic beams.
//!
//! Joint springs (`kr`, `kr`, `ka`, `kt`, `kt`, `k_axis` in the joint's own
//! axes, `z` along the joint axis) and axial springs join two nodes. Fixed
//! nodes are removed; the stiffness matrix of the free degrees of freedom
//! is factorised by a dense Cholesky decomposition (a structure that can
//! still move freely is reported as a mechanism).
//!
//! ## Limitations
//! Linear (small displacements, small rotations): the twin's non-linear
//! terms are its drives and its process, not large rotations of the arm
//! (a 2 mm deflection of a 2 m arm turns it by 1e-3 rad).

use nalgebra::{DMatrix, DVector, Matrix3, Matrix6, Rotation3, SMatrix, Vector3, Vector6};
use serde::Serialize;

/// Young's modulus of structural steel (Pa): 210 GPa (EN 1993-1-1).
pub const STEEL_YOUNGS_MODULUS_PA: f64 = 2.10e11;
/// Shear modulus of structural steel (Pa): 81 GPa (EN 1993-1-1).
pub const STEEL_SHEAR_MODULUS_PA: f64 = 8.1e10;
/// Density of steel (kg/m^3): 7850 (EN 1991-1-1).
pub const STEEL_DENSITY_KG_M3: f64 = 7850.0;

/// Smallest pivot of the stiffness matrix's Cholesky factor, relative to
/// its largest diagonal entry, below which the structure is taken for a
/// mechanism: round-off in a matrix whose entries span 1e-12 leaves
/// pivots of 1e-16 relative; the twin's softest stiffness (the screws,
/// 1e6 N.m/rad about their joints) against its stiffest (short levers,
/// about 1e11 N/m) is 1e-5.
const PIVOT_TOLERANCE: f64 = 1e-12;

/// Errors of the twin's mechanics.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum MechanicsError {
    /// An element refers to a node that does not exist, or has zero length.
    #[error("twin mechanics: element `{element}`: {reason}")]
    Element {
        /// The element's name.
        element: String,
        /// What is wrong.
        reason: String,
    },
    /// The stiffness matrix is not positive definite: the structure can
    /// move without deforming.
    #[error(
        "twin mechanics: the structure is a mechanism (stiffness matrix not positive definite, or a pivot below 1e-12 of its largest diagonal entry)"
    )]
    Mechanism,
    /// A load vector of the wrong length.
    #[error("twin mechanics: {found} load components for {nodes} nodes (need 6 per node)")]
    LoadLength {
        /// Components given.
        found: usize,
        /// Nodes of the frame.
        nodes: usize,
    },
}

/// Section of a prismatic beam, with its material.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Section {
    /// Young's modulus E (Pa).
    pub youngs_modulus_pa: f64,
    /// Shear modulus G (Pa).
    pub shear_modulus_pa: f64,
    /// Area A (m^2).
    pub area_m2: f64,
    /// Second moment about the local y axis, Iy (m^4): bending in x-z.
    pub iy_m4: f64,
    /// Second moment about the local z axis, Iz (m^4): bending in x-y.
    pub iz_m4: f64,
    /// Torsion constant J (m^4).
    pub torsion_m4: f64,
    /// Shear area along local y, Asy (m^2).
    pub shear_area_y_m2: f64,
    /// Shear area along local z, Asz (m^2).
    pub shear_area_z_m2: f64,
    /// Density (kg/m^3).
    pub density_kg_m3: f64,
}

impl Section {
    /// A steel box of outer `depth` along local y, `width` along local z and
    /// `wall` thickness (m). Torsion by Bredt's formula for a closed
    /// thin-walled section; each shear area is that of the two walls
    /// parallel to the shear (`2 t h`), the thin-walled value.
    pub fn steel_box(depth: f64, width: f64, wall: f64) -> Self {
        let (h, b, t) = (depth, width, wall);
        let (hi, bi) = (h - 2.0 * t, b - 2.0 * t);
        let (hm, bm) = (h - t, b - t);
        Self {
            youngs_modulus_pa: STEEL_YOUNGS_MODULUS_PA,
            shear_modulus_pa: STEEL_SHEAR_MODULUS_PA,
            area_m2: h * b - hi * bi,
            iz_m4: (b * h.powi(3) - bi * hi.powi(3)) / 12.0,
            iy_m4: (h * b.powi(3) - hi * bi.powi(3)) / 12.0,
            torsion_m4: 2.0 * t * (hm * bm).powi(2) / (hm + bm),
            shear_area_y_m2: 2.0 * t * h,
            shear_area_z_m2: 2.0 * t * b,
            density_kg_m3: STEEL_DENSITY_KG_M3,
        }
    }

    /// A steel tube of outer diameter `outer` and `wall` thickness (m); the
    /// shear area is half the area (thin-walled tube, shear coefficient 0.5).
    pub fn steel_tube(outer: f64, wall: f64) -> Self {
        let (ro, ri) = (outer / 2.0, outer / 2.0 - wall);
        let area = std::f64::consts::PI * (ro * ro - ri * ri);
        let i = std::f64::consts::FRAC_PI_4 * (ro.powi(4) - ri.powi(4));
        Self {
            youngs_modulus_pa: STEEL_YOUNGS_MODULUS_PA,
            shear_modulus_pa: STEEL_SHEAR_MODULUS_PA,
            area_m2: area,
            iy_m4: i,
            iz_m4: i,
            torsion_m4: 2.0 * i,
            shear_area_y_m2: 0.5 * area,
            shear_area_z_m2: 0.5 * area,
            density_kg_m3: STEEL_DENSITY_KG_M3,
        }
    }

    /// A solid rectangle `width` along local y by `thickness` along local z
    /// (m) of a material `(E, nu, density)` (Pa, -, kg/m^3): shear areas
    /// `5 A / 6`, torsion `J = b t^3 (1/3 - 0.21 t / b (1 - t^4 / (12 b^4)))`
    /// (Roark's formulas, table 10.7, for `b >= t`).
    pub fn rectangle(width: f64, thickness: f64, material: (f64, f64, f64)) -> Self {
        let (e, nu, rho) = material;
        let (b, t) = (width.max(thickness), width.min(thickness));
        let area = width * thickness;
        let torsion =
            b * t.powi(3) * (1.0 / 3.0 - 0.21 * t / b * (1.0 - t.powi(4) / (12.0 * b.powi(4))));
        Self {
            youngs_modulus_pa: e,
            shear_modulus_pa: e / (2.0 * (1.0 + nu)),
            area_m2: area,
            iy_m4: width * thickness.powi(3) / 12.0,
            iz_m4: thickness * width.powi(3) / 12.0,
            torsion_m4: torsion,
            shear_area_y_m2: 5.0 / 6.0 * area,
            shear_area_z_m2: 5.0 / 6.0 * area,
            density_kg_m3: rho,
        }
    }

    /// Mass per length (kg/m).
    pub fn mass_per_length_kg_m(&self) -> f64 {
        self.area_m2 * self.density_kg_m3
    }

    /// Tip flexibility of a cantilever of length `length` (m) in local axes
    /// (see the module documentation).
    pub fn cantilever_flexibility(&self, length: f64) -> Matrix6<f64> {
        let (e, g, l) = (self.youngs_modulus_pa, self.shear_modulus_pa, length);
        let mut f = Matrix6::zeros();
        f[(0, 0)] = l / (e * self.area_m2);
        f[(3, 3)] = l / (g * self.torsion_m4);
        // Bending in x-y (about z): Fy, Mz.
        f[(1, 1)] = l.powi(3) / (3.0 * e * self.iz_m4) + l / (g * self.shear_area_y_m2);
        f[(1, 5)] = l * l / (2.0 * e * self.iz_m4);
        f[(5, 1)] = f[(1, 5)];
        f[(5, 5)] = l / (e * self.iz_m4);
        // Bending in x-z (about y): Fz, My.
        f[(2, 2)] = l.powi(3) / (3.0 * e * self.iy_m4) + l / (g * self.shear_area_z_m2);
        f[(2, 4)] = -l * l / (2.0 * e * self.iy_m4);
        f[(4, 2)] = f[(2, 4)];
        f[(4, 4)] = l / (e * self.iy_m4);
        f
    }
}

/// One element of a [`Frame`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub enum Element {
    /// A prismatic Timoshenko beam from node `i` to node `j`; its local z
    /// axis is `z_hint` made normal to the beam.
    Beam {
        /// Name, for error messages.
        name: String,
        /// First node.
        i: usize,
        /// Second node.
        j: usize,
        /// Section and material.
        section: Section,
        /// Direction of the local z axis (global axes; the part normal to
        /// the beam is used).
        z_hint: Vector3<f64>,
    },
    /// Six springs between nodes `i` and `j` in the axes `axes` (columns
    /// x, y, z in global axes): `stiffness = [kx, ky, kz, krx, kry, krz]`
    /// (N/m, N.m/rad) on `u_j - u_i`, `theta_j - theta_i`.
    Spring6 {
        /// Name.
        name: String,
        /// First node.
        i: usize,
        /// Second node.
        j: usize,
        /// The spring axes.
        axes: Rotation3<f64>,
        /// Stiffness per axis.
        stiffness: Vector6<f64>,
    },
    /// An axial spring of stiffness `k_n_m` (N/m) along the line from `i`
    /// to `j`.
    Axial {
        /// Name.
        name: String,
        /// First node.
        i: usize,
        /// Second node.
        j: usize,
        /// Stiffness (N/m).
        k_n_m: f64,
    },
}

/// A linear 3D frame in one configuration: node positions, elements and
/// fixed nodes.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct Frame {
    /// Node positions (m, global).
    pub positions: Vec<Vector3<f64>>,
    /// The elements.
    pub elements: Vec<Element>,
    /// Nodes held in all six degrees of freedom.
    pub fixed: Vec<usize>,
}

fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// `[u_j - u_i + [r]x theta_i; theta_j - theta_i]` as a 6 x 12 matrix.
fn relative_motion(r: &Vector3<f64>) -> SMatrix<f64, 6, 12> {
    let mut b = SMatrix::<f64, 6, 12>::zeros();
    for k in 0..3 {
        b[(k, k)] = -1.0;
        b[(k, 6 + k)] = 1.0;
        b[(3 + k, 3 + k)] = -1.0;
        b[(3 + k, 9 + k)] = 1.0;
    }
    b.fixed_view_mut::<3, 3>(0, 3).copy_from(&skew(r));
    b
}

fn rotate6(r: &Matrix3<f64>, local: &Matrix6<f64>) -> Matrix6<f64> {
    let mut q = Matrix6::zeros();
    q.fixed_view_mut::<3, 3>(0, 0).copy_from(r);
    q.fixed_view_mut::<3, 3>(3, 3).copy_from(r);
    q * local * q.transpose()
}

/// Local axes of a beam (columns x, y, z in global axes).
pub fn beam_axes(
    from: &Vector3<f64>,
    to: &Vector3<f64>,
    z_hint: &Vector3<f64>,
) -> Option<Matrix3<f64>> {
    let x = (to - from).try_normalize(1e-12)?;
    let z = (z_hint - x * z_hint.dot(&x)).try_normalize(1e-9)?;
    let y = z.cross(&x);
    Some(Matrix3::from_columns(&[x, y, z]))
}

impl Frame {
    /// Number of nodes.
    pub fn n_nodes(&self) -> usize {
        self.positions.len()
    }

    fn element_stiffness(
        &self,
        element: &Element,
    ) -> Result<(usize, usize, SMatrix<f64, 12, 12>), MechanicsError> {
        let n = self.n_nodes();
        let check = |name: &str, i: usize, j: usize| {
            if i >= n || j >= n || i == j {
                return Err(MechanicsError::Element {
                    element: name.to_string(),
                    reason: format!("nodes {i} and {j} of {n}"),
                });
            }
            Ok(())
        };
        let (i, j, k6, r) = match element {
            Element::Beam {
                name,
                i,
                j,
                section,
                z_hint,
            } => {
                check(name, *i, *j)?;
                let (pi, pj) = (self.positions[*i], self.positions[*j]);
                let axes = beam_axes(&pi, &pj, z_hint).ok_or_else(|| MechanicsError::Element {
                    element: name.clone(),
                    reason: "zero length or local z along the beam".into(),
                })?;
                let flexibility = rotate6(&axes, &section.cantilever_flexibility((pj - pi).norm()));
                let stiffness = flexibility
                    .cholesky()
                    .ok_or_else(|| MechanicsError::Element {
                        element: name.clone(),
                        reason: "section constants must be positive".into(),
                    })?;
                (*i, *j, stiffness.inverse(), pj - pi)
            }
            Element::Spring6 {
                name,
                i,
                j,
                axes,
                stiffness,
            } => {
                check(name, *i, *j)?;
                let local = Matrix6::from_diagonal(stiffness);
                (*i, *j, rotate6(axes.matrix(), &local), Vector3::zeros())
            }
            Element::Axial { name, i, j, k_n_m } => {
                check(name, *i, *j)?;
                let axis = (self.positions[*j] - self.positions[*i])
                    .try_normalize(1e-12)
                    .ok_or_else(|| MechanicsError::Element {
                        element: name.clone(),
                        reason: "the spring's nodes coincide".into(),
                    })?;
                let mut k = Matrix6::zeros();
                k.fixed_view_mut::<3, 3>(0, 0)
                    .copy_from(&(axis * axis.transpose() * *k_n_m));
                // Only translations: the relative rotation of the ends is free.
                (*i, *j, k, Vector3::zeros())
            }
        };
        let b = relative_motion(&r);
        Ok((i, j, b.transpose() * k6 * b))
    }

    /// The assembled stiffness matrix of all `6 n` degrees of freedom
    /// (node-major, `[u; theta]` per node).
    ///
    /// # Errors
    /// An element with bad nodes or constants.
    pub fn stiffness(&self) -> Result<DMatrix<f64>, MechanicsError> {
        let n = 6 * self.n_nodes();
        let mut k = DMatrix::zeros(n, n);
        for element in &self.elements {
            let (i, j, ke) = self.element_stiffness(element)?;
            let dofs = |a: usize| if a < 6 { 6 * i + a } else { 6 * j + a - 6 };
            for a in 0..12 {
                for b in 0..12 {
                    k[(dofs(a), dofs(b))] += ke[(a, b)];
                }
            }
        }
        Ok(k)
    }

    /// Nodal loads equivalent to a uniform load `w` (N/m, global) on every
    /// beam whose section gives `w = density A g` (own weight), added to
    /// `loads`.
    pub fn add_own_weight(&self, gravity: &Vector3<f64>, loads: &mut [f64]) {
        for element in &self.elements {
            if let Element::Beam { i, j, section, .. } = element {
                let r = self.positions[*j] - self.positions[*i];
                let l = r.norm();
                let w = gravity * section.mass_per_length_kg_m();
                let moment = r.normalize().cross(&w) * (l * l / 12.0);
                for (node, sign) in [(*i, 1.0), (*j, -1.0)] {
                    for a in 0..3 {
                        loads[6 * node + a] += 0.5 * w[a] * l;
                        loads[6 * node + 3 + a] += sign * moment[a];
                    }
                }
            }
        }
    }

    /// Solves `K u = f` for the nodal loads `loads` (`[F; M]` per node, N
    /// and N.m, global): the displacements of every node (m, rad), zero at
    /// the fixed nodes.
    ///
    /// # Errors
    /// A load vector of the wrong length, bad elements, a mechanism.
    pub fn solve(&self, loads: &[f64]) -> Result<Vec<f64>, MechanicsError> {
        let n = 6 * self.n_nodes();
        if loads.len() != n {
            return Err(MechanicsError::LoadLength {
                found: loads.len(),
                nodes: self.n_nodes(),
            });
        }
        let free: Vec<usize> = (0..n).filter(|d| !self.fixed.contains(&(d / 6))).collect();
        let k = self.stiffness()?;
        let reduced = DMatrix::from_fn(free.len(), free.len(), |a, b| k[(free[a], free[b])]);
        let f = DVector::from_iterator(free.len(), free.iter().map(|&d| loads[d]));
        let largest = reduced.diagonal().amax();
        let factor = reduced.cholesky().ok_or(MechanicsError::Mechanism)?;
        // A free motion leaves a pivot at round-off level, not a negative one.
        let smallest = factor
            .l_dirty()
            .diagonal()
            .iter()
            .fold(f64::INFINITY, |m, v| m.min(v * v));
        if smallest.is_nan() || smallest <= PIVOT_TOLERANCE * largest {
            return Err(MechanicsError::Mechanism);
        }
        let u = factor.solve(&f);
        let mut out = vec![0.0; n];
        for (a, &d) in free.iter().enumerate() {
            out[d] = u[a];
        }
        Ok(out)
    }
}

/// Displacement `[u; theta]` of node `node` in a solution `u` of
/// [`Frame::solve`].
pub fn node_displacement(u: &[f64], node: usize) -> Vector6<f64> {
    Vector6::from_column_slice(&u[6 * node..6 * node + 6])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A straight cantilever along `axis` from the origin, `n` elements,
    /// clamped at node 0.
    fn cantilever(
        section: Section,
        length: f64,
        n: usize,
        axis: Vector3<f64>,
        z_hint: Vector3<f64>,
    ) -> Frame {
        let positions = (0..=n)
            .map(|k| axis * (length * k as f64 / n as f64))
            .collect();
        let elements = (0..n)
            .map(|k| Element::Beam {
                name: format!("b{k}"),
                i: k,
                j: k + 1,
                section,
                z_hint,
            })
            .collect();
        Frame {
            positions,
            elements,
            fixed: vec![0],
        }
    }

    fn tip(frame: &Frame, wrench: [f64; 6]) -> Vector6<f64> {
        let mut loads = vec![0.0; 6 * frame.n_nodes()];
        let last = frame.n_nodes() - 1;
        loads[6 * last..].copy_from_slice(&wrench);
        node_displacement(&frame.solve(&loads).unwrap(), last)
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-9 * b.abs().max(1e-30)
    }

    #[test]
    fn a_cantilever_matches_the_closed_form_solutions() {
        // A stocky steel box so that shear is visible (L / h = 4).
        let s = Section::steel_box(0.3, 0.2, 0.015);
        let (e, g, l) = (s.youngs_modulus_pa, s.shear_modulus_pa, 1.2);
        // Along a skew direction, so that the rotation to global axes is tested.
        let axis = Vector3::new(1.0, 2.0, -0.5).normalize();
        let hint = Vector3::new(0.0, 0.0, 1.0);
        let frame = cantilever(s, l, 5, axis, hint);
        let axes = beam_axes(&Vector3::zeros(), &axis, &hint).unwrap();
        let (y, z) = (axes.column(1).into_owned(), axes.column(2).into_owned());
        let global = |local_f: Vector3<f64>, local_m: Vector3<f64>| {
            let f = axes * local_f;
            let m = axes * local_m;
            [f.x, f.y, f.z, m.x, m.y, m.z]
        };
        let p = 1.0e4;
        // End force along local y: deflection P L^3 / 3EIz + P L / G Asy, slope P L^2 / 2EIz.
        let u = tip(&frame, global(Vector3::new(0.0, p, 0.0), Vector3::zeros()));
        let deflection = p * l.powi(3) / (3.0 * e * s.iz_m4) + p * l / (g * s.shear_area_y_m2);
        assert!(close(u.fixed_rows::<3>(0).dot(&y), deflection), "{u}");
        assert!(
            close(
                u.fixed_rows::<3>(3).dot(&z),
                p * l * l / (2.0 * e * s.iz_m4)
            ),
            "{u}"
        );
        // End force along local z: rotation about y is minus the slope.
        let u = tip(&frame, global(Vector3::new(0.0, 0.0, p), Vector3::zeros()));
        let deflection = p * l.powi(3) / (3.0 * e * s.iy_m4) + p * l / (g * s.shear_area_z_m2);
        assert!(close(u.fixed_rows::<3>(0).dot(&z), deflection), "{u}");
        assert!(
            close(
                u.fixed_rows::<3>(3).dot(&y),
                -p * l * l / (2.0 * e * s.iy_m4)
            ),
            "{u}"
        );
        // End moment about z: deflection M L^2 / 2EI, rotation M L / EI.
        let m = 2.0e3;
        let u = tip(&frame, global(Vector3::zeros(), Vector3::new(0.0, 0.0, m)));
        assert!(
            close(
                u.fixed_rows::<3>(0).dot(&y),
                m * l * l / (2.0 * e * s.iz_m4)
            ),
            "{u}"
        );
        assert!(
            close(u.fixed_rows::<3>(3).dot(&z), m * l / (e * s.iz_m4)),
            "{u}"
        );
        // Torsion: T L / GJ; axial: N L / EA.
        let u = tip(&frame, global(Vector3::zeros(), Vector3::new(m, 0.0, 0.0)));
        assert!(
            close(u.fixed_rows::<3>(3).dot(&axis), m * l / (g * s.torsion_m4)),
            "{u}"
        );
        let u = tip(&frame, global(Vector3::new(p, 0.0, 0.0), Vector3::zeros()));
        assert!(
            close(u.fixed_rows::<3>(0).dot(&axis), p * l / (e * s.area_m2)),
            "{u}"
        );
    }

    #[test]
    fn own_weight_of_a_cantilever_is_the_uniform_load_solution() {
        // Horizontal tube along x, gravity along -z: tip deflection
        // w L^4 / 8EI + w L^2 / 2 G As, tip rotation w L^3 / 6EI.
        let s = Section::steel_tube(0.2, 0.01);
        let l = 2.0;
        let frame = cantilever(s, l, 4, Vector3::x(), Vector3::z());
        let mut loads = vec![0.0; 6 * frame.n_nodes()];
        let g = Vector3::new(0.0, 0.0, -9.81);
        frame.add_own_weight(&g, &mut loads);
        let u = node_displacement(&frame.solve(&loads).unwrap(), 4);
        let w = 9.81 * s.mass_per_length_kg_m();
        let e = s.youngs_modulus_pa;
        let expected = w * l.powi(4) / (8.0 * e * s.iy_m4)
            + w * l * l / (2.0 * s.shear_modulus_pa * s.shear_area_z_m2);
        assert!(close(-u[2], expected), "{u}");
        // Downward slope: rotation about +y is positive.
        assert!(close(u[4], w * l.powi(3) / (6.0 * e * s.iy_m4)), "{u}");
    }

    #[test]
    fn springs_in_series_add_their_compliances() {
        // A beam on a joint spring about z and an axial spring in series.
        let s = Section::steel_tube(0.1, 0.01);
        let kt = 1.0e5;
        let frame = Frame {
            positions: vec![Vector3::zeros(), Vector3::zeros(), Vector3::x()],
            elements: vec![
                Element::Spring6 {
                    name: "joint".into(),
                    i: 0,
                    j: 1,
                    axes: Rotation3::identity(),
                    stiffness: Vector6::new(1e12, 1e12, 1e12, 1e12, 1e12, kt),
                },
                Element::Beam {
                    name: "beam".into(),
                    i: 1,
                    j: 2,
                    section: s,
                    z_hint: Vector3::z(),
                },
            ],
            fixed: vec![0],
        };
        let p = 100.0;
        let u = tip(&frame, [0.0, p, 0.0, 0.0, 0.0, 0.0]);
        let beam = p / (3.0 * s.youngs_modulus_pa * s.iz_m4)
            + p / (s.shear_modulus_pa * s.shear_area_y_m2);
        let joint = p / kt;
        let soft = 2.0 * p / 1e12 + p / 1e12;
        assert!((u[1] - beam - joint).abs() < soft + 1e-12 * u[1], "{u}");
        // A free joint and nothing else is a mechanism.
        let mut free = frame.clone();
        if let Element::Spring6 { stiffness, .. } = &mut free.elements[0] {
            stiffness[5] = 0.0;
        }
        let mut loads = vec![0.0; 18];
        loads[13] = p;
        assert_eq!(free.solve(&loads), Err(MechanicsError::Mechanism));
    }

    #[test]
    fn the_stiffness_matrix_is_symmetric_and_rigid_motions_cost_nothing() {
        let s = Section::steel_box(0.3, 0.2, 0.015);
        let mut frame = cantilever(
            s,
            1.0,
            3,
            Vector3::new(0.3, -0.2, 1.0).normalize(),
            Vector3::x(),
        );
        frame.elements.push(Element::Axial {
            name: "tie".into(),
            i: 0,
            j: 2,
            k_n_m: 1e7,
        });
        let k = frame.stiffness().unwrap();
        assert!((&k - k.transpose()).amax() <= 1e-9 * k.amax());
        // A rigid rotation about an arbitrary point and a translation.
        let omega = Vector3::new(0.01, -0.02, 0.03);
        let v = Vector3::new(1e-3, 2e-3, -1e-3);
        let mut u = DVector::zeros(6 * frame.n_nodes());
        for (n, p) in frame.positions.iter().enumerate() {
            let t = v + omega.cross(p);
            for a in 0..3 {
                u[6 * n + a] = t[a];
                u[6 * n + 3 + a] = omega[a];
            }
        }
        assert!((&k * u).amax() < 1e-6 * k.amax() * 1e-3);
    }
}
