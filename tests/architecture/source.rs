//! Reading a crate with `syn`: its modules, found from the crate root
//! through its `mod` items (a module under `#[cfg(test)]` is test code,
//! and so is every file only it reaches), each module's items, its
//! `use` items, and every path into the crate that its code names.
//!
//! A path into the crate is one that starts with `crate`, `$crate`,
//! `super`, `self`, the crate's own name (`extern crate self as x`), a
//! child module, or a name a module-level `use` binds to an item of the
//! crate. It is read wherever it stands: in a `use` tree (groups, renames
//! and globs expanded), a type, an expression, a pattern, an attribute's
//! tokens or a macro's. Items under `#[cfg(test)]` (or `doctest`, or
//! `#[test]`) are skipped by the attribute, wherever they stand; doc
//! comments are string literals to the parser and name nothing.

use std::collections::{BTreeMap, BTreeSet};

use proc_macro2::{Delimiter, Spacing, Span, TokenStream, TokenTree};
use quote::ToTokens;
use syn::{Attribute, Item, UseTree, Visibility};

/// A crate's files: path relative to its source folder -> text. What the
/// checker reads, from disk or from the self-tests' strings.
pub struct Files {
    /// The source folder as the messages print it (`ezy-core/src`).
    pub label: String,
    /// The crate root's file (`lib.rs`).
    pub root: String,
    pub texts: BTreeMap<String, String>,
}

impl Files {
    /// A crate made of `(path, text)` pairs, its root `lib.rs`.
    pub fn of(label: &str, files: &[(&str, &str)]) -> Files {
        Files {
            label: label.to_string(),
            root: "lib.rs".into(),
            texts: files.iter().map(|(p, t)| (p.to_string(), t.to_string())).collect(),
        }
    }

    /// Every `.rs` file below `dir`, the crate root `root`.
    pub fn read(label: &str, dir: &std::path::Path, root: &str) -> Files {
        let mut texts = BTreeMap::new();
        let mut stack = vec![dir.to_path_buf()];
        while let Some(d) = stack.pop() {
            let Ok(entries) = std::fs::read_dir(&d) else { continue };
            for entry in entries {
                let path = entry.unwrap().path();
                if path.is_dir() {
                    stack.push(path);
                } else if path.extension().is_some_and(|e| e == "rs") {
                    let rel = path.strip_prefix(dir).unwrap().to_string_lossy().replace('\\', "/");
                    texts.insert(rel, std::fs::read_to_string(&path).unwrap());
                }
            }
        }
        Files { label: label.to_string(), root: root.to_string(), texts }
    }
}

/// Who may name an item through a `use`: the module alone, the crate
/// (`pub(crate)`, `pub(super)`, `pub(in ..)`), or everyone (`pub`).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Vis {
    Private,
    Crate,
    Public,
}

impl Vis {
    fn of(v: &Visibility) -> Vis {
        match v {
            Visibility::Public(_) => Vis::Public,
            Visibility::Restricted(_) => Vis::Crate,
            Visibility::Inherited => Vis::Private,
        }
    }

    /// How a message names the `use`: `pub use`, `pub(crate) use`, `use`.
    pub fn spelling(self) -> &'static str {
        match self {
            Vis::Public => "pub use",
            Vis::Crate => "pub(crate) use",
            Vis::Private => "use",
        }
    }
}

/// Where a `use` leads: into the crate (an absolute module path and
/// item, segments after `crate`) or out of it (`ezy_core::files`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Target {
    Crate(Vec<String>),
    External(String),
}

/// One leaf of a module-level `use` tree.
#[derive(Clone, Debug)]
pub struct Import {
    pub line: usize,
    pub vis: Vis,
    pub target: Target,
    /// The name it binds (`as` applied); `None` for a glob.
    pub name: Option<String>,
}

/// A path into the crate that a module's code names.
#[derive(Clone, Debug)]
pub struct Named {
    pub line: usize,
    /// Absolute segments after `crate`.
    pub path: Vec<String>,
    /// A macro's path (`crate::m!`): its last segment is a macro.
    pub is_macro: bool,
    /// Written `$crate::` (in a `macro_rules!` body): a path for the
    /// macro's users, spelled through what the crate exports.
    pub dollar: bool,
}

