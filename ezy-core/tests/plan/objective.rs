//! Plans with a user's objective (a module of `plan.rs`: one test binary)
//! (`ezy_core::plan::Objective`): the effort recomputed by the user from
//! the input samples plans as the built-in effort, its gradient given and
//! differenced; a penalty on the end state instead of a target (a free
//! end) against the linear-quadratic problem's closed form; a failing or
//! non-finite user term refused by name.

use ezy_core::plan::{Input, Maneuver, Objective, ObjectiveGradient, Plan, PlanSettings, Status, Target};
use ezy_core::plan::{SampleGradient, Samples, UserValue};

use super::{MASS, Sleigh, show, sleigh};

/// The effort `sum_k h_k/3 (u_k^2 + u_k u_k+1 + u_k+1^2)` of the
/// piecewise-linear input at the samples (`h_k = t_k+1 - t_k`), with its
/// gradient where `exact`.
fn effort_of_samples(exact: bool) -> Objective {
    Objective::user("effort of the samples", move |s: &Samples| {
        let mut g = SampleGradient::zeros(s);
        let mut value = 0.0;
        for k in 0..s.t.len() - 1 {
            let h3 = (s.t[k + 1] - s.t[k]) / 3.0;
            let (a, b) = (s.u[k][0], s.u[k + 1][0]);
            value += h3 * (a * a + a * b + b * b);
            g.u[k][0] += h3 * (2.0 * a + b);
            g.u[k + 1][0] += h3 * (a + 2.0 * b);
        }
        Ok(UserValue { value, gradient: exact.then_some(g) })
    })
    .effort_weight(0.0)
}

fn rest_to_rest(objective: Objective) -> Maneuver {
    let target = Target::new().q("x", 1.0).at_rest();
    let settings = PlanSettings::new(4, 2.0);
    let plan = Plan::with_objective(vec![Input::new("F", -100.0, 100.0)], target, settings, objective, sleigh).unwrap();
    let m = plan.solve().unwrap();
    show(&m);
    m
}

/// Oracle: the user's objective that recomputes the effort exactly from
/// the input samples, with the effort's weight 0, plans as the built-in
/// effort: the same forces and objective to 1e-8 relative, its gradient
/// the user's (exact) or differenced by ezy with respect to the samples
/// (said so in the result).
#[test]
fn the_effort_as_a_user_objective_plans_as_the_built_in_one() {
    let built_in = rest_to_rest(Objective::effort());
    assert_eq!(built_in.status, Status::Optimal);
    assert_eq!(built_in.objective_gradient, ObjectiveGradient::Exact);
    assert_eq!(built_in.objective, built_in.effort);
    let size = built_in.inputs[0].value.iter().fold(0.0f64, |m, u| m.max(u.abs()));
    for (exact, how) in [(true, ObjectiveGradient::Exact), (false, ObjectiveGradient::Differenced)] {
        let m = rest_to_rest(effort_of_samples(exact));
        assert_eq!(m.status, Status::Optimal, "exact {exact}");
        assert_eq!(m.objective_gradient, how);
        assert_eq!(m.objective_name, "effort of the samples");
        let worst =
            m.inputs[0].value.iter().zip(&built_in.inputs[0].value).fold(0.0f64, |w, (a, b)| w.max((a - b).abs()));
        let de = (m.objective - built_in.objective).abs() / built_in.objective;
        eprintln!(
            "gradient {}: forces within {:.2e} relative, objective {:.15e} against {:.15e} ({de:.2e} relative)",
            how.as_str(),
            worst / size,
            m.objective,
            built_in.objective
        );
        assert!(worst <= 1e-8 * size, "exact {exact}: {:?} against {:?}", m.inputs[0].value, built_in.inputs[0].value);
        assert!(de <= 1e-8, "exact {exact}: objective {} against {}", m.objective, built_in.objective);
        // the user's term is the effort at the same point
        let user = m.user_objective.unwrap();
        assert!((user - m.effort).abs() <= 1e-12 * m.effort, "{user} against {}", m.effort);
    }
}

/// `c (x(T) - d)^2` on the end's position: the user's term and its gradient.
fn end_penalty(c: f64, d: f64, exact: bool) -> Objective {
    Objective::user("end penalty", move |s: &Samples| {
        let n = s.q.len() - 1;
        let e = s.q[n][0] - d;
        let mut g = SampleGradient::zeros(s);
        g.q[n][0] = 2.0 * c * e;
        Ok(UserValue { value: c * e * e, gradient: exact.then_some(g) })
    })
}

