//! `flexcal.Structure`: frame finite-element structures (beams, joints,
//! springs) read from a file, solved and condensed onto a node
//! (equations (24)-(27) of Marie, Courteille, Maurine 2013).

use std::path::PathBuf;
use std::sync::Arc;

use flexcal::fem::FemModel;
use numpy::PyArrayDyn;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::arrays::to_numpy;
use crate::interrupt::run_interruptible;

/// A frame structure with its load cases.
#[pyclass(frozen, module = "flexcal", name = "Structure")]
#[derive(Debug, Clone)]
pub struct Structure {
    model: Arc<FemModel>,
}

fn matrix6<'py>(py: Python<'py>, m: &nalgebra::Matrix6<f64>) -> Bound<'py, PyArrayDyn<f64>> {
    to_numpy(py, m.transpose().as_slice().to_vec(), &[6, 6])
}

#[pymethods]
impl Structure {
    /// Reads a structure file (TOML or JSON; mm are not used here: the
    /// file format's fields carry their units).
    #[staticmethod]
    fn from_file(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let model = run_interruptible(py, move || Ok(FemModel::read(&path)?))?;
        Ok(Self {
            model: Arc::new(model),
        })
    }

    /// Node names, in the order of the rows of `solve()`'s arrays.
    #[getter]
    fn node_names(&self) -> Vec<String> {
        self.model.structure.node_names().to_vec()
    }

    /// Load case names.
    #[getter]
    fn load_cases(&self) -> Vec<String> {
        self.model
            .load_cases
            .iter()
            .map(|c| c.name.clone())
            .collect()
    }

    /// Solves every load case: a dict from case name to the displacements
    /// of every node, shape (n_nodes, 6), [ux, uy, uz (m), rx, ry, rz (rad)]
    /// in global axes. Runs without the GIL.
    fn solve<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let model = Arc::clone(&self.model);
        let cases = run_interruptible(py, move || Ok(model.solve()?))?;
        let d = PyDict::new(py);
        for case in cases {
            let n = case.nodes.len();
            let data = case
                .nodes
                .iter()
                .flat_map(|u| u.iter().copied().collect::<Vec<_>>())
                .collect();
            d.set_item(case.name, to_numpy(py, data, &[n, 6]))?;
        }
        Ok(d)
    }

    /// Condenses the structure onto `node`: a dict with `k_eq` (6 x 6
    /// equivalent stiffness, [linear; angular], N/m, N/rad, N.m/m, N.m/rad),
    /// `c_eq` (its inverse) and `f_eq` (case name -> equivalent wrench
    /// (6,), N and N.m). Runs without the GIL.
    fn condense<'py>(&self, py: Python<'py>, node: String) -> PyResult<Bound<'py, PyDict>> {
        let model = Arc::clone(&self.model);
        let c = run_interruptible(py, move || Ok(model.condense(&node)?))?;
        let d = PyDict::new(py);
        d.set_item("k_eq", matrix6(py, &c.k_eq))?;
        d.set_item("c_eq", matrix6(py, &c.c_eq))?;
        let f = PyDict::new(py);
        for (name, w) in &c.f_eq {
            f.set_item(name, to_numpy(py, w.as_slice().to_vec(), &[6]))?;
        }
        d.set_item("f_eq", f)?;
        Ok(d)
    }

    fn __repr__(&self) -> String {
        format!(
            "Structure(nodes={}, load_cases={})",
            self.model.structure.node_count(),
            self.model.load_cases.len()
        )
    }
}
