//! Hinge friction (`hinge-friction`, Coulomb-viscous): a wheel on a
//! ground hinge spun down against the closed form, with both right-hand
//! sides (the fused one on the minimal coordinates, the DAE's force
//! vector), and its numbers refused by key (issue 65).

use ezy_core::Method;

ezy_core::model! {
    /// A wheel on an axle fixed to the ground at its centre of mass: one
    /// body, one ground hinge, one degree of freedom (its angle).
    pub struct Wheel {
        /// Moment of inertia about the axle [kg m^2]
        param I = 0.5;
        body wheel(x, y, phi) { mass: 2.0, inertia: I }
        point O on wheel at (0, 0);
        hinge O: O = ground(0, 0);
    }
}

/// The wheel spinning down from `w0` [rad/s] under hinge friction with
/// viscous coefficient `cv`, Coulomb torque `tc` and smoothing `ws`, to
/// `t_end`, sampled every `every` [s]: DOP853 at 1e-12 in the
/// formulation `formulation`.
fn spin_down(
    (cv, tc, ws): (f64, f64, f64),
    w0: f64,
    t_end: f64,
    every: f64,
    formulation: ezy_core::Formulation,
) -> ezy_core::Solution {
    use ezy_core::effects::HingeFriction;
    let bearing = HingeFriction { hinge: "O".into(), damping: cv, torque: tc, smoothing: ws };
    ezy_core::Problem::new(Wheel::default())
        .effect("bearing", bearing)
        .unwrap()
        .q("x", 0.0)
        .unwrap()
        .q("y", 0.0)
        .unwrap()
        .q("phi", 0.0)
        .unwrap()
        .qd("phi", w0)
        .unwrap()
        .t_end(t_end)
        .every(every)
        .formulation(formulation)
        .method(Method::Dop853)
        .tolerances(1e-12, 1e-12)
        .solve()
        .unwrap()
}

/// Checks a spin-down against the Coulomb-viscous closed form `w_pure(t)`
/// (`I w' = -(c_v w + T_c sgn w)`, rest at `t_star`) and the ledger:
/// 1. while `w_pure >= 100 w_s` the smooth law's Coulomb part differs
///    from `T_c sgn w` by `T_c (1 - tanh 100) < 3e-87 T_c`, so `w(t)`
///    follows the closed form to the integrator's accuracy: DOP853 at
///    rtol = atol = 1e-12 on a contracting one-dimensional flow (`dw'/dw
///    < 0`: errors do not grow), whose global error stays below 1e-12
///    per unit time of `w0`; allowed `1e-10 w0` (measured: 3.4e-13 w0);
/// 2. it comes to rest (`w < w_s / 100`) no earlier than `t_star` less one
///    `tau_s = I w_s / T_c` (the smooth torque is never larger than the
///    pure one, so it never runs ahead of it) and no later than `t_star +
///    6 tau_s` plus a sample: it reaches `3 w_s` less than `0.003 tau_s`
///    after the pure law's `t_star - 3 tau_s` (the lag `tau_s` times the
///    integral of `coth u - 1` from 3 up, `-ln(1 - e^-6)`), and from there
///    to `w_s` takes at most `2 w_s I / (T_c tanh 1) = 2.6 tau_s`; below
///    `w_s` the torque is at least `T_c tanh(1) w / w_s` (tanh is concave),
///    a decay at least as fast as `exp(-0.76 t / tau_s)`, which reaches
///    `w_s / 100` within `ln(100) / 0.76 = 6.1 tau_s`: at most `t_star -
///    3 tau_s + 2.6 tau_s + 6.1 tau_s < t_star + 6 tau_s` (measured: 4 tau_s);
/// 3. it never turns back (`w >= -1e-10 w0`: past rest the law is a
///    damping, and what is left is the integrator's error, as in 1) and the
///    energy ledger closes: `T - T0 = W_bearing` at every sample to
///    `1e-9 T0` (both sides integrated to 1e-12), so the dissipated work
///    `-W_bearing(t_end)` is the lost kinetic energy `I (w0^2 - w^2) / 2`.
fn check_spin_down(s: &ezy_core::Solution, w0: f64, (cv, tc, ws): (f64, f64, f64), every: f64) {
    let inertia = Wheel::default().I;
    let w = s.column("phid").unwrap();
    let work = s.column("W_bearing").unwrap();
    let (t_star, w_pure): (f64, Box<dyn Fn(f64) -> f64>) = if cv > 0.0 {
        let r = tc / cv;
        ((inertia / cv) * (1.0 + w0 / r).ln(), Box::new(move |t: f64| (w0 + r) * (-cv * t / inertia).exp() - r))
    } else {
        (inertia * w0 / tc, Box::new(move |t: f64| w0 - tc * t / inertia))
    };
    let tau_s = inertia * ws / tc;
    let mut compared = 0;
    let mut worst: f64 = 0.0;
    for (k, &t) in s.t.iter().enumerate() {
        if t < t_star && w_pure(t) >= 100.0 * ws {
            worst = worst.max((w[k] - w_pure(t)).abs());
            compared += 1;
        }
    }
    assert!(compared > 100, "{compared} samples where w >> w_s");
    assert!(worst <= 1e-10 * w0, "w(t) against the closed form: {worst:e} rad/s off (w0 = {w0})");
    let stop = s.t.iter().zip(&w).find(|(_, w)| **w < ws / 100.0).map(|(t, _)| *t).expect("it comes to rest");
    assert!(
        stop >= t_star - tau_s && stop <= t_star + 6.0 * tau_s + every,
        "at rest at {stop} s, t* = {t_star} s, tau_s = {tau_s} s"
    );
    let lowest = w.iter().copied().fold(f64::INFINITY, f64::min);
    assert!(lowest >= -1e-10 * w0, "it turns back: min {lowest:e} rad/s");
    let t0 = s.kinetic_energy[0];
    assert!((t0 - 0.5 * inertia * w0 * w0).abs() <= 1e-12 * t0, "T0 = {t0}: the wheel's spin alone");
    let mut gap: f64 = 0.0;
    for (k, (&e, &wk)) in s.kinetic_energy.iter().zip(&work).enumerate() {
        assert!((e - t0 - wk).abs() <= 1e-9 * t0, "t = {}: T - T0 = {} but W = {wk}", s.t[k], e - t0);
        gap = gap.max((e - t0 - wk).abs());
    }
    let lost = 0.5 * inertia * (w0 * w0 - w.last().unwrap().powi(2));
    let dissipated = -work.last().unwrap();
    assert!((dissipated - lost).abs() <= 1e-9 * t0, "dissipated {dissipated} J, lost {lost} J");
    eprintln!(
        "w0 = {w0}: worst |w - w_closed| = {worst:e} rad/s; at rest at {stop} s, t* = {t_star} s, tau_s = {tau_s:e} s; lowest w {lowest:e}; ledger gap {gap:e} J of T0 = {t0} J"
    );
}

