//! The study's HTML report: text, tables and figures laid out from the
//! typed results of [`super::run_study`]; nothing is computed here but unit
//! conversions and formatting.

use flexcal_calib::UnknownStatus;
use flexcal_elastic::fuzzy_compliance::ComplianceComponent;
use flexcal_elastic::grid::GridValues;
use flexcal_elastic::metrics::LoadMetricsTable;
use flexcal_kinematics::ParamKind;

use super::{ElasticResults, FormingResults, GeometricResults, Study, ValidationFigures};
use crate::Result;
use crate::report::svg::{Series, YScale, bar_chart, heat_map, line_chart};
use crate::report::{Report, Section};

/// The study's self-contained HTML report (text, tables and SVG figures of
/// the paper's Figs. 7, 9, 10, 13-15, 17 and C.21-C.24).
pub fn study_report(study: &Study) -> Result<Report> {
    let mut report = Report::new(
        "flexcal: elasto-geometrical calibration of the virtual IR-663",
        format!(
            "Reference study of Marie, Courteille, Maurine (2013) on flexcal's virtual robot; seed {}, {:.1} s.",
            study.summary.seed, study.summary.runtime_s
        ),
    );
    let out = &study.options.out;
    report.push(twin_section(&study.summary.twin));
    report.push(geometric_section(&study.geometric, out));
    report.push(elastic_section(&study.elastic, out));
    report.push(fuzzy_section(&study.elastic));
    report.push(forming_section(&study.forming));
    Ok(report)
}

fn twin_section(twin: &super::TwinSummary) -> Section {
    let mut s = Section::new("The virtual IR-663 (a simulation)");
    s.paragraph(
        "Every figure below is measured on flexcal's virtual IR-663, a simulation, not a real robot. Its \
         truth is richer than every model identified from it: its own finite-element structure with its own \
         weight in every campaign, ball screws whose stiffness about the joints changes with the \
         configuration, drives with lost motion and torque hardening, cyclic transmission errors, a camera \
         frame the calibration must register, noise derived from the instrument's published accuracy, and a \
         forming beam, contact and dead weight that differ from the user's process model. Each term was \
         chosen from its source, then measured; none was tuned towards a figure.",
    );
    s.table(
        "The twin's truth terms",
        &["term", "on", "magnitude", "source"],
        twin.terms
            .iter()
            .map(|t| {
                vec![
                    t.name.clone(),
                    if t.enabled { "yes" } else { "no" }.into(),
                    t.magnitude.clone(),
                    t.source.clone(),
                ]
            })
            .collect(),
    );
    s
}

/// The validation outside box (59), the mass estimate and the
/// calibration with the masses 25 % off.
fn outside_and_masses_tables(s: &mut Section, g: &super::GeometricSummary) {
    let row = |name: &str, f: &ValidationFigures| {
        vec![
            name.to_string(),
            format!("{:.4}", f.position_mean_mm),
            format!("{:.4}", f.position_max_mm),
        ]
    };
    let o = &g.outside_box;
    s.table(
        format!(
            "Validation on {} poses outside box (59), where the robot's weight loads the joints unlike any identification pose (noise floor {:.4} mm mean)",
            o.poses, g.noise_floor_position_mean_mm
        ),
        &["robot model", "mean position [mm]", "max position [mm]"],
        vec![
            row("nominal", &o.before),
            row("geometric", &o.geometric),
            row("elasto-geometric", &o.elasto_geometric),
        ],
    );
    s.paragraph(format!(
        "Measurement noise: {:.1} um per axis, one LED's share of the camera's 37 um single-point accuracy (the \
         three LEDs' errors are mostly systematic, so taken as correlated); {:.1} um if they were independent \
         (not used).",
        g.noise_position_std_per_axis_um, g.noise_position_std_per_axis_independent_leds_um
    ));
    s.table(
        "The mass table the elasto-geometric calibration starts from (an estimate from the outline and catalogues)",
        &["mass", "frame", "kg", "centre [mm]", "uncertainty [%]", "source"],
        g.mass_estimate
            .iter()
            .map(|m| {
                vec![
                    m.name.clone(),
                    m.frame.clone(),
                    format!("{:.1}", m.mass_kg),
                    format!("{:.0}, {:.0}, {:.0}", m.center_mm[0], m.center_mm[1], m.center_mm[2]),
                    format!("{:.0}", m.uncertainty_percent),
                    m.source.clone(),
                ]
            })
            .collect(),
    );
    let mut rows = vec![{
        let mut r = row("x 1 (the estimate)", &g.elasto_geometric);
        r.extend(row("", &o.elasto_geometric).into_iter().skip(1));
        r
    }];
    for m in &g.mass_scaled {
        let mut r = row(&format!("x {}", m.scale), &m.inside);
        r.extend(row("", &m.outside).into_iter().skip(1));
        rows.push(r);
    }
    s.table(
        "Elasto-geometric calibration with every estimated mass scaled",
        &[
            "masses",
            "inside, mean [mm]",
            "inside, max [mm]",
            "outside, mean [mm]",
            "outside, max [mm]",
        ],
        rows,
    );
}