/// Oracle: `m x'' = F` from rest, `min int_0^T F^2 dt + c (x(T) - d)^2`
/// with the end free (no target). Pontryagin: `H = F^2 + l1 v + l2 F /
/// m`, `l1' = 0`, `l2' = -l1`, so `F = -l2 / (2 m)` is linear in time, and
/// `l2(T) = 0` (`v(T)` free) makes `F(t) = a (T - t)`. Then `x(T) = a T^3
/// / (3 m)` and the effort `a^2 T^3 / 3`; with `k = T^3 / (3 m^2)`, the
/// cost `J(a) = a^2 m^2 k + c (a m k - d)^2` is least at
/// `a = c d / (m (1 + c k))`: `x(T) = d c k / (1 + c k)` and the cost
/// `c d^2 / (1 + c k)`.
/// The force is linear, so 4 segments hold it exactly: the plan's end
/// and objective to 1e-6 relative, the user's gradient exact and
/// differenced.
#[test]
fn an_end_penalty_without_target_matches_the_closed_form() {
    let (c, d, t_end) = (10.0, 1.0, 2.0);
    let k = t_end * t_end * t_end / (3.0 * MASS * MASS);
    let (x_end, cost) = (d * c * k / (1.0 + c * k), c * d * d / (1.0 + c * k));
    let a = c * d / (MASS * (1.0 + c * k));
    for exact in [true, false] {
        let plan = Plan::with_objective(
            vec![Input::new("F", f64::NEG_INFINITY, f64::INFINITY)],
            Target::new(),
            PlanSettings::new(4, t_end),
            end_penalty(c, d, exact),
            sleigh,
        )
        .unwrap();
        let m = plan.solve().unwrap();
        show(&m);
        assert_eq!(m.status, Status::Optimal, "exact {exact}");
        assert_eq!(m.equalities, 0);
        let x = m.states.last().unwrap()[0];
        eprintln!(
            "exact {exact}: x(T) {x:.12} against {x_end:.12} ({:.1e}), cost {:.12} against {cost:.12} ({:.1e})",
            (x - x_end).abs() / x_end,
            m.objective,
            (m.objective - cost).abs() / cost
        );
        assert!((x - x_end).abs() <= 1e-6 * x_end, "x(T) = {x} against {x_end}");
        assert!((m.objective - cost).abs() <= 1e-6 * cost, "cost {} against {cost}", m.objective);
        for (t, u) in m.t.iter().zip(&m.inputs[0].value) {
            assert!((u - a * (t_end - t)).abs() <= 1e-6 * a * t_end, "F({t}) = {u} against {}", a * (t_end - t));
        }
        // the verification run ends where the plan does
        let v = m.verification.as_ref().unwrap();
        assert!((v.end[0] - x).abs() <= 1e-6, "{v:?}");
    }
}

/// A user's term that fails or is not finite ends the solve with an error
/// naming it, not a plan; a free end without a user's term, and an effort
/// weight not finite or 0 alone, are refused.
#[test]
fn a_failing_user_objective_is_refused_by_name() {
    let settings = PlanSettings::new(4, 2.0);
    let input = || vec![Input::new("F", -100.0, 100.0)];
    let target = || Target::new().q("x", 1.0).at_rest();
    let solve = |objective: Objective| {
        Plan::with_objective(input(), target(), settings, objective, sleigh).unwrap().solve().unwrap_err().to_string()
    };
    let e = solve(Objective::user("broken", |_: &Samples| Err("no data".into())));
    assert!(e.contains("objective `broken` failed: no data"), "{e}");
    // finite at the warm start (F = 0), not after it
    let e = solve(Objective::user("blows up", |s: &Samples| {
        let v = if s.u.iter().any(|u| u[0] != 0.0) { f64::INFINITY } else { 0.0 };
        Ok(UserValue { value: v, gradient: Some(SampleGradient::zeros(s)) })
    }));
    assert!(e.contains("`blows up` returned inf (not finite)"), "{e}");
    let e = solve(Objective::user("nan slope", |s: &Samples| {
        let mut g = SampleGradient::zeros(s);
        g.u[3][0] = f64::NAN;
        Ok(UserValue { value: 1.0, gradient: Some(g) })
    }));
    assert!(e.contains("`nan slope`'s gradient with respect to u.F at node 3 (t = 1.5 s) is NaN"), "{e}");
    let refused = |r: Result<Plan<Sleigh>, ezy_core::analysis::AnalysisError>, words: &str| {
        let e = r.unwrap_err().to_string();
        assert!(e.contains(words), "{e}");
    };
    refused(Plan::with_objective(input(), Target::new(), settings, Objective::effort(), sleigh), "no target");
    refused(
        Plan::with_objective(input(), target(), settings, Objective::effort().effort_weight(f64::NAN), sleigh),
        "effort_weight NaN",
    );
    refused(
        Plan::with_objective(input(), target(), settings, Objective::effort().effort_weight(0.0), sleigh),
        "nothing to minimize",
    );
}
