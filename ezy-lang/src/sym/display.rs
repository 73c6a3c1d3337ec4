//! Infix printing of expressions, for tests, error messages and readable
//! equations. Symbols are printed through a naming function.

use super::{Arena, Id, Node, Sym};

impl Arena {
    /// Prints `id` in infix form, naming symbols with `name`.
    pub fn display(&self, id: Id, name: &dyn Fn(Sym) -> String) -> String {
        self.fmt_prec(id, name, 0)
    }

    // precedence: 0 = sum context, 1 = product context, 2 = power base
    fn fmt_prec(&self, id: Id, name: &dyn Fn(Sym) -> String, prec: u8) -> String {
        let (s, own) = match self.node(id) {
            Node::Const(bits) => {
                let v = f64::from_bits(*bits);
                (fmt_num(v), if v < 0.0 { 0 } else { 3 })
            }
            Node::Sym(s) => (name(*s), 3),
            Node::Add(ts) => (self.sum(ts, &|t| self.fmt_prec(t, name, 0)), 0),
            Node::Mul(fs) => {
                // a negative coefficient is a sign: `-0.5*l`, not `(-0.5)*l`
                let (sign, coef, fs) = match self.as_const(fs[0]) {
                    Some(-1.0) => ("-", None, &fs[1..]),
                    Some(c) if c < 0.0 => ("-", Some(fmt_num(-c)), &fs[1..]),
                    _ => ("", None, &fs[..]),
                };
                let mut body: Vec<String> = coef.into_iter().collect();
                body.extend(self.reading_order(fs).into_iter().map(|f| self.fmt_prec(f, name, 1)));
                (format!("{sign}{}", body.join("*")), if sign.is_empty() { 1 } else { 0 })
            }
            Node::Pow(b, n) => (format!("{}^{}", self.fmt_prec(*b, name, 2), fmt_exp(*n)), 2),
            Node::Sin(a) => (format!("sin({})", self.fmt_prec(*a, name, 0)), 3),
            Node::Cos(a) => (format!("cos({})", self.fmt_prec(*a, name, 0)), 3),
            Node::Sqrt(a) => (format!("sqrt({})", self.fmt_prec(*a, name, 0)), 3),
        };
        if own < prec || (own == 2 && prec == 2) { format!("({s})") } else { s }
    }
}

impl Arena {
    /// A sum printed term by term with ` + ` and ` - `.
    fn sum(&self, ts: &[Id], print: &dyn Fn(Id) -> String) -> String {
        let mut out = String::new();
        for (i, (t, neg)) in self.signed_terms(ts).into_iter().enumerate() {
            let piece = negate_if(print(t), neg);
            if i == 0 {
                out.push_str(&piece);
            } else if let Some(rest) = piece.strip_prefix('-') {
                out.push_str(" - ");
                out.push_str(rest);
            } else {
                out.push_str(" + ");
                out.push_str(&piece);
            }
        }
        out
    }

    /// The terms of a sum for reading: a term `-(u + v)` is spread into
    /// `-u`, `-v` (`x1 - x2 + d cos phi2` rather than `x1 - (x2 - d cos phi2)`).
    /// Returns `(term, negated)`.
    fn signed_terms(&self, ts: &[Id]) -> Vec<(Id, bool)> {
        let mut out = Vec::with_capacity(ts.len());
        for &t in ts {
            if let Node::Mul(fs) = self.node(t)
                && fs.len() == 2
                && self.as_const(fs[0]) == Some(-1.0)
                && let Node::Add(inner) = self.node(fs[1])
            {
                out.extend(self.signed_terms(inner).into_iter().map(|(u, n)| (u, !n)));
            } else {
                out.push((t, false));
            }
        }
        out
    }

    /// Factors of a product in reading order: numbers, family indices,
    /// parameters, coordinates and rates, powers, functions, sums
    /// (`b*cos(phi1)`, `2*i*L`).
    fn reading_order(&self, fs: &[Id]) -> Vec<Id> {
        let rank = |f: Id| match self.node(f) {
            Node::Const(_) => 0,
            Node::Sym(Sym::Index(_)) => 1,
            Node::Sym(Sym::Param(_)) => 2,
            Node::Sym(_) => 3,
            Node::Pow(..) => 4,
            Node::Sin(_) | Node::Cos(_) | Node::Sqrt(_) => 5,
            _ => 6,
        };
        let mut out = fs.to_vec();
        out.sort_by_key(|&f| rank(f));
        out
    }
}