fn unit_of(kind: ParamKind) -> (&'static str, f64) {
    match kind {
        ParamKind::Length => ("mm", 1e3),
        ParamKind::Angle => ("deg", 180.0 / std::f64::consts::PI),
    }
}

/// The geometric calibration's section: what the twin carries, the
/// validation table ([`validation_table`]), the poses outside and the
/// masses, the combinations ([`combinations_table`]), the identified
/// errors against the truth ([`identified_errors_table`]), the errors
/// during identification (Fig. 7, [`iteration_figures`]), the
/// sensitivities (Figs. C.21-C.24, [`sensitivity_figures`]) and the
/// validation errors per pose.
fn geometric_section(g: &GeometricResults, out: &std::path::Path) -> Section {
    let mut s = Section::new("Geometric calibration (paper section 3.2)");
    s.paragraph(format!(
        "The virtual IR-663 carries the geometric errors of the paper's Appendix C and every other term of \
         its truth (its weight, its drives, its transmission errors). Its 27 identification and 16 validation \
         poses (box (59)) are measured by the photogrammetry system in its own frame, which the calibration \
         registers with the robot. {} of the {} parameters of xi and the frame are identified; the others \
         cannot be separated by these poses and stay nominal, their effect absorbed in the combinations below \
         (the paper's equation (C.1)). The elasto-geometric calibration identifies, on the same poses, the \
         geometry together with joint compliances under gravity (the links' estimated masses, the payload \
         identified). A perfect model would still show the noise floor: {:.4} mm mean.",
        g.summary.rank, g.summary.parameters, g.summary.noise_floor_position_mean_mm
    ));
    validation_table(&mut s, g);
    outside_and_masses_tables(&mut s, &g.summary);
    combinations_table(&mut s, &g.calibration);
    identified_errors_table(&mut s, g);
    iteration_figures(&mut s, &g.calibration);
    sensitivity_figures(&mut s, &g.sensitivity);
    let per_pose: Vec<(f64, f64)> = g
        .validation
        .after_per_pose
        .iter()
        .enumerate()
        .map(|(i, e)| (i as f64 + 1.0, e.position * 1e3))
        .collect();
    s.figure(
        line_chart(
            "Validation position error per pose after calibration",
            "validation pose",
            "position error [mm]",
            &[Series::new("calibrated", per_pose)],
            YScale::Linear,
        ),
        "Distance between measured and predicted TCP positions on the validation poses with the calibrated model.",
    );
    let dir = out.join("geometric");
    s.paragraph("Rerun this step with the individual commands:");
    s.code(format!(
        "flexcal twin geometric --out {d} --seed SEED\nflexcal calibrate --robot ir663 --data {d}/identification.csv --validate {d}/validation.csv --fixed-target --out {d}/calibrated.toml --report {d}/report.json",
        d = dir.display()
    ));
    s
}

/// The validation on the 16 other poses, beside the noise floor and the
/// paper's figures.
fn validation_table(s: &mut Section, g: &GeometricResults) {
    let stat_row = |name: &str, f: &ValidationFigures| {
        vec![
            name.to_string(),
            format!("{:.4}", f.position_mean_mm),
            format!("{:.4}", f.position_max_mm),
            format!("{:.4}", f.orientation_mean_deg),
            format!("{:.4}", f.orientation_max_deg),
        ]
    };
    s.table(
        "Validation on the 16 other poses (paper, real IR-663: 0.96 mm / 0.14 deg before, 0.24 mm / 0.03 deg after)",
        &["robot model", "mean position [mm]", "max position [mm]", "mean orientation [deg]", "max orientation [deg]"],
        vec![
            stat_row("nominal", &g.summary.validation_before),
            stat_row("geometric", &g.summary.validation_after),
            stat_row("elasto-geometric", &g.summary.elasto_geometric),
            vec![
                "noise floor".into(),
                format!("{:.4}", g.summary.noise_floor_position_mean_mm),
                String::new(),
                String::new(),
                String::new(),
            ],
            vec![
                "paper (real IR-663)".into(),
                "0.96 -> 0.24".into(),
                String::new(),
                "0.14 -> 0.03".into(),
                String::new(),
            ],
        ],
    );
}

