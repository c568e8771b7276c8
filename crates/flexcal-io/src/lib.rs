//! File plumbing shared by every flexcal crate that reads or writes files.
//!
//! Two things live here, so that they are written once:
//!
//! * [`write_atomic`]: every output file is written to a temporary file in the
//!   destination folder and renamed over the target, so an interrupted run or
//!   a failed step never leaves a half-written file nor destroys the previous
//!   one.
//! * [`CsvTable`]: a CSV file read as text, with numeric look-ups that report
//!   the file, the line and the column of a bad value. Measurement sets, path
//!   files and fuzzy training data are all read through it, with either the
//!   usual `,` separator or the `;` separator and decimal comma used by some
//!   laser-tracker exports.
//!
//! ```
//! use flexcal_io::{CsvOptions, CsvTable};
//! let text = "q1,q2\n0.1,0.2\n0.3,0.4\n";
//! let table = CsvTable::from_str(text, "inline.csv", &CsvOptions::default()).unwrap();
//! assert_eq!(table.column_f64("q2").unwrap(), vec![0.2, 0.4]);
//! assert!(table.column_f64("q3").is_err());
//! ```

pub mod fuzz;

use std::io::Write;
use std::path::{Path, PathBuf};

/// Errors of file input and output, each naming the file and, where it
/// applies, the line (1-based, counting the header as line 1) and column.
#[derive(Debug, thiserror::Error)]
pub enum IoError {
    /// The file could not be opened, read, written or renamed.
    #[error("{path}: {source}")]
    Io {
        /// The file concerned.
        path: PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// The CSV text is malformed (unbalanced quotes, ragged rows).
    #[error("{path}:{line}: malformed CSV: {message}")]
    Malformed {
        /// The file concerned.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// A required column is absent from the header.
    #[error("{path}: missing column '{column}' (header has: {available})")]
    MissingColumn {
        /// The file concerned.
        path: PathBuf,
        /// The column that was asked for.
        column: String,
        /// The columns the header does have, comma-separated.
        available: String,
    },
    /// A cell does not hold a finite number.
    #[error("{path}:{line}: column '{column}': '{value}' is not a finite number")]
    BadNumber {
        /// The file concerned.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// Column name.
        column: String,
        /// The offending text.
        value: String,
    },
    /// The file has a header but no data rows.
    #[error("{path}: no data rows")]
    Empty {
        /// The file concerned.
        path: PathBuf,
    },
}

/// Writes `contents` to `path` atomically: the bytes go to a temporary file in
/// the same folder, which is flushed and then renamed over `path`. Missing
/// parent folders are created. If anything fails, `path` keeps its previous
/// contents (or stays absent).
pub fn write_atomic(path: impl AsRef<Path>, contents: impl AsRef<[u8]>) -> Result<(), IoError> {
    let path = path.as_ref();
    let io_err = |source| IoError::Io {
        path: path.to_path_buf(),
        source,
    };
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    std::fs::create_dir_all(&dir).map_err(io_err)?;
    let mut tmp = tempfile::Builder::new()
        .prefix(".flexcal-tmp-")
        .tempfile_in(&dir)
        .map_err(io_err)?;
    tmp.write_all(contents.as_ref()).map_err(io_err)?;
    // Temporary files are created private (0600); give the result the
    // permissions of the file it replaces, or the usual 0644 for a new file.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::metadata(path)
            .map(|m| m.permissions().mode())
            .unwrap_or(0o644);
        tmp.as_file()
            .set_permissions(std::fs::Permissions::from_mode(mode))
            .map_err(io_err)?;
    }
    tmp.as_file().sync_all().map_err(io_err)?;
    tmp.persist(path).map_err(|e| io_err(e.error))?;
    Ok(())
}

/// Reads a whole text file, naming it in the error.
pub fn read_to_string(path: impl AsRef<Path>) -> Result<String, IoError> {
    let path = path.as_ref();
    std::fs::read_to_string(path).map_err(|source| IoError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// How a CSV file is laid out.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CsvOptions {
    /// Field separator (default `b','`).
    pub delimiter: u8,
    /// Whether numbers use a decimal comma (`1,5` for 1.5; default false).
    /// Only meaningful with a delimiter other than `,`.
    pub decimal_comma: bool,
    /// Lines starting with this byte are comments (default `Some(b'#')`).
    pub comment: Option<u8>,
}

impl Default for CsvOptions {
    fn default() -> Self {
        Self {
            delimiter: b',',
            decimal_comma: false,
            comment: Some(b'#'),
        }
    }
}

impl CsvOptions {
    /// `;`-separated with decimal comma, as written by spreadsheet software in
    /// many European locales.
    pub fn semicolon_decimal_comma() -> Self {
        Self {
            delimiter: b';',
            decimal_comma: true,
            comment: None,
        }
    }
}

/// A CSV file held as text: a header and rows of cells, each row remembering
/// its line in the file so that errors can point at it.
#[derive(Debug, Clone)]
pub struct CsvTable {
    path: PathBuf,
    header: Vec<String>,
    rows: Vec<Vec<String>>,
    lines: Vec<usize>,
    decimal_comma: bool,
}

impl CsvTable {
    /// Reads and splits a CSV file. Every row must have as many cells as the
    /// header; blank lines and comment lines are skipped.
    pub fn read(path: impl AsRef<Path>, options: &CsvOptions) -> Result<Self, IoError> {
        let path = path.as_ref();
        let text = read_to_string(path)?;
        Self::from_str(&text, path, options)
    }

    /// Splits CSV text; `path` is only used to name the source in errors.
    #[allow(clippy::should_implement_trait)]
    pub fn from_str(
        text: &str,
        path: impl AsRef<Path>,
        options: &CsvOptions,
    ) -> Result<Self, IoError> {
        let path = path.as_ref().to_path_buf();
        let mut reader = csv::ReaderBuilder::new()
            .delimiter(options.delimiter)
            .comment(options.comment)
            .has_headers(true)
            .flexible(false)
            .trim(csv::Trim::All)
            .from_reader(text.as_bytes());
        let malformed = |line: usize, message: String| IoError::Malformed {
            path: path.clone(),
            line,
            message,
        };
        let header: Vec<String> = reader
            .headers()
            .map_err(|e| malformed(1, e.to_string()))?
            .iter()
            .map(|s| s.trim_start_matches('\u{feff}').to_string())
            .collect();
        let mut rows = Vec::new();
        let mut lines = Vec::new();
        let mut counter = LineCounter::new(text, options.comment);
        for record in reader.records() {
            let record = record.map_err(|e| {
                let line = e.position().map_or(0, |p| counter.line_at(p));
                let message = match e.kind() {
                    csv::ErrorKind::UnequalLengths {
                        expected_len, len, ..
                    } => format!("expected {expected_len} fields as in the header, found {len}"),
                    _ => e.to_string(),
                };
                malformed(line, message)
            })?;
            let line = record.position().map_or(0, |p| counter.line_at(p));
            rows.push(record.iter().map(str::to_string).collect());
            lines.push(line);
        }
        Ok(Self {
            path,
            header,
            rows,
            lines,
            decimal_comma: options.decimal_comma,
        })
    }

    /// The file this table was read from.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Column names in file order.
    pub fn header(&self) -> &[String] {
        &self.header
    }

    /// Number of data rows.
    pub fn len(&self) -> usize {
        self.rows.len()
    }

    /// Whether the table has no data rows.
    pub fn is_empty(&self) -> bool {
        self.rows.is_empty()
    }

    /// Fails with [`IoError::Empty`] when the table has no data rows.
    pub fn require_rows(&self) -> Result<(), IoError> {
        if self.rows.is_empty() {
            Err(IoError::Empty {
                path: self.path.clone(),
            })
        } else {
            Ok(())
        }
    }

    /// 1-based line of data row `row` in the file.
    pub fn line_of(&self, row: usize) -> usize {
        self.lines[row]
    }

    /// Index of a column, if the header has it.
    pub fn find_column(&self, name: &str) -> Option<usize> {
        self.header.iter().position(|h| h == name)
    }

    /// Index of a required column.
    pub fn column_index(&self, name: &str) -> Result<usize, IoError> {
        self.find_column(name)
            .ok_or_else(|| IoError::MissingColumn {
                path: self.path.clone(),
                column: name.to_string(),
                available: self.header.join(", "),
            })
    }

    /// Raw text of a cell.
    pub fn cell(&self, row: usize, column: usize) -> &str {
        &self.rows[row][column]
    }

    /// A cell parsed as a finite number.
    pub fn f64_at(&self, row: usize, column: usize) -> Result<f64, IoError> {
        let raw = self.cell(row, column);
        let parsed = if self.decimal_comma {
            raw.replace(',', ".").parse::<f64>()
        } else {
            raw.parse::<f64>()
        };
        match parsed {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(IoError::BadNumber {
                path: self.path.clone(),
                line: self.lines[row],
                column: self.header[column].clone(),
                value: raw.to_string(),
            }),
        }
    }

    /// A whole named column parsed as finite numbers.
    pub fn column_f64(&self, name: &str) -> Result<Vec<f64>, IoError> {
        let c = self.column_index(name)?;
        (0..self.rows.len()).map(|r| self.f64_at(r, c)).collect()
    }

    /// An optional named column: `None` when the header lacks it.
    pub fn optional_column_f64(&self, name: &str) -> Result<Option<Vec<f64>>, IoError> {
        match self.find_column(name) {
            None => Ok(None),
            Some(_) => self.column_f64(name).map(Some),
        }
    }
}

/// Formats rows of numbers as CSV text under a header, with full precision
/// (shortest representation that round-trips).
pub fn format_csv(header: &[&str], rows: impl IntoIterator<Item = Vec<f64>>) -> String {
    let mut out = header.join(",");
    out.push('\n');
    for row in rows {
        let mut first = true;
        for v in row {
            if !first {
                out.push(',');
            }
            first = false;
            out.push_str(&format!("{v}"));
        }
        out.push('\n');
    }
    out
}

/// Line numbers of records from their byte positions, counted once through
/// the text (records come in file order).
struct LineCounter<'a> {
    bytes: &'a [u8],
    comment: Option<u8>,
    /// Bytes before this offset are counted...
    counted_to: usize,
    /// ...and hold this many line ends.
    line_ends: usize,
}

impl<'a> LineCounter<'a> {
    fn new(text: &'a str, comment: Option<u8>) -> Self {
        Self {
            bytes: text.as_bytes(),
            comment,
            counted_to: 0,
            line_ends: 0,
        }
    }

