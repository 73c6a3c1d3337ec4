//! A small symbolic engine: an expression arena with hash-consing
//! (so shared subexpressions are stored once: CSE for free), simplifying
//! constructors, differentiation, evaluation and printing.
//!
//! After egg's `RecExpr`: a node's children always have smaller ids than the
//! node, so ascending id order is an evaluation order, and emitting reachable
//! nodes in that order as `let` bindings gives straight-line code.
//!
//! Canonical forms kept by the constructors (deterministic, one pass, no
//! search):
//! - `Add` is n-ary and flat; like terms are collected (`2x + 3x = 5x`), the
//!   constant is folded, `k m sin(u)^2 + k m cos(u)^2 = k m`;
//! - `Mul` is n-ary and flat, with at most one numeric coefficient (first);
//!   equal factors become powers (`x x = x^2`);
//! - children of `Add`/`Mul` are sorted by id;
//! - constants are folded everywhere; `-x` is `(-1) * x`, `x / y` is
//!   `x * y^-1`.

mod collect;
mod diff;
mod display;
pub(crate) mod hoist;
mod trig;

pub use hoist::Grouping;

use std::collections::HashMap;

/// The most products one product of sums (or power of a sum) may form
/// when [`Arena::expand`] multiplies it out at once (the built-in models
/// form at most 4); past it, only the factors that change during a run
/// are multiplied out.
pub const MAX_EXPANDED: usize = 1024;

/// Index of a node in the [`Arena`].
#[derive(Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Debug)]
pub struct Id(u32);

impl Id {
    /// Position in the arena.
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

/// A symbol: generalized coordinate, velocity, model parameter, or the
/// index of a family element.
#[derive(Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Debug)]
pub enum Sym {
    /// Generalized coordinate `q[i]`.
    Q(usize),
    /// Generalized velocity `qd[i]`.
    Qd(usize),
    /// Model parameter number `i`.
    Param(usize),
    /// The index of a family element as a real number, `i` in
    /// `ground(i * L, 0)`: index number `k` of the element kernel it
    /// appears in (`Group::indices` in `kinematics`; 0 is the kernel's own
    /// element). A constant for the derivatives (not a coordinate), but
    /// not fixed across the elements: never hoisted into a table of
    /// constants (`Arena::fixed_nodes`).
    Index(usize),
}

/// One node of the arena.
#[derive(Clone, PartialEq, Eq, Hash, Debug)]
pub enum Node {
    /// A number, stored as its bits (`-0.0` normalized to `0.0`).
    Const(u64),
    /// A symbol.
    Sym(Sym),
    /// Sum of at least two terms, sorted.
    Add(Box<[Id]>),
    /// Product of at least two factors, sorted; a numeric coefficient comes first.
    Mul(Box<[Id]>),
    /// Integer power, exponent not 0 or 1.
    Pow(Id, i32),
    /// Sine.
    Sin(Id),
    /// Cosine.
    Cos(Id),
    /// Square root.
    Sqrt(Id),
}

/// The expression arena.
#[derive(Default, Debug, Clone)]
pub struct Arena {
    nodes: Vec<Node>,
    memo: HashMap<Node, Id>,
}

impl Arena {
    /// An empty arena.
    pub fn new() -> Self {
        Self::default()
    }

    /// The node behind `id`.
    pub fn node(&self, id: Id) -> &Node {
        &self.nodes[id.index()]
    }

    /// The node `node` if the arena holds it (nothing is added).
    pub fn find(&self, node: &Node) -> Option<Id> {
        self.memo.get(node).copied()
    }

    fn intern(&mut self, node: Node) -> Id {
        if let Some(&id) = self.memo.get(&node) {
            return id;
        }
        let id = Id(u32::try_from(self.nodes.len()).expect("expression arena overflow"));
        self.nodes.push(node.clone());
        self.memo.insert(node, id);
        id
    }

    /// The value of `id` if it is a constant.
    pub fn as_const(&self, id: Id) -> Option<f64> {
        match self.node(id) {
            Node::Const(bits) => Some(f64::from_bits(*bits)),
            _ => None,
        }
    }

