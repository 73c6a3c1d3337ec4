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
            Node::Add(ts) => {
                let mut out = String::new();
                for (i, &t) in ts.iter().enumerate() {
                    let piece = self.fmt_prec(t, name, 0);
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
                (out, 0)
            }
            Node::Mul(fs) => {
                let (sign, fs) = match self.as_const(fs[0]) {
                    Some(-1.0) => ("-", &fs[1..]),
                    _ => ("", &fs[..]),
                };
                let body: Vec<String> = fs.iter().map(|&f| self.fmt_prec(f, name, 1)).collect();
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

fn fmt_num(v: f64) -> String {
    if v.fract() == 0.0 && v.abs() < 1e15 { format!("{}", v as i64) } else { format!("{v}") }
}

fn fmt_exp(n: i32) -> String {
    if n < 0 { format!("({n})") } else { n.to_string() }
}
