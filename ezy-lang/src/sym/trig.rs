//! Trigonometric polynomials in linear form: products of sines and cosines
//! turned into sums of sines and cosines of sums and differences of their
//! arguments (the product-to-sum identities), so that rotation-invariant
//! quantities lose their absolute angles (`cos a cos b + sin a sin b` is
//! `cos(a - b)`); then each `cos(a - b)`, `sin(a - b)` of two angles written
//! back as a product of the angles' own sines and cosines, which the code
//! computes anyway.

use std::collections::HashMap;

use super::{Arena, Id, Node};

/// A sine or a cosine.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Kind {
    Sin,
    Cos,
}

impl Arena {
    /// `e` multiplied out ([`Arena::expand`]) with every product of sines
    /// and cosines (integer powers too) replaced by its sum of sines and
    /// cosines of sums and differences: `cos a cos b = (cos(a - b) +
    /// cos(a + b)) / 2`, `sin a sin b = (cos(a - b) - cos(a + b)) / 2`,
    /// `sin a cos b = (sin(a + b) + sin(a - b)) / 2`; arguments with a
    /// negative leading coefficient are turned (`cos(-x) = cos x`,
    /// `sin(-x) = -sin x`), so like terms meet. Once the sum would have
    /// more than [`super::MAX_EXPANDED`] terms, the further sines and
    /// cosines stay factors as they are (the same value).
    pub fn linearize(&mut self, e: Id) -> Id {
        let e = self.expand(e);
        let terms: Vec<Id> = match self.node(e) {
            Node::Add(ts) => ts.to_vec(),
            _ => vec![e],
        };
        let mut out = Vec::new();
        for t in terms {
            let (coef, m) = self.split_coef(t);
            let mut rest = Vec::new();
            // the monomial's trigonometric factors: (coefficient, kind, argument)
            let mut sum: Vec<(f64, Option<(Kind, Id)>)> = vec![(coef, None)];
            for f in self.factors(m) {
                let (base, n) = match *self.node(f) {
                    Node::Pow(b, n) if n > 0 => (b, n),
                    _ => (f, 1),
                };
                let kind = match *self.node(base) {
                    Node::Sin(a) => Some((Kind::Sin, a)),
                    Node::Cos(a) => Some((Kind::Cos, a)),
                    _ => None,
                };
                // a factor that would make the sum so far more than
                // MAX_EXPANDED sines and cosines (2^n from n factors)
                // stays a factor
                let within = 2usize
                    .checked_pow(n as u32)
                    .and_then(|w| w.checked_mul(sum.len()))
                    .and_then(|w| w.checked_add(out.len()));
                let Some(k) = kind.filter(|_| within.is_some_and(|w| w <= super::MAX_EXPANDED)) else {
                    rest.push(f);
                    continue;
                };
                for _ in 0..n {
                    sum = self.times(&sum, k);
                }
            }
            let rest = self.mul(&rest);
            for (c, trig) in sum {
                let k = self.cst(c);
                let tr = match trig {
                    None => self.cst(1.0),
                    Some((Kind::Sin, a)) => self.sin(a),
                    Some((Kind::Cos, a)) => self.cos(a),
                };
                out.push(self.mul(&[k, rest, tr]));
            }
        }
        self.add(&out)
    }

    /// `sum * trig`, each product by the product-to-sum identities.
    fn times(&mut self, sum: &[(f64, Option<(Kind, Id)>)], (k2, b): (Kind, Id)) -> Vec<(f64, Option<(Kind, Id)>)> {
        let mut out = Vec::new();
        for &(c, t) in sum {
            let Some((k1, a)) = t else {
                out.push(self.canon(c, k2, b));
                continue;
            };
            let (d, s) = (self.sub(a, b), self.add2(a, b));
            // f(a) g(b) = (k_d t(a - b) + k_s t(a + b)) / 2
            let (kind, k_d, k_s) = match (k1, k2) {
                (Kind::Cos, Kind::Cos) => (Kind::Cos, 0.5, 0.5),
                (Kind::Sin, Kind::Sin) => (Kind::Cos, 0.5, -0.5),
                (Kind::Sin, Kind::Cos) => (Kind::Sin, 0.5, 0.5),
                (Kind::Cos, Kind::Sin) => (Kind::Sin, -0.5, 0.5),
            };
            out.push(self.canon(k_d * c, kind, d));
            out.push(self.canon(k_s * c, kind, s));
        }
        out
    }

    /// `c trig(arg)` with the argument's sign made canonical and a constant
    /// argument folded (`None` is the constant 1).
    fn canon(&mut self, c: f64, kind: Kind, arg: Id) -> (f64, Option<(Kind, Id)>) {
        if let Some(v) = self.as_const(arg) {
            return match kind {
                Kind::Cos => (c * v.cos(), None),
                Kind::Sin => (c * v.sin(), None),
            };
        }
        let lead = match self.node(arg).clone() {
            Node::Add(ts) => ts[0],
            _ => arg,
        };
        let (k, _) = self.split_coef(lead);
        if k < 0.0 {
            let neg = self.neg(arg);
            return match kind {
                Kind::Cos => (c, Some((Kind::Cos, neg))),
                Kind::Sin => (-c, Some((Kind::Sin, neg))),
            };
        }
        (c, Some((kind, arg)))
    }

