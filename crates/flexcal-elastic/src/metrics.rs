//! Per-load accuracy metrics of an elastic model, as in Table 5 of the
//! reference paper: for each load magnitude (both directions pooled), the RMS
//! of the residual norm, the largest residual norm, the largest |x| and |z|
//! residual components, in mm; and the RMS over all samples.
//!
//! The function is model-agnostic: the parametric beam model and the fuzzy
//! compliance model are evaluated with the same [`per_load_metrics`].

use std::fmt;

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// One residual `predicted - measured` TCP displacement (m, base axes) and
/// the magnitude of the load that produced it (N).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ResidualSample {
    /// Load magnitude (N); samples whose loads round to the same newton are pooled.
    pub load_n: f64,
    /// Residual (m), base axes.
    pub residual: Vector3<f64>,
}

/// Metrics of one load magnitude (mm).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LoadMetrics {
    /// Load magnitude (N).
    pub load_n: f64,
    /// Number of samples.
    pub count: usize,
    /// RMS of the residual norm, `sqrt(mean |e|^2)` (mm).
    pub rms_mm: f64,
    /// Largest residual norm (mm).
    pub max_norm_mm: f64,
    /// Largest |x| component (mm).
    pub max_abs_x_mm: f64,
    /// Largest |z| component (mm).
    pub max_abs_z_mm: f64,
}

/// The per-load table (rows by increasing load) and the overall RMS.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LoadMetricsTable {
    /// One row per load magnitude.
    pub rows: Vec<LoadMetrics>,
    /// RMS of the residual norm over all samples (mm).
    pub overall_rms_mm: f64,
    /// Number of samples.
    pub count: usize,
}

/// Computes the per-load table of `samples` (empty input gives an empty
/// table with a zero overall RMS).
pub fn per_load_metrics(samples: &[ResidualSample]) -> LoadMetricsTable {
    let mut loads: Vec<f64> = samples.iter().map(|s| s.load_n.round()).collect();
    loads.sort_by(f64::total_cmp);
    loads.dedup();
    let rows = loads
        .iter()
        .map(|&load| {
            let group: Vec<&ResidualSample> = samples
                .iter()
                .filter(|s| s.load_n.round() == load)
                .collect();
            let sum_sq: f64 = group.iter().map(|s| s.residual.norm_squared()).sum();
            let max = |f: &dyn Fn(&ResidualSample) -> f64| {
                group.iter().map(|s| f(s)).fold(0.0, f64::max) * 1e3
            };
            LoadMetrics {
                load_n: load,
                count: group.len(),
                rms_mm: (sum_sq / group.len() as f64).sqrt() * 1e3,
                max_norm_mm: max(&|s| s.residual.norm()),
                max_abs_x_mm: max(&|s| s.residual.x.abs()),
                max_abs_z_mm: max(&|s| s.residual.z.abs()),
            }
        })
        .collect();
    let total: f64 = samples.iter().map(|s| s.residual.norm_squared()).sum();
    let overall_rms_mm = if samples.is_empty() {
        0.0
    } else {
        (total / samples.len() as f64).sqrt() * 1e3
    };
    LoadMetricsTable {
        rows,
        overall_rms_mm,
        count: samples.len(),
    }
}

impl fmt::Display for LoadMetricsTable {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{:>8} {:>5} {:>10} {:>14} {:>12} {:>12}",
            "load (N)", "n", "RMS (mm)", "max norm (mm)", "max |x| (mm)", "max |z| (mm)"
        )?;
        for r in &self.rows {
            writeln!(
                f,
                "{:>8.0} {:>5} {:>10.4} {:>14.4} {:>12.4} {:>12.4}",
                r.load_n, r.count, r.rms_mm, r.max_norm_mm, r.max_abs_x_mm, r.max_abs_z_mm
            )?;
        }
        write!(
            f,
            "{:>8} {:>5} {:>10.4}",
            "all", self.count, self.overall_rms_mm
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn metrics_match_hand_computation() {
        let s = |load, x, y, z| ResidualSample {
            load_n: load,
            residual: Vector3::new(x, y, z),
        };
        let samples = [
            s(300.0, 3e-6, 0.0, 4e-6),
            s(300.2, 0.0, 0.0, -1e-5),
            s(900.0, -2e-5, 0.0, 0.0),
        ];
        let t = per_load_metrics(&samples);
        assert_eq!(t.rows.len(), 2);
        let r = &t.rows[0];
        assert_eq!(r.count, 2);
        // norms 5 um and 10 um: RMS sqrt((25 + 100) / 2) um.
        assert!((r.rms_mm - (62.5f64).sqrt() * 1e-3).abs() < 1e-12);
        assert!((r.max_norm_mm - 0.01).abs() < 1e-12);
        assert!((r.max_abs_x_mm - 0.003).abs() < 1e-12);
        assert!((r.max_abs_z_mm - 0.01).abs() < 1e-12);
        assert!((t.rows[1].max_abs_x_mm - 0.02).abs() < 1e-12);
        assert!((t.overall_rms_mm - ((25.0 + 100.0 + 400.0) / 3.0f64).sqrt() * 1e-3).abs() < 1e-12);
        assert!(t.to_string().contains("all"));
    }

    #[test]
    fn empty_input_gives_empty_table() {
        let t = per_load_metrics(&[]);
        assert!(t.rows.is_empty());
        assert_eq!(t.overall_rms_mm, 0.0);
    }
}
