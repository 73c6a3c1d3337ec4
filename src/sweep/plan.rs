//! A sweep's runs: the axes of parameter values and which values run
//! number `i` takes, computed from `i` alone (no list of runs is kept, so
//! a sweep of millions of runs takes no memory for its plan).

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// How an axis' values are given.
#[derive(Debug, Clone, PartialEq)]
pub enum Values {
    /// Given values (`--grid` evenly spaced, `--list` as listed).
    Fixed(Vec<f64>),
    /// Uniform in `[lo, hi]` (`--random`).
    Random {
        /// Lower bound.
        lo: f64,
        /// Upper bound.
        hi: f64,
    },
}

/// One swept parameter.
#[derive(Debug, Clone, PartialEq)]
pub struct Axis {
    /// The name `--set` takes (a model or scene parameter, a family count,
    /// `EFFECT.KEY`).
    pub name: String,
    /// Its values.
    pub values: Values,
}

/// The runs of a sweep: the product of the fixed axes (the first varies
/// slowest) and, for each of their points, `samples` draws of the random
/// axes.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    /// The axes: fixed ones first, then the random ones.
    pub axes: Vec<Axis>,
    /// Random draws per point of the fixed axes (1 without random axes).
    pub samples: u64,
    /// Seed of the draws.
    pub seed: u64,
}

/// Most runs one sweep may have.
pub const MAX_RUNS: u64 = 1 << 40;

fn number(text: &str, what: &str, v: &str) -> Result<f64, String> {
    match v.trim().parse::<f64>() {
        Ok(x) if x.is_finite() => Ok(x),
        _ => Err(format!("`{text}`: {what} `{}` is not a finite number", v.trim())),
    }
}

fn name_of<'a>(text: &'a str, form: &str) -> Result<(&'a str, &'a str), String> {
    let (name, rest) = text.split_once('=').ok_or_else(|| format!("`{text}`: expected {form}"))?;
    let name = name.trim();
    if name.is_empty() {
        return Err(format!("`{text}`: no parameter name before `=`"));
    }
    Ok((name, rest))
}

/// `NAME=START:STOP:COUNT`: COUNT evenly spaced values from START to STOP.
///
/// # Errors
/// A malformed text, a bound that is not finite, a COUNT that is not a
/// whole number >= 1 (or 1 with START != STOP).
pub fn grid(text: &str) -> Result<Axis, String> {
    let (name, rest) = name_of(text, "NAME=START:STOP:COUNT")?;
    let parts: Vec<&str> = rest.split(':').collect();
    let [a, b, n] = parts[..] else { return Err(format!("`{text}`: expected NAME=START:STOP:COUNT")) };
    let (a, b) = (number(text, "START", a)?, number(text, "STOP", b)?);
    let n: u64 = n
        .trim()
        .parse()
        .ok()
        .filter(|&n| n >= 1)
        .ok_or_else(|| format!("`{text}`: COUNT `{}` must be a whole number >= 1", n.trim()))?;
    if n == 1 && a != b {
        return Err(format!("`{text}`: one value from {a} to {b}: give COUNT >= 2, or START = STOP"));
    }
    if n > MAX_RUNS {
        return Err(format!("`{text}`: COUNT {n} is more than {MAX_RUNS} runs"));
    }
    // the end points exactly, the rest by the same formula on every machine,
    // rounded to 15 significant digits so that a decimal grid gives its
    // decimals (0.45, not 0.44999999999999996)
    let values = (0..n)
        .map(|k| if k + 1 == n { b } else { a + (b - a) * (k as f64 / (n - 1).max(1) as f64) })
        .map(|v| format!("{v:.14e}").parse::<f64>().expect("a formatted number parses"))
        .collect();
    Ok(Axis { name: name.into(), values: Values::Fixed(values) })
}

/// `NAME=V1,V2,...`.
///
/// # Errors
/// A malformed text or a value that is not a finite number.
pub fn list(text: &str) -> Result<Axis, String> {
    let (name, rest) = name_of(text, "NAME=V1,V2,...")?;
    let values = rest.split(',').map(|v| number(text, "value", v)).collect::<Result<Vec<_>, _>>()?;
    Ok(Axis { name: name.into(), values: Values::Fixed(values) })
}

/// `NAME=LO:HI`.
///
/// # Errors
/// A malformed text, or bounds that are not finite with LO < HI.
pub fn random(text: &str) -> Result<Axis, String> {
    let (name, rest) = name_of(text, "NAME=LO:HI")?;
    let (lo, hi) = rest.split_once(':').ok_or_else(|| format!("`{text}`: expected NAME=LO:HI"))?;
    let (lo, hi) = (number(text, "LO", lo)?, number(text, "HI", hi)?);
    if lo >= hi {
        return Err(format!("`{text}`: LO must be below HI"));
    }
    Ok(Axis { name: name.into(), values: Values::Random { lo, hi } })
}