/// The non-identifiable parameters and the combinations (C.1) the
/// identified ones stand for.
fn combinations_table(s: &mut Section, c: &flexcal_calib::Calibration) {
    let lines: Vec<Vec<String>> = c
        .combinations
        .iter()
        .map(|k| k.to_text(1e-3))
        .filter(|l| !l.is_empty())
        .map(|l| vec![l])
        .collect();
    s.table(
        "Non-identifiable parameters and the combinations the identified ones stand for",
        &["combination"],
        if lines.is_empty() {
            vec![vec!["(none: every parameter is identifiable)".into()]]
        } else {
            lines
        },
    );
}

/// Every parameter's identified error against the twin's true error.
fn identified_errors_table(s: &mut Section, g: &GeometricResults) {
    let model = &g.model;
    let c = &g.calibration;
    let mut rows = Vec::new();
    for (j, p) in model.params().iter().enumerate() {
        let (unit, scale) = unit_of(p.kind);
        let u = &c.unknowns[j];
        let true_error = (g.true_xi[j] - model.nominal_params()[j]) * scale;
        let identified = (u.value - u.initial) * scale;
        rows.push(vec![
            p.name.clone(),
            unit.to_string(),
            format!("{true_error:.4}"),
            match u.status {
                UnknownStatus::Identified => format!("{identified:.4}"),
                UnknownStatus::NonIdentifiable => "x (not identifiable)".into(),
                UnknownStatus::PoorlyIdentifiable => {
                    "kept nominal (standard error too large)".into()
                }
                UnknownStatus::Fixed => "fixed".into(),
                UnknownStatus::NoInfluence => "no influence".into(),
                UnknownStatus::AtBound => "held at its bound".into(),
            },
            u.standard_error
                .map(|se| format!("{:.4}", se * scale))
                .unwrap_or_default(),
        ]);
    }
    s.table(
        "Identified errors against the twin's true errors (an identified value of a deferred combination differs from the true error by the combination's other terms)",
        &["parameter", "unit", "true error", "identified", "standard error"],
        rows,
    );
}

/// Figure 7: position and orientation RMS errors of the identification
/// set at each iterate (every solve in order).
fn iteration_figures(s: &mut Section, c: &flexcal_calib::Calibration) {
    let history =
        |value: &dyn Fn(&flexcal_calib::ResidualNorms) -> Option<f64>| -> Vec<(f64, f64)> {
            c.residual_history
                .iter()
                .enumerate()
                .filter_map(|(i, h)| value(h).map(|v| (i as f64, v)))
                .collect()
        };
    s.figure(
        line_chart(
            "Position error during identification (Fig. 7)",
            "iteration",
            "RMS position error (mm)",
            &[Series::new(
                "identification set",
                history(&|h| Some(h.position_rms * 1e3)),
            )],
            YScale::Log,
        ),
        "RMS over the 27 identification poses of the position error at each iterate of Levenberg-Marquardt (each solve starts again from the nominal robot when the base set changes).",
    );
    s.figure(
        line_chart(
            "Orientation error during identification (Fig. 7)",
            "iteration",
            "RMS orientation error (deg)",
            &[Series::new(
                "identification set",
                history(&|h| h.orientation_rms.map(f64::to_degrees)),
            )],
            YScale::Log,
        ),
        "RMS over the identification poses of the orientation error angle at each iterate.",
    );
}