    /// 1-based line on which the record at `position` starts. The reader's
    /// position is where it began to read: possibly the `\n` of a CRLF line
    /// end, blank lines or comment lines before the record, which its own
    /// line count also gets wrong. Skip those and count the line ends
    /// before the record.
    fn line_at(&mut self, position: &csv::Position) -> usize {
        let bytes = self.bytes;
        let mut at = (position.byte() as usize).min(bytes.len());
        loop {
            while at < bytes.len() && matches!(bytes[at], b'\r' | b'\n') {
                at += 1;
            }
            if at < bytes.len() && Some(bytes[at]) == self.comment {
                at = bytes[at..]
                    .iter()
                    .position(|&b| b == b'\n')
                    .map_or(bytes.len(), |n| at + n + 1);
            } else {
                break;
            }
        }
        if at < self.counted_to {
            // Out of order (not expected): count from the start.
            self.counted_to = 0;
            self.line_ends = 0;
        }
        self.line_ends += bytes[self.counted_to..at]
            .iter()
            .filter(|&&b| b == b'\n')
            .count();
        self.counted_to = at;
        1 + self.line_ends
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reports_line_and_column_of_bad_number() {
        let text = "a,b\n1,2\n3,x\n";
        let t = CsvTable::from_str(text, "t.csv", &CsvOptions::default()).unwrap();
        let err = t.column_f64("b").unwrap_err().to_string();
        assert!(err.contains("t.csv:3"), "{err}");
        assert!(err.contains("'b'"), "{err}");
        let nan = CsvTable::from_str("a\nNaN\n", "n.csv", &CsvOptions::default()).unwrap();
        assert!(nan.column_f64("a").is_err());
    }

    #[test]
    fn lines_are_counted_right_with_crlf_ends() {
        let text = "a;b\r\n1;2\r\n# note\r\n3;x\r\n4;5;6\r\n";
        let options = CsvOptions {
            delimiter: b';',
            ..CsvOptions::default()
        };
        let err = CsvTable::from_str(text, "w.csv", &options)
            .unwrap_err()
            .to_string();
        assert!(err.contains("w.csv:5"), "{err}");
        let t = CsvTable::from_str("a;b\r\n1;2\r\n\r\n3;x\r\n", "w.csv", &options).unwrap();
        assert_eq!((t.line_of(0), t.line_of(1)), (2, 4));
        let err = t.column_f64("b").unwrap_err().to_string();
        assert!(err.contains("w.csv:4"), "{err}");
        // The same with LF ends: a comment line before the record.
        let t = CsvTable::from_str("a;b\n1;2\n# note\n\n3;x\n", "l.csv", &options).unwrap();
        assert_eq!((t.line_of(0), t.line_of(1)), (2, 5));
    }

    #[test]
    fn ragged_rows_are_malformed_with_their_line() {
        let err = CsvTable::from_str("a,b\n1,2\n3\n", "r.csv", &CsvOptions::default())
            .unwrap_err()
            .to_string();
        assert!(err.contains("r.csv:3"), "{err}");
    }

    #[test]
    fn decimal_comma_semicolon() {
        let t = CsvTable::from_str(
            "x;y\n1,5;-2,25\n",
            "d.csv",
            &CsvOptions::semicolon_decimal_comma(),
        )
        .unwrap();
        assert_eq!(t.column_f64("x").unwrap(), vec![1.5]);
        assert_eq!(t.column_f64("y").unwrap(), vec![-2.25]);
    }

    #[test]
    fn missing_column_lists_header() {
        let t = CsvTable::from_str("a,b\n1,2\n", "m.csv", &CsvOptions::default()).unwrap();
        let err = t.column_f64("c").unwrap_err().to_string();
        assert!(err.contains("'c'") && err.contains("a, b"), "{err}");
    }

    #[test]
    fn atomic_write_replaces_and_round_trips() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("sub/out.csv");
        let text = format_csv(&["a", "b"], vec![vec![0.1, 1e-17], vec![-3.0, 2.5]]);
        write_atomic(&p, &text).unwrap();
        let t = CsvTable::read(&p, &CsvOptions::default()).unwrap();
        assert_eq!(t.column_f64("b").unwrap(), vec![1e-17, 2.5]);
        write_atomic(&p, "a\n7\n").unwrap();
        assert_eq!(read_to_string(&p).unwrap(), "a\n7\n");
        // Only the target remains in the folder: no temporary leftovers.
        assert_eq!(std::fs::read_dir(p.parent().unwrap()).unwrap().count(), 1);
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let mode = std::fs::metadata(&p).unwrap().permissions().mode() & 0o777;
            assert_eq!(mode, 0o644);
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::test_runner::Config {
            // Seeded: every run draws the same cases.
            rng_seed: proptest::test_runner::RngSeed::Fixed(20130007),
            failure_persistence: None,
            ..proptest::test_runner::Config::default()
        })]
        #[test]
        fn csv_round_trips_any_finite_numbers(values in proptest::collection::vec(-1e12f64..1e12, 1..20)) {
            let text = format_csv(&["v"], values.iter().map(|v| vec![*v]));
            let t = CsvTable::from_str(&text, "p.csv", &CsvOptions::default()).unwrap();
            proptest::prop_assert_eq!(t.column_f64("v").unwrap(), values);
        }

        /// Each data row is found on its line whatever the line ends and
        /// whatever blank and comment lines stand between the rows.
        #[test]
        fn rows_are_found_on_their_lines(
            kinds in proptest::collection::vec(0u8..4, 1..40),
            crlf in proptest::bool::ANY,
        ) {
            let end = if crlf { "\r\n" } else { "\n" };
            let mut text = format!("a,b{end}");
            let mut expected = Vec::new();
            for (k, kind) in kinds.iter().enumerate() {
                match kind {
                    0 => text.push_str(end),
                    1 => text.push_str(&format!("# note {k}{end}")),
                    _ => {
                        expected.push(text.matches('\n').count() + 1);
                        text.push_str(&format!("{k},{}{end}", 2 * k));
                    }
                }
            }
            let t = CsvTable::from_str(&text, "l.csv", &CsvOptions::default()).unwrap();
            let found: Vec<usize> = (0..t.len()).map(|r| t.line_of(r)).collect();
            proptest::prop_assert_eq!(found, expected);
        }
    }
}