    /// Is `id` the constant zero?
    pub fn is_zero(&self, id: Id) -> bool {
        self.as_const(id) == Some(0.0)
    }

    /// A numeric constant.
    pub fn cst(&mut self, value: f64) -> Id {
        let value = if value == 0.0 { 0.0 } else { value };
        self.intern(Node::Const(value.to_bits()))
    }

    /// A symbol.
    pub fn sym(&mut self, s: Sym) -> Id {
        self.intern(Node::Sym(s))
    }

    /// `a + b`.
    pub fn add2(&mut self, a: Id, b: Id) -> Id {
        self.add(&[a, b])
    }

    /// `a - b`.
    pub fn sub(&mut self, a: Id, b: Id) -> Id {
        let nb = self.neg(b);
        self.add(&[a, nb])
    }

    /// `a * b`.
    pub fn mul2(&mut self, a: Id, b: Id) -> Id {
        self.mul(&[a, b])
    }

    /// `-a`.
    pub fn neg(&mut self, a: Id) -> Id {
        let m1 = self.cst(-1.0);
        self.mul(&[m1, a])
    }

    /// `a / b`.
    pub fn div(&mut self, a: Id, b: Id) -> Id {
        let inv = self.pow(b, -1);
        self.mul(&[a, inv])
    }

    /// Splits a term into (numeric coefficient, rest).
    fn split_coef(&mut self, t: Id) -> (f64, Id) {
        match self.node(t).clone() {
            Node::Const(bits) => (f64::from_bits(bits), self.cst(1.0)),
            Node::Mul(fs) => match self.as_const(fs[0]) {
                Some(c) => (c, self.mul(&fs[1..])),
                None => (1.0, t),
            },
            _ => (1.0, t),
        }
    }

    /// The factors of a monomial (itself if not a product).
    fn factors(&self, t: Id) -> Vec<Id> {
        match self.node(t) {
            Node::Mul(fs) => fs.to_vec(),
            Node::Const(bits) if f64::from_bits(*bits) == 1.0 => Vec::new(),
            _ => vec![t],
        }
    }

    /// Sum of terms, simplified (see the module docs).
    pub fn add(&mut self, terms: &[Id]) -> Id {
        let mut flat = Vec::with_capacity(terms.len());
        for &t in terms {
            match self.node(t) {
                Node::Add(ts) => flat.extend_from_slice(ts),
                _ => flat.push(t),
            }
        }
        // Collect like terms: monomial -> coefficient, in first-seen order.
        let mut monos: Keyed<f64> = Keyed::default();
        for t in flat {
            let (c, m) = self.split_coef(t);
            monos.add(m, c, |e, c| *e += c);
        }
        let mut monos = monos.items;
        monos.retain(|(_, c)| *c != 0.0);
        self.pythagoras(&mut monos);
        let one = self.cst(1.0);
        let mut constant = 0.0;
        let mut out = Vec::with_capacity(monos.len());
        for (m, c) in monos {
            if m == one {
                constant += c;
            } else if c == 1.0 {
                out.push(m);
            } else {
                let k = self.cst(c);
                out.push(self.mul(&[k, m]));
            }
        }
        if constant != 0.0 {
            out.push(self.cst(constant));
        }
        self.add_raw(out)
    }

    /// The sum of `ts` as it is, with no like terms collected (what
    /// [`Arena::add`] ends with, and what factoring needs so as not to be
    /// undone): `0` for none, the term for one.
    fn add_raw(&mut self, mut ts: Vec<Id>) -> Id {
        match ts.len() {
            0 => self.cst(0.0),
            1 => ts[0],
            _ => {
                ts.sort();
                self.intern(Node::Add(ts.into_boxed_slice()))
            }
        }
    }

