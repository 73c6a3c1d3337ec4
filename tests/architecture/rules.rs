//! The rules, on a crate as read (`source::read`): floors, circles
//! between floor-table modules and between the files of one folder,
//! items named where they are defined, commands apart.

use std::collections::{BTreeMap, BTreeSet};

use crate::source::{Crate, Import, Named, Target, Vis};

/// One line of a crate's floor table: a module (relative to `crate`),
/// its floor, and what it holds (one line, printed in
/// docs/dev/architecture.md). A module belongs to the longest module of
/// its crate's table that is a prefix of its path.
pub struct Floor {
    pub module: &'static str,
    pub floor: u32,
    pub holds: &'static str,
}

/// A module outside the floors, and why (a door: it only re-exports for
/// the crate's users).
pub struct Door {
    pub module: &'static str,
    pub reason: &'static str,
}

/// An item whose naming does not count toward the circle rule of its
/// folder's files, and why: the one deliberate knot of a folder, named
/// item by item so that any other import between the same files still
/// counts.
pub struct Knot {
    /// The item's path (relative to `crate`); a path below it (a variant)
    /// is the item too.
    pub item: &'static str,
    pub reason: &'static str,
}

/// A crate's rules.
pub struct Rules {
    /// The crate's package name.
    pub name: &'static str,
    /// Its source folder, relative to the workspace.
    pub src: &'static str,
    /// The crate root's file in `src`.
    pub root: &'static str,
    pub floors: &'static [Floor],
    /// Modules outside the floors that only re-export for the crate's
    /// users (the crate root always is one): the code of the crate names
    /// nothing through them, and their own imports are not checked.
    pub doors: &'static [Door],
    /// Items whose naming does not count toward the circle rule of the
    /// files of a folder.
    pub knots: &'static [Knot],
    /// A folder whose child modules are commands: none imports another.
    pub commands: Option<&'static str>,
}

/// A broken rule, as the failure message prints it.
pub type Violation = String;

/// The module a path names, and the item after it (`None`: the path
/// names the module itself).
pub fn split(path: &[String], is_macro: bool, krate: &Crate) -> (String, Option<String>) {
    let most = if is_macro { path.len().saturating_sub(1) } else { path.len() };
    for n in (0..=most).rev() {
        let m = path[..n].join("::");
        if krate.modules.contains_key(&m) {
            return (m, path.get(n).cloned());
        }
    }
    (String::new(), path.first().cloned())
}

/// How a module has the name `item`.
enum Found<'k> {
    /// One of its items defines it (or nothing of it does: an item made
    /// by a macro, a variant).
    Here,
    /// One of its `use` items binds it.
    Import(&'k Import),
    /// A glob `use` brings it from a module that has it.
    Glob(&'k Import),
}

fn find<'k>(krate: &'k Crate, module: &str, item: &str, depth: u32) -> Found<'k> {
    let m = &krate.modules[module];
    if m.defines.contains(item) {
        return Found::Here;
    }
    if let Some(imp) = m.imports.iter().find(|i| i.name.as_deref() == Some(item)) {
        return Found::Import(imp);
    }
    if depth < 8 {
        for imp in m.imports.iter().filter(|i| i.name.is_none()) {
            if let Target::Crate(p) = &imp.target
                && let (g, None) = split(p, false, krate)
                && g != module
                && has(krate, &g, item, depth + 1)
            {
                return Found::Glob(imp);
            }
        }
    }
    Found::Here
}

/// Whether `module` defines `item` or imports it.
fn has(krate: &Crate, module: &str, item: &str, depth: u32) -> bool {
    let m = &krate.modules[module];
    m.defines.contains(item)
        || m.imports.iter().any(|i| i.name.as_deref() == Some(item))
        || matches!(find(krate, module, item, depth), Found::Glob(_))
}

/// The module of the crate that defines `item` of `module`, through its
/// re-exports (an item of another crate stays with the module of this
/// one that re-exports it); `module` itself when `item` is `None`.
pub fn home(krate: &Crate, module: &str, item: Option<&str>, depth: u32) -> String {
    let Some(item) = item else { return module.to_string() };
    if depth > 8 {
        return module.to_string();
    }
    match find(krate, module, item, depth) {
        Found::Here => module.to_string(),
        Found::Import(imp) | Found::Glob(imp) => match &imp.target {
            Target::External(_) => module.to_string(),
            Target::Crate(p) => {
                let (m, i) = split(p, false, krate);
                let next = if imp.name.is_some() { i.as_deref() } else { Some(item) };
                home(krate, &m, next, depth + 1)
            }
        },
    }
}

/// Where `item` of `module` is defined, as a path to write.
fn defining(krate: &Crate, module: &str, item: &str, depth: u32) -> String {
    let here = || format!("crate::{}", join(module, item));
    if depth > 8 {
        return here();
    }
    let next = |imp: &Import, item: &str| match &imp.target {
        Target::External(p) if imp.name.is_some() => p.clone(),
        Target::External(p) => format!("{p}::{item}"),
        Target::Crate(p) => {
            let (m, i) = split(p, false, krate);
            match (i, imp.name.is_some()) {
                (Some(i), true) => defining(krate, &m, &i, depth + 1),
                (None, true) => format!("crate::{m}"),
                (_, false) => defining(krate, &m, item, depth + 1),
            }
        }
    };
    match find(krate, module, item, depth) {
        Found::Here => here(),
        Found::Import(imp) | Found::Glob(imp) => next(imp, item),
    }
}

