//! The mechanisms against checks that do not come from ezy: the four-bar's
//! output angle against Freudenstein's equation, the slider-crank's piston
//! against the closed form of its position, the double pendulum's small
//! oscillations against the frequencies of its linearization and its
//! energy against conservation, the IFToMM N-four-bar against the
//! equation of its one-degree-of-freedom parallelogram motion; the
//! assembly from a hinge angle on the branch nearest the starting values;
//! and every model's derived terms against finite differences and dual
//! numbers.

use crate::common;

use common::setup;
use ezy_core::kkt::KktMethod;
use ezy_core::{Dynamics, EffectSpec, Method, Model, ProjectionKind, RunSettings, simulate};
use ezy_models::{DoublePendulum, FourBar, NFourBar, SliderCrank, scenes};

/// Runs a built-in scene with its own settings, keeping every sample.
fn run_scene<M: Model + Default>(name: &str) -> (ezy_core::Summary, common::Recorder, common::Setup<M>) {
    run_scene_as(name, scenes::get(name).run_settings().formulation)
}

/// [`run_scene`] in `formulation`.
fn run_scene_as<M: Model + Default>(
    name: &str,
    formulation: ezy_core::Formulation,
) -> (ezy_core::Summary, common::Recorder, common::Setup<M>) {
    let scene = scenes::get(name);
    let s = setup::<M>(&scene, &[]).unwrap();
    let mut sys = Dynamics::new(s.model.clone(), s.effects.clone(), KktMethod::Auto).with_drives(s.drives.clone());
    let settings = RunSettings { balance_limit: None, max_steps: None, formulation, ..scene.run_settings() };
    let mut rec = common::Recorder::default();
    let summary = simulate(&mut sys, &s.y0, &settings, &mut rec).unwrap();
    (summary, rec, s)
}

#[test]
fn mechanisms_match_finite_differences_and_dual_numbers() {
    ezy::testing::assert_derivatives(&FourBar::default());
    ezy::testing::assert_derivatives(&SliderCrank::default());
    ezy::testing::assert_derivatives(&DoublePendulum::default());
    ezy::testing::assert_derivatives(&NFourBar::default());
}

/// Freudenstein's equation for the four-bar with crank `a`, coupler `b`,
/// rocker `c`, ground `d`, input angle `theta2` and output angle `theta4`
/// (both from the ground line O2 -> O4):
/// `K1 cos(theta4) - K2 cos(theta2) + K3 = cos(theta2 - theta4)` with
/// `K1 = d/a`, `K2 = d/c`, `K3 = (a^2 - b^2 + c^2 + d^2) / (2 a c)`
/// (Freudenstein, *Trans. ASME* 77, 1955). It holds at every sample of the
/// `four-bar` scene (10 s, the crank turning some 12 times) to 1e-9: the
/// residual of a solution on the constraints to 1e-12 m of links of 0.1
/// m is about 1e-11.
#[test]
fn the_four_bar_follows_freudenstein() {
    let (summary, rec, s) = run_scene::<FourBar>("four-bar");
    let m = &s.model;
    let (k1, k2, k3) = (m.d / m.a, m.d / m.c, (m.a * m.a - m.b * m.b + m.c * m.c + m.d * m.d) / (2.0 * m.a * m.c));
    let mut worst = 0.0f64;
    for y in &rec.y {
        let (t2, t4) = (y[2], y[8]);
        worst = worst.max((k1 * t4.cos() - k2 * t2.cos() + k3 - (t2 - t4).cos()).abs());
    }
    eprintln!("four-bar: Freudenstein residual {worst:e}, ledger {:e} J", summary.max_energy_error);
    assert!(worst <= 1e-9, "Freudenstein residual {worst:e}");
    let turns = (rec.y.last().unwrap()[2] - rec.y[0][2]) / std::f64::consts::TAU;
    assert!(turns > 10.0, "the crank turns fully: {turns} turns");
    assert!(summary.max_energy_error <= 1e-9, "ledger {:e}", summary.max_energy_error);
    // assembled from theta_O2 = 0.5 on the open branch (the starting values)
    assert_eq!(s.y0[2], 0.5);
    assert!((s.y0[8] - 1.4625932).abs() < 1e-6, "open branch: phi4 = {}", s.y0[8]);
    assert_eq!(s.initial.branch.len(), 2);
}

