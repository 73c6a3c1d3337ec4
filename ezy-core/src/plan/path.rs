//! Path constraints: bounds `lower <= g(t_k, q_k, qd_k, u_k) <= upper` at
//! the mesh's nodes (Betts, *Practical Methods for Optimal Control*, 2nd
//! ed., SIAM 2010, §4.2: a path constraint of a direct transcription
//! enforced at its grid points).
//!
//! `g` is a state component (`q.x`, `qd.x`: a column of the run's CSV)
//! or a function of the user's own of one node's sample ([`Samples`]
//! with one row: the node's time, state and inputs), which returns its
//! value and, if it can, its gradient (else ezy differences it with
//! respect to the sample, as an objective's). Each finite bound is one
//! inequality of the program per node, differentiated through the nodes'
//! exact sensitivities as the objective is. A state component is bounded
//! at nodes 1 ... N (node 0 is the problem's initial state, which no
//! unknown moves: checked once, refused where it violates the bound); a
//! function at every node (it may take the inputs).
//!
//! Between the nodes nothing is enforced: the verification run, sampled
//! eight times per segment, reports the largest violation it finds
//! ([`super::Verification::path_violation`]), which shrinks with the mesh.

use std::sync::Arc;

use super::objective::{self, SampleNames, Samples, UserObjective, UserValue};
use crate::analysis::AnalysisError;
use crate::model::Model;

/// What a path constraint bounds.
#[derive(Clone)]
enum Bounded {
    /// A coordinate (`velocity`: its velocity).
    State { coord: String, velocity: bool },
    /// A function of one node's sample.
    Function(Arc<UserObjective>),
}

/// A bound on a state component or a function of the user's own at every
/// node of the mesh: `lower <= g <= upper` (one side may be infinite).
#[derive(Clone)]
pub struct PathConstraint {
    /// Its name as results print it (`q.y`, `qd.x`, or the function's).
    pub name: String,
    /// Lower bound \[`g`'s unit\] (`-inf` for none).
    pub lower: f64,
    /// Upper bound (`inf` for none).
    pub upper: f64,
    bounded: Bounded,
}

impl std::fmt::Debug for PathConstraint {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "PathConstraint({})", self.describe())
    }
}

impl PathConstraint {
    /// `lower <= q.coord <= upper` \[m or rad\] at nodes 1 ... N.
    pub fn q(coord: &str, lower: f64, upper: f64) -> Self {
        let bounded = Bounded::State { coord: coord.into(), velocity: false };
        Self { name: format!("q.{coord}"), lower, upper, bounded }
    }

    /// `lower <= qd.coord <= upper` \[m/s or rad/s\] at nodes 1 ... N.
    pub fn qd(coord: &str, lower: f64, upper: f64) -> Self {
        let bounded = Bounded::State { coord: coord.into(), velocity: true };
        Self { name: format!("qd.{coord}"), lower, upper, bounded }
    }

    /// `lower <= g(sample) <= upper` at nodes 0 ... N, `g` a function of
    /// the user's own called with one node's sample (each field of
    /// [`Samples`] one row); its gradient (same shapes) or `None`, when
    /// ezy differences it.
    pub fn function(
        name: impl Into<String>,
        lower: f64,
        upper: f64,
        g: impl Fn(&Samples) -> Result<UserValue, String> + Send + Sync + 'static,
    ) -> Self {
        Self { name: name.into(), lower, upper, bounded: Bounded::Function(Arc::new(g)) }
    }

    /// `-0.5 <= q.y`, `qd.x <= 0.6`, `-1 <= g <= 1`.
    pub fn describe(&self) -> String {
        match (self.lower.is_finite(), self.upper.is_finite()) {
            (true, true) => format!("{} <= {} <= {}", self.lower, self.name, self.upper),
            (true, false) => format!("{} >= {}", self.name, self.lower),
            _ => format!("{} <= {}", self.name, self.upper),
        }
    }

    /// Refuses bounds that are NaN, a lower above its upper, both
    /// infinite (nothing bounded), or finite beyond
    /// [`crate::settings::MAX_MAGNITUDE`].
    pub(super) fn check(&self) -> Result<(), String> {
        let (lo, hi) = (self.lower, self.upper);
        if lo.is_nan() || hi.is_nan() || lo > hi || lo == f64::INFINITY || hi == f64::NEG_INFINITY {
            return Err(format!(
                "path constraint on {}: bounds {lo}:{hi}: give numbers, the lower at most the upper",
                self.name
            ));
        }
        for bound in [lo, hi].into_iter().filter(|v| v.is_finite()) {
            crate::settings::check_magnitude(&format!("path constraint on {}: bound", self.name), bound)?;
        }
        if !lo.is_finite() && !hi.is_finite() {
            return Err(format!("path constraint on {}: both bounds infinite, nothing is bounded", self.name));
        }
        Ok(())
    }
}

/// A path constraint resolved against the model: its state component
/// (index in `[q, qd]`) or its function.
#[derive(Clone)]
pub(super) struct Resolved {
    pub constraint: PathConstraint,
    pub comp: Option<usize>,
}

impl Resolved {
    /// The function, for a function's constraint (`None`: a state
    /// component's, `comp`).
    fn function(&self) -> Option<&UserObjective> {
        match &self.constraint.bounded {
            Bounded::Function(f) => Some(&**f),
            Bounded::State { .. } => None,
        }
    }

    /// How messages name it: `path constraint `g``.
    fn label(&self) -> String {
        format!("path constraint `{}`", self.constraint.name)
    }