pub fn join(a: &str, b: &str) -> String {
    match (a.is_empty(), b.is_empty()) {
        (true, _) => b.to_string(),
        (_, true) => a.to_string(),
        _ => format!("{a}::{b}"),
    }
}

/// The table line a module belongs to: the longest prefix of its path.
pub fn unit_of<'r>(path: &str, floors: &'r [Floor]) -> Option<&'r Floor> {
    floors
        .iter()
        .filter(|f| path == f.module || path.starts_with(&format!("{}::", f.module)))
        .max_by_key(|f| f.module.len())
}

/// One import between two nodes (table modules, or files of a folder):
/// where it is written and what it names.
#[derive(Clone)]
struct Edge {
    at: String,
    what: String,
}

type Graph = BTreeMap<String, BTreeMap<String, Edge>>;

/// Every broken rule of `krate` by `rules`.
pub fn check(krate: &Crate, rules: &Rules) -> Vec<Violation> {
    let mut bad: Vec<Violation> = krate.problems.clone();
    let doors: BTreeSet<&str> = rules.doors.iter().map(|d| d.module).chain([""]).collect();
    for f in rules.floors {
        if !krate.modules.contains_key(f.module) {
            bad.push(format!(
                "the floor table of {} names `{}`, which is no module of the crate",
                rules.name, f.module
            ));
        }
    }
    let mut units: Graph = BTreeMap::new();
    let mut folders: BTreeMap<String, Graph> = BTreeMap::new();
    for (a, m) in &krate.modules {
        let unit = unit_of(a, rules.floors);
        if unit.is_none() && !doors.contains(a.as_str()) {
            bad.push(format!("{}: module `{a}` has no floor in the table of {}", m.file, rules.name));
        }
        for n in &m.names {
            let at = krate.at(a, n.line);
            let (named, item) = split(&n.path, n.is_macro, krate);
            let what = format!("`crate::{}{}`", n.path.join("::"), if n.is_macro { "!" } else { "" });
            if let Some(v) = through_reexport(krate, &doors, a, n, &named, item.as_deref(), &at, &what) {
                bad.push(v);
            }
            // what the path depends on: the module that defines the item
            let t = home(krate, &named, item.as_deref(), 0);
            if let Some(cmds) = rules.commands {
                let command =
                    |p: &str| p.strip_prefix(&format!("{cmds}::")).map(|r| r.split("::").next().unwrap().to_string());
                if let (Some(x), Some(y)) = (command(a), command(&t))
                    && x != y
                {
                    bad.push(format!(
                        "{at}: the command `{cmds}::{x}` imports the command `{cmds}::{y}` ({what}): a command imports no other"
                    ));
                }
            }
            if let (Some(u), Some(v)) = (unit, unit_of(&t, rules.floors))
                && u.module != v.module
            {
                if v.floor > u.floor {
                    bad.push(format!(
                        "{at}: {} imports {what} from {}: an import goes only down",
                        placed(a, u),
                        placed(&t, v)
                    ));
                } else {
                    let e = Edge { at: at.clone(), what: what.clone() };
                    units.entry(u.module.to_string()).or_default().entry(v.module.to_string()).or_insert(e);
                }
            }
            if doors.contains(a.as_str()) || unit.map(|u| u.module) != unit_of(&t, rules.floors).map(|u| u.module) {
                continue;
            }
            let path = n.path.join("::");
            if rules.knots.iter().any(|k| path == k.item || path.starts_with(&format!("{}::", k.item))) {
                continue;
            }
            if let Some((folder, x, y)) = folder_nodes(a, &t) {
                let e = Edge { at, what };
                folders.entry(folder).or_default().entry(x).or_default().entry(y).or_insert(e);
            }
        }
    }
    for circle in circles(&units) {
        bad.push(format!("modules of {}'s floor table import each other in a circle: {circle}", rules.name));
    }
    for (folder, graph) in &folders {
        for circle in circles(graph) {
            let name = if folder.is_empty() { "the crate root".to_string() } else { format!("`{folder}`") };
            bad.push(format!(
                "the files of {name} ({}) import each other in a circle: {circle}",
                folder_file(krate, folder)
            ));
        }
    }
    bad
}

/// A module and its line of the table, as messages name them.
fn placed(module: &str, f: &Floor) -> String {
    if module == f.module {
        format!("`{module}` (floor {})", f.floor)
    } else {
        format!("`{module}` (in `{}`, floor {})", f.module, f.floor)
    }
}

/// The folder a module's files are in, as messages print it.
fn folder_file(krate: &Crate, folder: &str) -> String {
    let f = &krate.modules[folder].file;
    format!("{}/", f.rsplit_once('/').map_or(f.as_str(), |(d, _)| d))
}

