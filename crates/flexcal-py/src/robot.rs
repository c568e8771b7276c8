//! `flexcal.Robot`: a validated robot model, its forward and inverse
//! models and Jacobians on NumPy arrays.

use std::path::PathBuf;
use std::sync::Arc;

use crate::arrays::{AllowTypeChange, PyArrayLikeDyn};
use flexcal::kinematics::{
    Data, ImportedRobot, InverseOptions, InverseTarget, KinematicsError as KinError, Model,
    ParamKind, RobotDescription, SerialChain, builtin_robot_names, forward_frame_pose,
    forward_pose, inverse_pose, joint_jacobian_into, param_jacobian_into,
};
use nalgebra::{DMatrix, Isometry3, Matrix3, Matrix6xX, Rotation3, Translation3, UnitQuaternion};
use numpy::{PyArrayDyn, PyArrayMethods};
use pyo3::prelude::*;

use crate::arrays::{Rows, exact, rows, to_numpy};
use crate::errors::{Failure, InputError, kinematics_error};
use crate::interrupt::{run_detached, run_here};

/// Configurations per batch between two checks for Ctrl-C.
const BATCH_ROWS: usize = 16_384;
/// Below this many configurations a call uses one thread.
const PARALLEL_MIN_ROWS: usize = 2_048;

/// One entry of the parameter vector xi of a robot.
#[pyclass(frozen, module = "flexcal", name = "Parameter", get_all)]
#[derive(Debug, Clone)]
pub struct Parameter {
    /// Name (`d3`, `alpha2`, `beta3`, `theta1`, ...).
    pub name: String,
    /// SI unit of the value: `m` or `rad`.
    pub unit: &'static str,
    /// Nominal value (m or rad).
    pub nominal: f64,
    /// The frame owning the parameter.
    pub frame: String,
    /// Position of the parameter in xi.
    pub index: usize,
}

#[pymethods]
impl Parameter {
    fn __repr__(&self) -> String {
        format!(
            "Parameter(name={:?}, unit={:?}, nominal={}, frame={:?}, index={})",
            self.name, self.unit, self.nominal, self.frame, self.index
        )
    }
}

/// A robot model (validated once, then frozen): built-in, or read from a
/// description file. Arrays are in SI units: joint coordinates in rad
/// (revolute) or m (prismatic, screw), lengths in m, angles in rad.
#[pyclass(frozen, module = "flexcal", name = "Robot")]
#[derive(Debug, Clone)]
pub struct Robot {
    pub(crate) model: Arc<Model>,
}

impl Robot {
    pub(crate) fn new(model: Model) -> Self {
        Self {
            model: Arc::new(model),
        }
    }

    fn xi(&self, xi: Option<PyArrayLikeDyn<'_, f64, AllowTypeChange>>) -> PyResult<Vec<f64>> {
        match xi {
            None => Ok(self.model.nominal_params().to_vec()),
            Some(xi) => Ok(exact("xi", &xi, &[Some(self.model.n_params())])?.0),
        }
    }

    fn configurations<'a>(
        &self,
        q: &'a PyArrayLikeDyn<'_, f64, AllowTypeChange>,
    ) -> PyResult<Rows<'a>> {
        rows("q", q, self.model.n_actuated())
    }

    /// A 6 x `columns` Jacobian per configuration of `q` at `xi` (nominal
    /// when None), `per_row` writing one row-major into its output slice;
    /// shape (6, columns) or (n, 6, columns).
    fn jacobians<'py, F>(
        &self,
        py: Python<'py>,
        q: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
        xi: Option<PyArrayLikeDyn<'py, f64, AllowTypeChange>>,
        threads: Option<usize>,
        columns: usize,
        per_row: F,
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>>
    where
        F: Fn(&Model, &mut Data, &[f64], &[f64], &mut [f64]) -> Result<(), KinError> + Sync,
    {
        let q = self.configurations(&q)?;
        let xi = self.xi(xi)?;
        let out = batched(py, &self.model, &q, 6 * columns, threads, |m, d, q, out| {
            per_row(m, d, q, &xi, out)
        })?;
        Ok(to_numpy(py, out, &shape(&q, &[6, columns])))
    }
}

