//! Differentiation: one rule per node kind, built with the simplifying
//! constructors, memoized per variable.

use std::collections::HashMap;

use super::{Arena, Id, Node, Sym};

impl Arena {
    /// `d expr / d var`.
    pub fn diff(&mut self, expr: Id, var: Sym) -> Id {
        let mut memo = HashMap::new();
        self.diff_memo(expr, var, &mut memo)
    }

    fn diff_memo(&mut self, e: Id, var: Sym, memo: &mut HashMap<Id, Id>) -> Id {
        if let Some(&d) = memo.get(&e) {
            return d;
        }
        let d = match self.node(e).clone() {
            Node::Const(_) => self.cst(0.0),
            Node::Sym(s) => self.cst(if s == var { 1.0 } else { 0.0 }),
            Node::Add(ts) => {
                let ds: Vec<Id> = ts.iter().map(|&t| self.diff_memo(t, var, memo)).collect();
                self.add(&ds)
            }
            Node::Mul(fs) => {
                let mut terms = Vec::new();
                for i in 0..fs.len() {
                    let di = self.diff_memo(fs[i], var, memo);
                    if self.is_zero(di) {
                        continue;
                    }
                    let mut prod: Vec<Id> = fs.to_vec();
                    prod[i] = di;
                    terms.push(self.mul(&prod));
                }
                self.add(&terms)
            }
            Node::Pow(b, n) => {
                let db = self.diff_memo(b, var, memo);
                let k = self.cst(f64::from(n));
                let p = self.pow(b, n - 1);
                self.mul(&[k, p, db])
            }
            Node::Sin(a) => {
                let da = self.diff_memo(a, var, memo);
                let c = self.cos(a);
                self.mul(&[c, da])
            }
            Node::Cos(a) => {
                let da = self.diff_memo(a, var, memo);
                let s = self.sin(a);
                let m1 = self.cst(-1.0);
                self.mul(&[m1, s, da])
            }
            Node::Sqrt(a) => {
                let da = self.diff_memo(a, var, memo);
                let half = self.cst(0.5);
                let inv = self.pow(e, -1);
                self.mul(&[half, inv, da])
            }
        };
        memo.insert(e, d);
        d
    }
}

impl Arena {
    /// `expr` with every symbol renamed by `rename` (an injective renaming
    /// keeps the structure: a family element kernel's local coordinates
    /// become a single model's global ones).
    pub fn subst(&mut self, expr: Id, rename: &dyn Fn(Sym) -> Sym, memo: &mut HashMap<Id, Id>) -> Id {
        self.map_leaves(expr, &mut |ar, s| ar.sym(rename(s)), false, memo)
    }

    /// `expr` with the symbols `with` maps replaced by those expressions
    /// (the others kept), simplified on the way up; a numeric coefficient
    /// of a sum that a replacement created is distributed over its terms,
    /// so that like terms meet (`x - (x + y)` is `-y`).
    pub fn replace(&mut self, expr: Id, with: &dyn Fn(Sym) -> Option<Id>, memo: &mut HashMap<Id, Id>) -> Id {
        self.map_leaves(expr, &mut |ar, s| with(s).unwrap_or_else(|| ar.sym(s)), true, memo)
    }

    /// Whether `expr` mentions a symbol for which `which` holds.
    pub fn mentions(&self, expr: Id, which: &dyn Fn(Sym) -> bool) -> bool {
        self.reachable(&[expr]).into_iter().any(|id| matches!(self.node(id), Node::Sym(s) if which(*s)))
    }

    fn map_leaves(
        &mut self,
        expr: Id,
        leaf: &mut dyn FnMut(&mut Arena, Sym) -> Id,
        distribute: bool,
        memo: &mut HashMap<Id, Id>,
    ) -> Id {
        if let Some(&d) = memo.get(&expr) {
            return d;
        }
        let out = match self.node(expr).clone() {
            Node::Const(_) => expr,
            Node::Sym(s) => leaf(self, s),
            Node::Add(ts) => {
                let ts: Vec<Id> = ts.iter().map(|&t| self.map_leaves(t, leaf, distribute, memo)).collect();
                self.add(&ts)
            }
            Node::Mul(fs) => {
                let fs: Vec<Id> = fs.iter().map(|&f| self.map_leaves(f, leaf, distribute, memo)).collect();
                match (distribute, &fs[..]) {
                    (true, &[k, sum]) | (true, &[sum, k])
                        if self.as_const(k).is_some() && matches!(self.node(sum), Node::Add(_)) =>
                    {
                        let Node::Add(ts) = self.node(sum).clone() else { unreachable!("matched") };
                        let ts: Vec<Id> = ts.iter().map(|&t| self.mul2(k, t)).collect();
                        self.add(&ts)
                    }
                    _ => self.mul(&fs),
                }
            }
            Node::Pow(b, n) => {
                let b = self.map_leaves(b, leaf, distribute, memo);
                self.pow(b, n)
            }
            Node::Sin(a) => {
                let a = self.map_leaves(a, leaf, distribute, memo);
                self.sin(a)
            }
            Node::Cos(a) => {
                let a = self.map_leaves(a, leaf, distribute, memo);
                self.cos(a)
            }
            Node::Sqrt(a) => {
                let a = self.map_leaves(a, leaf, distribute, memo);
                self.sqrt(a)
            }
        };
        memo.insert(expr, out);
        out
    }
}
