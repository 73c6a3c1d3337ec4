//! The run's divergence and energy guards (issue 38): measured against the
//! problem's own energies, silent on a bounded motion at any tolerance and
//! at any mass scale, and still stopping a run whose state blows up. The
//! simple pendulum of IFToMM benchmark A01 against its closed form.

use crate::common;

use std::f64::consts::{FRAC_PI_2, PI};

use common::Recorder;
use common::build;
use ezy_core::kkt::KktMethod;
use ezy_core::{Method, RunSettings, simulate};

use ezy_models::{ChaplyginSleigh, Pendulum, scenes};
use ezy_scene::InitValue;

/// `(K(k), sn(u, k))` for `0 <= k < 1` by the arithmetic-geometric mean and
/// the descending Landen transformation (Abramowitz & Stegun 16.4, 17.6):
/// `a0 = 1, b0 = sqrt(1 - k^2)`, `a, b <- (a + b) / 2, sqrt(a b)`,
/// `c = (a - b) / 2` until `c` is at rounding; `K = pi / (2 a_N)`,
/// `phi_N = 2^N a_N u`, `phi_(n-1) = (phi_n + asin(c_n / a_n sin phi_n)) / 2`,
/// `sn = sin phi_0`. `u` is first reduced modulo the period `4 K`.
fn jacobi(u: f64, k: f64) -> (f64, f64) {
    let (mut a, mut b) = (1.0f64, (1.0 - k * k).sqrt());
    let (mut an, mut cn) = (vec![a], vec![k]);
    while cn.last().unwrap().abs() > 1e-17 && an.len() < 30 {
        let c = (a - b) / 2.0;
        (a, b) = ((a + b) / 2.0, (a * b).sqrt());
        an.push(a);
        cn.push(c);
    }
    let kk = PI / (2.0 * a);
    let u = u - 4.0 * kk * (u / (4.0 * kk)).round();
    let n = an.len() - 1;
    let mut phi = 2f64.powi(n as i32) * a * u;
    for i in (1..=n).rev() {
        phi = (phi + (cn[i] / an[i] * phi.sin()).asin()) / 2.0;
    }
    (kk, phi.sin())
}

#[test]
fn jacobi_sn_and_k_match_known_values() {
    let k = 0.5f64.sqrt();
    let (kk, sn_k) = jacobi(0.0, k);
    assert!((kk - 1.8540746773013719).abs() < 1e-15, "K(1/sqrt 2) = {kk}");
    assert_eq!(sn_k, 0.0);
    assert!((jacobi(kk, k).1 - 1.0).abs() < 1e-15);
    // sn(K/2) = 1 / sqrt(1 + k'), k' = sqrt(1 - k^2)
    assert!((jacobi(kk / 2.0, k).1 - 1.0 / (1.0 + k).sqrt()).abs() < 1e-15);
    // sn(u, 0) = sin u, over many periods
    for u in [0.3, 2.0, 1234.5] {
        assert!((jacobi(u, 0.0).1 - u.sin()).abs() < 1e-12, "{u}");
    }
    // odd, 2K-antiperiodic
    assert!((jacobi(-0.7, k).1 + jacobi(0.7, k).1).abs() < 1e-15);
    assert!((jacobi(0.7 + 2.0 * kk, k).1 + jacobi(0.7, k).1).abs() < 1e-14);
}

/// IFToMM A01: `L` = 1 m, m = 1 kg, g = 9.81 m/s^2, released at rest with
/// the link horizontal. From the downward vertical, `theta0 = pi/2`,
/// `sin(theta/2) = k sn(K(k) - omega0 t, k)` with `k = sin(theta0/2)`,
/// `omega0 = sqrt(g/L)`; the point mass is at `L (sin theta, -cos theta)`.
fn a01_position(t: f64) -> [f64; 2] {
    let (l, g): (f64, f64) = (1.0, 9.81);
    let k = (FRAC_PI_2 / 2.0).sin();
    let (kk, _) = jacobi(0.0, k);
    let theta = 2.0 * (k * jacobi(kk - (g / l).sqrt() * t, k).1).asin();
    [l * theta.sin(), -l * theta.cos()]
}

