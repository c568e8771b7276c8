//! The study over several seeds: the acceptance figures as min / median /
//! max, so that no conclusion rests on one draw of the noise.

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::{StudyObserver, StudyOptions, Summary, Table5, run_study};
use crate::Result;

/// Smallest, median and largest value of a figure over the seeds.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Spread {
    /// Smallest value.
    pub min: f64,
    /// Median (the mean of the two middle values for an even count).
    pub median: f64,
    /// Largest value.
    pub max: f64,
}

impl Spread {
    /// The spread of `values` (NaN everywhere when empty).
    pub fn of(values: &[f64]) -> Self {
        let mut v: Vec<f64> = values.to_vec();
        v.sort_by(f64::total_cmp);
        let n = v.len();
        if n == 0 {
            return Self {
                min: f64::NAN,
                median: f64::NAN,
                max: f64::NAN,
            };
        }
        let median = if n % 2 == 1 {
            v[n / 2]
        } else {
            0.5 * (v[n / 2 - 1] + v[n / 2])
        };
        Self {
            min: v[0],
            median,
            max: v[n - 1],
        }
    }

    fn text(&self, digits: usize) -> String {
        format!(
            "{:.d$} / {:.d$} / {:.d$}",
            self.min,
            self.median,
            self.max,
            d = digits
        )
    }
}

/// One load of Table 5, both models on the same metric, over the seeds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LoadComparison {
    /// RMS of the parametric model (mm).
    pub parametric_rms_mm: Spread,
    /// RMS of the fuzzy model (mm).
    pub fuzzy_rms_mm: Spread,
    /// Seeds on which the fuzzy model's RMS is below the parametric one's.
    pub fuzzy_better_seeds: usize,
}

/// The acceptance figures of the study over several seeds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MultiSeedSummary {
    /// The seeds.
    pub seeds: Vec<u64>,
    /// Validation mean position error before calibration (mm).
    pub before_mean_mm: Spread,
    /// Validation mean position error, geometric model (mm).
    pub geometric_mean_mm: Spread,
    /// Validation max position error, geometric model (mm).
    pub geometric_max_mm: Spread,
    /// Validation mean position error, elasto-geometric model (mm).
    pub elasto_geometric_mean_mm: Spread,
    /// Validation max position error, elasto-geometric model (mm).
    pub elasto_geometric_max_mm: Spread,
    /// Seeds on which the elasto-geometric mean is below the geometric one.
    pub elasto_geometric_better_mean_seeds: usize,
    /// Seeds on which the elasto-geometric max is below the geometric one.
    pub elasto_geometric_better_max_seeds: usize,
    /// Noise floor of the validation mean (mm).
    pub noise_floor_mean_mm: Spread,
    /// Outside box (59): validation mean before calibration (mm).
    pub outside_before_mean_mm: Spread,
    /// Outside box (59): validation mean and max, geometric model (mm).
    pub outside_geometric_mm: MeanMax,
    /// Outside box (59): validation mean and max, elasto-geometric model (mm).
    pub outside_elasto_geometric_mm: MeanMax,
    /// Outside box (59): seeds on which the elasto-geometric mean is below
    /// the geometric one.
    pub outside_elasto_geometric_better_mean_seeds: usize,
    /// Outside box (59): seeds on which the elasto-geometric max is below
    /// the geometric one.
    pub outside_elasto_geometric_better_max_seeds: usize,
    /// Loaded validation (box (59), the payload at the TCP): mean before
    /// calibration (mm).
    pub loaded_before_mean_mm: Spread,
    /// Loaded validation: mean and max, geometric model (mm).
    pub loaded_geometric_mm: MeanMax,
    /// Loaded validation: mean and max, elasto-geometric model told the
    /// payload (mm).
    pub loaded_elasto_geometric_mm: MeanMax,
    /// Loaded validation: seeds on which the elasto-geometric mean is below
    /// the geometric one.
    pub loaded_elasto_geometric_better_mean_seeds: usize,
    /// Loaded validation: seeds on which the elasto-geometric max is below
    /// the geometric one.
    pub loaded_elasto_geometric_better_max_seeds: usize,
    /// The elasto-geometric calibration with every estimated mass scaled:
    /// validation inside and outside box (59) and loaded, per scale.
    pub mass_scaled: Vec<MassScaleSpread>,
    /// Table 5 per metric (`"plane_xz"`, `"three_d"` on the campaign's
    /// grid, `"held_out_plane_xz"`, `"held_out_three_d"` on the held-out
    /// configurations) and load (`"300"`, ..., `"all"`).
    pub table5: BTreeMap<String, BTreeMap<String, LoadComparison>>,
    /// Noise floor of each Table 5 metric (mm).
    pub table5_noise_floor_mm: BTreeMap<String, Spread>,
    /// Forming: largest |deviation| along z_p without compensation over
    /// the contact points (mm).
    pub forming_uncompensated_contact_mm: Spread,
    /// Forming: the same over the whole path (mm).
    pub forming_uncompensated_path_mm: Spread,
    /// Forming: each compensation's figures, in the study's order.
    pub forming_compensations: Vec<CompensationSpread>,
    /// Wall-clock time of one study (s).
    pub runtime_s: Spread,
    /// Every seed's summary.
    pub summaries: Vec<Summary>,
}

