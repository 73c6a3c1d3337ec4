//! Validation of a parsed model. Every error is spanned at the user's token
//! and all of them are reported at once (after serde_derive's `Ctxt`).

use std::collections::HashMap;

use syn::Ident;

use crate::ast::{Affine, Drive, HingeTarget, ModelDef, Ref};

/// Collects errors; `finish` combines them into one.
#[derive(Default)]
pub struct Errors {
    first: Option<syn::Error>,
    count: usize,
}

impl Errors {
    /// Adds an error.
    pub fn push(&mut self, e: syn::Error) {
        self.count += 1;
        match &mut self.first {
            Some(first) => first.combine(e),
            None => self.first = Some(e),
        }
    }
    /// Number of errors so far.
    pub fn count(&self) -> usize {
        self.count
    }
    /// Adds an error at `tokens`.
    pub fn at<T: quote::ToTokens>(&mut self, tokens: T, msg: impl std::fmt::Display) {
        self.push(syn::Error::new_spanned(tokens, msg));
    }
    /// `Err` with every error pushed so far, if any.
    pub fn finish(self) -> syn::Result<()> {
        self.first.map_or(Ok(()), Err)
    }
}

/// A resolved reference to a point: its index among the point items and,
/// for a family point, which element (`None` for a single point).
pub type PointRef = (usize, Option<Affine>);

/// A body element: the body item and, for a family body, which element.
pub type BodyRef = (usize, Option<Affine>);

/// Names resolved to indices (`usize::MAX` where a name did not resolve;
/// such an item produces no expressions).
pub struct Resolved {
    /// Body item of every point.
    pub point_body: Vec<usize>,
    /// The element of the body family a single point sits on (`None` for a
    /// single body or for a family point, which sits on the element of the
    /// same index).
    pub point_body_index: Vec<Option<Affine>>,
    /// Points joined by every hinge (second is `None` for the ground).
    pub hinge_points: Vec<(PointRef, Option<PointRef>)>,
    /// Points of every slider: the moving point and the guiding point
    /// (`None` for a ground line).
    pub slider_points: Vec<(PointRef, Option<PointRef>)>,
    /// Hinge (index) of every drive.
    pub drive_hinge: Vec<usize>,
    /// Contact point of every skate.
    pub skate_point: Vec<PointRef>,
}

impl Resolved {
    /// The body element a point reference sits on.
    pub fn body_of(&self, def: &ModelDef, (p, index): &PointRef) -> BodyRef {
        let b = self.point_body[*p];
        if def.points[*p].family.is_some() { (b, index.clone()) } else { (b, self.point_body_index[*p].clone()) }
    }
}

/// Whether two body references are the same element for every count.
pub fn same_body(a: &BodyRef, b: &BodyRef) -> bool {
    a.0 == b.0
        && match (&a.1, &b.1) {
            (None, None) => true,
            (Some(x), Some(y)) => x.same(y),
            _ => false,
        }
}

fn check_unique<'a>(errs: &mut Errors, kind: &str, names: impl Iterator<Item = &'a Ident>) {
    let mut seen: HashMap<String, &Ident> = HashMap::new();
    for n in names {
        if seen.insert(n.to_string(), n).is_some() {
            errs.at(n, format!("duplicate {kind} name `{n}`"));
        }
    }
}

fn known(names: &[String]) -> String {
    if names.is_empty() { "none".to_string() } else { names.join(", ") }
}

/// Checks the counts an index names.
fn check_index(errs: &mut Errors, def: &ModelDef, a: &Affine) {
    if let Some(n) = &a.count
        && !def.counts.iter().any(|c| c.name == *n)
    {
        let names: Vec<String> = def.counts.iter().map(|c| c.name.to_string()).collect();
        errs.at(n, format!("unknown count `{n}` in an index; known counts: {}", known(&names)));
    }
}

/// The value of `a` at loop value `v` and the counts' declared values
/// (`None` where it names a count that does not exist).
fn value_at(def: &ModelDef, a: &Affine, v: i64) -> Option<i64> {
    let count = match &a.count {
        Some(n) => def.counts.iter().find(|c| c.name == *n)?.value,
        None => 0,
    };
    Some(a.c + count + if a.var { v } else { 0 })
}

/// The range `start..end` of family `f` at the counts' declared values.
fn range_at(def: &ModelDef, f: usize) -> Option<(i64, i64)> {
    let fam = &def.families[f];
    Some((value_at(def, &fam.start, 0)?, value_at(def, &fam.end, 0)?))
}