/// A module of the crate.
#[derive(Debug, Default)]
pub struct Module {
    /// Its file as the messages print it (`ezy-core/src/formulation/dae.rs`).
    pub file: String,
    /// The names its items define (child modules and macros included).
    pub defines: BTreeSet<String>,
    pub children: BTreeSet<String>,
    pub imports: Vec<Import>,
    pub names: Vec<Named>,
}

/// A crate as read: its modules by path, and what could not be read.
pub struct Crate {
    /// Each module by its path (`formulation::dae`; the crate root `""`).
    pub modules: BTreeMap<String, Module>,
    /// Files that fail to parse, `mod` items without a file, files no
    /// `mod` item reaches.
    pub problems: Vec<String>,
}

impl Crate {
    /// The module's file and the line, as a message prints them.
    pub fn at(&self, module: &str, line: usize) -> String {
        format!("{}:{line}", self.modules[module].file)
    }
}

/// Reads the crate `files`, from its root down its `mod` items.
pub fn read(files: &Files) -> Crate {
    let mut reader = Reader {
        files,
        krate: Crate { modules: BTreeMap::new(), problems: Vec::new() },
        reached: BTreeSet::new(),
        test_only: BTreeSet::new(),
        self_names: BTreeSet::new(),
    };
    if let Some(file) = reader.parse(&files.root) {
        for item in &file.items {
            if let Item::ExternCrate(e) = item
                && e.ident == "self"
                && let Some((_, alias)) = &e.rename
            {
                reader.self_names.insert(unraw(&alias.to_string()));
            }
        }
        let dir = parent_dir(&files.root);
        reader.module(Vec::new(), &files.root, &dir, &file.items);
    }
    for path in files.texts.keys() {
        if !reader.reached.contains(path) && !reader.test_only.contains(path) {
            reader.krate.problems.push(format!(
                "{}/{path}: no `mod` item of the crate reaches this file (dead code, or a module declared elsewhere)",
                files.label
            ));
        }
    }
    reader.krate
}

struct Reader<'a> {
    files: &'a Files,
    krate: Crate,
    /// Files read as library modules.
    reached: BTreeSet<String>,
    /// Files a `#[cfg(test)] mod` names (and what they reach).
    test_only: BTreeSet<String>,
    /// The crate's names for itself (`extern crate self as ezy_python`).
    self_names: BTreeSet<String>,
}

fn parent_dir(file: &str) -> String {
    file.rsplit_once('/').map_or(String::new(), |(d, _)| d.to_string())
}

fn join_dir(dir: &str, name: &str) -> String {
    if dir.is_empty() { name.to_string() } else { format!("{dir}/{name}") }
}

pub fn unraw(s: &str) -> String {
    s.strip_prefix("r#").unwrap_or(s).to_string()
}

fn line(span: Span) -> usize {
    span.start().line
}

/// Whether the attributes make an item test code: `#[cfg(test)]`,
/// `#[cfg(doctest)]`, `#[cfg(all(test, ..))]` or `#[test]`.
pub fn is_test(attrs: &[Attribute]) -> bool {
    attrs.iter().any(|a| {
        a.path().is_ident("test")
            || (a.path().is_ident("cfg") && a.meta.require_list().is_ok_and(|l| cfg_needs_test(l.tokens.clone())))
    })
}

/// Whether a `cfg` predicate holds only in a test build.
pub fn cfg_needs_test(tokens: TokenStream) -> bool {
    let toks: Vec<TokenTree> = tokens.into_iter().collect();
    match toks.as_slice() {
        [TokenTree::Ident(i)] => i == "test" || i == "doctest",
        [TokenTree::Ident(i), TokenTree::Group(g)] if i == "all" => {
            let mut parts = vec![TokenStream::new()];
            for t in g.stream() {
                match &t {
                    TokenTree::Punct(p) if p.as_char() == ',' => parts.push(TokenStream::new()),
                    _ => parts.last_mut().unwrap().extend([t]),
                }
            }
            parts.into_iter().any(cfg_needs_test)
        }
        _ => false,
    }
}