/// Mean and max position error of one validation over the seeds (mm).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MeanMax {
    /// Mean position error (mm).
    pub mean: Spread,
    /// Max position error (mm).
    pub max: Spread,
}

impl MeanMax {
    fn of(figures: &[&super::ValidationFigures]) -> Self {
        let pick = |get: fn(&super::ValidationFigures) -> f64| {
            Spread::of(&figures.iter().map(|f| get(f)).collect::<Vec<_>>())
        };
        Self {
            mean: pick(|f| f.position_mean_mm),
            max: pick(|f| f.position_max_mm),
        }
    }
}

/// The elasto-geometric calibration with every mass scaled, over the seeds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MassScaleSpread {
    /// The factor applied to every estimated mass.
    pub scale: f64,
    /// Validation inside box (59) (mm).
    pub inside_mm: MeanMax,
    /// Validation outside box (59) (mm).
    pub outside_mm: MeanMax,
    /// Loaded validation (mm).
    pub loaded_mm: MeanMax,
}

fn mass_scale_spreads(summaries: &[Summary]) -> Vec<MassScaleSpread> {
    let scales: Vec<f64> = summaries
        .first()
        .map(|s| s.geometric.mass_scaled.iter().map(|m| m.scale).collect())
        .unwrap_or_default();
    scales
        .into_iter()
        .map(|scale| {
            let runs: Vec<&super::MassScaleFigures> = summaries
                .iter()
                .filter_map(|s| s.geometric.mass_scaled.iter().find(|m| m.scale == scale))
                .collect();
            MassScaleSpread {
                scale,
                inside_mm: MeanMax::of(&runs.iter().map(|m| &m.inside).collect::<Vec<_>>()),
                outside_mm: MeanMax::of(&runs.iter().map(|m| &m.outside).collect::<Vec<_>>()),
                loaded_mm: MeanMax::of(&runs.iter().map(|m| &m.loaded).collect::<Vec<_>>()),
            }
        })
        .collect()
}

/// One compensation's forming figures over the seeds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CompensationSpread {
    /// The elastic model.
    pub model: String,
    /// Largest |deviation| along z_p over the contact points (mm).
    pub contact_mm: Spread,
    /// Largest |deviation| along z_p over the whole path (mm).
    pub path_mm: Spread,
    /// Improvement over the contact points (%).
    pub improvement_contact_percent: Spread,
    /// Improvement over the whole path (%).
    pub improvement_path_percent: Spread,
    /// Seeds on which every contact point is within +-0.15 mm.
    pub within_tolerance_seeds: usize,
}