/// Checks that the element `a` of family `f`, named by an item of family
/// `within` (or a single item), exists at the counts' declared values
/// for every element of `within`: the first and the last suffice, the
/// index being `v + constant`. (At other counts the model's
/// `check_counts` checks it again.)
fn check_in_range(
    errs: &mut Errors,
    def: &ModelDef,
    owner: &str,
    name: &Ident,
    a: &Affine,
    f: usize,
    within: Option<usize>,
) {
    let Some((start, end)) = range_at(def, f) else { return };
    let values: Vec<i64> = match within {
        Some(w) if a.var => match range_at(def, w) {
            Some((s, e)) if e > s => vec![s, e - 1],
            _ => return,
        },
        _ => vec![0],
    };
    let var = within.map(|w| def.families[w].var.to_string()).unwrap_or_default();
    for v in values {
        let Some(value) = value_at(def, a, v) else { return };
        if value < start || value >= end {
            let counts: Vec<String> = def.counts.iter().map(|c| format!("{} = {}", c.name, c.value)).collect();
            let at = if a.var { format!(" at {var} = {v}") } else { String::new() };
            let fam = &def.families[f];
            errs.push(syn::Error::new(
                a.span,
                format!(
                    "{owner} refers to `{name}[{}]` = {name}{value}{at}, which does not exist: {name} has elements {start}..{end} ({}..{}, with {})",
                    a.show(&var),
                    fam.start.show(""),
                    fam.end.show(""),
                    if counts.is_empty() { "no count".to_string() } else { counts.join(", ") },
                ),
            ));
            return;
        }
    }
}

/// Resolves `r` among items named `names` whose families are `families`:
/// an element of a family needs an index (one that exists at the
/// declared counts, for every element of the family `within` the
/// reference is made in), a single item none.
#[expect(clippy::too_many_arguments, reason = "the reference, where it is made, and what it may name")]
fn resolve(
    errs: &mut Errors,
    def: &ModelDef,
    kind: &str,
    owner: &str,
    r: &Ref,
    names: &[String],
    families: &[Option<usize>],
    within: Option<usize>,
) -> usize {
    let Some(i) = names.iter().position(|n| r.name == n) else {
        let plural = if kind == "body" { "bodies".to_string() } else { format!("{kind}s") };
        errs.at(&r.name, format!("{owner} refers to unknown {kind} `{}`; known {plural}: {}", r.name, known(names)));
        return usize::MAX;
    };
    match (&r.index, families[i]) {
        (Some(a), Some(f)) => {
            check_index(errs, def, a);
            check_in_range(errs, def, owner, &r.name, a, f, within);
        }
        (None, Some(f)) => errs.at(
            &r.name,
            format!(
                "{owner}: `{}` is a family (`for {} in ..`); name one element, e.g. `{}[{}]`",
                r.name, def.families[f].var, r.name, def.families[f].var
            ),
        ),
        (Some(a), None) => errs.push(syn::Error::new(
            a.span,
            format!("{owner}: `{}` is a single {kind}, not a family; drop the index", r.name),
        )),
        (None, None) => {}
    }
    i
}

/// Checks names and references; returns the resolved indices.
pub fn check(def: &ModelDef, errs: &mut Errors) -> Resolved {
    check_names(def, errs);
    check_declared_size(def, errs);
    let lookup = Lookup {
        def,
        body_names: def.bodies.iter().map(|b| b.name.to_string()).collect(),
        body_families: def.bodies.iter().map(|b| b.family).collect(),
        point_names: def.points.iter().map(|p| p.name.to_string()).collect(),
        point_families: def.points.iter().map(|p| p.family).collect(),
    };
    let (point_body, point_body_index) = point_bodies(def, &lookup, errs);
    let res_points = Resolved {
        point_body: point_body.clone(),
        point_body_index: point_body_index.clone(),
        hinge_points: Vec::new(),
        slider_points: Vec::new(),
        drive_hinge: Vec::new(),
        skate_point: Vec::new(),
    };
    let hinge_points = def
        .hinges
        .iter()
        .map(|h| joint(errs, &lookup, &res_points, ("hinge", &h.name, h.family), &h.point, &h.target))
        .collect();
    let slider_points = def
        .sliders
        .iter()
        .map(|s| {
            let kind = if s.heading { "slider" } else { "slot" };
            joint(errs, &lookup, &res_points, (kind, &s.name, s.family), &s.point, &s.target)
        })
        .collect();
    let hinge_names: Vec<String> = def.hinges.iter().map(|h| h.name.to_string()).collect();
    let drive_hinge = def.drives.iter().map(|d| drive_hinge(errs, def, &hinge_names, d)).collect();
    let skate_point =
        def.skates.iter().map(|s| lookup.point(errs, &format!("skate `{}`", s.name), &s.point, s.family)).collect();
    Resolved { point_body, point_body_index, hinge_points, slider_points, drive_hinge, skate_point }
}