fn item_attrs(item: &Item) -> &[Attribute] {
    match item {
        Item::Const(i) => &i.attrs,
        Item::Enum(i) => &i.attrs,
        Item::ExternCrate(i) => &i.attrs,
        Item::Fn(i) => &i.attrs,
        Item::ForeignMod(i) => &i.attrs,
        Item::Impl(i) => &i.attrs,
        Item::Macro(i) => &i.attrs,
        Item::Mod(i) => &i.attrs,
        Item::Static(i) => &i.attrs,
        Item::Struct(i) => &i.attrs,
        Item::Trait(i) => &i.attrs,
        Item::TraitAlias(i) => &i.attrs,
        Item::Type(i) => &i.attrs,
        Item::Union(i) => &i.attrs,
        Item::Use(i) => &i.attrs,
        _ => &[],
    }
}

/// The name an item defines, if any.
fn item_name(item: &Item) -> Option<String> {
    let ident = match item {
        Item::Const(i) => &i.ident,
        Item::Enum(i) => &i.ident,
        Item::Fn(i) => &i.sig.ident,
        Item::Macro(i) => i.ident.as_ref()?,
        Item::Mod(i) => &i.ident,
        Item::Static(i) => &i.ident,
        Item::Struct(i) => &i.ident,
        Item::Trait(i) => &i.ident,
        Item::TraitAlias(i) => &i.ident,
        Item::Type(i) => &i.ident,
        Item::Union(i) => &i.ident,
        _ => return None,
    };
    Some(unraw(&ident.to_string()))
}

/// One leaf of a `use` tree before resolution: its segments as written,
/// the name it binds (`None` for a glob), its line.
struct Leaf {
    segs: Vec<String>,
    name: Option<String>,
    line: usize,
}

fn leaves(tree: &UseTree, prefix: &mut Vec<String>, out: &mut Vec<Leaf>) {
    match tree {
        UseTree::Path(p) => {
            prefix.push(unraw(&p.ident.to_string()));
            leaves(&p.tree, prefix, out);
            prefix.pop();
        }
        UseTree::Name(n) => {
            let name = unraw(&n.ident.to_string());
            let line = line(n.ident.span());
            if name == "self" {
                out.push(Leaf { segs: prefix.clone(), name: prefix.last().cloned(), line });
            } else {
                let mut segs = prefix.clone();
                segs.push(name.clone());
                out.push(Leaf { segs, name: Some(name), line });
            }
        }
        UseTree::Rename(r) => {
            let name = unraw(&r.ident.to_string());
            let mut segs = prefix.clone();
            if name != "self" {
                segs.push(name);
            }
            out.push(Leaf { segs, name: Some(unraw(&r.rename.to_string())), line: line(r.ident.span()) });
        }
        UseTree::Glob(g) => out.push(Leaf { segs: prefix.clone(), name: None, line: line(g.star_token.span) }),
        UseTree::Group(g) => {
            for t in &g.items {
                leaves(t, prefix, out);
            }
        }
    }
}

/// What a module's first path segments resolve against.
pub struct Scope<'s> {
    pub module: &'s [String],
    pub children: &'s BTreeSet<String>,
    /// Names bound by the module's `use` items to paths into the crate.
    pub aliases: &'s BTreeMap<String, Vec<String>>,
    pub self_names: &'s BTreeSet<String>,
}

impl Scope<'_> {
    /// The absolute path (segments after `crate`) that `segs` names, if
    /// it leads into the crate. `segs[0]` may be `$crate`.
    pub fn resolve(&self, segs: &[String]) -> Option<Vec<String>> {
        let first = segs.first()?.as_str();
        let mut base: Vec<String>;
        let mut rest = &segs[1..];
        match first {
            "crate" | "$crate" => base = Vec::new(),
            "self" => base = self.module.to_vec(),
            "super" => {
                base = self.module.to_vec();
                base.pop()?;
                while rest.first().is_some_and(|s| s == "super") {
                    base.pop()?;
                    rest = &rest[1..];
                }
            }
            _ if self.self_names.contains(first) => base = Vec::new(),
            _ if self.children.contains(first) => {
                base = self.module.to_vec();
                base.push(first.to_string());
            }
            _ => base = self.aliases.get(first)?.clone(),
        }
        base.extend(rest.iter().cloned());
        Some(base)
    }
}