impl Plan {
    /// The plan of `axes` (fixed first, then random), checking that no
    /// name is given twice and that the sweep is not empty or too large.
    ///
    /// # Errors
    /// A name given twice, random axes without `samples` (or `samples`
    /// without random axes), more than [`MAX_RUNS`] runs.
    pub fn new(mut axes: Vec<Axis>, samples: Option<u64>, seed: u64) -> Result<Self, String> {
        if axes.is_empty() {
            return Err("no axis: give at least one --grid, --list or --random".into());
        }
        for (k, a) in axes.iter().enumerate() {
            if axes[..k].iter().any(|b| b.name == a.name) {
                return Err(format!("`{}` is swept twice", a.name));
            }
        }
        axes.sort_by_key(|a| matches!(a.values, Values::Random { .. }));
        let random = axes.iter().any(|a| matches!(a.values, Values::Random { .. }));
        let samples = match (random, samples) {
            (true, Some(n)) => n,
            (true, None) => return Err("--random needs --samples N (the number of draws)".into()),
            (false, Some(_)) => return Err("--samples is for --random axes; this sweep has none".into()),
            (false, None) => 1,
        };
        let plan = Self { axes, samples, seed };
        let mut runs: u64 = plan.samples;
        for a in &plan.axes {
            if let Values::Fixed(v) = &a.values {
                runs = runs.saturating_mul(v.len() as u64);
            }
        }
        if runs > MAX_RUNS {
            return Err(format!("the sweep has {runs} runs, more than {MAX_RUNS}"));
        }
        Ok(plan)
    }

    /// Number of runs.
    pub fn runs(&self) -> u64 {
        (0..self.axes.len()).filter_map(|k| self.fixed_values(k)).map(|v| v.len() as u64).product::<u64>()
            * self.samples
    }

    /// The axes' names, in column order.
    pub fn names(&self) -> Vec<String> {
        self.axes.iter().map(|a| a.name.clone()).collect()
    }

    /// The parameter values of run `i` (in the order of the axes), pushed
    /// onto `out` after clearing it. Run `i` takes random draw `i mod
    /// samples`, the ChaCha8 stream of that number from the seed: every
    /// point of the fixed axes sees the same draws (common random
    /// numbers), and a draw depends on its number and the seed alone (not
    /// on the shard or the order of the runs).
    pub fn values_into(&self, i: u64, out: &mut Vec<f64>) {
        // the fixed axes come first (`Plan::new` sorts them), the last
        // varying fastest
        let fixed = self.axes.iter().take_while(|a| matches!(a.values, Values::Fixed(_))).count();
        out.clear();
        out.resize(fixed, 0.0);
        let mut rest = i / self.samples;
        for k in (0..fixed).rev() {
            let v = self.fixed_values(k).expect("a fixed axis");
            out[k] = v[(rest % v.len() as u64) as usize];
            rest /= v.len() as u64;
        }
        let mut rng: Option<ChaCha8Rng> = None;
        for a in &self.axes {
            if let Values::Random { lo, hi } = a.values {
                let rng = rng.get_or_insert_with(|| {
                    let mut r = ChaCha8Rng::seed_from_u64(self.seed);
                    r.set_stream(i % self.samples);
                    r
                });
                let u: f64 = rng.random();
                out.push(lo + (hi - lo) * u);
            }
        }
    }

    /// The values of run `i`.
    pub fn values(&self, i: u64) -> Vec<f64> {
        let mut v = Vec::new();
        self.values_into(i, &mut v);
        v
    }

    /// The distinct values of the fixed axis `k` (`None` for a random one).
    pub fn fixed_values(&self, k: usize) -> Option<&[f64]> {
        match &self.axes[k].values {
            Values::Fixed(v) => Some(v),
            Values::Random { .. } => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn product_order_and_draws() {
        let plan = Plan::new(vec![grid("a=0:1:3").unwrap(), list("b=5,6").unwrap()], None, 1).unwrap();
        assert_eq!(plan.runs(), 6);
        let all: Vec<Vec<f64>> = (0..6).map(|i| plan.values(i)).collect();
        assert_eq!(all, [[0.0, 5.0], [0.0, 6.0], [0.5, 5.0], [0.5, 6.0], [1.0, 5.0], [1.0, 6.0]]);
        let plan = Plan::new(vec![random("w=1:2").unwrap(), list("b=5,6").unwrap()], Some(10), 7).unwrap();
        assert_eq!(plan.names(), ["b", "w"]);
        assert_eq!(plan.runs(), 20);
        let v = plan.values(13);
        assert_eq!(v[0], 6.0);
        assert!((1.0..=2.0).contains(&v[1]));
        // the same draw whatever else was drawn before
        assert_eq!(plan.values(13), v);
        assert_ne!(plan.values(12)[1], v[1]);
        assert_ne!(Plan::new(plan.axes.clone(), Some(10), 8).unwrap().values(13)[1], v[1]);
    }

    #[test]
    fn refuses() {
        for bad in ["a=0:1", "a=0:1:0", "a=0:1:1", "=0:1:2", "a=0:x:2", "a=0:inf:2"] {
            assert!(grid(bad).is_err(), "{bad}");
        }
        assert!(list("a=1,,2").is_err());
        assert!(random("a=2:1").is_err());
        assert!(Plan::new(vec![list("a=1").unwrap(), list("a=2").unwrap()], None, 1).is_err());
        assert!(Plan::new(vec![random("a=1:2").unwrap()], None, 1).is_err());
        assert!(Plan::new(vec![list("a=1").unwrap()], Some(3), 1).is_err());
        assert!(Plan::new(vec![grid("a=0:1:2000000").unwrap(), grid("b=0:1:2000000").unwrap()], None, 1).is_err());
        assert_eq!(grid("a=2:2:1").unwrap().values, Values::Fixed(vec![2.0]));
        let Values::Fixed(v) = grid("a=0.05:0.5:10").unwrap().values else { unreachable!() };
        assert_eq!(v[8], 0.45);
        assert_eq!(v[2], 0.15);
    }
}
