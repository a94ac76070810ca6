//! The file-level import graph of one Rust crate, read with `syn`: a file depends on another
//! when it uses a name defined there, following `use` aliases and re-exports to the file that
//! defines the name. Re-exports in facades (`lib.rs`, `main.rs`, `mod.rs`) are naming, not use,
//! and make no edge; test modules (`#[cfg(test)]`) are left out.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use anyhow::Context;
use syn::visit::Visit;

use super::graph::FileGraph;

/// Re-export chains followed at most this deep (a guard against `pub use` loops).
const MAX_REEXPORT_DEPTH: usize = 16;

/// One module of the crate: a file, or an inline `mod name { ... }` inside one.
#[derive(Debug, Default)]
struct Module {
    file: usize,
    parent: Option<usize>,
    children: BTreeMap<String, usize>,
    /// Names of the items defined here.
    items: BTreeSet<String>,
    /// Local names brought in by `use`, as absolute paths.
    aliases: BTreeMap<String, Vec<String>>,
    /// `pub use` names as absolute paths (followed when resolving).
    reexports: BTreeMap<String, Vec<String>>,
    /// `pub use path::*` targets.
    glob_reexports: Vec<Vec<String>>,
}

/// The crate's modules and the files they live in.
struct Crate {
    graph: FileGraph,
    modules: Vec<Module>,
    /// Per module: the parsed items whose paths are read once every module is known.
    bodies: Vec<(usize, Vec<syn::Item>)>,
}

/// The file graph of the crate whose roots (`lib.rs`, `main.rs`, `bin/*.rs`) are under `src_dir`.
pub fn crate_graph(src_dir: &Path) -> anyhow::Result<FileGraph> {
    let mut krate = Crate { graph: FileGraph::default(), modules: Vec::new(), bodies: Vec::new() };
    let mut roots: Vec<PathBuf> = ["lib.rs", "main.rs"].iter().map(|r| src_dir.join(r)).filter(|p| p.is_file()).collect();
    if let Ok(entries) = std::fs::read_dir(src_dir.join("bin")) {
        let mut bins: Vec<PathBuf> =
            entries.filter_map(Result::ok).map(|e| e.path()).filter(|p| p.extension().is_some_and(|e| e == "rs")).collect();
        bins.sort();
        roots.extend(bins);
    }
    for root in roots {
        let first = krate.modules.len();
        krate.load_file(&root, None, None)?;
        krate.read_uses(first)?;
    }
    Ok(krate.graph)
}

impl Crate {
    /// Loads `path` as a module (and its `mod` declarations, recursively).
    fn load_file(&mut self, path: &Path, parent: Option<usize>, name: Option<&str>) -> anyhow::Result<usize> {
        let text = std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
        let file = syn::parse_file(&text).with_context(|| format!("cannot parse {}", path.display()))?;
        let node = self.graph.node(path.to_path_buf());
        let dir = module_dir(path);
        self.add_module(node, parent, name, file.items, &dir, path)
    }

    fn add_module(
        &mut self,
        file: usize,
        parent: Option<usize>,
        name: Option<&str>,
        items: Vec<syn::Item>,
        dir: &Path,
        path: &Path,
    ) -> anyhow::Result<usize> {
        let index = self.modules.len();
        self.modules.push(Module { file, parent, ..Module::default() });
        if let (Some(p), Some(n)) = (parent, name) {
            self.modules[p].children.insert(n.to_owned(), index);
        }
        let mut kept = Vec::new();
        for item in items {
            if is_test_only(item_attrs(&item)) {
                continue;
            }
            match item {
                syn::Item::Mod(m) => {
                    let child_name = m.ident.to_string();
                    match m.content {
                        Some((_, inner)) => {
                            self.add_module(file, Some(index), Some(&child_name), inner, &dir.join(&child_name), path)?;
                        }
                        None => {
                            let child = child_path(dir, &child_name, &m.attrs)
                                .with_context(|| format!("{}: no file for `mod {child_name};`", path.display()))?;
                            self.load_file(&child, Some(index), Some(&child_name))?;
                        }
                    }
                }
                other => {
                    if let Some(ident) = item_name(&other) {
                        self.modules[index].items.insert(ident);
                    }
                    kept.push(other);
                }
            }
        }
        self.bodies.push((index, kept));
        Ok(index)
    }