impl Reader<'_> {
    fn parse(&mut self, path: &str) -> Option<syn::File> {
        let Some(text) = self.files.texts.get(path) else {
            self.krate.problems.push(format!("{}/{path}: no such file", self.files.label));
            return None;
        };
        match syn::parse_file(text) {
            Ok(f) => Some(f),
            Err(e) => {
                let at = e.span().start();
                self.krate.problems.push(format!("{}/{path}:{}: does not parse: {e}", self.files.label, at.line));
                None
            }
        }
    }

    /// Marks the file a test-only `mod` names, and every file below the
    /// folder its own child modules would be in.
    fn mark_test_only(&mut self, file: &str) {
        self.test_only.insert(file.to_string());
        let dir = file.strip_suffix("/mod.rs").or(file.strip_suffix(".rs")).unwrap_or(file);
        let below: Vec<String> =
            self.files.texts.keys().filter(|k| k.starts_with(&format!("{dir}/"))).cloned().collect();
        self.test_only.extend(below);
    }

    /// Reads one module: `items` from `file`; `dir` is the folder its
    /// child modules' files are in.
    fn module(&mut self, path: Vec<String>, file: &str, dir: &str, items: &[Item]) {
        self.reached.insert(file.to_string());
        let key = path.join("::");
        let mut m = Module { file: format!("{}/{file}", self.files.label), ..Module::default() };
        let mut uses = Vec::new();
        let mut subs = Vec::new();
        let mut code = Vec::new();
        for item in items {
            if is_test(item_attrs(item)) {
                if let Item::Mod(sub) = item
                    && sub.content.is_none()
                {
                    let name = unraw(&sub.ident.to_string());
                    for f in [join_dir(dir, &format!("{name}.rs")), join_dir(dir, &format!("{name}/mod.rs"))] {
                        if self.files.texts.contains_key(&f) {
                            self.mark_test_only(&f);
                        }
                    }
                }
                continue;
            }
            if let Some(name) = item_name(item) {
                m.defines.insert(name);
            }
            match item {
                Item::Mod(sub) => {
                    m.children.insert(unraw(&sub.ident.to_string()));
                    subs.push(sub);
                }
                Item::Use(u) => uses.push(u),
                Item::ExternCrate(_) => {}
                _ => code.push(item),
            }
        }
        let aliases = self.imports(&path, &mut m, &uses);
        let scope = Scope { module: &path, children: &m.children, aliases: &aliases, self_names: &self.self_names };
        let mut names = Vec::new();
        for item in code {
            scan(item.to_token_stream(), &scope, &mut names);
        }
        m.names.extend(names);
        m.imports.sort_by_key(|i| i.line);
        m.names.sort_by_key(|n| n.line);
        self.krate.modules.insert(key, m);
        for sub in subs {
            self.child(&path, file, dir, sub);
        }
    }

    /// The module-level `use` items of the module at `path` into `m`'s
    /// imports and names; returns the names they bind to items of the
    /// crate. A leaf may start with a name another leaf binds, so the
    /// leaves that start at the crate, `self`, `super` or a child are
    /// read first.
    fn imports(&self, path: &[String], m: &mut Module, uses: &[&syn::ItemUse]) -> BTreeMap<String, Vec<String>> {
        let mut aliases: BTreeMap<String, Vec<String>> = BTreeMap::new();
        let mut pending: Vec<(Vis, Leaf)> = Vec::new();
        for u in uses {
            let mut out = Vec::new();
            leaves(&u.tree, &mut Vec::new(), &mut out);
            pending.extend(out.into_iter().map(|l| (Vis::of(&u.vis), l)));
        }
        for round in 0..2 {
            let scope = Scope { module: path, children: &m.children, aliases: &aliases, self_names: &self.self_names };
            let mut later = Vec::new();
            let mut found = Vec::new();
            for (vis, leaf) in pending {
                let lead = leaf.segs.first().map(String::as_str);
                let relative = lead.is_some_and(|s| {
                    matches!(s, "crate" | "self" | "super") || self.self_names.contains(s) || m.children.contains(s)
                });
                let target = match scope.resolve(&leaf.segs) {
                    Some(abs) if round == 1 || relative => Target::Crate(abs),
                    _ if round == 0 => {
                        later.push((vis, leaf));
                        continue;
                    }
                    _ => Target::External(leaf.segs.join("::")),
                };
                found.push(Import { line: leaf.line, vis, target, name: leaf.name });
            }
            for imp in found {
                if let Target::Crate(abs) = &imp.target {
                    if let Some(name) = &imp.name {
                        aliases.insert(name.clone(), abs.clone());
                    }
                    m.names.push(Named { line: imp.line, path: abs.clone(), is_macro: false, dollar: false });
                }
                m.imports.push(imp);
            }
            pending = later;
        }
        aliases
    }

    /// Reads the child module `sub` of the module at `path` (in `file`,
    /// its children's files in `dir`): inline, or from its file.
    fn child(&mut self, path: &[String], file: &str, dir: &str, sub: &syn::ItemMod) {
        let name = unraw(&sub.ident.to_string());
        let mut child = path.to_vec();
        child.push(name.clone());
        let path_attr = sub.attrs.iter().find_map(|a| match &a.meta {
            syn::Meta::NameValue(nv) if nv.path.is_ident("path") => match &nv.value {
                syn::Expr::Lit(syn::ExprLit { lit: syn::Lit::Str(s), .. }) => Some(s.value()),
                _ => None,
            },
            _ => None,
        });
        if let Some((_, content)) = &sub.content {
            self.module(child, file, &join_dir(dir, &name), content);
            return;
        }
        let candidates = match &path_attr {
            Some(p) => vec![join_dir(&parent_dir(file), p)],
            None => vec![join_dir(dir, &format!("{name}.rs")), join_dir(dir, &format!("{name}/mod.rs"))],
        };
        let Some(f) = candidates.iter().find(|c| self.files.texts.contains_key(*c)).cloned() else {
            self.krate.problems.push(format!(
                "{}/{file}:{}: `mod {name};` has no file ({})",
                self.files.label,
                line(sub.ident.span()),
                candidates.join(" or ")
            ));
            return;
        };
        let Some(parsed) = self.parse(&f) else { return };
        let sub_dir = if f.ends_with("/mod.rs") || path_attr.is_some() {
            parent_dir(&f)
        } else {
            f.strip_suffix(".rs").unwrap().to_string()
        };
        self.module(child, &f, &sub_dir, &parsed.items);
    }
}

