//! `flexcal.compensate_path`: compensation of a tool path given as arrays,
//! through the facade's compensation workflow (the paper's fake poses,
//! equations (39)-(41)).

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

use crate::arrays::{AllowTypeChange, PyArrayLikeDyn};
use flexcal::compensation::{
    CommandedPath as Commanded, CompensationSetup, ElasticSpec, ProcessSpec, compensate_path_file,
    default_start_joints, load_elastic,
};
use nalgebra::Vector6;
use numpy::PyArrayDyn;
use pyo3::prelude::*;

use crate::arrays::{exact, to_numpy};
use crate::errors::{FileError, InputError, facade_error};
use crate::interrupt::run_interruptible;
use crate::robot::{Robot, isometry_from_matrix};

/// The commanded path: one compensated point per target point (SI units).
#[pyclass(frozen, module = "flexcal", name = "CommandedPath")]
#[derive(Debug)]
pub struct CommandedPath {
    path: Arc<Commanded>,
    dof: usize,
}

#[pymethods]
impl CommandedPath {
    /// Commanded actuated coordinates, shape (n, dof), rad or m.
    #[getter]
    fn q<'py>(&self, py: Python<'py>) -> Bound<'py, PyArrayDyn<f64>> {
        let data = self
            .path
            .points
            .iter()
            .flat_map(|(_, p)| p.q_commanded.clone())
            .collect();
        to_numpy(py, data, &[self.path.points.len(), self.dof])
    }

    /// Commanded TCP poses in the base frame, shape (n, 4, 4), m.
    #[getter]
    fn poses<'py>(&self, py: Python<'py>) -> Bound<'py, PyArrayDyn<f64>> {
        let data = self
            .path
            .points
            .iter()
            .flat_map(|(_, p)| {
                p.commanded_base
                    .to_homogeneous()
                    .transpose()
                    .as_slice()
                    .to_vec()
            })
            .collect();
        to_numpy(py, data, &[self.path.points.len(), 4, 4])
    }

    /// Predicted pose error without compensation, shape (n, 6),
    /// [linear (m); angular (rad)] in the base frame.
    #[getter]
    fn predicted_error<'py>(&self, py: Python<'py>) -> Bound<'py, PyArrayDyn<f64>> {
        let data = self
            .path
            .points
            .iter()
            .flat_map(|(_, p)| p.uncompensated_error.as_slice().to_vec())
            .collect();
        to_numpy(py, data, &[self.path.points.len(), 6])
    }

    /// Remaining pose error after compensation, shape (n, 6), [m; rad].
    #[getter]
    fn residual<'py>(&self, py: Python<'py>) -> Bound<'py, PyArrayDyn<f64>> {
        let data = self
            .path
            .points
            .iter()
            .flat_map(|(_, p)| p.residual.as_slice().to_vec())
            .collect();
        to_numpy(py, data, &[self.path.points.len(), 6])
    }

    /// Iterations of the compensation of each point.
    #[getter]
    fn iterations(&self) -> Vec<usize> {
        self.path.points.iter().map(|(_, p)| p.iterations).collect()
    }

    /// Largest predicted position deviation without compensation (m).
    #[getter]
    fn max_predicted_deviation(&self) -> f64 {
        self.path.max_predicted_deviation_m()
    }

    /// Largest position residual after compensation (m).
    #[getter]
    fn max_residual(&self) -> f64 {
        self.path.max_residual_m()
    }

    /// The elastic and process models used, in words.
    #[getter]
    fn models(&self) -> (String, String) {
        (self.path.elastic.clone(), self.path.process.clone())
    }

    /// The commanded path as `flexcal compensate` writes it (CSV, mm).
    fn to_csv(&self) -> String {
        self.path.to_csv(self.dof)
    }

    /// The commanded path as a KRL program.
    fn to_krl(&self) -> PyResult<String> {
        self.path.to_krl().map_err(|e| facade_error(&e))
    }

    fn __len__(&self) -> usize {
        self.path.points.len()
    }
}

static TEMPORARY_FILES: AtomicUsize = AtomicUsize::new(0);

