//! The TCP grid of a deflection campaign in the x-z plane: where each pose
//! of a set sits on the grid (65) of the reference paper, so that a value
//! per pose can be laid out as a map (Figs. 9 and 15).

use flexcal_kinematics::{Data, KinematicsError, Model, forward_pose};
use serde::{Deserialize, Serialize};

use crate::campaign::DeflectionMeasurement;

/// Values on the grid of TCP positions in the x-z plane.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GridValues {
    /// Grid x values (m), increasing.
    pub xs: Vec<f64>,
    /// Grid z values (m), increasing.
    pub zs: Vec<f64>,
    /// `values[row of z][column of x]`, NaN where no pose sits.
    pub values: Vec<Vec<f64>>,
}

/// The grid cell of each pose of a set of measurements.
#[derive(Debug, Clone, PartialEq)]
pub struct TcpGrid {
    xs: Vec<f64>,
    zs: Vec<f64>,
    /// (column, row) of each measurement, none when off the grid lines.
    cells: Vec<Option<(usize, usize)>>,
}

impl TcpGrid {
    /// Places each measurement at its nominal TCP position (forward model
    /// with the robot's nominal parameters), rounded to the centimetre: the
    /// grid steps are ~0.16 m, so the rounded positions identify the lines.
    ///
    /// # Errors
    /// A configuration the forward model cannot evaluate.
    pub fn of_measurements(
        robot: &Model,
        measurements: &[DeflectionMeasurement],
    ) -> Result<Self, KinematicsError> {
        let mut data = Data::new(robot);
        let key = |v: f64| (v * 1e2).round() / 1e2;
        let mut positions = Vec::with_capacity(measurements.len());
        for m in measurements {
            let x = forward_pose(robot, &mut data, &m.q, robot.nominal_params())?;
            positions.push((key(x.translation.vector.x), key(x.translation.vector.z)));
        }
        let mut xs: Vec<f64> = positions.iter().map(|c| c.0).collect();
        let mut zs: Vec<f64> = positions.iter().map(|c| c.1).collect();
        for v in [&mut xs, &mut zs] {
            v.sort_by(f64::total_cmp);
            v.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
        }
        let cells = positions
            .iter()
            .map(|(cx, cz)| {
                Some((
                    xs.iter().position(|x| (x - cx).abs() < 1e-9)?,
                    zs.iter().position(|z| (z - cz).abs() < 1e-9)?,
                ))
            })
            .collect();
        Ok(Self { xs, zs, cells })
    }

    /// Lays out one value per measurement (`value(k)` for measurement `k`).
    pub fn lay_out(&self, value: impl Fn(usize) -> f64) -> GridValues {
        let mut values = vec![vec![f64::NAN; self.xs.len()]; self.zs.len()];
        for (k, cell) in self.cells.iter().enumerate() {
            if let Some((c, r)) = cell {
                values[*r][*c] = value(k);
            }
        }
        GridValues {
            xs: self.xs.clone(),
            zs: self.zs.clone(),
            values,
        }
    }
}