/// `-piece` when `neg` (a leading `-` cancels).
fn negate_if(piece: String, neg: bool) -> String {
    match (neg, piece.strip_prefix('-')) {
        (false, _) => piece,
        (true, Some(rest)) => rest.to_string(),
        (true, None) => format!("-{piece}"),
    }
}

fn fmt_num(v: f64) -> String {
    if v.fract() == 0.0 && v.abs() < 1e15 { format!("{}", v as i64) } else { format!("{v}") }
}

fn fmt_exp(n: i32) -> String {
    if n < 0 { format!("({n})") } else { n.to_string() }
}

impl Arena {
    /// Prints `id` as LaTeX math, naming symbols with `name` (which returns
    /// LaTeX): products by juxtaposition, negative powers as fractions,
    /// `\sin`, `\cos`, `\sqrt{}`.
    pub fn latex(&self, id: Id, name: &dyn Fn(Sym) -> String) -> String {
        self.latex_prec(id, name, 0)
    }

    fn latex_prec(&self, id: Id, name: &dyn Fn(Sym) -> String, prec: u8) -> String {
        let (s, own) = match self.node(id) {
            Node::Const(bits) => {
                let v = f64::from_bits(*bits);
                (fmt_num(v), if v < 0.0 { 0 } else { 3 })
            }
            Node::Sym(s) => (name(*s), 3),
            Node::Add(ts) => (self.sum(ts, &|t| self.latex_prec(t, name, 0)), 0),
            Node::Mul(fs) => {
                let (sign, coef, rest) = match self.as_const(fs[0]) {
                    Some(-1.0) => ("-", None, &fs[1..]),
                    Some(c) if c < 0.0 => ("-", Some(fmt_num(-c)), &fs[1..]),
                    Some(c) => ("", Some(fmt_num(c)), &fs[1..]),
                    None => ("", None, &fs[..]),
                };
                let (mut num, mut den) = (coef.into_iter().collect::<Vec<_>>(), Vec::new());
                for f in self.reading_order(rest) {
                    match self.node(f) {
                        Node::Pow(b, n) if *n < 0 => {
                            let p = self.pow_latex(*b, -n, name);
                            den.push(p);
                        }
                        _ => num.push(self.latex_prec(f, name, 1)),
                    }
                }
                let num = if num.is_empty() { "1".to_string() } else { num.join(" ") };
                if den.is_empty() {
                    (format!("{sign}{num}"), if sign.is_empty() { 1 } else { 0 })
                } else {
                    (format!("{sign}\\frac{{{num}}}{{{}}}", den.join(" ")), if sign.is_empty() { 3 } else { 0 })
                }
            }
            Node::Pow(b, n) if *n < 0 => (format!("\\frac{{1}}{{{}}}", self.pow_latex(*b, -n, name)), 3),
            Node::Pow(b, n) => (self.pow_latex(*b, *n, name), 2),
            Node::Sin(a) => (format!("\\sin{}", self.latex_arg(*a, name)), 1),
            Node::Cos(a) => (format!("\\cos{}", self.latex_arg(*a, name)), 1),
            Node::Sqrt(a) => (format!("\\sqrt{{{}}}", self.latex_prec(*a, name, 0)), 3),
        };
        if own < prec || (own == 2 && prec == 2) { format!("\\left({s}\\right)") } else { s }
    }

    /// `b^{n}` for `n >= 1` (`b` when `n == 1`).
    fn pow_latex(&self, b: Id, n: i32, name: &dyn Fn(Sym) -> String) -> String {
        let base = self.latex_prec(b, name, 2);
        if n == 1 { base } else { format!("{base}^{{{n}}}") }
    }

    /// The argument of `\sin`/`\cos`: a bare symbol as ` x`, else parenthesized.
    fn latex_arg(&self, a: Id, name: &dyn Fn(Sym) -> String) -> String {
        match self.node(a) {
            Node::Sym(s) => format!(" {}", name(*s)),
            _ => format!("\\left({}\\right)", self.latex_prec(a, name, 0)),
        }
    }
}