fn punct(t: Option<&TokenTree>, c: char) -> bool {
    matches!(t, Some(TokenTree::Punct(p)) if p.as_char() == c)
}

/// Whether `toks[i..]` starts with `::`.
fn colons(toks: &[TokenTree], i: usize) -> bool {
    matches!(toks.get(i), Some(TokenTree::Punct(p)) if p.as_char() == ':' && p.spacing() == Spacing::Joint)
        && punct(toks.get(i + 1), ':')
}

fn ident(t: Option<&TokenTree>) -> Option<String> {
    match t {
        Some(TokenTree::Ident(i)) => Some(unraw(&i.to_string())),
        _ => None,
    }
}

/// Whether `toks[i]` starts an attribute (`#[...]`) that makes what
/// follows test code.
fn test_attribute(toks: &[TokenTree], i: usize) -> bool {
    if !punct(toks.get(i), '#') {
        return false;
    }
    let Some(TokenTree::Group(g)) = toks.get(i + 1) else { return false };
    if g.delimiter() != Delimiter::Bracket {
        return false;
    }
    let inner: Vec<TokenTree> = g.stream().into_iter().collect();
    match inner.as_slice() {
        [TokenTree::Ident(t)] => t == "test",
        [TokenTree::Ident(c), TokenTree::Group(p)] => c == "cfg" && cfg_needs_test(p.stream()),
        _ => false,
    }
}

