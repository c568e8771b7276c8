//! A plan as a self-contained HTML page (`flexcal plan --html FILE`): the
//! predicted accuracy against the number of poses with the knee, the
//! planned poses, what the campaign cannot determine, and the predicted
//! accuracy map over the region (`calibrate`'s map section). Everything
//! comes from the typed [`CampaignPlan`]; units mm.

use super::CampaignPlan;
use crate::calibration::html::map_section;
use crate::report::svg::{self, Series, YScale};
use crate::report::{Report, Section};

impl CampaignPlan {
    /// The plan as a report page (write it with [`Report::to_html`]).
    pub fn html_report(&self) -> Report {
        let mut report = Report::new(
            format!("Campaign plan for {}", self.robot),
            format!(
                "{} model, {} poses of {} candidates, region of {} points, {}",
                self.model,
                self.count,
                self.candidates,
                self.region_points,
                self.instrument.describe()
            ),
        );
        report.push(self.curve_section());
        report.push(self.poses_section());
        report.push(self.identifiability_section());
        let mut map = map_section(&self.prediction.map);
        match &self.prior {
            Some(prior) => {
                map.paragraph(format!(
                    "{}. {}.",
                    prior.describe(),
                    super::parts_line(&self.prediction.map)
                ));
            }
            None => {
                map.paragraph(
                    "The scatter of a plan is the instrument's noise: the bound of a measured campaign uses the scatter of its own residuals, which also holds what the model lacks.",
                );
            }
        }
        report.push(map);
        report
    }

    /// The curve of the predicted bound against the number of poses.
    fn curve_section(&self) -> Section {
        let mut section = Section::new("Predicted accuracy against the number of poses");
        let series = |label: &str, f: fn(&super::RegionAccuracy) -> f64| {
            Series::new(
                label,
                self.curve
                    .iter()
                    .map(|p| (p.poses as f64, f(&p.accuracy)))
                    .collect(),
            )
        };
        let mut all = vec![
            series("mean", |a| a.mean_bound_95_mm),
            series("95th percentile", |a| a.p95_bound_95_mm),
            series("max", |a| a.max_bound_95_mm).dashed(),
        ];
        if self.targets.len() > 1 {
            for (t, target) in self.targets.iter().enumerate() {
                let points = self
                    .curve
                    .iter()
                    .filter_map(|p| {
                        let a = p.per_target.get(t)?;
                        Some((p.poses as f64, a.accuracy.mean_bound_95_mm))
                    })
                    .collect();
                all.push(Series::new(format!("mean, target {}", target.name), points));
            }
        }
        if let Some(knee) = self
            .knee
            .and_then(|k| self.curve.iter().find(|p| p.poses == k))
        {
            let mut marker = Series::new(
                "knee",
                vec![(knee.poses as f64, knee.accuracy.mean_bound_95_mm)],
            );
            marker.markers = true;
            all.push(marker);
        }
        section.paragraph(format!(
            "{}. Each count is the greedy campaign of that many poses; the knee ({}) is the smallest count whose mean bound is within the tolerance of the curve's last.",
            self.criterion,
            self.knee.map_or("none".to_string(), |k| format!("{k} poses"))
        ));
        section.figure(
            svg::line_chart(
                "Predicted 95 % bound over the region",
                "poses",
                "95 % bound [mm]",
                &all,
                YScale::Log,
            ),
            "Mean, 95th percentile and maximum over the region points (and every target) of the predicted 95 % bound on the position error; with several targets, each target's mean too.",
        );
        if self.targets.len() > 1 {
            let rows = self
                .prediction
                .per_target
                .iter()
                .map(|t| {
                    let a = t.accuracy;
                    vec![
                        t.target.clone(),
                        format!("{:.4}", a.mean_bound_95_mm),
                        format!("{:.4}", a.p95_bound_95_mm),
                        format!("{:.4}", a.max_bound_95_mm),
                    ]
                })
                .collect();
            section.table(
                format!(
                    "Predicted 95 % bound over the region of each target, {} planned poses (mm)",
                    self.count
                ),
                &["target", "mean", "p95", "max"],
                rows,
            );
        }
        section
    }

    /// The planned poses.
    fn poses_section(&self) -> Section {
        let mut section = Section::new("Planned poses");
        let n = self.configurations.first().map_or(0, Vec::len);
        let mut header: Vec<String> = vec!["#".into(), "origin".into()];
        header.extend((1..=n).map(|i| format!("q{i}")));
        let header: Vec<&str> = header.iter().map(String::as_str).collect();
        let rows = self
            .configurations
            .iter()
            .zip(&self.origins)
            .enumerate()
            .map(|(k, (q, origin))| {
                let mut row = vec![(k + 1).to_string(), origin.clone()];
                row.extend(q.iter().map(|v| format!("{v:.5}")));
                row
            })
            .collect();
        section.table(
            format!("{} poses in measurement order (rad or m)", self.count),
            &header,
            rows,
        );
        section
    }

    /// What the campaign cannot determine.
    fn identifiability_section(&self) -> Section {
        let mut section = Section::new("What the campaign cannot determine");
        let p = &self.prediction;
        section.paragraph(format!(
            "{} unknowns identified by the planned poses.",
            p.rank
        ));
        if p.identifiability_notes.is_empty() {
            section.paragraph("Every unknown of the model is identified.");
        }
        for note in &p.identifiability_notes {
            section.paragraph(note);
        }
        for line in &p.combinations {
            section.paragraph(line);
        }
        section
    }
}