    /// Reads the `use` items and code paths of the modules from `first` on, once every module of
    /// their crate root is known.
    fn read_uses(&mut self, first: usize) -> anyhow::Result<()> {
        let bodies: Vec<(usize, Vec<syn::Item>)> = self.bodies.drain(..).filter(|(m, _)| *m >= first).collect();
        // Aliases and re-exports first: code paths and other modules' uses resolve through them.
        for (module, items) in &bodies {
            for item in items {
                if let syn::Item::Use(u) = item {
                    let mut leaves = Vec::new();
                    use_leaves(&u.tree, &mut Vec::new(), &mut leaves);
                    let public = !matches!(u.vis, syn::Visibility::Inherited);
                    for (segments, local) in leaves {
                        let Some(absolute) = self.absolute(*module, &segments) else { continue };
                        match local {
                            Some(local) if public => {
                                self.modules[*module].reexports.insert(local.clone(), absolute.clone());
                                self.modules[*module].aliases.insert(local, absolute);
                            }
                            Some(local) => {
                                self.modules[*module].aliases.insert(local, absolute);
                            }
                            None if public => self.modules[*module].glob_reexports.push(absolute),
                            None => {}
                        }
                    }
                }
            }
        }
        for (module, items) in &bodies {
            let facade = self.is_facade(*module);
            for item in items {
                if let syn::Item::Use(u) = item {
                    let public = !matches!(u.vis, syn::Visibility::Inherited);
                    if public && facade {
                        continue;
                    }
                    let mut leaves = Vec::new();
                    use_leaves(&u.tree, &mut Vec::new(), &mut leaves);
                    for (segments, _) in leaves {
                        let base = &segments[..segments.len() - usize::from(segments.last().is_some_and(|s| s == "*"))];
                        self.add_path_edge(*module, base);
                    }
                } else {
                    let mut paths = PathCollector::default();
                    paths.visit_item(item);
                    for segments in paths.paths {
                        self.add_path_edge(*module, &segments);
                    }
                }
            }
        }
        Ok(())
    }

    /// True for a crate root or a `mod.rs` (a file whose module is not inline).
    fn is_facade(&self, module: usize) -> bool {
        let file = self.modules[module].file;
        let is_file_module = self.modules[module].parent.is_none_or(|p| self.modules[p].file != file);
        let name = self.graph.files[file].file_name().and_then(|n| n.to_str()).unwrap_or("");
        is_file_module && (self.modules[module].parent.is_none() || name == "mod.rs")
    }

    /// Adds the edge of one path used in `module` (a `use` leaf or a path in code).
    fn add_path_edge(&mut self, module: usize, segments: &[String]) {
        let Some(absolute) = self.absolute(module, segments) else { return };
        if let Some((file, name, is_module)) = self.resolve_from(self.root_of(module), &absolute, 0) {
            // A module named alone (`use a::b;`, `pub(super)`) uses nothing yet: the paths
            // through it do.
            if !is_module {
                let from = self.modules[module].file;
                self.graph.add_edge(from, file, &name);
            }
        }
    }

    /// The absolute path (from the crate root, without `crate`) of `segments` as written in
    /// `module`; `None` for paths into other crates, `std` or local bindings.
    fn absolute(&self, module: usize, segments: &[String]) -> Option<Vec<String>> {
        let first = segments.first()?;
        let mut current = module;
        let rest: &[String] = match first.as_str() {
            "crate" => return Some(segments[1..].to_vec()),
            "self" => &segments[1..],
            "super" => {
                let mut i = 0;
                while segments.get(i).is_some_and(|s| s == "super") {
                    current = self.modules[current].parent?;
                    i += 1;
                }
                &segments[i..]
            }
            name => {
                if self.modules[module].children.contains_key(name) {
                    segments
                } else if let Some(target) = self.modules[module].aliases.get(name) {
                    return Some(target.iter().chain(&segments[1..]).cloned().collect());
                } else {
                    return None;
                }
            }
        };
        let mut path = self.path_of(current);
        path.extend(rest.iter().cloned());
        Some(path)
    }

