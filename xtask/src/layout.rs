//! `cargo xtask layout`: three checks of the workspace's layout, read from
//! the sources with `syn` (nothing is compiled).
//!
//! 1. **Import cycles** (the check that fails). Every crate of every
//!    workspace member (`src/lib.rs`, `src/main.rs`, `src/bin/*`, `tests/*`,
//!    `examples/*`, `benches/*`) is parsed into its module tree (`mod m;`
//!    followed to `m.rs` or `m/mod.rs`, `#[path]` honoured, inline modules
//!    kept as modules). Each path written in a module — `use` trees, paths
//!    in types and expressions, and `crate::`/`super::`/`self::` token runs
//!    inside macro calls — that starts with `crate`, `self`, `super` or a
//!    child module's name is resolved to the module that defines what it
//!    names, following `use` re-exports (named and glob) of the modules on
//!    the way. A reference from module `u` to module `v` is an edge between
//!    the two children of their nearest common ancestor that contain them
//!    (none if one contains the other: a parent and its children are one
//!    unit). A cycle is a strongly connected set of siblings (at every
//!    level of the tree); each is reported with its members and the
//!    shortest loop through the first of them, every edge of the loop with
//!    the first place (file:line) that makes it, the last one being the
//!    edge that closes it. Code under
//!    `#[cfg(test)]` is left out: a module's tests may use its neighbours.
//! 2. **One public path per item of the core** (fails). The core is the
//!    `beamest` library without `board` (the board support the binaries
//!    use). A module is *exported* if it and every module above it are
//!    declared `pub mod`. A `pub use` in an exported module whose target is
//!    declared `pub` in an exported module (or is an exported module) gives
//!    that item a second public path, and is reported with its place. A
//!    module whose items its parent re-exports is therefore `pub(crate)`,
//!    and a module kept `pub` as a namespace (`estimator::robust`) is not
//!    re-exported from above.
//! 3. **`pub` items of the core that nothing outside it names** (reported;
//!    fails only with `--deny-unused-pub`). Its
//!    items declared `pub` (not `pub(crate)`) outside `#[cfg(test)]` are
//!    collected, in exported modules and, in the others, those an exported
//!    module re-exports (and the methods of such a module): module-level `fn`, `struct`, `enum`, `union`, `const`,
//!    `static`, `type`, `trait`, `mod`, exported `macro_rules!`, and the
//!    `pub` functions, constants and types of inherent `impl` blocks. One is
//!    *used* if its identifier occurs as a token in any file of another
//!    crate (beamctl, host-tests, xtask, the binaries `src/bin/*`, every
//!    test, example and bench) or in `board`, under a name a `pub use … as` gives it, or
//!    in the public face of a used item (its signature, `pub` fields,
//!    variant fields, type; to a fixed point): a textual heuristic on
//!    identifiers, so a name shared with something else (`new`, `len`)
//!    counts as used.

use std::collections::{BTreeMap, BTreeSet, HashMap, VecDeque};
use std::fmt;
use std::fs;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use proc_macro2::{TokenStream, TokenTree};
use quote::ToTokens;
use syn::visit::{self, Visit};
use syn::{Attribute, ImplItem, Item, UseTree, Visibility};

use crate::workspace_root;

/// A module of one crate.
#[derive(Debug)]
struct Module {
    /// Path from the crate root (empty for the root).
    path: Vec<String>,
    /// The file it is written in.
    file: PathBuf,
    parent: Option<usize>,
    children: BTreeMap<String, usize>,
    /// Names of the items it declares (modules excepted).
    items: BTreeSet<String>,
    /// Non-private `use`s: the name they bring in and the path they name.
    reexports: Vec<(String, Vec<String>)>,
    /// Non-private glob `use`s: the path of the module they open.
    globs: Vec<Vec<String>>,
    /// Paths written in it (first segment `crate`, `self`, `super` or a
    /// child's name), with their line.
    refs: Vec<(Vec<String>, usize)>,
    /// Declared `pub mod` (not `pub(crate)` or narrower) in its parent; the
    /// root counts as public.
    public: bool,
    /// Names of the items it declares `pub`.
    pub_items: BTreeSet<String>,
    /// Its `pub use`s (not `pub(crate)`): name, path, line.
    pub_uses: Vec<(String, Vec<String>, usize)>,
}

/// One crate's module tree (module 0 is the root).
#[derive(Debug)]
pub struct Crate {
    /// `member/target`, e.g. `beamctl/lib` or `host-tests/tests/link`.
    name: String,
    modules: Vec<Module>,
}

/// `#[cfg(test)]` on an item.
fn is_cfg_test(attrs: &[Attribute]) -> bool {
    attrs.iter().any(|a| {
        a.path().is_ident("cfg")
            && a.meta
                .require_list()
                .is_ok_and(|l| l.tokens.to_string().trim() == "test")
    })
}

/// The value of `#[path = "…"]`, if any.
fn path_attr(attrs: &[Attribute]) -> Option<String> {
    attrs.iter().find_map(|a| match &a.meta {
        syn::Meta::NameValue(nv) if nv.path.is_ident("path") => match &nv.value {
            syn::Expr::Lit(syn::ExprLit {
                lit: syn::Lit::Str(s),
                ..
            }) => Some(s.value()),
            _ => None,
        },
        _ => None,
    })
}

/// `use` trees as full paths: (path, name brought in); a glob ends in `*`.
fn use_paths(tree: &UseTree, prefix: &mut Vec<String>, out: &mut Vec<(Vec<String>, String)>) {
    match tree {
        UseTree::Path(p) => {
            prefix.push(p.ident.to_string());
            use_paths(&p.tree, prefix, out);
            prefix.pop();
        }
        UseTree::Name(n) => {
            let name = n.ident.to_string();
            if name == "self" {
                let last = prefix.last().cloned().unwrap_or_default();
                out.push((prefix.clone(), last));
            } else {
                let mut p = prefix.clone();
                p.push(name.clone());
                out.push((p, name));
            }
        }
        UseTree::Rename(r) => {
            let mut p = prefix.clone();
            let name = r.ident.to_string();
            if name != "self" {
                p.push(name);
            }
            out.push((p, r.rename.to_string()));
        }
        UseTree::Glob(_) => {
            let mut p = prefix.clone();
            p.push("*".into());
            out.push((p, "*".into()));
        }
        UseTree::Group(g) => {
            for t in &g.items {
                use_paths(t, prefix, out);
            }
        }
    }
}

