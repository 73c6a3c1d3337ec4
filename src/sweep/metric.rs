//! A sweep's metrics: one number per run, a column of the trajectory (or a
//! figure's column function of columns) reduced over a time window, as the
//! run goes (no table is kept).

use ezy_scene::Column;

/// The gait's quantities a metric may name (`gait.NAME`, [`super::gait`]): the orbit's own
/// ([`ezy_core::analysis::PeriodicOrbit::VALUE_NAMES`]), then the actuators' mean power \[W\]
/// and the efficiency \[m/J\] (which take one more period's integral).
pub(crate) const GAIT_NAMES: [&str; 12] = [
    "period",
    "mean_speed",
    "mean_forward_speed",
    "dx",
    "dy",
    "dheading",
    "mean_abs_speed",
    "drift_speed",
    "dx_world",
    "dy_world",
    "mean_power",
    "efficiency",
];

/// How a metric reduces its column over the window.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Reduce {
    /// The time average `1/(t1 - t0) ∫ v dt` by the trapezoidal rule over
    /// the output rows in the window.
    Mean,
    /// The largest value.
    Max,
    /// The smallest value.
    Min,
    /// The value at the last output row in the window.
    Final,
    /// The time of an event's first occurrence \[s\] (`event_time(NAME)`,
    /// from the run's events, not its rows).
    EventTime,
    /// How often an event happened (`event_count(NAME)`).
    EventCount,
    /// A quantity of the gait the run settles onto (`gait.NAME`, the
    /// name `periodic.csv` gives it): the periodic orbit is sought from
    /// the run's end, as `ezy analyze` seeks it ([`super::gait`]).
    Gait,
}

impl Reduce {
    fn name(self) -> &'static str {
        match self {
            Self::Mean => "mean",
            Self::Max => "max",
            Self::Min => "min",
            Self::Final => "final",
            Self::EventTime => "event_time",
            Self::EventCount => "event_count",
            Self::Gait => "gait",
        }
    }
}

/// `mean(norm(x1d, y1d), 50, 60)`: a reduction of a column expression
/// over the output rows with `t0 <= t <= t1` \[s\].
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Metric {
    /// The text as given (trimmed): the metric's column in `sweep.csv`.
    pub text: String,
    /// The reduction.
    pub reduce: Reduce,
    /// The column expression (the syntax of a figure's `y`).
    pub column: Column,
    /// Window start \[s\] (`None`: the start of the run).
    pub t0: Option<f64>,
    /// Window end \[s\] (`None`: the end of the run).
    pub t1: Option<f64>,
    /// The event an `event_time` or `event_count` metric reads (its
    /// `column` is then the time, read by nothing).
    pub event: Option<String>,
    /// The gait's quantity a `gait.NAME` metric reads (its `column` is
    /// then the time, read by nothing).
    pub gait: Option<String>,
}

impl std::str::FromStr for Metric {
    type Err = String;