    /// The absolute path of a module.
    fn path_of(&self, mut module: usize) -> Vec<String> {
        let mut names = Vec::new();
        while let Some(parent) = self.modules[module].parent {
            if let Some((name, _)) = self.modules[parent].children.iter().find(|(_, m)| **m == module) {
                names.push(name.clone());
            }
            module = parent;
        }
        names.reverse();
        names
    }

    /// The root module of the crate root that `module` belongs to.
    fn root_of(&self, mut module: usize) -> usize {
        while let Some(parent) = self.modules[module].parent {
            module = parent;
        }
        module
    }

    /// The file that defines what an absolute path names (from the crate root `root`), the name,
    /// and whether it is a module.
    fn resolve_from(&self, root: usize, absolute: &[String], depth: usize) -> Option<(usize, String, bool)> {
        let mut module = root;
        let mut i = 0;
        while let Some(&child) = absolute.get(i).and_then(|s| self.modules[module].children.get(s)) {
            module = child;
            i += 1;
        }
        let here = &self.modules[module];
        let Some(name) = absolute.get(i) else {
            return Some((here.file, absolute.last().cloned().unwrap_or_default(), true));
        };
        if here.items.contains(name) {
            return Some((here.file, name.clone(), false));
        }
        if depth < MAX_REEXPORT_DEPTH {
            if let Some(target) = here.reexports.get(name) {
                let path: Vec<String> = target.iter().chain(&absolute[i + 1..]).cloned().collect();
                return self.resolve_from(root, &path, depth + 1);
            }
            for glob in &here.glob_reexports {
                let path: Vec<String> = glob.iter().chain(&absolute[i..]).cloned().collect();
                if let Some(found) = self.resolve_from(root, &path, depth + 1).filter(|(file, _, _)| *file != here.file) {
                    return Some(found);
                }
            }
        }
        Some((here.file, name.clone(), false))
    }
}

/// The folder that holds the files of `path`'s child modules.
fn module_dir(path: &Path) -> PathBuf {
    let parent = path.parent().unwrap_or(Path::new("."));
    match path.file_name().and_then(|n| n.to_str()) {
        Some("lib.rs" | "main.rs" | "mod.rs") => parent.to_path_buf(),
        _ if parent.file_name().is_some_and(|n| n == "bin") => parent.to_path_buf(),
        _ => parent.join(path.file_stem().unwrap_or_default()),
    }
}

/// The file of `mod name;` declared in a module whose children live in `dir`.
fn child_path(dir: &Path, name: &str, attrs: &[syn::Attribute]) -> Option<PathBuf> {
    for attr in attrs {
        if attr.path().is_ident("path")
            && let syn::Meta::NameValue(nv) = &attr.meta
            && let syn::Expr::Lit(syn::ExprLit { lit: syn::Lit::Str(s), .. }) = &nv.value
        {
            return Some(dir.join(s.value()));
        }
    }
    [dir.join(format!("{name}.rs")), dir.join(name).join("mod.rs")].into_iter().find(|p| p.is_file())
}

/// True for `#[cfg(test)]` (and `#[cfg(all(test, ...))]`-style) attributes.
fn is_test_only(attrs: &[syn::Attribute]) -> bool {
    attrs.iter().any(|a| {
        a.path().is_ident("cfg")
            && a.meta
                .require_list()
                .is_ok_and(|l| l.tokens.to_string().split(|c: char| !c.is_alphanumeric() && c != '_').any(|t| t == "test"))
    })
}

