//! Elastic campaign files: measured TCP positions with and without load, in
//! flexcal's measurement CSV conventions, and the deflections they give.
//!
//! One file per load case (a load magnitude and direction). Columns:
//! `pose_id, q1..qn` (actuated coordinates, rad or m), `x_mm, y_mm, z_mm`
//! (measured TCP position in the robot base frame), `fx_n, fy_n, fz_n,
//! mx_nm, my_nm, mz_nm` (wrench applied at the TCP, base axes; all zero on an
//! unloaded row) and optionally `sx_mm, sy_mm, sz_mm` (standard deviation of
//! each measured coordinate). Lines starting with `#` are comments. Each
//! pose appears twice with the same `pose_id` and the same q: once unloaded,
//! once loaded. The measured deflection is loaded minus unloaded (section
//! 3.3.1: "subtraction of the poses measured with and without payload").

use std::path::{Path, PathBuf};

use flexcal_io::{CsvOptions, CsvTable};
use nalgebra::{Vector3, Vector6};

use crate::error::{ElasticError, Result};

/// One measured TCP position row.
#[derive(Debug, Clone, PartialEq)]
pub struct PositionRow {
    /// Identifier pairing the loaded and unloaded rows of a pose.
    pub pose_id: u64,
    /// Actuated coordinates (rad, m).
    pub q: Vec<f64>,
    /// Measured TCP position (m), base frame.
    pub position: Vector3<f64>,
    /// Applied TCP wrench [N; N.m], base axes (zero when unloaded).
    pub wrench: Vector6<f64>,
    /// Standard deviation of each measured coordinate (m).
    pub sigma: Vector3<f64>,
}

/// One measured deflection: a configuration, the wrench applied at the TCP,
/// and the TCP displacement it caused.
#[derive(Debug, Clone, PartialEq)]
pub struct DeflectionMeasurement {
    /// Pose identifier in its file.
    pub pose_id: u64,
    /// Actuated coordinates (rad, m).
    pub q: Vec<f64>,
    /// Wrench applied at the TCP [N; N.m], base axes.
    pub wrench: Vector6<f64>,
    /// Measured TCP displacement, loaded minus unloaded (m), base axes.
    pub deflection: Vector3<f64>,
    /// Standard deviation of each deflection component (m): the loaded and
    /// unloaded deviations combined.
    pub sigma: Vector3<f64>,
}

impl DeflectionMeasurement {
    /// Magnitude of the applied force (N).
    pub fn load_n(&self) -> f64 {
        self.wrench.fixed_rows::<3>(0).norm()
    }
}

/// The deflections of one file (one load case).
#[derive(Debug, Clone, PartialEq)]
pub struct DeflectionSet {
    /// File the set was read from (empty for sets built in memory).
    pub path: PathBuf,
    /// Name (file stem).
    pub name: String,
    /// Deflections, in file order of the loaded rows.
    pub measurements: Vec<DeflectionMeasurement>,
}

impl DeflectionSet {
    /// Load magnitude of the set (N): the largest load of its measurements.
    pub fn load_n(&self) -> f64 {
        self.measurements
            .iter()
            .map(DeflectionMeasurement::load_n)
            .fold(0.0, f64::max)
    }
}

const WRENCH_COLUMNS: [&str; 6] = ["fx_n", "fy_n", "fz_n", "mx_nm", "my_nm", "mz_nm"];
const POSITION_COLUMNS: [&str; 3] = ["x_mm", "y_mm", "z_mm"];
const SIGMA_COLUMNS: [&str; 3] = ["sx_mm", "sy_mm", "sz_mm"];

/// CSV text of position rows, with `comments` as leading `#` lines.
pub fn format_position_rows(rows: &[PositionRow], comments: &[String]) -> String {
    let n = rows.first().map_or(0, |r| r.q.len());
    let mut header: Vec<String> = vec!["pose_id".into()];
    header.extend((1..=n).map(|i| format!("q{i}")));
    header.extend(POSITION_COLUMNS.iter().map(|s| s.to_string()));
    header.extend(WRENCH_COLUMNS.iter().map(|s| s.to_string()));
    header.extend(SIGMA_COLUMNS.iter().map(|s| s.to_string()));
    let header_refs: Vec<&str> = header.iter().map(String::as_str).collect();
    let body = flexcal_io::format_csv(
        &header_refs,
        rows.iter().map(|r| {
            let mut v = vec![r.pose_id as f64];
            v.extend(&r.q);
            v.extend((r.position * 1e3).iter());
            v.extend(r.wrench.iter());
            v.extend((r.sigma * 1e3).iter());
            v
        }),
    );
    let mut text = String::new();
    for c in comments {
        text.push_str("# ");
        text.push_str(c);
        text.push('\n');
    }
    text.push_str(&body);
    text
}

