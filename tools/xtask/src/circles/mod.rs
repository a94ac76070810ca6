//! `cargo xtask circles` (and a step of `cargo xtask test`): no import circle inside any crate
//! or among the page's modules. A circle is a set of files each of which, through the others,
//! uses a name defined in itself; it makes the files one unit that cannot be read, tested or
//! moved apart. docs/ARCHITECTURE.md says how each crate is layered.

mod graph;
mod js;
mod rust;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use graph::FileGraph;

use crate::util::workspace_root;

/// Checks every crate under `crates/` and `tools/`, and `web/src`; fails naming each circle
/// and what ties it.
pub fn run() -> anyhow::Result<f64> {
    println!("\n==> no import circle inside a crate or the page (docs/ARCHITECTURE.md)");
    let start = std::time::Instant::now();
    let root = workspace_root();
    let mut report = String::new();
    let mut units = 0;
    for (name, graph) in unit_graphs(&root)? {
        units += 1;
        for circle in graph.circles() {
            report.push_str(&describe(&root, &name, &graph, &circle));
        }
    }
    if !report.is_empty() {
        anyhow::bail!("import circles found:\n{report}");
    }
    println!("    {units} crates and the page: no circle");
    Ok(start.elapsed().as_secs_f64())
}

/// The file graph of each crate (`crates/*`, `tools/*` with a `src/`) and of `web/src`.
fn unit_graphs(root: &Path) -> anyhow::Result<Vec<(String, FileGraph)>> {
    let mut dirs: Vec<PathBuf> = Vec::new();
    for parent in ["crates", "tools"] {
        if let Ok(entries) = std::fs::read_dir(root.join(parent)) {
            dirs.extend(
                entries.filter_map(Result::ok).map(|e| e.path()).filter(|p| p.join("Cargo.toml").is_file() && p.join("src").is_dir()),
            );
        }
    }
    dirs.sort();
    let mut graphs = Vec::new();
    for dir in dirs {
        let name = dir.strip_prefix(root).unwrap_or(&dir).display().to_string();
        graphs.push((name, rust::crate_graph(&dir.join("src"))?));
    }
    let web = root.join("web/src");
    if web.is_dir() {
        graphs.push(("web/src".to_owned(), js::module_graph(&web)?));
    }
    Ok(graphs)
}

/// One circle in words: its files, then each tie `a -> b: names`.
fn describe(root: &Path, unit: &str, graph: &FileGraph, circle: &[usize]) -> String {
    let short = |i: usize| graph.files[i].strip_prefix(root).unwrap_or(&graph.files[i]).display().to_string();
    let mut text = format!("  {unit}: {}\n", circle.iter().map(|&i| short(i)).collect::<Vec<_>>().join(", "));
    for (&(a, b), names) in &graph.edges {
        if circle.contains(&a) && circle.contains(&b) {
            let names: Vec<&str> = names.iter().map(String::as_str).collect();
            let _ = writeln!(text, "    {} -> {}: {}", short(a), short(b), names.join(", "));
        }
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A crate laid out in a fresh temporary folder from `(path, text)` pairs.
    fn crate_with(files: &[(&str, &str)]) -> (PathBuf, FileGraph) {
        static NEXT: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
        let n = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let dir = std::env::temp_dir().join(format!("xtask-circles-{}-{n}", std::process::id()));
        for (path, text) in files {
            let path = dir.join(path);
            std::fs::create_dir_all(path.parent().unwrap()).unwrap();
            std::fs::write(path, text).unwrap();
        }
        let graph = rust::crate_graph(&dir).unwrap();
        (dir, graph)
    }

    fn circles_of(files: &[(&str, &str)]) -> Vec<Vec<String>> {
        let (dir, graph) = crate_with(files);
        let named = graph
            .circles()
            .iter()
            .map(|c| c.iter().map(|&i| graph.files[i].strip_prefix(&dir).unwrap().display().to_string()).collect())
            .collect();
        std::fs::remove_dir_all(&dir).unwrap();
        named
    }

    #[test]
    fn two_files_using_each_others_items_are_a_circle() {
        let circles = circles_of(&[
            ("lib.rs", "mod a;\nmod b;\n"),
            ("a.rs", "use crate::b::B;\npub struct A(B);\n"),
            ("b.rs", "pub struct B;\npub fn f() -> usize { std::mem::size_of::<crate::a::A>() }\n"),
        ]);
        assert_eq!(circles, vec![vec!["a.rs".to_owned(), "b.rs".to_owned()]]);
    }

    #[test]
    fn a_parent_that_re_exports_its_child_is_no_circle() {
        let circles = circles_of(&[
            ("lib.rs", "pub mod render;\n"),
            ("render/mod.rs", "mod frame;\npub use frame::Frame;\npub const SIZE: usize = 4;\n"),
            ("render/frame.rs", "use super::SIZE;\npub struct Frame([u8; SIZE]);\n"),
        ]);
        assert!(circles.is_empty(), "{circles:?}");
    }

    #[test]
    fn uses_are_followed_through_re_exports_and_module_aliases() {
        // a uses b's item through the parent's re-export; b uses a's item through a module alias.
        let circles = circles_of(&[
            ("lib.rs", "pub mod m;\n"),
            ("m/mod.rs", "mod a;\nmod b;\npub use b::Beta;\n"),
            ("m/a.rs", "use crate::m::Beta;\npub fn alpha() -> Option<Beta> { None }\n"),
            ("m/b.rs", "use super::a;\npub struct Beta;\npub fn g() { let _ = a::alpha(); }\n"),
        ]);
        assert_eq!(circles, vec![vec!["m/a.rs".to_owned(), "m/b.rs".to_owned()]]);
    }

    #[test]
    fn test_modules_are_left_out() {
        let circles = circles_of(&[
            ("lib.rs", "mod a;\nmod b;\n"),
            ("a.rs", "pub struct A;\n#[cfg(test)]\nmod tests { use crate::b::B; }\n"),
            ("b.rs", "pub struct B(crate::a::A);\n"),
        ]);
        assert!(circles.is_empty(), "{circles:?}");
    }

    #[test]
    fn a_missing_module_file_is_an_error_naming_it() {
        let dir = std::env::temp_dir().join(format!("xtask-circles-missing-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("lib.rs"), "mod gone;\n").unwrap();
        let error = rust::crate_graph(&dir).unwrap_err();
        std::fs::remove_dir_all(&dir).unwrap();
        assert!(format!("{error:#}").contains("mod gone;"), "{error:#}");
    }
}
