//! The verification of a plan: the whole planned input run through the
//! ordinary simulation (the user's problem with the inputs over
//! `[0, T]`, one run from its initial state), its end compared with the
//! target.

use super::{BuildInputs, TargetError, Verification};
use crate::analysis::AnalysisError;
use crate::effects::waveform::Table;
use crate::model::Model;

/// The run of `build` with `tables` to `t_end` \[s\], its end state
/// compared with `target` (`(index in [q, qd], value)`, every component
/// the target names) and with the plan's own end `planned` (2 nq).
///
/// # Errors
/// The problem's or the run's failure.
pub(super) fn verify<M: Model>(
    build: &BuildInputs<M>,
    tables: &[Table],
    t_end: f64,
    target: &[(usize, f64)],
    planned: &[f64],
) -> Result<Verification, AnalysisError> {
    let problem = build(tables)?.t_end(t_end).every(t_end);
    let names = problem.state_names();
    let n2 = 2 * problem.model.info().nq();
    let solution = problem.solve()?;
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
    Ok(Verification { end, errors, max_run_error, max_plan_error, steps: solution.summary.steps })
}