/// Hinge friction (`hinge-friction`, Coulomb-viscous, `tau = -(c_v w +
/// T_c tanh(w / w_s))`) spins a wheel down as the closed form of `I w' =
/// -(c_v w + T_c sgn w)` says while `w >> w_s`: `w(t) = (w0 + T_c/c_v)
/// exp(-c_v t / I) - T_c/c_v`, at rest at `t* = (I/c_v) ln(1 + c_v w0 /
/// T_c)`; and with `c_v = 0` (pure Coulomb) it decays linearly, `w(t) =
/// w0 - T_c t / I`, at rest at `t* = I w0 / T_c`. Tolerances in
/// `check_spin_down`. The fused right-hand side on the minimal
/// coordinates (the default here: hinge torques handed to the generated
/// code) and the DAE's generic force vector evaluate the one law alike.
#[test]
fn hinge_friction_spins_a_wheel_down_as_the_closed_form_says() {
    use ezy_core::Formulation;
    // I = 0.5 kg m^2, c_v = 0.2 N m s/rad, T_c = 0.3 N m, w_s = 1e-3 rad/s:
    // t* = 2.5 ln(1 + 2 / 0.3) = 5.092 s, tau_s = 1.7 ms
    let law = (0.2, 0.3, 1e-3);
    let (w0, every) = (10.0, 1e-4);
    let fused = spin_down(law, w0, 6.0, every, Formulation::Auto);
    check_spin_down(&fused, w0, law, every);
    let dae = spin_down(law, w0, 6.0, every, Formulation::Dae);
    check_spin_down(&dae, w0, law, every);
    let (a, b) = (fused.column("phid").unwrap(), dae.column("phid").unwrap());
    let gap = a.iter().zip(&b).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    assert!(gap <= 1e-9 * w0, "the fused and the DAE right-hand sides differ by {gap:e} rad/s");
    // pure Coulomb: w0 = 3 rad/s, t* = 0.5 * 3 / 0.3 = 5 s
    let coulomb = (0.0, 0.3, 1e-3);
    check_spin_down(&spin_down(coulomb, 3.0, 6.0, every, Formulation::Auto), 3.0, coulomb, every);
}

/// The hinge friction's numbers are checked with messages naming the key,
/// like every kind's.
#[test]
fn hinge_friction_refuses_bad_numbers_by_key() {
    use ezy_core::effects::HingeFriction;
    let bad = |damping: f64, torque: f64, smoothing: f64| {
        let spec = HingeFriction { hinge: "O".into(), damping, torque, smoothing };
        match ezy_core::Problem::new(Wheel::default()).effect("bearing", spec) {
            Err(ezy_core::SimError::Setup(ezy_core::SetupError::Effect { field, message, .. })) => (field, message),
            other => panic!("{other:?}"),
        }
    };
    let (field, message) = bad(-0.1, 0.3, 1e-3);
    assert_eq!(field, "damping");
    assert!(message.contains("damping = -0.1 must be zero or positive"), "{message}");
    let (field, message) = bad(0.1, -0.3, 1e-3);
    assert_eq!(field, "torque");
    assert!(message.contains("torque = -0.3 must be zero or positive"), "{message}");
    let (field, message) = bad(0.1, 0.3, 0.0);
    assert_eq!(field, "smoothing");
    assert!(message.contains("smoothing = 0 must be a positive rate [rad/s]"), "{message}");
    let (field, message) = bad(0.1, 0.3, f64::NAN);
    assert_eq!(field, "smoothing", "{message}");
    let spec = HingeFriction { hinge: "Q".into(), damping: 0.0, torque: 0.3, smoothing: 1e-3 };
    let Err(ezy_core::SimError::Setup(ezy_core::SetupError::Effect { field, message, .. })) =
        ezy_core::Problem::new(Wheel::default()).effect("b", spec)
    else {
        panic!("an unknown hinge is refused")
    };
    assert_eq!(field, "hinge");
    assert!(message.contains("unknown hinge `Q`"), "{message}");
}