fn compensation_spreads(summaries: &[Summary]) -> Vec<CompensationSpread> {
    let models: Vec<String> = summaries
        .first()
        .map(|s| {
            s.forming
                .compensations
                .iter()
                .map(|c| c.model.clone())
                .collect()
        })
        .unwrap_or_default();
    models
        .into_iter()
        .map(|model| {
            let figures: Vec<&super::CompensationFigures> = summaries
                .iter()
                .filter_map(|s| s.forming.compensations.iter().find(|c| c.model == model))
                .collect();
            let f = |get: fn(&super::CompensationFigures) -> f64| {
                Spread::of(&figures.iter().map(|c| get(c)).collect::<Vec<_>>())
            };
            CompensationSpread {
                contact_mm: f(|c| c.max_deviation_contact_mm),
                path_mm: f(|c| c.max_deviation_path_mm),
                improvement_contact_percent: f(|c| c.improvement_contact_percent),
                improvement_path_percent: f(|c| c.improvement_path_percent),
                within_tolerance_seeds: figures
                    .iter()
                    .filter(|c| c.within_tolerance_contact)
                    .count(),
                model,
            }
        })
        .collect()
}

fn compare_loads(parametric: &[&Table5], fuzzy: &[&Table5]) -> BTreeMap<String, LoadComparison> {
    let mut keys: Vec<String> = parametric
        .first()
        .map(|t| t.loads.keys().cloned().collect())
        .unwrap_or_default();
    keys.push("all".into());
    keys.into_iter()
        .map(|key| {
            let pick = |t: &Table5| -> f64 {
                if key == "all" {
                    t.all.rms_mm
                } else {
                    t.loads.get(&key).map_or(f64::NAN, |f| f.rms_mm)
                }
            };
            let p: Vec<f64> = parametric.iter().map(|t| pick(t)).collect();
            let f: Vec<f64> = fuzzy.iter().map(|t| pick(t)).collect();
            let better = p.iter().zip(&f).filter(|(p, f)| f < p).count();
            (
                key,
                LoadComparison {
                    parametric_rms_mm: Spread::of(&p),
                    fuzzy_rms_mm: Spread::of(&f),
                    fuzzy_better_seeds: better,
                },
            )
        })
        .collect()
}

/// Seeds on which `better` holds of the (geometric, elasto-geometric)
/// figures `pick` gives.
fn seeds_where(
    summaries: &[Summary],
    pick: fn(&Summary) -> (&super::ValidationFigures, &super::ValidationFigures),
    better: fn(&super::ValidationFigures, &super::ValidationFigures) -> bool,
) -> usize {
    summaries
        .iter()
        .filter(|s| {
            let (geometric, elasto_geometric) = pick(s);
            better(geometric, elasto_geometric)
        })
        .count()
}

/// Whether the second figures' mean (or max) is below the first's.
fn lower_mean(a: &super::ValidationFigures, b: &super::ValidationFigures) -> bool {
    b.position_mean_mm < a.position_mean_mm
}

fn lower_max(a: &super::ValidationFigures, b: &super::ValidationFigures) -> bool {
    b.position_max_mm < a.position_max_mm
}

