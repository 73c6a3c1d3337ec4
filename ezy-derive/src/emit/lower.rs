//! The derived expressions lowered to Rust: `let` bindings of an arena's
//! nodes in evaluation order (a sine and a cosine of one angle as one
//! `sin_cos`) and one expression per output, coordinates named globally
//! (`q[k]`, straight-line code) or locally (`ql[k]`, an element kernel);
//! and [`Hoisted`], the same with the fixed nodes read from a table and
//! the bindings emitted on demand, for the fused right-hand side. Every
//! other part of the back end lowers its expressions here.

use proc_macro2::TokenStream;
use quote::{format_ident, quote};

use std::collections::HashMap;

use super::layout::affine_tokens;
use super::{join, lit_f64, runtime};
use ezy_lang::ast::{Affine, ModelDef};
use ezy_lang::kinematics::Derived;
use ezy_lang::sym::{Id, Node, Sym};

/// How generated code names coordinates: `q[k]` (global, straight-line) or
/// `ql[k]` (an element's local copy).
#[derive(Clone, Copy, PartialEq, Eq)]
pub(super) enum Coords {
    Global,
    Local,
}

/// Straight-line code computing `outputs`: `(let bindings, one expression
/// per output)`. `Sym::Index(k)` is the value of `indices[k]` at the loop
/// value `v` of [`each_element`](super::layout::each_element) (empty
/// outside a family).
pub(super) fn lower(
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
pub(super) struct Hoisted<'a> {
    d: &'a Derived,
    def: &'a ModelDef,
    name: &'a dyn Fn(Sym) -> TokenStream,
    /// The table's nodes, in the order of `k`, and each one's slot.
    pub(super) table: Vec<Id>,
    slot: HashMap<Id, usize>,
    /// Whether a node was bound already.
    pub(super) done: Vec<bool>,
    /// Where set, a sine or cosine is bound together with its partner
    /// (the cosine or sine of the same angle) if the partner is marked
    /// here: the nodes the function binds somewhere (one `sin_cos`, one
    /// argument reduction, where the two would be bound apart).
    pub(super) pair_with: Option<Vec<bool>>,
    /// Every node bound, in order (what `pair_with` is made of).
    pub(super) log: Vec<Id>,
}

impl<'a> Hoisted<'a> {
    /// The table of the nodes `outputs` need.
    pub(super) fn new(d: &'a Derived, def: &'a ModelDef, outputs: &[Id], name: &'a dyn Fn(Sym) -> TokenStream) -> Self {
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

    /// The operands of `id`.
    fn children(&self, id: Id) -> Vec<Id> {
        match self.d.ar.node(id) {
            Node::Add(xs) | Node::Mul(xs) => xs.to_vec(),
            Node::Pow(a, _) | Node::Sin(a) | Node::Cos(a) | Node::Sqrt(a) => vec![*a],
            Node::Const(_) | Node::Sym(_) => Vec::new(),
        }
    }

    /// How the code names `id`.
    pub(super) fn refer(&self, id: Id) -> TokenStream {
        match (self.slot.get(&id), self.d.ar.node(id)) {
            (Some(i), _) => quote!(k[#i]),
            (None, Node::Sym(s @ (Sym::Q(_) | Sym::Qd(_)))) => (self.name)(*s),
            _ => leaf_or_let(self.d, self.def, id),
        }
    }

    /// The bindings `roots` need that are not bound yet, depth first.
    pub(super) fn lets_for(&mut self, roots: &[Id]) -> TokenStream {
        let mut order = Vec::new();
        for &r in roots {
            self.visit(r, &mut order);
        }
        let refer = |id: Id| self.refer(id);
        // the table serves a model without families: no index
        let_bindings(self.d, self.def, &order, &refer, &[])
    }

    /// Adds to `order` the bindings `id` needs that are not bound yet,
    /// its operands' first, and `id`'s partner (see `pair_with`).
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