/// Collects the paths written in one module's items (not its child
/// modules', which are modules of their own).
struct PathCollector {
    paths: Vec<(Vec<String>, usize)>,
}

impl PathCollector {
    /// `crate :: a :: b`-like runs in a macro's tokens.
    fn scan_tokens(&mut self, tokens: TokenStream) {
        let flat: Vec<TokenTree> = tokens.into_iter().collect();
        let mut i = 0;
        while i < flat.len() {
            match &flat[i] {
                TokenTree::Group(g) => self.scan_tokens(g.stream()),
                TokenTree::Ident(id) if matches!(id.to_string().as_str(), "crate" | "super") => {
                    let line = id.span().start().line;
                    let mut path = vec![id.to_string()];
                    let mut j = i + 1;
                    // `::` is two `:` puncts.
                    while j + 2 < flat.len() {
                        match (&flat[j], &flat[j + 1], flat.get(j + 2)) {
                            (
                                TokenTree::Punct(a),
                                TokenTree::Punct(b),
                                Some(TokenTree::Ident(n)),
                            ) if a.as_char() == ':' && b.as_char() == ':' => {
                                path.push(n.to_string());
                                j += 3;
                            }
                            _ => break,
                        }
                    }
                    if path.len() > 1 {
                        self.paths.push((path, line));
                    }
                    i = j;
                    continue;
                }
                _ => {}
            }
            i += 1;
        }
    }
}

impl<'ast> Visit<'ast> for PathCollector {
    fn visit_item(&mut self, i: &'ast Item) {
        if let Item::Mod(_) = i {
            return;
        }
        if item_attrs(i).is_some_and(is_cfg_test) {
            return;
        }
        visit::visit_item(self, i);
    }

    fn visit_impl_item(&mut self, i: &'ast ImplItem) {
        let attrs = match i {
            ImplItem::Fn(f) => &f.attrs[..],
            ImplItem::Const(c) => &c.attrs[..],
            ImplItem::Type(t) => &t.attrs[..],
            _ => &[][..],
        };
        if !is_cfg_test(attrs) {
            visit::visit_impl_item(self, i);
        }
    }

    fn visit_item_use(&mut self, u: &'ast syn::ItemUse) {
        let mut out = Vec::new();
        use_paths(&u.tree, &mut Vec::new(), &mut out);
        let line = u.use_token.span.start().line;
        for (mut p, _) in out {
            if p.last().is_some_and(|s| s == "*") {
                p.pop();
            }
            self.paths.push((p, line));
        }
    }

    fn visit_path(&mut self, p: &'ast syn::Path) {
        if p.leading_colon.is_none() {
            let segs: Vec<String> = p.segments.iter().map(|s| s.ident.to_string()).collect();
            let line = p
                .segments
                .first()
                .map_or(0, |s| s.ident.span().start().line);
            self.paths.push((segs, line));
        }
        visit::visit_path(self, p);
    }

    fn visit_macro(&mut self, m: &'ast syn::Macro) {
        self.scan_tokens(m.tokens.clone());
        visit::visit_macro(self, m);
    }
}

/// The attributes of an item.
fn item_attrs(i: &Item) -> Option<&[Attribute]> {
    Some(match i {
        Item::Const(x) => &x.attrs,
        Item::Enum(x) => &x.attrs,
        Item::ExternCrate(x) => &x.attrs,
        Item::Fn(x) => &x.attrs,
        Item::ForeignMod(x) => &x.attrs,
        Item::Impl(x) => &x.attrs,
        Item::Macro(x) => &x.attrs,
        Item::Mod(x) => &x.attrs,
        Item::Static(x) => &x.attrs,
        Item::Struct(x) => &x.attrs,
        Item::Trait(x) => &x.attrs,
        Item::TraitAlias(x) => &x.attrs,
        Item::Type(x) => &x.attrs,
        Item::Union(x) => &x.attrs,
        Item::Use(x) => &x.attrs,
        _ => return None,
    })
}

/// The declared name of an item (modules and `use`s excepted).
/// The visibility of an item that has one.
fn item_vis(i: &Item) -> Option<&Visibility> {
    match i {
        Item::Const(x) => Some(&x.vis),
        Item::Enum(x) => Some(&x.vis),
        Item::Fn(x) => Some(&x.vis),
        Item::Static(x) => Some(&x.vis),
        Item::Struct(x) => Some(&x.vis),
        Item::Trait(x) => Some(&x.vis),
        Item::Type(x) => Some(&x.vis),
        Item::Union(x) => Some(&x.vis),
        Item::Mod(x) => Some(&x.vis),
        _ => None,
    }
}

fn item_name(i: &Item) -> Option<String> {
    Some(match i {
        Item::Const(x) => x.ident.to_string(),
        Item::Enum(x) => x.ident.to_string(),
        Item::Fn(x) => x.sig.ident.to_string(),
        Item::Macro(x) => x.ident.as_ref()?.to_string(),
        Item::Static(x) => x.ident.to_string(),
        Item::Struct(x) => x.ident.to_string(),
        Item::Trait(x) => x.ident.to_string(),
        Item::TraitAlias(x) => x.ident.to_string(),
        Item::Type(x) => x.ident.to_string(),
        Item::Union(x) => x.ident.to_string(),
        _ => return None,
    })
}

