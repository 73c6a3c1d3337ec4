//! Optimal maneuver planning on the EzyRoller (a module of `plan.rs`: one
//! test binary) (`ezy_core::plan`): from
//! rest to rest 1 m ahead with least squared hinge torque.

use ezy_core::effects::{HingeMotor, Table, Waveform};
use ezy_core::plan::{Input, Plan, PlanSettings, Target};
use ezy_core::{Method, Problem, SimError};

ezy_core::model! {
    /// The EzyRoller (as `models/src/ezyroller.rs`): a rear frame (skate
    /// A) and a steering fork (skate C) joined by a hinge at B.
    pub struct EzyRoller {
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

/// The `drive` scene's start (at rest, the fork turned back) with the
/// hinge motor's torque from the first table.
fn roller(tables: &[Table]) -> Result<Problem<EzyRoller>, SimError> {
    Problem::new(EzyRoller::default())
        .q("x1", 0.0)?
        .q("y1", 0.0)?
        .q("phi1", 0.0)?
        .q("phi2", std::f64::consts::PI)?
        .qd("x1", 0.0)?
        .qd("phi1", 0.0)?
        .method(Method::Dop853)
        .tolerances(1e-11, 1e-11)
        .effect("motor", HingeMotor { hinge: "B".into(), torque: Waveform::Table(tables[0].clone()) })
}

fn rest_to_rest(segments: usize, t_end: f64, evaluations: usize) -> ezy_core::plan::Maneuver {
    let target = Target::new().q("x1", 1.0).at_rest();
    // the drive scene's torque: from a constant, x1 moves only at second order
    let input = Input::new("tau", -10.0, 10.0).guess_waveform(Waveform::cos(2.0, std::f64::consts::PI));
    let settings = PlanSettings { max_evaluations: evaluations, ..PlanSettings::new(segments, t_end) };
    let plan = Plan::new(vec![input], target, settings, roller).unwrap();
    let m = plan.solve().unwrap();
    eprint!("{segments} segments: ");
    super::show(&m);
    m
}

/// From rest to rest 1 m ahead in 8 s with least squared hinge torque.
/// Not reached yet. Measured with 10 segments (65 unknowns, 57
/// equalities): 500 evaluations in 64 s, SLSQP converging linearly
/// (violation 2e-5 after 480) while the whole state jumped 0.19 m/s in
/// `x2d` at node 9 (a dependent velocity, from the two angular rates, the
/// fork near straight); with 1500 evaluations (39 s) the restarts with
/// the nodes partitioned again ended infeasible at 8.6e-3 (the
/// verification run 0.28 from the target); 20 segments (135 unknowns),
/// 1458 evaluations in 32 s, infeasible at 3.0e-2.
///
/// Tried since (2026-11-30, 2 cores), none reaches it: every inner
/// node's whole state as unknowns, started from its projection onto the
/// constraints (119 unknowns, 10 segments: infeasible 4.6e-2, SLSQP
/// limited by rounding after 333 evaluations; 20 segments 3.3e-2, 40
/// segments 1.7e-2 in 237 s); every target velocity as an equality
/// (dependent rows: a Newton KKT matrix singular, multipliers 1e16); a
/// Gauss-Newton SQP on the effort's exact Hessian with an L1 merit line
/// search (the linearized end moves x1 only to first order, the motion
/// is second order in the torque: steps of 100 N m rejected, the
/// violation 0.79 -> 0.61 in 44 iterations); single shooting
/// (`PlanSettings::intervals` = 1: 11 unknowns, 3 equalities, SLSQP
/// finds no descent at 9.5e-2; 20 segments: SLSQP's own iterate NaN) and
/// 4 intervals of 5 segments (5.3e-2); a homotopy of the target from the
/// warm start's own end, each step's nearest feasible point by
/// Levenberg-Marquardt (single shooting, 20 segments over 8 s: feasible
/// to 3e-6 a fifth of the way, 8.6e-3 at 0.3, 9.6e-2 at the end; 32
/// segments over 16 s: 1.5e-5 at 0.6, 2.4e-2 at 0.8, 4.7e-2 at the end).
/// Every failure ends with the frame's centre nearly still and the
/// vehicle turning (phi1d 0.2-0.5 rad/s): the at-rest rows kept (x1d,
/// y1d: the frame's centre) do not reach the turning, which the end
/// map's linearization there moves only weakly. The Jacobian is right
/// (`plan::tests`, 5e-8). The next step: the Lagrangian's curvature
/// (second-order sensitivities, an exact-Hessian SQP), and the rest rows
/// chosen at the end, not at the warm start. With `y1 = 0`, `phi1 = 0`
/// and `phi2 = pi` targeted too (the fork straight, away from the
/// spin about the rear skate; 20 segments, 600 evaluations, about 20 s
/// each): a node at every segment ends 9.3e-3 from the target with a
/// continuity violated by 6.9e-2; single shooting 0.13; 4 intervals
/// 7.6e-2.
#[test]
#[ignore = "SLSQP does not reach the EzyRoller's rest-to-rest plan yet (ill-conditioned partitions; slow quasi-Newton convergence)"]
fn roller_rest_to_rest_one_metre() {
    let m = rest_to_rest(10, 8.0, 1500);
    assert!(m.optimal(), "{:?}", m.status);
    let v = m.verification.as_ref().unwrap();
    assert!(v.max_run_error <= 1e-6, "{v:?}");
}

/// The premise of shooting: the segments' runs chained (each from the
/// last one's end, its clock from 0, its torque the table between its two
/// nodes) are the whole run with the piecewise-linear torque, to the
/// integration's accuracy (measured 2.9e-9 at 1e-11 over 8 s; 1.2e-10 at
/// 1e-13).
#[test]
fn chained_segments_are_the_whole_run() {
    let (n, t_end) = (10usize, 8.0);
    let h = t_end / n as f64;
    let mesh: Vec<f64> = (0..=n).map(|k| k as f64 * h).collect();
    let u: Vec<f64> = mesh.iter().map(|&t| 2.0 * (std::f64::consts::PI * t).cos()).collect();
    {
        let tol = 1e-11;
        let whole = roller(&[Table { t: mesh.clone(), value: u.clone(), extrapolate: Default::default() }])
            .unwrap()
            .tolerances(tol, tol)
            .t_end(t_end)
            .every(h)
            .solve()
            .unwrap();
        let names = ["x1", "y1", "phi1", "x2", "y2", "phi2"];
        let mut x: Vec<f64> = whole.y[0][..12].to_vec();
        for k in 0..n {
            let mut p =
                roller(&[Table { t: vec![0.0, h], value: vec![u[k], u[k + 1]], extrapolate: Default::default() }])
                    .unwrap()
                    .tolerances(tol, tol)
                    .t_end(h)
                    .every(h);
            for (i, name) in names.iter().enumerate() {
                p = p.q(name, x[i]).unwrap().qd(name, x[6 + i]).unwrap();
            }
            let s = p.solve().unwrap();
            x = s.final_state()[..12].to_vec();
            let w = &whole.y[k + 1];
            let d = (0..12).fold(0.0f64, |m, i| m.max((w[i] - x[i]).abs()));
            eprintln!("tol {tol:e} node {} t {}: max difference {d:.2e}", k + 1, whole.t[k + 1]);
            assert!(d <= 1e-8, "node {}: {d:e}", k + 1);
        }
    }
}

/// Time per evaluation (each N segment runs with sensitivities) of the
/// EzyRoller's plan at 10, 20 and 50 segments, a short budget each.
#[test]
#[ignore = "a measurement"]
fn roller_timings() {
    for n in [10, 20, 50] {
        let m = rest_to_rest(n, 8.0, 40);
        eprintln!("{n} segments: {:.3} s per evaluation", m.seconds / m.evaluations as f64);
    }
}