/// The folder two modules share, and each one's node in it: the child
/// of the folder it is in; `None` where one of them is the folder's own
/// file (its `mod.rs`), which declares the files and is not one of them.
fn folder_nodes(a: &str, t: &str) -> Option<(String, String, String)> {
    if a == t {
        return None;
    }
    let sa: Vec<&str> = if a.is_empty() { vec![] } else { a.split("::").collect() };
    let st: Vec<&str> = if t.is_empty() { vec![] } else { t.split("::").collect() };
    let common = sa.iter().zip(&st).take_while(|(x, y)| x == y).count();
    let folder = sa[..common].join("::");
    let node = |s: &[&str]| s.get(common).map(|c| join(&folder, c));
    Some((folder.clone(), node(&sa)?, node(&st)?))
}

/// The re-export rule: a module names an item where it is defined.
#[expect(clippy::too_many_arguments, reason = "the name's parts, each printed")]
fn through_reexport(
    krate: &Crate,
    doors: &BTreeSet<&str>,
    a: &str,
    n: &Named,
    t: &str,
    item: Option<&str>,
    at: &str,
    what: &str,
) -> Option<Violation> {
    let item = item?;
    if t == a || n.dollar || doors.contains(a) {
        return None;
    }
    let found = find(krate, t, item, 0);
    let def = defining(krate, t, item, 0);
    let where_ = |imp: &Import| format!("{}:{}", krate.modules[t].file, imp.line);
    match found {
        Found::Here => None,
        Found::Import(imp) if t.is_empty() => Some(format!(
            "{at}: `{a}` names {what} through the crate root's `{} {item}` ({}); name it where it is defined: `{def}`",
            imp.vis.spelling(),
            where_(imp)
        )),
        Found::Import(imp) => Some(format!(
            "{at}: `{a}` names {what} through the `{}` in `{t}` ({}); name it where it is defined: `{def}`",
            imp.vis.spelling(),
            where_(imp)
        )),
        Found::Glob(imp) => {
            let Target::Crate(src) = &imp.target else { return None };
            let vis = if imp.vis == Vis::Private { "use" } else { imp.vis.spelling() };
            Some(format!(
                "{at}: `{a}` names {what} through the glob `{vis} crate::{}::*` in `{}` ({}); name it where it is defined: `{def}`",
                src.join("::"),
                if t.is_empty() { "the crate root" } else { t },
                where_(imp)
            ))
        }
    }
}

/// The circles of a graph: one line per strongly connected component
/// of more than one node, with a shortest circle through its first
/// node, each step with the import that makes it.
fn circles(graph: &Graph) -> Vec<String> {
    let nodes: BTreeSet<&String> = graph.keys().chain(graph.values().flat_map(|e| e.keys())).collect();
    let reach = |from: &str| -> BTreeSet<String> {
        let mut seen = BTreeSet::new();
        let mut stack = vec![from.to_string()];
        while let Some(n) = stack.pop() {
            for next in graph.get(&n).into_iter().flat_map(|e| e.keys()) {
                if seen.insert(next.clone()) {
                    stack.push(next.clone());
                }
            }
        }
        seen
    };
    let reaches: BTreeMap<&String, BTreeSet<String>> = nodes.iter().map(|n| (*n, reach(n))).collect();
    let mut done: BTreeSet<String> = BTreeSet::new();
    let mut out = Vec::new();
    for n in &nodes {
        if done.contains(*n) || !reaches[n].contains(*n) {
            continue;
        }
        let component: BTreeSet<String> = reaches[n].iter().filter(|m| reaches[*m].contains(*n)).cloned().collect();
        done.extend(component.iter().cloned());
        // a shortest circle from `n` back to `n`
        let mut prev: BTreeMap<String, String> = BTreeMap::new();
        let mut queue = std::collections::VecDeque::from([n.to_string()]);
        let mut last = None;
        while let Some(x) = queue.pop_front() {
            for y in graph.get(&x).into_iter().flat_map(|e| e.keys()) {
                if y == *n {
                    last = Some(x.clone());
                    break;
                }
                if !prev.contains_key(y) {
                    prev.insert(y.clone(), x.clone());
                    queue.push_back(y.clone());
                }
            }
            if last.is_some() {
                break;
            }
        }
        let mut path = vec![n.to_string()];
        let mut x = last.unwrap();
        while x != **n {
            path.push(x.clone());
            x = prev[&x].clone();
        }
        let len = path.len();
        path[1..len].reverse();
        path.push(n.to_string());
        let steps: Vec<String> = path
            .windows(2)
            .map(|w| {
                let e = &graph[&w[0]][&w[1]];
                format!("`{}` -> `{}` ({}: {})", show(&w[0]), show(&w[1]), e.at, e.what)
            })
            .collect();
        let members: Vec<String> = component.iter().map(|m| format!("`{}`", show(m))).collect();
        out.push(format!("{} modules ({}); {}", component.len(), members.join(", "), steps.join(", ")));
    }
    out
}

fn show(module: &str) -> &str {
    if module.is_empty() { "crate" } else { module }
}
