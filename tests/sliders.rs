//! Sliders (prismatic joints) and slots (pin-in-slot joints) in the model
//! language: a cart on a ground rail against its closed form, a
//! telescoping two-body vehicle whose derived terms pass `ezy check` and
//! whose energy ledger closes, and a bar whose end pin runs in a ground
//! slot (its heading free) against the conservation laws that fix it.

use crate::common;

use ezy_core::kkt::KktMethod;
use ezy_core::{Dynamics, EffectSpec, Model, simulate};

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

ezy_core::model! {
    /// A bar whose end pin P runs in a horizontal ground slot through
    /// (0, 0) (its heading free), and a crank-and-block: a crank pinned to
    /// the ground whose pin C runs in a slot across the block (a Scotch
    /// yoke, the slot's line turning with the block).
    pub struct SlottedBar {
        /// Length of the bar [m]
        param l = 1.2;
        /// Mass of the bar [kg]
        param m = 3.0;
        /// Inertia of the bar about its centre [kg m^2]
        param I = 0.36;
        body bar(x, y, phi) { mass: m, inertia: I }
        point P on bar at (l / 2, 0);
        slot S: P on ground(0, 0) along (1, 0);
        body crank(x2, y2, phi2) { mass: 1.0, inertia: 0.05 }
        body block(x3, y3, phi3) { mass: 2.0, inertia: 0.2 }
        point O on crank at (-0.2, 0);
        point C on crank at (0.2, 0);
        point B on block at (0, 0);
        hinge O: O = ground(3, 0);
        slot Y: C on B along (0, 1);
    }
}

fn force(at: &str, fx: f64, fy: f64) -> EffectSpec {
    toml::from_str(&format!("kind = \"force\"\nat = \"{at}\"\nfx = {{ constant = {fx} }}\nfy = {{ constant = {fy} }}"))
        .unwrap()
}

fn run<M: Model>(model: M, effects: Vec<EffectSpec>, y0: Vec<f64>, t_end: f64) -> (ezy_core::Summary, Vec<f64>) {
    let effects = effects.iter().map(|e| e.resolve("push", &model).unwrap()).collect();
    let mut sys = Dynamics::new(model, effects, KktMethod::Auto);
    let s = simulate(&mut sys, &y0, &common::dop853(t_end, t_end, 1e-12), &mut common::Recorder::default()).unwrap();
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

/// Slot rows (one per slot, `S.n`; no heading row), their convective
/// terms and the point velocities against finite differences and dual
/// numbers, for a ground slot and a slot in a moving body.
#[test]
fn slot_terms_pass_the_derivative_check() {
    ezy::testing::assert_derivatives(&SlottedBar::default());
    let info = SlottedBar::default().info();
    assert_eq!(info.constraints, ["O.x", "O.y", "S.n", "Y.n"]);
    assert_eq!((info.sliders[0].row, info.sliders[0].heading), (2, false));
    assert_eq!(info.n_holonomic, 4);
}

/// The bar in its slot, set spinning and sliding: the slot's force is
/// vertical, so the centre's x velocity stays what it was
/// (`x(t) = x0 + vx t`), and with no force doing work the kinetic energy
/// stays constant; the heading turns (free) while the pin stays on the
/// line. The crank and block are at rest and stay so. DOP853 at 1e-12
/// over 5 s: 1e-9 on `x`, 1e-10 J on `T`, residuals 1e-12.
#[test]
fn a_bar_in_a_slot_keeps_its_momentum_along_the_slot_and_its_energy() {
    let m = SlottedBar::default();
    let (l, phi0, w0, vx) = (1.2f64, 0.3f64, 2.0f64, 0.7f64);
    // centre below the line so that P = centre + (l/2) (cos, sin) phi is on y = 0
    let y_c = -(l / 2.0) * phi0.sin();
    let yd_c = -(l / 2.0) * phi0.cos() * w0;
    let mut y0 = vec![0.0, y_c, phi0, 3.2, 0.0, 0.0, 3.4, 0.0, 0.0];
    y0.extend([vx, yd_c, w0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
    let t0 = 0.5 * (3.0 * (vx * vx + yd_c * yd_c) + 0.36 * w0 * w0);
    let mut sys = Dynamics::new(m, vec![], KktMethod::Auto);
    let mut rec = common::Recorder::default();
    let s = simulate(&mut sys, &y0, &common::dop853(5.0, 0.05, 1e-12), &mut rec).unwrap();
    assert!(s.max_residual_position <= 1e-12 && s.max_residual_velocity <= 1e-12, "{s:?}");
    for (t, y) in rec.t.iter().zip(&rec.y) {
        assert!((y[0] - vx * t).abs() <= 1e-9, "x({t}) = {} want {}", y[0], vx * t);
        let p_y = y[1] + (l / 2.0) * y[2].sin();
        assert!(p_y.abs() <= 1e-12, "P off the slot at t = {t}: {p_y}");
        let qd = &y[9..18];
        let tk = 0.5 * (3.0 * (qd[0] * qd[0] + qd[1] * qd[1]) + 0.36 * qd[2] * qd[2]);
        assert!((tk - t0).abs() <= 1e-10, "T({t}) = {tk} want {t0}");
        let still =
            y[3..9].iter().zip(&y0[3..9]).chain(qd[3..].iter().zip(&[0.0; 6])).all(|(a, b)| (a - b).abs() <= 1e-12);
        assert!(still, "crank and block stay at rest: {:?}", &y[3..]);
    }
    let turned = rec.y.last().unwrap()[2] - phi0;
    assert!(turned.abs() > 1.0, "the heading is free and turns: {turned}");
}
