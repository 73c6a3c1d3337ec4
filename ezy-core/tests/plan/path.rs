//! Path constraints (`Plan::with_path`): the sleigh pushed along its
//! skate from rest to rest 1 m ahead in 2 s with its speed at most
//! 0.6 m/s at the nodes, against the discrete program's own optimum (an
//! active-set solution of its KKT system, independent of the planner)
//! and the continuous closed form; the same bound as a function of the
//! user's own, exact and differenced; an infeasible bound; refusals.

use ezy_core::plan::{Input, Maneuver, PathConstraint, Plan, PlanSettings, SampleGradient, Status, Target, UserValue};

use super::{MASS, show, sleigh};

const D: f64 = 1.0;
const T: f64 = 2.0;
const VMAX: f64 = 0.6;

fn plan(segments: usize, path: Vec<PathConstraint>) -> Plan<super::Sleigh> {
    let target = Target::new().q("x", D).at_rest();
    Plan::new(vec![Input::new("F", -100.0, 100.0)], target, PlanSettings::new(segments, T), super::sleigh)
        .unwrap()
        .with_path(path)
        .unwrap()
}

/// The discrete program by itself: `m x'' = F`, `F` piecewise linear
/// through the node values `u` (N + 1) on `N` segments of `h`; the
/// velocity `v_k = h / (2 m) sum_{i<k} (u_i + u_i+1)` and the end
/// `x_N = sum_i (v_i h + h^2 (2 u_i + u_i+1) / (6 m))` exact, the effort
/// `sum_i h/3 (u_i^2 + u_i u_i+1 + u_i+1^2)` exact; `x_N = d`, `v_N = 0`,
/// `v_k <= vmax` (k = 1 ... N). Solved by an active-set method on the
/// KKT system `[2H A^T; A 0] [u; lambda] = [0; b]` until every inactive
/// bound holds and every active multiplier is >= 0 (its optimality
/// certificate: the program is a convex QP). Returns `(u, effort)`.
fn discrete_optimum(n: usize, vmax: f64) -> (Vec<f64>, f64) {
    let h = T / n as f64;
    let nu = n + 1;
    let velocity = |k: usize| {
        let mut a = vec![0.0; nu];
        for i in 0..k {
            a[i] += h / (2.0 * MASS);
            a[i + 1] += h / (2.0 * MASS);
        }
        a
    };
    let mut end = vec![0.0; nu];
    for i in 0..n {
        for (e, v) in end.iter_mut().zip(velocity(i)) {
            *e += v * h;
        }
        end[i] += h * h * 2.0 / (6.0 * MASS);
        end[i + 1] += h * h / (6.0 * MASS);
    }
    let mut hess = nalgebra_lm::DMatrix::<f64>::zeros(nu, nu);
    for i in 0..n {
        hess[(i, i)] += 2.0 * h / 3.0;
        hess[(i + 1, i + 1)] += 2.0 * h / 3.0;
        hess[(i, i + 1)] += h / 3.0;
        hess[(i + 1, i)] += h / 3.0;
    }
    let eq = [(end, D), (velocity(n), 0.0)];
    let mut active: Vec<usize> = Vec::new();
    for _ in 0..4 * n {
        let rows: Vec<(Vec<f64>, f64)> =
            eq.iter().cloned().chain(active.iter().map(|&k| (velocity(k), vmax))).collect();
        let m = rows.len();
        let mut kkt = nalgebra_lm::DMatrix::<f64>::zeros(nu + m, nu + m);
        let mut rhs = nalgebra_lm::DVector::<f64>::zeros(nu + m);
        for r in 0..nu {
            for c in 0..nu {
                kkt[(r, c)] = 2.0 * hess[(r, c)];
            }
        }
        for (i, (a, b)) in rows.iter().enumerate() {
            for (c, v) in a.iter().enumerate() {
                kkt[(nu + i, c)] = *v;
                kkt[(c, nu + i)] = *v;
            }
            rhs[nu + i] = *b;
        }
        let sol = kkt.lu().solve(&rhs).expect("a regular KKT matrix");
        let u: Vec<f64> = sol.iter().take(nu).copied().collect();
        let lambda: Vec<f64> = sol.iter().skip(nu + 2).copied().collect();
        let speed = |k: usize| velocity(k).iter().zip(&u).map(|(a, b)| a * b).sum::<f64>();
        let worst = (1..n)
            .filter(|k| !active.contains(k))
            .map(|k| (speed(k) - vmax, k))
            .fold((1e-13, 0), |m, v| if v.0 > m.0 { v } else { m });
        let negative =
            lambda.iter().enumerate().fold((-1e-13, None), |m, (i, &l)| if l < m.0 { (l, Some(i)) } else { m });
        if let (_, Some(i)) = negative {
            active.remove(i);
        } else if worst.1 > 0 {
            active.push(worst.1);
        } else {
            let effort = (0..n).map(|i| h / 3.0 * (u[i] * u[i] + u[i] * u[i + 1] + u[i + 1] * u[i + 1])).sum();
            return (u, effort);
        }
    }
    panic!("the active-set method did not settle");
}

