//! A sweep's runs: the axes of parameter values and which values run
//! number `i` takes, computed from `i` alone (no list of runs is kept, so
//! a sweep of millions of runs takes no memory for its plan).

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// How an axis' values are given.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Values {
    /// Given values (`--list`, as listed).
    Fixed(Vec<f64>),
    /// `count` evenly spaced values from `start` to `stop`, both included
    /// (`--grid`): computed when asked ([`grid_value`]), never stored, so
    /// an axis of a billion values takes no memory.
    Grid {
        /// First value.
        start: f64,
        /// Last value.
        stop: f64,
        /// Number of values (from 1 to [`MAX_RUNS`]).
        count: u64,
    },
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
pub(crate) struct Axis {
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
pub(crate) struct Plan {
    /// The axes: fixed ones first, then the random ones.
    pub axes: Vec<Axis>,
    /// Random draws per point of the fixed axes (1 without random axes).
    pub samples: u64,
    /// Seed of the draws.
    pub seed: u64,
}

/// Most runs one sweep may have.
pub(crate) const MAX_RUNS: u64 = 1 << 40;

impl Values {
    /// Number of values of a fixed axis (`None` for a random one).
    pub(crate) fn count(&self) -> Option<u64> {
        match self {
            Self::Fixed(v) => Some(v.len() as u64),
            Self::Grid { count, .. } => Some(*count),
            Self::Random { .. } => None,
        }
    }

    /// Value `j` of a fixed axis (`j` below [`Values::count`]).
    ///
    /// # Panics
    /// For a random axis, or `j` out of range.
    pub(crate) fn get(&self, j: u64) -> f64 {
        match self {
            Self::Fixed(v) => v[usize::try_from(j).expect("an index of a stored list")],
            Self::Grid { start, stop, count } => grid_value(*start, *stop, *count, j),
            Self::Random { .. } => panic!("a random axis has no fixed values"),
        }
    }
}

/// `v` rounded to 15 significant digits (so that a decimal grid gives
/// its decimals: 0.45, not 0.44999999999999996), or `v` itself where the
/// rounding would overflow (next to `f64::MAX`).
fn decimal(v: f64) -> f64 {
    let r: f64 = format!("{v:.14e}").parse().unwrap_or(v);
    if r.is_finite() { r } else { v }
}

/// Value `k` of `n` evenly spaced values from `a` to `b` (finite), both
/// included: the end points as given, the rest by the same formula on
/// every machine, all rounded to 15 significant digits; finite whenever `a`
/// and `b` are (bounds whose difference overflows, such as -1e308 and
/// 1e308, are combined as `a (1 - s) + b s`).
pub(crate) fn grid_value(a: f64, b: f64, n: u64, k: u64) -> f64 {
    if k + 1 == n {
        return decimal(b);
    }
    let s = k as f64 / (n - 1).max(1) as f64;
    let d = b - a;
    decimal(if d.is_finite() { a + d * s } else { a * (1.0 - s) + b * s })
}

/// `u` in `[0, 1)` mapped onto `[lo, hi]` (finite): finite whenever the
/// bounds are, even where `hi - lo` overflows.
fn between(lo: f64, hi: f64, u: f64) -> f64 {
    let d = hi - lo;
    if d.is_finite() { lo + d * u } else { lo * (1.0 - u) + hi * u }
}

/// A whole number from 1 to 2^53, also written as a float (`1e9`).
fn whole(v: &str) -> Option<u64> {
    let x: f64 = v.trim().parse().ok()?;
    (x.is_finite() && x >= 1.0 && x.fract() == 0.0 && x <= 9_007_199_254_740_992.0).then_some(x as u64)
}

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
pub(crate) fn grid(text: &str) -> Result<Axis, String> {
    let (name, rest) = name_of(text, "NAME=START:STOP:COUNT")?;
    let parts: Vec<&str> = rest.split(':').collect();
    let [a, b, n] = parts[..] else { return Err(format!("`{text}`: expected NAME=START:STOP:COUNT")) };
    let (a, b) = (number(text, "START", a)?, number(text, "STOP", b)?);
    let count = n.trim();
    let n = whole(count).ok_or_else(|| format!("`{text}`: COUNT `{count}` must be a whole number >= 1"))?;
    if n == 1 && a != b {
        return Err(format!(
            "`{text}`: one value from {} to {}: give COUNT >= 2, or START = STOP",
            ezy_core::fmt_value(a),
            ezy_core::fmt_value(b)
        ));
    }
    // the count is checked before anything is built for it; the values
    // are computed run by run (`Values::Grid`)
    if n > MAX_RUNS {
        return Err(format!("`{text}`: COUNT {count} is more than {MAX_RUNS} (2^40), the most runs a sweep may have"));
    }
    Ok(Axis { name: name.into(), values: Values::Grid { start: a, stop: b, count: n } })
}

/// `NAME=V1,V2,...`.
///
/// # Errors
/// A malformed text or a value that is not a finite number.
pub(crate) fn list(text: &str) -> Result<Axis, String> {
    let (name, rest) = name_of(text, "NAME=V1,V2,...")?;
    let values = rest.split(',').map(|v| number(text, "value", v)).collect::<Result<Vec<_>, _>>()?;
    Ok(Axis { name: name.into(), values: Values::Fixed(values) })
}

/// `NAME=LO:HI`.
///
/// # Errors
/// A malformed text, or bounds that are not finite with LO < HI.
pub(crate) fn random(text: &str) -> Result<Axis, String> {
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
    pub(crate) fn new(mut axes: Vec<Axis>, samples: Option<u64>, seed: u64) -> Result<Self, String> {
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
        // the product of the axes' lengths, counted before any run
        let mut runs: u64 = plan.samples;
        for a in &plan.axes {
            if let Some(n) = a.values.count() {
                runs = runs.saturating_mul(n);
            }
        }
        if runs > MAX_RUNS {
            let lengths: Vec<String> =
                (plan.axes.iter().filter_map(|a| a.values.count().map(|n| format!("{} ({n})", a.name))))
                    .chain((random).then(|| format!("--samples ({})", plan.samples)))
                    .collect();
            return Err(format!(
                "the sweep has {} runs ({}), more than {MAX_RUNS} (2^40), the most a sweep may have",
                if runs == u64::MAX { "more than 2^64".to_string() } else { runs.to_string() },
                lengths.join(" x ")
            ));
        }
        Ok(plan)
    }

    /// Number of runs.
    pub(crate) fn runs(&self) -> u64 {
        self.axes.iter().filter_map(|a| a.values.count()).product::<u64>() * self.samples
    }

    /// The axes' names, in column order.
    pub(crate) fn names(&self) -> Vec<String> {
        self.axes.iter().map(|a| a.name.clone()).collect()
    }

    /// The parameter values of run `i` (in the order of the axes), pushed
    /// onto `out` after clearing it. Run `i` takes random draw `i mod
    /// samples`, the ChaCha8 stream of that number from the seed: every
    /// point of the fixed axes sees the same draws (common random
    /// numbers), and a draw depends on its number and the seed alone (not
    /// on the shard or the order of the runs).
    pub(crate) fn values_into(&self, i: u64, out: &mut Vec<f64>) {
        // the fixed axes come first (`Plan::new` sorts them), the last
        // varying fastest
        let fixed = self.axes.iter().take_while(|a| a.values.count().is_some()).count();
        out.clear();
        out.resize(fixed, 0.0);
        let mut rest = i / self.samples;
        for k in (0..fixed).rev() {
            let values = &self.axes[k].values;
            let n = values.count().expect("a fixed axis");
            out[k] = values.get(rest % n);
            rest /= n;
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
                out.push(between(lo, hi, u));
            }
        }
    }