/// Starting values pick the assembly branch: the crossed four-bar from
/// starting values near it, with the same crank angle; and a hinge angle
/// given with a starting value for a given coordinate is refused.
#[test]
fn starting_values_pick_the_assembly_branch() {
    let scene = scenes::get("four-bar");
    let mut crossed = scene.clone();
    crossed.initial.guess =
        vec![("phi3".into(), ezy_scene::InitValue::Num(-1.2)), ("phi4".into(), ezy_scene::InitValue::Num(-1.9))];
    let s = setup::<FourBar>(&crossed, &[]).unwrap();
    // the crossed branch: theta4 = 4.3762700 - 2 pi
    assert!((s.y0[8] - (4.37627 - std::f64::consts::TAU)).abs() < 1e-5, "crossed: phi4 = {}", s.y0[8]);
    assert_eq!(s.y0[2], 0.5);
    assert!(s.initial.notes()[0].contains("phi4 = -1.90"), "{:?}", s.initial.notes());
    let mut both = scene.clone();
    both.initial.q.push(("phi3".into(), ezy_scene::InitValue::Num(0.8)));
    let err = setup::<FourBar>(&both, &[]).unwrap_err().to_string();
    assert!(err.contains("`phi3` is given in `initial.q`, so it is fixed"), "{err}");
}

/// The slider-crank's piston: `x = r cos(theta) + sqrt(l^2 - r^2
/// sin^2(theta))` for the crank angle `theta` (zero offset: the triangle
/// O-A-B with B on the x axis), at every sample of the `slider-crank`
/// scene (5 s, gravity, the crank spinning) to 1e-9 m (measured about
/// 2e-12 m), and the ledger `T - T(0) = W_gravity` to 1e-9 J.
#[test]
fn the_slider_crank_piston_follows_the_closed_form() {
    let (summary, rec, s) = run_scene::<SliderCrank>("slider-crank");
    let (r, l) = (s.model.r, s.model.l);
    let mut worst = 0.0f64;
    for y in &rec.y {
        let th = y[2];
        let x = r * th.cos() + (l * l - (r * th.sin()).powi(2)).sqrt();
        worst = worst.max((y[6] - x).abs());
        assert!(y[7].abs() <= 1e-12 && y[8].abs() <= 1e-12, "the piston stays on its line, heading 0");
    }
    eprintln!("slider-crank: piston {worst:e} m, ledger {:e} J", summary.max_energy_error);
    assert!(worst <= 1e-9, "piston against the closed form: {worst:e} m");
    assert!(summary.max_energy_error <= 1e-9, "ledger {:e}", summary.max_energy_error);
    assert!(rec.y.last().unwrap()[2] > 30.0, "the crank turned: {}", rec.y.last().unwrap()[2]);
}

/// The double pendulum's energy is conserved to the integrator's
/// tolerance over the chaotic `double-pendulum` scene (rtol 1e-11):
/// `|T - T(0) - W_gravity| <= 1e-9 J` of some 10 J exchanged in the DAE;
/// on the two angles (auto's minimal coordinates, where the error is
/// controlled on 4 components instead of 12 and the steps are longer)
/// 1.78e-9 J was measured, bounded at 3e-9 J.
#[test]
fn the_double_pendulum_conserves_its_energy() {
    use ezy_core::Formulation;
    for (formulation, bound, minimal) in [(Formulation::Dae, 1e-9, false), (Formulation::Auto, 3e-9, true)] {
        let (summary, rec, _) = run_scene_as::<DoublePendulum>("double-pendulum", formulation);
        let exchanged = rec.kinetic.iter().fold(0.0f64, |m, t| m.max(*t));
        eprintln!("double pendulum, {formulation:?}: T up to {exchanged} J, ledger {:e} J", summary.max_energy_error);
        assert_eq!(summary.minimal_coordinates, minimal, "{formulation:?}");
        assert!(exchanged > 5.0, "it swings: T up to {exchanged} J");
        assert!(summary.max_energy_error <= bound, "{formulation:?}: ledger {:e} J", summary.max_energy_error);
    }
}

