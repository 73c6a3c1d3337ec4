//! Forward sensitivities of runs (`ezy_core::sensitivity`) against the
//! Chaplygin sleigh's closed form differentiated by hand and against
//! central differences of whole runs, for every explicit method, with
//! respect to scene, effect, model and initial-value parameters.

use crate::common;

use ezy::models::{ChaplyginSleigh, EzyRoller, scenes};
use ezy_core::sensitivity::{Derivative, Parameter, Sensitivities};
use ezy_core::{Method, Model, Problem};

/// The parameters `names` of a built-in scene's problem (as `ezy
/// sensitivity --wrt` takes them).
fn parameters<M: Model + Default>(scene: &ezy_scene::Scene, names: &[&str]) -> Vec<Parameter<M>> {
    names.iter().map(|n| scene.parameter(&M::default(), &[], n).unwrap()).collect()
}

/// `d(column)/dp` at the last sample from central differences of whole
/// runs at `p +- h` and `p +- h/2`, `h = 1e-4 max(1, |p|)`, extrapolated
/// (Richardson: error O(h^4), where a plain difference's O(h^2) was 2e-6
/// of the fork length's sensitivity, `c` = 0.12 m); the runs' own error,
/// about the tolerance 1e-13 relative, stays below 1e-8 of the result.
fn difference<M: Model>(param: &Parameter<M>, settings: &ezy_core::RunSettings, column: &str) -> f64 {
    let end = |v: f64| {
        let mut p = param.problem(v).unwrap();
        p.settings = *settings;
        *p.solve().unwrap().column(column).unwrap().last().unwrap()
    };
    let central = |h: f64| (end(param.value + h) - end(param.value - h)) / (2.0 * h);
    let h = 1e-4 * param.value.abs().max(1.0);
    (4.0 * central(h / 2.0) - central(h)) / 3.0
}

/// Largest relative disagreement between the sensitivity run's last
/// sample and differences of whole runs over `columns` and every
/// parameter, relative to the largest sensitivity of that parameter.
fn worst_against_differences<M: Model>(
    s: &Sensitivities,
    params: &[Parameter<M>],
    settings: &ezy_core::RunSettings,
    columns: &[&str],
) -> f64 {
    let mut worst: f64 = 0.0;
    for p in params {
        let got: Vec<f64> =
            columns.iter().map(|c| *s.column(&format!("d{c}/d{}", p.name)).unwrap().last().unwrap()).collect();
        let scale = common::max_abs(got.iter().copied()).max(1e-300);
        for (c, g) in columns.iter().zip(&got) {
            let want = difference(p, settings, c);
            let rel = (g - want).abs() / scale;
            assert!(rel.is_finite(), "{c}/{}: {g} against {want}", p.name);
            worst = worst.max(rel);
            if rel > 1e-6 {
                eprintln!("d{c}/d{}: {g:.12e} against {want:.12e} (rel {rel:.1e})", p.name);
            }
        }
    }
    worst
}

/// The sleigh's forward speed `u(t) = U tanh(k U t + s0)` with `U^2 =
/// u0^2 + (J/m) w0^2`, `s0 = atanh(u0/U)` (docs/physics.md §9)
/// differentiated by hand with respect to the initial speed `u0`:
/// `dU/du0 = u0/U`, `ds0/du0 = 1/U`, so `du/du0 = (u0/U) tanh z + (1 + k
/// t u0) sech^2 z` with `z = k U t + s0`. The run starts at heading 0,
/// so `u0` is the initial `x` velocity (`initial.qd.x`). RK4 at the
/// scene's `dt = 1e-4 s` integrates the state to 1e-12; the sensitivity
/// agrees to 1e-10 over the 10 s (measured 1.4e-14).
#[test]
fn sleigh_speed_sensitivity_is_the_closed_form_differentiated_by_hand() {
    let scene = scenes::sleigh();
    let (problem, _) = scene.problem::<ChaplyginSleigh>(&[]).unwrap();
    let s = problem.sensitivities(&["initial.qd.x"]).unwrap();
    assert_eq!(s.derivatives, vec![Derivative::InitialOnly]);
    let (u0, w0) = (1.0, 1.0);
    let (big_u, k, s0) = common::sleigh_closed_form(u0, w0);
    let col = |n: &str| s.column(n).unwrap();
    let (phi, xd, yd) = (col("phi"), col("xd"), col("yd"));
    let (dphi, dxd, dyd) = (col("dphi/dinitial.qd.x"), col("dxd/dinitial.qd.x"), col("dyd/dinitial.qd.x"));
    let mut worst: f64 = 0.0;
    for (i, &t) in s.t.iter().enumerate() {
        let (c, sn) = (phi[i].cos(), phi[i].sin());
        let du = dxd[i] * c + dyd[i] * sn + (-xd[i] * sn + yd[i] * c) * dphi[i];
        let z = k * big_u * t + s0;
        let want = u0 / big_u * z.tanh() + (1.0 + k * t * u0) / z.cosh().powi(2);
        worst = worst.max((du - want).abs());
    }
    eprintln!("sleigh: worst {worst:.1e}");
    assert!(worst < 1e-10, "du/du0 deviates from the closed form by {worst:e}");
    assert_eq!(*s.t.last().unwrap(), 10.0);
}

/// The EzyRoller's `drive` over 2 s: sensitivities with respect to the
/// motor's amplitude and frequency (scene parameters), the rear body's
/// mass (a model parameter: masses and nothing else), the fork length `c`
/// (a model parameter in the constraints) and the initial hinge angle,
/// against central differences of whole runs (DOP853 at 1e-13), to 1e-6
/// of the largest sensitivity, for DOP853, DOPRI5 and RK4 (and the
/// differences of RK4 runs at the same fixed step).
#[test]
fn drive_sensitivities_match_differences_of_whole_runs_for_every_method() {
    let mut scene = scenes::drive();
    scene.t_end = 2.0;
    let names = ["M0", "omega", "m2", "c", "initial.q.phi2"];
    let params = parameters::<EzyRoller>(&scene, &names);
    let columns = ["x1", "y1", "phi1", "phi2", "x1d", "phi2d"];
    for (method, tol, dt) in [(Method::Dop853, 1e-13, 1e-4), (Method::Dopri5, 1e-12, 1e-4), (Method::Rk4, 1e-9, 1e-3)] {
        let (mut problem, _) = scene.problem::<EzyRoller>(&[]).unwrap();
        problem.settings = ezy_core::RunSettings {
            method,
            rtol: tol,
            atol: tol,
            dt,
            formulation: ezy_core::Formulation::Dae,
            ..problem.settings
        };
        let params: Vec<Parameter<EzyRoller>> = params
            .iter()
            .map(|p| {
                let (settings, p) = (problem.settings, p.clone());
                Parameter::new(p.name.clone(), p.value, move |v| {
                    let mut q: Problem<EzyRoller> = p.problem(v)?;
                    q.settings = settings;
                    Ok(q)
                })
            })
            .collect();
        let s = problem.sensitivities_with(&params).unwrap();
        assert!(s.derivatives.iter().take(4).all(|d| matches!(d, Derivative::Central { .. })), "{:?}", s.derivatives);
        assert_eq!(s.derivatives[4], Derivative::InitialOnly);
        let worst = worst_against_differences(&s, &params, &problem.settings, &columns);
        eprintln!("{method:?}: worst {worst:.1e}");
        assert!(worst < 1e-6, "{method:?}: sensitivities disagree with differences of runs by {worst:.1e}");
    }
}
