//! No module cycles inside flexcal-calib: module A uses `crate::b` and b
//! uses `crate::a`, directly or through others. Read from the sources: the
//! `crate::<module>` paths in the code (not the comments) of each file
//! under `src/` (items re-exported at
//! the crate root, `crate::Name`, are resolved to the module that defines
//! them through `lib.rs`'s `pub use` lines).

use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;

fn sources() -> BTreeMap<String, String> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("src");
    std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "rs"))
        .map(|p| {
            (
                p.file_stem().unwrap().to_string_lossy().into_owned(),
                std::fs::read_to_string(&p).unwrap(),
            )
        })
        .collect()
}

/// Identifiers following `crate::` in `text`, with `crate::{a, b::c}` groups
/// expanded to their first segments.
fn crate_paths(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut rest = text;
    while let Some(i) = rest.find("crate::") {
        rest = &rest[i + 7..];
        if let Some(group) = rest.strip_prefix('{') {
            let end = group.find('}').unwrap_or(group.len());
            for item in group[..end].split(',') {
                let first: String = item
                    .trim()
                    .chars()
                    .take_while(|c| c.is_alphanumeric() || *c == '_')
                    .collect();
                if !first.is_empty() {
                    out.push(first);
                }
            }
        } else {
            let first: String = rest
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            out.push(first);
        }
    }
    out
}

#[test]
fn flexcal_calib_has_no_module_cycle() {
    let files = sources();
    let lib = &files["lib"];
    let modules: BTreeSet<String> = files.keys().filter(|k| *k != "lib").cloned().collect();
    // Root re-exports: `pub use module::{A, B}` / `pub use module::A`.
    let mut owner: BTreeMap<String, String> = BTreeMap::new();
    let mut text = lib.as_str();
    while let Some(i) = text.find("pub use ") {
        text = &text[i + 8..];
        let end = text.find(';').unwrap_or(text.len());
        let statement = &text[..end];
        if let Some((module, items)) = statement.split_once("::") {
            let items = items.trim_start_matches('{').trim_end_matches('}');
            for item in items.split(',') {
                let name = item.trim();
                if !name.is_empty() {
                    owner.insert(name.to_string(), module.trim().to_string());
                }
            }
        }
    }
    let mut edges: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (module, text) in &files {
        if module == "lib" {
            continue;
        }
        // Test modules may use anything; doc links are not dependencies.
        let code: String = text
            .split("#[cfg(test)]")
            .next()
            .unwrap_or(text)
            .lines()
            .filter(|l| !l.trim_start().starts_with("//"))
            .collect::<Vec<_>>()
            .join("\n");
        for path in crate_paths(&code) {
            let target = if modules.contains(&path) {
                Some(path)
            } else {
                owner.get(&path).cloned()
            };
            if let Some(target) = target {
                if &target != module {
                    edges.entry(module.clone()).or_default().insert(target);
                }
            }
        }
    }
    // Depth-first search for a cycle.
    fn visit(
        node: &str,
        edges: &BTreeMap<String, BTreeSet<String>>,
        stack: &mut Vec<String>,
        done: &mut BTreeSet<String>,
    ) -> Option<Vec<String>> {
        if let Some(start) = stack.iter().position(|s| s == node) {
            let mut cycle = stack[start..].to_vec();
            cycle.push(node.to_string());
            return Some(cycle);
        }
        if done.contains(node) {
            return None;
        }
        stack.push(node.to_string());
        for next in edges.get(node).into_iter().flatten() {
            if let Some(cycle) = visit(next, edges, stack, done) {
                return Some(cycle);
            }
        }
        stack.pop();
        done.insert(node.to_string());
        None
    }
    let mut done = BTreeSet::new();
    for module in &modules {
        let cycle = visit(module, &edges, &mut Vec::new(), &mut done);
        assert!(
            cycle.is_none(),
            "module cycle: {}",
            cycle.unwrap().join(" -> ")
        );
    }
    // The check sees the dependencies it should.
    assert!(edges["validate"].contains("identify"), "{edges:?}");
    assert!(edges["identify"].contains("metrics"), "{edges:?}");
}