/// Small oscillations of the double pendulum about hanging straight down,
/// started in each normal mode of the linearization with amplitude 1e-4
/// rad: the angular frequency from the zero crossings of the upper bar's
/// angle over 10 periods equals the closed form to 1e-7 (the amplitude's
/// nonlinear shift is about 1e-9; a crossing is located by linear
/// interpolation between 0.2 ms samples, exact to third order at a zero).
///
/// Linearization in the absolute angles `theta_i` from the vertical
/// (Goldstein, *Classical Mechanics*, small oscillations): `M theta'' + K theta = 0`
/// with `M = [[I1 + m1 L1^2/4 + m2 L1^2, m2 L1 L2/2], [m2 L1 L2/2, I2 + m2
/// L2^2/4]]`, `K = diag((m1/2 + m2) g L1, m2 g L2/2)`, `I_i = m_i L_i^2/12`;
/// `det(K - w^2 M) = 0`.
#[test]
fn small_oscillations_match_the_linearized_frequencies() {
    let m = DoublePendulum::default();
    let (l1, l2) = (m.L1, m.L2);
    let (mm, kk, roots) = common::double_pendulum_modes(&m);
    let gravity: EffectSpec = toml::from_str("kind = \"gravity\"").unwrap();
    for w2 in roots {
        let w = w2.sqrt();
        // mode shape from the first row of (K - w^2 M) v = 0
        let v = [w2 * mm[0][1], kk[0] - w2 * mm[0][0]];
        let scale = 1e-4 / v[0].abs().max(v[1].abs());
        let (p1, p2) = (-std::f64::consts::FRAC_PI_2 + scale * v[0], -std::f64::consts::FRAC_PI_2 + scale * v[1]);
        let e1 = [l1 * p1.cos(), l1 * p1.sin()];
        let y0 = vec![
            l1 / 2.0 * p1.cos(),
            l1 / 2.0 * p1.sin(),
            p1,
            e1[0] + l2 / 2.0 * p2.cos(),
            e1[1] + l2 / 2.0 * p2.sin(),
            p2,
            0.0,
            0.0,
            0.0,
            0.0,
            0.0,
            0.0,
            0.0,
        ];
        let mut sys = Dynamics::new(m.clone(), vec![gravity.resolve("gravity", &m).unwrap()], KktMethod::Auto);
        let period = std::f64::consts::TAU / w;
        let settings = RunSettings {
            dt: 1e-3,
            t_end: 10.25 * period,
            every: 2e-4,
            projection: ProjectionKind::MassWeighted,
            method: Method::Dop853,
            formulation: ezy_core::Formulation::Dae,
            rtol: 1e-12,
            atol: 1e-14,
            balance_limit: None,
            max_steps: None,
        };
        let mut rec = common::Recorder::default();
        simulate(&mut sys, &y0, &settings, &mut rec).unwrap();
        let theta: Vec<f64> = rec.y.iter().map(|y| y[2] + std::f64::consts::FRAC_PI_2).collect();
        let mut crossings = Vec::new();
        for i in 1..theta.len() {
            if theta[i - 1].signum() != theta[i].signum() && theta[i] != 0.0 {
                let f = theta[i - 1] / (theta[i - 1] - theta[i]);
                crossings.push(rec.t[i - 1] + f * (rec.t[i] - rec.t[i - 1]));
            }
        }
        assert!(crossings.len() >= 20, "{} crossings", crossings.len());
        let measured = std::f64::consts::PI * (crossings.len() - 1) as f64 / (crossings.last().unwrap() - crossings[0]);
        eprintln!("mode: omega {measured} against {w} rad/s (rel {:e})", (measured - w).abs() / w);
        assert!((measured - w).abs() <= 1e-7 * w, "omega {measured} want {w} (rel {:e})", (measured - w).abs() / w);
    }
}