    /// `k m sin(u)^2 + k m cos(u)^2 -> k m`, repeated until none is left.
    fn pythagoras(&mut self, monos: &mut Vec<(Id, f64)>) {
        'again: loop {
            for i in 0..monos.len() {
                let (m, c) = monos[i];
                let fs = self.factors(m);
                for (pos, &f) in fs.iter().enumerate() {
                    let Node::Pow(base, 2) = *self.node(f) else { continue };
                    let Node::Sin(u) = *self.node(base) else { continue };
                    let mut rest: Vec<Id> = fs.clone();
                    rest.remove(pos);
                    let rest_id = self.mul(&rest);
                    let cu = self.cos_raw(u);
                    let cu2 = self.pow(cu, 2);
                    rest.push(cu2);
                    let partner = self.mul(&rest);
                    if let Some(j) = monos.iter().position(|&(mm, cc)| mm == partner && cc == c) {
                        let (hi, lo) = if i > j { (i, j) } else { (j, i) };
                        monos.remove(hi);
                        monos.remove(lo);
                        if let Some(e) = monos.iter_mut().find(|(mm, _)| *mm == rest_id) {
                            e.1 += c;
                        } else {
                            monos.push((rest_id, c));
                        }
                        monos.retain(|(_, c)| *c != 0.0);
                        continue 'again;
                    }
                }
            }
            return;
        }
    }

    /// Product of factors, simplified (see the module docs).
    pub fn mul(&mut self, factors: &[Id]) -> Id {
        let mut coef = 1.0;
        // (base, exponent) in first-seen order
        let mut powers: Keyed<i32> = Keyed::default();
        let mut stack: Vec<Id> = factors.to_vec();
        stack.reverse();
        while let Some(f) = stack.pop() {
            match self.node(f).clone() {
                Node::Const(bits) => coef *= f64::from_bits(bits),
                Node::Mul(fs) => stack.extend(fs.iter().rev()),
                Node::Pow(b, n) => push_power(&mut powers, b, n),
                _ => push_power(&mut powers, f, 1),
            }
        }
        if coef == 0.0 {
            return self.cst(0.0);
        }
        let mut out = Vec::with_capacity(powers.items.len() + 1);
        for (b, n) in powers.items {
            if n == 0 {
                continue;
            }
            let p = self.pow(b, n);
            match self.node(p).clone() {
                Node::Const(bits) => coef *= f64::from_bits(bits),
                Node::Mul(fs) => {
                    for &g in fs.iter() {
                        match self.as_const(g) {
                            Some(c) => coef *= c,
                            None => out.push(g),
                        }
                    }
                }
                _ => out.push(p),
            }
        }
        out.sort();
        if out.is_empty() {
            return self.cst(coef);
        }
        if coef == 1.0 && out.len() == 1 {
            return out[0];
        }
        if coef != 1.0 {
            out.insert(0, self.cst(coef));
        }
        self.intern(Node::Mul(out.into_boxed_slice()))
    }

    /// `e` multiplied out: every product of sums, and every positive
    /// integer power of a sum, distributed, so that like terms meet and
    /// cancel and `sin^2 + cos^2` folds (see [`Arena::add`]). Nothing is
    /// distributed inside `sin`, `cos`, `sqrt` or a negative power.
    ///
    /// A product that would form more than [`MAX_EXPANDED`] products is
    /// multiplied out over its factors that mention a coordinate or a
    /// velocity only, its other factors kept whole (and kept as it is if
    /// even that is too many): `(a + 1) (a + 2) ... (a + 50)` has 2^50
    /// products, which no model needs (the built-in ones form at most 4
    /// at once). The value is the same either way.
    pub fn expand(&mut self, e: Id) -> Id {
        self.expand_memo(e, &mut HashMap::new())
    }