/// The index after the item, statement, field or arm that starts at `i`
/// (its attributes first): up to a `;` or `,` outside angle brackets,
/// or through its first `{ .. }`.
fn skip_item(toks: &[TokenTree], mut i: usize) -> usize {
    while punct(toks.get(i), '#') && matches!(toks.get(i + 1), Some(TokenTree::Group(_))) {
        i += 2;
    }
    let mut angle = 0i32;
    while let Some(t) = toks.get(i) {
        i += 1;
        match t {
            TokenTree::Group(g) if g.delimiter() == Delimiter::Brace => return i,
            TokenTree::Punct(p) => match p.as_char() {
                ';' => return i,
                ',' if angle <= 0 => return i,
                '<' => angle += 1,
                '>' if !(i >= 2
                    && matches!(&toks[i - 2], TokenTree::Punct(q) if matches!(q.as_char(), '-' | '=') && q.spacing() == Spacing::Joint)) =>
                {
                    angle -= 1
                }
                _ => {}
            },
            _ => {}
        }
    }
    i
}

/// Every path into the crate that `tokens` name, resolved in `scope`,
/// with `use` statements (in function bodies) expanded; test code
/// skipped by its attribute.
pub fn scan(tokens: TokenStream, scope: &Scope, out: &mut Vec<Named>) {
    let toks: Vec<TokenTree> = tokens.into_iter().collect();
    let mut i = 0;
    while i < toks.len() {
        if test_attribute(&toks, i) {
            i = skip_item(&toks, i);
            continue;
        }
        // a `use` in a block
        if ident(toks.get(i)).is_some_and(|s| s == "use") && !(i > 0 && colons(&toks, i.saturating_sub(2))) {
            let end = (i..toks.len()).find(|&k| punct(toks.get(k), ';')).unwrap_or(toks.len() - 1);
            let stream: TokenStream = toks[i..=end].iter().cloned().collect();
            if let Ok(u) = syn::parse2::<syn::ItemUse>(stream) {
                let mut ls = Vec::new();
                leaves(&u.tree, &mut Vec::new(), &mut ls);
                for l in ls {
                    if let Some(path) = scope.resolve(&l.segs) {
                        out.push(Named { line: l.line, path, is_macro: false, dollar: false });
                    }
                }
                i = end + 1;
                continue;
            }
        }
        if let Some((named, next)) = path_at(&toks, i, scope) {
            out.extend(named);
            i = next;
            continue;
        }
        if let TokenTree::Group(g) = &toks[i] {
            scan(g.stream(), scope, out);
        }
        i += 1;
    }
}

/// The path that starts at `toks[i]`, if a path starts there: the crate
/// path it names (if it leads into the crate) and the index after it.
fn path_at(toks: &[TokenTree], i: usize, scope: &Scope) -> Option<(Option<Named>, usize)> {
    // in the middle of a path (`a::b`) or after a `.` (a method, a field)
    if i > 0 && ((i > 1 && colons(toks, i - 2)) || punct(toks.get(i - 1), '.')) {
        return None;
    }
    let (dollar, start) = if punct(toks.get(i), '$') && ident(toks.get(i + 1)).is_some_and(|s| s == "crate") {
        (true, i + 1)
    } else {
        (false, i)
    };
    let first = ident(toks.get(start))?;
    if !colons(toks, start + 1) || ident(toks.get(start + 3)).is_none() {
        return None;
    }
    let line = line(toks[start].span());
    let mut segs = vec![if dollar { "$crate".to_string() } else { first }];
    let mut k = start + 1;
    while colons(toks, k)
        && let Some(s) = ident(toks.get(k + 2))
    {
        segs.push(s);
        k += 3;
    }
    let is_macro = punct(toks.get(k), '!');
    let named = scope.resolve(&segs).map(|path| Named { line, path, is_macro, dollar });
    Some((named, k))
}