fn assert_matches(m: &Maneuver, n: usize) {
    let (u, effort) = discrete_optimum(n, VMAX);
    eprintln!("discrete optimum: effort {effort:.12e}, forces {u:?}");
    assert_eq!(m.status, Status::Optimal);
    assert!((m.effort - effort).abs() <= 1e-8 * effort, "effort {} against {effort}", m.effort);
    let scale = u.iter().fold(0.0f64, |a, b| a.max(b.abs()));
    for (k, (a, b)) in m.inputs[0].value.iter().zip(&u).enumerate() {
        assert!((a - b).abs() <= 1e-6 * scale, "F at node {k}: {a} against {b}");
    }
}

/// The speed bound changes the plan (unbounded, it peaks at
/// `1.5 d / T = 0.75` m/s), and the planner's optimum is the discrete
/// program's to 1e-8 in effort (its feasibility tolerance is 1e-8 in
/// the state's units, its stationarity 1e-5; the QP's optimum is unique,
/// its Hessian positive definite). The continuous optimum (a convex
/// problem, whose first-order conditions suffice): `F` linear to zero
/// at `t1 = 1.5 (T - d / vmax)` = 0.5 s, coasting at `vmax` until
/// `T - t1`, the cost `8 m^2 vmax^2 / (3 t1)` = 7.68 N^2 s. On 8
/// segments `t1` is a node, the continuous optimum is a piecewise-linear
/// force and the discrete program's optimum: equal to 1e-8. On 6 it is
/// not: the discrete optimum is 3 % dearer (7.92). The speed rises
/// monotonically to the coast in both, so between the nodes the
/// verification run finds it within its bound as well.
#[test]
fn a_speed_bound_at_the_nodes_is_the_discrete_programs_optimum() {
    let continuous = 8.0 * MASS * MASS * VMAX * VMAX / (3.0 * 1.5 * (T - D / VMAX));
    let free = 12.0 * D * D * MASS * MASS / T.powi(3);
    let m = plan(8, vec![PathConstraint::qd("x", f64::NEG_INFINITY, VMAX)]).solve().unwrap();
    show(&m);
    assert_matches(&m, 8);
    assert_eq!(m.inequalities, 8, "one upper bound at each of nodes 1 ... 8");
    eprintln!("effort {} (continuous optimum {continuous}, unbounded {free})", m.effort);
    assert!((m.effort - continuous).abs() <= 1e-8 * continuous);
    // the nodes' speeds within the bound, those of the coast on it
    let speeds: Vec<f64> = m.states.iter().map(|x| x[3]).collect();
    assert!(speeds.iter().all(|v| *v <= VMAX + 1e-8), "{speeds:?}");
    assert!(speeds[2..=6].iter().all(|v| (v - VMAX).abs() <= 1e-8), "{speeds:?}");
    let v = m.verification.as_ref().unwrap();
    assert!(v.max_run_error <= 1e-6);
    assert!(v.path_violation.0 <= 1e-8, "{:?}", v.path_violation);
    // with a node's state an unknown at every other segment (the bound
    // on both kinds of node: an unknown's and a chained one's)
    let mut p = plan(8, vec![PathConstraint::qd("x", f64::NEG_INFINITY, VMAX)]);
    p.settings.intervals = 4;
    let m = p.solve().unwrap();
    show(&m);
    assert_matches(&m, 8);

    let m = plan(6, vec![PathConstraint::qd("x", f64::NEG_INFINITY, VMAX)]).solve().unwrap();
    show(&m);
    assert_matches(&m, 6);
    eprintln!("6 segments: effort {} (continuous optimum {continuous})", m.effort);
    assert!(m.effort > free * 1.1, "the bound is active");
    assert!((m.effort - continuous).abs() <= 0.05 * continuous);
    let v = m.verification.as_ref().unwrap();
    assert!(v.path_violation.0 <= 1e-8, "{:?}", v.path_violation);
}

