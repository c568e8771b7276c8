//! The forming cell as it is: the twin's own sheet, clamp, tool tip and
//! dead weight, written for the twin and solved by its own mechanics
//! ([`mechanics`](super::mechanics)); nothing of the user's process model
//! (`flexcal_compensate`'s cantilever beam) is used.
//!
//! The part is the paper's Al-5005 bar (section 4): 585 mm long, 50 mm wide,
//! 14 mm thick, clamped at one end, its top surface the part frame's
//! `z = 0`, the bar along `+x_p`. The twin's bar differs from the
//! handbook bar a user models:
//! - **Young's modulus** 70 GPa, the value Eurocode 9 (EN 1999-1-1, table
//!   3.1) gives for every wrought aluminium alloy; the handbook value a user
//!   takes for 5005 (ASM, MatWeb) is 68.9 GPa: +1.6 %.
//! - **Thickness** +1 % (14.14 mm): inside the tolerance of rolled
//!   aluminium plate of this thickness (EN 485-4 allows several tenths of a
//!   millimetre); the bending stiffness grows with its cube (+3 %).
//! - **Clamp compliance**: a bolted clamp lets the root turn; the twin
//!   models it as a rotational spring as soft as one sheet thickness of
//!   extra bar (`k = E I / t`), the order of the root-rotation corrections
//!   of clamped-beam tests (a fraction of to about one thickness).
//! - **Tool tip** a hemisphere of 10 mm radius (incremental forming tools
//!   are 10 to 30 mm in diameter): the TCP is its lowest point, but on the
//!   bent bar it touches where the surface's normal passes through its
//!   centre, behind the TCP by `r sin(alpha)` for a slope `alpha`, and it
//!   pushes along that normal.
//! - **Friction**: Coulomb, `mu = 0.15`, the middle of the 0.1-0.2 that
//!   engineering friction tables give for a lubricated steel tool on
//!   aluminium; the paper names this longitudinal force as the main
//!   remaining error of its compensation (section 4). The force acts on
//!   the top surface, half a thickness above the bar's axis, so it bends
//!   the bar too. Its direction is that of the tool's last motion along
//!   the surface (`mu N cos(angle between motion and surface)`: full when
//!   travelling along the bar, none when plunging along the normal).
//! - **Dead weight** +0.5 % from its weighed value (an industrial hanging
//!   scale's accuracy, +-0.5 % of the reading).
//!
//! The bar is a Timoshenko beam of 12 elements (plus a node at the
//! contact) in small deflection: its slope stays below 0.07 rad over the
//! paper's 25 mm plunge, so the geometric non-linearity it neglects is of
//! the order of the slope squared (0.5 %).

use nalgebra::{Vector3, Vector6};
use serde::Serialize;

use super::TruthSwitches;
use super::error::TruthError;
use super::mechanics::{Element, Frame, Section, node_displacement};
use super::terms::TwinTerm;

/// Length of the bar from the clamp (m), the paper's section 4.
pub const BAR_LENGTH_M: f64 = 0.585;
/// Width of the bar (m).
pub const BAR_WIDTH_M: f64 = 0.050;
/// Nominal thickness of the bar (m).
pub const BAR_THICKNESS_M: f64 = 0.014;
/// Handbook Young's modulus of Al-5005 (Pa), what a user takes.
pub const HANDBOOK_MODULUS_PA: f64 = 68.9e9;
/// Poisson's ratio of aluminium.
const POISSON: f64 = 0.33;
/// Density of aluminium (kg/m^3).
const DENSITY: f64 = 2700.0;
/// Elements of the bar's mesh.
const ELEMENTS: usize = 12;

/// The forming truth terms.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FormingTruth {
    /// The true Young's modulus of the bar (Pa; default 70e9, Eurocode 9).
    pub modulus_pa: f64,
    /// Relative offset of the true thickness from the nominal 14 mm
    /// (default +0.01).
    pub thickness_offset: f64,
    /// Clamp compliance as extra bar length, in thicknesses (default 1).
    pub clamp_extra_thicknesses: f64,
    /// Radius of the hemispherical tool tip (m; default 0.010).
    pub tool_radius_m: f64,
    /// Coulomb friction coefficient tool-bar (default 0.15).
    pub friction_coefficient: f64,
    /// Relative error of the weighed dead weight (default +0.005).
    pub payload_relative_error: f64,
}

impl Default for FormingTruth {
    fn default() -> Self {
        Self {
            modulus_pa: 70e9,
            thickness_offset: 0.01,
            clamp_extra_thicknesses: 1.0,
            tool_radius_m: 0.010,
            friction_coefficient: 0.15,
            payload_relative_error: 0.005,
        }
    }
}

