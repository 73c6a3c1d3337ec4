//! A sweep's gait metrics (`gait.mean_speed`, `gait.drift_speed`, ...):
//! each run's gait, sought from the run's end as `ezy analyze` seeks it
//! (its period the forcing's, its guess the run's last state, run on
//! period by period while still in a transient), and its quantities by
//! the names `periodic.csv` gives them, so a sweep and an analysis say
//! the same thing under the same name.

use ezy_core::Model;
use ezy_core::analysis::PeriodicOrbit;
use ezy_core::effects::Periodicity;

use super::SweepJob;
use super::metric::Metric;
use crate::session::{self, RunOptions};

/// The value of each gait metric of `metrics` (`None` for the others)
/// for the run of `job`'s scene at `opts`' settings (which ended early
/// where `stopped` says), sought at the forcing's phase 0 of the last
/// whole period before `settings.t_end` from a run to there, the one
/// `ezy analyze` makes.
///
/// # Errors
/// The first gait metric's name and why there is no value: the run
/// stopped early at an event, the scene is not driven periodically, the
/// search found no gait (or the motion grows without bound), the
/// efficiency of a gait without input power.
pub(super) fn values<M: Model>(
    proto: &M,
    job: &SweepJob,
    settings: &ezy_core::RunSettings,
    opts: &RunOptions,
    stopped: Option<&(String, f64)>,
) -> Result<Vec<Option<f64>>, String> {
    let Some(first) = job.metrics.iter().find(|m| m.gait.is_some()) else {
        return Ok(vec![None; job.metrics.len()]);
    };
    let fail = |why: String| format!("metric `{}`: {why}", first.text);
    if let Some((event, t)) = stopped {
        return Err(fail(format!(
            "the run stopped at event `{event}` at {} s, before its end; a gait is sought from the run's end",
            ezy_core::fmt_value(*t)
        )));
    }
    let (problem, _) = session::problem(proto, &job.scene, opts, *settings).map_err(|e| fail(e.to_string()))?;
    let (mut an, x0) = problem.clone().analysis().map_err(|e| fail(e.to_string()))?;
    an.check_size().map_err(|e| fail(e.to_string()))?;
    an.stop_when(|| crate::output::transaction::pending().is_some());
    let period = match an.forcing() {
        Some(Periodicity::Period(t)) => t,
        _ => {
            return Err(fail(
                "the scene is not driven periodically (a motor or force with a waveform that repeats), so it has no gait"
                    .into(),
            ));
        }
    };
    let symmetry = an.symmetry(0.0, &x0).map_err(|e| fail(e.to_string()))?;
    let ps = session::periodic_settings(opts);
    // at the forcing's phase 0, the last whole period of the run, from
    // the run `ezy analyze` makes for its guess (the same states): the
    // orbit's phase and frame are the analysis'
    let t_run = (settings.t_end / period).floor().max(1.0) * period;
    let (samples, _) =
        session::run_to(proto, &job.scene, opts, t_run, session::GUESSES).map_err(|e| fail(e.to_string()))?;
    let guess = samples.last().cloned().unwrap_or(x0);
    let orbit = an.gait(t_run, period, &guess, symmetry, &ps).map_err(|e| fail(e.to_string()))?;
    let powered = job.metrics.iter().any(|m| matches!(m.gait.as_deref(), Some("mean_power" | "efficiency")));
    let power = if powered {
        Some(problem.gait_sensitivities(&orbit, &[], &ps).map_err(|e| fail(e.to_string()))?)
    } else {
        None
    };
    job.metrics.iter().map(|m| value(m, &orbit, power.as_ref())).collect()
}

/// One metric's value on the gait (`None` for a metric of the rows).
fn value(
    m: &Metric,
    orbit: &PeriodicOrbit,
    power: Option<&ezy_core::sensitivity::GaitSensitivities>,
) -> Result<Option<f64>, String> {
    let Some(name) = m.gait.as_deref() else { return Ok(None) };
    let v = match (name, power) {
        ("mean_power", Some(g)) => g.mean_power,
        ("efficiency", Some(g)) => g.efficiency,
        _ => orbit.value(name).ok_or_else(|| format!("metric `{}`: no such quantity", m.text))?,
    };
    if v.is_finite() {
        Ok(Some(v))
    } else {
        Err(format!("metric `{}` is {v} on this gait (an efficiency without input power has none)", m.text))
    }
}
