//! The verification of a plan: the whole planned input run through the
//! ordinary simulation (the user's problem with the inputs over
//! `[0, T]`, one run from its initial state), its end compared with the
//! target, and its samples (eight per segment) with the path constraints.

use super::objective::Samples;
use super::path::{self, Resolved};
use super::{BuildInputs, TargetError, Verification};
use crate::effects::waveform::Table;
use crate::model::Model;

/// The run of `build` with `tables` to `t_end` \[s\] (on `segments`
/// segments), its end state compared with `target` (`(index in [q, qd],
/// value)`, every component the target names) and with the plan's own
/// end `planned` (2 nq), its samples with the path constraints `path`.
///
/// # Errors
/// The problem's or the run's failure, a path function's, in words.
pub(super) fn verify<M: Model>(
    build: &BuildInputs<M>,
    tables: &[Table],
    (t_end, segments): (f64, usize),
    (target, path): (&[(usize, f64)], &[Resolved]),
    planned: &[f64],
) -> Result<Verification, String> {
    let every = if path.is_empty() { t_end } else { t_end / (8 * segments) as f64 };
    let problem = build(tables).map_err(|e| e.to_string())?.t_end(t_end).every(every);
    let names = problem.state_names();
    let nq = problem.model.info().nq();
    let n2 = 2 * nq;
    let solution = problem.solve().map_err(|e| e.to_string())?;
    let samples = Samples {
        t: solution.t.clone(),
        q: solution.y.iter().map(|y| y[..nq].to_vec()).collect(),
        qd: solution.y.iter().map(|y| y[nq..n2].to_vec()).collect(),
        u: solution.t.iter().map(|&t| tables.iter().map(|tb| tb.eval(t)).collect()).collect(),
    };
    let path_violation = path::largest_violation(path, &samples)?;
    let end = solution.final_state()[..n2].to_vec();
    let errors: Vec<TargetError> = target
        .iter()
        .map(|&(c, value)| TargetError {
            name: names[c].clone(),
            target: value,
            run: end[c] - value,
            plan: planned[c] - value,
        })
        .collect();
    let max_run_error = errors.iter().fold(0.0f64, |m, e| m.max(e.run.abs()));
    let max_plan_error = errors.iter().fold(0.0f64, |m, e| m.max(e.plan.abs()));
    Ok(Verification { end, errors, max_run_error, max_plan_error, steps: solution.summary.steps, path_violation })
}