/// Writes position rows atomically.
///
/// # Errors
/// I/O errors naming the file.
pub fn write_position_rows(
    path: impl AsRef<Path>,
    rows: &[PositionRow],
    comments: &[String],
) -> Result<()> {
    flexcal_io::write_atomic(path, format_position_rows(rows, comments))?;
    Ok(())
}

/// Reads the position rows of a file whose robot has `n_actuated` coordinates.
///
/// # Errors
/// Missing columns, malformed numbers (with file, line and column), a
/// negative standard deviation, a pose id that is not a non-negative integer.
pub fn read_position_rows(path: impl AsRef<Path>, n_actuated: usize) -> Result<Vec<PositionRow>> {
    let table = CsvTable::read(path.as_ref(), &CsvOptions::default())?;
    position_rows_from_table(&table, n_actuated)
}

fn position_rows_from_table(table: &CsvTable, n_actuated: usize) -> Result<Vec<PositionRow>> {
    table.require_rows()?;
    let path = table.path().to_path_buf();
    let col = |name: &str| table.column_index(name);
    let id_col = col("pose_id")?;
    let q_cols = (1..=n_actuated)
        .map(|i| col(&format!("q{i}")))
        .collect::<std::result::Result<Vec<_>, _>>()?;
    let p_cols = POSITION_COLUMNS
        .iter()
        .map(|c| col(c))
        .collect::<std::result::Result<Vec<_>, _>>()?;
    let w_cols = WRENCH_COLUMNS
        .iter()
        .map(|c| col(c))
        .collect::<std::result::Result<Vec<_>, _>>()?;
    let s_cols = SIGMA_COLUMNS.map(|c| table.find_column(c));
    let mut rows = Vec::with_capacity(table.len());
    for r in 0..table.len() {
        let line = table.line_of(r);
        let id = table.f64_at(r, id_col)?;
        if !(id >= 0.0 && id.fract() == 0.0 && id < 2f64.powi(53)) {
            return Err(ElasticError::Data {
                path: path.clone(),
                line,
                message: format!("pose_id must be a non-negative integer, got {id}"),
            });
        }
        let q = q_cols
            .iter()
            .map(|&c| table.f64_at(r, c))
            .collect::<std::result::Result<Vec<_>, _>>()?;
        let mut position = Vector3::zeros();
        for k in 0..3 {
            position[k] = table.f64_at(r, p_cols[k])? * 1e-3;
        }
        let mut wrench = Vector6::zeros();
        for k in 0..6 {
            wrench[k] = table.f64_at(r, w_cols[k])?;
        }
        let mut sigma = Vector3::zeros();
        for k in 0..3 {
            if let Some(c) = s_cols[k] {
                let s = table.f64_at(r, c)?;
                if s < 0.0 {
                    return Err(ElasticError::Data {
                        path: path.clone(),
                        line,
                        message: format!(
                            "{}: a standard deviation cannot be negative ({s})",
                            SIGMA_COLUMNS[k]
                        ),
                    });
                }
                sigma[k] = s * 1e-3;
            }
        }
        rows.push(PositionRow {
            pose_id: id as u64,
            q,
            position,
            wrench,
            sigma,
        });
    }
    Ok(rows)
}

/// Pairs loaded and unloaded rows by `pose_id` into deflections.
///
/// # Errors
/// A loaded pose without its unloaded row (or the reverse), two unloaded rows
/// for one pose, loaded and unloaded rows whose q differ.
pub fn deflections_from_rows(
    path: &Path,
    rows: &[PositionRow],
) -> Result<Vec<DeflectionMeasurement>> {
    let data_error = |line: usize, message: String| ElasticError::Data {
        path: path.to_path_buf(),
        line,
        message,
    };
    // Lines are 1-based with the header first; comments shift them, so the
    // row index is reported alongside.
    let mut out = Vec::new();
    for (i, r) in rows.iter().enumerate() {
        if r.wrench.iter().all(|&v| v == 0.0) {
            let paired = rows
                .iter()
                .any(|o| o.pose_id == r.pose_id && o.wrench.iter().any(|&v| v != 0.0));
            if !paired {
                return Err(data_error(
                    0,
                    format!("pose {} (data row {}) has no loaded row", r.pose_id, i + 1),
                ));
            }
            continue;
        }
        let unloaded: Vec<&PositionRow> = rows
            .iter()
            .filter(|o| o.pose_id == r.pose_id && o.wrench.iter().all(|&v| v == 0.0))
            .collect();
        let base = match unloaded.as_slice() {
            [one] => *one,
            [] => {
                return Err(data_error(
                    0,
                    format!(
                        "pose {} (data row {}) has no unloaded row (all wrench columns zero)",
                        r.pose_id,
                        i + 1
                    ),
                ));
            }
            _ => {
                return Err(data_error(
                    0,
                    format!(
                        "pose {} has {} unloaded rows, expected one",
                        r.pose_id,
                        unloaded.len()
                    ),
                ));
            }
        };
        let same_q = base.q.len() == r.q.len()
            && base
                .q
                .iter()
                .zip(&r.q)
                .all(|(a, b)| (a - b).abs() <= 1e-9 * (1.0 + a.abs()));
        if !same_q {
            return Err(data_error(
                0,
                format!(
                    "pose {}: the loaded and unloaded rows have different q",
                    r.pose_id
                ),
            ));
        }
        out.push(DeflectionMeasurement {
            pose_id: r.pose_id,
            q: r.q.clone(),
            wrench: r.wrench,
            deflection: r.position - base.position,
            sigma: (r.sigma.component_mul(&r.sigma) + base.sigma.component_mul(&base.sigma))
                .map(f64::sqrt),
        });
    }
    if out.is_empty() {
        return Err(data_error(0, "no loaded row (every wrench is zero)".into()));
    }
    Ok(out)
}