/// Figures C.21-C.24: mean and max of mu_P (55) and mu_Phi (56), split by
/// the unit of the parameter (per mm or per degree of error).
fn sensitivity_figures(s: &mut Section, table: &flexcal_kinematics::SensitivityTable) {
    let per_unit = |kind: ParamKind| match kind {
        ParamKind::Length => 1e-3,
        ParamKind::Angle => std::f64::consts::PI / 180.0,
    };
    let series = ["mean".to_string(), "max".to_string()];
    let figures = [
        (
            "Position sensitivity to length errors (Fig. C.21)",
            ParamKind::Length,
            true,
            "mm per mm",
            1e3,
        ),
        (
            "Position sensitivity to angular errors (Fig. C.22)",
            ParamKind::Angle,
            true,
            "mm per deg",
            1e3,
        ),
        (
            "Orientation sensitivity to length errors (Fig. C.23)",
            ParamKind::Length,
            false,
            "deg per mm",
            180.0 / std::f64::consts::PI,
        ),
        (
            "Orientation sensitivity to angular errors (Fig. C.24)",
            ParamKind::Angle,
            false,
            "deg per deg",
            180.0 / std::f64::consts::PI,
        ),
    ];
    for (title, kind, position, unit, scale) in figures {
        let mut names = Vec::new();
        let mut values = vec![Vec::new(), Vec::new()];
        for j in (0..table.names.len()).filter(|&j| table.kinds[j] == kind) {
            let (mean, max) = if position {
                (table.mean_position[j], table.max_position[j])
            } else {
                (table.mean_orientation[j], table.max_orientation[j])
            };
            names.push(table.names[j].clone());
            values[0].push(mean * scale * per_unit(kind));
            values[1].push(max * scale * per_unit(kind));
        }
        s.figure(
            bar_chart(title, unit, &names, &series, &values, YScale::Linear),
            format!(
                "Sensitivity index {} of each {} parameter over the 27 identification poses.",
                if position { "mu_P (55)" } else { "mu_Phi (56)" },
                if kind == ParamKind::Length {
                    "length"
                } else {
                    "angular"
                }
            ),
        );
    }
}

fn table5_rows(label: &str, table: &LoadMetricsTable) -> Vec<Vec<String>> {
    let mut rows: Vec<Vec<String>> = table
        .rows
        .iter()
        .map(|r| {
            vec![
                label.to_string(),
                format!("{:.0}", r.load_n),
                format!("{:.4}", r.rms_mm),
                format!("{:.4}", r.max_norm_mm),
                format!("{:.4}", r.max_abs_x_mm),
                format!("{:.4}", r.max_abs_z_mm),
            ]
        })
        .collect();
    rows.push(vec![
        label.to_string(),
        "all".into(),
        format!("{:.4}", table.overall_rms_mm),
        String::new(),
        String::new(),
        String::new(),
    ]);
    rows
}

fn grid_map(title: &str, grid: &GridValues, unit: &str) -> String {
    heat_map(
        title,
        "TCP x [m]",
        "TCP z [m]",
        &grid.xs,
        &grid.zs,
        &grid.values,
        unit,
    )
}

fn per_pose(values: &[f64]) -> Vec<(f64, f64)> {
    values
        .iter()
        .enumerate()
        .map(|(k, v)| (k as f64 + 1.0, *v))
        .collect()
}

