//! The transcription's Jacobian against central differences of its
//! constraints, on the EzyRoller (written here with `model!`: the models
//! crate is out of ezy-core's reach), with a node at every segment, at
//! some and at none (single shooting); and the gradient of an objective
//! with a user's term of the samples against central differences of the
//! whole objective, the user's gradient given and differenced; the path
//! constraints' rows likewise; and all of them with the duration free
//! (its column: the segments' rates and their inputs' stretch).

use std::sync::Arc;

use super::objective::{Objective, SampleGradient, Samples, UserValue};
use super::transcription::Transcription;
use super::*;
use crate::Method;
use crate::effects::HingeMotor;

crate::model! {
    /// The EzyRoller (as `ezy_models::EzyRoller`).
    pub struct Roller {
        param a = 0.2;
        param b = 0.6;
        param c = 0.1;
        param d = 0.1;
        param m1 = 46.0;
        param I1 = 10.0;
        param m2 = 1.0;
        param I2 = 0.005;
        body body1(x1, y1, phi1) { mass: m1, inertia: I1 }
        body body2(x2, y2, phi2) { mass: m2, inertia: I2 }
        point A on body1 at (-a, 0);
        point B1 on body1 at (b, 0);
        point B2 on body2 at (-d, 0);
        point C on body2 at (c, 0);
        hinge B: B1 = B2;
        skate A: A along (1, 0);
        skate C: C along (1, 0);
    }
}

fn roller(tables: &[Table]) -> Result<Problem<Roller>, SimError> {
    Problem::new(Roller::default())
        .q("x1", 0.0)?
        .q("y1", 0.0)?
        .q("phi1", 0.0)?
        .q("phi2", std::f64::consts::PI)?
        .qd("x1", 0.0)?
        .qd("phi1", 0.0)?
        .method(Method::Dop853)
        .tolerances(1e-12, 1e-12)
        .effect("motor", HingeMotor { hinge: "B".into(), torque: Waveform::Table(tables[0].clone()) })
}

/// The transcription of a plan to `x1 = 1` at rest on 6 segments of
/// 0.5 s with `intervals` shooting intervals, and a point off its warm
/// start (the inputs and the nodes moved); path constraints on `qd.x1`
/// and on a function of the time, a coordinate and the input (its
/// gradient differenced); with `free`, the duration an unknown (3.02 s
/// at the point).
fn transcription(intervals: usize, free: bool) -> (Transcription<Roller>, Vec<f64>) {
    let (n, t_end) = (6usize, 3.0);
    let h = t_end / n as f64;
    let build: Arc<BuildInputs<Roller>> = Arc::new(roller);
    let plan = Plan::new(
        vec![Input::new("tau", -10.0, 10.0).guess_waveform(Waveform::cos(2.0, std::f64::consts::PI))],
        Target::new().q("x1", 1.0).at_rest(),
        PlanSettings { intervals, ..PlanSettings::new(n, t_end) },
        roller,
    )
    .unwrap();
    let mesh = plan.mesh();
    let guess: Vec<f64> = mesh.iter().map(|&t| plan.inputs[0].guess.eval(t)).collect();
    let first = check::problem(&plan, &guess).unwrap();
    let target = check::target(&first, &plan.target).unwrap();
    let x = plan.warm_start(&first, h, &guess).unwrap();
    let mut tr = Transcription::new(&build, vec!["tau".into()], (n, h, intervals), &first.model, &x).unwrap();
    if free {
        tr.free_time();
    }
    let mut w = guess;
    w.resize(tr.n, 0.0);
    tr.gather(&x, &mut w);
    if free {
        w[tr.col_t()] = t_end;
    }
    // off the warm start: the inputs and the nodes moved
    for (k, v) in w.iter_mut().enumerate() {
        *v += 0.01 * ((k as f64) * 1.7).sin();
    }
    tr.set_target(check::independent(&first.model, &x[n], &target));
    tr.t = mesh;
    let own = PathConstraint::function("g", -1.0, 1.0, |s: &Samples| {
        Ok(UserValue { value: s.q[0][0] * s.t[0] + 0.1 * s.u[0][0], gradient: None })
    });
    let path = [PathConstraint::qd("x1", f64::NEG_INFINITY, 0.5), own];
    tr.set_path(path::resolve(&first.model, &path, &x[0]).unwrap());
    (tr, w)
}

/// `w` with its unknown `k` moved by `+-step`, `step = 1e-6` of its size
/// (at least 1e-6): `(step, w + step e_k, w - step e_k)`.
fn shifted(w: &[f64], k: usize) -> (f64, Vec<f64>, Vec<f64>) {
    let step = 1e-6 * w[k].abs().max(1.0);
    let (mut a, mut b) = (w.to_vec(), w.to_vec());
    a[k] += step;
    b[k] -= step;
    (step, a, b)
}

