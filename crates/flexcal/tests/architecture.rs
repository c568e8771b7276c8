//! The workspace's architecture, checked: no module cycle inside any crate,
//! and no crate dependency against the direction of the design's table
//! (`DESIGN.md`, "Crates": robot-agnostic numerics know nothing of robots,
//! kinematics nothing of elasticity, nothing depends on the twin or the CLI).
//!
//! A module cycle is a module that reaches itself through `crate::x`
//! paths (`use crate::b` in `a`, `crate::a` in `b`, directly or through
//! others); a module is a top-level file or folder of a crate's `src`.
//!
//! Known violations being removed are listed explicitly below; the lists
//! may only shrink: an entry that no longer occurs fails the test too, so
//! that it is deleted when its cycle or arrow is gone.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Module cycles present when this test was written, per crate: the
/// identify / screen / validate cycle of `flexcal-calib` and the
/// description / builtin / model / forward cycle of `flexcal-kinematics`.
const KNOWN_MODULE_CYCLES: &[(&str, &[&str])] = &[
    ("flexcal-calib", &["identify", "screen", "validate"]),
    (
        "flexcal-kinematics",
        &["builtin", "description", "forward", "model"],
    ),
];

/// Allowed dependencies among the workspace crates (`DESIGN.md`'s table);
/// `flexcal-io` (file helpers) is allowed everywhere, and `flexcal-calib`
/// may use the robot-agnostic `flexcal-fuzzy` (its residual model).
const ALLOWED: &[(&str, &[&str])] = &[
    ("flexcal-io", &[]),
    ("flexcal-kinematics", &[]),
    ("flexcal-optim", &[]),
    ("flexcal-fem", &[]),
    ("flexcal-fuzzy", &["flexcal-optim"]),
    (
        "flexcal-calib",
        &["flexcal-kinematics", "flexcal-optim", "flexcal-fuzzy"],
    ),
    (
        "flexcal-elastic",
        &[
            "flexcal-kinematics",
            "flexcal-optim",
            "flexcal-fem",
            "flexcal-fuzzy",
            "flexcal-calib",
        ],
    ),
    (
        "flexcal-compensate",
        &["flexcal-kinematics", "flexcal-optim", "flexcal-elastic"],
    ),
    (
        "flexcal-twin",
        &[
            "flexcal-kinematics",
            "flexcal-optim",
            "flexcal-fem",
            "flexcal-fuzzy",
            "flexcal-calib",
            "flexcal-elastic",
            "flexcal-compensate",
        ],
    ),
    (
        "flexcal",
        &[
            "flexcal-kinematics",
            "flexcal-optim",
            "flexcal-fem",
            "flexcal-fuzzy",
            "flexcal-calib",
            "flexcal-elastic",
            "flexcal-compensate",
            "flexcal-twin",
        ],
    ),
    ("flexcal-cli", &["flexcal"]),
    ("flexcal-py", &["flexcal"]),
];

/// Dependencies against the table present when this test was written:
/// `flexcal-elastic` -> `flexcal-compensate` (the compensation seam moves to
/// the elastic side), and the CLI's direct use of the subject crates (the
/// CLI moves onto the facade).
const KNOWN_FORBIDDEN: &[(&str, &str)] = &[
    ("flexcal-elastic", "flexcal-compensate"),
    ("flexcal-cli", "flexcal-calib"),
    ("flexcal-cli", "flexcal-compensate"),
    ("flexcal-cli", "flexcal-elastic"),
    ("flexcal-cli", "flexcal-fem"),
    ("flexcal-cli", "flexcal-fuzzy"),
    ("flexcal-cli", "flexcal-kinematics"),
    ("flexcal-cli", "flexcal-optim"),
    ("flexcal-cli", "flexcal-twin"),
];

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The identifiers `x` of every `crate::x` in `text`.
fn crate_paths(text: &str) -> BTreeSet<String> {
    let mut found = BTreeSet::new();
    let bytes = text.as_bytes();
    let mut start = 0;
    while let Some(k) = text[start..].find("crate::") {
        let at = start + k;
        let boundary = at == 0 || !(bytes[at - 1].is_ascii_alphanumeric() || bytes[at - 1] == b'_');
        let rest = &text[at + "crate::".len()..];
        let name: String = rest
            .chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
            .collect();
        if boundary && !name.is_empty() {
            found.insert(name);
        }
        start = at + "crate::".len();
    }
    found
}