fn parse_file(file: &Path) -> Result<syn::File, String> {
    let text = fs::read_to_string(file).map_err(|e| format!("reading {}: {e}", file.display()))?;
    syn::parse_file(&text).map_err(|e| {
        let at = e.span().start();
        format!("{}:{}:{}: {e}", file.display(), at.line, at.column + 1)
    })
}

impl Crate {
    /// Parse the crate whose root file is `root`.
    pub fn load(name: &str, root: &Path) -> Result<Self, String> {
        let mut c = Crate {
            name: name.to_string(),
            modules: Vec::new(),
        };
        let file = parse_file(root)?;
        let dir = root.parent().unwrap_or(Path::new(".")).to_path_buf();
        c.add_module(
            Vec::new(),
            root.to_path_buf(),
            None,
            true,
            &file.items,
            &dir,
        )?;
        Ok(c)
    }

    /// Add a module with its `items`; `dir` is where its `mod m;` files are.
    fn add_module(
        &mut self,
        path: Vec<String>,
        file: PathBuf,
        parent: Option<usize>,
        public: bool,
        items: &[Item],
        dir: &Path,
    ) -> Result<usize, String> {
        let idx = self.modules.len();
        let mut collector = PathCollector { paths: Vec::new() };
        for i in items {
            collector.visit_item(i);
        }
        let mut m = Module {
            path: path.clone(),
            file: file.clone(),
            parent,
            children: BTreeMap::new(),
            items: BTreeSet::new(),
            reexports: Vec::new(),
            globs: Vec::new(),
            refs: collector.paths,
            public,
            pub_items: BTreeSet::new(),
            pub_uses: Vec::new(),
        };
        for i in items {
            if item_attrs(i).is_some_and(is_cfg_test) {
                continue;
            }
            if let Some(n) = item_name(i) {
                if item_vis(i).is_some_and(is_pub) {
                    m.pub_items.insert(n.clone());
                }
                m.items.insert(n);
            }
            if let Item::Use(u) = i {
                if !matches!(u.vis, Visibility::Inherited) {
                    let line = u.use_token.span.start().line;
                    let mut out = Vec::new();
                    use_paths(&u.tree, &mut Vec::new(), &mut out);
                    for (mut p, name) in out {
                        if name == "*" {
                            p.pop();
                            m.globs.push(p);
                        } else {
                            if is_pub(&u.vis) {
                                m.pub_uses.push((name.clone(), p.clone(), line));
                            }
                            m.reexports.push((name, p));
                        }
                    }
                }
            }
        }
        self.modules.push(m);
        for i in items {
            let Item::Mod(md) = i else { continue };
            if is_cfg_test(&md.attrs) {
                continue;
            }
            let name = md.ident.to_string();
            let mut child_path = path.clone();
            child_path.push(name.clone());
            let child = match &md.content {
                Some((_, inner)) => {
                    let child_dir = match path_attr(&md.attrs) {
                        Some(p) => dir.join(p),
                        None => dir.join(&name),
                    };
                    let public = is_pub(&md.vis);
                    self.add_module(
                        child_path,
                        file.clone(),
                        Some(idx),
                        public,
                        inner,
                        &child_dir,
                    )?
                }
                None => {
                    let (child_file, child_dir) = match path_attr(&md.attrs) {
                        Some(p) => {
                            let f = dir.join(p);
                            let d = f.parent().unwrap_or(dir).to_path_buf();
                            (f, d)
                        }
                        None => {
                            let flat = dir.join(format!("{name}.rs"));
                            if flat.exists() {
                                (flat, dir.join(&name))
                            } else {
                                (dir.join(&name).join("mod.rs"), dir.join(&name))
                            }
                        }
                    };
                    let parsed = parse_file(&child_file)?;
                    let public = is_pub(&md.vis);
                    self.add_module(
                        child_path,
                        child_file,
                        Some(idx),
                        public,
                        &parsed.items,
                        &child_dir,
                    )?
                }
            };
            self.modules[idx].children.insert(name, child);
        }
        Ok(idx)
    }

    /// The module that `path`, written in module `at`, names (its deepest
    /// module, re-exports followed); `None` for paths outside the crate.
    fn resolve(&self, at: usize, path: &[String]) -> Option<usize> {
        self.resolve_within(at, path, 0)
    }

    /// [`Self::resolve`], `depth` re-exports deep (at most 8 followed).
    fn resolve_within(&self, at: usize, path: &[String], depth: u32) -> Option<usize> {
        let (first, rest) = path.split_first()?;
        let mut m = match first.as_str() {
            "crate" => 0,
            "self" => at,
            "super" => self.modules[at].parent?,
            name => *self.modules[at].children.get(name)?,
        };
        let mut rest = rest;
        while first == "super" && rest.first().is_some_and(|s| s == "super") {
            m = self.modules[m].parent?;
            rest = &rest[1..];
        }
        Some(self.descend(m, rest, depth))
    }

    /// Follow `rest` down from module `m`.
    fn descend(&self, m: usize, rest: &[String], depth: u32) -> usize {
        let Some((s, tail)) = rest.split_first() else {
            return m;
        };
        let module = &self.modules[m];
        if let Some(&c) = module.children.get(s) {
            return self.descend(c, tail, depth);
        }
        if module.items.contains(s) || depth > 8 {
            return m;
        }
        if let Some((_, p)) = module.reexports.iter().find(|(n, _)| n == s) {
            let mut full = p.clone();
            full.extend_from_slice(tail);
            return self.resolve_within(m, &full, depth + 1).unwrap_or(m);
        }
        for g in &module.globs {
            if let Some(src) = self.resolve_within(m, g, depth + 1) {
                if src != m && self.declares(src, s) {
                    return self.descend(src, rest, depth + 1);
                }
            }
        }
        m
    }

    /// Module `m` declares or re-exports `name`.
    fn declares(&self, m: usize, name: &str) -> bool {
        let module = &self.modules[m];
        module.items.contains(name)
            || module.children.contains_key(name)
            || module.reexports.iter().any(|(n, _)| n == name)
    }