/// Checks that the declared counts give at most [`crate::MAX_COORDS`]
/// generalized coordinates (a model past it could not even describe
/// itself: its description lists every coordinate).
fn check_declared_size(def: &ModelDef, errs: &mut Errors) {
    let mut nq: i128 = 0;
    for b in &def.bodies {
        let n = match b.family {
            Some(f) => match range_at(def, f) {
                Some((s, e)) => i128::from(e.saturating_sub(s).max(0)),
                None => return,
            },
            None => 1,
        };
        nq += 3 * n;
    }
    if nq > crate::MAX_COORDS as i128
        && let Some(first) = def.counts.first()
    {
        let given: Vec<String> = def.counts.iter().map(|c| format!("{} = {}", c.name, c.value)).collect();
        errs.at(
            &first.name,
            format!(
                "{} give{} {nq} generalized coordinates, more than the {} ezy sets up; declare a smaller count (a scene may set it)",
                given.join(", "),
                if def.counts.len() == 1 { "s" } else { "" },
                crate::MAX_COORDS
            ),
        );
    }
}

/// The parameters defined by expressions ([`ModelDef::derived`]) in an
/// order in which each comes after those it names (Kahn's), and the
/// cycles among the rest: each as the indices into `derived` around it,
/// reported once. A parameter left out of the order and of every cycle
/// names one in a cycle.
pub fn derived_order(def: &ModelDef) -> (Vec<usize>, Vec<Vec<usize>>) {
    let n = def.derived.len();
    let by_name: HashMap<String, usize> =
        def.derived.iter().enumerate().map(|(k, d)| (d.name.to_string(), k)).collect();
    let uses: Vec<Vec<usize>> = def
        .derived
        .iter()
        .map(|d| {
            let mut names = Vec::new();
            idents(&d.expr, &mut names);
            let mut k: Vec<usize> = names.iter().filter_map(|id| by_name.get(&id.to_string()).copied()).collect();
            k.sort_unstable();
            k.dedup();
            k
        })
        .collect();
    let mut users = vec![Vec::new(); n];
    for (j, u) in uses.iter().enumerate() {
        for &k in u {
            users[k].push(j);
        }
    }
    let mut waiting: Vec<usize> = uses.iter().map(Vec::len).collect();
    let mut order: Vec<usize> = (0..n).filter(|&j| waiting[j] == 0).collect();
    let mut at = 0;
    while at < order.len() {
        for &j in &users[order[at]] {
            waiting[j] -= 1;
            if waiting[j] == 0 {
                order.push(j);
            }
        }
        at += 1;
    }
    // the rest: a depth-first search from each, among the rest, for a
    // way back to it
    let mut reported = vec![false; n];
    let mut cycles = Vec::new();
    for start in (0..n).filter(|&j| waiting[j] > 0) {
        if reported[start] {
            continue;
        }
        let mut path = vec![start];
        let mut next = vec![0usize];
        let mut seen = vec![false; n];
        while let Some(&j) = path.last() {
            let i = next[next.len() - 1];
            if i == uses[j].len() {
                path.pop();
                next.pop();
                continue;
            }
            *next.last_mut().expect("as long as path") += 1;
            let k = uses[j][i];
            if k == start {
                path.iter().for_each(|&c| reported[c] = true);
                cycles.push(std::mem::take(&mut path));
                break;
            }
            if waiting[k] > 0 && !seen[k] && !reported[k] {
                seen[k] = true;
                path.push(k);
                next.push(0);
            }
        }
    }
    (order, cycles)
}

/// The identifiers `e` names (paths of one segment, function names
/// aside), with a stack of its own: a chain `a + b + c + ...` is as deep
/// as it is long, which the text's nesting bound does not limit.
fn idents<'e>(e: &'e syn::Expr, out: &mut Vec<&'e Ident>) {
    use syn::Expr;
    let mut stack = vec![e];
    while let Some(e) = stack.pop() {
        match e {
            Expr::Path(p) => out.extend(p.path.get_ident()),
            Expr::Paren(p) => stack.push(&p.expr),
            Expr::Group(g) => stack.push(&g.expr),
            Expr::Unary(u) => stack.push(&u.expr),
            Expr::Binary(b) => stack.extend([&*b.left, &*b.right]),
            Expr::Call(c) => stack.extend(c.args.iter()),
            _ => {}
        }
    }
}