fn item_attrs(item: &syn::Item) -> &[syn::Attribute] {
    match item {
        syn::Item::Const(i) => &i.attrs,
        syn::Item::Enum(i) => &i.attrs,
        syn::Item::Fn(i) => &i.attrs,
        syn::Item::Impl(i) => &i.attrs,
        syn::Item::Macro(i) => &i.attrs,
        syn::Item::Mod(i) => &i.attrs,
        syn::Item::Static(i) => &i.attrs,
        syn::Item::Struct(i) => &i.attrs,
        syn::Item::Trait(i) => &i.attrs,
        syn::Item::Type(i) => &i.attrs,
        syn::Item::Union(i) => &i.attrs,
        syn::Item::Use(i) => &i.attrs,
        _ => &[],
    }
}

/// The name an item defines in its module, if any.
fn item_name(item: &syn::Item) -> Option<String> {
    let ident = match item {
        syn::Item::Const(i) => &i.ident,
        syn::Item::Enum(i) => &i.ident,
        syn::Item::Fn(i) => &i.sig.ident,
        syn::Item::Macro(i) => i.ident.as_ref()?,
        syn::Item::Static(i) => &i.ident,
        syn::Item::Struct(i) => &i.ident,
        syn::Item::Trait(i) => &i.ident,
        syn::Item::TraitAlias(i) => &i.ident,
        syn::Item::Type(i) => &i.ident,
        syn::Item::Union(i) => &i.ident,
        _ => return None,
    };
    Some(ident.to_string())
}

/// The leaves of a `use` tree: each full path with the local name it binds (`None` for a glob,
/// whose path then ends in `*`). `use a::b::{self}` binds `b` to `a::b`.
fn use_leaves(tree: &syn::UseTree, prefix: &mut Vec<String>, out: &mut Vec<(Vec<String>, Option<String>)>) {
    match tree {
        syn::UseTree::Path(p) => {
            prefix.push(p.ident.to_string());
            use_leaves(&p.tree, prefix, out);
            prefix.pop();
        }
        syn::UseTree::Name(n) => {
            let name = n.ident.to_string();
            if name == "self" {
                if let Some(last) = prefix.last().cloned() {
                    out.push((prefix.clone(), Some(last)));
                }
            } else {
                out.push((prefix.iter().cloned().chain([name.clone()]).collect(), Some(name)));
            }
        }
        syn::UseTree::Rename(r) => {
            let path: Vec<String> =
                if r.ident == "self" { prefix.clone() } else { prefix.iter().cloned().chain([r.ident.to_string()]).collect() };
            if r.rename != "_" {
                out.push((path, Some(r.rename.to_string())));
            }
        }
        syn::UseTree::Glob(_) => out.push((prefix.iter().cloned().chain(["*".to_owned()]).collect(), None)),
        syn::UseTree::Group(g) => {
            for t in &g.items {
                use_leaves(t, prefix, out);
            }
        }
    }
}

/// Every path written in an item's code and types (not in macro bodies, not in nested `use`
/// items, not in `#[cfg(test)]` code).
#[derive(Default)]
struct PathCollector {
    paths: Vec<Vec<String>>,
}

impl<'ast> Visit<'ast> for PathCollector {
    fn visit_path(&mut self, path: &'ast syn::Path) {
        self.paths.push(path.segments.iter().map(|s| s.ident.to_string()).collect());
        syn::visit::visit_path(self, path);
    }

    fn visit_item_use(&mut self, _: &'ast syn::ItemUse) {}

    fn visit_item_mod(&mut self, _: &'ast syn::ItemMod) {}

    fn visit_item_fn(&mut self, item: &'ast syn::ItemFn) {
        if !is_test_only(&item.attrs) {
            syn::visit::visit_item_fn(self, item);
        }
    }

    fn visit_impl_item_fn(&mut self, item: &'ast syn::ImplItemFn) {
        if !is_test_only(&item.attrs) {
            syn::visit::visit_impl_item_fn(self, item);
        }
    }

    fn visit_attribute(&mut self, _: &'ast syn::Attribute) {}

    fn visit_visibility(&mut self, _: &'ast syn::Visibility) {}
}
