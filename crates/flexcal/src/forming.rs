//! The forming experiment of the reference paper (section 4, Figure 17) on
//! the virtual IR-663, from the files a user has: a 920 N tool plunges
//! 25 mm into a clamped Al-5005 beam and travels 200 mm, commanded without
//! compensation and with each elastic model given (`flexcal twin forming`).
//!
//! The twin's truth (its own robot, beam, contact and weight) plays the
//! robot; the user's side has the calibrated geometry, the identified
//! models and the part located by the camera, never the truth.

use std::path::{Path, PathBuf};

use flexcal_compensate::compensation::DynTcpDeflection;
use flexcal_compensate::path::{PathPoint, target_path_to_csv};
use flexcal_elastic::description::ElasticDescription;
use flexcal_elastic::fuzzy_compliance::{FuzzyCompliance, RobotFuzzyCompliance};
use flexcal_elastic::model::ElasticModel;
use flexcal_elastic::tcp::FeTcpModel;
use flexcal_elastic::workflow::StiffnessReport;
use flexcal_twin::forming::{FormingOptions, FormingResult, TwinCell, forming_path, run_forming};
use flexcal_twin::truth::TruthSwitches;

use crate::{Error, Result};

/// The user's files of a forming experiment.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FormingConfig {
    /// Seed of the measurement noise (default 17).
    pub seed: u64,
    /// Calibrated robot description (`flexcal calibrate --out`) whose xi
    /// commands the robot; none: the nominal xi.
    pub calibrated: Option<PathBuf>,
    /// The calibration's report (`flexcal calibrate --report`): its
    /// identified measurement frame carries the part, located by the
    /// camera, into the calibrated robot's base; none: the part's pose in
    /// the base is taken as known exactly.
    pub calibration_report: Option<PathBuf>,
    /// Stiffness report (`flexcal identify stiffness --report`) whose Gamma
    /// the FE beam model uses; none: the nominal Gamma.
    pub fe_report: Option<PathBuf>,
    /// Fuzzy compliance model (`flexcal identify compliance --out`) to
    /// compensate with too.
    pub fuzzy: Option<PathBuf>,
}

impl Default for FormingConfig {
    fn default() -> Self {
        Self {
            seed: FormingOptions::default().seed,
            calibrated: None,
            calibration_report: None,
            fe_report: None,
            fuzzy: None,
        }
    }
}

/// A forming experiment: its target path and what the twin measured.
#[derive(Debug, Clone, PartialEq)]
pub struct FormingExperiment {
    /// The target path in the part frame.
    pub target_path: Vec<PathPoint>,
    /// The measured paths: uncompensated, then one per elastic model (the
    /// fuzzy model first when given, then the FE beam model).
    pub result: FormingResult,
}

impl FormingExperiment {
    /// The files [`FormingExperiment::write`] writes, in order.
    pub const FILES: [&'static str; 3] = [
        "target_path.csv",
        "forming_result.json",
        "forming_paths.csv",
    ];

    /// Writes the target path (`target_path.csv`), the result
    /// (`forming_result.json`) and the data of Figure 17
    /// (`forming_paths.csv`, [`FormingResult::paths_csv`]) into `dir`
    /// (created if missing), each atomically.
    ///
    /// # Errors
    /// The file that could not be written.
    pub fn write(&self, dir: &Path) -> Result<()> {
        let json = serde_json::to_string_pretty(&self.result).map_err(|source| Error::Json {
            context: "forming result".into(),
            source,
        })?;
        let texts = [
            target_path_to_csv(&self.target_path),
            json + "\n",
            self.result.paths_csv(),
        ];
        for (name, text) in Self::FILES.iter().zip(texts) {
            flexcal_io::write_atomic(dir.join(name), text)?;
        }
        Ok(())
    }
}

impl FormingExperiment {
    /// What `flexcal twin forming` prints once [`FormingExperiment::write`]
    /// has written into `dir`: the largest |deviation along z_p| (mm)
    /// uncompensated and with each model, then the files and the paths'
    /// numbers in `forming_paths.csv`; `seed` is the measurement noise's.
    pub fn summary_text(&self, seed: u64, dir: &Path) -> String {
        let result = &self.result;
        let mut text = format!(
            "virtual IR-663 forming (seed {seed}): max |deviation along z_p| {:.3} mm uncompensated\n",
            result.uncompensated.max_abs_deviation_z_mm
        );
        for c in &result.compensated {
            text += &format!("  {}: {:.3} mm\n", c.label, c.max_abs_deviation_z_mm);
        }
        let labels: Vec<String> = result
            .paths()
            .enumerate()
            .map(|(p, path)| format!("{p}: {}", path.label))
            .collect();
        text + &format!(
            "target_path.csv, forming_result.json and forming_paths.csv (paths {}) written to {}\n",
            labels.join("; "),
            dir.display()
        )
    }
}