impl MultiSeedSummary {
    /// The acceptance figures of the study summaries `summaries` (one per
    /// seed).
    pub fn from_summaries(summaries: Vec<Summary>) -> Self {
        let f = |get: &dyn Fn(&Summary) -> f64| -> Spread {
            Spread::of(&summaries.iter().map(get).collect::<Vec<_>>())
        };
        fn g(s: &Summary) -> &super::GeometricSummary {
            &s.geometric
        }
        fn inside(s: &Summary) -> (&super::ValidationFigures, &super::ValidationFigures) {
            (&s.geometric.validation_after, &s.geometric.elasto_geometric)
        }
        fn outside(s: &Summary) -> (&super::ValidationFigures, &super::ValidationFigures) {
            let o = &s.geometric.outside_box;
            (&o.geometric, &o.elasto_geometric)
        }
        fn loaded(s: &Summary) -> (&super::ValidationFigures, &super::ValidationFigures) {
            (
                &s.geometric.loaded.geometric,
                &s.geometric.loaded.elasto_geometric,
            )
        }
        let mut table5 = BTreeMap::new();
        let mut floors = BTreeMap::new();
        for (name, pick) in [
            (
                "plane_xz",
                (|s: &Summary| &s.elastic.same_metric.plane_xz)
                    as fn(&Summary) -> &super::SameMetric,
            ),
            ("three_d", |s: &Summary| &s.elastic.same_metric.three_d),
            ("held_out_plane_xz", |s: &Summary| {
                &s.elastic.held_out.plane_xz
            }),
            ("held_out_three_d", |s: &Summary| {
                &s.elastic.held_out.three_d
            }),
        ] {
            let parametric: Vec<&Table5> = summaries.iter().map(|s| &pick(s).parametric).collect();
            let fuzzy: Vec<&Table5> = summaries.iter().map(|s| &pick(s).fuzzy).collect();
            table5.insert(name.to_string(), compare_loads(&parametric, &fuzzy));
            floors.insert(name.to_string(), f(&|s| pick(s).noise_floor_mm));
        }
        Self {
            seeds: summaries.iter().map(|s| s.seed).collect(),
            before_mean_mm: f(&|s| g(s).validation_before.position_mean_mm),
            geometric_mean_mm: f(&|s| g(s).validation_after.position_mean_mm),
            geometric_max_mm: f(&|s| g(s).validation_after.position_max_mm),
            elasto_geometric_mean_mm: f(&|s| g(s).elasto_geometric.position_mean_mm),
            elasto_geometric_max_mm: f(&|s| g(s).elasto_geometric.position_max_mm),
            elasto_geometric_better_mean_seeds: seeds_where(&summaries, inside, lower_mean),
            elasto_geometric_better_max_seeds: seeds_where(&summaries, inside, lower_max),
            noise_floor_mean_mm: f(&|s| g(s).noise_floor_position_mean_mm),
            outside_before_mean_mm: f(&|s| g(s).outside_box.before.position_mean_mm),
            outside_geometric_mm: MeanMax::of(
                &summaries
                    .iter()
                    .map(|s| &g(s).outside_box.geometric)
                    .collect::<Vec<_>>(),
            ),
            outside_elasto_geometric_mm: MeanMax::of(
                &summaries
                    .iter()
                    .map(|s| &g(s).outside_box.elasto_geometric)
                    .collect::<Vec<_>>(),
            ),
            outside_elasto_geometric_better_mean_seeds: seeds_where(
                &summaries, outside, lower_mean,
            ),
            outside_elasto_geometric_better_max_seeds: seeds_where(&summaries, outside, lower_max),
            loaded_before_mean_mm: f(&|s| g(s).loaded.before.position_mean_mm),
            loaded_geometric_mm: MeanMax::of(
                &summaries
                    .iter()
                    .map(|s| &g(s).loaded.geometric)
                    .collect::<Vec<_>>(),
            ),
            loaded_elasto_geometric_mm: MeanMax::of(
                &summaries
                    .iter()
                    .map(|s| &g(s).loaded.elasto_geometric)
                    .collect::<Vec<_>>(),
            ),
            loaded_elasto_geometric_better_mean_seeds: seeds_where(&summaries, loaded, lower_mean),
            loaded_elasto_geometric_better_max_seeds: seeds_where(&summaries, loaded, lower_max),
            mass_scaled: mass_scale_spreads(&summaries),
            table5,
            table5_noise_floor_mm: floors,
            forming_uncompensated_contact_mm: f(&|s| s.forming.uncompensated_contact_mm),
            forming_uncompensated_path_mm: f(&|s| s.forming.uncompensated_path_mm),
            forming_compensations: compensation_spreads(&summaries),
            runtime_s: f(&|s| s.runtime_s),
            summaries,
        }
    }

    /// The figures as Markdown tables (min / median / max): the geometric
    /// step inside box (59), outside it and loaded, the masses scaled,
    /// Table 5 and the forming task.
    pub fn to_markdown(&self) -> String {
        let n = self.seeds.len();
        let seeds: Vec<String> = self.seeds.iter().map(u64::to_string).collect();
        let mut out = format!(
            "Seeds {} (min / median / max over {n} seeds).\n\n",
            seeds.join(", ")
        );
        self.geometric_markdown(&mut out);
        self.outside_markdown(&mut out);
        self.loaded_markdown(&mut out);
        self.masses_markdown(&mut out);
        self.table5_markdown(&mut out);
        self.forming_markdown(&mut out);
        out
    }

