//! Collection in the state: a sum multiplied out and its terms gathered
//! by the part that changes during a run (coordinates, velocities, their
//! sines and cosines), each such monomial once with the sum of its fixed
//! coefficients (parameters and numbers), which the table of constants
//! then holds as one entry ([`Arena::group_fixed`]). `m2 cos^2 th +
//! m2 (1 + k)^2 sin^2 th + J sin^2 th` becomes `m2 + K sin^2 th`
//! (`K = m2 (1 + k)^2 + J - m2`): the mass matrix of Maggi's equations
//! in the form a hand derivation gives it (Kane & Levinson 1985, ch. 6).
//! [`Arena::op_count`] weighs the result against the form it came from,
//! so a caller keeps whichever is cheaper.

use std::collections::HashSet;

use super::{Arena, Id, Node};

/// The most terms a multiplied-out sum may have before collection gives
/// up on it (a large model's products of sums grow as their product;
/// the factored form is then kept).
const MAX_TERMS: usize = 400;
/// The most products one step of multiplying out may form before their
/// like terms are collected.
const MAX_PRODUCTS: usize = 2000;

impl Arena {
    /// `e` multiplied out ([`Arena::expand`]; sines and cosines stay
    /// whole), every squared cosine written as `1 - sin^2` (so `K_c
    /// cos^2 u + K_s sin^2 u` is `K_c + (K_s - K_c) sin^2 u`, and no power
    /// of a cosine above the first is left), and its terms gathered by
    /// their non-fixed factors, each gathered coefficient a sum of fixed
    /// products. `None` as soon as a sum on the way has more than
    /// `MAX_TERMS` terms (before it is built). `fixed` is
    /// [`Arena::fixed_nodes`] as far as an earlier call extended it.
    ///
    /// Writing `K cos^2 u` as `K - K sin^2 u` moves its rounding: near
    /// `u = +-pi/2` its relative error is about `eps / cos^2 u` of the
    /// term, which matters only where such a term is most of an entry
    /// that is small there (a mass matrix entry with no constant part);
    /// the caller keeps the factored form where it is not more costly.
    pub fn collect_state(&mut self, e: Id, fixed: &mut Vec<bool>) -> Option<Id> {
        let terms = self.expand_bounded(e, &mut std::collections::HashMap::new())?;
        // cos^n u = cos^(n-2) u (1 - sin^2 u) until no cosine is squared:
        // a polynomial in the sines with each cosine at most linear
        let mut work = terms;
        let mut reduced = Vec::with_capacity(work.len());
        while let Some(t) = work.pop() {
            match self.cos_power(t) {
                Some((rest, u, n)) => {
                    let (c, s) = (self.cos(u), self.sin(u));
                    let (cn, s2) = (self.pow(c, n - 2), self.pow(s, 2));
                    let keep = self.mul2(rest, cn);
                    let minus = self.cst(-1.0);
                    let other = self.mul(&[minus, keep, s2]);
                    work.extend([keep, other]);
                    if work.len() + reduced.len() > MAX_TERMS {
                        return None;
                    }
                }
                None => reduced.push(t),
            }
        }
        self.extend_fixed(fixed);
        // state monomial -> its fixed coefficients, in first-seen order
        let mut groups: Vec<(Id, Vec<Id>)> = Vec::new();
        for t in reduced {
            let (mut kf, mut sf) = (Vec::new(), Vec::new());
            let fs = match self.node(t) {
                Node::Mul(fs) => fs.to_vec(),
                _ => vec![t],
            };
            for f in fs {
                if fixed.get(f.index()).copied().unwrap_or(false) { kf.push(f) } else { sf.push(f) }
            }
            let (k, s) = (self.mul(&kf), self.mul(&sf));
            match groups.iter_mut().find(|(m, _)| *m == s) {
                Some(g) => g.1.push(k),
                None => groups.push((s, vec![k])),
            }
        }
        let sums: Vec<(Id, Id)> = groups.into_iter().map(|(m, ks)| (m, self.add(&ks))).collect();
        let mut out = Vec::with_capacity(sums.len());
        for (m, k) in sums {
            if !self.is_zero(k) {
                out.push(self.mul2(k, m));
            }
        }
        // as it is: a coefficient that is a sum stays one term
        Some(self.add_raw(out))
    }