/// The largest difference of the Jacobian from central differences of
/// the constraints (h = 1e-6 of each unknown's size), relative to the
/// column's largest entry.
fn jacobian_error(intervals: usize, free: bool) -> f64 {
    let (mut tr, w) = transcription(intervals, free);
    let p = tr.evaluate(&w).unwrap();
    assert_eq!(p.g.len(), 6 + 7 * 2, "qd.x1's upper bound at nodes 1 to 6, g's two at nodes 0 to 6");
    let mut worst = 0.0f64;
    for k in 0..tr.n {
        let (step, a, b) = shifted(&w, k);
        let (pa, pb) = (tr.evaluate(&a).unwrap(), tr.evaluate(&b).unwrap());
        let rows = p.jac.iter().chain(&p.g_jac);
        let size = rows.clone().fold(1e-3f64, |m, row| m.max(row[k].abs()));
        let (va, vb) = (pa.c.iter().chain(&pa.g), pb.c.iter().chain(&pb.g));
        for (i, ((row, a), b)) in rows.zip(va).zip(vb).enumerate() {
            let fd = (a - b) / (2.0 * step);
            let e = (fd - row[k]).abs() / size;
            if e > worst {
                eprintln!("unknown {k}, {}: jac {} fd {fd} ({e:.1e})", tr.row_name(i), row[k]);
            }
            worst = worst.max(e);
        }
    }
    eprintln!("{intervals} intervals, free time {free}, {} unknowns: largest relative error {worst:.2e}", tr.n);
    worst
}

/// Differences at h = 1e-6 with runs at 1e-12 are good to about 1e-6
/// relative; a wrong chain term (a missed product, the inputs' stretch
/// with a free duration) is of order 1.
#[test]
fn the_jacobian_is_the_constraints_derivative() {
    for (intervals, free) in [(6, false), (2, false), (1, false), (1, true), (2, true), (6, true)] {
        assert!(jacobian_error(intervals, free) <= 1e-5, "{intervals} intervals, free time {free}");
    }
}

/// A user's term of every kind of sample: the coordinates, a velocity at
/// every node, the input cubed and the fork's x at the end; its exact
/// gradient given where `exact`, else none (differenced by ezy).
fn user_term(exact: bool) -> Objective {
    Objective::user("test", move |s: &Samples| {
        let n = s.t.len() - 1;
        let mut value = (s.q[n][3] - 3.0).sin();
        let mut g = SampleGradient::zeros(s);
        g.q[n][3] = (s.q[n][3] - 3.0).cos();
        for k in 0..=n {
            let (x, w, u) = (s.q[k][0] - 0.2, s.qd[k][2], s.u[k][0]);
            value += 3.0 * x * x + w * w * (1.0 + s.t[k]) + 0.01 * u * u * u;
            g.q[k][0] += 6.0 * x;
            g.qd[k][2] += 2.0 * w * (1.0 + s.t[k]);
            g.u[k][0] += 0.03 * u * u;
        }
        Ok(UserValue { value, gradient: exact.then_some(g) })
    })
    .effort_weight(0.5)
}

/// The largest difference of the objective's gradient from central
/// differences of the whole objective (`effort_weight * effort + J_user`,
/// h = 1e-6 of each unknown's size), relative to the gradient's largest
/// entry.
fn objective_gradient_error(intervals: usize, exact: bool, free: bool) -> f64 {
    let (mut tr, w) = transcription(intervals, free);
    tr.objective = user_term(exact).time_weight(if free { 2.0 } else { 0.0 });
    let p = tr.evaluate(&w).unwrap();
    assert_eq!(tr.differenced, !exact);
    let time = if free { 2.0 * w[tr.col_t()] } else { 0.0 };
    assert!(p.user.is_some_and(|u| (p.objective - 0.5 * p.effort - time - u).abs() <= 1e-12 * p.objective.abs()));
    let size = p.objective_grad.iter().fold(1e-3f64, |m, g| m.max(g.abs()));
    let mut worst = 0.0f64;
    for k in 0..tr.n {
        let (step, a, b) = shifted(&w, k);
        let fd = (tr.evaluate(&a).unwrap().objective - tr.evaluate(&b).unwrap().objective) / (2.0 * step);
        let e = (fd - p.objective_grad[k]).abs() / size;
        if e > worst {
            eprintln!("unknown {k}: gradient {} fd {fd} ({e:.1e})", p.objective_grad[k]);
        }
        worst = worst.max(e);
    }
    eprintln!(
        "{intervals} intervals, exact {exact}, free time {free}: largest relative error of the objective's gradient {worst:.2e}"
    );
    worst
}