/// Evaluates `per_row` on every row of `q`, writing `width` values per row,
/// through [`batched_into`], each thread with its own [`Data`].
fn batched<F>(
    py: Python<'_>,
    model: &Model,
    q: &Rows,
    width: usize,
    threads: Option<usize>,
    per_row: F,
) -> PyResult<Vec<f64>>
where
    F: Fn(&Model, &mut Data, &[f64], &mut [f64]) -> Result<(), KinError> + Sync,
{
    let mut out = vec![0.0; q.n * width];
    batched_into(py, q.n, width, threads, &mut out, |first_row, part| {
        run_rows(model, q, first_row, part, width, &per_row)
    })?;
    Ok(out)
}

/// Fills `out`, `n` rows of `width` values, with `per_rows(first_row,
/// part)`, `part` being the rows from `first_row` on: in batches of
/// [`BATCH_ROWS`] rows without the GIL (checking for Ctrl-C between
/// batches), each split over up to `threads` threads.
fn batched_into<F>(
    py: Python<'_>,
    n: usize,
    width: usize,
    threads: Option<usize>,
    out: &mut [f64],
    per_rows: F,
) -> PyResult<()>
where
    F: Fn(usize, &mut [f64]) -> Result<(), Failure> + Sync,
{
    let threads = match threads {
        Some(0) => return Err(InputError::new_err("threads: must be at least 1")),
        Some(t) => t,
        None => std::thread::available_parallelism().map_or(1, |n| n.get()),
    };
    if n <= PARALLEL_MIN_ROWS.min(BATCH_ROWS) / 8 {
        // Small batches: the GIL round trip would cost more than the work.
        return run_here(|| per_rows(0, out));
    }
    let mut start = 0;
    for chunk in out.chunks_mut(BATCH_ROWS * width) {
        let rows_here = chunk.len() / width;
        let workers = if rows_here < PARALLEL_MIN_ROWS {
            1
        } else {
            threads.min(rows_here / (PARALLEL_MIN_ROWS / 2)).max(1)
        };
        run_detached(py, || {
            if workers == 1 {
                return per_rows(start, chunk);
            }
            let per_worker = rows_here.div_ceil(workers);
            std::thread::scope(|scope| {
                let handles: Vec<_> = chunk
                    .chunks_mut(per_worker * width)
                    .enumerate()
                    .map(|(w, part)| {
                        let per_rows = &per_rows;
                        scope.spawn(move || per_rows(start + w * per_worker, part))
                    })
                    .collect();
                handles.into_iter().try_for_each(|h| {
                    h.join().unwrap_or_else(|payload| {
                        Err(Failure::Panic(crate::errors::panic_message(payload)))
                    })
                })
            })
        })?;
        py.check_signals()?;
        start += rows_here;
    }
    Ok(())
}

fn run_rows<F>(
    model: &Model,
    q: &Rows,
    first_row: usize,
    out: &mut [f64],
    width: usize,
    per_row: &F,
) -> Result<(), Failure>
where
    F: Fn(&Model, &mut Data, &[f64], &mut [f64]) -> Result<(), KinError>,
{
    let mut data = Data::new(model);
    for (k, values) in out.chunks_mut(width).enumerate() {
        let row = first_row + k;
        per_row(model, &mut data, q.row(row), values).map_err(|e| Failure::KinematicsAt(row, e))?;
    }
    Ok(())
}

fn write_pose(x: &Isometry3<f64>, out: &mut [f64]) {
    out[..3].copy_from_slice(x.translation.vector.as_slice());
    // [x, y, z, w], scalar last (SciPy's Rotation.from_quat order).
    out[3..7].copy_from_slice(x.rotation.coords.as_slice());
}

/// Output shape: `tail` with a leading `n` when the input was batched.
fn shape(q: &Rows, tail: &[usize]) -> Vec<usize> {
    let mut s = Vec::with_capacity(tail.len() + 1);
    if q.batched {
        s.push(q.n);
    }
    s.extend_from_slice(tail);
    s
}

/// A homogeneous 4 x 4 matrix (rotation part orthonormal to 1e-6) as a pose.
pub(crate) fn isometry_from_matrix(name: &str, m: &[f64]) -> PyResult<Isometry3<f64>> {
    let bottom = [m[12], m[13], m[14], m[15]];
    let r = Matrix3::new(m[0], m[1], m[2], m[4], m[5], m[6], m[8], m[9], m[10]);
    let orthonormal = (r.transpose() * r - Matrix3::identity()).abs().max() < 1e-6
        && (r.determinant() - 1.0).abs() < 1e-6;
    if bottom != [0.0, 0.0, 0.0, 1.0] || !orthonormal {
        return Err(InputError::new_err(format!(
            "{name}: not a rigid transform (the rotation part must be orthonormal with determinant 1 to 1e-6 and the last row [0, 0, 0, 1])"
        )));
    }
    let rotation = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r));
    Ok(Isometry3::from_parts(
        Translation3::new(m[3], m[7], m[11]),
        rotation,
    ))
}