    /// The values of run `i`.
    pub(crate) fn values(&self, i: u64) -> Vec<f64> {
        let mut v = Vec::new();
        self.values_into(i, &mut v);
        v
    }

    /// Number of values of axis `k` (`None` for a random one).
    pub(crate) fn fixed_len(&self, k: usize) -> Option<u64> {
        self.axes[k].values.count()
    }

    /// The values of the fixed axis `k` (`None` for a random one), as an
    /// iterator: a grid's are computed one by one.
    pub(crate) fn fixed_iter(&self, k: usize) -> Option<impl Iterator<Item = f64> + '_> {
        let values = &self.axes[k].values;
        values.count().map(|n| (0..n).map(move |j| values.get(j)))
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
        assert_eq!(grid("a=2:2:1").unwrap().values.get(0), 2.0);
        let v = grid("a=0.05:0.5:10").unwrap().values;
        assert_eq!(v.get(8), 0.45);
        assert_eq!(v.get(2), 0.15);
        assert_eq!(v.get(9), 0.5);
        // an axis of 2^40 values is not built, and finite bounds give
        // finite values even where their difference overflows
        let huge = grid("a=-1e308:1e308:1099511627776").unwrap().values;
        assert_eq!(huge.count(), Some(1 << 40));
        assert_eq!((huge.get(0), huge.get((1 << 40) - 1)), (-1e308, 1e308));
        assert!((0..1000).all(|k| huge.get(k * 1_000_000_007).is_finite()));
        assert!(grid("a=0:1:1099511627777").unwrap_err().contains("more than 1099511627776"));
        assert_eq!(grid("a=0:1:1e3").unwrap().values.count(), Some(1000));
        let wide = Plan::new(vec![random("w=-1.7e308:1.7e308").unwrap()], Some(50), 3).unwrap();
        assert!((0..50).all(|i| wide.values(i)[0].is_finite()));
    }
}