/// The bar's push on the tool at one tool position.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Contact {
    /// Force of the bar on the tool, part axes (N).
    pub force_part_n: Vector3<f64>,
    /// Normal contact force (N; 0 without contact).
    pub normal_n: f64,
    /// Where the tool touches the bar, from the clamp (m).
    pub contact_x_m: f64,
    /// Slope of the bar at the contact (rad, > 0 descending towards the
    /// free end).
    pub slope_rad: f64,
}

impl FormingTruth {
    /// The true dead weight (N) behind the weighed `nominal_n`.
    pub fn true_payload_n(&self, nominal_n: f64, payload_error: bool) -> f64 {
        if payload_error {
            nominal_n * (1.0 + self.payload_relative_error)
        } else {
            nominal_n
        }
    }

    fn section(&self, switches: &TruthSwitches) -> Section {
        let modulus = if switches.beam_modulus_offset {
            self.modulus_pa
        } else {
            HANDBOOK_MODULUS_PA
        };
        let thickness = self.thickness(switches);
        Section::rectangle(BAR_WIDTH_M, thickness, (modulus, POISSON, DENSITY))
    }

    fn thickness(&self, switches: &TruthSwitches) -> f64 {
        if switches.sheet_thickness {
            BAR_THICKNESS_M * (1.0 + self.thickness_offset)
        } else {
            BAR_THICKNESS_M
        }
    }

    /// The bar's nodal displacements under `load` (N, part axes) applied on
    /// its top surface at `x` from the clamp: `(deflection down, slope)` at
    /// `x` (m, rad).
    fn bar_response(
        &self,
        switches: &TruthSwitches,
        x: f64,
        load: &Vector3<f64>,
    ) -> Result<(f64, f64), TruthError> {
        let section = self.section(switches);
        let mut stations: Vec<f64> = (0..=ELEMENTS)
            .map(|k| BAR_LENGTH_M * k as f64 / ELEMENTS as f64)
            .collect();
        let x = x.clamp(1e-4, BAR_LENGTH_M);
        if stations.iter().all(|s| (s - x).abs() > 1e-6) {
            stations.push(x);
            stations.sort_by(f64::total_cmp);
        }
        let contact = stations
            .iter()
            .position(|s| (s - x).abs() <= 1e-6)
            .unwrap_or(0);
        let mut positions: Vec<Vector3<f64>> = stations
            .iter()
            .map(|&s| Vector3::new(s, 0.0, 0.0))
            .collect();
        let mut elements: Vec<Element> = (0..stations.len() - 1)
            .map(|k| Element::Beam {
                name: format!("bar{k}"),
                i: k,
                j: k + 1,
                section,
                z_hint: Vector3::z(),
            })
            .collect();
        let mut fixed = vec![0];
        let mut offset = 0;
        if switches.clamp_compliance {
            // The clamp: a root node joined to the bar's first node by a
            // spring about y as soft as `clamp_extra_thicknesses` of bar.
            let k_root = section.youngs_modulus_pa * section.iy_m4
                / (self.clamp_extra_thicknesses * self.thickness(switches));
            positions.insert(0, Vector3::zeros());
            offset = 1;
            for e in &mut elements {
                if let Element::Beam { i, j, .. } = e {
                    *i += 1;
                    *j += 1;
                }
            }
            let rigid = 1e13;
            elements.push(Element::Spring6 {
                name: "clamp".into(),
                i: 0,
                j: 1,
                axes: nalgebra::Rotation3::identity(),
                stiffness: Vector6::new(rigid, rigid, rigid, rigid, k_root, rigid),
            });
            fixed = vec![0];
        }
        let frame = Frame {
            positions,
            elements,
            fixed,
        };
        let node = contact + offset;
        let mut loads = vec![0.0; 6 * frame.n_nodes()];
        // On the top surface, half a thickness above the bar's axis.
        let arm = Vector3::new(0.0, 0.0, 0.5 * self.thickness(switches));
        let moment = arm.cross(load);
        for a in 0..3 {
            loads[6 * node + a] = load[a];
            loads[6 * node + 3 + a] = moment[a];
        }
        let u = node_displacement(&frame.solve(&loads)?, node);
        Ok((-u[2], u[4]))
    }

