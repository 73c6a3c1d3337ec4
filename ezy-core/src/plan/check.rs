//! A plan's request checked before any work, its target resolved against
//! the model, and the program's scales.

use super::nlp::Scales;
use super::objective::Objective;
use super::transcription::Transcription;
use super::{Input, MAX_UNKNOWNS, Plan, PlanSettings, Target};
use crate::analysis::AnalysisError;
use crate::effects::waveform::{Extrapolate, Table};
use crate::model::Model;
use crate::problem::Problem;

fn fail<T>(reason: String) -> Result<T, AnalysisError> {
    Err(AnalysisError::Request { reason })
}

/// Refuses what [`Plan::with_objective`] documents, naming the culprit.
pub(super) fn request(
    inputs: &[Input],
    target: &Target,
    s: &PlanSettings,
    objective: &Objective,
) -> Result<(), AnalysisError> {
    objective.check().map_err(|reason| AnalysisError::Request { reason })?;
    if inputs.is_empty() {
        return fail("a plan without inputs: name at least one input the problem's effects take".into());
    }
    for (k, i) in inputs.iter().enumerate() {
        if inputs[..k].iter().any(|o| o.name == i.name) {
            return fail(format!("input `{}` is named twice", i.name));
        }
        if i.lower.is_nan() || i.upper.is_nan() || i.lower > i.upper {
            return fail(format!(
                "input `{}`: bounds {}:{}: give numbers, the lower at most the upper (infinite for none)",
                i.name, i.lower, i.upper
            ));
        }
    }
    if target.entries.is_empty() && !target.rest && objective.user.is_none() {
        return fail(
            "no target: name at least one component of q or qd at t_end (or at rest), or give an objective of the samples (a free end)"
                .into(),
        );
    }
    if let Some((name, v, value)) = target.entries.iter().find(|e| !e.2.is_finite()) {
        return fail(format!("target {}{name} = {value}: give a finite value", if *v { "qd." } else { "q." }));
    }
    if s.segments == 0 {
        return fail("0 segments: a plan needs at least one".into());
    }
    if !(1..=s.segments).contains(&s.intervals) {
        return fail(format!(
            "{} shooting intervals for {} segments: give 1 (single shooting) to {} (a node at every segment)",
            s.intervals, s.segments, s.segments
        ));
    }
    if !(s.t_end.is_finite() && s.t_end > 0.0) {
        return fail(format!("t_end = {} s: give a finite duration > 0", s.t_end));
    }
    if let Some((lo, hi)) = s.free_time {
        if let Err(reason) = crate::settings::check_magnitude("free time's upper bound [s]", hi) {
            return fail(reason);
        }
        if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && lo <= s.t_end && s.t_end <= hi) {
            return fail(format!(
                "free time {lo}:{hi} s: give finite bounds 0 < lower <= t_end ({} s) <= upper",
                s.t_end
            ));
        }
    } else if objective.time_weight > 0.0 {
        return fail(format!(
            "time_weight {}: the duration is fixed (t_end = {} s); free it within bounds (free_time) to minimize it",
            objective.time_weight, s.t_end
        ));
    }
    if !(s.tolerance > 0.0 && s.tolerance < 1.0) {
        return fail(format!("tolerance {}: give a violation in (0, 1)", s.tolerance));
    }
    if !(s.state_box.is_finite() && s.state_box >= 1.0) {
        return fail(format!("state_box {}: give a finite multiple >= 1 of the states' scales", s.state_box));
    }
    if s.max_evaluations < 2 {
        return fail(format!("a budget of {} evaluations: give at least 2", s.max_evaluations));
    }
    if s.max_unknowns > MAX_UNKNOWNS {
        return fail(format!("a limit of {} unknowns: at most {MAX_UNKNOWNS} (SLSQP is dense)", s.max_unknowns));
    }
    // segments alone past the limit: refused before any problem is built
    let at_least = inputs.len().saturating_mul(s.segments.saturating_add(1));
    if at_least > s.max_unknowns {
        return fail(unknowns(at_least, s, "input nodes alone"));
    }
    let mesh = (0..=s.segments).map(|k| s.t_end * k as f64 / s.segments as f64);
    for i in inputs {
        i.guess
            .validate()
            .map_err(|e| AnalysisError::Request { reason: format!("input `{}`: its guess: {e}", i.name) })?;
        if let Some((t, g)) = mesh
            .clone()
            .map(|t| (t, i.guess.eval(t)))
            .find(|(_, g)| !(g.is_finite() && (i.lower..=i.upper).contains(g)))
        {
            return fail(format!(
                "input `{}`: its guess {g} at t = {t} s is not a finite number within its bounds {}:{}",
                i.name, i.lower, i.upper
            ));
        }
    }
    Ok(())
}