impl Robot {
    /// A robot file read by the facade's rule with import options.
    fn from_robot_file(
        path: &std::path::Path,
        options: flexcal::kinematics::ImportOptions,
    ) -> PyResult<Self> {
        let spec = flexcal::RobotSpec::File(path.to_path_buf());
        let model = spec
            .model_with(&options)
            .map_err(|e| crate::errors::facade_error(&e))?;
        Ok(Self::new(model))
    }
}

#[pymethods]
impl Robot {
    /// A built-in robot by name (`ur10`, `ir663`, `puma560`; see
    /// `Robot.builtin_names()`). Raises `UnknownRobotError` for another name.
    #[staticmethod]
    fn builtin(name: &str) -> PyResult<Self> {
        let model = RobotDescription::builtin(name)
            .and_then(|d| d.build())
            .map_err(|e| kinematics_error(&e))?;
        Ok(Self::new(model))
    }

    /// A robot by the command line's rule: a built-in name is that robot,
    /// anything else a description file read by the format its extension
    /// selects. Raises `UnknownRobotError` when `spec` is neither.
    ///
    /// `tip`: the tip link of a URDF, or the frame or link a TOML or
    /// built-in robot's TCP moves to (an unknown name raises
    /// `KinematicsError` naming the frames there are); `root`: a URDF's
    /// root link (refused for other robots); `values`: the symbol values of
    /// a `.par` file (TOML, SI units).
    #[staticmethod]
    #[pyo3(signature = (spec, tip = None, root = None, values = None))]
    fn load(
        spec: &str,
        tip: Option<String>,
        root: Option<String>,
        values: Option<PathBuf>,
    ) -> PyResult<Self> {
        let options = flexcal::kinematics::ImportOptions { tip, root, values };
        let model = flexcal::load_robot_with(spec, &options)
            .map_err(|e| crate::errors::facade_error(&e))?;
        Ok(Self::new(model))
    }

    /// A robot from URDF text (see `from_urdf`); `source` names it in
    /// messages. Malformed text raises `FileError` with its line.
    #[staticmethod]
    #[pyo3(signature = (text, tip = None, root = None, source = "<string>"))]
    fn from_urdf_string(
        text: &str,
        tip: Option<String>,
        root: Option<String>,
        source: &str,
    ) -> PyResult<Self> {
        let options = flexcal::kinematics::ImportOptions {
            tip,
            root,
            values: None,
        };
        let model = flexcal::kinematics::urdf::UrdfRobot::parse(text, source)
            .and_then(|robot| ImportedRobot::from_urdf(&robot, &options))
            .and_then(|imported| imported.description.build())
            .map_err(|e| kinematics_error(&e))?;
        Ok(Self::new(model))
    }

    /// Every name `fk(frame=...)` takes: `"0"` (the base frame), the
    /// robot's frames (`"1"`..`"n"` for an imported URDF or `.par`), then
    /// the links attached to them (a URDF's link names: `"wrist_2_link"`,
    /// `"tool0"`).
    #[getter]
    fn frame_names(&self) -> Vec<String> {
        self.model.named_frames()
    }

    /// A robot from a URDF file: the path from `root` (default: the root of
    /// the tree) to `tip` (default: the single leaf below the root), as a
    /// Khalil-Kleinfinger model that reproduces the file's poses. Raises
    /// `FlexcalError` naming the file and line of a malformed file, or the
    /// candidate tips when the tree has several leaves.
    #[staticmethod]
    #[pyo3(signature = (path, tip = None, root = None))]
    fn from_urdf(path: PathBuf, tip: Option<String>, root: Option<String>) -> PyResult<Self> {
        Self::from_robot_file(
            &path,
            flexcal::kinematics::ImportOptions {
                tip,
                root,
                values: None,
            },
        )
    }

    /// A robot from a SYMORO `.par` file, its symbols' values read from the
    /// TOML file `values` (SI units).
    #[staticmethod]
    #[pyo3(signature = (path, values = None))]
    fn from_par(path: PathBuf, values: Option<PathBuf>) -> PyResult<Self> {
        Self::from_robot_file(
            &path,
            flexcal::kinematics::ImportOptions {
                tip: None,
                root: None,
                values,
            },
        )
    }

