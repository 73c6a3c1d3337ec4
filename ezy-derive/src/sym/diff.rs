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
        if let Some(&d) = memo.get(&expr) {
            return d;
        }
        let out = match self.node(expr).clone() {
            Node::Const(_) => expr,
            Node::Sym(s) => self.sym(rename(s)),
            Node::Add(ts) => {
                let ts: Vec<Id> = ts.iter().map(|&t| self.subst(t, rename, memo)).collect();
                self.add(&ts)
            }
            Node::Mul(fs) => {
                let fs: Vec<Id> = fs.iter().map(|&f| self.subst(f, rename, memo)).collect();
                self.mul(&fs)
            }
            Node::Pow(b, n) => {
                let b = self.subst(b, rename, memo);
                self.pow(b, n)
            }
            Node::Sin(a) => {
                let a = self.subst(a, rename, memo);
                self.sin(a)
            }
            Node::Cos(a) => {
                let a = self.subst(a, rename, memo);
                self.cos(a)
            }
            Node::Sqrt(a) => {
                let a = self.subst(a, rename, memo);
                self.sqrt(a)
            }
        };
        memo.insert(expr, out);
        out
    }
}