/// The `pendulum` scene is benchmark A01: the point mass starts at (L, 0)
/// at rest, on the LU path (no inertia: a singular mass matrix); the
/// model's derived terms match finite differences and dual numbers.
#[test]
fn the_pendulum_scene_is_iftomm_a01() {
    let scene = scenes::get("pendulum");
    let (sys, y0) = build::<Pendulum>(&scene, &[], KktMethod::Auto).unwrap();
    assert_eq!(sys.kkt_name(), "dense-lu");
    assert_eq!(sys.mass[..3], [1.0, 1.0, 0.0]);
    assert!((y0[0] - 1.0).abs() < 1e-15 && y0[1].abs() < 1e-15, "{y0:?}");
    assert!(y0[3..6].iter().all(|v| *v == 0.0));
    ezy::testing::assert_derivatives(&Pendulum::default());
    let [x, y] = a01_position(0.0);
    assert!((x - 1.0).abs() < 1e-15 && y.abs() < 1e-15, "{x}, {y}");
}

/// A01 at rtol = atol = 1e-5 runs its 2000 s through `ezy run` (with the
/// energy guard on): the 0.054 J the tolerance lets the energy drift is
/// 5.5e-3 of the pendulum's 9.81 J, and the run ends without a note.
/// Before the guard measured against the run's own energies, it stopped at
/// t = 393 s: "the solution itself grows without bound".
#[test]
fn a01_at_a_loose_tolerance_runs_to_its_end() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("a01");
    let argv = [
        "ezy",
        "run",
        "pendulum",
        "--t-end",
        "2000",
        "--rtol",
        "1e-5",
        "--atol",
        "1e-5",
        "--every",
        "10",
        "--no-figures",
        "--out",
        out.to_str().unwrap(),
    ];
    let mut text = Vec::new();
    ezy::App::new().run_cli(argv, &mut text).unwrap_or_else(|e| panic!("{e}"));
    let csv = std::fs::read_to_string(out.join("trajectory.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 201);
    assert!(csv.lines().last().unwrap().starts_with("2000"), "{}", csv.lines().last().unwrap());
}

/// A01 at rtol = atol = 1e-10 against the closed form: the point mass
/// within 1e-4 m of `L (sin theta, -cos theta)` at every second of the
/// 2000 s (845 periods). Measured: 1.2e-5 m at most (at t = 1999 s), 0.36 s
/// for the run (37166 steps; release build, one thread).
#[test]
fn a01_at_a_tight_tolerance_follows_the_closed_form() {
    let scene = scenes::get("pendulum");
    let (mut sys, y0) = build::<Pendulum>(&scene, &[], KktMethod::Auto).unwrap();
    let settings = RunSettings { t_end: 2000.0, every: 1.0, rtol: 1e-10, atol: 1e-10, ..scene.run_settings() };
    assert_eq!(settings.method, Method::Dop853);
    let mut rec = Recorder::default();
    let clock = std::time::Instant::now();
    let s = simulate(&mut sys, &y0, &settings, &mut rec).unwrap();
    let elapsed = clock.elapsed().as_secs_f64();
    assert_eq!(rec.t.len(), 2001);
    let mut worst = (0.0f64, 0.0);
    for (t, y) in rec.t.iter().zip(&rec.y) {
        let [x, z] = a01_position(*t);
        let e = (y[0] - x).hypot(y[1] - z);
        if e > worst.0 {
            worst = (e, *t);
        }
    }
    eprintln!(
        "A01 at 1e-10: position error {:.3e} m at t = {} s, |T - T0 - W| = {:.3e} J, {} steps, {elapsed:.3} s",
        worst.0, worst.1, s.max_energy_error, s.steps
    );
    assert!(worst.0 < 1e-4, "position error {:e} m at t = {} s", worst.0, worst.1);
    assert!(s.energy_drift.is_none());
}

/// A01 at rtol = atol = 1e-3: the tolerance lets the energy drift beyond
/// 1e-2 of the pendulum's 9.81 J (0.28 J by 2000 s), which is said once
/// in a note, and the run goes to its end. Before, this stopped at t = 13 s.
#[test]
fn a01_drifting_at_a_loose_tolerance_gets_a_note() {
    let scene = scenes::get("pendulum");
    let (mut sys, y0) = build::<Pendulum>(&scene, &[], KktMethod::Auto).unwrap();
    let settings = RunSettings { t_end: 2000.0, every: 10.0, rtol: 1e-3, atol: 1e-3, ..scene.run_settings() };
    let mut rec = Recorder::default();
    let s = simulate(&mut sys, &y0, &settings, &mut rec).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(*rec.t.last().unwrap(), 2000.0);
    let (t, relative) = s.energy_drift.expect("the drift is recorded");
    assert!(t > 1.0 && relative > 1e-2 && relative < 2e-2, "{t} s, {relative:e}");
    assert_eq!(rec.notes.len(), 1, "{:?}", rec.notes);
    // `rtol` as a library spells it, whatever the command-line tests of
    // this binary do on other threads (a spelling is scoped to its call)
    let note = &rec.notes[0];
    assert!(note.contains("a tighter `rtol` keeps the energy"), "{note}");
}

/// The Chaplygin sleigh with m = I = 1e14 (the scene's RK4 at h = 1e-4 s,
/// energy guard on) runs, and its trajectory is that of m = I = 1: the
/// motion does not depend on a common mass scale. Before, it stopped at
/// t = 6e-4 s: one ulp of T = 1e14 J (0.0156 J) against an absolute 1 J.
/// Measured: 4.3e-15 relative.
#[test]
fn a_sleigh_of_1e14_kg_moves_as_one_of_1_kg() {
    let scene = scenes::sleigh();
    let run = |m: f64| {
        let sets = [("m".to_string(), m), ("I".to_string(), m)];
        let (mut sys, y0) = build::<ChaplyginSleigh>(&scene, &sets, KktMethod::Auto).unwrap();
        let settings = RunSettings { every: 0.1, ..scene.run_settings() };
        assert!(settings.balance_limit.is_some());
        let mut rec = Recorder::default();
        simulate(&mut sys, &y0, &settings, &mut rec).unwrap_or_else(|e| panic!("m = I = {m:e}: {e}"));
        rec
    };
    let (light, heavy) = (run(1.0), run(1e14));
    assert_eq!(light.t.len(), 101);
    assert_eq!(light.t, heavy.t);
    let mut worst = 0.0f64;
    for (a, b) in light.y.iter().zip(&heavy.y) {
        // q and qd (the work states are absent: no effects)
        for k in 0..6 {
            worst = worst.max((a[k] - b[k]).abs() / a[k].abs().max(1.0));
        }
    }
    eprintln!("sleigh m = I = 1e14 against 1: {worst:.3e} relative");
    assert!(worst < 1e-9, "{worst:e}");
    let ratio = heavy.kinetic.last().unwrap() / light.kinetic.last().unwrap();
    assert!((ratio / 1e14 - 1.0).abs() < 1e-9, "{ratio:e}");
}

/// Energies at the rounding level are no reason to stop: a pendulum
/// hanging at rest (T ~ 1e-37 J, all noise) and one released from the
/// horizontal with explicit Euler (whose first step does no work at all,
/// W = 0 against T = (h g)^2 / 2) are measured against the work gravity
/// can do over the link, m g L = 9.81 J.
#[test]
fn a_pendulum_at_rest_or_starting_from_rest_is_not_stopped() {
    let mut scene = scenes::get("pendulum");
    for (phi, method) in [(-FRAC_PI_2, Method::Rk4), (-FRAC_PI_2, Method::Euler), (0.0, Method::Euler)] {
        scene.initial.q = vec![("phi".into(), InitValue::Num(phi))];
        let (mut sys, y0) = build::<Pendulum>(&scene, &[], KktMethod::Auto).unwrap();
        let settings = RunSettings { t_end: 1.0, dt: 1e-4, every: 0.1, method, ..scene.run_settings() };
        let mut rec = Recorder::default();
        simulate(&mut sys, &y0, &settings, &mut rec).unwrap_or_else(|e| panic!("phi = {phi}, {method:?}: {e}"));
    }
}

/// A fixed step far too large for the stiff four-bar is still stopped:
/// at h = 1e-2 s by the energy balance (93 % of the run's energy made by
/// the integration), at h = 0.1 s by the kinetic energy growing 5e6 times
/// beyond all the energy the run was given; both name the step.
#[test]
fn a_step_too_large_for_a_stiff_scene_is_still_stopped() {
    let scene = scenes::get("four-bar-stiff");
    for (h, want) in
        [(1e-2, "the energy balance |T - T0 - W| relative to the run's energy scale"), (0.1, "the state diverged")]
    {
        let (mut sys, y0) = build::<ezy_models::ElasticFourBar>(&scene, &[], KktMethod::Auto).unwrap();
        // the DAE's guards (auto takes minimal coordinates here, where the
        // energy balance stops both steps)
        let settings =
            RunSettings { dt: h, method: Method::Rk4, formulation: ezy_core::Formulation::Dae, ..scene.run_settings() };
        let mut rec = Recorder::default();
        let e = simulate(&mut sys, &y0, &settings, &mut rec).unwrap_err().to_string();
        assert!(e.contains(want) && e.contains(&format!("the step h = {h} s is too large")), "{h}: {e}");
        assert!(!e.contains("NaN") && !e.contains("inf"), "{e}");
        assert!(rec.y.iter().flatten().all(|v| v.is_finite()));
    }
}

/// A force law that grows without bound (a spring of negative stiffness
/// pushing the sleigh away: x ~ e^(10 t)) overflows at t = 35 s; the
/// message says the solution itself grows, for the adaptive methods and,
/// since the energy balance held to the end, for RK4 too (before, RK4's
/// was "the step h = 0.001 s is too large").
#[test]
fn a_force_law_growing_without_bound_is_named_as_the_cause() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("runaway.toml");
    std::fs::write(
        &file,
        r#"name = "runaway"
description = "the sleigh pushed away from a ground point by a spring of negative stiffness"
model = "chaplygin_sleigh"
t_end = 100.0

[initial]
q = { x = 0.0, y = 0.0, phi = 0.0 }
qd = { x = 1.0, phi = 0.0 }

[integrator]
method = "dop853"

[output]
every = 1.0

[effects.push]
kind = "spring-damper"
from = "sleigh"
to = "ground(-1, 0)"
stiffness = -100.0
rest_length = 0.0
damping = 0.0
"#,
    )
    .unwrap();
    for method in ["dop853", "rk4"] {
        let out = dir.path().join(method);
        let argv = [
            "ezy",
            "run",
            file.to_str().unwrap(),
            "--integrator",
            method,
            "--dt",
            "1e-3",
            "--no-figures",
            "--out",
            out.to_str().unwrap(),
        ];
        let e = ezy::App::new().run_cli(argv, &mut Vec::new()).unwrap_err().to_string();
        // DOP853's stages near overflow meet the regularized KKT solve and
        // it ends by its step size (open: it should say "grows" too)
        let grows = e.contains("the solution itself grows without bound");
        assert!(grows || (method == "dop853" && e.contains("the step size fell to")), "{method}: {e}");
        assert!(!e.contains("is too large"), "{method}: {e}");
        assert!(!out.join("trajectory.csv").exists(), "{method}");
    }
}