/// Checks that names are unique, parameters finite, family variables
/// named apart from parameters and counts, and that there is a body.
fn check_names(def: &ModelDef, errs: &mut Errors) {
    check_unique(
        errs,
        "parameter",
        def.params
            .iter()
            .map(|p| &p.name)
            .chain(def.derived.iter().map(|p| &p.name))
            .chain(def.counts.iter().map(|c| &c.name)),
    );
    for cycle in derived_order(def).1 {
        let names: Vec<String> = cycle.iter().map(|&k| def.derived[k].name.to_string()).collect();
        errs.at(
            &def.derived[cycle[0]].name,
            format!(
                "parameter `{}` is defined by itself: {} -> {}; define one of them by a number",
                names[0],
                names.join(" -> "),
                names[0]
            ),
        );
    }
    check_unique(errs, "body", def.bodies.iter().map(|b| &b.name));
    check_unique(errs, "point", def.points.iter().map(|p| &p.name));
    check_unique(errs, "hinge", def.hinges.iter().map(|h| &h.name));
    check_unique(errs, "skate", def.skates.iter().map(|s| &s.name));
    check_unique(
        errs,
        "joint or drive",
        def.hinges
            .iter()
            .map(|h| &h.name)
            .chain(def.sliders.iter().map(|s| &s.name))
            .chain(def.drives.iter().map(|d| &d.name)),
    );
    check_unique(errs, "coordinate", def.bodies.iter().flat_map(|b| b.coords.iter()));
    for p in &def.params {
        if !p.value.is_finite() {
            errs.push(syn::Error::new(p.value_span, format!("parameter `{}` must be finite", p.name)));
        }
    }
    for f in &def.families {
        check_index(errs, def, &f.start);
        check_index(errs, def, &f.end);
        // the variable names the element's index in the family's expressions
        let kind = if def.params.iter().any(|p| p.name == f.var) || def.derived.iter().any(|p| p.name == f.var) {
            Some("parameter")
        } else if def.counts.iter().any(|c| c.name == f.var) {
            Some("count")
        } else {
            None
        };
        if let Some(kind) = kind {
            errs.at(
                &f.var,
                format!(
                    "the family variable `{v}` has the name of {kind} `{v}`; in the family's expressions `{v}` names the element's index, so rename one",
                    v = f.var
                ),
            );
        }
    }
    if def.bodies.is_empty() {
        errs.at(
            &def.name,
            format!("model `{}` has no body; add `body NAME(x, y, phi) {{ mass: .., inertia: .. }}`", def.name),
        );
    }
}

/// The names and families of the bodies and points a reference may name.
struct Lookup<'a> {
    def: &'a ModelDef,
    body_names: Vec<String>,
    body_families: Vec<Option<usize>>,
    point_names: Vec<String>,
    point_families: Vec<Option<usize>>,
}

impl Lookup<'_> {
    /// Resolves a reference to a point of `owner`, an item of family
    /// `within` (or a single item).
    fn point(&self, errs: &mut Errors, owner: &str, r: &Ref, within: Option<usize>) -> PointRef {
        (resolve(errs, self.def, "point", owner, r, &self.point_names, &self.point_families, within), r.index.clone())
    }
}

/// Every point's body item and, for a single point, the element of a body
/// family it sits on ([`Resolved::point_body`], [`Resolved::point_body_index`]);
/// a family point sits on the element of the same index of a body family.
fn point_bodies(def: &ModelDef, lookup: &Lookup, errs: &mut Errors) -> (Vec<usize>, Vec<Option<Affine>>) {
    let mut point_body = Vec::with_capacity(def.points.len());
    let mut point_body_index = Vec::with_capacity(def.points.len());
    for p in &def.points {
        let owner = format!("point `{}`", p.name);
        let b = resolve(errs, def, "body", &owner, &p.body, &lookup.body_names, &lookup.body_families, p.family);
        point_body.push(b);
        let exact = p.body.index.as_ref().is_some_and(|a| a.var && a.count.is_none() && a.c == 0);
        match p.family {
            Some(f) if b != usize::MAX && (def.bodies[b].family.is_none() || !exact) => {
                let v = &def.families[f].var;
                errs.at(
                    &p.body.name,
                    format!(
                        "point `{}[{v}]` of a family sits on the element of the same index of a body family: write `on BODY[{v}]`",
                        p.name
                    ),
                );
                point_body_index.push(None);
            }
            Some(_) => point_body_index.push(None),
            None => point_body_index.push(p.body.index.clone()),
        }
    }
    (point_body, point_body_index)
}