/// Compensates a tool path: `points` (n, 3) target positions in the part
/// frame (m; the tool z axis along -z of the part), `x_base_part` (4, 4)
/// the part frame in the robot base frame (m), `elastic` as the command
/// line names it (`fe:NAME|FILE` or `fuzzy:FILE`), `process` likewise
/// (`cantilever:LENGTH_MM,WIDTH_MM,THICKNESS_MM,MATERIAL` or `constant:FX,FY,FZ,MX,MY,MZ` in N and N.m), `payload`
/// (6,) the constant wrench on the tool in the base frame [N; N.m],
/// `start_joints` (dof,) the inverse model's start (default: mid-range),
/// `xi` the robot parameters (default: the robot's nominal values, which
/// are the identified ones for `CalibrationResult.robot`).
///
/// The points go to the facade's file workflow through a temporary CSV
/// (mm). Runs without the GIL; Ctrl-C returns at once.
#[pyfunction]
#[pyo3(signature = (robot, points, x_base_part, elastic, process, payload = None, start_joints = None, xi = None))]
#[allow(clippy::too_many_arguments)]
pub fn compensate_path<'py>(
    py: Python<'py>,
    robot: &Robot,
    points: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
    x_base_part: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
    elastic: &str,
    process: &str,
    payload: Option<PyArrayLikeDyn<'py, f64, AllowTypeChange>>,
    start_joints: Option<PyArrayLikeDyn<'py, f64, AllowTypeChange>>,
    xi: Option<PyArrayLikeDyn<'py, f64, AllowTypeChange>>,
) -> PyResult<CommandedPath> {
    let model = Arc::clone(&robot.model);
    let (points, shape) = exact("points", &points, &[None, Some(3)])?;
    if shape[0] == 0 {
        return Err(InputError::new_err("points: the path has no point"));
    }
    let (m, _) = exact("x_base_part", &x_base_part, &[Some(4), Some(4)])?;
    let x_base_part = isometry_from_matrix("x_base_part", &m)?;
    let payload_base = match payload {
        Some(p) => Vector6::from_column_slice(&exact("payload", &p, &[Some(6)])?.0),
        None => Vector6::zeros(),
    };
    let start_joints = match start_joints {
        Some(s) => exact("start_joints", &s, &[Some(model.n_actuated())])?.0,
        None => default_start_joints(&model),
    };
    let xi = match xi {
        Some(x) => exact("xi", &x, &[Some(model.n_params())])?.0,
        None => model.nominal_params().to_vec(),
    };
    let elastic: ElasticSpec = elastic.parse().map_err(|e| facade_error(&e))?;
    let process: ProcessSpec = process.parse().map_err(|e| facade_error(&e))?;
    let mut text = String::from("x_mm,y_mm,z_mm\n");
    for p in points.chunks(3) {
        text.push_str(&format!(
            "{:.9},{:.9},{:.9}\n",
            p[0] * 1e3,
            p[1] * 1e3,
            p[2] * 1e3
        ));
    }
    let file: PathBuf = std::env::temp_dir().join(format!(
        "flexcal-path-{}-{}.csv",
        std::process::id(),
        TEMPORARY_FILES.fetch_add(1, Ordering::Relaxed)
    ));
    std::fs::write(&file, text)
        .map_err(|e| FileError::new_err(format!("{}: {e}", file.display())))?;
    let setup = CompensationSetup {
        x_base_part,
        payload_base,
        start_joints,
    };
    let worker_model = Arc::clone(&model);
    let worker_file = file.clone();
    let result = run_interruptible(py, move || {
        let elastic_model = load_elastic(&elastic, &worker_model, &xi)?;
        let path = compensate_path_file(
            &worker_model,
            xi,
            elastic_model.as_ref(),
            process.as_process(),
            &setup,
            &worker_file,
        );
        let _ = std::fs::remove_file(&worker_file);
        Ok(path?)
    });
    if result.is_err() {
        let _ = std::fs::remove_file(&file);
    }
    Ok(CommandedPath {
        path: Arc::new(result?),
        dof: model.n_actuated(),
    })
}
