//! Process models: the wrench that the process exerts on the tool, as a
//! function of where the tool actually is.
//!
//! A forming tool pressing on a part is pushed back by the part, and how hard
//! depends on how far the tool went in. Compensation therefore solves robot and
//! process together (see the crate docs); this module only answers "what wrench
//! does the process put on the tool when its tip is here?".
//!
//! Two models:
//! * [`ConstantWrench`]: a wrench that does not depend on the tool position
//!   (machining force estimate, contact force held by a controller).
//! * [`CantileverBeam`]: the forming experiment of the reference paper
//!   (section 4): a clamped rectangular beam pushed down by the tool tip, in
//!   small-deflection Euler-Bernoulli theory (`F = 3 E I w / a^3`) or as a
//!   large-deflection elastica whose load follows the deformed beam (the
//!   incremental analysis with geometry update of the paper), with optional
//!   Coulomb friction along the beam.
//!
//! The part frame R_p of the beam: x along the beam from the clamp (x = 0) to
//! the free end (x = length), z up, the undeformed top surface at z = 0, the
//! beam centred on y = 0.

use nalgebra::{Vector3, Vector6};

/// Errors of process models.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ProcessError {
    /// A model parameter is out of its range.
    #[error("process parameter {name} = {value}: {why}")]
    InvalidParameter {
        /// Parameter name, as in the files and on the command line.
        name: &'static str,
        /// The value given.
        value: f64,
        /// What the value should be.
        why: &'static str,
    },
    /// The beam's large-deflection equilibrium could not be found for this
    /// tool position (a deflection too large for the beam, or a contact
    /// point beyond the free end).
    #[error(
        "cantilever beam: no equilibrium found with the tool at x = {x_mm:.3} mm, z = {z_mm:.3} mm ({why})"
    )]
    NoEquilibrium {
        /// Tool tip x in the part frame (mm).
        x_mm: f64,
        /// Tool tip z in the part frame (mm).
        z_mm: f64,
        /// Why the solver gave up.
        why: &'static str,
    },
    /// The tool position is not finite.
    #[error("tool position is not finite: {0:?}")]
    NotFinite([f64; 3]),
}

/// Where the tool is and where it is going, in the part frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ToolState {
    /// Tool tip position in the part frame (m).
    pub position: Vector3<f64>,
    /// Direction of motion of the tool tip (any length; zero when at rest),
    /// used for friction.
    pub motion: Vector3<f64>,
}

impl ToolState {
    /// A tool at rest at `position` (m).
    pub fn at(position: Vector3<f64>) -> Self {
        Self {
            position,
            motion: Vector3::zeros(),
        }
    }
}

/// Per-thread state that a process model may keep from one evaluation to
/// the next: for the large-deflection cantilever, the last equilibrium,
/// from which Newton starts when the tool has moved little (along a path,
/// two to three residual evaluations instead of five to seven). The
/// result does not depend on it beyond the solver tolerance.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ProcessWorkspace {
    /// Last large-deflection equilibrium: tool position (x, z) in the part
    /// frame (m), friction coefficient with its sign, and the unknowns
    /// (kappa0, a, N, phi).
    last_equilibrium: Option<([f64; 3], [f64; 4])>,
}

/// A process that pushes on the tool.
pub trait ProcessModel: Send + Sync {
    /// A short description for reports (`"cantilever, large deflection"`).
    fn describe(&self) -> String;

    /// Wrench exerted on the tool, `[f; m]` in N and N.m, expressed in the
    /// part frame and reduced at the tool tip.
    fn wrench_on_tool(&self, tool: &ToolState) -> Result<Vector6<f64>, ProcessError>;

    /// [`wrench_on_tool`](Self::wrench_on_tool) with a per-thread
    /// workspace the model may start from (a model without iterations
    /// ignores it, which is the default).
    ///
    /// # Errors
    /// As [`wrench_on_tool`](Self::wrench_on_tool).
    fn wrench_on_tool_in(
        &self,
        workspace: &mut ProcessWorkspace,
        tool: &ToolState,
    ) -> Result<Vector6<f64>, ProcessError> {
        let _ = workspace;
        self.wrench_on_tool(tool)
    }
}

