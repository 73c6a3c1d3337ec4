//! Sliders (prismatic joints) in the model language: a cart on a ground
//! rail against its closed form, and a telescoping two-body vehicle whose
//! derived terms pass `ezy check` and whose energy ledger closes.

mod common;

use ezy_core::kkt::KktMethod;
use ezy_core::{Dynamics, EffectSpec, Method, Model, ProjectionKind, RunSettings, simulate};

ezy_core::model! {
    /// A cart on a straight ground rail through (0, 0.5) at 30 degrees,
    /// its heading fixed at 0.2 rad.
    pub struct RailCart {
        /// Mass [kg]
        param m = 2.0;
        /// Inertia [kg m^2]
        param I = 0.3;
        body cart(x, y, phi) { mass: m, inertia: I }
        point P on cart at (0.1, -0.05);
        slider R: P on ground(0, 0.5) along (0.8660254037844386, 0.5) angle 0.2;
    }
}

ezy_core::model! {
    /// A telescoping vehicle: a rear frame with a skate, and a front part
    /// that slides along the frame's axis and carries a skate of its own.
    pub struct Telescope {
        /// Mass of the frame [kg]
        param m1 = 10.0;
        /// Inertia of the frame [kg m^2]
        param I1 = 1.0;
        /// Mass of the front part [kg]
        param m2 = 2.0;
        /// Inertia of the front part [kg m^2]
        param I2 = 0.1;
        /// Distance of the rear skate behind the frame's centre [m]
        param a = 0.4;
        body frame(x1, y1, phi1) { mass: m1, inertia: I1 }
        body front(x2, y2, phi2) { mass: m2, inertia: I2 }
        point A on frame at (-a, 0);
        point O on frame at (0, 0);
        point Q on front at (0, 0);
        point C on front at (0.3, 0);
        slider S: Q on O along (1, 0);
        skate A: A along (1, 0);
        skate C: C along (1, 0);
    }
}

fn force(at: &str, fx: f64, fy: f64) -> EffectSpec {
    toml::from_str(&format!("kind = \"force\"\nat = \"{at}\"\nfx = {{ constant = {fx} }}\nfy = {{ constant = {fy} }}"))
        .unwrap()
}

fn run<M: Model>(model: M, effects: Vec<EffectSpec>, y0: Vec<f64>, t_end: f64) -> (ezy_core::Summary, Vec<f64>) {
    let effects = effects.iter().map(|e| e.resolve("push", &model).unwrap()).collect();
    let mut sys = Dynamics::new(model, effects, KktMethod::Auto);
    let settings = RunSettings {
        dt: 1e-3,
        t_end,
        every: t_end,
        projection: ProjectionKind::MassWeighted,
        method: Method::Dop853,
        rtol: 1e-12,
        atol: 1e-12,
        balance_limit: None,
        max_steps: None,
    };
    let s = simulate(&mut sys, &y0, &settings, &mut common::Recorder::default()).unwrap();
    let last = s.final_state.clone();
    (s, last)
}

/// A constant world force (2, 1) N on a cart on the rail: the cart moves
/// along the rail with acceleration `F . t / m` from rest, its heading
/// stays 0.2 rad, and the work is `F . displacement`.
#[test]
fn a_cart_on_a_rail_follows_the_closed_form() {
    let m = RailCart::default();
    let t = [0.8660254037844386, 0.5];
    // initial position: P = (0.1, -0.05) rotated by 0.2 from the centre, on the rail at s = 0
    let (c, s) = (0.2f64.cos(), 0.2f64.sin());
    let p = [c * 0.1 + s * 0.05, s * 0.1 - c * 0.05];
    let y0 = vec![-p[0], 0.5 - p[1], 0.2, 0.0, 0.0, 0.0, 0.0];
    let (summary, y) = run(m, vec![force("cart", 2.0, 1.0)], y0.clone(), 2.0);
    let acc = (2.0 * t[0] + 1.0 * t[1]) / 2.0;
    let dist = 0.5 * acc * 4.0;
    for (k, want) in [
        (0, y0[0] + dist * t[0]),
        (1, y0[1] + dist * t[1]),
        (2, 0.2),
        (3, acc * 2.0 * t[0]),
        (4, acc * 2.0 * t[1]),
        (5, 0.0),
    ] {
        assert!((y[k] - want).abs() <= 1e-10, "y[{k}] = {} want {want}", y[k]);
    }
    let work = 2.0 * dist * t[0] + dist * t[1];
    assert!((y[6] - work).abs() <= 1e-10, "W = {} want {work}", y[6]);
    assert!(summary.max_residual_position <= 1e-12 && summary.max_residual_velocity <= 1e-12);
}

/// Generated slider rows, their convective terms and the point velocities
/// against finite differences and dual numbers (`ezy check`), for both models.
#[test]
fn slider_terms_pass_the_derivative_check() {
    ezy::testing::assert_derivatives(&RailCart::default());
    ezy::testing::assert_derivatives(&Telescope::default());
    let report = ezy::testing::check_derivatives(&Telescope::default());
    assert!(report.terms[0].compared > 0, "no slider rows compared: {report:?}");
    assert_eq!(Telescope::default().info().constraints, ["S.n", "S.phi", "A", "C"]);
    assert_eq!(Telescope::default().info().sliders[0].row, 0);
}

/// The telescope pushed at its front skate point (a force along and across
/// the frame): constraints hold to 1e-12 and `T - T0 = W` to 1e-10 J over
/// 5 s, and the front part keeps the frame's heading.
#[test]
fn a_telescope_keeps_its_constraints_and_its_ledger() {
    let m = Telescope::default();
    let y0 = vec![0.0, 0.0, 0.0, 0.5, 0.0, 0.0, 0.3, 0.0, 0.0, 0.3, 0.0, 0.0, 0.0];
    let (s, y) = run(m, vec![force("C", 1.0, 0.4)], y0, 5.0);
    assert!(s.max_residual_position <= 1e-12 && s.max_residual_velocity <= 1e-12, "{s:?}");
    assert!(s.max_energy_error <= 1e-10, "ledger {:e}", s.max_energy_error);
    assert!((y[2] - y[5]).abs() <= 1e-12, "headings {} {}", y[2], y[5]);
    assert!(y[12] > 0.1, "the force did work: {}", y[12]);
}