    /// `FUNC(COLUMN)` or `FUNC(COLUMN, T0, T1)` with FUNC one of `mean`,
    /// `max`, `min`, `final` and COLUMN a column name or a column function
    /// (`norm(a, b)`, `diff(a, b)`, `from_start(a)`, `balance_gap(a, b)`);
    /// or `event_time(EVENT)`, `event_count(EVENT)` of an event of the
    /// scene.
    fn from_str(s: &str) -> Result<Self, String> {
        let text = s.trim();
        if let Some(name) = text.strip_prefix("gait.") {
            if !GAIT_NAMES.contains(&name) {
                return Err(format!(
                    "metric `{text}`: a gait has no quantity `{name}`; its quantities: {}",
                    GAIT_NAMES.map(|n| format!("gait.{n}")).join(", ")
                ));
            }
            let column = Column::Named("t".into());
            let reduce = Reduce::Gait;
            return Ok(Self {
                text: text.into(),
                reduce,
                column,
                t0: None,
                t1: None,
                event: None,
                gait: Some(name.into()),
            });
        }
        let usage = || {
            format!(
                "metric `{text}`: expected FUNC(COLUMN) or FUNC(COLUMN, T0, T1) with FUNC mean, max, min or final, e.g. `mean(norm(x1d, y1d), 50, 60)`"
            )
        };
        if let Some(why) = ezy_scene::unbalanced_parentheses(text) {
            return Err(format!("metric `{text}`: {why}"));
        }
        let open = text.find('(').ok_or_else(usage)?;
        let inner = text[open + 1..].strip_suffix(')').ok_or_else(usage)?;
        let event = match text[..open].trim() {
            "event_time" => Some(Reduce::EventTime),
            "event_count" => Some(Reduce::EventCount),
            _ => None,
        };
        if let Some(reduce) = event {
            let name = inner.trim();
            ezy_core::events::check_event_name(name).map_err(|e| format!("metric `{text}`: {e}"))?;
            let column = Column::Named("t".into());
            let event = Some(name.into());
            return Ok(Self { text: text.to_string(), reduce, column, t0: None, t1: None, event, gait: None });
        }
        let reduce = match text[..open].trim() {
            "mean" => Reduce::Mean,
            "max" => Reduce::Max,
            "min" => Reduce::Min,
            "final" => Reduce::Final,
            other => {
                return Err(format!(
                    "metric `{text}`: unknown function `{other}`; known: mean, max, min, final, event_time, event_count"
                ));
            }
        };
        let args = ezy_scene::split_outside_parentheses(inner);
        let column: Column = args[0].parse().map_err(|e| format!("metric `{text}`: {e}"))?;
        let time = |a: &str| -> Result<f64, String> {
            match a.trim().parse::<f64>() {
                Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
                _ => Err(format!("metric `{text}`: the window bound `{}` is not a time >= 0 [s]", a.trim())),
            }
        };
        let (t0, t1) = match args.len() {
            1 => (None, None),
            3 => (Some(time(args[1])?), Some(time(args[2])?)),
            n => return Err(format!("metric `{text}`: {n} arguments; give a column, or a column and a window T0, T1")),
        };
        if let (Some(a), Some(b)) = (t0, t1)
            && a >= b
        {
            return Err(format!(
                "metric `{text}`: the window [{}, {}] s is empty (T0 must be below T1)",
                ezy_core::fmt_value(a),
                ezy_core::fmt_value(b)
            ));
        }
        Ok(Self { text: text.to_string(), reduce, column, t0, t1, event: None, gait: None })
    }
}

impl Metric {
    /// Checks that an event metric names an event of the scene, whose
    /// events are `events`.
    ///
    /// # Errors
    /// The metric and the scene's events.
    pub(crate) fn check_event(&self, events: &[&str]) -> Result<(), String> {
        match &self.event {
            Some(name) if !events.contains(&name.as_str()) => Err(format!(
                "metric `{}`: the scene has no event `{name}`; its events: {}",
                self.text,
                if events.is_empty() { "none ([events.NAME] tables)".to_string() } else { events.join(", ") }
            )),
            _ => Ok(()),
        }
    }

    /// The value of an event metric from the run's events (`None` for a
    /// metric of the rows).
    ///
    /// # Errors
    /// `event_time` of an event that did not happen.
    pub(crate) fn event_value(&self, events: &[ezy_core::EventRecord]) -> Option<Result<f64, String>> {
        let name = self.event.as_deref()?;
        let mut of = events.iter().filter(|e| e.name == name);
        Some(match self.reduce {
            Reduce::EventCount => Ok(of.count() as f64),
            _ => of
                .next()
                .map(|e| e.t)
                .ok_or_else(|| format!("metric `{}`: the event `{name}` did not happen in the run", self.text)),
        })
    }

    /// Checks the window against a run of `t_end` \[s\] with output every
    /// `every` \[s\]: it must lie in the run and hold two output rows.
    ///
    /// # Errors
    /// The metric, the window and why it does not fit.
    pub(crate) fn check_window(&self, t_end: f64, every: f64) -> Result<(), String> {
        let (t0, t1) = (self.t0.unwrap_or(0.0), self.t1.unwrap_or(t_end));
        if t1 > t_end * (1.0 + 1e-12) {
            return Err(format!(
                "metric `{}`: the window ends at {} s, after the run's end at {} s",
                self.text,
                ezy_core::fmt_value(t1),
                ezy_core::fmt_value(t_end)
            ));
        }
        if self.t0.is_some() && t1 - t0 < every {
            return Err(format!(
                "metric `{}`: the window [{}, {}] s is shorter than the output interval {} s, so it may hold no output row; widen it or give a smaller --every",
                self.text,
                ezy_core::fmt_value(t0),
                ezy_core::fmt_value(t1),
                ezy_core::fmt_value(every)
            ));
        }
        Ok(())
    }