fn elastic_section(e: &ElasticResults, out: &std::path::Path) -> Section {
    let o = &e.stiffness;
    let mut s = Section::new("Elastic model and stiffness identification (paper section 3.3.1)");
    s.paragraph(format!(
        "The virtual IR-663's elasticity is richer than the beam model identified on it: its joints 2 and 8 are \
         driven by ball screws whose stiffness about the joint, k h(q)^2, changes with the configuration, and \
         its links bend. The campaign loads the TCP with 300, 600, 900 and 1100 N along x and along z on the \
         63 poses of grid (65); the true deflection under 1100 N vertical spans {:.2} to {:.2} mm (paper: 1.6 \
         to 2.5 mm). The two 900 N sets identify the joint stiffnesses Gamma of the beam model of Figure 8 \
         (differential evolution, then Levenberg-Marquardt in log space); the other sets validate it.",
        e.campaign.deflection_norm_1100n_z_mm[0], e.campaign.deflection_norm_1100n_z_mm[1]
    ));
    s.table(
        "Identified joint stiffnesses (Table 3 analogue)",
        &[
            "parameter",
            "identified",
            "unit",
            "after global search",
            "sensitivity [sigma per ln unit]",
        ],
        o.fitted
            .names
            .iter()
            .enumerate()
            .map(|(j, n)| {
                vec![
                    n.clone(),
                    format!("{:.4e}", o.fitted.gamma[j]),
                    o.fitted.units[j].clone(),
                    format!("{:.4e}", o.fitted.gamma_global_search[j]),
                    format!("{:.3e}", o.fitted.identifiability.sensitivity[j]),
                ]
            })
            .collect(),
    );
    s.table(
        "Identifiability of the stiffness parameters",
        &["finding"],
        o.fitted
            .identifiability
            .describe()
            .into_iter()
            .map(|l| vec![l])
            .collect(),
    );
    s.table(
        "Table 5: residuals of the elastic models per load, both directions pooled (paper: parametric 0.110 mm, fuzzy 0.065 mm overall RMS)",
        &["model", "load [N]", "RMS [mm]", "max norm [mm]", "max |x| [mm]", "max |z| [mm]"],
        {
            let mut rows = table5_rows("parametric (FE)", &o.table);
            rows.extend(table5_rows("fuzzy (x-z plane)", &e.compliance.table));
            rows
        },
    );
    s.paragraph(format!(
        "The noise floor, the RMS norm of the deflection noise stated in the files, is {:.3} mm: no model can \
         get below it on these data.",
        o.noise_floor_mm
    ));
    let same = &e.summary.same_metric;
    let rows = |label: &str, t: &super::Table5| -> Vec<Vec<String>> {
        t.loads
            .iter()
            .map(|(load, f)| {
                vec![
                    label.to_string(),
                    load.clone(),
                    format!("{:.4}", f.rms_mm),
                    format!("{:.4}", f.max_norm_mm),
                ]
            })
            .chain(std::iter::once(vec![
                label.to_string(),
                "all".into(),
                format!("{:.4}", t.all.rms_mm),
                String::new(),
            ]))
            .collect()
    };
    s.table(
        format!(
            "Table 5 on the same metric: residual norms in the x-z plane (noise floor {:.4} mm) and in 3-D (noise floor {:.4} mm; the fuzzy model predicts no y deflection)",
            same.plane_xz.noise_floor_mm, same.three_d.noise_floor_mm
        ),
        &["model", "load [N]", "RMS [mm]", "max norm [mm]"],
        {
            let mut r = rows("parametric, x-z plane", &same.plane_xz.parametric);
            r.extend(rows("fuzzy, x-z plane", &same.plane_xz.fuzzy));
            r.extend(rows("parametric, 3-D", &same.three_d.parametric));
            r.extend(rows("fuzzy, 3-D", &same.three_d.fuzzy));
            r
        },
    );
    if let Some(v) = &e.vertical {
        // Figure 9: deflection norm over the grid under the largest vertical load.
        s.figure(
            grid_map(
                &format!("Measured deflection norm, {:.0} N vertical (Fig. 9)", v.load_n),
                &v.deflection_norm_mm,
                "mm",
            ),
            "Norm of the measured TCP deflection over the grid (65) in the plane y = 0 (the 3 poses of the corner that the arm cannot reach with the tool down sit at their own, larger x).",
        );
        // Figure 10: model against measurement along the set.
        s.figure(
            line_chart(
                &format!(
                    "Vertical deflection, {:.0} N vertical load (Fig. 10)",
                    v.load_n
                ),
                "pose of the grid",
                "deflection along z [mm]",
                &[
                    Series::new("measured", per_pose(&v.measured_z_mm)),
                    Series::new("parametric model", per_pose(&v.parametric_z_mm)).dashed(),
                ],
                YScale::Linear,
            ),
            "Measured TCP deflection and the identified beam model's prediction, pose by pose.",
        );
    }
    let dir = out.join("elastic");
    s.paragraph("Rerun these steps with the individual commands:");
    s.code(format!(
        "flexcal twin elastic --out {d} --seed SEED\nflexcal identify stiffness --robot ir663 --elastic ir663 --data {d} --train-load 900 --seed SEED --report {d}/stiffness_report.json",
        d = dir.display()
    ));
    s
}

