//! A gait written as text: `alpha1=0.8+0.3*cos(t),alpha2=-0.8+0.3*sin(t)`,
//! each expression a trigonometric polynomial in `t` over one period
//! `t` in \[0, 2 pi\], read into harmonics (exactly what a drive takes).

use super::{Gait, harmonic};
use crate::effects::waveform::{Harmonic, Waveform};
use crate::geometry::GeometryError;

/// Longest gait text read \[bytes\].
const MAX_LEN: usize = 4096;
/// Deepest nesting of parentheses and operators.
const MAX_DEPTH: usize = 64;

/// A value of the expression: `constant + slope t + sum harmonics`.
#[derive(Debug, Clone, Default)]
struct Value {
    constant: f64,
    slope: f64,
    harmonics: Vec<Harmonic>,
}

impl Value {
    fn number(v: f64) -> Self {
        Self { constant: v, ..Self::default() }
    }
    fn is_constant(&self) -> bool {
        self.slope == 0.0 && self.harmonics.is_empty()
    }
    fn scale(mut self, k: f64) -> Self {
        self.constant *= k;
        self.slope *= k;
        for h in &mut self.harmonics {
            h.amplitude *= k;
        }
        self
    }
    fn add(mut self, other: Value) -> Self {
        self.constant += other.constant;
        self.slope += other.slope;
        self.harmonics.extend(other.harmonics);
        self
    }
}

/// A recursive-descent reader of one expression.
struct Reader<'a> {
    text: &'a [u8],
    at: usize,
    depth: usize,
}

impl Reader<'_> {
    fn skip(&mut self) {
        while self.text.get(self.at).is_some_and(u8::is_ascii_whitespace) {
            self.at += 1;
        }
    }
    fn peek(&mut self) -> Option<u8> {
        self.skip();
        self.text.get(self.at).copied()
    }
    fn fail<T>(&self, what: &str) -> Result<T, String> {
        Err(format!("{what} at character {}", self.at + 1))
    }
    fn enter(&mut self) -> Result<(), String> {
        self.depth += 1;
        if self.depth > MAX_DEPTH { self.fail("nested too deep") } else { Ok(()) }
    }
    /// sum := term (('+' | '-') term)*
    fn sum(&mut self) -> Result<Value, String> {
        self.enter()?;
        let mut v = self.term()?;
        while let Some(op @ (b'+' | b'-')) = self.peek() {
            self.at += 1;
            let t = self.term()?;
            v = v.add(if op == b'-' { t.scale(-1.0) } else { t });
        }
        self.depth -= 1;
        Ok(v)
    }
    /// term := unary (('*' | '/') unary)*
    fn term(&mut self) -> Result<Value, String> {
        let mut v = self.unary()?;
        while let Some(op @ (b'*' | b'/')) = self.peek() {
            self.at += 1;
            let w = self.unary()?;
            v = if op == b'/' {
                if !w.is_constant() || w.constant == 0.0 {
                    return self.fail("division by something not a nonzero constant");
                }
                v.scale(1.0 / w.constant)
            } else if w.is_constant() {
                v.scale(w.constant)
            } else if v.is_constant() {
                w.scale(v.constant)
            } else {
                return self.fail("a product of two terms that vary with t (write a sum of harmonics)");
            };
        }
        Ok(v)
    }
    /// unary := '-' unary | '+' unary | atom
    fn unary(&mut self) -> Result<Value, String> {
        match self.peek() {
            Some(b'-') => {
                self.at += 1;
                self.enter()?;
                let v = self.unary()?.scale(-1.0);
                self.depth -= 1;
                Ok(v)
            }
            Some(b'+') => {
                self.at += 1;
                self.enter()?;
                let v = self.unary();
                self.depth -= 1;
                v
            }
            _ => self.atom(),
        }
    }
    /// atom := number | 't' | 'pi' | ('cos' | 'sin') '(' sum ')' | '(' sum ')'
    fn atom(&mut self) -> Result<Value, String> {
        let start = self.at;
        match self.peek() {
            Some(b'(') => {
                self.at += 1;
                let v = self.sum()?;
                self.close()?;
                Ok(v)
            }
            Some(c) if c.is_ascii_digit() || c == b'.' => {
                let begin = self.at;
                while self.text.get(self.at).is_some_and(|c| c.is_ascii_digit() || *c == b'.') {
                    self.at += 1;
                }
                if self.text.get(self.at).is_some_and(|c| *c == b'e' || *c == b'E') {
                    self.at += 1;
                    if self.text.get(self.at).is_some_and(|c| *c == b'+' || *c == b'-') {
                        self.at += 1;
                    }
                    while self.text.get(self.at).is_some_and(u8::is_ascii_digit) {
                        self.at += 1;
                    }
                }
                let s = std::str::from_utf8(&self.text[begin..self.at]).unwrap_or("");
                match s.parse::<f64>() {
                    Ok(v) if v.is_finite() && v.abs() <= 1e6 => Ok(Value::number(v)),
                    Ok(v) => {
                        self.at = begin;
                        self.fail(&format!("the number {v} (numbers up to 1e6 in size)"))
                    }
                    Err(_) => {
                        self.at = begin;
                        self.fail(&format!("`{s}` is not a number"))
                    }
                }
            }
            Some(c) if c.is_ascii_alphabetic() => {
                let begin = self.at;
                while self.text.get(self.at).is_some_and(u8::is_ascii_alphanumeric) {
                    self.at += 1;
                }
                let word = std::str::from_utf8(&self.text[begin..self.at]).unwrap_or("");
                match word {
                    "t" => Ok(Value { slope: 1.0, ..Value::default() }),
                    "pi" => Ok(Value::number(std::f64::consts::PI)),
                    "cos" | "sin" => {
                        if self.peek() != Some(b'(') {
                            return self.fail(&format!("`{word}` without `(`"));
                        }
                        self.at += 1;
                        let arg = self.sum()?;
                        self.close()?;
                        if !arg.harmonics.is_empty() {
                            self.at = begin;
                            return self.fail(&format!("`{word}` of a harmonic (its argument must be k*t + c)"));
                        }
                        let k = arg.slope;
                        if (k - k.round()).abs() > 1e-12 {
                            self.at = begin;
                            return self.fail(&format!(
                                "`{word}` of {k}*t: the frequency must be a whole number so that the gait closes at t = 2 pi"
                            ));
                        }
                        let shift = if word == "sin" { -std::f64::consts::FRAC_PI_2 } else { 0.0 };
                        let h = if k == 0.0 {
                            let v = if word == "sin" { arg.constant.sin() } else { arg.constant.cos() };
                            return Ok(Value::number(v));
                        } else {
                            harmonic(1.0, k.round(), arg.constant + shift)
                        };
                        Ok(Value { harmonics: vec![h], ..Value::default() })
                    }
                    _ => {
                        self.at = start;
                        self.fail(&format!("`{word}` (write numbers, t, pi, cos, sin)"))
                    }
                }
            }
            Some(c) => self.fail(&format!("unexpected `{}`", c as char)),
            None => self.fail("an expression ends early"),
        }
    }
    fn close(&mut self) -> Result<(), String> {
        if self.peek() == Some(b')') {
            self.at += 1;
            Ok(())
        } else {
            self.fail("a missing `)`")
        }
    }
}