    /// Module `m` can be named from outside the crate: it and every
    /// module above it are declared `pub mod`.
    fn exported(&self, m: usize) -> bool {
        self.chain(m).iter().all(|&a| self.modules[a].public)
    }

    /// Module `m`'s item `name` has a public path there: `m` is exported
    /// and declares it `pub` or `pub use`s it, or `name` is an exported
    /// child module of `m`.
    fn has_own_public_path(&self, m: usize, name: &str) -> bool {
        if !self.exported(m) {
            return false;
        }
        let module = &self.modules[m];
        module.pub_items.contains(name)
            || module.pub_uses.iter().any(|(n, _, _)| n == name)
            || module
                .children
                .get(name)
                .is_some_and(|&c| self.modules[c].public)
    }

    /// What `use path` written in module `at` brings in: the module its
    /// last segment lives in (the one the rest names) and that segment.
    fn use_target<'p>(&self, at: usize, path: &'p [String]) -> Option<(usize, &'p String)> {
        let (last, head) = path.split_last()?;
        let home = if head.is_empty() {
            at
        } else {
            self.resolve(at, head)?
        };
        Some((home, last))
    }

    /// `pub use`s of exported modules that give an item a second public
    /// path: what they name already has one where it is declared. `skip`
    /// leaves a subtree out (the board support).
    fn second_paths(&self, skip: Option<usize>) -> Vec<SecondPath> {
        let mut out = Vec::new();
        for (i, m) in self.modules.iter().enumerate() {
            if skip.is_some_and(|b| self.within(i, b)) || !self.exported(i) {
                continue;
            }
            for (name, path, line) in &m.pub_uses {
                let Some((home, last)) = self.use_target(i, path) else {
                    continue;
                };
                if home != i && self.has_own_public_path(home, last) {
                    out.push(SecondPath {
                        file: m.file.clone(),
                        line: *line,
                        name: name.clone(),
                        reexported: path.join("::"),
                    });
                }
            }
        }
        out
    }

    /// `a` is `b` or inside it.
    fn within(&self, mut a: usize, b: usize) -> bool {
        loop {
            if a == b {
                return true;
            }
            match self.modules[a].parent {
                Some(p) => a = p,
                None => return false,
            }
        }
    }

    /// The ancestors of `m` from itself up to the root.
    fn chain(&self, m: usize) -> Vec<usize> {
        let mut v = vec![m];
        let mut a = m;
        while let Some(p) = self.modules[a].parent {
            v.push(p);
            a = p;
        }
        v
    }

    /// Sibling edges: (parent, from child, to child) → first witness.
    fn sibling_edges(&self) -> BTreeMap<(usize, usize, usize), (PathBuf, usize)> {
        let mut edges = BTreeMap::new();
        for (u, m) in self.modules.iter().enumerate() {
            for (p, line) in &m.refs {
                let Some(v) = self.resolve(u, p) else {
                    continue;
                };
                if self.within(u, v) || self.within(v, u) {
                    continue;
                }
                let cu = self.chain(u);
                let cv = self.chain(v);
                // The nearest common ancestor and the children under it.
                let Some((iu, lca)) = cu.iter().enumerate().find(|(_, a)| cv.contains(a)) else {
                    continue;
                };
                let iv = cv.iter().position(|a| a == lca).unwrap_or(0);
                let (Some(&a), Some(&b)) = (cu.get(iu.wrapping_sub(1)), cv.get(iv.wrapping_sub(1)))
                else {
                    continue;
                };
                edges
                    .entry((*lca, a, b))
                    .or_insert_with(|| (m.file.clone(), *line));
            }
        }
        edges
    }

    /// Every import cycle of this crate.
    pub fn cycles(&self) -> Vec<Cycle> {
        let edges = self.sibling_edges();
        let mut by_parent: BTreeMap<usize, BTreeMap<usize, Vec<usize>>> = BTreeMap::new();
        for &(p, a, b) in edges.keys() {
            by_parent
                .entry(p)
                .or_default()
                .entry(a)
                .or_default()
                .push(b);
        }
        let mut out = Vec::new();
        for (parent, graph) in by_parent {
            for scc in strongly_connected(&graph) {
                if scc.len() < 2 {
                    continue;
                }
                let loop_ = shortest_loop(&graph, &scc);
                let name = |i: usize| self.modules[i].path.last().cloned().unwrap_or_default();
                let steps = loop_
                    .windows(2)
                    .map(|w| {
                        let (file, line) = edges[&(parent, w[0], w[1])].clone();
                        Step {
                            from: name(w[0]),
                            to: name(w[1]),
                            file,
                            line,
                        }
                    })
                    .collect();
                let mut members: Vec<String> = scc.iter().map(|&i| name(i)).collect();
                members.sort();
                let inside: BTreeSet<usize> = scc.iter().copied().collect();
                let mut all: Vec<Step> = edges
                    .iter()
                    .filter(|((p, a, b), _)| {
                        *p == parent && inside.contains(a) && inside.contains(b)
                    })
                    .map(|((_, a, b), (file, line))| Step {
                        from: name(*a),
                        to: name(*b),
                        file: file.clone(),
                        line: *line,
                    })
                    .collect();
                all.sort_by(|x, y| (&x.from, &x.to).cmp(&(&y.from, &y.to)));
                out.push(Cycle {
                    krate: self.name.clone(),
                    parent: self.modules[parent].path.clone(),
                    members,
                    steps,
                    edges: all,
                });
            }
        }
        out
    }
}