/// Runs the forming experiment on the virtual IR-663 with the user's files.
///
/// # Errors
/// An unreadable or mismatched file (calibrated robot, reports, fuzzy
/// model), named; a path point that cannot be commanded.
pub fn run_forming_experiment(config: &FormingConfig) -> Result<FormingExperiment> {
    let robot = crate::load_robot("ir663")?;
    let twin = TwinCell::new(TruthSwitches::default())?;
    let xi = crate::compensation::calibrated_xi(&robot, config.calibrated.as_deref())?;
    // The FE model the user would have: the built-in description, not the twin's truth.
    let description = ElasticDescription::builtin("ir663")?;
    let fe_model = ElasticModel::new(&robot, &description)?;
    let (gamma, origin) = match &config.fe_report {
        Some(path) => (
            StiffnessReport::read(path)?.gamma_for(&fe_model, path)?,
            "identified Gamma",
        ),
        None => (fe_model.nominal_gamma(), "nominal Gamma"),
    };
    let fe_label = format!("compensated, FE beam model ({origin})");
    let fe = FeTcpModel::new(fe_model, xi.clone(), gamma, fe_label.clone())?;
    let fuzzy = match &config.fuzzy {
        Some(path) => Some(RobotFuzzyCompliance::new(
            FuzzyCompliance::read(path)?,
            robot.clone(),
        )?),
        None => None,
    };
    let mut models: Vec<(&str, &dyn DynTcpDeflection)> = Vec::new();
    if let Some(f) = &fuzzy {
        models.push(("compensated, fuzzy model", f));
    }
    models.push((&fe_label, &fe));
    let defaults = FormingOptions::default();
    let x_base_part_user = match &config.calibration_report {
        Some(path) => Some(twin.part_located_by_camera(
            &defaults.x_base_part,
            &flexcal_calib::read_measurement_frame(path)?,
        )),
        None => None,
    };
    let options = FormingOptions {
        seed: config.seed,
        x_base_part_user,
        ..defaults
    };
    let result = run_forming(&twin, &xi, &models, &options)?;
    Ok(FormingExperiment {
        target_path: forming_path(&options),
        result,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_experiment_writes_the_measured_paths_of_figure_17() {
        let experiment = run_forming_experiment(&FormingConfig::default()).unwrap();
        let result = &experiment.result;
        assert_eq!(result.compensated.len(), 1, "the FE beam model only");
        assert_eq!(result.target_mm.len(), experiment.target_path.len());
        let dir = tempfile::tempdir().unwrap();
        experiment.write(dir.path()).unwrap();
        let table = flexcal_io::CsvTable::read(
            dir.path().join("forming_paths.csv"),
            &flexcal_io::CsvOptions::default(),
        )
        .unwrap();
        let n = result.target_mm.len();
        assert_eq!(table.len(), 2 * n);
        // Row (path 1, point k): the compensated path's measured z is the
        // target's plus its deviation.
        let k = n / 2;
        let z_measured = table.column_f64("z_measured_mm").unwrap()[n + k];
        let expected = result.target_mm[k].1 + result.compensated[0].deviation_z_mm[k];
        assert!((z_measured - expected).abs() < 1e-12);
        let json = std::fs::read_to_string(dir.path().join("forming_result.json")).unwrap();
        let value: serde_json::Value = serde_json::from_str(&json).unwrap();
        assert_eq!(
            value["uncompensated"]["max_abs_deviation_z_mm"].as_f64(),
            Some(result.uncompensated.max_abs_deviation_z_mm)
        );
        // The summary: the uncompensated deviation, one line per model,
        // then the files with the paths' numbers.
        let text = experiment.summary_text(17, dir.path());
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 2 + result.compensated.len(), "{text}");
        assert!(
            lines[0].starts_with("virtual IR-663 forming (seed 17): max |deviation along z_p| ")
        );
        assert!(
            lines[1].starts_with("  compensated, FE beam model (nominal Gamma): "),
            "{text}"
        );
        assert!(lines[2].contains("(paths 0: "), "{text}");
        assert!(lines[2].ends_with(&format!("written to {}", dir.path().display())));
    }
}