    /// The geometric step on the validation poses of box (59).
    fn geometric_markdown(&self, out: &mut String) {
        let n = self.seeds.len();
        *out += "| geometric step, validation | mean position [mm] | max position [mm] |\n|---|---|---|\n";
        *out += &format!(
            "| nominal (frame registered) | {} | |\n",
            self.before_mean_mm.text(3)
        );
        *out += &format!(
            "| geometric | {} | {} |\n",
            self.geometric_mean_mm.text(4),
            self.geometric_max_mm.text(4)
        );
        *out += &format!(
            "| elasto-geometric | {} | {} |\n",
            self.elasto_geometric_mean_mm.text(4),
            self.elasto_geometric_max_mm.text(4)
        );
        *out += &format!("| noise floor | {} | |\n", self.noise_floor_mean_mm.text(4));
        *out += "| paper (real IR-663) | 0.96 -> 0.24 | |\n\n";
        *out += &format!(
            "Elasto-geometric below geometric: mean on {} of {n} seeds, max on {} of {n}.\n\n",
            self.elasto_geometric_better_mean_seeds, self.elasto_geometric_better_max_seeds
        );
    }

    /// The geometric step on the validation poses outside box (59).
    fn outside_markdown(&self, out: &mut String) {
        let n = self.seeds.len();
        *out += "| geometric step, validation outside box (59) | mean position [mm] | max position [mm] |\n|---|---|---|\n";
        *out += &format!(
            "| nominal (frame registered) | {} | |\n",
            self.outside_before_mean_mm.text(3)
        );
        for (name, figures) in [
            ("geometric", &self.outside_geometric_mm),
            ("elasto-geometric", &self.outside_elasto_geometric_mm),
        ] {
            *out += &format!(
                "| {name} | {} | {} |\n",
                figures.mean.text(4),
                figures.max.text(4)
            );
        }
        *out += &format!(
            "| noise floor | {} | |\n\nOutside box (59), elasto-geometric below geometric: mean on {} of {n} seeds, max on {} of {n}.\n\n",
            self.noise_floor_mean_mm.text(4),
            self.outside_elasto_geometric_better_mean_seeds,
            self.outside_elasto_geometric_better_max_seeds
        );
    }

    /// The geometric step on the loaded validation poses.
    fn loaded_markdown(&self, out: &mut String) {
        let n = self.seeds.len();
        *out += "| geometric step, loaded validation (box (59), payload at the TCP) | mean position [mm] | max position [mm] |\n|---|---|---|\n";
        *out += &format!(
            "| nominal (frame registered) | {} | |\n",
            self.loaded_before_mean_mm.text(3)
        );
        for (name, figures) in [
            ("geometric", &self.loaded_geometric_mm),
            (
                "elasto-geometric, told the payload",
                &self.loaded_elasto_geometric_mm,
            ),
        ] {
            *out += &format!(
                "| {name} | {} | {} |\n",
                figures.mean.text(4),
                figures.max.text(4)
            );
        }
        *out += &format!(
            "| noise floor | {} | |\n\nLoaded, elasto-geometric below geometric: mean on {} of {n} seeds, max on {} of {n}.\n\n",
            self.noise_floor_mean_mm.text(4),
            self.loaded_elasto_geometric_better_mean_seeds,
            self.loaded_elasto_geometric_better_max_seeds
        );
    }

    /// The elasto-geometric step with the masses scaled.
    fn masses_markdown(&self, out: &mut String) {
        *out += "| elasto-geometric, masses scaled | inside, mean [mm] | inside, max [mm] | outside, mean [mm] | outside, max [mm] | loaded, mean [mm] | loaded, max [mm] |\n|---|---|---|---|---|---|---|\n";
        let row = |scale: &str, inside: &MeanMax, outside: &MeanMax, loaded: &MeanMax| {
            format!(
                "| {scale} | {} | {} | {} | {} | {} | {} |\n",
                inside.mean.text(4),
                inside.max.text(4),
                outside.mean.text(4),
                outside.max.text(4),
                loaded.mean.text(4),
                loaded.max.text(4)
            )
        };
        *out += &row(
            "x 1 (the estimate)",
            &MeanMax {
                mean: self.elasto_geometric_mean_mm,
                max: self.elasto_geometric_max_mm,
            },
            &self.outside_elasto_geometric_mm,
            &self.loaded_elasto_geometric_mm,
        );
        for m in &self.mass_scaled {
            *out += &row(
                &format!("x {}", m.scale),
                &m.inside_mm,
                &m.outside_mm,
                &m.loaded_mm,
            );
        }
        *out += "\n";
    }