    /// The columns it reads, checked against the trajectory's `columns`.
    ///
    /// # Errors
    /// The first column the trajectory lacks, with a hint of how to get it.
    pub(crate) fn check_columns(&self, columns: &[String]) -> Result<(), String> {
        for c in self.column.inputs() {
            if !columns.iter().any(|k| k == c) {
                let hint = if c == "T" || c == "W" || c.starts_with("W_") {
                    " (energy columns need `energy` in the scene's output.include)"
                } else if c.starts_with("res_") {
                    " (residuals need `residuals` in the scene's output.include)"
                } else {
                    ""
                };
                return Err(format!(
                    "metric `{}`: the trajectory has no column `{c}`{hint}; its columns: {}",
                    self.text,
                    columns.join(", ")
                ));
            }
        }
        Ok(())
    }
}

/// A metric being reduced over a run's rows.
#[derive(Debug, Clone)]
pub(crate) struct Accumulator {
    reduce: Reduce,
    inputs: [usize; 2],
    kind: Kind,
    t0: f64,
    t1: f64,
    /// First value of the input column (`from_start`, `balance_gap`).
    first: Option<f64>,
    /// The previous row in the window: `(t, v)`.
    last: Option<(f64, f64)>,
    /// Integral (mean), extreme (max, min).
    acc: f64,
    /// First row's time in the window.
    start: f64,
}

#[derive(Debug, Clone, Copy)]
enum Kind {
    Named,
    Norm,
    Diff,
    FromStart,
    BalanceGap,
}

impl Accumulator {
    /// Reduces `m` over rows with the layout `columns` (checked with
    /// [`Metric::check_columns`]).
    ///
    /// # Errors
    /// A column the layout lacks.
    pub(crate) fn new(m: &Metric, columns: &[String]) -> Result<Self, String> {
        m.check_columns(columns)?;
        let at = |c: &str| columns.iter().position(|k| k == c).expect("checked");
        let ins = m.column.inputs();
        let inputs = [at(ins[0]), at(ins.get(1).copied().unwrap_or(ins[0]))];
        let kind = match m.column {
            Column::Named(_) => Kind::Named,
            Column::Norm(..) => Kind::Norm,
            Column::Diff(..) => Kind::Diff,
            Column::FromStart(_) => Kind::FromStart,
            Column::BalanceGap(..) => Kind::BalanceGap,
        };
        let acc = match m.reduce {
            Reduce::Max => f64::NEG_INFINITY,
            Reduce::Min => f64::INFINITY,
            _ => 0.0,
        };
        Ok(Self {
            reduce: m.reduce,
            inputs,
            kind,
            t0: m.t0.unwrap_or(f64::NEG_INFINITY),
            t1: m.t1.unwrap_or(f64::INFINITY),
            first: None,
            last: None,
            acc,
            start: 0.0,
        })
    }

    /// Whether the output row at `t` \[s\] can change the value, on an
    /// output grid of `every` \[s\]: a row in the window; for `final`,
    /// only the window's last row (the run's last one without a window);
    /// for the event metrics, none. (`from_start` and `balance_gap` also
    /// read the run's first row, which a run always outputs.)
    pub(crate) fn reads(&self, t: f64, every: f64) -> bool {
        match self.reduce {
            Reduce::EventTime | Reduce::EventCount | Reduce::Gait => false,
            Reduce::Final => t <= self.t1 && t >= self.t0 && t > self.final_after(every),
            Reduce::Mean | Reduce::Max | Reduce::Min => t >= self.t0 && t <= self.t1,
        }
    }

    /// `final`'s rows lie after this time \[s\]: the last grid row at or
    /// before `t1` lies within one interval `every` of it (a margin of
    /// half an interval for rounding).
    fn final_after(&self, every: f64) -> f64 {
        self.t1 - 1.5 * every
    }

    /// The earliest time at or after `t` \[s\] whose row
    /// [`Accumulator::reads`] may read (on the same grid; infinite if
    /// none): never later than the first such row.
    pub(crate) fn next_read(&self, t: f64, every: f64) -> f64 {
        let start = match self.reduce {
            Reduce::EventTime | Reduce::EventCount | Reduce::Gait => return f64::INFINITY,
            Reduce::Final => self.t0.max(self.final_after(every)),
            Reduce::Mean | Reduce::Max | Reduce::Min => self.t0,
        };
        if t > self.t1 { f64::INFINITY } else { t.max(start) }
    }