/// [`Gait::parse`].
pub(super) fn parse(names: &[String], spec: &str) -> Result<Gait, GeometryError> {
    let bad = |reason: String| GeometryError::Request { reason };
    if spec.len() > MAX_LEN {
        return Err(bad(format!("--gait: {} bytes of text, more than the {MAX_LEN} read", spec.len())));
    }
    if let Some(c) = spec.chars().find(|c| c.is_control()) {
        return Err(bad(format!("--gait: a control character ({:?}) in the text", c)));
    }
    let mut shape: Vec<Option<Waveform>> = vec![None; names.len()];
    for part in spec.split(',') {
        let Some((name, expr)) = part.split_once('=') else {
            return Err(bad(format!("--gait: `{}` is not name=expression", part.trim())));
        };
        let name = name.trim();
        let k = names.iter().position(|n| n == name).ok_or_else(|| {
            bad(format!("--gait: `{name}` is not a shape coordinate (they are {})", names.join(", ")))
        })?;
        if shape[k].is_some() {
            return Err(bad(format!("--gait: `{name}` is given twice")));
        }
        let mut reader = Reader { text: expr.as_bytes(), at: 0, depth: 0 };
        let value = reader
            .sum()
            .and_then(|v| if reader.peek().is_some() { reader.fail("text after the expression") } else { Ok(v) });
        let value = value.map_err(|e| bad(format!("--gait: {name} = `{}`: {e}", expr.trim())))?;
        if value.slope != 0.0 {
            return Err(bad(format!(
                "--gait: {name} = `{}` grows with t outside a cos or sin: the gait would not close",
                expr.trim()
            )));
        }
        let mut harmonics = vec![harmonic(value.constant, 0.0, 0.0)];
        harmonics.extend(value.harmonics);
        shape[k] = Some(Waveform::Harmonics(harmonics));
    }
    let mut out = Vec::new();
    for (k, w) in shape.into_iter().enumerate() {
        out.push(w.ok_or_else(|| bad(format!("--gait: shape coordinate `{}` is not given", names[k])))?);
    }
    Gait::from_text(out, 2.0 * std::f64::consts::PI, names)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_gait_is_read_into_harmonics() {
        let names = vec!["alpha1".to_string(), "alpha2".to_string()];
        let g = parse(&names, "alpha1=0.8+0.3*cos(t), alpha2 = -0.8 + 0.3*sin(t) - cos(2*t + pi/2)/4").unwrap();
        for t in [0.0, 0.7, 2.0, 5.5] {
            let (r, rd) = g.at(t);
            let want =
                [0.8 + 0.3 * t.cos(), -0.8 + 0.3 * t.sin() - (2.0 * t + std::f64::consts::FRAC_PI_2).cos() / 4.0];
            let rate = [-0.3 * t.sin(), 0.3 * t.cos() + (2.0 * t + std::f64::consts::FRAC_PI_2).sin() / 2.0];
            for k in 0..2 {
                assert!((r[k] - want[k]).abs() < 1e-15 && (rd[k] - rate[k]).abs() < 1e-15, "{t} {k}");
            }
        }
        for (text, says) in [
            ("alpha1=cos(t)", "`alpha2` is not given"),
            ("alpha1=cos(0.5*t),alpha2=0", "whole number"),
            ("alpha1=t,alpha2=0", "would not close"),
            ("alpha1=cos(t)*sin(t),alpha2=0", "product"),
            ("alpha1=1e300,alpha2=0", "up to 1e6"),
            ("alpha1=nan,alpha2=0", "`nan`"),
            ("beta=1,alpha2=0", "not a shape coordinate"),
            ("alpha1=0.9+0.3*cos(1000000*t),alpha2=0", "alpha1: its fastest harmonic, angular frequency"),
            ("alpha1=(1,alpha2=0", "missing `)`"),
        ] {
            let e = parse(&names, text).unwrap_err().to_string();
            assert!(e.contains(says), "{text}: {e}");
        }
        let deep = format!("alpha1={}1{},alpha2=0", "(".repeat(100), ")".repeat(100));
        assert!(parse(&names, &deep).unwrap_err().to_string().contains("nested too deep"));
    }
}
