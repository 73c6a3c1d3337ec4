//! Loop-invariant code motion for a right-hand side: the subexpressions
//! that mention only numbers and parameters are fixed for a run, so the
//! generated code computes them once (a table of constants) instead of at
//! every evaluation. [`Arena::group_fixed`] first gathers the fixed
//! factors of each product and the fixed terms of each sum into one node,
//! `-(d / (c + d)) * sin th` instead of `-1 * d * (c + d)^-1 * sin th`, so
//! that the whole fixed part becomes one entry of the table;
//! [`Arena::fixed_nodes`] tells which nodes are fixed.

use std::collections::HashMap;

use super::{Arena, Id, Node, Sym};

/// The memo of [`Arena::group_fixed`]: its results, and which nodes are
/// fixed.
#[derive(Default)]
pub struct Grouping {
    out: HashMap<Id, Id>,
    fixed: Vec<bool>,
}

impl Arena {
    /// For every node of the arena, whether it mentions no coordinate, no
    /// velocity and no family index (numbers and parameters only: the
    /// same for every element), indexed by [`Id::index`].
    pub fn fixed_nodes(&self) -> Vec<bool> {
        let mut fixed = Vec::with_capacity(self.nodes.len());
        self.extend_fixed(&mut fixed);
        fixed
    }

    /// [`Arena::fixed_nodes`] continued over the nodes added since `fixed`
    /// was last extended (children have smaller ids: one pass).
    pub(super) fn extend_fixed(&self, fixed: &mut Vec<bool>) {
        for node in &self.nodes[fixed.len()..] {
            let f = match node {
                Node::Const(_) | Node::Sym(Sym::Param(_)) => true,
                Node::Sym(_) => false,
                Node::Add(xs) | Node::Mul(xs) => xs.iter().all(|x| fixed[x.index()]),
                Node::Pow(a, _) | Node::Sin(a) | Node::Cos(a) | Node::Sqrt(a) => fixed[a.index()],
            };
            fixed.push(f);
        }
    }

    /// `e` with the fixed factors of every product that also has others,
    /// and the fixed terms of every sum that also has others, gathered into
    /// one fixed node each (two or more of them; a numeric coefficient
    /// counts as one). The value is the same; only the order of the
    /// operations, and so the rounding, changes. The gathered nodes are
    /// built as they are, not flattened back into their parents.
    pub fn group_fixed(&mut self, e: Id, memo: &mut Grouping) -> Id {
        if let Some(&d) = memo.out.get(&e) {
            return d;
        }
        let out = match self.node(e).clone() {
            Node::Const(_) | Node::Sym(_) => e,
            _ if self.is_fixed(e, &mut memo.fixed) => e,
            Node::Add(ts) => {
                let ts: Vec<Id> = ts.iter().map(|&t| self.group_fixed(t, memo)).collect();
                let (fixed, rest): (Vec<Id>, Vec<Id>) =
                    ts.into_iter().partition(|&t| self.is_fixed(t, &mut memo.fixed));
                let mut out = rest;
                if !fixed.is_empty() {
                    out.push(self.add_raw(fixed));
                }
                self.add_raw(out)
            }
            Node::Mul(fs) => {
                let fs: Vec<Id> = fs.iter().map(|&f| self.group_fixed(f, memo)).collect();
                let (fixed, rest): (Vec<Id>, Vec<Id>) =
                    fs.into_iter().partition(|&f| self.is_fixed(f, &mut memo.fixed));
                let mut out = rest;
                match fixed.len() {
                    0 => {}
                    1 => out.push(fixed[0]),
                    _ => out.push(self.mul_raw(fixed)),
                }
                self.mul_raw(out)
            }
            Node::Pow(b, n) => {
                let b = self.group_fixed(b, memo);
                self.pow(b, n)
            }
            Node::Sin(a) => {
                let a = self.group_fixed(a, memo);
                self.sin(a)
            }
            Node::Cos(a) => {
                let a = self.group_fixed(a, memo);
                self.cos(a)
            }
            Node::Sqrt(a) => {
                let a = self.group_fixed(a, memo);
                self.sqrt(a)
            }
        };
        memo.out.insert(e, out);
        out
    }

    /// Whether `e` mentions only numbers and parameters, `fixed` being
    /// [`Arena::fixed_nodes`] as far as it was extended.
    fn is_fixed(&self, e: Id, fixed: &mut Vec<bool>) -> bool {
        self.extend_fixed(fixed);
        fixed[e.index()]
    }

    /// The product of `fs` as it is (no flattening, no folding), a
    /// numeric coefficient first: `1` for none, the factor for one.
    fn mul_raw(&mut self, mut fs: Vec<Id>) -> Id {
        match fs.len() {
            0 => self.cst(1.0),
            1 => fs[0],
            _ => {
                fs.sort_by_key(|&f| (self.as_const(f).is_none(), f));
                self.intern(Node::Mul(fs.into_boxed_slice()))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grouping_keeps_the_value_and_gathers_the_fixed_part() {
        let mut ar = Arena::new();
        let (x, y) = (ar.sym(Sym::Q(0)), ar.sym(Sym::Qd(1)));
        let (c, d) = (ar.sym(Sym::Param(0)), ar.sym(Sym::Param(1)));
        // -(d / (c + d)) sin x y + 3 c + d + x
        let l = ar.add2(c, d);
        let frac = ar.div(d, l);
        let s = ar.sin(x);
        let m = ar.mul(&[frac, s, y]);
        let m = ar.neg(m);
        let three = ar.cst(3.0);
        let c3 = ar.mul2(three, c);
        let e = ar.add(&[m, c3, d, x]);
        let g = ar.group_fixed(e, &mut Grouping::default());
        let env = |s: Sym| match s {
            Sym::Q(0) => 0.7,
            Sym::Qd(1) => -1.3,
            Sym::Param(0) => 0.1,
            Sym::Param(1) => 0.25,
            _ => f64::NAN,
        };
        let (v0, v1) = (ar.eval(e, &env), ar.eval(g, &env));
        assert!((v0 - v1).abs() <= 1e-15 * v0.abs(), "{v0} != {v1}");
        // the grouped sum: x, the product, and one fixed node (3 c + d)
        let fixed = ar.fixed_nodes();
        let Node::Add(ts) = ar.node(g).clone() else { panic!("a sum") };
        assert_eq!(ts.len(), 3);
        assert_eq!(ts.iter().filter(|t| fixed[t.index()]).count(), 1);
        // the product: sin x, y and one fixed factor, -(d / (c + d))
        let prod = ts.iter().find(|t| matches!(ar.node(**t), Node::Mul(_))).copied().expect("the product");
        let Node::Mul(fs) = ar.node(prod).clone() else { unreachable!() };
        assert_eq!(fs.len(), 3);
        assert_eq!(fs.iter().filter(|f| fixed[f.index()]).count(), 1);
        assert!(!fixed[g.index()] && !fixed[prod.index()]);
    }
}