/// Modules of the crate at `src` that reach themselves through `crate::` paths.
fn modules_on_cycles(src: &Path) -> BTreeSet<String> {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    let mut uses: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for file in files {
        let rel = file.strip_prefix(src).unwrap();
        let first = rel
            .components()
            .next()
            .unwrap()
            .as_os_str()
            .to_string_lossy();
        let module = first.trim_end_matches(".rs").to_string();
        if module == "lib" || module == "main" {
            continue;
        }
        let text = std::fs::read_to_string(&file).unwrap();
        let targets = crate_paths(&text);
        let entry = uses.entry(module.clone()).or_default();
        entry.extend(targets.into_iter().filter(|t| *t != module));
    }
    let modules: BTreeSet<String> = uses.keys().cloned().collect();
    let mut on_cycle = BTreeSet::new();
    for m in &modules {
        // Depth-first search from m's neighbours back to m.
        let mut stack: Vec<&String> = uses[m].iter().filter(|n| modules.contains(*n)).collect();
        let mut seen = BTreeSet::new();
        while let Some(n) = stack.pop() {
            if n == m {
                on_cycle.insert(m.clone());
                break;
            }
            if seen.insert(n.clone()) {
                stack.extend(uses[n].iter().filter(|x| modules.contains(*x)));
            }
        }
    }
    on_cycle
}

fn crates() -> Vec<(String, PathBuf)> {
    let mut out: Vec<(String, PathBuf)> = std::fs::read_dir(workspace().join("crates"))
        .unwrap()
        .flatten()
        .filter(|e| e.path().join("Cargo.toml").is_file())
        .map(|e| (e.file_name().to_string_lossy().to_string(), e.path()))
        .collect();
    out.sort();
    out
}

#[test]
fn no_module_cycle_inside_any_crate_beyond_the_known_ones() {
    let mut problems = Vec::new();
    for (name, dir) in crates() {
        let found = modules_on_cycles(&dir.join("src"));
        let known: BTreeSet<String> = KNOWN_MODULE_CYCLES
            .iter()
            .filter(|(c, _)| *c == name)
            .flat_map(|(_, ms)| ms.iter().map(|m| m.to_string()))
            .collect();
        let new: Vec<&String> = found.difference(&known).collect();
        let gone: Vec<&String> = known.difference(&found).collect();
        if !new.is_empty() {
            problems.push(format!("{name}: modules on a cycle: {new:?}"));
        }
        if !gone.is_empty() {
            problems.push(format!(
                "{name}: no longer on a cycle, delete from KNOWN_MODULE_CYCLES: {gone:?}"
            ));
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// The workspace crates named in the `[dependencies]` table of a manifest.
fn workspace_dependencies(manifest: &str) -> BTreeSet<String> {
    let mut in_deps = false;
    let mut out = BTreeSet::new();
    for line in manifest.lines() {
        let line = line.trim();
        if line.starts_with('[') {
            in_deps = line == "[dependencies]";
            continue;
        }
        if in_deps {
            let name = line.split(['.', '=', ' ']).next().unwrap_or("");
            if name == "flexcal" || name.starts_with("flexcal-") {
                out.insert(name.to_string());
            }
        }
    }
    out
}

#[test]
fn crate_dependencies_follow_the_design_table() {
    let mut problems = Vec::new();
    let mut found_forbidden = BTreeSet::new();
    for (name, dir) in crates() {
        let manifest = std::fs::read_to_string(dir.join("Cargo.toml")).unwrap();
        let Some((_, allowed)) = ALLOWED.iter().find(|(c, _)| *c == name) else {
            problems.push(format!("{name}: not in the design table (add its row)"));
            continue;
        };
        for dep in workspace_dependencies(&manifest) {
            if dep == "flexcal-io" || allowed.contains(&dep.as_str()) {
                continue;
            }
            found_forbidden.insert((name.clone(), dep));
        }
    }
    let known: BTreeSet<(String, String)> = KNOWN_FORBIDDEN
        .iter()
        .map(|(a, b)| (a.to_string(), b.to_string()))
        .collect();
    for (a, b) in found_forbidden.difference(&known) {
        problems.push(format!("{a} -> {b}: against the design table"));
    }
    for (a, b) in known.difference(&found_forbidden) {
        problems.push(format!(
            "{a} -> {b}: no longer present, delete from KNOWN_FORBIDDEN"
        ));
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

#[test]
fn the_cycle_finder_finds_a_cycle_and_ignores_a_chain() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path();
    std::fs::write(src.join("lib.rs"), "mod a; mod b; mod c;").unwrap();
    std::fs::write(src.join("a.rs"), "use crate::b::x;").unwrap();
    std::fs::write(src.join("b.rs"), "fn f() { crate::c::g() }").unwrap();
    std::fs::write(src.join("c.rs"), "// no crate paths").unwrap();
    assert!(modules_on_cycles(src).is_empty());
    std::fs::write(src.join("c.rs"), "use crate::a::y; use mycrate::b;").unwrap();
    let found: Vec<String> = modules_on_cycles(src).into_iter().collect();
    assert_eq!(found, ["a", "b", "c"]);
    assert_eq!(
        workspace_dependencies(
            "[dependencies]\nflexcal-io.workspace = true\nflexcal = { path = \"x\" }\nserde = \"1\"\n[dev-dependencies]\nflexcal-twin.workspace = true\n"
        ),
        BTreeSet::from(["flexcal".to_string(), "flexcal-io".to_string()])
    );
}