    /// The terms of `e` multiplied out as [`Arena::expand`] does, or
    /// `None` as soon as a product of sums or a power of a sum would have
    /// more than [`MAX_TERMS`] terms, checked before it is formed (a large
    /// model's entries grow as products of its sums).
    fn expand_bounded(&mut self, e: Id, memo: &mut std::collections::HashMap<Id, Vec<Id>>) -> Option<Vec<Id>> {
        if let Some(ts) = memo.get(&e) {
            return Some(ts.clone());
        }
        let terms_of = |ar: &Arena, x: Id| match ar.node(x) {
            Node::Add(ts) => ts.to_vec(),
            _ => vec![x],
        };
        let out: Vec<Id> = match self.node(e).clone() {
            Node::Add(ts) => {
                let mut all = Vec::new();
                for t in ts.iter() {
                    all.extend(self.expand_bounded(*t, memo)?);
                    if all.len() > MAX_TERMS {
                        return None;
                    }
                }
                let sum = self.add(&all);
                terms_of(self, sum)
            }
            Node::Mul(fs) => {
                let mut terms = vec![self.cst(1.0)];
                for f in fs.iter() {
                    let ft = self.expand_bounded(*f, memo)?;
                    terms = self.times_bounded(&terms, &ft)?;
                }
                terms
            }
            Node::Pow(b, n) if n > 1 && matches!(self.node(b), Node::Add(_)) => {
                let bt = self.expand_bounded(b, memo)?;
                let mut terms = vec![self.cst(1.0)];
                for _ in 0..n {
                    terms = self.times_bounded(&terms, &bt)?;
                }
                terms
            }
            _ => vec![e],
        };
        memo.insert(e, out.clone());
        Some(out)
    }

    /// The terms of `(sum of a) (sum of b)` with like terms collected, or
    /// `None` if that would form more than [`MAX_PRODUCTS`] products or
    /// leave more than [`MAX_TERMS`] terms.
    fn times_bounded(&mut self, a: &[Id], b: &[Id]) -> Option<Vec<Id>> {
        if a.len() * b.len() > MAX_PRODUCTS {
            return None;
        }
        let mut products = Vec::with_capacity(a.len() * b.len());
        for &x in a {
            for &y in b {
                products.push(self.mul2(x, y));
            }
        }
        let sum = self.add(&products);
        let terms = match self.node(sum) {
            Node::Add(ts) => ts.to_vec(),
            _ => vec![sum],
        };
        (terms.len() <= MAX_TERMS).then_some(terms)
    }

    /// `(rest, u, n)` if the monomial `m` is `rest cos^n u` with `n >= 2`.
    fn cos_power(&mut self, m: Id) -> Option<(Id, Id, i32)> {
        let fs = self.factors(m);
        for (pos, &f) in fs.iter().enumerate() {
            let Node::Pow(base, n) = *self.node(f) else { continue };
            let Node::Cos(u) = *self.node(base) else { continue };
            if n < 2 {
                continue;
            }
            let mut rest = fs.clone();
            rest.remove(pos);
            return Some((self.mul(&rest), u, n));
        }
        None
    }

    /// The arithmetic operations the straight-line code of `roots` takes
    /// beyond the nodes of `done` (already computed) and the fixed ones
    /// (`fixed`, [`Arena::fixed_nodes`]: the table of constants): an
    /// `n`-term sum or product `n - 1`, a square or a reciprocal 1,
    /// another power 2, a sine or cosine 20 (a library call). The nodes
    /// counted are added to `done`.
    pub fn op_count(&self, roots: &[Id], fixed: &[bool], done: &mut HashSet<Id>) -> usize {
        let mut stack: Vec<Id> = roots.to_vec();
        let mut ops = 0;
        while let Some(id) = stack.pop() {
            if fixed.get(id.index()).copied().unwrap_or(false) || !done.insert(id) {
                continue;
            }
            ops += match self.node(id) {
                Node::Const(_) | Node::Sym(_) => 0,
                Node::Add(xs) | Node::Mul(xs) => {
                    stack.extend_from_slice(xs);
                    xs.len() - 1
                }
                Node::Pow(a, n) => {
                    stack.push(*a);
                    if *n == 2 || *n == -1 { 1 } else { 2 }
                }
                Node::Sin(a) | Node::Cos(a) => {
                    stack.push(*a);
                    20
                }
                Node::Sqrt(a) => {
                    stack.push(*a);
                    15
                }
            };
        }
        ops
    }

    /// `e` in collected form if that is cheaper: `candidate` (already
    /// collected and rewritten) against `e`, each counted beyond `done`;
    /// the one kept has its nodes added to `done`.
    pub fn cheaper(&self, e: Id, candidate: Option<Id>, fixed: &[bool], done: &mut HashSet<Id>) -> Id {
        let Some(c) = candidate else {
            self.op_count(&[e], fixed, done);
            return e;
        };
        let (mut d1, mut d2) = (done.clone(), done.clone());
        let (n_old, n_new) = (self.op_count(&[e], fixed, &mut d1), self.op_count(&[c], fixed, &mut d2));
        if n_new < n_old {
            *done = d2;
            c
        } else {
            *done = d1;
            e
        }
    }
}

#[cfg(test)]
mod tests {
    use std::collections::HashSet;

    use super::super::{Arena, Id, Node, Sym};

