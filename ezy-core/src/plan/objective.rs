//! The objective a plan minimizes: the effort `sum_j int_0^T u_j(t)^2 dt`
//! times a weight, plus an optional term of the user's own,
//! `J_user(samples)`, a function of the run at the mesh's N + 1 nodes.
//!
//! The samples are the nodes' times `t_k` \[s\], the state `x_k = [q_k,
//! qd_k]` there (node 0 the problem's initial state; node `k >= 1` the
//! end of segment `k - 1`, which is segment `k`'s start wherever the plan
//! is continuous: in single shooting, the default, the chained runs' end
//! states) and the inputs' node values `u_k`. The user's function returns
//! the term's value and, if it can, its gradient with respect to every
//! sample but the times (which are fixed); where it gives none, ezy
//! differences it with respect to the samples (central differences, the
//! function called twice per sample component: no extra simulation), and
//! the result says so ([`ObjectiveGradient::Differenced`]). The chain
//! rule to the program's unknowns `w` takes the samples' exact
//! sensitivities `d x_k / d w` (the forward sensitivities multiplied
//! along the chain of segments) and `d u_k / d w` (the identity on the
//! input nodes).

use std::sync::Arc;

/// The run at the mesh's N + 1 nodes, as a user's objective is given it.
#[derive(Debug, Clone, PartialEq)]
pub struct Samples {
    /// The nodes' times \[s\] (N + 1).
    pub t: Vec<f64>,
    /// The coordinates at each node (N + 1 rows of nq) \[m or rad\].
    pub q: Vec<Vec<f64>>,
    /// The velocities at each node (N + 1 rows of nq) \[m/s or rad/s\].
    pub qd: Vec<Vec<f64>>,
    /// The inputs at each node (N + 1 rows of one per input) \[the
    /// input's unit\].
    pub u: Vec<Vec<f64>>,
}

/// The gradient of a user's objective with respect to the samples (the
/// times excluded: they are fixed): the same shapes as [`Samples::q`],
/// [`Samples::qd`] and [`Samples::u`], each entry the objective's unit
/// over the sample's.
#[derive(Debug, Clone, PartialEq)]
pub struct SampleGradient {
    /// `d J / d q_k` (N + 1 rows of nq).
    pub q: Vec<Vec<f64>>,
    /// `d J / d qd_k` (N + 1 rows of nq).
    pub qd: Vec<Vec<f64>>,
    /// `d J / d u_k` (N + 1 rows of one per input).
    pub u: Vec<Vec<f64>>,
}

impl SampleGradient {
    /// Zeros shaped as `s`.
    pub fn zeros(s: &Samples) -> Self {
        let zero = |rows: &[Vec<f64>]| rows.iter().map(|r| vec![0.0; r.len()]).collect();
        Self { q: zero(&s.q), qd: zero(&s.qd), u: zero(&s.u) }
    }
}

/// What a user's objective returns: its value and, if it has it, its
/// gradient with respect to the samples (`None`: ezy differences it).
#[derive(Debug, Clone, PartialEq)]
pub struct UserValue {
    /// `J_user` \[the objective's unit, the effort's: input unit^2 s\].
    pub value: f64,
    /// `d J_user / d samples`, or `None`.
    pub gradient: Option<SampleGradient>,
}

/// A user's objective term: the samples to its value (and gradient), or
/// why it cannot be evaluated (the plan then fails with that reason).
pub type UserObjective = dyn Fn(&Samples) -> Result<UserValue, String> + Send + Sync;

/// What a plan minimizes: `effort_weight * sum_j int u_j^2 dt +
/// time_weight * T + J_user`.
#[derive(Clone)]
pub struct Objective {
    /// The effort's weight (finite, >= 0; 1 by default).
    pub effort_weight: f64,
    /// The duration's weight \[objective unit / s\] (finite, >= 0; 0 by
    /// default): with a free duration ([`super::PlanSettings::free_time`])
    /// a minimum-time plan.
    pub time_weight: f64,
    /// The user's term and its name (as results print it), if any.
    pub user: Option<(String, Arc<UserObjective>)>,
}

impl Default for Objective {
    fn default() -> Self {
        Self::effort()
    }
}

impl std::fmt::Debug for Objective {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Objective")
            .field("effort_weight", &self.effort_weight)
            .field("time_weight", &self.time_weight)
            .field("user", &self.user.as_ref().map(|u| &u.0))
            .finish()
    }
}

impl Objective {
    /// The effort alone, weight 1: the planner's default.
    pub fn effort() -> Self {
        Self { effort_weight: 1.0, time_weight: 0.0, user: None }
    }

    /// The duration `T` alone (weight 1, the effort's 0): a minimum-time
    /// plan, whose duration must be free
    /// ([`super::PlanSettings::free_time`]).
    pub fn time() -> Self {
        Self { effort_weight: 0.0, time_weight: 1.0, user: None }
    }

