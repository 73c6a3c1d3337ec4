//! `quote!` the struct, its `Default` and its `Model` impl from the derived
//! expressions.
//!
//! A model without families gets straight-line code: every expression it
//! needs, renamed to global coordinates, in arena order, as `let` bindings
//! (shared subexpressions computed once per call), and straight-line
//! products with `G` at its compile-time pattern. A model with families
//! gets, per constraint item, one element kernel inside a loop over the
//! family's elements: the element's coordinates are gathered from `q` by
//! the runtime layout ([`ezy_core::__private::Layout`]), so the generated
//! code does not grow with the counts.

use proc_macro2::{Literal, TokenStream};
use quote::{format_ident, quote};

use std::collections::HashMap;

use crate::ast::{Affine, ModelDef, doc_of, escape_unit, split_unit};
use crate::check::{BodyRef, PointRef, Resolved};
use crate::kinematics::{Derived, Group, Kind, own_index};
use crate::sym::{Arena, Id, Node, Sym};

fn lit_f64(v: f64) -> TokenStream {
    if v.is_finite() {
        let l = Literal::f64_suffixed(v);
        quote!(#l)
    } else {
        quote!(::core::f64::NAN)
    }
}

/// `a op b op c ...`
fn join(items: impl Iterator<Item = TokenStream>, op: TokenStream) -> TokenStream {
    let mut out = TokenStream::new();
    for (i, item) in items.enumerate() {
        if i > 0 {
            out.extend(op.clone());
        }
        out.extend(item);
    }
    out
}

/// How generated code names coordinates: `q[k]` (global, straight-line) or
/// `ql[k]` (an element's local copy).
#[derive(Clone, Copy, PartialEq, Eq)]
enum Coords {
    Global,
    Local,
}

/// Straight-line code computing `outputs`: `(let bindings, one expression
/// per output)`. `Sym::Index(k)` is the value of `indices[k]` at the loop
/// value `v` of [`each_element`] (empty outside a family).
fn lower(
    d: &Derived,
    def: &ModelDef,
    outputs: &[Id],
    coords: Coords,
    indices: &[Affine],
) -> (TokenStream, Vec<TokenStream>) {
    let refer = |id: Id| -> TokenStream {
        match d.ar.node(id) {
            Node::Sym(Sym::Q(k)) if coords == Coords::Global => quote!(q[#k]),
            Node::Sym(Sym::Qd(k)) if coords == Coords::Global => quote!(qd[#k]),
            Node::Sym(Sym::Q(k)) => quote!(ql[#k]),
            Node::Sym(Sym::Qd(k)) => quote!(qdl[#k]),
            _ => leaf_or_let(d, def, id),
        }
    };
    let lets = let_bindings(d, def, &d.ar.reachable(outputs), &refer, indices);
    (lets, outputs.iter().map(|&o| refer(o)).collect())
}

/// How generated code refers to a number (`S::from_f64(..)`), a parameter
/// (its `p_NAME` binding), a family index (its `ixK` binding) or a
/// computed node (its `tNN` binding).
fn leaf_or_let(d: &Derived, def: &ModelDef, id: Id) -> TokenStream {
    let private = runtime();
    match d.ar.node(id) {
        Node::Const(bits) => {
            let l = lit_f64(f64::from_bits(*bits));
            quote!(<S as #private::Scalar>::from_f64(#l))
        }
        Node::Sym(Sym::Param(i)) => {
            let p = format_ident!("p_{}", def.params[*i].name);
            quote!(#p)
        }
        Node::Sym(Sym::Index(k)) => {
            let ix = format_ident!("ix{}", k);
            quote!(#ix)
        }
        _ => {
            let t = format_ident!("t{}", id.index());
            quote!(#t)
        }
    }
}

/// The `let` bindings of the nodes `ids` (ascending: an evaluation order):
/// a parameter read from its field, a family index `Sym::Index(k)`
/// computed from the loop value `v` (the value of `indices[k]`, an
/// integer, as a real), every other non-leaf node computed from its
/// children as `refer` names them.
fn let_bindings(
    d: &Derived,
    def: &ModelDef,
    ids: &[Id],
    refer: &dyn Fn(Id) -> TokenStream,
    indices: &[Affine],
) -> TokenStream {
    let private = runtime();
    let scalar = quote!(<S as #private::Scalar>);
    let mut lets = TokenStream::new();
    // a sine and a cosine of one angle in this batch are one `sin_cos`
    // (one argument reduction), bound where the first of the two is
    let mut partner: HashMap<(Id, bool), Id> = HashMap::new();
    for &id in ids {
        match d.ar.node(id) {
            Node::Sin(a) => partner.insert((*a, true), id),
            Node::Cos(a) => partner.insert((*a, false), id),
            _ => None,
        };
    }
    let mut paired: std::collections::HashSet<Id> = std::collections::HashSet::new();
    for &id in ids {
        if paired.contains(&id) {
            continue;
        }
        let pair = match d.ar.node(id) {
            Node::Sin(a) => partner.get(&(*a, false)).map(|&c| (*a, id, c)),
            Node::Cos(a) => partner.get(&(*a, true)).map(|&s| (*a, s, id)),
            _ => None,
        };
        if let Some((a, s, c)) = pair {
            let a = refer(a);
            let (ts, tc) = (format_ident!("t{}", s.index()), format_ident!("t{}", c.index()));
            lets.extend(quote!(let (#ts, #tc): (S, S) = #scalar::sin_cos(#a);));
            paired.insert(if s == id { c } else { s });
            continue;
        }
        let rhs = match d.ar.node(id) {
            Node::Sym(Sym::Param(i)) => {
                let p = format_ident!("p_{}", def.params[*i].name);
                let field = &def.params[*i].name;
                lets.extend(quote!(let #p: S = #scalar::from_f64(self.#field);));
                continue;
            }
            Node::Sym(Sym::Index(k)) => {
                let ix = format_ident!("ix{}", k);
                let a = affine_tokens(indices.get(*k).expect("a family index names an index of its kernel"));
                lets.extend(quote!(let #ix: S = #scalar::from_f64(#a as f64);));
                continue;
            }
            Node::Const(_) | Node::Sym(_) => continue,
            Node::Add(ts) => join(ts.iter().map(|&t| refer(t)), quote!(+)),
            Node::Mul(fs) => {
                if d.ar.as_const(fs[0]) == Some(-1.0) {
                    let p = join(fs[1..].iter().map(|&f| refer(f)), quote!(*));
                    quote!(-(#p))
                } else {
                    join(fs.iter().map(|&f| refer(f)), quote!(*))
                }
            }
            Node::Pow(b, n) => {
                let b = refer(*b);
                match *n {
                    2 => quote!(#b * #b),
                    3 => quote!(#b * #b * #b),
                    -1 => quote!(#scalar::recip(#b)),
                    -2 => quote!(#scalar::recip(#b * #b)),
                    n => quote!(#scalar::powi(#b, #n)),
                }
            }
            Node::Sin(a) => {
                let a = refer(*a);
                quote!(#scalar::sin(#a))
            }
            Node::Cos(a) => {
                let a = refer(*a);
                quote!(#scalar::cos(#a))
            }
            Node::Sqrt(a) => {
                let a = refer(*a);
                quote!(#scalar::sqrt(#a))
            }
        };
        let t = format_ident!("t{}", id.index());
        lets.extend(quote!(let #t: S = #rhs;));
    }
    lets
}

/// Straight-line code for a right-hand side whose fixed nodes (numbers
/// and parameters only, `Arena::fixed_nodes`; not a single number or
/// parameter) that another node or an output uses are read from the table
/// `k` instead of computed. The bindings are emitted on demand, just
/// before the statement that needs them, so that a block that runs only
/// sometimes (a body's force that is not zero) can bind its own values
/// in its own scope. (The order is not a speed matter: the compiler
/// schedules the straight-line code itself; a depth-first order with the
/// costlier operand first executed the same instructions.)
struct Hoisted<'a> {
    d: &'a Derived,
    def: &'a ModelDef,
    name: &'a dyn Fn(Sym) -> TokenStream,
    /// The table's nodes, in the order of `k`, and each one's slot.
    table: Vec<Id>,
    slot: HashMap<Id, usize>,
    /// Whether a node was bound already.
    done: Vec<bool>,
    /// Where set, a sine or cosine is bound together with its partner
    /// (the cosine or sine of the same angle) if the partner is marked
    /// here: the nodes the function binds somewhere (one `sin_cos`, one
    /// argument reduction, where the two would be bound apart).
    pair_with: Option<Vec<bool>>,
    /// Every node bound, in order (what `pair_with` is made of).
    log: Vec<Id>,
}

impl<'a> Hoisted<'a> {
    /// The table of the nodes `outputs` need.
    fn new(d: &'a Derived, def: &'a ModelDef, outputs: &[Id], name: &'a dyn Fn(Sym) -> TokenStream) -> Self {
        let fixed = d.ar.fixed_nodes();
        let mut seen = vec![false; fixed.len()];
        let mut stack: Vec<Id> = outputs.to_vec();
        let mut table = Vec::new();
        while let Some(id) = stack.pop() {
            if std::mem::replace(&mut seen[id.index()], true) {
                continue;
            }
            match d.ar.node(id) {
                Node::Const(_) | Node::Sym(_) => {}
                _ if fixed[id.index()] => table.push(id),
                Node::Add(xs) | Node::Mul(xs) => stack.extend_from_slice(xs),
                Node::Pow(a, _) | Node::Sin(a) | Node::Cos(a) | Node::Sqrt(a) => stack.push(*a),
            }
        }
        table.sort();
        let slot = table.iter().enumerate().map(|(i, &id)| (id, i)).collect();
        Self { d, def, name, table, slot, done: vec![false; fixed.len()], pair_with: None, log: Vec::new() }
    }

    /// Whether `id` is computed here: not a number, symbol or table entry.
    fn computed(&self, id: Id) -> bool {
        !matches!(self.d.ar.node(id), Node::Const(_) | Node::Sym(_)) && !self.slot.contains_key(&id)
    }

    fn children(&self, id: Id) -> Vec<Id> {
        match self.d.ar.node(id) {
            Node::Add(xs) | Node::Mul(xs) => xs.to_vec(),
            Node::Pow(a, _) | Node::Sin(a) | Node::Cos(a) | Node::Sqrt(a) => vec![*a],
            Node::Const(_) | Node::Sym(_) => Vec::new(),
        }
    }

    /// How the code names `id`.
    fn refer(&self, id: Id) -> TokenStream {
        match (self.slot.get(&id), self.d.ar.node(id)) {
            (Some(i), _) => quote!(k[#i]),
            (None, Node::Sym(s @ (Sym::Q(_) | Sym::Qd(_)))) => (self.name)(*s),
            _ => leaf_or_let(self.d, self.def, id),
        }
    }

    /// The bindings `roots` need that are not bound yet, depth first.
    fn lets_for(&mut self, roots: &[Id]) -> TokenStream {
        let mut order = Vec::new();
        for &r in roots {
            self.visit(r, &mut order);
        }
        let refer = |id: Id| self.refer(id);
        // the table serves a model without families: no index
        let_bindings(self.d, self.def, &order, &refer, &[])
    }

    fn visit(&mut self, id: Id, order: &mut Vec<Id>) {
        let param = matches!(self.d.ar.node(id), Node::Sym(Sym::Param(_) | Sym::Index(_)));
        if self.done[id.index()] || !(self.computed(id) || param) {
            return;
        }
        self.done[id.index()] = true;
        for c in self.children(id) {
            self.visit(c, order);
        }
        order.push(id);
        self.log.push(id);
        if let Some(p) = self.partner(id) {
            order.push(p);
            self.log.push(p);
        }
    }

    /// The cosine of `id`'s angle if `id` is a sine (the sine if a
    /// cosine) that is to be bound with it now (see `pair_with`), marked
    /// bound.
    fn partner(&mut self, id: Id) -> Option<Id> {
        let pair_with = self.pair_with.as_ref()?;
        let other = match self.d.ar.node(id) {
            Node::Sin(a) => Node::Cos(*a),
            Node::Cos(a) => Node::Sin(*a),
            _ => return None,
        };
        let p = self.d.ar.find(&other)?;
        if !pair_with[p.index()] || self.done[p.index()] || !self.computed(p) {
            return None;
        }
        self.done[p.index()] = true;
        Some(p)
    }
}

/// `(index expression, as i64)` of an affine index at loop value `v`.
fn affine_tokens(a: &Affine) -> TokenStream {
    let mut t = quote!(0i64);
    if a.var {
        t = quote!(#t + v);
    }
    if let Some(n) = &a.count {
        let c = format_ident!("c_{}", n);
        t = quote!(#t + #c);
    }
    let c = a.c;
    quote!((#t + #c))
}

/// `let l = self.__ezy_layout();` and the counts (`c_N`, which
/// [`affine_tokens`] names): the opening of every generated function that
/// walks the items.
fn layout_prelude(def: &ModelDef) -> TokenStream {
    let counts = count_lets(def);
    quote!(let l = self.__ezy_layout(); #counts)
}

/// The runtime counts as `let c_N: i64` bindings.
fn count_lets(def: &ModelDef) -> TokenStream {
    let mut out = TokenStream::new();
    for c in &def.counts {
        let (n, v) = (&c.name, format_ident!("c_{}", c.name));
        out.extend(quote!(let #v: i64 = self.#n as i64;));
    }
    out
}

/// Position of an element in its family (`value - start`), as `i64`
/// (`0` for a single item).
fn position(family: Option<usize>, index: Option<&Affine>) -> TokenStream {
    match (family, index) {
        (Some(f), Some(a)) => {
            let a = affine_tokens(a);
            quote!((#a - l.f_start[#f]))
        }
        _ => quote!(0i64),
    }
}

/// First `q` column of a body element, as `usize` (its position in range
/// is checked by `check_counts`).
fn body_column(def: &ModelDef, b: &BodyRef) -> TokenStream {
    let bi = b.0;
    let pos = position(def.bodies[bi].family, b.1.as_ref());
    quote!((l.body_off[#bi] + 3 * (#pos as usize)))
}

/// Global index of a body element among all bodies.
fn body_index(def: &ModelDef, b: &BodyRef) -> TokenStream {
    let bi = b.0;
    let pos = position(def.bodies[bi].family, b.1.as_ref());
    quote!((l.body_index[#bi] + (#pos as usize)))
}

/// Global index of a point element among all points.
fn point_index(def: &ModelDef, p: &PointRef) -> TokenStream {
    let pi = p.0;
    let pos = position(def.points[pi].family, p.1.as_ref());
    quote!((l.point_index[#pi] + (#pos as usize)))
}

/// The body element a point item's element sits on (loop value `v` = the
/// point's index).
fn point_body(def: &ModelDef, res: &Resolved, p: usize) -> BodyRef {
    let var = Affine { var: true, count: None, c: 0, span: proc_macro2::Span::call_site() };
    if def.points[p].family.is_some() {
        (res.point_body[p], Some(var))
    } else {
        (res.point_body[p], res.point_body_index[p].clone())
    }
}

/// `for e in 0..len { let v = start + e; #body }` over an item's family,
/// or the body once with `e = 0` for a single item.
fn each_element(family: Option<usize>, body: TokenStream) -> TokenStream {
    match family {
        Some(f) => quote! {
            for e in 0..l.f_len[#f] {
                let v: i64 = l.f_start[#f] + e as i64;
                #body
            }
        },
        None => quote! {
            {
                let e = 0usize;
                let v = 0i64;
                #body
            }
        },
    }
}

/// `let ql = [q[c0], q[c0 + 1], ...]` (and `qdl`) for a group's slots.
fn gather(def: &ModelDef, slots: &[BodyRef], with_qd: bool) -> TokenStream {
    let cols: Vec<TokenStream> = slots.iter().map(|b| body_column(def, b)).collect();
    let n = 3 * slots.len();
    let names: Vec<_> = (0..slots.len()).map(|s| format_ident!("col{}", s)).collect();
    let idx: Vec<TokenStream> = (0..n)
        .map(|k| {
            let c = &names[k / 3];
            let o = k % 3;
            quote!(#c + #o)
        })
        .collect();
    let qd = if with_qd { quote!(let qdl: [S; #n] = [#(qd[#idx]),*];) } else { quote!() };
    quote! {
        #(let #names: usize = #cols;)*
        let ql: [S; #n] = [#(q[#idx]),*];
        #qd
    }
}

/// Which outputs a loop-form numeric function writes per group.
#[derive(Clone, Copy)]
struct Outputs {
    phi: bool,
    values: bool,
    gamma: bool,
    holonomic_only: bool,
}

/// Loop form of a constraint function over all groups.
fn group_loops(d: &Derived, def: &ModelDef, o: Outputs) -> TokenStream {
    let mut out = TokenStream::new();
    for (gi, g) in d.groups.iter().enumerate() {
        if (o.holonomic_only && !g.holonomic()) || g.slots.is_empty() {
            continue;
        }
        let pat = g.local_pattern(&d.ar);
        let (nr, nnz) = (g.rows(), pat.len());
        let mut ids: Vec<Id> = Vec::new();
        if o.phi && g.holonomic() {
            ids.extend(&g.phi);
        }
        if o.values {
            ids.extend(pat.iter().map(|&(r, c)| g.g[r][c]));
        }
        if o.gamma {
            ids.extend(&g.gamma);
        }
        let (lets, exprs) = lower(d, def, &ids, Coords::Local, &g.indices);
        let mut writes = TokenStream::new();
        let mut k = 0;
        if o.phi && g.holonomic() {
            for r in 0..nr {
                let ex = &exprs[k];
                writes.extend(quote!(phi[rb + #r] = #ex;));
                k += 1;
            }
        }
        if o.values {
            for j in 0..nnz {
                let ex = &exprs[k];
                writes.extend(quote!(values[vb + #j] = #ex;));
                k += 1;
            }
        }
        if o.gamma {
            for r in 0..nr {
                let ex = &exprs[k];
                writes.extend(quote!(gamma[rb + #r] = #ex;));
                k += 1;
            }
        }
        let gat = gather(def, &g.slots, o.gamma);
        out.extend(each_element(
            g.family,
            quote! {
                #gat
                let rb = l.row[#gi] + e * #nr;
                let vb = l.val[#gi] + e * #nnz;
                #lets
                #writes
            },
        ));
    }
    out
}

/// Loop form of `points` / `point_velocities`.
fn point_loops(d: &Derived, def: &ModelDef, res: &Resolved, vel: bool) -> TokenStream {
    let mut out = TokenStream::new();
    for (pi, p) in d.points.iter().enumerate() {
        if p.body.is_none() {
            continue;
        }
        let ids: Vec<Id> = if vel { p.vel.to_vec() } else { p.pos.to_vec() };
        let (lets, ex) = lower(d, def, &ids, Coords::Local, &[own_index()]);
        let (e0, e1) = (&ex[0], &ex[1]);
        let gat = gather(def, &[point_body(def, res, pi)], vel);
        out.extend(each_element(
            def.points[pi].family,
            quote! {
                #gat
                let k = 2 * (l.point_index[#pi] + e);
                #lets
                out[k] = #e0;
                out[k + 1] = #e1;
            },
        ));
    }
    out
}

/// Straight-line form: every output renamed to global coordinates (a
/// model without families: all columns are known at compile time).
struct Static {
    /// `G` entries in pattern order, `phi` rows, `gamma` rows, point
    /// positions and velocities (x, y per point), all global.
    values: Vec<Id>,
    phi: Vec<Id>,
    gamma: Vec<Id>,
    points: Vec<Id>,
    vel: Vec<Id>,
    pattern: Vec<(usize, usize)>,
    nq: usize,
    nc: usize,
}

fn static_form(d: &mut Derived, def: &ModelDef, res: &Resolved) -> Static {
    let body_col = |b: &BodyRef| 3 * b.0;
    let mut st = Static {
        values: Vec::new(),
        phi: Vec::new(),
        gamma: Vec::new(),
        points: Vec::new(),
        vel: Vec::new(),
        pattern: Vec::new(),
        nq: 3 * def.bodies.len(),
        nc: 0,
    };
    let groups = std::mem::take(&mut d.groups);
    let mut row = 0;
    for g in &groups {
        let cols: Vec<usize> = g.slots.iter().map(body_col).collect();
        let rename = |s: Sym| match s {
            Sym::Q(k) => Sym::Q(cols[k / 3] + k % 3),
            Sym::Qd(k) => Sym::Qd(cols[k / 3] + k % 3),
            p => p,
        };
        let mut memo = HashMap::new();
        let mut sub = |ar: &mut Arena, id: Id| ar.subst(id, &rename, &mut memo);
        if g.holonomic() {
            for &p in &g.phi {
                let x = sub(&mut d.ar, p);
                st.phi.push(x);
            }
        }
        for (r, c) in g.local_pattern(&d.ar) {
            st.pattern.push((row + r, cols[c / 3] + c % 3));
            let x = sub(&mut d.ar, g.g[r][c]);
            st.values.push(x);
        }
        for &x in &g.gamma {
            let x = sub(&mut d.ar, x);
            st.gamma.push(x);
        }
        row += g.rows();
    }
    d.groups = groups;
    st.nc = row;
    for (pi, p) in d.points.iter().enumerate() {
        let b = point_body(def, res, pi);
        let col = body_col(&b);
        let rename = |s: Sym| match s {
            Sym::Q(k) => Sym::Q(col + k),
            Sym::Qd(k) => Sym::Qd(col + k),
            p => p,
        };
        let mut memo = HashMap::new();
        for k in 0..2 {
            let (a, b) = (p.pos[k], p.vel[k]);
            let a = d.ar.subst(a, &rename, &mut memo);
            let b = d.ar.subst(b, &rename, &mut memo);
            st.points.push(a);
            st.vel.push(b);
        }
    }
    st
}

/// Assignments `out[k] = expr_k` with their bindings (global coordinates).
fn assign(d: &Derived, def: &ModelDef, groups: &[(&str, &[Id])]) -> TokenStream {
    let all: Vec<Id> = groups.iter().flat_map(|(_, ids)| ids.iter().copied()).collect();
    let (lets, exprs) = lower(d, def, &all, Coords::Global, &[]);
    let mut body = lets;
    let mut start = 0;
    for (name, ids) in groups {
        let out = format_ident!("{}", name);
        let n = ids.len();
        body.extend(quote!(let #out = &mut #out[..#n];));
        for (k, e) in exprs[start..start + n].iter().enumerate() {
            body.extend(quote!(#out[#k] = #e;));
        }
        start += n;
    }
    body
}

/// Template of an expression for [`ezy_core::__private::render_equation`]:
/// symbols as markers `\u{1}q3\u{2}` (local coordinate 3), `d` (its
/// rate), `p` (parameter); a family index `Sym::Index(k)` as
/// [`index_marker`], which the generated code replaces by the element's
/// index before rendering.
fn templates(ar: &Arena, id: Id) -> (String, String) {
    let name = |s: Sym| match s {
        Sym::Q(k) => format!("\u{1}q{k}\u{2}"),
        Sym::Qd(k) => format!("\u{1}d{k}\u{2}"),
        Sym::Param(i) => format!("\u{1}p{i}\u{2}"),
        Sym::Index(k) => index_marker(k),
    };
    (ar.display(id, &name), ar.latex(id, &name))
}

/// The marker of `Sym::Index(k)` in a template: control characters that
/// neither the templates' other markers nor a name contain.
fn index_marker(k: usize) -> String {
    format!("\u{3}{k}\u{4}")
}

thread_local! {
    /// The runtime crate's path for the expansion under way ([`with_root`]).
    static ROOT: std::cell::RefCell<TokenStream> = std::cell::RefCell::new(quote!(::ezy_core));
}

/// Runs `f` with `root` as the path of the runtime crate: the `$crate` of
/// the `model!` the user called (`ezy_core::model!`, re-exported as
/// `ezy::model!`, passes its own), so the generated code names the crate
/// that defined the macro however the user depends on it (directly,
/// through `ezy`, renamed), without reading their `Cargo.toml`.
pub fn with_root<T>(root: TokenStream, f: impl FnOnce() -> T) -> T {
    let old = ROOT.with(|r| r.replace(root));
    let out = f();
    ROOT.with(|r| r.replace(old));
    out
}

/// `ROOT::__private`, the paths the generated code uses (see [`with_root`]).
fn runtime() -> TokenStream {
    ROOT.with(|r| {
        let root = r.borrow().clone();
        quote!(#root::__private)
    })
}

/// The whole expansion.
pub fn emit(def: &ModelDef, res: &Resolved, d: &mut Derived) -> TokenStream {
    let name = &def.name;
    let vis = &def.vis;
    let attrs = &def.attrs;
    let private = runtime();
    let is_static = def.families.is_empty() && def.counts.is_empty();

    // struct and Default
    let fields = def.params.iter().map(|p| {
        let pattrs = escape_unit(&p.attrs);
        let n = &p.name;
        quote!(#(#pattrs)* pub #n: f64,)
    });
    let count_fields = def.counts.iter().map(|c| {
        let cattrs = escape_unit(&c.attrs);
        let n = &c.name;
        quote!(#(#cattrs)* pub #n: usize,)
    });
    let defaults = def.params.iter().map(|p| {
        let n = &p.name;
        let v = lit_f64(p.value);
        quote!(#n: #v,)
    });
    let count_defaults = def.counts.iter().map(|c| {
        let n = &c.name;
        let v = c.value as usize;
        quote!(#n: #v,)
    });

    // parameters by index: the reals, then the counts
    let np = def.params.len();
    let get_arms = def.params.iter().enumerate().map(|(i, p)| {
        let n = &p.name;
        quote!(#i => self.#n,)
    });
    let set_arms = def.params.iter().enumerate().map(|(i, p)| {
        let n = &p.name;
        quote!(#i => self.#n = value,)
    });
    let get_counts = def.counts.iter().enumerate().map(|(i, c)| {
        let (n, i) = (&c.name, np + i);
        quote!(#i => self.#n as f64,)
    });
    let set_counts = def.counts.iter().enumerate().map(|(i, c)| {
        let (n, i) = (&c.name, np + i);
        let msg = format!("count `{}` must be a whole number >= 1, got {{}}", c.name);
        quote!(#i => {
            assert!(value >= 1.0 && value.fract() == 0.0 && value <= 1e9, #msg, value);
            self.#n = value as usize;
        })
    });

    let prelude = layout_prelude(def);
    let layout = layout_fn(def, d);
    let info = info_fn(def, res, d);
    let check = check_fn(def, res, d);
    let equations = equations_fn(def, res, d);

    // mass and local geometry: loops over items (constant per element)
    let mut mass_body = TokenStream::new();
    for (bi, b) in def.bodies.iter().enumerate() {
        let (lets, ex) = lower(d, def, &d.mass[bi], Coords::Local, &[own_index()]);
        let (m0, m1, m2) = (&ex[0], &ex[1], &ex[2]);
        mass_body.extend(each_element(
            b.family,
            quote! {
                let k = l.body_off[#bi] + 3 * e;
                #lets
                out[k] = #m0; out[k + 1] = #m1; out[k + 2] = #m2;
            },
        ));
    }
    let mut local_body = TokenStream::new();
    for (pi, p) in def.points.iter().enumerate() {
        let (lets, ex) = lower(d, def, &d.points[pi].local, Coords::Local, &[own_index()]);
        let (a, b) = (&ex[0], &ex[1]);
        local_body.extend(each_element(
            p.family,
            quote! {
                let k = 2 * (l.point_index[#pi] + e);
                #lets
                points[k] = #a; points[k + 1] = #b;
            },
        ));
    }
    for (ki, s) in def.skates.iter().enumerate() {
        let (lets, ex) = lower(d, def, &d.blades[ki], Coords::Local, &[own_index()]);
        let (a, b) = (&ex[0], &ex[1]);
        let gi = d.groups.iter().position(|g| g.kind == Kind::Skate && g.item == ki).expect("one group per skate");
        local_body.extend(each_element(
            s.family,
            quote! {
                let k = 2 * (l.item_index[#gi] + e);
                #lets
                blades[k] = #a; blades[k + 1] = #b;
            },
        ));
    }

    let numerics = if is_static {
        let st = static_form(d, def, res);
        let nh = st.phi.len();
        let nnz_h = st.pattern.iter().filter(|(r, _)| *r < nh).count();
        let nq = st.nq;
        let phi_body = assign(d, def, &[("phi", &st.phi)]);
        let jac_body = assign(d, def, &[("values", &st.values[..nnz_h])]);
        let g_body = assign(d, def, &[("values", &st.values)]);
        let terms_body = assign(d, def, &[("values", &st.values), ("gamma", &st.gamma)]);
        let phi_g_body = assign(d, def, &[("phi", &st.phi), ("values", &st.values)]);
        let points_body = assign(d, def, &[("out", &st.points)]);
        let vel_body = assign(d, def, &[("out", &st.vel)]);
        let kernels = sparse_kernels(&st.pattern, nq, st.nc);
        let q_only = quote!(let q = &q[..#nq];);
        let q_qd = quote!(let q = &q[..#nq]; let qd = &qd[..#nq];);
        let fns =
            numeric_fns(&q_only, &q_qd, [phi_body, jac_body, g_body, phi_g_body, terms_body, points_body, vel_body]);
        let minimal = crate::minimal::derive(&mut d.ar, def, res, &st.phi, &st.pattern, &st.values, st.nc);
        let fused = match &minimal {
            Ok(m) => {
                let mass: Vec<Id> = d.mass.iter().flatten().copied().collect();
                // the hinges in `ModelInfo::hinges`' order (a model with
                // minimal coordinates has no families: a body's slot is its index)
                let hinges: Vec<(usize, Option<usize>)> = d
                    .groups
                    .iter()
                    .filter(|g| g.kind == Kind::Hinge)
                    .map(|g| (g.slots[0].0, g.slots.get(1).map(|b| b.0)))
                    .collect();
                let maggi = crate::minimal::maggi(&mut d.ar, m, &mass, &hinges);
                fused_fns(d, def, m, &maggi)
            }
            Err(_) => TokenStream::new(),
        };
        let minimal = minimal_fns(d, def, minimal);
        quote! {
            #kernels
            #minimal
            #fused

            fn unrolled_kernels(&self) -> bool {
                true
            }

            #fns
        }
    } else {
        let o = |phi, values, gamma, holonomic_only| Outputs { phi, values, gamma, holonomic_only };
        let phi_body = group_loops(d, def, o(true, false, false, true));
        let jac_body = group_loops(d, def, o(false, true, false, true));
        let g_body = group_loops(d, def, o(false, true, false, false));
        let phi_g_body = group_loops(d, def, o(true, true, false, false));
        let terms_body = group_loops(d, def, o(false, true, true, false));
        let points_body = point_loops(d, def, res, false);
        let vel_body = point_loops(d, def, res, true);
        let layout = layout_prelude(def);
        let fns =
            numeric_fns(&layout, &layout, [phi_body, jac_body, g_body, phi_g_body, terms_body, points_body, vel_body]);
        let minimal = minimal_fns(d, def, Err("it has families (`for`), whose minimal form is not derived yet".into()));
        quote!(#fns #minimal)
    };

    quote! {
        #(#attrs)*
        #[derive(Debug, Clone, PartialEq)]
        #[allow(non_snake_case)]
        #vis struct #name {
            #(#fields)*
            #(#count_fields)*
        }

        impl ::core::default::Default for #name {
            fn default() -> Self {
                Self { #(#defaults)* #(#count_defaults)* }
            }
        }

        #[allow(non_snake_case, unused_variables, unused_mut, unused_parens, clippy::all, clippy::pedantic)]
        impl #name {
            #layout
        }

        #[allow(non_snake_case, unused_variables, unused_mut, unused_parens, clippy::all, clippy::pedantic)]
        impl #private::Model for #name {
            #info
            #equations
            #check

            fn param(&self, index: usize) -> f64 {
                match index {
                    #(#get_arms)*
                    #(#get_counts)*
                    _ => panic!("parameter index {} out of range", index),
                }
            }

            fn set_param(&mut self, index: usize, value: f64) {
                match index {
                    #(#set_arms)*
                    #(#set_counts)*
                    _ => panic!("parameter index {} out of range", index),
                }
            }

            fn mass_diagonal(&self, out: &mut [f64]) {
                type S = f64;
                #prelude
                #mass_body
            }

            fn local_geometry(&self, points: &mut [f64], blades: &mut [f64]) {
                type S = f64;
                #prelude
                #local_body
            }

            #numerics
        }
    }
}

/// `minimal_layout` and `minimal_expand` (`ezy_core::MinimalLayout`) from
/// the derived minimal form, or a `minimal_layout` that says why there is none.
fn minimal_fns(d: &Derived, def: &ModelDef, m: Result<crate::minimal::Minimal, String>) -> TokenStream {
    let private = runtime();
    let m = match m {
        Ok(m) => m,
        Err(why) => {
            let why = format!("model {} has no minimal coordinates: {why}", def.name);
            return quote! {
                fn minimal_layout(&self) -> ::core::result::Result<#private::MinimalLayout, ::std::string::String> {
                    ::core::result::Result::Err(::std::string::String::from(#why))
                }
            };
        }
    };
    let pivots: Vec<Id> = m.pivots.iter().map(|p| p.2).collect();
    let (pivot_lets, pivot_exprs) = lower(d, def, &pivots, Coords::Global, &[]);
    let pivot_items =
        m.pivots.iter().zip(&pivot_exprs).map(|((name, k, _), e)| quote!((::std::string::String::from(#name), #k, #e)));
    let (coords, speeds) = (&m.coords, &m.speeds);
    let nq = m.qd.len();
    let mut outputs: Vec<Id> = m.q_dep.iter().map(|p| p.1).collect();
    outputs.extend(&m.qd);
    outputs.extend(&m.b);
    outputs.extend(&m.c);
    outputs.extend(&m.frames);
    let (lets, exprs) = lower(d, def, &outputs, Coords::Global, &[]);
    // the state alone (`minimal_state`): the same expressions for q_D and
    // qd, lowered on their own so that none of B's or c's is computed
    let (state_lets, state_exprs) = lower(d, def, &outputs[..m.q_dep.len() + nq], Coords::Global, &[]);
    let mut state_sets = TokenStream::new();
    for ((j, _), e) in m.q_dep.iter().zip(&state_exprs) {
        state_sets.extend(quote!(q[#j] = #e;));
    }
    for (j, e) in state_exprs[m.q_dep.len()..].iter().enumerate() {
        state_sets.extend(quote!(qd_out[#j] = #e;));
    }
    let mut sets = TokenStream::new();
    let nqd = m.q_dep.len();
    for ((j, _), e) in m.q_dep.iter().zip(&exprs) {
        sets.extend(quote!(q[#j] = #e;));
    }
    let mut rest = exprs[nqd..].iter();
    for (j, e) in rest.by_ref().take(nq).enumerate() {
        sets.extend(quote!(qd_out[#j] = #e;));
    }
    for (k, e) in rest.by_ref().take(m.b.len()).enumerate() {
        sets.extend(quote!(b[#k] = #e;));
    }
    for (k, e) in rest.enumerate() {
        sets.extend(quote!(c[#k] = #e;));
    }
    // Maggi's B^T M B (lower triangle) and B^T (F - M c) in the body
    // frames over B's structural nonzeros, with B's constant entries
    // inlined; F is f turned into each body's frame by the expansion's
    // cos, sin (c[nq..])
    let nu = m.speeds.len();
    let entry = |j: usize, i: usize| -> Option<TokenStream> {
        let id = m.b[j * nu + i];
        match d.ar.as_const(id) {
            Some(0.0) => None,
            Some(1.0) => Some(TokenStream::new()),
            Some(v) => {
                let v = lit_f64(v);
                Some(quote!(#v *))
            }
            None => {
                let k = j * nu + i;
                Some(quote!(b[#k] *))
            }
        }
    };
    let force = |j: usize| -> TokenStream {
        let (i, axis) = (j / 3, j % 3);
        let (cs, sn) = (nq + 2 * i, nq + 2 * i + 1);
        let (x, y) = (3 * i, 3 * i + 1);
        match axis {
            0 => quote!((c[#cs] * f[#x] + c[#sn] * f[#y])),
            1 => quote!((c[#cs] * f[#y] - c[#sn] * f[#x])),
            _ => quote!(f[#j]),
        }
    };
    let mut maggi = TokenStream::new();
    for i in 0..nu {
        for k in 0..=i {
            let terms: Vec<TokenStream> = (0..nq)
                .filter_map(|j| {
                    let (bi, bk) = (entry(j, i)?, entry(j, k)?);
                    Some(quote!(#bi #bk mass[#j]))
                })
                .collect();
            let sum = if terms.is_empty() { quote!(0.0) } else { join(terms.into_iter(), quote!(+)) };
            let at = i * nu + k;
            maggi.extend(quote!(a[#at] = #sum;));
        }
        let terms: Vec<TokenStream> = (0..nq)
            .filter_map(|j| {
                let bi = entry(j, i)?;
                let fj = force(j);
                Some(if d.ar.is_zero(m.c[j]) { quote!(#bi #fj) } else { quote!(#bi (#fj - mass[#j] * c[#j])) })
            })
            .collect();
        let sum = if terms.is_empty() { quote!(0.0) } else { join(terms.into_iter(), quote!(+)) };
        maggi.extend(quote!(r[#i] = #sum;));
    }
    let nc_len = nq + m.frames.len();
    quote! {
        #[inline]
        fn minimal_maggi(&self, mass: &[f64], b: &[f64], c: &[f64], f: &[f64], a: &mut [f64], r: &mut [f64]) {
            let (mass, b, c, f) = (&mass[..#nq], &b[..#nq * #nu], &c[..#nc_len], &f[..#nq]);
            let (a, r) = (&mut a[..#nu * #nu], &mut r[..#nu]);
            #maggi
        }

        fn minimal_layout(&self) -> ::core::result::Result<#private::MinimalLayout, ::std::string::String> {
            type S = f64;
            #pivot_lets
            ::core::result::Result::Ok(#private::MinimalLayout {
                coords: ::std::vec![#(#coords),*],
                speeds: ::std::vec![#(#speeds),*],
                pivots: ::std::vec![#(#pivot_items),*],
            })
        }

        #[inline]
        fn minimal_expand<S: #private::Scalar>(&self, q: &mut [S], qd_out: &mut [S], b: &mut [S], c: &mut [S]) {
            // the speeds in, read before anything is written
            #[allow(unused_variables)]
            let qd: [S; #nq] = ::core::array::from_fn(|k| qd_out[k]);
            #lets
            #sets
        }

        #[inline]
        fn minimal_state<S: #private::Scalar>(&self, q: &mut [S], qd_out: &mut [S]) -> bool {
            #[allow(unused_variables)]
            let qd: [S; #nq] = ::core::array::from_fn(|k| qd_out[k]);
            #state_lets
            #state_sets
            true
        }
    }
}

/// `minimal_constants` and `minimal_rhs`: the right-hand side on the
/// minimal coordinates `m` in one straight-line function (the expansion,
/// the applied force through a closure, Maggi's `B^T M B` and
/// `B^T (F - M c)` from `maggi`), the fixed parts of its expressions read
/// from a table computed once per run.
fn fused_fns(d: &Derived, def: &ModelDef, m: &crate::minimal::Minimal, maggi: &crate::minimal::Maggi) -> TokenStream {
    let (nq, np, nu) = (m.qd.len(), m.coords.len(), m.speeds.len());
    let nz = np + nu;
    // the kept coordinates and the speeds read from z
    let name = |s: Sym| -> TokenStream {
        let i = match s {
            Sym::Q(j) => m.coords.iter().position(|&c| c == j),
            Sym::Qd(j) => m.speeds.iter().position(|&c| c == j).map(|i| np + i),
            Sym::Param(_) | Sym::Index(_) => None,
        };
        let i = i.unwrap_or_else(|| panic!("the minimal form mentions {s:?}, neither kept nor independent"));
        quote!(z[#i])
    };
    let mut outputs: Vec<Id> = m.q_dep.iter().map(|p| p.1).collect();
    outputs.extend(&m.qd);
    outputs.extend(&maggi.a);
    outputs.extend(&maggi.minus_bmc);
    outputs.extend(&maggi.b);
    outputs.extend(&m.frames);
    outputs.extend(maggi.hinge.iter().flatten());
    let mut h = Hoisted::new(d, def, &outputs, &name);
    let nk = h.table.len();
    let (table_lets, table_exprs) = lower(d, def, &h.table, Coords::Global, &[]);
    // the body of `minimal_rhs` (every coordinate and rate written) or of
    // `minimal_rhs_lean` (only the headings', what a hinge torque reads):
    // the coordinates and rates `write` keeps and the kept coordinates'
    // rates, each value computed just before it is stored, then Maggi's
    // part with its own bindings
    let nh = maggi.hinge.len();
    let private = runtime();
    let fresh = h.done.clone();
    let body = |h: &mut Hoisted, write: &dyn Fn(usize) -> bool| {
        h.done = fresh.clone();
        let mut sets = TokenStream::new();
        for (i, &j) in m.coords.iter().enumerate().filter(|(_, j)| write(**j)) {
            sets.extend(quote!(q[#j] = z[#i];));
        }
        for &(j, e) in m.q_dep.iter().filter(|(j, _)| write(*j)) {
            sets.extend(h.lets_for(&[e]));
            let e = h.refer(e);
            sets.extend(quote!(q[#j] = #e;));
        }
        for (j, &e) in m.qd.iter().enumerate() {
            let kept = m.coords.iter().position(|&c| c == j);
            if !write(j) && kept.is_none() {
                continue;
            }
            sets.extend(h.lets_for(&[e]));
            let e = h.refer(e);
            if write(j) {
                sets.extend(quote!(qd[#j] = #e;));
            }
            if let Some(i) = kept {
                sets.extend(quote!(pd[#i] = #e;));
            }
        }
        let maggi_sets = maggi_tokens(d, m, maggi, h);
        quote! {
            type S = f64;
            // every slice cut to its length once: no bounds check below
            let (k, z) = (&k[..#nk], &z[..#nz]);
            let (q, qd, dz) = (&mut q[..#nq], &mut qd[..#nq], &mut dz[..#nz]);
            let pd = &mut dz[..#np];
            #sets
            let mut f = [0.0f64; #nq];
            let mut tau = [0.0f64; #nh];
            forces(q, qd, &mut f, &mut tau).map_err(#private::MinimalRhsError::Forces)?;
            #maggi_sets
            ::core::result::Result::Ok(())
        }
    };
    // each body twice: the second binds a sine and a cosine of one angle
    // together wherever the first bound both (in separate statements)
    let paired = |h: &mut Hoisted, write: &dyn Fn(usize) -> bool| {
        h.log.clear();
        h.pair_with = None;
        body(h, write);
        let mut bound = vec![false; h.done.len()];
        for id in &h.log {
            bound[id.index()] = true;
        }
        h.pair_with = Some(bound);
        let tokens = body(h, write);
        h.pair_with = None;
        tokens
    };
    let full = paired(&mut h, &|_| true);
    let lean = paired(&mut h, &|j| j % 3 == 2);
    let signature = |name: proc_macro2::Ident| {
        quote! {
            #[inline]
            fn #name<E, F>(
                &self,
                k: &[f64],
                z: &[f64],
                q: &mut [f64],
                qd: &mut [f64],
                dz: &mut [f64],
                forces: F,
            ) -> ::core::result::Result<(), #private::MinimalRhsError<E>>
            where
                F: ::core::ops::FnOnce(&[f64], &[f64], &mut [f64], &mut [f64]) -> ::core::result::Result<(), E>,
        }
    };
    let (rhs, rhs_lean) = (signature(format_ident!("minimal_rhs")), signature(format_ident!("minimal_rhs_lean")));
    quote! {
        fn minimal_constants(&self) -> ::core::option::Option<::std::vec::Vec<f64>> {
            type S = f64;
            #table_lets
            ::core::option::Option::Some(::std::vec![#(#table_exprs),*])
        }

        #rhs { #full }

        #rhs_lean { #lean }
    }
}

/// The Maggi part of the fused right-hand side (`B^T M B`, `B^T (F - M
/// c)` with the applied force and the hinges' torques, and the solve),
/// its bindings emitted where `h` has not bound them yet.
fn maggi_tokens(
    d: &Derived,
    m: &crate::minimal::Minimal,
    maggi: &crate::minimal::Maggi,
    h: &mut Hoisted<'_>,
) -> TokenStream {
    let (nq, np, nu) = (m.qd.len(), m.coords.len(), m.speeds.len());
    // Maggi's B^T M B (lower triangle), then B^T (F - M c): -B^T M c
    // first, then F, the force f turned into each body's frame, a body's
    // force skipped where it is zero (a motor's hinge torque has none)
    let mut maggi_sets = TokenStream::new();
    let mut a = vec![quote!(0.0f64); nu * nu];
    for i in 0..nu {
        for k in 0..=i {
            let e = maggi.a[i * (i + 1) / 2 + k];
            maggi_sets.extend(h.lets_for(&[e]));
            let (e, v) = (h.refer(e), format_ident!("a{}_{}", i, k));
            maggi_sets.extend(quote!(let #v: S = #e;));
            a[i * nu + k] = quote!(#v);
        }
    }
    let r: Vec<proc_macro2::Ident> = (0..nu).map(|i| format_ident!("r{}", i)).collect();
    for (ri, &bmc) in r.iter().zip(&maggi.minus_bmc) {
        maggi_sets.extend(h.lets_for(&[bmc]));
        let e = h.refer(bmc);
        maggi_sets.extend(quote!(let mut #ri: S = #e;));
    }
    for body in 0..nq / 3 {
        let (x, y, w) = (3 * body, 3 * body + 1, 3 * body + 2);
        let (cs, sn) = (m.frames[2 * body], m.frames[2 * body + 1]);
        // `r_i += B_ji F_j` over the body's velocities `j` in `axes`, in a
        // block of its own that runs where the force is not zero (its
        // bindings scoped to it)
        let mut block = |h: &mut Hoisted, axes: &[usize], force: TokenStream, test: TokenStream| {
            let saved = h.done.clone();
            let mut lets = TokenStream::new();
            let mut adds = TokenStream::new();
            for &axis in axes {
                let (j, fj) = (3 * body + axis, [quote!(fx), quote!(fy), quote!(f[#w])][axis].clone());
                for (i, ri) in r.iter().enumerate() {
                    let bji = maggi.b[j * nu + i];
                    match d.ar.as_const(bji) {
                        Some(0.0) => {}
                        Some(1.0) => adds.extend(quote!(#ri += #fj;)),
                        _ => {
                            lets.extend(h.lets_for(&[bji]));
                            let b = h.refer(bji);
                            adds.extend(quote!(#ri += #b * #fj;));
                        }
                    }
                }
            }
            if !adds.is_empty() {
                let frame = if axes.contains(&0) { h.lets_for(&[cs, sn]) } else { TokenStream::new() };
                maggi_sets.extend(quote!(if #test { #frame #lets #force #adds }));
            }
            h.done = saved;
        };
        let (c, s) = (h.refer(cs), h.refer(sn));
        block(
            h,
            &[0, 1],
            quote!(let (fx, fy) = (#c * f[#x] + #s * f[#y], #c * f[#y] - #s * f[#x]);),
            quote!(f[#x] != 0.0 || f[#y] != 0.0),
        );
        block(h, &[2], TokenStream::new(), quote!(f[#w] != 0.0));
    }
    // each hinge's torque along its row `B_a - B_b`, where it is not zero
    for (hinge, row) in maggi.hinge.iter().enumerate() {
        let saved = h.done.clone();
        let mut lets = TokenStream::new();
        let mut adds = TokenStream::new();
        for (ri, &coef) in r.iter().zip(row) {
            match d.ar.as_const(coef) {
                Some(0.0) => {}
                Some(1.0) => adds.extend(quote!(#ri += tau[#hinge];)),
                Some(-1.0) => adds.extend(quote!(#ri -= tau[#hinge];)),
                _ => {
                    lets.extend(h.lets_for(&[coef]));
                    let c = h.refer(coef);
                    adds.extend(quote!(#ri += #c * tau[#hinge];));
                }
            }
        }
        if !adds.is_empty() {
            maggi_sets.extend(quote!(if tau[#hinge] != 0.0 { #lets #adds }));
        }
        h.done = saved;
    }
    let private = runtime();
    let scratch = if nu > 8 { nu * (nu + 1) } else { 0 };
    maggi_sets.extend(quote! {
        let a: [S; #nu * #nu] = [#(#a),*];
        let r: [S; #nu] = [#(#r),*];
        let mut scratch = [0.0f64; #scratch];
        #private::ldl_solve(&a, #nu, #nu, &r, &mut dz[#np..], &mut scratch)
            .map_err(#private::MinimalRhsError::Maggi)?;
    });
    maggi_sets
}

/// Straight-line products with `G` at its compile-time sparsity pattern:
/// `normal_matrix` (`G W^-1 G^T`, lower triangle), `g_winv_mul` (`G W^-1 u`),
/// `sub_winv_gt_mul` (`v -= W^-1 G^T x`). No index arithmetic at run time.
fn sparse_kernels(pattern: &[(usize, usize)], nq: usize, nc: usize) -> TokenStream {
    let rows: Vec<Vec<(usize, usize)>> = (0..nc)
        .map(|r| pattern.iter().enumerate().filter(|(_, p)| p.0 == r).map(|(e, p)| (e, p.1)).collect())
        .collect();
    let zero = quote!(0.0f64);
    let mut normal = TokenStream::new();
    for i in 0..nc {
        for j in 0..=i {
            let mut terms = Vec::new();
            for &(e1, k) in &rows[i] {
                for &(e2, k2) in &rows[j] {
                    if k == k2 {
                        terms.push(quote!(values[#e1] * values[#e2] * winv[#k]));
                    }
                }
            }
            let idx = i * nc + j;
            let sum = if terms.is_empty() { zero.clone() } else { join(terms.into_iter(), quote!(+)) };
            normal.extend(quote!(a[#idx] = #sum;));
        }
    }
    let mut gmul = TokenStream::new();
    for (i, row) in rows.iter().enumerate() {
        let terms: Vec<TokenStream> = row.iter().map(|&(e, k)| quote!(values[#e] * (winv[#k] * u[#k]))).collect();
        let sum = if terms.is_empty() { zero.clone() } else { join(terms.into_iter(), quote!(+)) };
        gmul.extend(quote!(out[#i] = #sum;));
    }
    let mut gt = TokenStream::new();
    for k in 0..nq {
        let terms: Vec<TokenStream> = pattern
            .iter()
            .enumerate()
            .filter(|(_, p)| p.1 == k)
            .map(|(e, p)| {
                let r = p.0;
                quote!(values[#e] * x[#r])
            })
            .collect();
        if !terms.is_empty() {
            let sum = join(terms.into_iter(), quote!(+));
            gt.extend(quote!(v[#k] -= winv[#k] * (#sum);));
        }
    }
    let nnz = pattern.len();
    let nn = nc * nc;
    quote! {
        #[inline]
        fn normal_matrix(&self, _pattern: &[(usize, usize)], _nc: usize, values: &[f64], winv: &[f64], a: &mut [f64]) {
            let values = &values[..#nnz];
            let winv = &winv[..#nq];
            let a = &mut a[..#nn];
            #normal
        }

        #[inline]
        fn g_winv_mul(&self, _pattern: &[(usize, usize)], values: &[f64], winv: &[f64], u: &[f64], out: &mut [f64]) {
            let values = &values[..#nnz];
            let winv = &winv[..#nq];
            let u = &u[..#nq];
            let out = &mut out[..#nc];
            #gmul
        }

        #[inline]
        fn sub_winv_gt_mul(&self, _pattern: &[(usize, usize)], values: &[f64], winv: &[f64], x: &[f64], v: &mut [f64]) {
            let values = &values[..#nnz];
            let winv = &winv[..#nq];
            let x = &x[..#nc];
            let v = &mut v[..#nq];
            #gt
        }
    }
}

/// The seven generic numeric functions of `Model` around their bodies
/// (`phi`, `holonomic_jacobian`, `constraint_matrix`,
/// `phi_and_constraint_matrix`, `constraint_terms`, `points`,
/// `point_velocities`), each opening with `q_prelude` or, when it takes
/// `qd`, `qd_prelude`.
fn numeric_fns(q_prelude: &TokenStream, qd_prelude: &TokenStream, bodies: [TokenStream; 7]) -> TokenStream {
    let private = runtime();
    let [phi, jac, g, phi_g, terms, points, vel] = bodies;
    quote! {
        #[inline]
        fn phi<S: #private::Scalar>(&self, q: &[S], phi: &mut [S]) {
            #q_prelude
            #phi
        }

        #[inline]
        fn holonomic_jacobian<S: #private::Scalar>(&self, q: &[S], values: &mut [S]) {
            #q_prelude
            #jac
        }

        #[inline]
        fn constraint_matrix<S: #private::Scalar>(&self, q: &[S], values: &mut [S]) {
            #q_prelude
            #g
        }

        #[inline]
        fn phi_and_constraint_matrix<S: #private::Scalar>(&self, q: &[S], phi: &mut [S], values: &mut [S]) {
            #q_prelude
            #phi_g
        }

        #[inline]
        fn constraint_terms<S: #private::Scalar>(&self, q: &[S], qd: &[S], values: &mut [S], gamma: &mut [S]) {
            #qd_prelude
            #terms
        }

        #[inline]
        fn points<S: #private::Scalar>(&self, q: &[S], out: &mut [S]) {
            #q_prelude
            #points
        }

        #[inline]
        fn point_velocities<S: #private::Scalar>(&self, q: &[S], qd: &[S], out: &mut [S]) {
            #qd_prelude
            #vel
        }
    }
}

/// Number of elements of an item (`l.f_len[f]`, or 1).
fn len_tokens(family: Option<usize>) -> TokenStream {
    match family {
        Some(f) => quote!(l.f_len[#f]),
        None => quote!(1usize),
    }
}

/// The runtime name of an item's element: `"J"` or `format!("J{v}")`.
fn element_name(name: &str, family: Option<usize>) -> TokenStream {
    match family {
        Some(_) => quote!(::std::format!("{}{}", #name, v)),
        None => quote!(::std::string::String::from(#name)),
    }
}

fn kind_index(k: Kind) -> usize {
    match k {
        Kind::Hinge => 0,
        Kind::Slider => 1,
        Kind::Drive => 2,
        Kind::Skate => 3,
    }
}

fn item_name(def: &ModelDef, g: &Group) -> String {
    match g.kind {
        Kind::Hinge => def.hinges[g.item].name.to_string(),
        Kind::Slider => def.sliders[g.item].name.to_string(),
        Kind::Drive => def.drives[g.item].name.to_string(),
        Kind::Skate => def.skates[g.item].name.to_string(),
    }
}

/// `fn __ezy_layout(&self)`: where every item's elements sit in `q`, the
/// rows of `G` and its pattern values, at the current counts.
fn layout_fn(def: &ModelDef, d: &Derived) -> TokenStream {
    let private = runtime();
    let (nf, nb, np, ng) = (def.families.len(), def.bodies.len(), def.points.len(), d.groups.len());
    let counts = count_lets(def);
    let mut body = TokenStream::new();
    for (f, fam) in def.families.iter().enumerate() {
        let (s, e) = (affine_tokens(&fam.start), affine_tokens(&fam.end));
        body.extend(quote! {
            let start: i64 = #s;
            let end: i64 = #e;
            l.f_start[#f] = start;
            l.f_len[#f] = if end > start { (end - start) as usize } else { 0 };
        });
    }
    body.extend(quote!(let mut off = 0usize; let mut bi = 0usize;));
    for (b, item) in def.bodies.iter().enumerate() {
        let n = len_tokens(item.family);
        body.extend(quote! { l.body_off[#b] = off; l.body_index[#b] = bi; off += 3 * #n; bi += #n; });
    }
    body.extend(quote!(let mut pi = 0usize;));
    for (p, item) in def.points.iter().enumerate() {
        let n = len_tokens(item.family);
        body.extend(quote! { l.point_index[#p] = pi; pi += #n; });
    }
    body.extend(quote!(let mut row = 0usize; let mut val = 0usize; let mut kc = [0usize; 4];));
    for (gi, g) in d.groups.iter().enumerate() {
        let n = len_tokens(g.family);
        let (nr, nnz, k) = (g.rows(), g.local_pattern(&d.ar).len(), kind_index(g.kind));
        body.extend(quote! {
            l.row[#gi] = row; l.val[#gi] = val; l.item_index[#gi] = kc[#k];
            row += #nr * #n; val += #nnz * #n; kc[#k] += #n;
        });
        if g.holonomic() {
            body.extend(quote!(l.nh = row; l.nnz_h = val;));
        }
    }
    quote! {
        /// Offsets of every item at the current counts.
        #[inline]
        fn __ezy_layout(&self) -> #private::Layout<#nf, #nb, #np, #ng> {
            #counts
            let mut l = #private::Layout {
                f_start: [0; #nf], f_len: [0; #nf], body_off: [0; #nb], body_index: [0; #nb],
                point_index: [0; #np], row: [0; #ng], val: [0; #ng], item_index: [0; #ng],
                nq: 0, nc: 0, nh: 0, nnz: 0, nnz_h: 0, n_bodies: 0, n_points: 0,
            };
            #body
            l.nq = off; l.n_bodies = bi; l.n_points = pi; l.nc = row; l.nnz = val;
            l
        }
    }
}

/// `fn info(&self)`: names, indices and the pattern at the current counts.
fn info_fn(def: &ModelDef, res: &Resolved, d: &Derived) -> TokenStream {
    let private = runtime();
    let prelude = layout_prelude(def);
    let model_name = def.name.to_string();
    let model_doc = doc_of(&def.attrs).split(". ").next().unwrap_or("").trim_end_matches('.').to_string();
    let mut params_info: Vec<TokenStream> = def
        .params
        .iter()
        .map(|p| {
            let (doc, unit) = split_unit(&doc_of(&p.attrs));
            let n = p.name.to_string();
            let v = lit_f64(p.value);
            quote!(#private::ParamInfo { name: #n, default: #v, unit: #unit, doc: #doc, count: false })
        })
        .collect();
    params_info.extend(def.counts.iter().map(|c| {
        let (doc, _) = split_unit(&doc_of(&c.attrs));
        let n = c.name.to_string();
        let v = lit_f64(c.value as f64);
        quote!(#private::ParamInfo { name: #n, default: #v, unit: "", doc: #doc, count: true })
    }));
    // a parameter alone (not a family's index variable, not a number)
    let param_of = |e: &syn::Expr| -> TokenStream {
        match e {
            syn::Expr::Path(p) if p.path.get_ident().is_some_and(|id| def.params.iter().any(|q| q.name == *id)) => {
                let n = p.path.get_ident().expect("checked").to_string();
                quote!(::core::option::Option::Some(#n))
            }
            _ => quote!(::core::option::Option::None),
        }
    };
    let mut body = TokenStream::new();
    for (bi, b) in def.bodies.iter().enumerate() {
        let name = element_name(&b.name.to_string(), b.family);
        let cs: Vec<TokenStream> = b.coords.iter().map(|c| element_name(&c.to_string(), b.family)).collect();
        let (mp, ip) = (param_of(&b.mass), param_of(&b.inertia));
        body.extend(each_element(
            b.family,
            quote! {
                let k = l.body_off[#bi] + 3 * e;
                #(coords.push(#cs);)*
                bodies.push(#private::BodyInfo { name: #name, coords: [k, k + 1, k + 2], mass_param: #mp, inertia_param: #ip });
            },
        ));
    }
    for (pi, p) in def.points.iter().enumerate() {
        let name = element_name(&p.name.to_string(), p.family);
        let b = body_index(def, &point_body(def, res, pi));
        body.extend(each_element(p.family, quote!(points.push(#private::PointInfo { name: #name, body: #b });)));
    }
    for (gi, g) in d.groups.iter().enumerate() {
        let iname = item_name(def, g);
        let name = element_name(&iname, g.family);
        let nr = g.rows();
        let slot = |s: usize| g.slots.get(s).map(|b| body_index(def, b));
        let item = match g.kind {
            Kind::Hinge => {
                let a = slot(0).expect("a hinge has a body");
                let b = match slot(1) {
                    Some(b) => quote!(::core::option::Option::Some(#b)),
                    None => quote!(::core::option::Option::None),
                };
                let p = point_index(def, &res.hinge_points[g.item].0);
                quote!(hinges.push(#private::HingeInfo { name: #name, body_a: #a, body_b: #b, row: rb, point: #p });)
            }
            Kind::Slider => {
                let b = slot(0).expect("a slider has a body");
                let a = match slot(1) {
                    Some(a) => quote!(::core::option::Option::Some(#a)),
                    None => quote!(::core::option::Option::None),
                };
                let heading = def.sliders[g.item].heading;
                quote!(sliders.push(#private::SliderInfo { name: #name, body_a: #a, body_b: #b, row: rb, heading: #heading });)
            }
            Kind::Drive => {
                let h = res.drive_hinge[g.item];
                let hg = d.groups.iter().position(|x| x.kind == Kind::Hinge && x.item == h).expect("hinge group");
                // element e of a family drive drives element e of its hinge family
                quote!(drives.push(#private::DriveInfo { name: #name, hinge: l.item_index[#hg] + e, row: rb });)
            }
            Kind::Skate => {
                let p = point_index(def, &res.skate_point[g.item]);
                quote!(skates.push(#private::SkateInfo { name: #name, point: #p, row: rb });)
            }
        };
        let suffixes = &g.suffixes;
        let cols: Vec<TokenStream> = g.slots.iter().map(|b| body_column(def, b)).collect();
        let ns = cols.len();
        let entries = g.local_pattern(&d.ar).into_iter().map(|(r, c)| {
            let (s, o) = (c / 3, c % 3);
            quote!(pattern.push((rb + #r, cols[#s] + #o));)
        });
        body.extend(each_element(
            g.family,
            quote! {
                let rb = l.row[#gi] + e * #nr;
                let cols: [usize; #ns] = [#(#cols),*];
                #item
                let base = #name;
                #(constraints.push(::std::format!("{}{}", base, #suffixes));)*
                #(#entries)*
            },
        ));
    }
    quote! {
        fn info(&self) -> #private::ModelInfo {
            #prelude
            let mut coords = ::std::vec::Vec::with_capacity(l.nq);
            let mut bodies = ::std::vec::Vec::with_capacity(l.n_bodies);
            let mut points = ::std::vec::Vec::with_capacity(l.n_points);
            let mut hinges = ::std::vec::Vec::new();
            let mut sliders = ::std::vec::Vec::new();
            let mut drives = ::std::vec::Vec::new();
            let mut skates = ::std::vec::Vec::new();
            let mut constraints = ::std::vec::Vec::with_capacity(l.nc);
            let mut pattern = ::std::vec::Vec::with_capacity(l.nnz);
            #body
            #private::ModelInfo {
                name: #model_name,
                doc: #model_doc,
                coords,
                params: ::std::vec![#(#params_info),*],
                bodies,
                points,
                hinges,
                sliders,
                drives,
                skates,
                constraints,
                n_holonomic: l.nh,
                pattern,
            }
        }
    }
}

/// `fn check_counts(&self)`: every family reference stays inside the
/// family it names, joints join distinct bodies, and names are unique.
fn check_fn(def: &ModelDef, res: &Resolved, d: &Derived) -> TokenStream {
    let private = runtime();
    let prelude = layout_prelude(def);
    let mut body = TokenStream::new();
    for c in &def.counts {
        let n = &c.name;
        let msg = format!("count `{}` is 0; it must be at least 1", c.name);
        body.extend(quote!(if self.#n < 1 { return ::core::result::Result::Err(::std::string::String::from(#msg)); }));
    }
    if !def.counts.is_empty() {
        let pairs = def.counts.iter().map(|c| {
            let (n, s) = (&c.name, c.name.to_string());
            quote!((#s, self.#n))
        });
        body.extend(quote!(#private::check_model_size(l.nq, &[#(#pairs),*])?;));
    }
    // does element `value` of family `f` exist? else an error naming `what`
    let in_range = |f: usize, index: &Affine, var: &str, owner: TokenStream, what: String| -> TokenStream {
        let a = affine_tokens(index);
        let shown = index.show(var);
        let fam = &def.families[f];
        let range = format!("{}..{}", fam.start.show(""), fam.end.show(""));
        quote! {
            let value: i64 = #a;
            if value < l.f_start[#f] || value >= l.f_start[#f] + l.f_len[#f] as i64 {
                return ::core::result::Result::Err(::std::format!(
                    "{} refers to {}[{}] = {}{}, which does not exist: {} has elements {}..{} ({})",
                    #owner, #what, #shown, #what, value, #what, l.f_start[#f], l.f_start[#f] + l.f_len[#f] as i64, #range
                ));
            }
        }
    };
    for (pi, p) in def.points.iter().enumerate() {
        let b = res.point_body[pi];
        let Some(fb) = def.bodies[b].family else { continue };
        let var = p.family.map(|f| def.families[f].var.to_string()).unwrap_or_default();
        let owner_name = element_name(&p.name.to_string(), p.family);
        let owner = quote!(::std::format!("point `{}`", #owner_name));
        let (_, index) = point_body(def, res, pi);
        let check = in_range(fb, index.as_ref().expect("family body"), &var, owner, def.bodies[b].name.to_string());
        body.extend(each_element(p.family, check));
    }
    for g in &d.groups {
        let var = g.family.map(|f| def.families[f].var.to_string()).unwrap_or_default();
        let kind = match g.kind {
            Kind::Hinge => "hinge",
            Kind::Slider if !def.sliders[g.item].heading => "slot",
            Kind::Slider => "slider",
            Kind::Drive => "drive",
            Kind::Skate => "skate",
        };
        let owner_name = element_name(&item_name(def, g), g.family);
        let owner = quote!(::std::format!("{} `{}`", #kind, #owner_name));
        let mut checks = TokenStream::new();
        let refs: Vec<&PointRef> = match g.kind {
            Kind::Hinge => {
                let (a, b) = &res.hinge_points[g.item];
                std::iter::once(a).chain(b).collect()
            }
            Kind::Slider => {
                let (a, b) = &res.slider_points[g.item];
                std::iter::once(a).chain(b).collect()
            }
            Kind::Skate => vec![&res.skate_point[g.item]],
            Kind::Drive => Vec::new(),
        };
        for r in refs {
            if let (Some(fp), Some(index)) = (def.points[r.0].family, &r.1) {
                checks.extend(in_range(fp, index, &var, owner.clone(), def.points[r.0].name.to_string()));
            }
        }
        for b in &g.slots {
            if let (Some(fb), Some(index)) = (def.bodies[b.0].family, &b.1) {
                checks.extend(in_range(fb, index, &var, owner.clone(), def.bodies[b.0].name.to_string()));
            }
        }
        // a direction naming the family's index is not zero at any element
        // (one zero at the compile-time numbers is a compile error)
        if let Some([tx, ty]) = g.direction
            && (d.ar.mentions(tx, &|s| matches!(s, Sym::Index(_)))
                || d.ar.mentions(ty, &|s| matches!(s, Sym::Index(_))))
        {
            let (lets, ex) = lower(d, def, &[tx, ty], Coords::Local, &g.indices);
            let (ex, ey) = (&ex[0], &ex[1]);
            let shown = match g.kind {
                Kind::Skate => "blade direction `along",
                _ => "direction `along",
            };
            let (ax, ay) = match g.kind {
                Kind::Skate => (&def.skates[g.item].along[0], &def.skates[g.item].along[1]),
                _ => (&def.sliders[g.item].along[0], &def.sliders[g.item].along[1]),
            };
            let written = format!("{shown} ({}, {})`", quote!(#ax), quote!(#ay));
            checks.extend(quote! {
                #lets
                let (tx, ty): (f64, f64) = (#ex, #ey);
                let n2 = tx * tx + ty * ty;
                if !(n2 > 0.0 && n2.is_finite()) {
                    return ::core::result::Result::Err(::std::format!(
                        "{} has its {} = ({}, {}) at this element and these parameters: not a direction; give one that is not zero at any element",
                        #owner, #written, tx, ty
                    ));
                }
            });
        }
        if g.slots.len() == 2 && g.kind != Kind::Drive {
            let (a, b) = (body_index(def, &g.slots[0]), body_index(def, &g.slots[1]));
            checks.extend(quote! {
                if #a == #b {
                    return ::core::result::Result::Err(::std::format!("{} joins two points of the same body", #owner));
                }
            });
        }
        body.extend(each_element(g.family, checks));
    }
    quote! {
        fn check_counts(&self) -> ::core::result::Result<(), ::std::string::String> {
            type S = f64;
            #prelude
            #body
            let info = <Self as #private::Model>::info(self);
            #private::unique_names(&info)
        }
    }
}

/// `fn equations(&self)`: each item's templates rendered per element.
fn equations_fn(def: &ModelDef, res: &Resolved, d: &Derived) -> TokenStream {
    let private = runtime();
    let prelude = layout_prelude(def);
    let params: Vec<String> = def.params.iter().map(|p| p.name.to_string()).collect();
    // a template naming family indices gets the element's values first
    // (an integer; a negative one in parentheses); where it names one
    // index, its forms at 0, 1 and -1 come simplified from the arena
    // (`x - 0*L` is `x`, `x - 1*L` is `x - L`)
    let mut ar = d.ar.clone();
    let mut render = |id: Id, out: &str, indices: &[Affine]| -> TokenStream {
        let (t, x) = templates(&ar, id);
        let out = format_ident!("{}", out);
        let named: Vec<usize> = (0..indices.len())
            .filter(|&k| {
                let m = index_marker(k);
                t.contains(&m) || x.contains(&m)
            })
            .collect();
        if named.is_empty() {
            return quote!(eq.#out.push(#private::render_equation(#t, #x, &names, &params)););
        }
        let mut subs = TokenStream::new();
        for &k in &named {
            let m = index_marker(k);
            let a = affine_tokens(&indices[k]);
            subs.extend(quote! {
                let n: i64 = #a;
                let n = if n < 0 { ::std::format!("({})", n) } else { ::std::format!("{}", n) };
                let (t, x) = (t.replace(#m, &n), x.replace(#m, &n));
            });
        }
        let generic = quote!({
            let (t, x) = (::std::string::String::from(#t), ::std::string::String::from(#x));
            #subs
            eq.#out.push(#private::render_equation(&t, &x, &names, &params));
        });
        let [k] = named[..] else { return generic };
        let a = affine_tokens(&indices[k]);
        let arms = [0i64, 1, -1].map(|v| {
            let value = ar.cst(v as f64);
            let at = ar.replace(id, &|s| (s == Sym::Index(k)).then_some(value), &mut Default::default());
            let (t, x) = templates(&ar, at);
            quote!(#v => eq.#out.push(#private::render_equation(#t, #x, &names, &params)),)
        });
        quote!(match #a as i64 { #(#arms)* _ => #generic })
    };
    let names_of = |slots: &[BodyRef]| -> TokenStream {
        let cols: Vec<TokenStream> = slots.iter().map(|b| body_column(def, b)).collect();
        let n = 3 * slots.len();
        let idx = (0..n).map(|k| {
            let (s, o) = (k / 3, k % 3);
            quote!(info.coords[cols[#s] + #o].as_str())
        });
        let ns = slots.len();
        quote! {
            let cols: [usize; #ns] = [#(#cols),*];
            let names: [&str; #n] = [#(#idx),*];
        }
    };
    let own = [own_index()];
    let mut body = TokenStream::new();
    for (bi, b) in def.bodies.iter().enumerate() {
        let pushes: Vec<TokenStream> = d.mass[bi].iter().map(|&m| render(m, "mass", &own)).collect();
        body.extend(each_element(b.family, quote!(let names: [&str; 0] = []; #(#pushes)*)));
    }
    for g in &d.groups {
        if g.slots.is_empty() {
            continue;
        }
        let names = names_of(&g.slots);
        let mut pushes = TokenStream::new();
        let ix = &g.indices;
        if g.holonomic() {
            pushes.extend(g.phi.iter().map(|&x| render(x, "phi", ix)));
        }
        pushes.extend(g.velocity.iter().map(|&x| render(x, "velocity", ix)));
        pushes.extend(g.local_pattern(&d.ar).into_iter().map(|(r, c)| render(g.g[r][c], "jacobian", ix)));
        pushes.extend(g.gamma.iter().map(|&x| render(x, "gamma", ix)));
        body.extend(each_element(g.family, quote!(#names #pushes)));
    }
    for (pi, p) in d.points.iter().enumerate() {
        if p.body.is_none() {
            continue;
        }
        let names = names_of(&[point_body(def, res, pi)]);
        let pushes: Vec<TokenStream> = p.vel.iter().map(|&x| render(x, "point_velocities", &own)).collect();
        body.extend(each_element(def.points[pi].family, quote!(#names #(#pushes)*)));
    }
    quote! {
        fn equations(&self) -> #private::Equations {
            #prelude
            let info = <Self as #private::Model>::info(self);
            let params: &[&str] = &[#(#params),*];
            let mut eq = #private::Equations::default();
            eq.coords = info.coords.iter().map(|c| #private::render_equation("\u{1}q0\u{2}", "\u{1}q0\u{2}", &[c.as_str()], &[])).collect();
            #body
            eq
        }
    }
}