    /// Takes one output row (`row[0]` is the time \[s\]).
    pub(crate) fn push(&mut self, row: &[f64]) {
        let (a, b) = (row[self.inputs[0]], row[self.inputs[1]]);
        let a0 = *self.first.get_or_insert(a);
        let t = row[0];
        if t < self.t0 || t > self.t1 {
            return;
        }
        let v = match self.kind {
            Kind::Named => a,
            Kind::Norm => a.hypot(b),
            Kind::Diff => a - b,
            Kind::FromStart => a - a0,
            Kind::BalanceGap => (a - a0 - b).abs(),
        };
        match self.reduce {
            Reduce::Mean => match self.last {
                Some((tp, vp)) => self.acc += 0.5 * (t - tp) * (v + vp),
                None => self.start = t,
            },
            Reduce::Max => self.acc = self.acc.max(v),
            Reduce::Min => self.acc = self.acc.min(v),
            Reduce::Final => self.acc = v,
            // read from the run's events ([`Metric::event_value`]) or
            // its gait ([`super::gait`])
            Reduce::EventTime | Reduce::EventCount | Reduce::Gait => {}
        }
        self.last = Some((t, v));
    }

    /// The metric's value.
    ///
    /// # Errors
    /// No row fell in the window, or the value is not finite.
    pub(crate) fn value(&self, m: &Metric) -> Result<f64, String> {
        let Some((t, v)) = self.last else {
            return Err(format!("metric `{}`: no output row in its window", m.text));
        };
        let value = match self.reduce {
            Reduce::Mean if t > self.start => self.acc / (t - self.start),
            Reduce::Mean => v,
            _ => self.acc,
        };
        if value.is_finite() {
            Ok(value)
        } else {
            Err(format!("metric `{}` is {value} ({} of a value that is not finite)", m.text, self.reduce.name()))
        }
    }
}