    /// The effort (weight 1) plus the user's term `function` named `name`.
    pub fn user(
        name: impl Into<String>,
        function: impl Fn(&Samples) -> Result<UserValue, String> + Send + Sync + 'static,
    ) -> Self {
        Self { effort_weight: 1.0, time_weight: 0.0, user: Some((name.into(), Arc::new(function))) }
    }

    /// The same objective with the duration's weight `weight` (finite,
    /// >= 0: checked by [`super::Plan::with_objective`]).
    #[must_use]
    pub fn time_weight(mut self, weight: f64) -> Self {
        self.time_weight = weight;
        self
    }

    /// The same objective with the effort's weight `weight` (finite, >= 0:
    /// checked by [`super::Plan::with_objective`]).
    #[must_use]
    pub fn effort_weight(mut self, weight: f64) -> Self {
        self.effort_weight = weight;
        self
    }

    /// The objective in words: `effort`, `2 x effort + name`, `time`,
    /// `effort + 0.5 x time`, `name`.
    pub fn describe(&self) -> String {
        let weighted = |w: f64, what: &str| match w {
            0.0 => None,
            1.0 => Some(what.to_string()),
            w => Some(format!("{w} x {what}")),
        };
        let terms: Vec<String> = [
            weighted(self.effort_weight, "effort"),
            weighted(self.time_weight, "time"),
            self.user.as_ref().map(|u| u.0.clone()),
        ]
        .into_iter()
        .flatten()
        .collect();
        if terms.is_empty() { "nothing".into() } else { terms.join(" + ") }
    }

    /// Refuses a weight that is not finite and >= 0, and an objective
    /// that is nothing (weight 0 without a user's term).
    pub(super) fn check(&self) -> Result<(), String> {
        if !(self.effort_weight.is_finite() && self.effort_weight >= 0.0) {
            return Err(format!("effort_weight {}: give a finite weight >= 0", self.effort_weight));
        }
        if !(self.time_weight.is_finite() && self.time_weight >= 0.0) {
            return Err(format!("time_weight {}: give a finite weight >= 0", self.time_weight));
        }
        if self.effort_weight == 0.0 && self.time_weight == 0.0 && self.user.is_none() {
            return Err("effort_weight 0 without a time weight or a user's objective: nothing to minimize".into());
        }
        Ok(())
    }
}

/// How the objective's gradient was had.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ObjectiveGradient {
    /// Exact: the effort's and the user's own gradient (if any), through
    /// the samples' sensitivities.
    Exact,
    /// The user's term differenced with respect to the samples (central
    /// differences, no extra simulation) at some evaluation, its chain to
    /// the unknowns exact.
    Differenced,
}

impl ObjectiveGradient {
    /// `"exact"` or `"differenced"`.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Exact => "exact",
            Self::Differenced => "differenced",
        }
    }
}

/// Relative step of the central differences: the cube root of the
/// machine epsilon (their truncation and rounding errors balanced).
const STEP: f64 = 6.055_454_452_393_343e-6;

/// Which sample a flat index names, for messages.
fn sample_name(s: &Samples, names: &SampleNames<'_>, block: usize, k: usize, i: usize) -> String {
    let what = match block {
        0 => format!("q.{}", names.coords.get(i).map_or("?", String::as_str)),
        1 => format!("qd.{}", names.coords.get(i).map_or("?", String::as_str)),
        _ => format!("u.{}", names.inputs.get(i).map_or("?", String::as_str)),
    };
    format!("{what} at node {k} (t = {} s)", s.t.get(k).copied().unwrap_or(f64::NAN))
}

/// The names messages give the samples: the model's coordinates and the
/// inputs.
pub(super) struct SampleNames<'a> {
    pub coords: &'a [String],
    pub inputs: &'a [String],
}

/// The user's value, checked finite.
fn value(f: &UserObjective, label: &str, s: &Samples) -> Result<UserValue, String> {
    let v = f(s).map_err(|e| format!("{label} failed: {e}"))?;
    if !v.value.is_finite() {
        return Err(format!("{label} returned {} (not finite): it must be a finite number", v.value));
    }
    Ok(v)
}

/// The user's term `f` (named `name`) at the samples `s`: its value, its
/// gradient with respect to `q`, `qd` and `u` (the user's own, or central
/// differences of `f`), and whether it was differenced.
///
/// # Errors
/// The function's failure; a value or gradient entry that is not finite,
/// or a gradient not shaped as the samples, named with its sample.
pub(super) fn evaluate(
    f: &UserObjective,
    name: &str,
    s: &Samples,
    names: &SampleNames<'_>,
) -> Result<(f64, SampleGradient, bool), String> {
    evaluate_as(f, &format!("the objective `{name}`"), s, names)
}