/// Tarjan's strongly connected components of `graph`.
fn strongly_connected(graph: &BTreeMap<usize, Vec<usize>>) -> Vec<Vec<usize>> {
    struct State<'a> {
        graph: &'a BTreeMap<usize, Vec<usize>>,
        index: HashMap<usize, usize>,
        low: HashMap<usize, usize>,
        stack: Vec<usize>,
        on_stack: BTreeSet<usize>,
        out: Vec<Vec<usize>>,
    }
    fn visit(s: &mut State<'_>, v: usize) {
        let n = s.index.len();
        s.index.insert(v, n);
        s.low.insert(v, n);
        s.stack.push(v);
        s.on_stack.insert(v);
        for &w in s.graph.get(&v).map_or(&[][..], |x| &x[..]) {
            if !s.index.contains_key(&w) {
                visit(s, w);
                let lw = s.low[&w];
                if let Some(l) = s.low.get_mut(&v) {
                    *l = (*l).min(lw);
                }
            } else if s.on_stack.contains(&w) {
                let iw = s.index[&w];
                if let Some(l) = s.low.get_mut(&v) {
                    *l = (*l).min(iw);
                }
            }
        }
        if s.low[&v] == s.index[&v] {
            let mut comp = Vec::new();
            while let Some(w) = s.stack.pop() {
                s.on_stack.remove(&w);
                comp.push(w);
                if w == v {
                    break;
                }
            }
            s.out.push(comp);
        }
    }
    let mut s = State {
        graph,
        index: HashMap::new(),
        low: HashMap::new(),
        stack: Vec::new(),
        on_stack: BTreeSet::new(),
        out: Vec::new(),
    };
    for &v in graph.keys() {
        if !s.index.contains_key(&v) {
            visit(&mut s, v);
        }
    }
    s.out
}

/// The shortest loop through the smallest member of `scc` inside it, as
/// the visited nodes with the start repeated at the end.
fn shortest_loop(graph: &BTreeMap<usize, Vec<usize>>, scc: &[usize]) -> Vec<usize> {
    let inside: BTreeSet<usize> = scc.iter().copied().collect();
    let start = *inside.iter().next().unwrap_or(&0);
    let mut prev: HashMap<usize, usize> = HashMap::new();
    let mut queue = VecDeque::from([start]);
    while let Some(v) = queue.pop_front() {
        for &w in graph.get(&v).map_or(&[][..], |x| &x[..]) {
            if !inside.contains(&w) {
                continue;
            }
            if w == start {
                let mut path = vec![start, v];
                let mut at = v;
                while at != start {
                    at = prev[&at];
                    path.push(at);
                }
                path.reverse();
                // path: start … v start → reversed gives start v … start.
                return path;
            }
            if let std::collections::hash_map::Entry::Vacant(e) = prev.entry(w) {
                e.insert(v);
                queue.push_back(w);
            }
        }
    }
    vec![start, start]
}

/// One edge of a reported cycle, with the first place that makes it.
#[derive(Debug, Clone)]
pub struct Step {
    from: String,
    to: String,
    file: PathBuf,
    line: usize,
}

/// A set of sibling modules that import each other round a loop.
#[derive(Debug, Clone)]
pub struct Cycle {
    krate: String,
    /// The parent module of the siblings (empty: the crate root).
    parent: Vec<String>,
    /// Every module of the strongly connected set.
    members: Vec<String>,
    /// One shortest loop through them; the last step closes it.
    steps: Vec<Step>,
    /// Every edge between them (what must go to break the set up).
    edges: Vec<Step>,
}

impl fmt::Display for Cycle {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let parent = if self.parent.is_empty() {
            "crate".to_string()
        } else {
            format!("crate::{}", self.parent.join("::"))
        };
        writeln!(
            f,
            "  {} under {parent}: {} modules {{{}}}",
            self.krate,
            self.members.len(),
            self.members.join(", ")
        )?;
        let root = workspace_root();
        let line = |f: &mut fmt::Formatter<'_>, s: &Step, note: &str| {
            let file = s.file.strip_prefix(&root).unwrap_or(&s.file);
            writeln!(
                f,
                "      {} -> {}  {}:{}{note}",
                s.from,
                s.to,
                file.display(),
                s.line
            )
        };
        writeln!(f, "    a loop:")?;
        for (i, s) in self.steps.iter().enumerate() {
            let last = i + 1 == self.steps.len();
            line(f, s, if last { "  (closes the cycle)" } else { "" })?;
        }
        if self.edges.len() > self.steps.len() {
            writeln!(f, "    every edge between them ({}):", self.edges.len())?;
            for s in &self.edges {
                line(f, s, "")?;
            }
        }
        Ok(())
    }
}

/// The workspace members (`members = [...]` of the root manifest).
fn members(root: &Path) -> Result<Vec<String>, String> {
    let text = fs::read_to_string(root.join("Cargo.toml"))
        .map_err(|e| format!("reading Cargo.toml: {e}"))?;
    let start = text
        .find("members")
        .ok_or("Cargo.toml: no workspace members")?;
    let list = &text[start..];
    let open = list.find('[').ok_or("Cargo.toml: members is not a list")?;
    let close = list.find(']').ok_or("Cargo.toml: members is not a list")?;
    Ok(list[open + 1..close]
        .split(',')
        .map(|s| s.trim().trim_matches('"').to_string())
        .filter(|s| !s.is_empty())
        .collect())
}

/// Crate roots of a member by cargo's conventions: (target name, root file).
fn crate_roots(dir: &Path) -> Vec<(String, PathBuf)> {
    let mut roots = Vec::new();
    for (name, rel) in [("lib", "src/lib.rs"), ("main", "src/main.rs")] {
        let p = dir.join(rel);
        if p.is_file() {
            roots.push((name.to_string(), p));
        }
    }
    for sub in ["src/bin", "tests", "examples", "benches"] {
        let Ok(entries) = fs::read_dir(dir.join(sub)) else {
            continue;
        };
        let mut found: Vec<(String, PathBuf)> = entries
            .flatten()
            .filter_map(|e| {
                let p = e.path();
                let stem = p.file_stem()?.to_string_lossy().into_owned();
                if p.is_file() && p.extension().is_some_and(|x| x == "rs") {
                    Some((format!("{sub}/{stem}"), p))
                } else if p.join("main.rs").is_file() {
                    Some((format!("{sub}/{stem}"), p.join("main.rs")))
                } else {
                    None
                }
            })
            .collect();
        found.sort();
        roots.extend(found);
    }
    roots
}