    /// The state component `c` at node `k` of `s`.
    fn component(s: &Samples, k: usize, c: usize) -> f64 {
        let nq = s.q[k].len();
        if c < nq { s.q[k][c] } else { s.qd[k][c - nq] }
    }
}

/// One inequality row: constraint `c` at node `k`, `sign` +1 for its
/// upper bound (`g - upper <= 0`), -1 for its lower (`lower - g <= 0`).
#[derive(Debug, Clone, Copy)]
pub(super) struct Row {
    pub c: usize,
    pub k: usize,
    pub sign: f64,
}

/// The path constraints resolved on `model`, checked at the initial state
/// `x0` (2 nq) where no unknown moves them.
///
/// # Errors
/// [`AnalysisError::Request`] for a coordinate the model does not have,
/// and a state component's bound that the initial state violates.
pub(super) fn resolve<M: Model>(
    model: &M,
    path: &[PathConstraint],
    x0: &[f64],
) -> Result<Vec<Resolved>, AnalysisError> {
    let info = model.info();
    let nq = info.nq();
    let mut out = Vec::new();
    for p in path {
        let comp = match &p.bounded {
            Bounded::State { coord, velocity } => {
                let Some(k) = info.coord_index(coord) else {
                    return Err(AnalysisError::Request {
                        reason: format!(
                            "path constraint {}: model {} has no coordinate `{coord}` (it has {})",
                            p.describe(),
                            info.name,
                            info.coords.join(", ")
                        ),
                    });
                };
                let c = if *velocity { nq + k } else { k };
                let v = x0[c];
                if v < p.lower || v > p.upper {
                    return Err(AnalysisError::Request {
                        reason: format!(
                            "path constraint {}: the initial state has {} = {v}, which no input can change",
                            p.describe(),
                            p.name
                        ),
                    });
                }
                Some(c)
            }
            Bounded::Function(_) => None,
        };
        out.push(Resolved { constraint: p.clone(), comp });
    }
    Ok(out)
}

/// The inequality rows of `path` on `segments` segments, with their names
/// at the nodes' times `t`.
pub(super) fn rows(path: &[Resolved], t: &[f64]) -> Vec<(Row, String)> {
    let mut out = Vec::new();
    for (c, p) in path.iter().enumerate() {
        let first = if p.comp.is_some() { 1 } else { 0 };
        for (k, tk) in t.iter().enumerate().skip(first) {
            for (sign, bound, word) in [(-1.0, p.constraint.lower, ">="), (1.0, p.constraint.upper, "<=")] {
                if bound.is_finite() {
                    let name = format!("path {} {word} {bound} at node {k} (t = {tk} s)", p.constraint.name);
                    out.push((Row { c, k, sign }, name));
                }
            }
        }
    }
    out
}

/// The value of constraint `p` at node `k` of the samples `s` and its
/// gradient with respect to that node's `[q, qd]` (2 nq) and `u`; whether
/// it was differenced.
///
/// # Errors
/// A function's failure, or a value or gradient not finite.
pub(super) fn at_node(
    p: &Resolved,
    s: &Samples,
    k: usize,
    names: &SampleNames<'_>,
) -> Result<(f64, Vec<f64>, Vec<f64>, bool), String> {
    match (p.function(), p.comp) {
        (Some(f), _) => {
            let (v, g, differenced) = objective::evaluate_as(f, &p.label(), &node_sample(s, k), names)?;
            let dx = g.q[0].iter().chain(&g.qd[0]).copied().collect();
            Ok((v, dx, g.u[0].clone(), differenced))
        }
        (None, c) => {
            let c = c.ok_or("a state's path constraint not resolved")?;
            let mut dx = vec![0.0; 2 * s.q[k].len()];
            dx[c] = 1.0;
            Ok((Resolved::component(s, k, c), dx, vec![0.0; s.u[k].len()], false))
        }
    }
}

/// The derivative of constraint `p` at node `k` of `s` with respect to
/// the node's time (central differences; 0 for a state component): a
/// free duration's chain.
///
/// # Errors
/// A function's failure.
pub(super) fn time_derivative(p: &Resolved, s: &Samples, k: usize) -> Result<f64, String> {
    match p.function() {
        None => Ok(0.0),
        Some(f) => Ok(objective::time_differences(f, &p.label(), &node_sample(s, k))?[0]),
    }
}

/// Node `k` of `s` as samples of one row.
pub(super) fn node_sample(s: &Samples, k: usize) -> Samples {
    Samples { t: vec![s.t[k]], q: vec![s.q[k].clone()], qd: vec![s.qd[k].clone()], u: vec![s.u[k].clone()] }
}

/// The largest violation of `path` over the samples `s` (any number of
/// rows: a run's output) and where; 0 and an empty place where none is
/// violated.
///
/// # Errors
/// A function's failure.
pub(super) fn largest_violation(path: &[Resolved], s: &Samples) -> Result<(f64, String), String> {
    let mut out = (0.0, String::new());
    for p in path {
        for k in 0..s.t.len() {
            let v = match (p.function(), p.comp) {
                (Some(f), _) => objective::value_as(f, &p.label(), &node_sample(s, k))?,
                (None, Some(c)) => Resolved::component(s, k, c),
                (None, None) => continue,
            };
            let excess = (p.constraint.lower - v).max(v - p.constraint.upper);
            if excess > out.0 {
                out = (excess, format!("{} = {v} at t = {} s", p.constraint.name, s.t[k]));
            }
        }
    }
    Ok(out)
}
