//! Optimal maneuver planning (`ezy_core::plan`): the least-effort force
//! that moves a sleigh from rest to rest against its closed form, a start
//! of zero input that the solver must leave, an unreachable target
//! reported infeasible, and the requests refused; plans with a user's
//! objective (`plan/objective.rs`); path constraints (`plan/path.rs`); a
//! free duration (`plan/time.rs`).

#[path = "plan/objective.rs"]
mod objective;
#[path = "plan/path.rs"]
mod path;
#[path = "plan/roller.rs"]
mod roller;
#[path = "plan/time.rs"]
mod time;

use ezy_core::effects::{Force, Frame, Table, Waveform};
use ezy_core::plan::{Input, Maneuver, Plan, PlanSettings, Status, Target};
use ezy_core::{Method, Problem, SimError};

ezy_core::model! {
    /// A sleigh: one body on a skate behind its centre of mass.
    pub struct Sleigh {
        param m = 2.0;
        param I = 0.1;
        param a = 0.5;
        body s(x, y, phi) { mass: m, inertia: I }
        point P on s at (-a, 0);
        skate P: P along (1, 0);
    }
}

const MASS: f64 = 2.0;

/// The sleigh at rest at the origin, pushed along its skate by the force
/// `F(t)` of the first table at its centre of mass.
fn sleigh(tables: &[Table]) -> Result<Problem<Sleigh>, SimError> {
    let force = Force {
        at: "s".into(),
        fx: Waveform::Table(tables[0].clone()),
        fy: Waveform::Constant(0.0),
        frame: Frame::Body,
    };
    Problem::new(Sleigh::default())
        .q("x", 0.0)?
        .q("y", 0.0)?
        .q("phi", 0.0)?
        .qd("x", 0.0)?
        .qd("phi", 0.0)?
        .method(Method::Dop853)
        .tolerances(1e-12, 1e-12)
        .effect("push", force)
}

fn plan(bounds: (f64, f64), d: f64, t_end: f64, segments: usize) -> Plan<Sleigh> {
    let target = Target::new().q("x", d).at_rest();
    Plan::new(vec![Input::new("F", bounds.0, bounds.1)], target, PlanSettings::new(segments, t_end), sleigh).unwrap()
}

fn show(m: &Maneuver) {
    eprintln!(
        "status {:?}; {}; effort {:.12e}; violation {:.1e} ({}); stationarity {:.1e}; {} unknowns, {} equalities, {} evaluations, {} runs, {:.3} s",
        m.status,
        m.termination,
        m.effort,
        m.violation.0,
        m.violation.1,
        m.stationarity,
        m.unknowns,
        m.equalities,
        m.evaluations,
        m.runs,
        m.seconds
    );
    match &m.verification {
        Ok(v) => eprintln!(
            "verification: run error {:.2e}, plan error {:.2e}: {:?}",
            v.max_run_error, v.max_plan_error, v.errors
        ),
        Err(e) => eprintln!("verification failed: {e}"),
    }
}

/// Minimum effort from rest at 0 to rest at `d` in `T` for `m x'' = F`:
/// `F(t) = m (6 d / T^2) (1 - 2 t / T)`, cost `12 d^2 m^2 / T^3` (the
/// Euler-Lagrange equation `F'' = 0`). Linear in time, so a
/// piecewise-linear input on 4 segments represents it exactly.
#[test]
fn sleigh_rest_to_rest_matches_the_closed_form() {
    let (d, t_end) = (1.0, 2.0);
    let m = plan((-100.0, 100.0), d, t_end, 4).solve().unwrap();
    show(&m);
    assert_eq!(m.status, Status::Optimal);
    let cost = 12.0 * d * d * MASS * MASS / t_end.powi(3);
    assert!((m.effort - cost).abs() <= 1e-8 * cost, "effort {} against {cost}", m.effort);
    let force = |t: f64| MASS * 6.0 * d / (t_end * t_end) * (1.0 - 2.0 * t / t_end);
    let worst = m.t.iter().zip(&m.inputs[0].value).fold(0.0f64, |w, (t, u)| w.max((u - force(*t)).abs()));
    eprintln!("force nodes: largest difference from the closed form {worst:.2e} N (F(0) = {} N)", force(0.0));
    for (t, u) in m.t.iter().zip(&m.inputs[0].value) {
        assert!((u - force(*t)).abs() <= 1e-7 * force(0.0), "F({t}) = {u}, closed form {}", force(*t));
    }
    let v = m.verification.as_ref().unwrap();
    assert!(v.max_run_error <= 1e-6 && v.max_plan_error <= 1e-8, "{v:?}");
}