/// Every crate of the workspace.
fn workspace_crates(root: &Path) -> Result<Vec<(String, Crate)>, String> {
    let mut out = Vec::new();
    for member in members(root)? {
        let dir = root.join(&member);
        let label = if member == "." {
            "beamest".to_string()
        } else {
            member.clone()
        };
        for (target, file) in crate_roots(&dir) {
            let name = format!("{label}/{target}");
            out.push((member.clone(), Crate::load(&name, &file)?));
        }
    }
    Ok(out)
}

/// A `pub use` that gives an item a second public path.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SecondPath {
    file: PathBuf,
    line: usize,
    /// The name it brings in.
    name: String,
    /// The path it re-exports, which is public already.
    reexported: String,
}

/// A `pub` item of the core.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub struct PubItem {
    file: PathBuf,
    line: usize,
    kind: &'static str,
    name: String,
    /// The identifiers its public face shows: a function's signature, the
    /// types of a struct's generics and `pub` fields, an enum's generics and variant fields, a
    /// constant's or alias's type, a trait's items; a method's with its impl's bounds. Whoever uses the item
    /// uses these too.
    shows: BTreeSet<String>,
}

/// `pub`, not `pub(crate)` or narrower.
fn is_pub(v: &Visibility) -> bool {
    matches!(v, Visibility::Public(_))
}

/// The `pub` items of `items` (module level and inherent `impl`s).
fn pub_items(file: &Path, items: &[Item], out: &mut Vec<PubItem>) {
    let mut push = |kind: &'static str, ident: &proc_macro2::Ident, face: TokenStream| {
        let mut shows = BTreeSet::new();
        idents(face, &mut shows);
        out.push(PubItem {
            file: file.to_path_buf(),
            line: ident.span().start().line,
            kind,
            name: ident.to_string(),
            shows,
        })
    };
    let pub_fields = |fields: &syn::Fields, all: bool| -> TokenStream {
        fields
            .iter()
            .filter(|f| all || is_pub(&f.vis))
            .map(|f| f.ty.to_token_stream())
            .collect()
    };
    for i in items {
        if item_attrs(i).is_some_and(is_cfg_test) {
            continue;
        }
        match i {
            Item::Fn(x) if is_pub(&x.vis) => push("fn", &x.sig.ident, x.sig.to_token_stream()),
            Item::Struct(x) if is_pub(&x.vis) => {
                let mut face = x.generics.to_token_stream();
                face.extend(pub_fields(&x.fields, false));
                push("struct", &x.ident, face)
            }
            Item::Enum(x) if is_pub(&x.vis) => {
                let mut face = x.generics.to_token_stream();
                face.extend(x.variants.iter().flat_map(|v| pub_fields(&v.fields, true)));
                push("enum", &x.ident, face)
            }
            Item::Union(x) if is_pub(&x.vis) => push(
                "union",
                &x.ident,
                pub_fields(&syn::Fields::Named(x.fields.clone()), false),
            ),
            Item::Const(x) if is_pub(&x.vis) => push("const", &x.ident, x.ty.to_token_stream()),
            Item::Static(x) if is_pub(&x.vis) => push("static", &x.ident, x.ty.to_token_stream()),
            Item::Type(x) if is_pub(&x.vis) => push("type", &x.ident, x.ty.to_token_stream()),
            Item::Trait(x) if is_pub(&x.vis) => push(
                "trait",
                &x.ident,
                x.items.iter().map(|i| i.to_token_stream()).collect(),
            ),
            Item::Mod(x) if is_pub(&x.vis) => push("mod", &x.ident, TokenStream::new()),
            Item::Macro(x) if x.attrs.iter().any(|a| a.path().is_ident("macro_export")) => {
                if let Some(id) = &x.ident {
                    push("macro", id, TokenStream::new());
                }
            }
            Item::Impl(imp) if imp.trait_.is_none() => {
                for ii in &imp.items {
                    match ii {
                        ImplItem::Fn(f) if is_pub(&f.vis) && !is_cfg_test(&f.attrs) => {
                            // The impl's bounds are part of every method's face.
                            let mut face = imp.generics.to_token_stream();
                            face.extend(imp.generics.where_clause.to_token_stream());
                            face.extend(f.sig.to_token_stream());
                            push("method", &f.sig.ident, face)
                        }
                        ImplItem::Const(c) if is_pub(&c.vis) && !is_cfg_test(&c.attrs) => {
                            push("assoc const", &c.ident, c.ty.to_token_stream())
                        }
                        ImplItem::Type(t) if is_pub(&t.vis) && !is_cfg_test(&t.attrs) => {
                            push("assoc type", &t.ident, t.ty.to_token_stream())
                        }
                        _ => {}
                    }
                }
            }
            _ => {}
        }
    }
}

/// Every identifier token in `tokens`.
fn idents(tokens: TokenStream, out: &mut BTreeSet<String>) {
    for t in tokens {
        match t {
            TokenTree::Ident(i) => {
                let s = i.to_string();
                out.insert(s.strip_prefix("r#").map(str::to_string).unwrap_or(s));
            }
            TokenTree::Group(g) => idents(g.stream(), out),
            _ => {}
        }
    }
}

/// The core (the `beamest` library) and its `board` module, which the
/// checks leave out.
fn core_of(crates: &[(String, Crate)]) -> Result<(&Crate, Option<usize>), String> {
    let core = crates
        .iter()
        .find(|(m, c)| m == "." && c.name.ends_with("/lib"))
        .map(|(_, c)| c)
        .ok_or("no beamest library")?;
    Ok((core, core.modules[0].children.get("board").copied()))
}

