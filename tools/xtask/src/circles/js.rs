//! The import graph of the page's ES modules: `import ... from './x.js'`, `export ... from
//! './x.js'` and side-effect imports, relative specifiers only (a worker started with
//! `new Worker(...)` is not an import).

use std::path::{Component, Path, PathBuf};

use anyhow::Context;

use super::graph::FileGraph;

/// The graph of the `.js` and `.mjs` files directly in `dir`.
pub fn module_graph(dir: &Path) -> anyhow::Result<FileGraph> {
    let mut graph = FileGraph::default();
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .with_context(|| format!("cannot list {}", dir.display()))?
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "js" || e == "mjs"))
        .collect();
    files.sort();
    for file in &files {
        graph.node(file.clone());
    }
    for file in &files {
        let text = std::fs::read_to_string(file).with_context(|| format!("cannot read {}", file.display()))?;
        let from = graph.node(file.clone());
        for specifier in relative_imports(&strip_comments(&text)) {
            let target = normalize(&file.parent().unwrap_or(dir).join(&specifier));
            if files.contains(&target) {
                let to = graph.node(target);
                graph.add_edge(from, to, &specifier);
            }
        }
    }
    Ok(graph)
}

/// The text without `//` and `/* */` comments (string contents are kept; a `//` inside a string
/// is rare enough in import lines not to matter).
fn strip_comments(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while !rest.is_empty() {
        if let Some(after) = rest.strip_prefix("/*") {
            rest = after.find("*/").map_or("", |end| &after[end + 2..]);
        } else if rest.starts_with("//") && !out.ends_with(':') {
            rest = rest.find('\n').map_or("", |end| &rest[end..]);
        } else {
            let c = rest.chars().next().unwrap_or(' ');
            out.push(c);
            rest = &rest[c.len_utf8()..];
        }
    }
    out
}

/// Specifiers starting with `.` after `from` or a bare `import`.
fn relative_imports(text: &str) -> Vec<String> {
    let mut found = Vec::new();
    for keyword in ["from", "import"] {
        let mut start = 0;
        while let Some(at) = text[start..].find(keyword) {
            let begin = start + at;
            start = begin + keyword.len();
            let before_ok = text[..begin].chars().next_back().is_none_or(|c| !c.is_alphanumeric() && c != '_' && c != '.');
            let rest = text[start..].trim_start();
            let Some(quote) = rest.chars().next().filter(|c| *c == '\'' || *c == '"') else { continue };
            if !before_ok || !text[start..].starts_with(char::is_whitespace) {
                continue;
            }
            if let Some(end) = rest[1..].find(quote) {
                let specifier = &rest[1..1 + end];
                if specifier.starts_with('.') {
                    found.push(specifier.to_owned());
                }
            }
        }
    }
    found
}

/// `a/./b/../c` as `a/c`.
fn normalize(path: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for component in path.components() {
        match component {
            Component::CurDir => {}
            Component::ParentDir => {
                out.pop();
            }
            other => out.push(other),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn imports_exports_and_side_effects_are_read_comments_are_not() {
        let text = "import { a,\n  b } from './a.js';\nexport * from \"./b.js\";\nimport './c.js';\n// import x from './d.js';\n/* import y from './e.js' */\nimport z from 'https://x/y.js';\nconst w = new Worker(new URL('./worker.js', import.meta.url));";
        assert_eq!(relative_imports(&strip_comments(text)), vec!["./a.js", "./b.js", "./c.js"]);
    }

    #[test]
    fn a_circle_between_modules_is_an_edge_pair() {
        let dir = std::env::temp_dir().join(format!("xtask-js-circle-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("a.js"), "import { b } from './b.js';\nexport const a = 1;\n").unwrap();
        std::fs::write(dir.join("b.js"), "import { a } from './a.js';\nexport const b = 2;\n").unwrap();
        std::fs::write(dir.join("c.js"), "import { a } from './a.js';\n").unwrap();
        let graph = module_graph(&dir).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        assert_eq!(graph.circles().len(), 1);
        assert_eq!(graph.circles()[0].len(), 2);
    }
}