fn unknowns(n: impl std::fmt::Display, s: &PlanSettings, what: &str) -> String {
    format!(
        "{n} unknowns ({what}) for {} segments: more than the limit of {} (max_unknowns; SLSQP is dense): take fewer segments",
        s.segments, s.max_unknowns
    )
}

/// The problem at the guesses over `[0, T]`, checked: no drives or
/// events, the program's size within the limits.
pub(super) fn problem<M: Model>(plan: &Plan<M>, guess: &[f64]) -> Result<Problem<M>, AnalysisError> {
    let s = &plan.settings;
    let mesh = plan.mesh();
    let tables: Vec<Table> = guess
        .chunks_exact(s.segments + 1)
        .map(|v| Table { t: mesh.clone(), value: v.to_vec(), extrapolate: Extrapolate::Hold })
        .collect();
    let p = (plan.build)(&tables)?;
    if let Some(d) = p.drives.first() {
        return fail(format!(
            "drive `{}`: a plan's segments restart the problem's clock, which a prescribed motion follows; remove the drive",
            d.name
        ));
    }
    if let Some(e) = p.events.first() {
        return fail(format!(
            "event `{}`: a plan's segment runs are differentiated, which events are not; remove it",
            e.name
        ));
    }
    let info = p.model.info();
    let nz = 2 * info.nq() - info.n_holonomic - info.nc();
    let n = s.unknowns(plan.inputs.len(), nz);
    if n > s.max_unknowns as u128 {
        return fail(unknowns(
            n,
            s,
            &format!(
                "{} input nodes and {nz} state components at each of {} inner nodes",
                guess.len(),
                s.intervals - 1
            ),
        ));
    }
    // a chained segment (inside a shooting interval) is differentiated
    // with respect to its whole start
    let nz_start = if s.intervals < s.segments { 2 * info.nq() } else { nz };
    let np = nz_start + 2 * plan.inputs.len();
    if np > crate::sensitivity::MAX_PARAMETERS {
        return fail(format!(
            "each segment's run is differentiated with respect to {np} numbers ({nz_start} state components and 2 nodes of each input), more than {}",
            crate::sensitivity::MAX_PARAMETERS
        ));
    }
    Ok(p)
}

/// The target's components as `(index in [q, qd], value)`.
///
/// # Errors
/// [`AnalysisError::Request`] for a coordinate the model does not have,
/// listing its coordinates, one given twice, a heading beyond
/// [`crate::settings::MAX_ANGLE`] or a value beyond
/// [`crate::settings::MAX_MAGNITUDE`] (as an initial state's).
pub(super) fn target<M: Model>(p: &Problem<M>, target: &Target) -> Result<Vec<(usize, f64)>, AnalysisError> {
    let info = p.model.info();
    let nq = info.nq();
    let mut out: Vec<(usize, f64)> = Vec::new();
    for (name, velocity, value) in &target.entries {
        let Some(k) = info.coord_index(name) else {
            return fail(format!(
                "target {}: model {} has no coordinate `{name}` (it has {})",
                if *velocity { "qd" } else { "q" },
                info.name,
                info.coords.join(", ")
            ));
        };
        let c = if *velocity { nq + k } else { k };
        // a heading at most MAX_ANGLE as an initial one; any component
        // at most MAX_MAGNITUDE (1e300 searched its whole budget, 100 s)
        let label = format!("target {}{name}", if *velocity { "qd." } else { "q." });
        let size = if !*velocity && info.is_angle(k) {
            crate::settings::check_angle(&label, *value)
        } else {
            crate::settings::check_magnitude(&label, *value)
        };
        if let Err(reason) = size {
            return fail(reason);
        }
        if out.iter().any(|o| o.0 == c) {
            return fail(format!(
                "target {} is given twice",
                if *velocity { format!("qd.{name}") } else { format!("q.{name}") }
            ));
        }
        out.push((c, *value));
    }
    if target.rest {
        for c in nq..2 * nq {
            match out.iter().find(|o| o.0 == c) {
                Some(&(_, v)) if v != 0.0 => {
                    return fail(format!("target qd.{} = {v} and at rest: say one", info.coords[c - nq]));
                }
                Some(_) => {}
                None => out.push((c, 0.0)),
            }
        }
    }
    Ok(out)
}