    /// The EzyRoller's `(B^T M B)_00` as Maggi's sum gives it:
    /// `m1 + m2 cos^2 th + m2 ((c/L) sin th + sin th)^2 + J (sin th / L)^2`
    /// over the angle difference `th`, with `m1, m2, c, L, J` parameters.
    fn mass_entry(ar: &mut Arena) -> (Id, Id) {
        let [m1, m2, c, l, j] = [0, 1, 2, 3, 4].map(|i| ar.sym(Sym::Param(i)));
        let (p1, p2) = (ar.sym(Sym::Q(2)), ar.sym(Sym::Q(5)));
        let th = ar.sub(p1, p2);
        let (s, co) = (ar.sin(th), ar.cos(th));
        let c_l = ar.div(c, l);
        let lat = ar.mul2(c_l, s);
        let lat = ar.add2(lat, s);
        let rot = ar.div(s, l);
        let co2 = ar.pow(co, 2);
        let lat2 = ar.pow(lat, 2);
        let rot2 = ar.pow(rot, 2);
        let terms = [m1, ar.mul2(m2, co2), ar.mul2(m2, lat2), ar.mul2(j, rot2)];
        (ar.add(&terms), th)
    }

    fn env(s: Sym) -> f64 {
        match s {
            Sym::Param(i) => [46.0, 1.0, 0.1, 0.2, 0.015][i],
            Sym::Q(2) => 0.4,
            Sym::Q(5) => -2.3,
            _ => f64::NAN,
        }
    }

    #[test]
    fn collection_keeps_the_value_and_leaves_one_sine_square() {
        let mut ar = Arena::new();
        let (e, th) = mass_entry(&mut ar);
        let c = ar.collect_state(e, &mut Vec::new()).expect("small");
        let (v0, v1) = (ar.eval(e, &env), ar.eval(c, &env));
        assert!((v0 - v1).abs() <= 4.0 * f64::EPSILON * v0.abs(), "{v0} != {v1}");
        // `K0 + K1 sin^2 th`: two terms, the state part of one of them
        // sin^2 th, no cosine left
        let Node::Add(ts) = ar.node(c).clone() else { panic!("a sum: {}", ar.display(c, &|s| format!("{s:?}"))) };
        assert_eq!(ts.len(), 2);
        let cos = ar.cos(th);
        assert!(!ar.reachable(&[c]).contains(&cos));
        // and it is the cheaper, beyond sin th and cos th (which the
        // expansion computes): 3 operations at run time (the square, the
        // product by its coefficient, the sum; the coefficients are in
        // the table) against 13
        let fixed = ar.fixed_nodes();
        let trig = [ar.sin(th), cos];
        let mut done = HashSet::new();
        ar.op_count(&trig, &fixed, &mut done);
        let n_new = ar.op_count(&[c], &fixed, &mut done.clone());
        let n_old = ar.op_count(&[e], &fixed, &mut done.clone());
        assert_eq!((n_new, n_old), (3, 13));
        assert_eq!(ar.cheaper(e, Some(c), &fixed, &mut done), c);
    }

    #[test]
    fn the_cheaper_form_is_kept() {
        // (x + y + z)^4 multiplied out is 15 monomials: its factored form stays
        let mut ar = Arena::new();
        let [x, y, z] = [0, 1, 2].map(|i| ar.sym(Sym::Qd(i)));
        let s = ar.add(&[x, y, z]);
        let e = ar.pow(s, 4);
        let c = ar.collect_state(e, &mut Vec::new());
        let fixed = ar.fixed_nodes();
        assert_eq!(ar.cheaper(e, c, &fixed, &mut HashSet::new()), e);
        assert_eq!(ar.cheaper(e, None, &fixed, &mut HashSet::new()), e);
        let env = |s: Sym| match s {
            Sym::Qd(i) => [0.3, -1.1, 2.0][i],
            _ => f64::NAN,
        };
        let (v0, v1) = (ar.eval(e, &env), ar.eval(c.expect("small"), &env));
        assert!((v0 - v1).abs() <= 16.0 * f64::EPSILON * v0.abs(), "{v0} != {v1}");
    }

    #[test]
    fn a_sum_too_large_to_multiply_out_is_refused() {
        // (x0 + ... + x9)^3: 220 monomials, 1,000 products on the way;
        // the fourth power: 2,200 products, refused before they are formed
        let mut ar = Arena::new();
        let xs: Vec<Id> = (0..10).map(|i| ar.sym(Sym::Qd(i))).collect();
        let s = ar.add(&xs);
        let e3 = ar.pow(s, 3);
        let mut fixed = Vec::new();
        let c3 = ar.collect_state(e3, &mut fixed).expect("220 terms");
        let Node::Add(ts) = ar.node(c3).clone() else { panic!("a sum") };
        assert_eq!(ts.len(), 220);
        let e4 = ar.pow(s, 4);
        let before = ar.nodes.len();
        assert!(ar.collect_state(e4, &mut fixed).is_none(), "715 monomials");
        assert!(ar.nodes.len() - before < 100, "{} nodes made on the way", ar.nodes.len() - before);
    }
}