    /// `e` with every `cos(a - b)` and `sin(a - b)` of two symbols written
    /// as `cos a cos b + sin a sin b` and `sin a cos b - cos a sin b`.
    pub fn trig_products(&mut self, e: Id, memo: &mut HashMap<Id, Id>) -> Id {
        if let Some(&d) = memo.get(&e) {
            return d;
        }
        let out = match self.node(e).clone() {
            Node::Const(_) | Node::Sym(_) => e,
            Node::Add(ts) => {
                let ts: Vec<Id> = ts.iter().map(|&t| self.trig_products(t, memo)).collect();
                self.add(&ts)
            }
            Node::Mul(fs) => {
                let fs: Vec<Id> = fs.iter().map(|&f| self.trig_products(f, memo)).collect();
                self.mul(&fs)
            }
            Node::Pow(b, n) => {
                let b = self.trig_products(b, memo);
                self.pow(b, n)
            }
            Node::Sqrt(a) => {
                let a = self.trig_products(a, memo);
                self.sqrt(a)
            }
            Node::Sin(a) | Node::Cos(a) => {
                let is_sin = matches!(self.node(e), Node::Sin(_));
                match self.difference(a) {
                    Some((x, y)) => {
                        let (cx, sx, cy, sy) = (self.cos(x), self.sin(x), self.cos(y), self.sin(y));
                        if is_sin {
                            let (p, m) = (self.mul2(sx, cy), self.mul2(cx, sy));
                            let m = self.neg(m);
                            self.intern(Node::Add(sorted(p, m)))
                        } else {
                            let (p, m) = (self.mul2(cx, cy), self.mul2(sx, sy));
                            self.intern(Node::Add(sorted(p, m)))
                        }
                    }
                    None => e,
                }
            }
        };
        memo.insert(e, out);
        out
    }

    /// `(x, y)` if `a` is `x - y` of two symbols.
    fn difference(&mut self, a: Id) -> Option<(Id, Id)> {
        let Node::Add(ts) = self.node(a).clone() else { return None };
        let [t0, t1] = ts[..] else { return None };
        let (c0, m0) = self.split_coef(t0);
        let (c1, m1) = self.split_coef(t1);
        let sym = |ar: &Arena, m: Id| matches!(ar.node(m), Node::Sym(_));
        if !(sym(self, m0) && sym(self, m1)) {
            return None;
        }
        match (c0, c1) {
            (1.0, -1.0) => Some((m0, m1)),
            (-1.0, 1.0) => Some((m1, m0)),
            _ => None,
        }
    }
}

fn sorted(a: Id, b: Id) -> Box<[Id]> {
    let mut v = vec![a, b];
    v.sort();
    v.into_boxed_slice()
}

impl Arena {
    /// `e` with common factors pulled out of its sums, greedily: the factor
    /// that most terms of a sum share (at least two) is taken out of them,
    /// `x a + x b + c = x (a + b) + c`, and the same is done inside, so a
    /// sum of long monomials becomes a nest of short products (Horner's
    /// scheme in several variables).
    pub fn factor(&mut self, e: Id, memo: &mut HashMap<Id, Id>) -> Id {
        self.factor_by(e, memo, false)
    }

    /// [`Arena::factor`] pulling out only factors that change during a
    /// run (that mention a coordinate, a velocity or a family index): the
    /// fixed ones stay with their terms' coefficients, which the table of
    /// constants then holds whole.
    pub fn factor_state(&mut self, e: Id, memo: &mut HashMap<Id, Id>) -> Id {
        self.factor_by(e, memo, true)
    }

    fn factor_by(&mut self, e: Id, memo: &mut HashMap<Id, Id>, state_only: bool) -> Id {
        if let Some(&d) = memo.get(&e) {
            return d;
        }
        let out = match self.node(e).clone() {
            Node::Add(ts) => {
                let ts: Vec<Id> = ts.iter().map(|&t| self.factor_by(t, memo, state_only)).collect();
                self.factor_sum(ts, state_only)
            }
            Node::Mul(fs) => {
                let fs: Vec<Id> = fs.iter().map(|&f| self.factor_by(f, memo, state_only)).collect();
                self.mul(&fs)
            }
            _ => e,
        };
        memo.insert(e, out);
        out
    }

    /// The sum of `ts` factored: `x (..) + (y (..) + (.. + rest))`, the
    /// terms without the first common factor factored in turn (a loop:
    /// a sum of many terms is no deep recursion), the terms with it
    /// factored inside (a recursion as deep as a term has factors).
    fn factor_sum(&mut self, ts: Vec<Id>, state_only: bool) -> Id {
        let mut ts = ts;
        let mut products = Vec::new();
        let tail = loop {
            let Some(x) = self.common_factor(&ts, state_only) else { break self.add_raw(ts) };
            let (mut with, mut without) = (Vec::new(), Vec::new());
            for t in ts {
                let mut fs = self.factors(t);
                match fs.iter().position(|&f| f == x) {
                    Some(p) => {
                        fs.remove(p);
                        with.push(self.mul(&fs));
                    }
                    None => without.push(t),
                }
            }
            let inner = self.factor_sum(with, state_only);
            let prod = self.mul2(x, inner);
            if without.is_empty() {
                break prod;
            }
            products.push(prod);
            ts = without;
        };
        products.into_iter().rev().fold(tail, |rest, prod| self.add_raw(vec![prod, rest]))
    }

    /// The non-numeric factor most of `ts` share (at least two; counted
    /// among those that change if `state_only`), the lowest id of the
    /// most shared.
    fn common_factor(&self, ts: &[Id], state_only: bool) -> Option<Id> {
        let changes = |s: super::Sym| !matches!(s, super::Sym::Param(_));
        let mut count: HashMap<Id, usize> = HashMap::new();
        for &t in ts {
            let mut fs = self.factors(t);
            fs.dedup();
            for f in fs {
                if self.as_const(f).is_none() && (!state_only || self.mentions(f, &changes)) {
                    *count.entry(f).or_default() += 1;
                }
            }
        }
        let (&x, &n) = count.iter().max_by_key(|(id, n)| (**n, std::cmp::Reverse(**id)))?;
        (n >= 2).then_some(x)
    }
}