    fn expand_memo(&mut self, e: Id, memo: &mut HashMap<Id, Id>) -> Id {
        if let Some(&d) = memo.get(&e) {
            return d;
        }
        let out = match self.node(e).clone() {
            Node::Add(ts) => {
                let ts: Vec<Id> = ts.iter().map(|&t| self.expand_memo(t, memo)).collect();
                self.add(&ts)
            }
            Node::Mul(fs) => {
                // each factor multiplied out, then into the terms so far
                let (mut terms, mut done) = (Some(vec![self.cst(1.0)]), Vec::with_capacity(fs.len()));
                for &f in fs.iter() {
                    let f = self.expand_memo(f, memo);
                    done.push(f);
                    terms = terms.and_then(|ts| self.times_within(&ts, f));
                }
                match terms {
                    Some(terms) => self.add(&terms),
                    None => self.expand_state_factors(&done),
                }
            }
            Node::Pow(b, n) if n > 1 && matches!(self.node(b), Node::Add(_)) => {
                let b = self.expand_memo(b, memo);
                match self.expanded_product(&vec![b; n as usize]) {
                    Some(terms) => self.add(&terms),
                    None => self.pow(b, n),
                }
            }
            _ => e,
        };
        memo.insert(e, out);
        out
    }

    /// The terms of the product of `fs` multiplied out (not yet summed),
    /// or `None` if that would form more than [`MAX_EXPANDED`] products.
    fn expanded_product(&mut self, fs: &[Id]) -> Option<Vec<Id>> {
        let mut terms = vec![self.cst(1.0)];
        for &f in fs {
            terms = self.times_within(&terms, f)?;
        }
        Some(terms)
    }

    /// [`Arena::distribute`], or `None` if it would form more than
    /// [`MAX_EXPANDED`] products (checked before any is formed).
    fn times_within(&mut self, terms: &[Id], f: Id) -> Option<Vec<Id>> {
        let width = match self.node(f) {
            Node::Add(ts) => ts.len(),
            _ => 1,
        };
        (terms.len().saturating_mul(width) <= MAX_EXPANDED).then(|| self.distribute(terms, f))
    }

    /// The product of `fs` (each multiplied out) multiplied out over its
    /// factors that mention a coordinate or a velocity, the others kept
    /// whole as one factor of every term; the product as it is if that
    /// too is more than [`MAX_EXPANDED`] products.
    fn expand_state_factors(&mut self, fs: &[Id]) -> Id {
        let state = |s: Sym| matches!(s, Sym::Q(_) | Sym::Qd(_));
        let (kept, spread): (Vec<Id>, Vec<Id>) = fs.iter().partition(|&&f| !self.mentions(f, &state));
        match self.expanded_product(&spread) {
            Some(terms) => {
                let whole = self.mul(&kept);
                let terms: Vec<Id> = terms.iter().map(|&t| self.mul2(whole, t)).collect();
                self.add(&terms)
            }
            None => self.mul(fs),
        }
    }

    /// The terms of `(sum of terms) * f`, `f`'s own terms distributed.
    fn distribute(&mut self, terms: &[Id], f: Id) -> Vec<Id> {
        let fs: Vec<Id> = match self.node(f) {
            Node::Add(ts) => ts.to_vec(),
            _ => vec![f],
        };
        let mut out = Vec::with_capacity(terms.len() * fs.len());
        for &t in terms {
            for &g in &fs {
                out.push(self.mul2(t, g));
            }
        }
        out
    }

    /// `b^n` for an integer `n`.
    pub fn pow(&mut self, b: Id, n: i32) -> Id {
        if n == 0 {
            return self.cst(1.0);
        }
        if n == 1 {
            return b;
        }
        match self.node(b).clone() {
            Node::Const(bits) => self.cst(f64::from_bits(bits).powi(n)),
            Node::Pow(c, m) => self.pow(c, m * n),
            Node::Mul(fs) => {
                let ps: Vec<Id> = fs.iter().map(|&f| self.pow(f, n)).collect();
                self.mul(&ps)
            }
            Node::Sqrt(x) if n % 2 == 0 => self.pow(x, n / 2),
            _ => self.intern(Node::Pow(b, n)),
        }
    }

    /// `sin(a)`.
    pub fn sin(&mut self, a: Id) -> Id {
        match self.as_const(a) {
            Some(v) => self.cst(v.sin()),
            None => self.intern(Node::Sin(a)),
        }
    }

    /// `cos(a)`.
    pub fn cos(&mut self, a: Id) -> Id {
        self.cos_raw(a)
    }

