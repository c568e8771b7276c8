//! No module cycle inside the crate: no module uses another that (directly or
//! through others) uses it back. Dependencies are read from the sources:
//! `crate::module` paths in code (not in comments), and `crate::Item` paths resolved through the
//! crate root's `pub use module::Item` re-exports.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

fn rust_files(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// Identifiers following `crate::` in `text`, with the names inside
/// `crate::{a, b::c}` groups.
fn crate_paths(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut rest = text;
    while let Some(at) = rest.find("crate::") {
        rest = &rest[at + "crate::".len()..];
        if let Some(group) = rest.strip_prefix('{') {
            let end = group.find('}').unwrap_or(group.len());
            for part in group[..end].split(',') {
                let name: String = part
                    .trim()
                    .chars()
                    .take_while(|c| c.is_alphanumeric() || *c == '_')
                    .collect();
                if !name.is_empty() {
                    out.push(name);
                }
            }
        } else {
            let name: String = rest
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            out.push(name);
        }
    }
    out
}

#[test]
fn the_crate_has_no_module_cycle() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let lib = std::fs::read_to_string(src.join("lib.rs")).unwrap();
    // Item -> module, from `pub use module::{Item, ...};` in lib.rs.
    let mut item_module: BTreeMap<String, String> = BTreeMap::new();
    let mut modules = BTreeSet::new();
    for statement in lib.split(';') {
        let s = statement.trim();
        if let Some(m) = s
            .strip_prefix("mod ")
            .or_else(|| s.strip_prefix("pub mod "))
        {
            modules.insert(m.trim().to_string());
        }
        if let Some(rest) = s.split("pub use ").nth(1) {
            let (module, items) = rest.split_once("::").unwrap();
            for item in items.trim_matches(|c| c == '{' || c == '}').split(',') {
                let item = item.trim();
                if !item.is_empty() {
                    item_module.insert(item.to_string(), module.trim().to_string());
                }
            }
        }
    }
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let mut uses: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for file in files {
        let relative = file.strip_prefix(&src).unwrap();
        let top = relative
            .components()
            .next()
            .unwrap()
            .as_os_str()
            .to_string_lossy()
            .trim_end_matches(".rs")
            .to_string();
        if top == "lib" {
            continue;
        }
        // Code only: doc links name items without making the module use them.
        let text: String = std::fs::read_to_string(&file)
            .unwrap()
            .lines()
            .filter(|l| !l.trim_start().starts_with("//"))
            .collect::<Vec<_>>()
            .join("\n");
        for name in crate_paths(&text) {
            let target = if modules.contains(&name) {
                Some(name)
            } else {
                item_module.get(&name).cloned()
            };
            if let Some(target) = target.filter(|t| *t != top) {
                uses.entry(top.clone()).or_default().insert(target);
            }
        }
    }
    // Depth-first search for a back edge.
    fn visit(
        m: &str,
        uses: &BTreeMap<String, BTreeSet<String>>,
        stack: &mut Vec<String>,
        done: &mut BTreeSet<String>,
    ) {
        if let Some(at) = stack.iter().position(|s| s == m) {
            panic!("module cycle: {} -> {m}", stack[at..].join(" -> "));
        }
        if done.contains(m) {
            return;
        }
        stack.push(m.to_string());
        for next in uses.get(m).into_iter().flatten() {
            visit(next, uses, stack, done);
        }
        stack.pop();
        done.insert(m.to_string());
    }
    let mut done = BTreeSet::new();
    for m in &modules {
        visit(m, &uses, &mut Vec::new(), &mut done);
    }
    println!("{uses:?}");
    assert!(
        uses.len() >= 5,
        "the dependency scan found too little: {uses:?}"
    );
}
