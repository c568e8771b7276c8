//! A campaign's file: TOML read with one-line errors naming the file, the
//! line and the key; paths resolved against the file's folder on reading
//! and written relative to it; the campaign embedded in a JSON report read
//! back.

use std::path::{Component, Path, PathBuf};

use super::Campaign;
use crate::{Error, Result};

/// Whether a path of a campaign is read (it must exist) or written.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Role {
    Input,
    Output,
}

/// The folder of a file, `.` for a bare file name.
pub(crate) fn folder_of(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// `path` with `.` removed and `..` applied to what precedes it (no file
/// system access).
fn lexical(path: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for c in path.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => match out.components().next_back() {
                Some(Component::Normal(_)) => {
                    out.pop();
                }
                _ => out.push(".."),
            },
            other => out.push(other.as_os_str()),
        }
    }
    out
}

/// `path` (absolute, or relative to the working directory) written
/// relative to `folder` (the same), with `..` where it lies outside; an
/// absolute path when no relative one exists (another drive) or the
/// working directory is unknown.
pub fn relative_path(path: &Path, folder: &Path) -> PathBuf {
    let (Ok(p), Ok(f)) = (std::path::absolute(path), std::path::absolute(folder)) else {
        return path.to_path_buf();
    };
    let (p, f) = (lexical(&p), lexical(&f));
    let (pc, fc): (Vec<_>, Vec<_>) = (p.components().collect(), f.components().collect());
    if pc.first() != fc.first() {
        return p;
    }
    let common = pc.iter().zip(&fc).take_while(|(a, b)| a == b).count();
    let mut out: PathBuf = fc[common..].iter().map(|_| Component::ParentDir).collect();
    out.extend(&pc[common..]);
    if out.as_os_str().is_empty() {
        out.push(".");
    }
    out
}

impl Campaign {
    /// Every path of the campaign with its key and role.
    fn paths_mut(&mut self) -> Vec<(String, &mut PathBuf, Role)> {
        let mut paths = Vec::new();
        let robot = &mut self.robot;
        paths.extend(
            robot
                .file
                .as_mut()
                .map(|p| ("robot.file".into(), p, Role::Input)),
        );
        paths.extend(
            robot
                .values
                .as_mut()
                .map(|p| ("robot.values".into(), p, Role::Input)),
        );
        for (k, p) in self.data.files.iter_mut().enumerate() {
            paths.push((format!("data.files[{k}]"), p, Role::Input));
        }
        let data_targets = self.data.targets.as_mut();
        paths.extend(data_targets.map(|p| ("data.targets".into(), p, Role::Input)));
        if let Some(v) = &mut self.validation {
            paths.push(("validation.file".into(), &mut v.file, Role::Input));
        }
        paths.extend(
            self.model
                .masses
                .as_mut()
                .map(|p| ("model.masses".into(), p, Role::Input)),
        );
        let grid = self.checks.accuracy_map.as_mut();
        paths.extend(grid.map(|p| ("checks.accuracy_map".into(), p, Role::Input)));
        let o = &mut self.outputs;
        for (key, path) in [
            ("outputs.calibrated_robot", &mut o.calibrated_robot),
            ("outputs.report", &mut o.report),
            ("outputs.html", &mut o.html),
            ("outputs.residuals", &mut o.residuals),
        ] {
            paths.extend(path.as_mut().map(|p| (key.to_string(), p, Role::Output)));
        }
        paths
    }

    /// The campaign with its paths written relative to `folder` (the
    /// folder of the file it will be written to).
    pub fn relative_to(&self, folder: &Path) -> Campaign {
        let mut campaign = self.clone();
        for (_, path, _) in campaign.paths_mut() {
            *path = relative_path(path, folder);
        }
        campaign.source = None;
        campaign
    }

    /// The campaign as TOML, paths relative to `folder`.
    pub fn to_toml_string(&self, folder: &Path) -> String {
        // Every field is a plain value, table or array of strings: the
        // serialiser cannot fail on them.
        toml::to_string(&self.relative_to(folder))
            .unwrap_or_else(|e| format!("# the campaign does not serialise: {e}\n"))
    }

    /// Writes the campaign to `path` (atomically: a temporary file renamed),
    /// its paths relative to the file's folder where possible.
    ///
    /// # Errors
    /// The file that could not be written.
    pub fn write(&self, path: &Path) -> Result<()> {
        Ok(flexcal_io::write_atomic(
            path,
            self.to_toml_string(folder_of(path)),
        )?)
    }

    /// Parses campaign TOML; `source` names the file in errors.
    ///
    /// # Errors
    /// [`Error::Campaign`] naming `source`, the line and the key: unknown
    /// keys, values of the wrong type, missing tables or keys.
    pub fn from_toml_str(text: &str, source: &Path) -> Result<Campaign> {
        let mut campaign: Campaign = toml::from_str(text).map_err(|e| {
            let start = e.span().map_or(0, |s| s.start.min(text.len()));
            let line = text[..start].matches('\n').count() + 1;
            Error::Campaign {
                origin: format!("{}:{line}", source.display()),
                key: key_at(text, start),
                message: e.message().trim().replace('\n', " "),
            }
        })?;
        campaign.source = Some(source.to_path_buf());
        Ok(campaign)
    }