/// Shooting intervals coarser than a node at every segment (single
/// shooting, two intervals) solve the same program: the same effort (the
/// closed form's to 1e-8) and forces, fewer unknowns; a chained
/// segment's start differentiated through the chain (the solve converges
/// only with an exact Jacobian: Optimal needs stationarity 1e-5).
#[test]
fn coarser_shooting_intervals_give_the_same_plan() {
    let (d, t_end) = (1.0f64, 2.0f64);
    let cost = 12.0 * d * d * MASS * MASS / t_end.powi(3);
    let mut every = plan((-100.0, 100.0), d, t_end, 4);
    every.settings.intervals = 4;
    let full = every.solve().unwrap();
    show(&full);
    assert_eq!(full.status, Status::Optimal);
    assert!(
        (full.effort - cost).abs() <= 1e-8 * cost,
        "a node at every segment: effort {} against {cost}",
        full.effort
    );
    for intervals in [1, 2] {
        let mut p = plan((-100.0, 100.0), d, t_end, 4);
        p.settings.intervals = intervals;
        let m = p.solve().unwrap();
        show(&m);
        assert_eq!(m.status, Status::Optimal);
        assert!(m.unknowns < full.unknowns, "{} unknowns against {}", m.unknowns, full.unknowns);
        assert!((m.effort - cost).abs() <= 1e-8 * cost, "{intervals} intervals: effort {} against {cost}", m.effort);
        for (a, b) in m.inputs[0].value.iter().zip(&full.inputs[0].value) {
            assert!((a - b).abs() <= 1e-7 * b.abs().max(1.0), "{intervals} intervals: {a} against {b}");
        }
        let v = m.verification.as_ref().unwrap();
        assert!(v.max_run_error <= 1e-6 && v.max_plan_error <= 1e-8, "{v:?}");
    }
    let mut p = plan((-100.0, 100.0), d, t_end, 4);
    p.settings.intervals = 5;
    refused(Plan::new(p.inputs.clone(), p.target.clone(), p.settings, sleigh), "5 shooting intervals for 4 segments");
    p.settings.intervals = 0;
    refused(Plan::new(p.inputs.clone(), p.target.clone(), p.settings, sleigh), "0 shooting intervals");
}

/// Calls of the stop hooks of `a_stop_ends_the_search_at_once`, and
/// the call from which the second says stop.
static ASKED: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
static STOP_AT: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(usize::MAX);

/// A stop hook that counts its calls and says stop from `STOP_AT` on.
fn stop_at() -> bool {
    ASKED.fetch_add(1, std::sync::atomic::Ordering::Relaxed) >= STOP_AT.load(std::sync::atomic::Ordering::Relaxed)
}

/// The stop hook ends the search at once: stopped halfway through (by
/// the hook's calls of a whole search), the best point so far, said
/// stopped, never optimal, no verification run, fewer evaluations; a
/// hook that says stop before any point is evaluated ends it with
/// `Stopped`.
#[test]
fn a_stop_ends_the_search_at_once() {
    use std::sync::atomic::Ordering::Relaxed;
    let whole = plan((-100.0, 100.0), 1.0, 2.0, 4).stop_when(stop_at).solve().unwrap();
    assert!(whole.optimal() && !whole.stopped);
    let calls = ASKED.swap(0, Relaxed);
    STOP_AT.store(calls / 2, Relaxed);
    let m = plan((-100.0, 100.0), 1.0, 2.0, 4).stop_when(stop_at).solve().unwrap();
    show(&m);
    eprintln!("{calls} calls of the hook in the whole search, {} evaluations", whole.evaluations);
    assert!(m.stopped && !m.optimal(), "{:?}", m.status);
    assert!(m.termination.contains("stopped"), "{}", m.termination);
    assert!(m.verification.is_err());
    assert!(m.evaluations < whole.evaluations, "{} evaluations of {}", m.evaluations, whole.evaluations);
    let e = plan((-100.0, 100.0), 1.0, 2.0, 4).stop_when(|| true).solve().unwrap_err();
    assert!(matches!(e, ezy_core::analysis::AnalysisError::Stopped), "{e}");
}

/// From a zero input (the sleigh stays at rest: the warm start is its
/// start, every gradient of the effort zero) the solver must move: the
/// effort is positive and the target met by the verification run.
#[test]
fn a_zero_start_is_left() {
    let m = plan((f64::NEG_INFINITY, f64::INFINITY), 0.5, 1.0, 6).solve().unwrap();
    show(&m);
    assert_eq!(m.status, Status::Optimal);
    assert!(m.effort > 0.0 && m.evaluations > 1);
    let cost = 12.0 * 0.25 * MASS * MASS / 1.0;
    assert!((m.effort - cost).abs() <= 1e-8 * cost, "effort {} against {cost}", m.effort);
    let v = m.verification.as_ref().unwrap();
    assert!(v.max_run_error <= 1e-6 && v.max_plan_error <= 1e-8, "{v:?}");
}

