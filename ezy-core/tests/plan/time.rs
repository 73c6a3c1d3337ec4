//! A free duration (`PlanSettings::free_time`): the sleigh pushed along
//! its skate from rest to rest 1 m ahead, in least time with `|F| <= 1 N`
//! against the discrete program's own optimum (a bang-bang force, its
//! duration in closed form) and the continuous one, and with the effort
//! plus the time against its closed form; refusals.

use ezy_core::plan::{Input, Objective, Plan, PlanSettings, Status, Target};

use super::{MASS, show, sleigh};

const D: f64 = 1.0;

fn plan(segments: usize, objective: Objective, bound: f64, (t0, lo, hi): (f64, f64, f64)) -> Plan<super::Sleigh> {
    let target = Target::new().q("x", D).at_rest();
    let settings = PlanSettings { free_time: Some((lo, hi)), ..PlanSettings::new(segments, t0) };
    Plan::with_objective(vec![Input::new("F", -bound, bound)], target, settings, objective, sleigh).unwrap()
}

/// The end `x_N` of `m x'' = F` from rest on `n` segments of `T = 1`,
/// `F` piecewise linear through `u` (exact: each segment's `x` gains
/// `v h + h^2 (2 u_k + u_k+1) / (6 m)`).
fn distance(u: &[f64]) -> f64 {
    let n = u.len() - 1;
    let h = 1.0 / n as f64;
    let (mut x, mut v) = (0.0, 0.0);
    for k in 0..n {
        x += v * h + h * h * (2.0 * u[k] + u[k + 1]) / (6.0 * MASS);
        v += h * (u[k] + u[k + 1]) / (2.0 * MASS);
    }
    x
}

/// Least time with `|F| <= 1`: continuous, bang-bang, `T* = 2 sqrt(m d /
/// F)` = 2.828 s. The discrete program (a piecewise-linear `F` on `N`
/// segments) is, for each `T`, a linear program in the nodes' forces
/// with one equality (rest at the end) beyond the bounds: its vertex
/// has every node at a bound but one, the middle one, 0 by symmetry:
/// `+1` before it, `-1` after. Its distance scales as `T^2`, so its
/// least time is `T_N = sqrt(d / x_N(1))` (`x_N(1)` from [`distance`]),
/// above `T*` by `O(1 / N)`. The plan: the time alone minimized from
/// 4 s, the duration free in [1, 10] s.
#[test]
fn least_time_is_the_bang_bang_force() {
    let t_star = 2.0 * (MASS * D / 1.0f64).sqrt();
    let mut last = f64::INFINITY;
    for n in [8usize, 16] {
        let m = plan(n, Objective::time(), 1.0, (4.0, 1.0, 10.0)).solve().unwrap();
        show(&m);
        let u: Vec<f64> = (0..=n).map(|k| (n / 2).cmp(&k) as i32 as f64).collect();
        let t_n = (D / distance(&u)).sqrt();
        eprintln!("{n} segments: T = {} s, the discrete optimum {t_n} s, the continuous {t_star} s", m.t_end);
        assert_eq!(m.status, Status::Optimal);
        // the middle node and T free, two equalities active: the
        // multipliers determined, every bound's sign read
        assert!(m.signs_checked);
        assert!((m.t_end - t_n).abs() <= 1e-8 * t_n, "T = {} against {t_n}", m.t_end);
        assert!((m.objective - m.t_end).abs() <= 1e-15 * m.t_end, "the objective is T: {}", m.objective);
        for (k, (a, b)) in m.inputs[0].value.iter().zip(&u).enumerate() {
            assert!((a - b).abs() <= 1e-6, "F at node {k}: {a} against {b}");
        }
        assert!((m.t.last().unwrap() - m.t_end).abs() <= 1e-15 && m.inputs[0].t.last() == Some(&m.t_end));
        assert!(t_n > t_star && t_n - t_star < last, "T_N falls toward T* as the mesh refines");
        last = t_n - t_star;
        let v = m.verification.as_ref().unwrap();
        assert!(v.max_run_error <= 1e-6, "{v:?}");
    }
}

/// The effort plus the time, `J = int F^2 dt + c T`: for each `T` the
/// least effort is `12 m^2 d^2 / T^3` (a force linear in time, exact on
/// any mesh), so `T* = (36 m^2 d^2 / c)^(1/4)` = 2 sqrt(3) s for c = 1
/// and `J* = 4 c T* / 3`. The plan from 2 s. `J` is flat at `T*` (`J''
/// = 576 / T*^5` = 1.16): an optimal status's first-order residual (at
/// most 1e-5 of the gradient's scale) leaves `T` known to about 1e-5,
/// `J` to its feasibility tolerance (1e-8, times a multiplier of 1).
#[test]
fn effort_plus_time_is_the_closed_form() {
    let c = 1.0;
    let t_star = (36.0 * MASS * MASS * D * D / c).powf(0.25);
    let m = plan(4, Objective::effort().time_weight(c), 100.0, (2.0, 0.5, 20.0)).solve().unwrap();
    show(&m);
    eprintln!("T = {} s against {t_star} s; J = {} against {}", m.t_end, m.objective, 4.0 * c * t_star / 3.0);
    assert_eq!(m.status, Status::Optimal);
    assert!((m.t_end - t_star).abs() <= 1e-5 * t_star, "T = {} against {t_star}", m.t_end);
    let j = 4.0 * c * t_star / 3.0;
    assert!((m.objective - j).abs() <= 1e-8 * j, "J = {} against {j}", m.objective);
    assert_eq!(m.objective_name, "effort + time");
}

#[test]
fn a_free_duration_is_refused_unless_well_posed() {
    let target = || Target::new().q("x", D).at_rest();
    let refused = |settings: PlanSettings, objective: Objective, words: &str| {
        let e = Plan::with_objective(vec![Input::new("F", -1.0, 1.0)], target(), settings, objective, sleigh)
            .unwrap_err()
            .to_string();
        assert!(e.contains(words), "{e}");
    };
    let free = |lo: f64, hi: f64| PlanSettings { free_time: Some((lo, hi)), ..PlanSettings::new(4, 2.0) };
    refused(PlanSettings::new(4, 2.0), Objective::time(), "the duration is fixed (t_end = 2 s)");
    refused(free(0.0, 3.0), Objective::time(), "give finite bounds 0 < lower");
    refused(free(3.0, 4.0), Objective::time(), "<= t_end (2 s) <= upper");
    refused(free(1.0, f64::INFINITY), Objective::time(), "free time's upper bound [s] = inf");
    refused(free(1.0, 1e300), Objective::time(), "free time's upper bound [s] = 1e300");
    refused(free(f64::NAN, 3.0), Objective::time(), "free time NaN:3");
    refused(free(1.0, 3.0), Objective::effort().time_weight(f64::NAN), "time_weight NaN");
    refused(free(1.0, 3.0), Objective::effort().effort_weight(0.0), "nothing to minimize");
}