/// The core's `pub` items (the `beamest` library less `board`) that no
/// file of another crate names, and how many there are in all.
fn unused_pub(crates: &[(String, Crate)]) -> Result<(Vec<PubItem>, usize), String> {
    let (core, board) = core_of(crates)?;
    // What exported modules re-export: (the module it is declared in, name).
    let mut via_use = BTreeSet::new();
    for (j, m) in core.modules.iter().enumerate() {
        if board.is_some_and(|b| core.within(j, b)) || !core.exported(j) {
            continue;
        }
        for (_, path, _) in &m.pub_uses {
            if let Some((home, last)) = core.use_target(j, path) {
                via_use.insert((home, last.clone()));
            }
        }
    }
    let mut items = Vec::new();
    let mut seen = BTreeSet::new();
    for (i, m) in core.modules.iter().enumerate() {
        if board.is_some_and(|b| core.within(i, b)) || !seen.insert(m.file.clone()) {
            continue;
        }
        // One parse per file; inline modules are walked with their file.
        let parsed = parse_file(&m.file)?;
        let mut found = Vec::new();
        collect_in_file(&m.file, &parsed.items, &mut found);
        if !core.exported(i) {
            // A `pub` item of a module that outside code cannot name counts
            // only if an exported module re-exports it; methods count if
            // anything of their module is re-exported (their type may be).
            let any = via_use.iter().any(|(h, _)| *h == i);
            found.retain(|it| {
                if it.kind == "method" || it.kind.starts_with("assoc") {
                    any
                } else {
                    via_use.contains(&(i, it.name.clone()))
                }
            });
        }
        items.extend(found);
    }
    let mut names = BTreeSet::new();
    let mut files = BTreeSet::new();
    for (_, c) in crates.iter().filter(|(_, c)| !std::ptr::eq(c, core)) {
        for m in &c.modules {
            files.insert(m.file.clone());
        }
    }
    // The board support is outside the core too: what it names is used.
    for (i, m) in core.modules.iter().enumerate() {
        if board.is_some_and(|b| core.within(i, b)) {
            files.insert(m.file.clone());
        }
    }
    for f in &files {
        let text = fs::read_to_string(f).map_err(|e| format!("reading {}: {e}", f.display()))?;
        let tokens = TokenStream::from_str(&text)
            .map_err(|e| format!("{}: not Rust tokens: {e}", f.display()))?;
        idents(tokens, &mut names);
    }
    // A `pub use … as NEW` of the core: NEW named outside uses the item.
    let aliases: Vec<(String, String)> = core
        .modules
        .iter()
        .flat_map(|m| m.pub_uses.iter())
        .filter_map(|(name, path, _)| {
            let last = path.last()?;
            (last != name).then(|| (name.clone(), last.clone()))
        })
        .collect();
    // What a used item shows is used with it (to a fixed point): an error
    // type a used function returns, a field's type, a trait's arguments.
    loop {
        let before = names.len();
        for (alias, original) in &aliases {
            if names.contains(alias) {
                names.insert(original.clone());
            }
        }
        for i in &items {
            if names.contains(&i.name) {
                names.extend(i.shows.iter().cloned());
            }
        }
        if names.len() == before {
            break;
        }
    }
    let total = items.len();
    let mut unused: Vec<PubItem> = items
        .into_iter()
        .filter(|i| !names.contains(&i.name))
        .collect();
    unused.sort();
    Ok((unused, total))
}

/// `pub` items of one file, inline modules (not `#[cfg(test)]`) included.
fn collect_in_file(file: &Path, items: &[Item], out: &mut Vec<PubItem>) {
    pub_items(file, items, out);
    for i in items {
        if let Item::Mod(m) = i {
            if let Some((_, inner)) = &m.content {
                if !is_cfg_test(&m.attrs) {
                    collect_in_file(file, inner, out);
                }
            }
        }
    }
}