/// Reads one deflection set.
///
/// # Errors
/// As [`read_position_rows`] and [`deflections_from_rows`].
pub fn read_deflection_set(path: impl AsRef<Path>, n_actuated: usize) -> Result<DeflectionSet> {
    let path = path.as_ref();
    let rows = read_position_rows(path, n_actuated)?;
    let measurements = deflections_from_rows(path, &rows)?;
    Ok(DeflectionSet {
        path: path.to_path_buf(),
        name: path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default(),
        measurements,
    })
}

/// Reads every `*.csv` file of `dir` (sorted by name) as a deflection set.
///
/// # Errors
/// [`ElasticError::NoData`] when the folder has no CSV file; read errors of
/// any file.
pub fn read_campaign_dir(dir: impl AsRef<Path>, n_actuated: usize) -> Result<Vec<DeflectionSet>> {
    let dir = dir.as_ref();
    let entries = std::fs::read_dir(dir).map_err(|source| {
        ElasticError::Io(flexcal_io::IoError::Io {
            path: dir.to_path_buf(),
            source,
        })
    })?;
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "csv"))
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(ElasticError::NoData {
            what: format!("{}: no .csv deflection file", dir.display()),
        });
    }
    files
        .iter()
        .map(|f| read_deflection_set(f, n_actuated))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(id: u64, load: f64, z: f64) -> PositionRow {
        PositionRow {
            pose_id: id,
            q: vec![0.1, 0.9, 0.7],
            position: Vector3::new(1.5, 0.0, z),
            wrench: Vector6::new(0.0, 0.0, -load, 0.0, 0.0, 0.0),
            sigma: Vector3::repeat(21e-6),
        }
    }

    #[test]
    fn rows_round_trip_and_pair() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("z_900.csv");
        let rows = vec![
            row(0, 0.0, 1.2),
            row(0, 900.0, 1.1985),
            row(1, 0.0, 1.4),
            row(1, 900.0, 1.398),
        ];
        write_position_rows(&path, &rows, &["test".into()]).unwrap();
        let back = read_position_rows(&path, 3).unwrap();
        assert_eq!(back.len(), 4);
        for (a, b) in rows.iter().zip(&back) {
            assert_eq!(a.pose_id, b.pose_id);
            assert_eq!(a.q, b.q);
            assert!((a.position - b.position).norm() < 1e-15);
            assert_eq!(a.wrench, b.wrench);
            assert!((a.sigma - b.sigma).norm() < 1e-18);
        }
        let set = read_deflection_set(&path, 3).unwrap();
        assert_eq!(set.measurements.len(), 2);
        assert!((set.measurements[0].deflection.z + 1.5e-3).abs() < 1e-12);
        assert!((set.measurements[0].sigma.x - 21e-6 * 2f64.sqrt()).abs() < 1e-15);
        assert_eq!(set.load_n(), 900.0);
    }

    #[test]
    fn unpaired_rows_are_reported() {
        let rows = vec![row(0, 0.0, 1.2), row(1, 900.0, 1.1985)];
        let err = deflections_from_rows(Path::new("f.csv"), &rows).unwrap_err();
        assert!(err.to_string().contains("pose 0"), "{err}");
    }

    #[test]
    fn missing_column_names_file_and_column() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.csv");
        std::fs::write(&path, "pose_id,q1,q2,q3,x_mm,y_mm\n0,0,0,0,1,2\n").unwrap();
        let err = read_position_rows(&path, 3).unwrap_err().to_string();
        assert!(err.contains("z_mm") && err.contains("bad.csv"), "{err}");
    }
}