    /// The bar's push on a tool whose tip centre is at `centre` (part
    /// frame, m) after the tool moved by `motion` (part frame, m; zero when
    /// it has not moved): the contact that puts the deformed surface at
    /// the tip's radius from its centre, or none when the tip does not
    /// reach the bar.
    ///
    /// # Errors
    /// The bar's mechanics (not expected).
    pub fn contact(
        &self,
        switches: &TruthSwitches,
        centre: &Vector3<f64>,
        motion: &Vector3<f64>,
    ) -> Result<Contact, TruthError> {
        let radius = if switches.tool_radius {
            self.tool_radius_m
        } else {
            0.0
        };
        let mu = if switches.tool_friction {
            self.friction_coefficient
        } else {
            0.0
        };
        let none = Contact {
            force_part_n: Vector3::zeros(),
            normal_n: 0.0,
            contact_x_m: centre.x,
            slope_rad: 0.0,
        };
        if centre.x < 0.0 || centre.x > BAR_LENGTH_M + radius {
            return Ok(none);
        }
        let mut slope: f64 = 0.0;
        let mut result = none;
        for _ in 0..30 {
            let x = (centre.x - radius * slope.sin()).min(BAR_LENGTH_M);
            // Upward normal and the surface's tangent towards the free end.
            let normal = Vector3::new(slope.sin(), 0.0, slope.cos());
            let tangent = Vector3::new(slope.cos(), 0.0, -slope.sin());
            let sliding = match motion.try_normalize(1e-12) {
                Some(m) => m.dot(&tangent),
                None => 0.0,
            };
            // Load on the bar per newton of normal force.
            let unit = -normal + tangent * (mu * sliding);
            let (w, s) = self.bar_response(switches, x, &unit)?;
            let normal_force = (radius * slope.cos() - centre.z) / w;
            if normal_force <= 0.0 {
                return Ok(none);
            }
            let next = (normal_force * s).atan();
            result = Contact {
                force_part_n: -unit * normal_force,
                normal_n: normal_force,
                contact_x_m: x,
                slope_rad: next,
            };
            if (next - slope).abs() < 1e-12 {
                break;
            }
            slope = next;
        }
        Ok(result)
    }