/// `cargo xtask layout [--deny-unused-pub]`.
pub fn run(args: &[String]) -> Result<(), String> {
    let mut deny_unused = false;
    for a in args {
        match a.as_str() {
            "--deny-unused-pub" => deny_unused = true,
            other => return Err(format!("layout: unknown option `{other}`")),
        }
    }
    let root = workspace_root();
    let crates = workspace_crates(&root)?;
    let modules: usize = crates.iter().map(|(_, c)| c.modules.len()).sum();
    println!(
        "layout: {} crates, {modules} modules ({})",
        crates.len(),
        crates
            .iter()
            .map(|(_, c)| c.name.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    );
    let cycles: Vec<Cycle> = crates.iter().flat_map(|(_, c)| c.cycles()).collect();
    println!("\nimport cycles between sibling modules: {}", cycles.len());
    for c in &cycles {
        print!("{c}");
    }
    let (core, board) = core_of(&crates)?;
    let second = core.second_paths(board);
    println!(
        "\nsecond public paths in the core (a `pub use` of what is public where it is declared): {}",
        second.len()
    );
    for d in &second {
        let file = d.file.strip_prefix(&root).unwrap_or(&d.file);
        println!(
            "  {}:{} pub use {} (as {})",
            file.display(),
            d.line,
            d.reexported,
            d.name
        );
    }
    let (unused, total) = unused_pub(&crates)?;
    println!(
        "\npub items of the core (beamest less board) named by no other crate: {} of {total}",
        unused.len()
    );
    let mut by_kind: BTreeMap<&str, usize> = BTreeMap::new();
    for u in &unused {
        *by_kind.entry(u.kind).or_default() += 1;
    }
    println!(
        "  by kind: {}",
        by_kind
            .iter()
            .map(|(k, n)| format!("{k} {n}"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    for u in &unused {
        let file = u.file.strip_prefix(&root).unwrap_or(&u.file);
        println!("  {}:{} {} {}", file.display(), u.line, u.kind, u.name);
    }
    let mut failures = Vec::new();
    if !cycles.is_empty() {
        failures.push(format!("{} import cycle(s)", cycles.len()));
    }
    if !second.is_empty() {
        failures.push(format!("{} second public path(s)", second.len()));
    }
    if deny_unused && !unused.is_empty() {
        failures.push(format!("{} unused pub item(s) of the core", unused.len()));
    }
    if failures.is_empty() {
        println!("\nlayout: OK");
        Ok(())
    } else {
        Err(format!("layout check failed: {}", failures.join(", ")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fresh directory under the system's temporary directory.
    fn tempdir(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("xtask-layout-{tag}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&d);
        fs::create_dir_all(&d).expect("temp dir");
        d
    }

    fn write(dir: &Path, rel: &str, text: &str) {
        let p = dir.join(rel);
        fs::create_dir_all(p.parent().expect("parent")).expect("dirs");
        fs::write(p, text).expect("write");
    }

    /// A cycle as (parent, members, loop of (from, to, line)).
    type Found = (String, Vec<String>, Vec<(String, String, usize)>);

    fn summary(c: &Crate) -> Vec<Found> {
        c.cycles()
            .into_iter()
            .map(|y| {
                (
                    y.parent.join("::"),
                    y.members,
                    y.steps
                        .into_iter()
                        .map(|s| (s.from, s.to, s.line))
                        .collect(),
                )
            })
            .collect()
    }

    #[test]
    fn a_reexport_of_a_public_item_is_a_second_path() {
        let d = tempdir("second");
        write(
            &d,
            "lib.rs",
            "pub mod a;\nmod b;\npub use a::A;\npub use b::B;\npub(crate) use a::C;\npub use a::D;\n",
        );
        write(
            &d,
            "a.rs",
            "pub struct A;\npub struct C;\npub use crate::b::B as D;\n",
        );
        write(&d, "b.rs", "pub struct B;\n");
        let c = Crate::load("t/lib", &d.join("lib.rs")).unwrap();
        let found: Vec<_> = c
            .second_paths(None)
            .into_iter()
            .map(|s| (s.name, s.reexported))
            .collect();
        // `a::A` is public where it is declared, `a::D` where `a`
        // re-exports it; `b::B` only through the re-export; a
        // `pub(crate) use` adds no public path.
        assert_eq!(
            found,
            [
                ("A".to_string(), "a::A".to_string()),
                ("D".to_string(), "a::D".to_string())
            ]
        );
    }

    #[test]
    fn finds_a_three_module_cycle_and_the_edge_that_closes_it() {
        let d = tempdir("three");
        write(
            &d,
            "lib.rs",
            "pub mod a;\npub mod b;\npub mod c;\npub mod d;\n",
        );
        write(&d, "a.rs", "use crate::b::B;\npub struct A;\n");
        write(&d, "b.rs", "pub struct B;\nfn f() { super::c::g(); }\n");
        write(
            &d,
            "c.rs",
            "pub fn g() {}\n\nfn h() -> crate::a::A { crate::a::A }\n",
        );
        // d uses a but nothing uses d: no cycle.
        write(&d, "d.rs", "use crate::a::A;\n");
        let c = Crate::load("t/lib", &d.join("lib.rs")).expect("load");
        let found = summary(&c);
        assert_eq!(
            found,
            vec![(
                String::new(),
                vec!["a".into(), "b".into(), "c".into()],
                vec![
                    ("a".into(), "b".into(), 1),
                    ("b".into(), "c".into(), 2),
                    ("c".into(), "a".into(), 3),
                ]
            )]
        );
    }

    #[test]
    fn follows_reexports_and_folds_children_into_their_parent() {
        let d = tempdir("reexport");
        // x re-exports x::inner::T; y uses it through the re-export, and
        // x::inner uses y: x and y form a cycle at the root. Inside x, the
        // parent–child references (x uses inner, inner uses super) are none.
        write(&d, "lib.rs", "mod x;\nmod y;\nmod z;\n");
        write(
            &d,
            "x/mod.rs",
            "mod inner;\npub use inner::T;\npub(crate) use inner::*;\n",
        );
        write(
            &d,
            "x/inner.rs",
            "pub struct T;\npub fn u() {}\nfn f() { let _ = crate::y::Y; super::T; }\n",
        );
        write(&d, "y.rs", "pub struct Y;\nuse crate::x::T;\n");
        // z only through a glob re-export of x: still an edge to x.
        write(&d, "z.rs", "fn f() { crate::x::u() }\n");
        let c = Crate::load("t/lib", &d.join("lib.rs")).expect("load");
        let found = summary(&c);
        assert_eq!(found.len(), 1, "{found:?}");
        assert_eq!(found[0].1, vec!["x".to_string(), "y".to_string()]);
        // The glob-resolved reference lands in x::inner.
        let z = c.modules[0].children["z"];
        let inner = c.modules[c.modules[0].children["x"]].children["inner"];
        assert_eq!(
            c.resolve(z, &["crate".into(), "x".into(), "u".into()]),
            Some(inner)
        );
    }

    #[test]
    fn nested_cycles_macro_paths_and_test_code() {
        let d = tempdir("nested");
        write(&d, "main.rs", "mod p;\n");
        write(&d, "p/mod.rs", "mod q;\nmod r;\n");
        // q → r through a macro's tokens; r → q in code; the test module's
        // reference back from r does not count, and neither would a cycle
        // made only by tests.
        write(&d, "p/q.rs", "fn f() { println!(\"{}\", super::r::N); }\n");
        write(
            &d,
            "p/r.rs",
            "pub const N: u8 = 1;\nfn g() { let _ = super::q::f; }\n#[cfg(test)]\nmod tests { use crate::p::q; }\n",
        );
        let c = Crate::load("t/main", &d.join("main.rs")).expect("load");
        let found = summary(&c);
        assert_eq!(
            found,
            vec![(
                "p".into(),
                vec!["q".into(), "r".into()],
                vec![("q".into(), "r".into(), 1), ("r".into(), "q".into(), 2)]
            )]
        );
        // Without r's code reference, no cycle.
        write(
            &d,
            "p/r.rs",
            "pub const N: u8 = 1;\n#[cfg(test)]\nmod tests { use crate::p::q; }\n",
        );
        let c = Crate::load("t/main", &d.join("main.rs")).expect("load");
        assert!(c.cycles().is_empty());
    }
}