    fn cos_raw(&mut self, a: Id) -> Id {
        match self.as_const(a) {
            Some(v) => self.cst(v.cos()),
            None => self.intern(Node::Cos(a)),
        }
    }

    /// `sqrt(a)`.
    pub fn sqrt(&mut self, a: Id) -> Id {
        match self.as_const(a) {
            Some(v) => self.cst(v.sqrt()),
            None => self.intern(Node::Sqrt(a)),
        }
    }

    /// Evaluates `id` with symbol values from `env`.
    pub fn eval(&self, id: Id, env: &dyn Fn(Sym) -> f64) -> f64 {
        let mut vals: HashMap<Id, f64> = HashMap::new();
        self.eval_memo(id, env, &mut vals)
    }

    fn eval_memo(&self, id: Id, env: &dyn Fn(Sym) -> f64, vals: &mut HashMap<Id, f64>) -> f64 {
        if let Some(&v) = vals.get(&id) {
            return v;
        }
        let v = match self.node(id) {
            Node::Const(bits) => f64::from_bits(*bits),
            Node::Sym(s) => env(*s),
            Node::Add(ts) => ts.iter().map(|&t| self.eval_memo(t, env, vals)).sum(),
            Node::Mul(fs) => fs.iter().map(|&f| self.eval_memo(f, env, vals)).product(),
            Node::Pow(b, n) => self.eval_memo(*b, env, vals).powi(*n),
            Node::Sin(a) => self.eval_memo(*a, env, vals).sin(),
            Node::Cos(a) => self.eval_memo(*a, env, vals).cos(),
            Node::Sqrt(a) => self.eval_memo(*a, env, vals).sqrt(),
        };
        vals.insert(id, v);
        v
    }

    /// The ids reachable from `roots`, ascending (an evaluation order).
    pub fn reachable(&self, roots: &[Id]) -> Vec<Id> {
        let mut seen = vec![false; self.nodes.len()];
        let mut stack: Vec<Id> = roots.to_vec();
        while let Some(id) = stack.pop() {
            if std::mem::replace(&mut seen[id.index()], true) {
                continue;
            }
            match self.node(id) {
                Node::Const(_) | Node::Sym(_) => {}
                Node::Add(xs) | Node::Mul(xs) => stack.extend_from_slice(xs),
                Node::Pow(a, _) | Node::Sin(a) | Node::Cos(a) | Node::Sqrt(a) => stack.push(*a),
            }
        }
        (0..self.nodes.len()).filter(|&i| seen[i]).map(|i| Id(i as u32)).collect()
    }
}

fn push_power(powers: &mut Keyed<i32>, b: Id, n: i32) {
    powers.add(b, n, |e, n| *e += n);
}

/// Values keyed by node, in first-seen order: found by a linear scan while
/// there are few, by a hash index once there are many (a sum or product
/// of thousands of distinct terms collects in linear time).
struct Keyed<T> {
    items: Vec<(Id, T)>,
    index: HashMap<Id, usize>,
}

impl<T> Default for Keyed<T> {
    fn default() -> Self {
        Self { items: Vec::new(), index: HashMap::new() }
    }
}

impl<T> Keyed<T> {
    /// Where there are more items than this, the index finds them.
    const SCAN: usize = 16;

    /// `merge(existing, value)` into `key`'s value, or `key` appended.
    fn add(&mut self, key: Id, value: T, merge: impl FnOnce(&mut T, T)) {
        let at = if self.items.len() <= Self::SCAN {
            self.items.iter().position(|(k, _)| *k == key)
        } else {
            if self.index.is_empty() {
                self.index.extend(self.items.iter().enumerate().map(|(i, (k, _))| (*k, i)));
            }
            self.index.get(&key).copied()
        };
        match at {
            Some(i) => merge(&mut self.items[i].1, value),
            None => {
                if !self.index.is_empty() {
                    self.index.insert(key, self.items.len());
                }
                self.items.push((key, value));
            }
        }
    }
}

#[cfg(test)]
mod tests;