    /// Reads a campaign file: parses it, resolves its relative paths
    /// against the file's folder and checks that every input file exists.
    ///
    /// # Errors
    /// The file that cannot be read; [`Error::Campaign`] naming the file
    /// and the key: a parse error ([`Campaign::from_toml_str`]), a path that
    /// is empty or names no file.
    pub fn read(path: &Path) -> Result<Campaign> {
        let text = flexcal_io::read_to_string(path)?;
        let mut campaign = Self::from_toml_str(&text, path)?;
        campaign.resolve(folder_of(path))?;
        Ok(campaign)
    }

    /// Reads the campaign a JSON report carries in its `config` section
    /// ([`super::CampaignRun::report_json`]), its paths resolved against
    /// the report's folder.
    ///
    /// # Errors
    /// The file that cannot be read or parsed; [`Error::Campaign`] for a
    /// report without a `config` section, or with one that is not a valid
    /// campaign or names files that do not exist.
    pub fn from_report(path: &Path) -> Result<Campaign> {
        let text = flexcal_io::read_to_string(path)?;
        let json_error = |source| Error::Json {
            context: path.display().to_string(),
            source,
        };
        let mut report: serde_json::Value = serde_json::from_str(&text).map_err(json_error)?;
        let campaign_error = |message: String| Error::Campaign {
            origin: path.display().to_string(),
            key: "config".into(),
            message,
        };
        let config = report
            .get_mut("config")
            .map(serde_json::Value::take)
            .ok_or_else(|| {
                campaign_error(
                    "the report carries no campaign (written by a flexcal without campaign files?)"
                        .into(),
                )
            })?;
        let mut campaign: Campaign =
            serde_json::from_value(config).map_err(|e| campaign_error(e.to_string()))?;
        campaign.source = Some(path.to_path_buf());
        campaign.resolve(folder_of(path))?;
        Ok(campaign)
    }

    /// Resolves relative paths against `folder`, refusing empty paths and
    /// input files that do not exist.
    fn resolve(&mut self, folder: &Path) -> Result<()> {
        let origin = self
            .source
            .as_ref()
            .map_or_else(String::new, |p| p.display().to_string());
        for (key, path, role) in self.paths_mut() {
            let error = |message: String| Error::Campaign {
                origin: origin.clone(),
                key: key.clone(),
                message,
            };
            let written = path.display().to_string();
            if written.trim().is_empty() || lexical(path).as_os_str().is_empty() {
                return Err(error(format!(
                    "`{written}` leaves no file name: give the path of a file, relative to {}",
                    folder.display()
                )));
            }
            let resolved = if path.is_absolute() {
                path.clone()
            } else {
                folder.join(&*path)
            };
            if role == Role::Input && !resolved.is_file() {
                let what = if resolved.is_dir() {
                    "is a folder, not a file"
                } else {
                    "names no file"
                };
                return Err(error(format!(
                    "`{written}` {what} (looked for {})",
                    resolved.display()
                )));
            }
            *path = resolved;
        }
        Ok(())
    }
}

/// The key of the TOML line holding byte `at`, with its table: `model.method`
/// for `method = 3` under `[model]`, the table alone for a table's header.
fn key_at(text: &str, at: usize) -> String {
    let line_start = text[..at].rfind('\n').map_or(0, |k| k + 1);
    let line = text[line_start..].lines().next().unwrap_or("");
    let table = text[..line_start]
        .lines()
        .rev()
        .chain(std::iter::once(line))
        .map(str::trim)
        .find(|l| l.starts_with('['))
        .map(|l| l.trim_matches(|c| c == '[' || c == ']').trim().to_string());
    let header = line.trim().starts_with('[');
    let key = line
        .split_once('=')
        .filter(|_| !header)
        .map(|(k, _)| k.trim().trim_matches('"').to_string());
    match (table, key) {
        (_, Some(key)) if key.contains('.') => key,
        (Some(table), Some(key)) => format!("{table}.{key}"),
        (None, Some(key)) => key,
        (Some(_), None) if header => line.trim().trim_matches(['[', ']']).trim().to_string(),
        (Some(table), None) => table,
        (None, None) => "(top level)".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relative_paths_climb_out_of_the_folder() {
        assert_eq!(
            relative_path(Path::new("/a/b/c.csv"), Path::new("/a/d")),
            PathBuf::from("../b/c.csv")
        );
        assert_eq!(
            relative_path(Path::new("/a/b/c.csv"), Path::new("/a/b/")),
            PathBuf::from("c.csv")
        );
        assert_eq!(
            relative_path(Path::new("/a/./x/../b.csv"), Path::new("/a")),
            PathBuf::from("b.csv")
        );
    }

    #[test]
    fn keys_are_named_with_their_table() {
        let text = "[robot]\nname = \"ur10\"\n\n[model]\nmethod = 3\n";
        assert_eq!(key_at(text, text.find("3").unwrap()), "model.method");
        assert_eq!(key_at(text, 1), "robot");
        assert_eq!(key_at("x = 1\n", 0), "x");
    }
}