    /// Table 5's comparison of the parametric and fuzzy models.
    fn table5_markdown(&self, out: &mut String) {
        let n = self.seeds.len();
        for (metric, loads) in &self.table5 {
            let floor = self.table5_noise_floor_mm.get(metric);
            *out += &format!(
                "| Table 5, {} (noise floor {} mm) | parametric RMS [mm] | fuzzy RMS [mm] | fuzzy better |\n|---|---|---|---|\n",
                match metric.as_str() {
                    "plane_xz" => "training grid, x-z plane",
                    "three_d" => "training grid, 3-D",
                    "held_out_plane_xz" => "held out, x-z plane",
                    _ => "held out, 3-D",
                },
                floor.map_or(String::new(), |s| s.text(4))
            );
            for (load, c) in loads {
                *out += &format!(
                    "| {load} {} | {} | {} | {} of {n} |\n",
                    if load == "all" { "" } else { "N" },
                    c.parametric_rms_mm.text(4),
                    c.fuzzy_rms_mm.text(4),
                    c.fuzzy_better_seeds
                );
            }
            *out += "\n";
        }
    }

    /// The forming task, uncompensated and compensated.
    fn forming_markdown(&self, out: &mut String) {
        let n = self.seeds.len();
        *out += "| forming, largest deviation along z_p | contact points | whole path |\n|---|---|---|\n";
        *out += &format!(
            "| uncompensated [mm] | {} | {} |\n",
            self.forming_uncompensated_contact_mm.text(3),
            self.forming_uncompensated_path_mm.text(3)
        );
        for c in &self.forming_compensations {
            *out += &format!(
                "| compensated, {} [mm] | {} | {} |\n",
                c.model,
                c.contact_mm.text(3),
                c.path_mm.text(3)
            );
            *out += &format!(
                "| improvement, {} [%] | {} | {} |\n",
                c.model,
                c.improvement_contact_percent.text(1),
                c.improvement_path_percent.text(1)
            );
        }
        *out += "| paper (real IR-663) | 80 %, within +/-0.15 mm | |\n\n";
        for c in &self.forming_compensations {
            *out += &format!(
                "{}: every contact point within +/-0.15 mm on {} of {n} seeds.\n",
                c.model, c.within_tolerance_seeds
            );
        }
    }
}

/// Runs the study once per seed (each under `out_root/seed-N`, without the
/// HTML report) and gathers the acceptance figures.
///
/// # Errors
/// Any study's failure.
pub fn multi_seed_study(
    seeds: &[u64],
    out_root: &Path,
    observer: &mut dyn StudyObserver,
) -> Result<MultiSeedSummary> {
    let mut summaries = Vec::with_capacity(seeds.len());
    for &seed in seeds {
        let options = StudyOptions {
            out: out_root.join(format!("seed-{seed}")),
            seed,
        };
        let study = run_study(&options, observer)?;
        study.summary.write(options.out.join("summary.json"))?;
        summaries.push(study.summary);
    }
    Ok(MultiSeedSummary::from_summaries(summaries))
}

#[cfg(test)]
mod tests {
    use super::Spread;

    #[test]
    fn spread_is_min_median_max() {
        let s = Spread::of(&[3.0, 1.0, 2.0, 10.0, -1.0]);
        assert_eq!((s.min, s.median, s.max), (-1.0, 2.0, 10.0));
        let s = Spread::of(&[4.0, 1.0, 2.0, 3.0]);
        assert_eq!((s.min, s.median, s.max), (1.0, 2.5, 4.0));
        assert!(Spread::of(&[]).median.is_nan());
    }
}