fn fuzzy_section(e: &ElasticResults) -> Section {
    let f = &e.compliance;
    let model = &f.fitted.compliance;
    let mut s = Section::new("Fuzzy compliance model (paper section 3.3.2)");
    let r = &f.fitted.report;
    s.paragraph(format!(
        "Four zero-order Takagi-Sugeno models (C_xx, C_xz, C_zx, C_zz) of the joint angles theta2 and theta8, \
         with strong triangular partitions, are fitted jointly on the two 900 N sets: the measured deflection is \
         linear in the conclusions of all four. {} training and {} test configurations; Solis-Wets places the \
         modal values and structure growth stops when the test error stops improving or the rule budget (12) is \
         reached. Test RMSE per displacement component {:.4} mm. Overall RMS on all loads {:.3} mm, {:.2} times \
         the noise floor of {:.3} mm (paper: 0.065 mm).",
        r.training_configurations,
        r.test_configurations,
        r.test_mm.rmse,
        f.table.overall_rms_mm,
        f.table.overall_rms_mm / f.noise_floor_mm,
        f.noise_floor_mm
    ));
    if let Some(table) = model.rule_base_table(ComplianceComponent::plane_xz()[0]) {
        s.paragraph("Rule base of C_xx (Table 4): modal values in degrees, conclusions in mm/kN.");
        s.code(table);
    }
    // Figure 13: the membership functions and the C_xx surface.
    let partitions = model.models()[0].structure().partitions();
    for (input, partition) in model.inputs().iter().zip(partitions) {
        let modal: Vec<f64> = partition
            .modal_values()
            .iter()
            .map(|v| v.to_degrees())
            .collect();
        let series: Vec<Series> = (0..modal.len())
            .map(|k| {
                let mut points = Vec::new();
                if k > 0 {
                    points.push((modal[k - 1], 0.0));
                }
                points.push((modal[k], 1.0));
                if k + 1 < modal.len() {
                    points.push((modal[k + 1], 0.0));
                }
                Series::new(format!("A{}", k + 1), points)
            })
            .collect();
        s.figure(
            line_chart(
                &format!("Membership functions of {} (Fig. 13)", input.name),
                &format!("{} [deg]", input.name),
                "membership degree",
                &series,
                YScale::Linear,
            ),
            format!(
                "The strong triangular partition of {} found by the search.",
                input.name
            ),
        );
    }
    if let Some(surface) = &e.surface {
        s.figure(
            heat_map(
                "Fuzzy model of C_xx over the joint angles (Fig. 13)",
                &format!("{} [deg]", model.inputs()[0].name),
                &format!("{} [deg]", model.inputs()[1].name),
                &surface.xs_deg,
                &surface.ys_deg,
                &surface.c_xx_mm_per_kn,
                "mm/kN",
            ),
            "The multilinear surface of the C_xx model between its modal values.",
        );
    }
    // Figures 14 and 15: both models against the measurements of the largest
    // vertical load, pose by pose and as relative error maps over the grid.
    if let Some(v) = &e.vertical {
        s.figure(
            line_chart(
                &format!(
                    "Vertical deflection, {:.0} N vertical load (Fig. 14)",
                    v.load_n
                ),
                "pose of the grid",
                "deflection along z [mm]",
                &[
                    Series::new("measured", per_pose(&v.measured_z_mm)),
                    Series::new("fuzzy model", per_pose(&v.fuzzy_z_mm)).dashed(),
                ],
                YScale::Linear,
            ),
            "Measured TCP deflection and the fuzzy model's prediction, pose by pose.",
        );
        for (label, grid) in [
            ("parametric model", &v.parametric_error_percent),
            ("fuzzy model", &v.fuzzy_error_percent),
        ] {
            s.figure(
                grid_map(
                    &format!("Error of the {label}, {:.0} N vertical (Fig. 15)", v.load_n),
                    grid,
                    "%",
                ),
                format!("Residual norm of the {label} relative to the measured deflection, over the grid."),
            );
        }
    }
    s.paragraph("Rerun this step with the individual command:");
    s.code("flexcal identify compliance --data DIR --inputs theta2,theta8 --train-load 900 --test-fraction 0.286 --seed SEED --out DIR/fuzzy_compliance.toml");
    s
}