    /// Names of the built-in robots.
    #[staticmethod]
    fn builtin_names() -> Vec<&'static str> {
        builtin_robot_names().to_vec()
    }

    /// A robot from a description file (TOML, lengths in mm and angles in
    /// degrees in fields named with their unit).
    #[staticmethod]
    fn from_toml(path: PathBuf) -> PyResult<Self> {
        let model = RobotDescription::from_toml_file(&path)
            .and_then(|d| d.build())
            .map_err(|e| kinematics_error(&e))?;
        Ok(Self::new(model))
    }

    /// A robot from description text (TOML, mm and degrees); `source`
    /// names it in messages.
    #[staticmethod]
    #[pyo3(signature = (text, source = "<string>"))]
    fn from_toml_string(text: &str, source: &str) -> PyResult<Self> {
        let model = RobotDescription::from_toml_str(text, source)
            .and_then(|d| d.build())
            .map_err(|e| kinematics_error(&e))?;
        Ok(Self::new(model))
    }

    /// The description as TOML text (mm, degrees), with the current
    /// nominal values (a calibrated robot writes its identified values).
    fn to_toml(&self) -> PyResult<String> {
        let d = self
            .model
            .description_with_params(self.model.nominal_params())
            .map_err(|e| kinematics_error(&e))?;
        Ok(d.to_toml_string())
    }

    /// The robot's name.
    #[getter]
    fn name(&self) -> String {
        self.model.name().to_string()
    }

    /// Number of actuated coordinates (the length of q).
    #[getter]
    fn dof(&self) -> usize {
        self.model.n_actuated()
    }

    /// Names of the actuated coordinates, in the order of q.
    #[getter]
    fn joint_names(&self) -> Vec<String> {
        self.model.actuated_names().to_vec()
    }

    /// Limits of the actuated coordinates, shape (dof, 2): [lower, upper]
    /// in rad or m.
    #[getter]
    fn joint_limits<'py>(&self, py: Python<'py>) -> Bound<'py, PyArrayDyn<f64>> {
        let data = self
            .model
            .actuated_limits()
            .iter()
            .flat_map(|&(lo, hi)| [lo, hi])
            .collect();
        to_numpy(py, data, &[self.model.n_actuated(), 2])
    }

    /// The parameters of xi (name, SI unit, nominal value, frame, index).
    #[getter]
    fn parameters(&self) -> Vec<Parameter> {
        self.model
            .params()
            .iter()
            .zip(self.model.nominal_params())
            .enumerate()
            .map(|(index, (p, &nominal))| Parameter {
                name: p.name.clone(),
                unit: match p.kind {
                    ParamKind::Length => "m",
                    ParamKind::Angle => "rad",
                },
                nominal,
                frame: p.frame.clone(),
                index,
            })
            .collect()
    }

    /// Names of the parameters, in the order of xi.
    #[getter]
    fn parameter_names(&self) -> Vec<String> {
        self.model.params().iter().map(|p| p.name.clone()).collect()
    }

    /// The nominal parameter vector xi (m, rad), shape (n_params,).
    #[getter]
    fn nominal<'py>(&self, py: Python<'py>) -> Bound<'py, PyArrayDyn<f64>> {
        to_numpy(
            py,
            self.model.nominal_params().to_vec(),
            &[self.model.n_params()],
        )
    }

    /// Forward model: the TCP pose in the robot base frame for one
    /// configuration q of shape (dof,) or many of shape (n, dof) (rad, m).
    ///
    /// `output="matrix"` returns homogeneous matrices, shape (4, 4) or
    /// (n, 4, 4), translation in m; `output="pose"` returns a tuple
    /// (positions (n, 3) in m, quaternions (n, 4) in the order `quaternion`
    /// names: `"xyzw"` (default, SciPy's `Rotation.from_quat`) or `"wxyz"`
    /// (flexcal's files, the CLI's pose files and the JSON reports).
    /// `xi` (n_params,) replaces the nominal parameters (m, rad). `frame`
    /// names a frame or link of the robot (any of `frame_names`: a hand of a
    /// two-armed robot, a URDF link such as `"wrist_2_link"`) whose pose is
    /// returned instead of the TCP's (no tool transform). Batches run
    /// without the GIL on up to `threads` threads (default: all cores),
    /// and Ctrl-C interrupts them between batches of 16 384.
    #[pyo3(signature = (q, xi = None, output = "matrix", threads = None, frame = None, quaternion = "xyzw"))]
    #[allow(clippy::too_many_arguments)]
    fn fk<'py>(
        &self,
        py: Python<'py>,
        q: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
        xi: Option<PyArrayLikeDyn<'py, f64, AllowTypeChange>>,
        output: &str,
        threads: Option<usize>,
        frame: Option<&str>,
        quaternion: &str,
    ) -> PyResult<Py<PyAny>> {
        // Where the scalar part goes: last (x, y, z, w) or first (w, x, y, z).
        let scalar_first = match quaternion {
            "xyzw" => false,
            "wxyz" => true,
            other => {
                return Err(InputError::new_err(format!(
                    "quaternion: expected \"xyzw\" or \"wxyz\", got {other:?}"
                )));
            }
        };
        let q = self.configurations(&q)?;
        let xi = self.xi(xi)?;
        let frame = frame
            .map(|name| {
                self.model
                    .locate(name)
                    .map_err(|e| InputError::new_err(format!("frame: {e}")))
            })
            .transpose()?;
        // A serial chain takes the precomputed path to the TCP; other robots
        // (closed loops, couplings on the TCP path) and other frames the
        // general forward model.
        let chain = match frame {
            Some(_) => None,
            None => SerialChain::new(&self.model, &xi).ok(),
        };
        let pose_at = |m: &Model, d: &mut Data, q: &[f64]| match (&chain, frame) {
            (Some(chain), _) => chain.pose(q),
            (None, Some((Some(f), x_frame_place))) => {
                forward_frame_pose(m, d, q, &xi, f, &x_frame_place)
            }
            // A place on the base does not move.
            (None, Some((None, x_base_place))) => Ok(x_base_place),
            (None, None) => forward_pose(m, d, q, &xi),
        };
        match output {
            "matrix" if chain.is_some() => {
                // The batch kernel, four configurations at a time, straight
                // into the NumPy array's memory.
                let chain = chain.as_ref().expect("checked by the guard");
                let array = PyArrayDyn::<f64>::zeros(py, shape(&q, &[4, 4]), false);
                {
                    let mut matrices = array.readwrite();
                    let out = matrices.as_slice_mut()?;
                    let width = q.width;
                    batched_into(py, q.n, 16, threads, out, |first_row, part| {
                        let rows =
                            &q.data[first_row * width..(first_row + part.len() / 16) * width];
                        // q was checked finite: no error is expected here.
                        chain.matrices_into(rows, part).map_err(Failure::from)
                    })?;
                }
                Ok(array.into_any().unbind())
            }
            "matrix" => {
                let out = batched(py, &self.model, &q, 16, threads, |m, d, q, out| {
                    let x = pose_at(m, d, q)?.to_homogeneous();
                    // nalgebra stores column-major; NumPy wants rows.
                    out.copy_from_slice(x.transpose().as_slice());
                    Ok(())
                })?;
                Ok(to_numpy(py, out, &shape(&q, &[4, 4])).into_any().unbind())
            }
            "pose" => {
                let out = batched(py, &self.model, &q, 7, threads, |m, d, q, out| {
                    write_pose(&pose_at(m, d, q)?, out);
                    Ok(())
                })?;
                let positions = out.chunks(7).flat_map(|r| r[..3].iter().copied()).collect();
                // write_pose gives [x, y, z, w].
                let quaternions = out
                    .chunks(7)
                    .flat_map(|r| {
                        let v = [r[3], r[4], r[5], r[6]];
                        if scalar_first {
                            [v[3], v[0], v[1], v[2]]
                        } else {
                            v
                        }
                    })
                    .collect();
                let p = to_numpy(py, positions, &shape(&q, &[3]));
                let r = to_numpy(py, quaternions, &shape(&q, &[4]));
                Ok((p, r).into_pyobject(py)?.into_any().unbind())
            }
            other => Err(InputError::new_err(format!(
                "output: expected \"matrix\" or \"pose\", got {other:?}"
            ))),
        }
    }

    /// Joint Jacobian d[p_tcp; phi]/dq: rows [linear (m/unit of q); angular
    /// (rad/unit of q)] in the base frame, the linear part at the TCP; shape
    /// (6, dof) or (n, 6, dof) for q of shape (dof,) or (n, dof).
    #[pyo3(signature = (q, xi = None, threads = None))]
    fn jacobian<'py>(
        &self,
        py: Python<'py>,
        q: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
        xi: Option<PyArrayLikeDyn<'py, f64, AllowTypeChange>>,
        threads: Option<usize>,
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        let na = self.model.n_actuated();
        self.jacobians(py, q, xi, threads, na, |m, d, q, xi, out| {
            let mut jac = Matrix6xX::zeros(na);
            joint_jacobian_into(m, d, q, xi, &mut jac)?;
            write_row_major(jac.as_slice(), 6, na, out);
            Ok(())
        })
    }

    /// Parameter Jacobian d[p_tcp; phi]/dxi (equations (49)-(52) of Marie,
    /// Courteille, Maurine 2013): rows [linear; angular] in the base frame,
    /// the linear part at the TCP, columns in the order of `parameters`
    /// (m/m, m/rad, rad/m, rad/rad); shape (6, n_params) or (n, 6, n_params).
    #[pyo3(signature = (q, xi = None, threads = None))]
    fn parameter_jacobian<'py>(
        &self,
        py: Python<'py>,
        q: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
        xi: Option<PyArrayLikeDyn<'py, f64, AllowTypeChange>>,
        threads: Option<usize>,
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        let np = self.model.n_params();
        self.jacobians(py, q, xi, threads, np, |m, d, q, xi, out| {
            let mut jac = DMatrix::zeros(6, np);
            param_jacobian_into(m, d, q, xi, &mut jac)?;
            write_row_major(jac.as_slice(), 6, np, out);
            Ok(())
        })
    }

    /// Inverse model: the actuated coordinates (dof,) that bring the TCP to
    /// `pose` (4 x 4 homogeneous matrix in the base frame, m), by damped
    /// least squares within the joint limits from `seed` (dof,) (the
    /// solution nearest the seed). `target="position-and-tool-axis"` leaves
    /// the rotation about the tool z axis free. Tolerances in m and rad.
    /// Raises `UnreachableError` when no configuration within the limits
    /// reaches the tolerances.
    #[pyo3(signature = (pose, seed, xi = None, target = "pose", max_iterations = 200, position_tolerance = 1e-11, orientation_tolerance = 1e-11))]
    #[allow(clippy::too_many_arguments)]
    fn ik<'py>(
        &self,
        py: Python<'py>,
        pose: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
        seed: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
        xi: Option<PyArrayLikeDyn<'py, f64, AllowTypeChange>>,
        target: &str,
        max_iterations: usize,
        position_tolerance: f64,
        orientation_tolerance: f64,
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        let (m, _) = exact("pose", &pose, &[Some(4), Some(4)])?;
        let x = isometry_from_matrix("pose", &m)?;
        let (seed, _) = exact("seed", &seed, &[Some(self.model.n_actuated())])?;
        let xi = self.xi(xi)?;
        let target = match target {
            "pose" => InverseTarget::Pose,
            "position-and-tool-axis" => InverseTarget::PositionAndToolAxis,
            other => {
                return Err(InputError::new_err(format!(
                    "target: expected \"pose\" or \"position-and-tool-axis\", got {other:?}"
                )));
            }
        };
        for (name, v) in [
            ("position_tolerance", position_tolerance),
            ("orientation_tolerance", orientation_tolerance),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(InputError::new_err(format!(
                    "{name}: must be finite and > 0, got {v}"
                )));
            }
        }
        let options = InverseOptions {
            target,
            max_iterations,
            position_tolerance,
            orientation_tolerance,
            ..InverseOptions::default()
        };
        let model = &self.model;
        let q = run_detached(py, || {
            let mut data = Data::new(model);
            Ok(inverse_pose(model, &mut data, &x, &seed, &xi, &options)?.q)
        })?;
        let n = q.len();
        Ok(to_numpy(py, q, &[n]))
    }

    fn __repr__(&self) -> String {
        format!(
            "Robot(name={:?}, dof={}, n_params={})",
            self.model.name(),
            self.model.n_actuated(),
            self.model.n_params()
        )
    }
}

/// Column-major `rows x cols` (nalgebra) into row-major `out`.
fn write_row_major(column_major: &[f64], rows: usize, cols: usize, out: &mut [f64]) {
    for c in 0..cols {
        for r in 0..rows {
            out[r * cols + c] = column_major[c * rows + r];
        }
    }
}