/// As [`evaluate`], its messages naming the function `label` (`the
/// objective `J``, `path constraint `g``).
///
/// # Errors
/// As [`evaluate`].
pub(super) fn evaluate_as(
    f: &UserObjective,
    label: &str,
    s: &Samples,
    names: &SampleNames<'_>,
) -> Result<(f64, SampleGradient, bool), String> {
    let v = value(f, label, s)?;
    let (g, differenced) = match v.gradient {
        Some(g) => {
            let shaped =
                |a: &[Vec<f64>], b: &[Vec<f64>]| a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.len() == y.len());
            if !(shaped(&g.q, &s.q) && shaped(&g.qd, &s.qd) && shaped(&g.u, &s.u)) {
                return Err(format!(
                    "{label} returned a gradient not shaped as the samples: give q and qd as {} rows of {} and u as {} rows of {}",
                    s.q.len(),
                    s.q.first().map_or(0, Vec::len),
                    s.u.len(),
                    s.u.first().map_or(0, Vec::len)
                ));
            }
            (g, false)
        }
        None => (differences(f, label, s)?, true),
    };
    for (block, rows) in [&g.q, &g.qd, &g.u].into_iter().enumerate() {
        for (k, row) in rows.iter().enumerate() {
            if let Some((i, d)) = row.iter().enumerate().find(|(_, d)| !d.is_finite()) {
                return Err(format!(
                    "{label}'s gradient with respect to {} is {d} (not finite){}",
                    sample_name(s, names, block, k, i),
                    if differenced { " (differenced)" } else { "" }
                ));
            }
        }
    }
    Ok((v.value, g, differenced))
}

/// Block `block` (0: q, 1: qd, 2: u) of the samples' or the gradient's
/// rows.
fn rows_of<'a>(
    q: &'a mut [Vec<f64>],
    qd: &'a mut [Vec<f64>],
    u: &'a mut [Vec<f64>],
    block: usize,
    k: usize,
) -> &'a mut [f64] {
    match block {
        0 => &mut q[k],
        1 => &mut qd[k],
        _ => &mut u[k],
    }
}

/// Central differences of `f` with respect to every sample but the
/// times: step `STEP * max(|sample|, 1)`, two calls per component.
fn differences(f: &UserObjective, label: &str, s: &Samples) -> Result<SampleGradient, String> {
    let mut g = SampleGradient::zeros(s);
    let mut p = s.clone();
    for block in 0..3 {
        let rows = [s.q.len(), s.qd.len(), s.u.len()][block];
        for k in 0..rows {
            let width = [&s.q, &s.qd, &s.u][block][k].len();
            for i in 0..width {
                let x = rows_of(&mut p.q, &mut p.qd, &mut p.u, block, k)[i];
                let h = STEP * x.abs().max(1.0);
                let (up, down) = (x + h, x - h);
                rows_of(&mut p.q, &mut p.qd, &mut p.u, block, k)[i] = up;
                let plus = value(f, label, &p)?.value;
                rows_of(&mut p.q, &mut p.qd, &mut p.u, block, k)[i] = down;
                let minus = value(f, label, &p)?.value;
                rows_of(&mut p.q, &mut p.qd, &mut p.u, block, k)[i] = x;
                // the steps as represented
                rows_of(&mut g.q, &mut g.qd, &mut g.u, block, k)[i] = (plus - minus) / (up - down);
            }
        }
    }
    Ok(g)
}

/// Central differences of `f` (named `label`) with respect to each of
/// the samples' times `t_k` (step `STEP * max(|t_k|, 1)`, two calls per
/// time): what a free duration's chain needs, `t_k = k T / N` moving
/// with `T`.
///
/// # Errors
/// As [`evaluate`]'s value.
pub(super) fn time_differences(f: &UserObjective, label: &str, s: &Samples) -> Result<Vec<f64>, String> {
    let mut p = s.clone();
    let mut out = Vec::with_capacity(s.t.len());
    for k in 0..s.t.len() {
        let x = s.t[k];
        let h = STEP * x.abs().max(1.0);
        let (up, down) = (x + h, x - h);
        p.t[k] = up;
        let plus = value(f, label, &p)?.value;
        p.t[k] = down;
        let minus = value(f, label, &p)?.value;
        p.t[k] = x;
        out.push((plus - minus) / (up - down));
    }
    Ok(out)
}

/// The user's value alone at `s` (the objective's scale at the warm
/// start), checked finite.
///
/// # Errors
/// As [`evaluate`]'s value.
pub(super) fn value_only(f: &UserObjective, name: &str, s: &Samples) -> Result<f64, String> {
    value_as(f, &format!("the objective `{name}`"), s)
}

/// As [`value_only`], its messages naming the function `label`.
///
/// # Errors
/// As [`evaluate`]'s value.
pub(super) fn value_as(f: &UserObjective, label: &str, s: &Samples) -> Result<f64, String> {
    value(f, label, s).map(|v| v.value)
}