/// Two evaluations (the start and one step) leave the zero start's
/// target unmet or its optimality unshown: never reported optimal.
#[test]
fn a_spent_budget_is_not_optimal() {
    let mut p = plan((-100.0, 100.0), 1.0, 2.0, 4);
    p.settings.max_evaluations = 2;
    let m = p.solve().unwrap();
    show(&m);
    assert!(!m.optimal(), "{:?}", m.status);
    assert!(matches!(m.status, Status::Infeasible { .. } | Status::NotConverged { .. }));
}

/// `|F| <= 0.1 N` moves the 2 kg sleigh from rest to rest at most
/// `a T^2 / 4 = 0.05 m` in 2 s: 1 m is out of reach, reported infeasible
/// with its violation (never optimal).
#[test]
fn an_unreachable_target_is_infeasible() {
    let m = plan((-0.1, 0.1), 1.0, 2.0, 4).solve().unwrap();
    show(&m);
    let Status::Infeasible { violation, constraint } = &m.status else { panic!("{:?}", m.status) };
    assert!(*violation > 0.1, "{violation} at {constraint}");
    assert!(!m.optimal());
}

fn refused(r: Result<Plan<Sleigh>, ezy_core::analysis::AnalysisError>, words: &str) {
    let e = r.unwrap_err().to_string();
    assert!(e.contains(words), "{e}");
}

#[test]
fn bad_requests_are_refused() {
    let target = || Target::new().q("x", 1.0).at_rest();
    let settings = PlanSettings::new(4, 2.0);
    refused(Plan::new(vec![Input::new("F", 1.0, -1.0)], target(), settings, sleigh), "input `F`: bounds 1:-1");
    refused(Plan::new(vec![Input::new("F", f64::NAN, 1.0)], target(), settings, sleigh), "input `F`: bounds NaN");
    refused(Plan::new(vec![Input::new("F", -1.0, 1.0)], target(), PlanSettings::new(0, 2.0), sleigh), "0 segments");
    refused(Plan::new(vec![Input::new("F", -1.0, 1.0)], target(), PlanSettings::new(4, 0.0), sleigh), "t_end = 0");
    refused(Plan::new(vec![], target(), settings, sleigh), "without inputs");
    refused(Plan::new(vec![Input::new("F", -1.0, 1.0)], Target::new(), settings, sleigh), "no target");
    refused(Plan::new(vec![Input::new("F", -1.0, 1.0)], Target::new().q("x", f64::NAN), settings, sleigh), "q.x = NaN");
    refused(Plan::new(vec![Input::new("F", -1.0, 1.0).guess(2.0)], target(), settings, sleigh), "guess 2");
    refused(Plan::new(vec![Input::new("F", -1.0, 1.0)], target(), PlanSettings::new(5000, 2.0), sleigh), "unknowns");
    let boxed = PlanSettings { state_box: f64::INFINITY, ..settings };
    refused(Plan::new(vec![Input::new("F", -1.0, 1.0)], target(), boxed, sleigh), "state_box inf");
    // refused by the solve, which knows the model
    let p = Plan::new(vec![Input::new("F", -1.0, 1.0)], Target::new().q("z", 1.0), settings, sleigh).unwrap();
    let e = p.solve().unwrap_err().to_string();
    assert!(e.contains("no coordinate `z`") && e.contains("x, y, phi"), "{e}");
    // a target beyond any number a run takes: refused at once, not searched
    for (t, culprit) in
        [(Target::new().q("x", 1e300), "target q.x = 1e300 is out of range"), (Target::new().q("phi", 1e7), "q.phi")]
    {
        let p = Plan::new(vec![Input::new("F", -1.0, 1.0)], t, settings, sleigh).unwrap();
        let e = p.solve().unwrap_err().to_string();
        assert!(e.contains(culprit), "{e}");
    }
    let small = PlanSettings { max_unknowns: 19, intervals: 4, ..settings };
    let p = Plan::new(vec![Input::new("F", -1.0, 1.0)], target(), small, sleigh).unwrap();
    let e = p.solve().unwrap_err().to_string();
    assert!(e.contains("20 unknowns") && e.contains("limit of 19"), "{e}");
    // a problem the inputs do not act on
    let inert =
        |_: &[Table]| sleigh(&[Table { t: vec![0.0, 1.0], value: vec![0.0, 0.0], extrapolate: Default::default() }]);
    let p = Plan::new(vec![Input::new("F", -1.0, 1.0)], target(), settings, inert).unwrap();
    let e = p.solve().unwrap_err().to_string();
    assert!(e.contains("do not act"), "{e}");
}