/// A wrench that does not depend on the tool position.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConstantWrench {
    /// `[fx, fy, fz, mx, my, mz]` on the tool, part frame [N, N.m].
    pub wrench: Vector6<f64>,
}

impl ProcessModel for ConstantWrench {
    fn describe(&self) -> String {
        format!(
            "constant wrench [{:.1}, {:.1}, {:.1}] N, [{:.2}, {:.2}, {:.2}] N.m",
            self.wrench[0],
            self.wrench[1],
            self.wrench[2],
            self.wrench[3],
            self.wrench[4],
            self.wrench[5]
        )
    }

    fn wrench_on_tool(&self, tool: &ToolState) -> Result<Vector6<f64>, ProcessError> {
        check_finite(&tool.position)?;
        Ok(self.wrench)
    }
}

/// A named material with its Young's modulus.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Material {
    /// Name as accepted on the command line.
    pub name: &'static str,
    /// Young's modulus (Pa).
    pub youngs_modulus_pa: f64,
}

/// Nominal handbook Young's moduli of common sheet and bar materials (Pa).
/// Real batches vary by a few percent; give the modulus explicitly when it
/// was measured.
pub const MATERIALS: &[Material] = &[
    Material {
        name: "al-5005",
        youngs_modulus_pa: 68.9e9,
    },
    Material {
        name: "al-5754",
        youngs_modulus_pa: 70.0e9,
    },
    Material {
        name: "al-6061",
        youngs_modulus_pa: 68.9e9,
    },
    Material {
        name: "steel",
        youngs_modulus_pa: 210.0e9,
    },
    Material {
        name: "stainless-304",
        youngs_modulus_pa: 193.0e9,
    },
    Material {
        name: "copper",
        youngs_modulus_pa: 117.0e9,
    },
    Material {
        name: "titanium-6al-4v",
        youngs_modulus_pa: 113.8e9,
    },
];

/// Looks a material up by name (case-insensitive).
pub fn material(name: &str) -> Option<Material> {
    MATERIALS
        .iter()
        .copied()
        .find(|m| m.name.eq_ignore_ascii_case(name))
}

/// Which beam theory the cantilever uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BeamTheory {
    /// Euler-Bernoulli, small deflection: vertical force `3 E I w / a^3` at
    /// the contact, contact point at the tool's x.
    SmallDeflection,
    /// Inextensible elastica, large deflection: the contact force is normal
    /// to the deformed beam (plus friction along it) and the contact point
    /// follows the beam's horizontal shortening.
    LargeDeflection,
}

/// A clamped rectangular beam pushed down by the tool tip (reference paper,
/// section 4: Al-5005, 585 x 50 x 14 mm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CantileverBeam {
    /// Free length from the clamp to the free end (m) (paper: 0.585).
    pub length_m: f64,
    /// Width along y (m) (paper: 0.050).
    pub width_m: f64,
    /// Thickness along z (m) (paper: 0.014).
    pub thickness_m: f64,
    /// Young's modulus (Pa) (Al-5005: 68.9e9).
    pub youngs_modulus_pa: f64,
    /// Coulomb friction coefficient between tool and beam (default 0: the
    /// paper neglects it and names it as its remaining error).
    pub friction_coefficient: f64,
    /// Beam theory.
    pub theory: BeamTheory,
}

/// Number of RK4 steps along the loaded part of the beam. The elastica is
/// smooth; 64 steps give relative errors below 1e-9 on the tip deflection.
const ELASTICA_STEPS: usize = 64;

/// Largest tool move (m) from the last large-deflection equilibrium from
/// which Newton starts at that equilibrium: well inside its quadratic
/// convergence region (the contact force changes by a few per cent over
/// 5 mm), and wider than the distance between consecutive evaluations
/// along a path (point spacing plus the deflection, about 1 mm).
pub const WARM_START_DISTANCE_M: f64 = 5e-3;

impl CantileverBeam {
    /// The beam of the reference paper with the chosen theory.
    pub fn reference(theory: BeamTheory) -> Self {
        Self {
            length_m: 0.585,
            width_m: 0.050,
            thickness_m: 0.014,
            youngs_modulus_pa: 68.9e9,
            friction_coefficient: 0.0,
            theory,
        }
    }