    /// The process terms as published, with their switches.
    pub fn terms(&self, switches: &TruthSwitches) -> Vec<TwinTerm> {
        let term = |name: &str, magnitude: String, source: &str, enabled: bool| TwinTerm {
            name: name.into(),
            magnitude,
            source: source.into(),
            enabled,
        };
        vec![
            term(
                "beam_modulus_offset",
                format!(
                    "the bar's Young's modulus {:.1} GPa, {:+.1} % from the handbook's 68.9 GPa",
                    self.modulus_pa * 1e-9,
                    100.0 * (self.modulus_pa / HANDBOOK_MODULUS_PA - 1.0)
                ),
                "Eurocode 9 (EN 1999-1-1) gives 70 GPa for wrought aluminium alloys; handbooks (ASM, MatWeb) give 68.9 GPa for 5005",
                switches.beam_modulus_offset,
            ),
            term(
                "sheet_thickness",
                format!(
                    "the bar {:+.1} % thicker than its nominal 14 mm (bending stiffness {:+.1} %)",
                    100.0 * self.thickness_offset,
                    100.0 * ((1.0 + self.thickness_offset).powi(3) - 1.0)
                ),
                "thickness tolerance of rolled aluminium plate (EN 485-4: several tenths of a millimetre at 14 mm)",
                switches.sheet_thickness,
            ),
            term(
                "clamp_compliance",
                format!(
                    "the clamp turns like {:.1} thickness of extra bar (rotational stiffness E I / t)",
                    self.clamp_extra_thicknesses
                ),
                "root rotation of bolted clamps: corrections of a fraction of to about one thickness in clamped-beam tests",
                switches.clamp_compliance,
            ),
            term(
                "tool_radius",
                format!(
                    "hemispherical tool tip of {:.0} mm radius: the contact moves behind the TCP on the bent bar and pushes along its normal",
                    self.tool_radius_m * 1e3
                ),
                "incremental forming tools, 10 to 30 mm in diameter",
                switches.tool_radius,
            ),
            term(
                "tool_friction",
                format!(
                    "Coulomb friction mu = {:.2} at the tool-bar contact, on the top surface",
                    self.friction_coefficient
                ),
                "engineering friction tables, lubricated steel on aluminium 0.1-0.2; named by the paper (section 4) as its compensation's remaining error",
                switches.tool_friction,
            ),
            term(
                "payload_error",
                format!(
                    "dead weight {:+.1} % from its weighed value",
                    100.0 * self.payload_relative_error
                ),
                "accuracy of an industrial hanging scale, +-0.5 % of the reading",
                switches.payload_error,
            ),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bare() -> TruthSwitches {
        TruthSwitches {
            beam_modulus_offset: false,
            sheet_thickness: false,
            clamp_compliance: false,
            tool_radius: false,
            tool_friction: false,
            ..TruthSwitches::default()
        }
    }

    #[test]
    fn a_point_tool_on_the_bare_bar_pushes_as_the_timoshenko_cantilever() {
        let truth = FormingTruth::default();
        let s = Section::rectangle(
            BAR_WIDTH_M,
            BAR_THICKNESS_M,
            (HANDBOOK_MODULUS_PA, POISSON, DENSITY),
        );
        let (a, w): (f64, f64) = (0.38, 0.025);
        let compliance = a.powi(3) / (3.0 * s.youngs_modulus_pa * s.iy_m4)
            + a / (s.shear_modulus_pa * s.shear_area_z_m2);
        let c = truth
            .contact(&bare(), &Vector3::new(a, 0.0, -w), &Vector3::zeros())
            .unwrap();
        // The push is normal to the bent bar: its vertical part P bends
        // it, its part along the bar, applied on the top surface half a
        // thickness h above the axis, bends it by the moment M = -h N
        // sin(alpha) about y. Cantilever under an end force and moment:
        // w = P (a^3 / 3EI + a / G As) + M a^2 / 2EI, slope P a^2 / 2EI + M a / EI.
        let (alpha, n) = (c.slope_rad, c.normal_n);
        let (p, m) = (n * alpha.cos(), -0.5 * BAR_THICKNESS_M * n * alpha.sin());
        let ei = s.youngs_modulus_pa * s.iy_m4;
        assert!((c.force_part_n.z - p).abs() < 1e-9 * p, "{c:?}");
        let deflection = p * compliance + m * a * a / (2.0 * ei);
        assert!((deflection - w).abs() < 1e-9 * w, "{c:?}: {deflection}");
        let slope = p * a * a / (2.0 * ei) + m * a / ei;
        assert!((alpha - slope.atan()).abs() < 1e-9, "{c:?}");
        // Above the surface: no contact.
        let free = truth
            .contact(&bare(), &Vector3::new(a, 0.0, 0.001), &Vector3::zeros())
            .unwrap();
        assert_eq!(free.normal_n, 0.0);
    }

    #[test]
    fn each_term_moves_the_contact_force_its_own_way() {
        let truth = FormingTruth::default();
        let at = Vector3::new(0.38, 0.0, -0.025);
        let still = Vector3::zeros();
        let force = |s: TruthSwitches, centre: Vector3<f64>, motion: Vector3<f64>| {
            truth.contact(&s, &centre, &motion).unwrap()
        };
        let base = force(bare(), at, still).normal_n;
        // Modulus and thickness stiffen the bar as E t^3.
        let stiffer = force(
            TruthSwitches {
                beam_modulus_offset: true,
                ..bare()
            },
            at,
            still,
        )
        .normal_n;
        assert!(
            (stiffer / base - 70.0f64 / 68.9).abs() < 2e-3,
            "{stiffer} {base}"
        );
        let thicker = force(
            TruthSwitches {
                sheet_thickness: true,
                ..bare()
            },
            at,
            still,
        )
        .normal_n;
        assert!(
            (thicker / base - 1.01f64.powi(3)).abs() < 3e-3,
            "{thicker} {base}"
        );
        // The clamp's compliance softens it.
        let clamped = force(
            TruthSwitches {
                clamp_compliance: true,
                ..bare()
            },
            at,
            still,
        )
        .normal_n;
        assert!(clamped < 0.97 * base, "{clamped} {base}");
        // A tip of radius r with its lowest point at the same place
        // touches behind it, where the bar is stiffer.
        let rounded = force(
            TruthSwitches {
                tool_radius: true,
                ..bare()
            },
            at + Vector3::new(0.0, 0.0, 0.010),
            still,
        );
        assert!(
            rounded.contact_x_m < 0.38 && rounded.normal_n > base,
            "{rounded:?}"
        );
        // Friction while travelling towards the clamp pulls the bar along -x.
        let rubbing = force(
            TruthSwitches {
                tool_friction: true,
                ..bare()
            },
            at,
            Vector3::new(-0.005, 0.0, 0.0),
        );
        let tangent = Vector3::new(rubbing.slope_rad.cos(), 0.0, -rubbing.slope_rad.sin());
        let ratio = rubbing.force_part_n.dot(&tangent) / rubbing.normal_n;
        // mu N, times the cosine between the motion and the bent surface.
        assert!(
            (ratio - 0.15 * rubbing.slope_rad.cos()).abs() < 1e-9,
            "{rubbing:?}"
        );
    }
}