/// The target's rows that the constraints at the state `x` (2 nq) do not
/// determine from the others: each row of `target` kept if it is
/// independent of `C_q`'s rows (positions) or `G`'s (velocities) and of
/// the rows kept before it (Gram-Schmidt, relative tolerance 1e-9).
pub(super) fn independent<M: Model>(model: &M, x: &[f64], target: &[(usize, f64)]) -> Vec<(usize, f64)> {
    let info = model.info();
    let (nq, nh, nc) = (info.nq(), info.n_holonomic, info.nc());
    let mut g = vec![0.0; info.pattern.len()];
    model.constraint_matrix(&x[..nq], &mut g);
    let mut dense = vec![0.0; nc * nq];
    crate::model::info::scatter_dense(&info.pattern, &g, nq, &mut dense);
    let mut kept = Vec::new();
    for velocity in [false, true] {
        let rows = if velocity { nc } else { nh };
        let mut basis: Vec<Vec<f64>> = Vec::new();
        let add = |v: Vec<f64>, basis: &mut Vec<Vec<f64>>| {
            let mut r = v;
            for b in basis.iter() {
                let d: f64 = r.iter().zip(b).map(|(a, b)| a * b).sum();
                r.iter_mut().zip(b).for_each(|(a, b)| *a -= d * b);
            }
            let norm = r.iter().map(|a| a * a).sum::<f64>().sqrt();
            if norm > 1e-9 {
                basis.push(r.iter().map(|a| a / norm).collect());
                true
            } else {
                false
            }
        };
        for row in dense.chunks_exact(nq).take(rows) {
            add(row.to_vec(), &mut basis);
        }
        for &(c, value) in target.iter().filter(|(c, _)| (*c >= nq) == velocity) {
            let mut e = vec![0.0; nq];
            e[c % nq] = 1.0;
            if add(e, &mut basis) {
                kept.push((c, value));
            }
        }
    }
    kept
}

/// The most an input's bound scales it, as a multiple of its warm
/// start's largest magnitude (at least 1).
const BOUND_SCALE: f64 = 100.0;

/// The program's scales: an input's its bounds' largest finite magnitude,
/// at most [`BOUND_SCALE`] times its guess's (without a bound its
/// guess's, at least 1); a state component's its largest magnitude over
/// the warm start's nodes and the target (at least 1); the objective the
/// effort of the inputs held at their scales over `T`, times its weight,
/// plus the magnitude of the user's term at the warm start (`user0`; the
/// effort's scale alone where that sum is 0).
pub(super) fn scales<M: Model>(
    plan: &Plan<M>,
    tr: &Transcription<M>,
    (x, user0): (&[Vec<f64>], f64),
    target: &[(usize, f64)],
) -> Scales {
    let n_seg = plan.settings.segments;
    let mesh = plan.mesh();
    let input_scale: Vec<f64> = plan
        .inputs
        .iter()
        .map(|i| {
            let b = [i.lower, i.upper].into_iter().filter(|v| v.is_finite()).fold(0.0f64, |m, v| m.max(v.abs()));
            let guess = mesh.iter().fold(1.0f64, |m, &t| m.max(i.guess.eval(t).abs()));
            // a bound far past the warm start says nothing of the input's
            // size: `|tau| <= 1e300` scaled the EzyRoller's torques to
            // 1e-300 and ended infeasible where no bound is optimal
            if b > 0.0 { b.min(BOUND_SCALE * guess) } else { guess }
        })
        .collect();
    let n2 = x[0].len();
    let state_scale: Vec<f64> = (0..n2)
        .map(|c| {
            let nodes = x.iter().fold(1.0f64, |m, xk| m.max(xk[c].abs()));
            target.iter().filter(|t| t.0 == c).fold(nodes, |m, t| m.max(t.1.abs()))
        })
        .collect();
    let mut w = vec![1.0; tr.n];
    for (c, s) in w.iter_mut().enumerate().take(tr.n_inputs()) {
        *s = input_scale[c / (n_seg + 1)];
    }
    for (col, comp) in tr.state_columns() {
        w[col] = state_scale[comp];
    }
    if tr.free_time {
        w[tr.col_t()] = plan.settings.t_end;
    }
    let c = tr.rows.iter().map(|(_, comp)| state_scale[*comp]).collect();
    // a state component's bound in its scale; a function's in its bounds'
    let g = tr
        .path_rows
        .iter()
        .map(|(row, _)| {
            let p = &tr.path[row.c];
            let bounds = [p.constraint.lower, p.constraint.upper].into_iter().filter(|v| v.is_finite());
            let own = bounds.fold(1.0f64, |m, v| m.max(v.abs()));
            p.comp.map_or(own, |comp| state_scale[comp].max(own))
        })
        .collect();
    let effort = input_scale.iter().map(|s| s * s).sum::<f64>() * plan.settings.t_end;
    let f = plan.objective.effort_weight * effort + plan.objective.time_weight * plan.settings.t_end + user0.abs();
    Scales { w, c, g, f: if f > 0.0 && f.is_finite() { f } else { effort } }
}