    /// Checks every parameter; the other methods assume it passed.
    pub fn validate(&self) -> Result<(), ProcessError> {
        let positive = [
            ("length_m", self.length_m),
            ("width_m", self.width_m),
            ("thickness_m", self.thickness_m),
            ("youngs_modulus_pa", self.youngs_modulus_pa),
        ];
        for (name, value) in positive {
            if !(value.is_finite() && value > 0.0) {
                return Err(ProcessError::InvalidParameter {
                    name,
                    value,
                    why: "must be finite and positive",
                });
            }
        }
        if !(self.friction_coefficient.is_finite() && self.friction_coefficient >= 0.0) {
            return Err(ProcessError::InvalidParameter {
                name: "friction_coefficient",
                value: self.friction_coefficient,
                why: "must be finite and non-negative",
            });
        }
        Ok(())
    }

    /// Second moment of area for bending in the x-z plane [m^4]: `b h^3 / 12`.
    pub fn second_moment_m4(&self) -> f64 {
        self.width_m * self.thickness_m.powi(3) / 12.0
    }

    /// Bending stiffness `E I` (N.m^2).
    pub fn bending_stiffness(&self) -> f64 {
        self.youngs_modulus_pa * self.second_moment_m4()
    }

    /// Small-deflection contact force magnitude (N) for a deflection `w` (m)
    /// at distance `a` (m) from the clamp: `3 E I w / a^3`.
    pub fn small_deflection_force(&self, a: f64, w: f64) -> f64 {
        3.0 * self.bending_stiffness() * w / a.powi(3)
    }

    /// Friction direction along x for the tool: opposite to its x motion.
    fn friction_sign(tool: &ToolState) -> f64 {
        if tool.motion.x > 1e-12 {
            -1.0
        } else if tool.motion.x < -1e-12 {
            1.0
        } else {
            0.0
        }
    }