fn forming_section(forming: &FormingResults) -> Section {
    let result = &forming.result;
    let summary = &forming.summary;
    let mut s = Section::new("Forming path compensation (paper section 4)");
    let figures: Vec<String> = summary
        .compensations
        .iter()
        .map(|c| {
            format!(
                "with the {} {:.3} mm over the contact points ({:.0} % better, {} +/- 0.15 mm) and {:.3} mm over the whole path ({:.0} % better)",
                c.model,
                c.max_deviation_contact_mm,
                c.improvement_contact_percent,
                if c.within_tolerance_contact { "within" } else { "not within" },
                c.max_deviation_path_mm,
                c.improvement_path_percent
            )
        })
        .collect();
    s.paragraph(format!(
        "The tool bends a clamped Al-5005 bar (585 x 50 x 14 mm): it plunges 25 mm 5 mm from the free end, \
         then travels 200 mm towards the clamp, carrying a {:.0} N dead weight ({}). The bar pushes back according \
         to where the tool actually is, so the twin solves its robot and its own bar together (its own Timoshenko \
         bar, 70 GPa, 1 % thicker, a compliant clamp, a 10 mm tool tip whose contact moves, Coulomb friction, a \
         dead weight 0.5 % off) and measures the path with the camera; the commands use the identified geometry, \
         an identified elastic model, the handbook bar without friction and the part located from {} noisy \
         reference points through the registered camera frame (fit residual {:.3} mm RMS). The contact points ({} of {}) are \
         those below the bar's surface, where the process load acts. Without compensation the deviation along z_p \
         reaches {:.3} mm over the contact points and {:.3} mm over the whole path (paper: 0.4 to 1.5 mm); \
         compensated, {}. The paper: 80 % better, within +/- 0.15 mm.",
        summary.dead_weight_n,
        summary.dead_weight_source,
        6,
        summary.part_fit_rms_mm,
        summary.contact_points,
        summary.path_points,
        summary.uncompensated_contact_mm,
        summary.uncompensated_path_mm,
        figures.join("; ")
    ));
    let xs: Vec<f64> = result.target_mm.iter().map(|p| p.0).collect();
    let series_of = |path: &crate::forming::MeasuredPath| -> Vec<(f64, f64)> {
        xs.iter()
            .zip(&result.target_mm)
            .zip(&path.deviation_z_mm)
            .map(|((x, t), d)| (*x, t.1 + d))
            .collect()
    };
    let mut series = vec![
        Series::new("target", result.target_mm.clone()).dashed(),
        Series::new("measured, uncompensated", series_of(&result.uncompensated)),
    ];
    for c in &result.compensated {
        series.push(Series::new(format!("measured, {}", c.label), series_of(c)));
    }
    s.figure(
        line_chart(
            "Tool path in the beam's vertical plane (Fig. 17)",
            "x_p [mm] (clamp at 0)",
            "z_p [mm]",
            &series,
            YScale::Linear,
        ),
        "Target path and the paths the twin measured without and with compensation.",
    );
    let indexed = |values: &[f64]| -> Vec<(f64, f64)> {
        values
            .iter()
            .enumerate()
            .map(|(k, d)| (k as f64, *d))
            .collect()
    };
    let mut deviations = vec![Series::new(
        "uncompensated",
        indexed(
            &result.uncompensated.deviation_z_mm
                [..xs.len().min(result.uncompensated.deviation_z_mm.len())],
        ),
    )];
    for c in &result.compensated {
        deviations.push(Series::new(c.label.clone(), indexed(&c.deviation_z_mm)));
        if let Some(p) = &c.predicted_uncompensated_z_mm {
            deviations.push(
                Series::new(
                    format!(
                        "predicted uncompensated ({})",
                        c.label.trim_start_matches("compensated, ")
                    ),
                    indexed(p),
                )
                .dashed(),
            );
        }
    }
    s.figure(
        line_chart(
            "Deviation from the target along z_p",
            "path point (plunge, then travel towards the clamp)",
            "deviation along z_p [mm]",
            &deviations,
            YScale::Linear,
        ),
        "Measured deviations point by point, and the deviation the user's model predicted before compensation.",
    );
    s.paragraph("Rerun this step with the individual commands (files of the earlier steps):");
    s.code(
        "flexcal twin forming --out DIR/forming --seed SEED --calibrated DIR/geometric/calibrated.toml \\\n    --fe-report DIR/elastic/stiffness_report.json --fuzzy DIR/elastic/fuzzy_compliance.toml\n\
         flexcal compensate --robot ir663 --calibrated DIR/geometric/calibrated.toml --elastic fuzzy:DIR/elastic/fuzzy_compliance.toml \\\n    \
         --path DIR/forming/target_path.csv --part-pose 1200,0,1450,0,0,0 --process cantilever:585,50,14,al-5005 \\\n    \
         --payload 0,0,-650 --out DIR/forming/commanded.csv --krl DIR/forming/commanded.src",
    );
    s
}