impl Metric {
    /// The metric of a run's samples and its gradient with respect to
    /// the run's parameters, from the run's state and sensitivities `s`
    /// (its rows: the samples; its columns: the coordinates and
    /// velocities). The reductions differentiated sample by sample: a
    /// mean's trapezoidal sum term by term, a `max` or `min` at the sample
    /// that attains it (the first), `final` at the window's last sample;
    /// `norm`, `diff`, `from_start` and `balance_gap` by the chain rule.
    ///
    /// # Errors
    /// A column that is not a state column (the sensitivities give
    /// those alone), an event metric, no sample in the window, a value
    /// that is not finite.
    pub(crate) fn with_gradient(&self, s: &ezy_core::sensitivity::Sensitivities) -> Result<(f64, Vec<f64>), String> {
        if self.event.is_some() {
            return Err(format!(
                "metric `{}`: an event's time or count is not differentiated (a run with sensitivities has no events)",
                self.text
            ));
        }
        if self.gait.is_some() {
            return Err(format!(
                "metric `{}`: a gait's quantity is not a function of one run; optimize it as a gait's quantity (the objective `{}` itself)",
                self.text, self.text
            ));
        }
        let at = |c: &str| {
            s.names.iter().position(|n| n == c).ok_or_else(|| {
                format!(
                    "metric `{}`: `{c}` is not a coordinate or velocity of the model; a run's derivatives are those of its state ({})",
                    self.text,
                    s.names.join(", ")
                )
            })
        };
        let ins = self.column.inputs();
        let (a, b) = (at(ins[0])?, at(ins.get(1).copied().unwrap_or(ins[0]))?);
        let (np, n2) = (s.parameters.len(), s.names.len());
        let d = |row: usize, k: usize, j: usize| s.s[row][j * n2 + k];
        let (t0, t1) = (self.t0.unwrap_or(f64::NEG_INFINITY), self.t1.unwrap_or(f64::INFINITY));
        // (t, v, dv/dp) at each sample in the window
        let mut rows: Vec<(f64, f64, Vec<f64>)> = Vec::new();
        for (i, &t) in s.t.iter().enumerate() {
            if t < t0 || t > t1 {
                continue;
            }
            let (xa, xb, xa0) = (s.x[i][a], s.x[i][b], s.x[0][a]);
            let (v, dv): (f64, Vec<f64>) = match self.column {
                Column::Named(_) => (xa, (0..np).map(|j| d(i, a, j)).collect()),
                Column::Norm(..) => {
                    let r = xa.hypot(xb);
                    let dr = |j| if r > 0.0 { (xa * d(i, a, j) + xb * d(i, b, j)) / r } else { 0.0 };
                    (r, (0..np).map(dr).collect())
                }
                Column::Diff(..) => (xa - xb, (0..np).map(|j| d(i, a, j) - d(i, b, j)).collect()),
                Column::FromStart(_) => (xa - xa0, (0..np).map(|j| d(i, a, j) - d(0, a, j)).collect()),
                Column::BalanceGap(..) => {
                    let g = xa - xa0 - xb;
                    (g.abs(), (0..np).map(|j| g.signum() * (d(i, a, j) - d(0, a, j) - d(i, b, j))).collect())
                }
            };
            rows.push((t, v, dv));
        }
        let Some(last) = rows.last() else {
            return Err(format!("metric `{}`: no sample in its window", self.text));
        };
        let (value, grad) = match self.reduce {
            Reduce::Final => (last.1, last.2.clone()),
            Reduce::Max | Reduce::Min => {
                let better = |x: f64, y: f64| if self.reduce == Reduce::Max { x > y } else { x < y };
                let best = rows.iter().fold(&rows[0], |m, r| if better(r.1, m.1) { r } else { m });
                (best.1, best.2.clone())
            }
            Reduce::Mean if rows.len() > 1 => {
                let span = last.0 - rows[0].0;
                let (mut v, mut g) = (0.0, vec![0.0; np]);
                for w in rows.windows(2) {
                    let h = 0.5 * (w[1].0 - w[0].0) / span;
                    v += h * (w[0].1 + w[1].1);
                    for (j, gj) in g.iter_mut().enumerate() {
                        *gj += h * (w[0].2[j] + w[1].2[j]);
                    }
                }
                (v, g)
            }
            Reduce::Mean => (last.1, last.2.clone()),
            Reduce::EventTime | Reduce::EventCount | Reduce::Gait => unreachable!("refused above"),
        };
        if !value.is_finite() || grad.iter().any(|g| !g.is_finite()) {
            return Err(format!("metric `{}` or its gradient is not finite ({value})", self.text));
        }
        Ok((value, grad))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cols() -> Vec<String> {
        ["t", "x", "y"].iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn parses_and_reduces() {
        let m: Metric = "mean(norm(x, y), 1, 3)".parse().unwrap();
        assert_eq!(m.reduce, Reduce::Mean);
        assert_eq!((m.t0, m.t1), (Some(1.0), Some(3.0)));
        let mut acc = Accumulator::new(&m, &cols()).unwrap();
        // |(x, y)| = t on [1, 3]: mean 2; the row at t = 0 is outside
        for t in 0..=4 {
            let t = f64::from(t);
            acc.push(&[t, 0.6 * t, 0.8 * t]);
        }
        assert!((acc.value(&m).unwrap() - 2.0).abs() < 1e-15);
        let m: Metric = "final(from_start(x))".parse().unwrap();
        let mut acc = Accumulator::new(&m, &cols()).unwrap();
        for (t, x) in [(0.0, 5.0), (1.0, 7.0), (2.0, 6.5)] {
            acc.push(&[t, x, 0.0]);
        }
        assert_eq!(acc.value(&m).unwrap(), 1.5);
        for (text, v) in [("max(x)", 7.0), ("min(x)", 5.0)] {
            let m: Metric = text.parse().unwrap();
            let mut acc = Accumulator::new(&m, &cols()).unwrap();
            for (t, x) in [(0.0, 5.0), (1.0, 7.0), (2.0, 6.5)] {
                acc.push(&[t, x, 0.0]);
            }
            assert_eq!(acc.value(&m).unwrap(), v, "{text}");
        }
    }

    #[test]
    fn reads_only_its_window() {
        let reads = |text: &str, t: f64| Accumulator::new(&text.parse().unwrap(), &cols()).unwrap().reads(t, 0.01);
        // the run's last row is observed whatever the observer wants
        assert!(!reads("final(x)", 59.0) && !reads("final(x)", 60.0));
        assert!(reads("final(x, 1, 2)", 2.0) && reads("final(x, 1, 2)", 1.995) && !reads("final(x, 1, 2)", 1.98));
        assert!(!reads("final(x, 1, 2)", 2.01));
        assert!(reads("mean(x, 1, 2)", 1.0) && reads("mean(x, 1, 2)", 2.0) && !reads("mean(x, 1, 2)", 0.99));
        assert!(reads("max(x)", 0.0) && reads("min(x)", 1e9));
        assert!(!reads("max(x, 3, 4)", 2.0));
    }

    #[test]
    fn next_read_is_never_late() {
        // on a grid of 0.01 s from 0 to 5 s, the first row at or after
        // each time that the metric reads is at or after `next_read`
        for text in ["final(x)", "final(x, 1, 2)", "mean(x, 1, 2)", "max(x)", "min(x, 3, 4)"] {
            let acc = Accumulator::new(&text.parse().unwrap(), &cols()).unwrap();
            let grid: Vec<f64> = (0..=500).map(|k| f64::from(k) * 0.01).collect();
            for (i, &t) in grid.iter().enumerate() {
                let next = acc.next_read(t, 0.01);
                assert!(next >= t, "{text} at {t}: {next}");
                if let Some(&first) = grid[i..].iter().find(|&&u| acc.reads(u, 0.01)) {
                    assert!(next <= first, "{text} at {t}: next_read {next} after the row {first} it reads");
                }
            }
        }
        let reads = |text: &str, t: f64| Accumulator::new(&text.parse().unwrap(), &cols()).unwrap().next_read(t, 0.01);
        // final(x, 1, 2) skips to just before its last row; a window past
        // its end reads nothing more
        assert!((reads("final(x, 1, 2)", 0.0) - 1.985).abs() < 1e-12);
        assert_eq!(reads("mean(x, 1, 2)", 2.5), f64::INFINITY);
    }

    #[test]
    fn refuses_bad_metrics() {
        for bad in ["mean", "avg(x)", "mean(x, 1)", "mean(x, 3, 1)", "mean(x, -1, 2)", "max(norm(x))", "mean(x"] {
            assert!(bad.parse::<Metric>().is_err(), "{bad}");
        }
        let m: Metric = "max(z)".parse().unwrap();
        assert!(Accumulator::new(&m, &cols()).unwrap_err().contains("no column `z`"));
        let m: Metric = "mean(x, 50, 70)".parse().unwrap();
        assert!(m.check_window(60.0, 0.01).unwrap_err().contains("after the run's end"));
        let m: Metric = "mean(x, 50, 50.001)".parse().unwrap();
        assert!(m.check_window(60.0, 0.01).is_err());
        // no row in the window: an error, never NaN
        let m: Metric = "mean(x, 1, 2)".parse().unwrap();
        let acc = Accumulator::new(&m, &cols()).unwrap();
        assert!(acc.value(&m).is_err());
    }

    /// A run with one parameter `p` whose state is `x = p t^2`, `y = 1 + p t`
    /// at t = 0, 0.5, 1, 1.5, 2 (so `dx/dp = t^2`, `dy/dp = t`): every
    /// reduction's value is the accumulator's over the same rows, and its
    /// derivative is the one of the formula, sample by sample.
    #[test]
    fn gradients_are_the_reductions_differentiated() {
        use ezy_core::sensitivity::{Derivative, Sensitivities};
        let p = 0.7;
        let t: Vec<f64> = (0..5).map(|i| 0.5 * f64::from(i)).collect();
        let s = Sensitivities {
            t: t.clone(),
            names: vec!["x".into(), "y".into()],
            parameters: vec!["p".into()],
            values: vec![p],
            derivatives: vec![Derivative::InitialOnly],
            x: t.iter().map(|t| vec![p * t * t, 1.0 + p * t]).collect(),
            s: t.iter().map(|t| vec![t * t, *t]).collect(),
            steps: 0,
            rejected: 0,
            evaluations: 0,
            formulation: ezy_core::Formulation::Dae,
            repartitions: 0,
        };
        let value = |text: &str, p: f64| {
            let m: Metric = text.parse().unwrap();
            let mut acc = Accumulator::new(&m, &cols()).unwrap();
            for &t in &t {
                acc.push(&[t, p * t * t, 1.0 + p * t]);
            }
            acc.value(&m).unwrap()
        };
        for text in [
            "final(x)",
            "mean(x)",
            "mean(y, 0.5, 1.5)",
            "max(diff(y, x))",
            "min(diff(y, x))",
            "final(norm(x, y))",
            "final(from_start(y))",
            "max(balance_gap(y, x), 1, 2)",
        ] {
            let (v, g) = text.parse::<Metric>().unwrap().with_gradient(&s).unwrap();
            let h = 1e-6;
            let fd = (value(text, p + h) - value(text, p - h)) / (2.0 * h);
            assert!((v - value(text, p)).abs() < 1e-15, "{text}: {v}");
            assert!((g[0] - fd).abs() < 1e-8, "{text}: {} against {fd}", g[0]);
        }
        let e = "final(z)".parse::<Metric>().unwrap().with_gradient(&s).unwrap_err();
        assert!(e.contains("`z` is not a coordinate or velocity"), "{e}");
    }
}