    /// Integrates the elastica of the loaded span [0, a] under a tip force
    /// `(fx, fz)` on the beam (fixed direction), from the clamp with initial
    /// curvature `kappa0`. Returns (x(a), z(a), theta(a), theta'(a)). The
    /// solver uses [`integrate_with_derivatives`](Self::integrate_with_derivatives);
    /// this plain form checks it.
    #[cfg(test)]
    fn integrate(&self, a: f64, kappa0: f64, fx: f64, fz: f64) -> [f64; 4] {
        let ei = self.bending_stiffness();
        // State: x, z, theta, theta'. EI theta'' = -cos(theta) fz + sin(theta) fx.
        let rhs = |s: [f64; 4]| -> [f64; 4] {
            let (sin, cos) = s[2].sin_cos();
            [cos, sin, s[3], (-cos * fz + sin * fx) / ei]
        };
        let h = a / ELASTICA_STEPS as f64;
        let mut y = [0.0, 0.0, 0.0, kappa0];
        let add = |y: [f64; 4], k: [f64; 4], f: f64| {
            [
                y[0] + f * k[0],
                y[1] + f * k[1],
                y[2] + f * k[2],
                y[3] + f * k[3],
            ]
        };
        for _ in 0..ELASTICA_STEPS {
            let k1 = rhs(y);
            let k2 = rhs(add(y, k1, h / 2.0));
            let k3 = rhs(add(y, k2, h / 2.0));
            let k4 = rhs(add(y, k3, h));
            for i in 0..4 {
                y[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
            }
        }
        y
    }

    /// [`integrate`](Self::integrate) together with the derivatives of
    /// (x(a), z(a), theta(a), theta'(a)) with respect to (kappa0, a, fx, fz)
    /// (columns), from the variational equations integrated by the same RK4
    /// steps: RK4 commutes with linearisation, so these are the exact
    /// derivatives of the discrete solution, at the cost of one augmented
    /// integration instead of eight more integrations for central
    /// differences. The length `a` enters through the step `a / n`: with
    /// `s = a t`, `dS_a/ds = (dF/dy) S_a + F / a`.
    fn integrate_with_derivatives(
        &self,
        a: f64,
        kappa0: f64,
        fx: f64,
        fz: f64,
    ) -> ([f64; 4], [[f64; 4]; 4]) {
        let ei = self.bending_stiffness();
        // State: y (4), then the four sensitivity columns (4 each).
        let rhs = |s: &[f64; 20]| -> [f64; 20] {
            let (sin, cos) = s[2].sin_cos();
            let f = [cos, sin, s[3], (-cos * fz + sin * fx) / ei];
            let d_theta = (sin * fz + cos * fx) / ei;
            let mut out = [0.0; 20];
            out[..4].copy_from_slice(&f);
            for p in 0..4 {
                let c = &s[4 + 4 * p..8 + 4 * p];
                let o = &mut out[4 + 4 * p..8 + 4 * p];
                o[0] = -sin * c[2];
                o[1] = cos * c[2];
                o[2] = c[3];
                o[3] = d_theta * c[2];
            }
            for i in 0..4 {
                out[8 + i] += f[i] / a;
            }
            out[15] += sin / ei;
            out[19] -= cos / ei;
            out
        };
        let h = a / ELASTICA_STEPS as f64;
        let mut y = [0.0; 20];
        y[3] = kappa0;
        // d theta'(0) / d kappa0 = 1.
        y[7] = 1.0;
        let add = |y: &[f64; 20], k: &[f64; 20], f: f64| -> [f64; 20] {
            std::array::from_fn(|i| y[i] + f * k[i])
        };
        for _ in 0..ELASTICA_STEPS {
            let k1 = rhs(&y);
            let k2 = rhs(&add(&y, &k1, h / 2.0));
            let k3 = rhs(&add(&y, &k2, h / 2.0));
            let k4 = rhs(&add(&y, &k3, h));
            for i in 0..20 {
                y[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
            }
        }
        let state = [y[0], y[1], y[2], y[3]];
        let columns = std::array::from_fn(|p| std::array::from_fn(|i| y[4 + 4 * p + i]));
        (state, columns)
    }

    /// Residuals of the large-deflection equilibrium (see
    /// [`large_deflection`](Self::large_deflection)) and their Jacobian with
    /// respect to u = (kappa0, a, N, phi), rows as the residuals.
    fn equilibrium_residual(
        &self,
        u: &[f64; 4],
        tool: (f64, f64),
        mu: f64,
    ) -> ([f64; 4], nalgebra::Matrix4<f64>) {
        let (x_t, z_t) = tool;
        let (kappa0, a, n, phi) = (u[0], u[1], u[2], u[3]);
        // Force on the beam: -N along the upward normal (-sin, cos), friction
        // -mu N along the tangent (cos, sin).
        let (sin, cos) = phi.sin_cos();
        let fx = n * sin - mu * n * cos;
        let fz = -n * cos - mu * n * sin;
        let (y, d) = self.integrate_with_derivatives(a, kappa0, fx, fz);
        let length = self.length_m;
        let r = [
            y[3] * a,
            (y[0] - x_t) / length,
            (y[1] - z_t) / length,
            y[2] - phi,
        ];
        // d(fx, fz)/dN and d(fx, fz)/dphi.
        let dforce_dn = (sin - mu * cos, -cos - mu * sin);
        let dforce_dphi = (n * cos + mu * n * sin, n * sin - mu * n * cos);
        // dy/du, column by unknown.
        let dy: [[f64; 4]; 4] = [
            d[0],
            d[1],
            std::array::from_fn(|i| d[2][i] * dforce_dn.0 + d[3][i] * dforce_dn.1),
            std::array::from_fn(|i| d[2][i] * dforce_dphi.0 + d[3][i] * dforce_dphi.1),
        ];
        let mut jac = nalgebra::Matrix4::zeros();
        for (j, column) in dy.iter().enumerate() {
            jac[(0, j)] = column[3] * a;
            jac[(1, j)] = column[0] / length;
            jac[(2, j)] = column[1] / length;
            jac[(3, j)] = column[2];
        }
        jac[(0, 1)] += y[3];
        jac[(3, 3)] -= 1.0;
        (r, jac)
    }

    /// Large-deflection equilibrium with the tool tip at (x_t, z_t), z_t < 0.
    /// Unknowns u = (kappa0, a, N, phi): clamp curvature, contact arc length,
    /// normal force magnitude, slope at the contact. Residuals: free-moment
    /// condition theta'(a) = 0, contact position = tool position, and phi =
    /// theta(a). Solved by Newton with the exact Jacobian of the discretised
    /// elastica, started from the last equilibrium in `workspace` when the
    /// tool has moved less than [`WARM_START_DISTANCE_M`] since, and from the
    /// small-deflection solution otherwise (or when the warm start fails).
    fn large_deflection(
        &self,
        workspace: &mut ProcessWorkspace,
        tool: &ToolState,
    ) -> Result<Vector6<f64>, ProcessError> {
        let (x_t, z_t) = (tool.position.x, tool.position.z);
        let mu = self.friction_coefficient * Self::friction_sign(tool);
        if let Some(([x, z, last_mu], u)) = workspace.last_equilibrium {
            let near = (x - x_t).hypot(z - z_t) <= WARM_START_DISTANCE_M;
            if near && last_mu == mu {
                if let Ok((wrench, u)) = self.large_deflection_from(u, x_t, z_t, mu, 8) {
                    workspace.last_equilibrium = Some(([x_t, z_t, mu], u));
                    return Ok(wrench);
                }
            }
        }
        let ei = self.bending_stiffness();
        let n0 = self.small_deflection_force(x_t, -z_t);
        // Linear theory: theta'(0) = -N a / EI, slope at the tip -N a^2 / (2 EI).
        let u = [-n0 * x_t / ei, x_t, n0, -n0 * x_t * x_t / (2.0 * ei)];
        let (wrench, u) = self.large_deflection_from(u, x_t, z_t, mu, 50)?;
        workspace.last_equilibrium = Some(([x_t, z_t, mu], u));
        Ok(wrench)
    }

    /// Newton on the large-deflection equilibrium from the unknowns `u`, at
    /// most `max_iterations` steps; the wrench on the tool and the solution.
    fn large_deflection_from(
        &self,
        mut u: [f64; 4],
        x_t: f64,
        z_t: f64,
        mu: f64,
        max_iterations: usize,
    ) -> Result<(Vector6<f64>, [f64; 4]), ProcessError> {
        let fail = |why| ProcessError::NoEquilibrium {
            x_mm: x_t * 1e3,
            z_mm: z_t * 1e3,
            why,
        };
        for _ in 0..max_iterations {
            let (r, jac) = self.equilibrium_residual(&u, (x_t, z_t), mu);
            let norm = r.iter().map(|v| v * v).sum::<f64>().sqrt();
            if norm < 1e-12 {
                if u[1] > self.length_m * (1.0 + 1e-9) {
                    return Err(fail("the contact point would lie beyond the free end"));
                }
                let (sin, cos) = u[3].sin_cos();
                let n = u[2];
                // Force on the tool = minus force on the beam.
                let fx = n * (-sin) + mu * n * cos;
                let fz = n * cos + mu * n * sin;
                return Ok((Vector6::new(fx, 0.0, fz, 0.0, 0.0, 0.0), u));
            }
            let rhs = nalgebra::Vector4::new(-r[0], -r[1], -r[2], -r[3]);
            let step = jac
                .lu()
                .solve(&rhs)
                .ok_or_else(|| fail("singular equilibrium equations"))?;
            for j in 0..4 {
                u[j] += step[j];
            }
            if !u.iter().all(|v| v.is_finite()) || u[1] <= 0.0 || u[2] < 0.0 {
                return Err(fail("the equilibrium iteration diverged"));
            }
        }
        Err(fail("no convergence of the Newton iterations"))
    }
}

fn check_finite(p: &Vector3<f64>) -> Result<(), ProcessError> {
    if p.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(ProcessError::NotFinite([p.x, p.y, p.z]))
    }
}

impl ProcessModel for CantileverBeam {
    fn describe(&self) -> String {
        format!(
            "cantilever beam {:.0} x {:.0} x {:.0} mm, E = {:.1} GPa, {}, friction {}",
            self.length_m * 1e3,
            self.width_m * 1e3,
            self.thickness_m * 1e3,
            self.youngs_modulus_pa * 1e-9,
            match self.theory {
                BeamTheory::SmallDeflection => "small deflection (Euler-Bernoulli)",
                BeamTheory::LargeDeflection => "large deflection (elastica)",
            },
            self.friction_coefficient
        )
    }