/// The IFToMM benchmark's N-four-bar (problem A02; scenes `four-bar-n2`
/// and `four-bar-n40`) moves as a parallelogram of one degree of freedom:
/// every crank at the same angle `theta`, every coupler level (`psi = 0`)
/// and translating, and `J theta'' = -g c cos(theta)` with `J = (N + 1) m
/// L^2 / 3 + N m L^2` (each crank turns about its pivot, each coupler
/// moves with the cranks' tips at `L theta'`) and `c = (N + 1) m L / 2 + N m
/// L` (the heights of their centres of mass, `L/2 sin(theta)` and `L
/// sin(theta)`). `theta` integrated here by RK4 at 1e-4 s (error about
/// 1e-15) agrees with the scenes' DOP853 at 1e-10 at every sample of the
/// first 0.5 s to 1e-8 rad (measured: 2e-10; over 10 s at N = 2: 1e-8),
/// and the ledger `T - T(0) = W_gravity` closes to 1e-9 of the largest
/// kinetic energy (measured: 6e-10 J of 11 J, 1e-8 J of 190 J). The start is the
/// benchmark's: cranks up, couplers level at `y = L` moving at `vx = 1` m/s
/// (the first passage through the singular configuration, all bars on the
/// x axis, is at 0.714 s; not run here).
#[test]
fn the_n_four_bar_moves_as_its_parallelogram() {
    for (name, n) in [("four-bar-n2", 2usize), ("four-bar-n40", 40)] {
        let mut scene = scenes::get(name);
        scene.t_end = 0.5;
        let s = setup::<NFourBar>(&scene, &[]).unwrap();
        let (l, m) = (s.model.L, s.model.m);
        assert_eq!(s.model.N, n);
        let g = 9.81;
        let big_j = (n + 1) as f64 * m * l * l / 3.0 + n as f64 * m * l * l;
        let c = (n + 1) as f64 * m * l / 2.0 + n as f64 * m * l;
        let nq = 3 * (2 * n + 1);
        let coupler = |k: usize| 3 * (n + 1) + 3 * (k - 1);
        // the start: cranks up at -1 rad/s, couplers level at y = L, vx = 1 m/s
        let up = std::f64::consts::FRAC_PI_2;
        for i in 0..=n {
            let (x, y) = (s.y0[3 * i], s.y0[3 * i + 1]);
            assert!((x - i as f64 * l).abs() < 1e-12 && (y - l / 2.0).abs() < 1e-12, "crank {i} at ({x}, {y})");
            assert!((s.y0[3 * i + 2] - up).abs() < 1e-12 && (s.y0[nq + 3 * i + 2] + 1.0).abs() < 1e-12);
        }
        for k in 1..=n {
            let j = coupler(k);
            assert!((s.y0[j + 1] - l).abs() < 1e-12 && s.y0[j + 2].abs() < 1e-12, "coupler {k}");
            assert!(
                (s.y0[nq + j] - 1.0).abs() < 1e-12 && s.y0[nq + j + 1].abs() < 1e-12,
                "coupler {k} moves at vx = 1"
            );
        }
        let mut sys = Dynamics::new(s.model.clone(), s.effects.clone(), KktMethod::Auto);
        let settings = RunSettings { balance_limit: None, max_steps: None, ..scene.run_settings() };
        let mut rec = common::Recorder::default();
        let summary = simulate(&mut sys, &s.y0, &settings, &mut rec).unwrap();
        assert!((rec.t.last().unwrap() - 0.5).abs() < 1e-12);
        let f = |y: [f64; 2]| [y[1], -g * c / big_j * y[0].cos()];
        let (mut y, mut t, mut worst) = ([up, -1.0], 0.0, 0.0f64);
        for (ts, row) in rec.t.iter().zip(&rec.y) {
            while t < ts - 1e-12 {
                let h = (ts - t).min(1e-4);
                let k1 = f(y);
                let k2 = f([y[0] + h / 2.0 * k1[0], y[1] + h / 2.0 * k1[1]]);
                let k3 = f([y[0] + h / 2.0 * k2[0], y[1] + h / 2.0 * k2[1]]);
                let k4 = f([y[0] + h * k3[0], y[1] + h * k3[1]]);
                for k in 0..2 {
                    y[k] += h / 6.0 * (k1[k] + 2.0 * k2[k] + 2.0 * k3[k] + k4[k]);
                }
                t += h;
            }
            for i in 0..=n {
                worst = worst.max((row[3 * i + 2] - y[0]).abs()).max((row[nq + 3 * i + 2] - y[1]).abs());
            }
            for k in 1..=n {
                worst = worst.max(row[coupler(k) + 2].abs());
            }
        }
        eprintln!(
            "{name}: theta {worst:e} rad from the parallelogram, ledger {:e} J of {:.1} J",
            summary.max_energy_error,
            rec.kinetic.iter().fold(0.0f64, |a, &t| a.max(t))
        );
        assert!(worst <= 1e-8, "{name}: {worst:e} rad");
        assert!(y[0] < 1.0, "{name}: the cranks turned down to theta = {}", y[0]);
        // relative to the kinetic energy gravity hands over (N = 40: 190 J)
        let exchanged = rec.kinetic.iter().fold(0.0f64, |a, &t| a.max(t));
        assert!(summary.max_energy_error <= 1e-9 * exchanged, "{name}: ledger {:e} J", summary.max_energy_error);
    }
}