/// The two points a joint relates: distinct, on different bodies
/// (`res_points` has the points' bodies resolved).
fn joint(
    errs: &mut Errors,
    lookup: &Lookup,
    res_points: &Resolved,
    (kind, name, within): (&str, &Ident, Option<usize>),
    point: &Ref,
    target: &HingeTarget,
) -> (PointRef, Option<PointRef>) {
    let (def, point_body) = (lookup.def, &res_points.point_body);
    let owner = format!("{kind} `{name}`");
    let a = lookup.point(errs, &owner, point, within);
    let b = match target {
        HingeTarget::Point(p) => {
            let b = lookup.point(errs, &owner, p, within);
            if a.0 != usize::MAX && b.0 != usize::MAX {
                let same_point = a.0 == b.0
                    && match (&a.1, &b.1) {
                        (None, None) => true,
                        (Some(x), Some(y)) => x.same(y),
                        _ => false,
                    };
                if same_point {
                    errs.at(&p.name, format!("{kind} `{name}` joins point `{}` to itself", p.name));
                } else if point_body[a.0] != usize::MAX
                    && point_body[b.0] != usize::MAX
                    && same_body(&res_points.body_of(def, &a), &res_points.body_of(def, &b))
                {
                    errs.at(
                        &p.name,
                        format!(
                            "{kind} `{name}` joins two points of the same body `{}`; a {kind} joins two bodies (or a body and `ground(x, y)`)",
                            lookup.body_names[point_body[a.0]]
                        ),
                    );
                }
            }
            Some(b)
        }
        HingeTarget::Ground { .. } => None,
    };
    (a, b)
}

/// The hinge a drive drives, among `hinge_names` (`usize::MAX` if
/// unknown): a family drive drives the hinge element of its own index,
/// over the hinge family's very range; a single drive a single hinge.
fn drive_hinge(errs: &mut Errors, def: &ModelDef, hinge_names: &[String], d: &Drive) -> usize {
    let owner = format!("drive `{}`", d.name);
    let Some(h) = hinge_names.iter().position(|h| d.hinge.name == h) else {
        errs.at(
            &d.hinge.name,
            format!("{owner} refers to unknown hinge `{}`; known hinges: {}", d.hinge.name, known(hinge_names)),
        );
        return usize::MAX;
    };
    if let Some(a) = &d.hinge.index {
        check_index(errs, def, a);
    }
    match (d.family, def.hinges[h].family) {
        (Some(fd), Some(fh)) => {
            let exact = d.hinge.index.as_ref().is_some_and(|a| a.var && a.count.is_none() && a.c == 0);
            let (rd, rh) = (&def.families[fd], &def.families[fh]);
            if !exact {
                errs.at(
                    &d.hinge.name,
                    format!("{owner}: a family drive drives the hinge of its own index: write `hinge {}[{}]`", d.hinge.name, rd.var),
                );
            } else if !(rd.start.same(&rh.start) && rd.end.same(&rh.end)) {
                errs.at(
                    &d.hinge.name,
                    format!(
                        "{owner}: the drive family ranges over {}..{} but the hinge family `{}` over {}..{}; declare the drive in a `for` with the hinge's range",
                        rd.start.show(&rd.var.to_string()),
                        rd.end.show(&rd.var.to_string()),
                        d.hinge.name,
                        rh.start.show(&rh.var.to_string()),
                        rh.end.show(&rh.var.to_string())
                    ),
                );
            }
        }
        (None, Some(fh)) => errs.at(
            &d.hinge.name,
            format!(
                "{owner}: `{}` is a hinge family: drive all of it with `for {} in ..` and `drive {}[{}]: hinge {}[{}];` (one element alone cannot be driven)",
                d.hinge.name, def.families[fh].var, d.name, def.families[fh].var, d.hinge.name, def.families[fh].var
            ),
        ),
        (Some(_), None) => errs.at(
            &d.hinge.name,
            format!("{owner}: `{}` is a single hinge; a single drive drives it (`drive {}: hinge {};` outside the `for`)", d.hinge.name, d.name, d.hinge.name),
        ),
        (None, None) => {
            if let Some(a) = &d.hinge.index {
                errs.push(syn::Error::new(
                    a.span,
                    format!("{owner}: `{}` is a single hinge, not a family; drop the index", d.hinge.name),
                ));
            }
        }
    }
    h
}