    fn wrench_on_tool(&self, tool: &ToolState) -> Result<Vector6<f64>, ProcessError> {
        self.wrench_on_tool_in(&mut ProcessWorkspace::default(), tool)
    }

    fn wrench_on_tool_in(
        &self,
        workspace: &mut ProcessWorkspace,
        tool: &ToolState,
    ) -> Result<Vector6<f64>, ProcessError> {
        self.validate()?;
        check_finite(&tool.position)?;
        let p = tool.position;
        // No contact above the beam, beside it, or beyond its ends.
        let on_beam = p.x > 0.0 && p.x <= self.length_m && p.y.abs() <= self.width_m / 2.0;
        if !on_beam || p.z >= 0.0 {
            return Ok(Vector6::zeros());
        }
        match self.theory {
            BeamTheory::SmallDeflection => {
                let n = self.small_deflection_force(p.x, -p.z);
                let friction = self.friction_coefficient * Self::friction_sign(tool) * n;
                Ok(Vector6::new(friction, 0.0, n, 0.0, 0.0, 0.0))
            }
            BeamTheory::LargeDeflection => self.large_deflection(workspace, tool),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn reference_beam_matches_the_reading_notes() {
        let beam = CantileverBeam::reference(BeamTheory::SmallDeflection);
        // I = 50 * 14^3 / 12 mm^4 = 11 433 mm^4.
        assert_relative_eq!(beam.second_moment_m4(), 11_433.33e-12, max_relative = 1e-5);
        // ~300 N at the free end, ~1 kN at 385 mm for a 25 mm push.
        let f_end = beam.small_deflection_force(0.585, 0.025);
        let f_in = beam.small_deflection_force(0.385, 0.025);
        assert!((290.0..310.0).contains(&f_end), "{f_end}");
        assert!((1000.0..1100.0).contains(&f_in), "{f_in}");
    }

    #[test]
    fn no_contact_gives_no_wrench() {
        for theory in [BeamTheory::SmallDeflection, BeamTheory::LargeDeflection] {
            let beam = CantileverBeam::reference(theory);
            for p in [
                Vector3::new(0.3, 0.0, 0.001),
                Vector3::new(0.7, 0.0, -0.01),
                Vector3::new(0.3, 0.2, -0.01),
                Vector3::new(-0.1, 0.0, -0.01),
            ] {
                assert_eq!(
                    beam.wrench_on_tool(&ToolState::at(p)).unwrap(),
                    Vector6::zeros()
                );
            }
        }
    }

    #[test]
    fn large_deflection_tends_to_small_deflection_for_small_pushes() {
        let small = CantileverBeam::reference(BeamTheory::SmallDeflection);
        let large = CantileverBeam::reference(BeamTheory::LargeDeflection);
        let p = ToolState::at(Vector3::new(0.45, 0.0, -1e-4));
        let ws = small.wrench_on_tool(&p).unwrap();
        let wl = large.wrench_on_tool(&p).unwrap();
        assert_relative_eq!(wl[2], ws[2], max_relative = 1e-4);
        assert!(wl[0].abs() < 1e-3 * wl[2]);
    }

    #[test]
    fn large_deflection_pushes_back_along_the_deformed_normal() {
        let large = CantileverBeam::reference(BeamTheory::LargeDeflection);
        let small = CantileverBeam::reference(BeamTheory::SmallDeflection);
        let p = ToolState::at(Vector3::new(0.385, 0.0, -0.025));
        let wl = large.wrench_on_tool(&p).unwrap();
        let ws = small.wrench_on_tool(&p).unwrap();
        // The deformed beam slopes down towards the free end: its upward
        // normal leans towards +x, so the tool is pushed towards +x.
        assert!(wl[0] > 0.0, "{wl}");
        // Slope ~ 3 w / (2 a) ~ 0.1 rad: horizontal part ~ 10 % of vertical.
        let ratio = wl[0] / wl[2];
        assert!((0.07..0.13).contains(&ratio), "{ratio}");
        // Same order as the linear theory, within 10 %.
        assert_relative_eq!(wl[2], ws[2], max_relative = 0.1);
    }

    #[test]
    fn friction_opposes_motion() {
        let mut beam = CantileverBeam::reference(BeamTheory::SmallDeflection);
        beam.friction_coefficient = 0.2;
        let mut tool = ToolState::at(Vector3::new(0.5, 0.0, -0.01));
        tool.motion = Vector3::new(-1.0, 0.0, 0.0);
        let w = beam.wrench_on_tool(&tool).unwrap();
        assert_relative_eq!(w[0], 0.2 * w[2], max_relative = 1e-12);
        beam.theory = BeamTheory::LargeDeflection;
        let wl = beam.wrench_on_tool(&tool).unwrap();
        assert!(wl[0] > 0.15 * wl[2], "{wl}");
    }

    #[test]
    fn bad_parameters_and_positions_are_named() {
        let mut beam = CantileverBeam::reference(BeamTheory::SmallDeflection);
        beam.thickness_m = -1.0;
        let err = beam
            .wrench_on_tool(&ToolState::at(Vector3::zeros()))
            .unwrap_err();
        assert!(err.to_string().contains("thickness_m"), "{err}");
        let beam = CantileverBeam::reference(BeamTheory::LargeDeflection);
        let err = beam
            .wrench_on_tool(&ToolState::at(Vector3::new(f64::NAN, 0.0, 0.0)))
            .unwrap_err();
        assert!(matches!(err, ProcessError::NotFinite(_)));
        assert_eq!(material("AL-5005").unwrap().youngs_modulus_pa, 68.9e9);
        assert!(material("unobtainium").is_none());
    }

    #[test]
    fn elastica_integration_matches_the_linear_closed_form() {
        let beam = CantileverBeam::reference(BeamTheory::LargeDeflection);
        let ei = beam.bending_stiffness();
        let (a, f) = (0.4, -1.0);
        // Linear theory: tip deflection f a^3 / (3 EI) with kappa0 = f a / EI.
        let y = beam.integrate(a, f * a / ei, 0.0, f);
        assert_relative_eq!(y[1], f * a.powi(3) / (3.0 * ei), max_relative = 1e-6);
        assert!(y[3].abs() < 1e-9);
    }

    #[test]
    fn equilibrium_jacobian_matches_central_differences() {
        let mut beam = CantileverBeam::reference(BeamTheory::LargeDeflection);
        beam.friction_coefficient = 0.15;
        let ei = beam.bending_stiffness();
        // A state near the equilibrium of a 25 mm push at 400 mm, and one off it.
        let n = 900.0;
        for u in [
            [-n * 0.4 / ei, 0.4, n, -n * 0.16 / (2.0 * ei)],
            [-1.3 * n * 0.4 / ei, 0.37, 0.8 * n, -0.05],
        ] {
            for mu in [0.0, -0.15] {
                let tool = (0.4, -0.025);
                let (_, jac) = beam.equilibrium_residual(&u, tool, mu);
                let scale = [1e-3 * u[0].abs(), 1e-3, 1e-3 * n, 1e-3];
                for j in 0..4 {
                    let h = 1e-3 * scale[j];
                    let (mut up, mut um) = (u, u);
                    up[j] += h;
                    um[j] -= h;
                    let (rp, _) = beam.equilibrium_residual(&up, tool, mu);
                    let (rm, _) = beam.equilibrium_residual(&um, tool, mu);
                    for i in 0..4 {
                        let fd = (rp[i] - rm[i]) / (2.0 * h);
                        let size = jac.column(j).amax().max(1e-12);
                        assert!(
                            (fd - jac[(i, j)]).abs() <= 1e-6 * size,
                            "d r{i} / d u{j}: analytic {} vs differences {fd}",
                            jac[(i, j)]
                        );
                    }
                }
                // The state part equals the plain integration.
                let (sin, cos) = u[3].sin_cos();
                let fx = u[2] * sin - mu * u[2] * cos;
                let fz = -u[2] * cos - mu * u[2] * sin;
                let (y, _) = beam.integrate_with_derivatives(u[1], u[0], fx, fz);
                assert_eq!(y, beam.integrate(u[1], u[0], fx, fz));
            }
        }
    }
}