/// The same bound as a function of the user's own of one node's sample
/// (its gradient given, then differenced by ezy) plans the same forces;
/// the function is asked at node 0 as well (it may take the inputs).
/// A second function, `sin^2(pi t / h)` <= 0.5, holds at every node (0
/// there) and is exceeded between them by 0.5 at each segment's middle:
/// the verification run, sampled eight times per segment, finds that
/// excess (its closed form) where the plan's nodes cannot.
#[test]
fn a_bound_of_the_users_own_function_plans_the_same() {
    let exact = PathConstraint::function("speed", f64::NEG_INFINITY, VMAX, |s| {
        let mut g = SampleGradient::zeros(s);
        g.qd[0][0] = 1.0;
        Ok(UserValue { value: s.qd[0][0], gradient: Some(g) })
    });
    let h = T / 8.0;
    let hump = PathConstraint::function("hump", f64::NEG_INFINITY, 0.5, move |s| {
        let value = (std::f64::consts::PI * s.t[0] / h).sin().powi(2);
        Ok(UserValue { value, gradient: Some(SampleGradient::zeros(s)) })
    });
    let m = plan(8, vec![exact, hump]).solve().unwrap();
    show(&m);
    assert_matches(&m, 8);
    assert_eq!(m.inequalities, 18);
    let v = m.verification.as_ref().unwrap();
    eprintln!("verification: {:?}", v.path_violation);
    assert!((v.path_violation.0 - 0.5).abs() <= 1e-12, "{:?}", v.path_violation);
    assert!(v.path_violation.1.starts_with("hump = "), "{:?}", v.path_violation);
    assert!(!m.path_differenced);
    let differenced = PathConstraint::function("speed", f64::NEG_INFINITY, VMAX, |s| {
        Ok(UserValue { value: s.qd[0][0], gradient: None })
    });
    let m = plan(8, vec![differenced]).solve().unwrap();
    assert_matches(&m, 8);
    assert!(m.path_differenced);
}

/// A bound below the mean speed `d / T` cannot be met: infeasible, the
/// violation named, never optimal.
#[test]
fn a_bound_below_the_mean_speed_is_infeasible() {
    let mut p = plan(6, vec![PathConstraint::qd("x", f64::NEG_INFINITY, 0.4)]);
    p.settings.max_evaluations = 60;
    let m = p.solve().unwrap();
    show(&m);
    let Status::Infeasible { violation, constraint } = &m.status else { panic!("{:?}", m.status) };
    assert!(*violation > 1e-3, "{violation} at {constraint}");
    assert!(constraint.contains("path qd.x <= 0.4") || constraint.starts_with("target"), "{constraint}");
}

#[test]
fn bad_path_constraints_are_refused_by_name() {
    let refused = |path: PathConstraint, words: &str| {
        let target = Target::new().q("x", D).at_rest();
        let p = Plan::new(vec![Input::new("F", -100.0, 100.0)], target, PlanSettings::new(4, T), sleigh).unwrap();
        let e = match p.with_path(vec![path]) {
            Ok(p) => p.solve().unwrap_err().to_string(),
            Err(e) => e.to_string(),
        };
        assert!(e.contains(words), "{e}");
    };
    refused(PathConstraint::qd("x", f64::NAN, 1.0), "bounds NaN:1");
    refused(PathConstraint::qd("x", 2.0, 1.0), "the lower at most the upper");
    refused(PathConstraint::q("y", f64::NEG_INFINITY, f64::INFINITY), "nothing is bounded");
    refused(PathConstraint::q("z", -1.0, 1.0), "no coordinate `z`");
    refused(PathConstraint::q("y", f64::NEG_INFINITY, 1e300), "path constraint on q.y: bound = 1e300");
    refused(PathConstraint::qd("x", 0.1, 1.0), "the initial state has qd.x = 0");
    let failing = PathConstraint::function("g", 0.0, 1.0, |_| Err("no such sensor".into()));
    refused(failing, "path constraint `g` failed: no such sensor");
}