/// Differences at h = 1e-6 with runs at 1e-12 are good to about 1e-6
/// relative; a missed chain term (a node's state taken as fixed, the
/// user's gradient of a sample dropped) is of order 1.
#[test]
fn the_objective_gradient_is_the_objectives_derivative() {
    for (intervals, exact, free) in
        [(1, true, false), (2, true, false), (6, true, false), (1, false, false), (1, true, true), (6, false, true)]
    {
        assert!(
            objective_gradient_error(intervals, exact, free) <= 1e-5,
            "{intervals} intervals, exact {exact}, free {free}"
        );
    }
}

/// A user's term that is not finite, or fails, is refused naming it (the
/// gradient's entry by its sample).
#[test]
fn a_user_term_not_finite_is_refused_by_name() {
    let (mut tr, w) = transcription(1, false);
    tr.objective = Objective::user("nan", |_: &Samples| Ok(UserValue { value: f64::NAN, gradient: None }));
    let e = tr.evaluate(&w).unwrap_err().to_string();
    assert!(e.contains("`nan` returned NaN"), "{e}");
    tr.objective = Objective::user("grad", |s: &Samples| {
        let mut g = SampleGradient::zeros(s);
        g.qd[2][1] = f64::INFINITY;
        Ok(UserValue { value: 1.0, gradient: Some(g) })
    });
    let e = tr.evaluate(&w).unwrap_err().to_string();
    assert!(e.contains("with respect to qd.y1 at node 2 (t = 1 s) is inf"), "{e}");
    tr.objective = Objective::user("fails", |_: &Samples| Err("no such thing".into()));
    let e = tr.evaluate(&w).unwrap_err().to_string();
    assert!(e.contains("`fails` failed: no such thing"), "{e}");
}

/// The first-order check reads the multipliers' signs where they are
/// determined: `min f` subject to `w0 - w1 = 0`, `w` in `[0, 10]^2`, at
/// `w = (0, 5)` with `w0` on its lower bound and `w1` free. The free
/// column gives the equality's multiplier, `lambda = -df/dw1`; the
/// reduced gradient at `w0` is then `df/dw0 + df/dw1`, which must be >= 0
/// on a lower bound. For `f = w0 + w1` it is 2 (stationary); for `f =
/// -2 w0 + w1` it is -1: moving along the equality off the bound lowers
/// `f`, and the check says so (1, the wrong sign over `|grad f|` = 1).
#[test]
fn a_bound_multiplier_of_the_wrong_sign_is_not_stationary() {
    let point = |grad: [f64; 2]| transcription::Point {
        w: vec![0.0, 5.0],
        effort: 0.0,
        user: None,
        objective: 0.0,
        objective_grad: grad.to_vec(),
        user_grad: Vec::new(),
        acts: true,
        c: vec![0.0],
        jac: vec![vec![1.0, -1.0]],
        g: Vec::new(),
        g_jac: Vec::new(),
        starts: Vec::new(),
        ends: Vec::new(),
    };
    let sc = nlp::Scales { w: vec![1.0, 1.0], c: vec![1.0], g: Vec::new(), f: 1.0 };
    let bounds = [(0.0, 10.0), (0.0, 10.0)];
    assert!(nlp::stationarity(&point([1.0, 1.0]), &sc, &bounds, 1e-8).0 <= 1e-15);
    assert!(nlp::stationarity(&point([1.0, 1.0]), &sc, &bounds, 1e-8).1, "the signs read");
    // both unknowns on their bounds (a vertex): nothing free to determine
    // the multiplier, the residual 0 and the signs not read
    let vertex = transcription::Point { w: vec![0.0, 0.0], ..point([-2.0, 1.0]) };
    assert_eq!(nlp::stationarity(&vertex, &sc, &bounds, 1e-8), (0.0, false));
    let wrong = nlp::stationarity(&point([-2.0, 1.0]), &sc, &bounds, 1e-8).0;
    assert!((wrong - 1.0).abs() <= 1e-12, "{wrong}");
    // an active inequality's multiplier likewise: g = w0 - w1 <= 0 in
    // place of the equality, f = -w0 + 2 w1: lambda = 2 >= 0 (stationary);
    // f = w0 - 2 w1 (at w0's lower bound the reduced gradient -1 too)
    let ineq = |grad: [f64; 2]| transcription::Point {
        c: Vec::new(),
        jac: Vec::new(),
        g: vec![0.0],
        g_jac: vec![vec![1.0, -1.0]],
        ..point(grad)
    };
    let sc = nlp::Scales { c: Vec::new(), g: vec![1.0], ..sc };
    assert!(nlp::stationarity(&ineq([-1.0, 2.0]), &sc, &bounds, 1e-8).0 <= 1e-15);
    assert!(nlp::stationarity(&ineq([1.0, -2.0]), &sc, &bounds, 1e-8).0 >= 1.0);
}
