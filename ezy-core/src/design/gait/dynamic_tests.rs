//! Gait optimization of a mixed system ([`super::dynamic`]): the
//! EzyRoller with viscous rolling resistance (the `drive-rolling-resistance`
//! scene's), its hinge angle prescribed as a Fourier gait (the model of
//! `models/src/ezyroller_driven.rs`, written here with `model!`).

use std::f64::consts::PI;
use std::time::Instant;

use super::{DriveGait, FourierGait};
use crate::analysis::AnalysisError;
use crate::design::Design;
use crate::design::optimize::Optimum;
use crate::design::optimize::evaluate::Evaluator;
use crate::design::optimize::{GaitQuantity, Goal, OptimizeSettings, Quantity, Sense, optimize};
use crate::effects::Waveform;
use crate::effects::{LinearDrag, RollingViscous};
use crate::{Method, Problem, SimError};

crate::model! {
    /// The EzyRoller with its hinge angle prescribed (as
    /// `ezy_models::EzyRollerDriven`).
    pub struct Roller {
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
        drive D: hinge B;
        skate A: A along (1, 0);
        skate C: C along (1, 0);
    }
}

/// The `drive-rolling-resistance` scene's roller (1 N s/m at both
/// skates, at rest) with its drive (the angle the design sets), run for
/// `t_end` (the gait's first guess: the state at its last whole period).
fn roller(t_end: f64) -> Result<Problem<Roller>, SimError> {
    Problem::new(Roller::default())
        .q("x1", 0.0)?
        .q("y1", 0.0)?
        .q("phi1", 0.0)?
        .qd("x1", 0.0)?
        .method(Method::Dop853)
        .tolerances(1e-11, 1e-11)
        .t_end(t_end)
        .effect("rolling_A", RollingViscous { skate: "A".into(), damping: 1.0 })?
        .effect("rolling_C", RollingViscous { skate: "C".into(), damping: 1.0 })
}

/// Order 1, period 2 s, fork turned back (`a0 = -pi`) and swinging
/// `a1 cos(pi t)`.
fn order1(a0: f64, a1: f64) -> FourierGait {
    FourierGait::new(vec![vec![a0, a1, 0.0]], 1, 2.0).unwrap()
}

/// The search's settings: the gait's orbit to 1e-12 (Newton) under DOP853
/// at 1e-12, so that its quantities are accurate to about 1e-12 of their
/// size, and the polish on the exact gradients.
fn settings() -> OptimizeSettings {
    DriveGait::optimize_settings()
}

fn maximize(q: GaitQuantity) -> Goal {
    Goal { objective: Quantity::Gait(q), sense: Sense::Maximize, constraints: vec![] }
}

/// The projected gradient relative to the objective's scale: `|P grad
/// F|` in the parameters scaled to their spans (the objective's change
/// across a span), over `|F|`.
fn relative_projected_gradient(o: &Optimum) -> f64 {
    o.projected_gradient_norm / o.objective.abs()
}

fn show(what: &str, o: &Optimum, seconds: f64) {
    eprintln!(
        "{what}: {:.2} s, {} evaluations ({} gaits, {} runs): {:?} = {:?}, {} = {}, |P grad| / |F| = {:.2e}, converged {} ({}); {}",
        seconds,
        o.history.len(),
        o.orbits,
        o.runs,
        o.names,
        o.values,
        o.objective_name,
        o.objective,
        relative_projected_gradient(o),
        o.converged,
        o.termination,
        o.kkt.describe()
    );
}

/// The EzyRoller with rolling resistance, its hinge angle `a0 + a1
/// cos(pi t)`: the offset within 0.5 rad of the fork turned back, the
/// amplitude at most 0.4 rad. Its mean forward speed is largest at
/// `a1 = 0.475` with the bound 0.5 (measured), so at 0.4 the amplitude's
/// bound binds and the offset is interior (`a0 = -pi + 0.049`: the speed
/// along the period's start heading is not even in the offset). The
/// optimum's projected gradient is below 1e-8 of the objective, the
/// binding bound is named `D.a1 <= 0.4` with its multiplier (the
/// objective's rate along it). Measured: 1.2e-10 in 14 evaluations
/// (0.7 s); without the polish 2.2e-9, and 1.9e-5 with the gait found
/// to the default 1e-9 (the values' accuracy then ranks the points).
/// With `a1 <= 0.5` (the optimum interior) SLSQP alone left 3.9e-8 at
/// 1e-12, 3e-6 at the defaults; polished, 3.8e-10.
#[test]
fn roller_forward_speed_binds_the_amplitude() {
    let gait = DriveGait::new(&["D"], order1(-PI + 0.1, 0.3))
        .free("D.a0", -PI - 0.5, -PI + 0.5)
        .unwrap()
        .free("D.a1", 0.05, 0.4)
        .unwrap();
    let design = gait.design(|| roller(60.0)).unwrap();
    let t = Instant::now();
    let o = optimize(&design, &maximize(GaitQuantity::MeanForwardSpeed), &settings(), None, &mut |_| {}).unwrap();
    show("roller, order 1", &o, t.elapsed().as_secs_f64());
    assert!(o.converged && o.kkt.holds, "{}", o.termination);
    assert!(relative_projected_gradient(&o) < 1e-8, "{}", relative_projected_gradient(&o));
    assert_eq!(o.at_bound, [false, true]);
    let binding: Vec<&str> = o.kkt.binding.iter().map(|b| b.name.as_str()).collect();
    assert_eq!(binding, ["D.a1 <= 0.4"]);
    // the multiplier is the objective's rate along the bound, dF/da1
    let (mu, g) = (o.kkt.binding[0].multiplier, o.gradient[1]);
    assert!(mu > 0.0 && (mu - g).abs() < 1e-9 * g, "{mu} against dF/da1 = {g}");
    assert!(o.objective > o.history[0].objective);
    // the gait at the optimum, as the design's values say
    let best = gait.gait_at(&o.values);
    assert_eq!(best.coefficients[0][2], 0.0);
    assert_eq!(best.coefficients[0][1], o.values[1]);
}

/// The objective and its gradient at `values` (the gait found from a run
/// of the design's problem), through the optimizer's own evaluation.
fn value_and_gradient<M: crate::model::Model>(
    design: &Design<M>,
    goal: &Goal,
    values: &[f64],
) -> Result<(f64, Vec<f64>), AnalysisError> {
    let mut ev = Evaluator::new(design, goal, settings().periodic, None);
    let p = ev.at(values, true)?;
    Ok((p.values[0], p.gradients[0].clone()))
}

/// Five-point central differences of the objective: error `h^4 F^(5) / 30`
/// and `1.5 noise / h`.
fn five_point<M: crate::model::Model>(design: &Design<M>, goal: &Goal, values: &[f64], k: usize, h: f64) -> f64 {
    let f = |s: f64| {
        let mut v = values.to_vec();
        v[k] += s * h;
        value_and_gradient(design, goal, &v).unwrap().0
    };
    (8.0 * (f(1.0) - f(-1.0)) - (f(2.0) - f(-2.0))) / (12.0 * h)
}

/// The exact gradient of the roller's mean forward speed in the gait's
/// coefficients (order 2, `b1` held: the implicit function theorem on the
/// orbit's shooting equations) against five-point central differences of
/// whole gaits (each found to 1e-12) at a point far from the optimum,
/// step 1e-3 rad: the differences err by `h^4 F^(5) / 30` (about 1e-12
/// here) and by the gaits' own error over the step, `1.5 * 1e-12 |F| /
/// h`, about 3e-9 of the gradient's size; held to 1e-8 of the largest
/// component (measured 7.8e-10).
#[test]
fn roller_gradient_against_differences() {
    let start = FourierGait::new(vec![vec![-PI + 0.1, 0.3, 0.0, 0.05, -0.04]], 2, 2.0).unwrap();
    let gait = DriveGait::new(&["D"], start)
        .free("D.a0", -PI - 0.5, -PI + 0.5)
        .unwrap()
        .free("D.a1", 0.0, 0.5)
        .unwrap()
        .free("D.a2", -0.2, 0.2)
        .unwrap()
        .free("D.b2", -0.2, 0.2)
        .unwrap();
    let design = gait.design(|| roller(60.0)).unwrap();
    let goal = maximize(GaitQuantity::MeanForwardSpeed);
    let t = Instant::now();
    let (f, g) = value_and_gradient(&design, &goal, &design.start).unwrap();
    let exact = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let h = 1e-3;
    let fd: Vec<f64> = (0..4).map(|k| five_point(&design, &goal, &design.start, k, h)).collect();
    let scale = g.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let err = g.iter().zip(&fd).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max) / scale;
    eprintln!(
        "roller gradient: F = {f}, exact {g:?} ({exact:.2} s), differences {fd:?} ({:.2} s), max error / max |grad| = {err:.2e}",
        t.elapsed().as_secs_f64()
    );
    assert!(err < 1e-8, "{err:e}");
}

crate::model! {
    /// A user's own vehicle, not among ezy's models: a Chaplygin sleigh
    /// (one skate behind its centre of mass) wagging a tail hinged at its
    /// rear, the hinge angle prescribed.
    pub struct TailedSleigh {
        param m1 = 2.0;
        param I1 = 0.1;
        param m2 = 0.5;
        param I2 = 0.02;
        body sled(x1, y1, phi1) { mass: m1, inertia: I1 }
        body tail(x2, y2, phi2) { mass: m2, inertia: I2 }
        point S on sled at (-0.1, 0);
        point H1 on sled at (-0.4, 0);
        point H2 on tail at (0.3, 0);
        hinge H: H1 = H2;
        drive W: hinge H;
        skate S: S along (1, 0);
    }
}

/// The sleigh at rest, linear drag on both bodies (the water or air the
/// loss that lets it reach a gait).
fn sleigh() -> Result<Problem<TailedSleigh>, SimError> {
    Problem::new(TailedSleigh::default())
        .q("x1", 0.0)?
        .q("y1", 0.0)?
        .q("phi1", 0.0)?
        .qd("x1", 0.0)?
        .qd("phi1", 0.0)?
        .method(Method::Dop853)
        .tolerances(1e-11, 1e-11)
        .t_end(60.0)
        .effect("drag_sled", LinearDrag { body: "sled".into(), c: 1.0, c_rot: 0.1 })?
        .effect("drag_tail", LinearDrag { body: "tail".into(), c: 0.5, c_rot: 0.02 })
}

/// The same path on a model the user typed: the sleigh's tail wagging
/// `a1 cos(omega t) + a2 cos(2 omega t) + b2 sin(2 omega t)` (order 2,
/// period 2 s, `a0` and `b1` held at 0), its efficiency (mean speed per
/// mean input power) maximized with `a1` in `[0.05, 0.6]` rad and the
/// second harmonic's within 0.3 rad. Measured: the efficiency grows as
/// the amplitude shrinks (0.978 m/J at the start, 1.024 at the optimum),
/// so `a1`'s lower bound binds, and the second harmonic is interior near
/// 0 (`a2 = -1.2e-4`, `b2 = 1.1e-5`).
#[test]
fn a_users_sleigh_through_the_same_path() {
    let start = FourierGait::new(vec![vec![0.0, 0.3, 0.0, 0.05, 0.05]], 2, 2.0).unwrap();
    let gait = DriveGait::new(&["W"], start)
        .free("W.a1", 0.05, 0.6)
        .unwrap()
        .free("W.a2", -0.3, 0.3)
        .unwrap()
        .free("W.b2", -0.3, 0.3)
        .unwrap();
    let design = gait.design(sleigh).unwrap();
    let t = Instant::now();
    let o = optimize(&design, &maximize(GaitQuantity::Efficiency), &settings(), None, &mut |_| {}).unwrap();
    show("tailed sleigh, order 2", &o, t.elapsed().as_secs_f64());
    assert!(o.converged && o.kkt.holds, "{}", o.termination);
    assert!(relative_projected_gradient(&o) < 1e-8, "{}", relative_projected_gradient(&o));
    assert_eq!(o.at_bound, [true, false, false]);
    let binding: Vec<&str> = o.kkt.binding.iter().map(|b| b.name.as_str()).collect();
    assert_eq!(binding, ["W.a1 >= 0.05"]);
    assert!(o.objective > o.history[0].objective);
}

crate::model! {
    /// The EzyRoller without a drive (its hinge free).
    pub struct Undriven {
        param m1 = 46.0;
        param I1 = 10.0;
        param m2 = 1.0;
        param I2 = 0.005;
        body body1(x1, y1, phi1) { mass: m1, inertia: I1 }
        body body2(x2, y2, phi2) { mass: m2, inertia: I2 }
        point A on body1 at (-0.2, 0);
        point B1 on body1 at (0.6, 0);
        point B2 on body2 at (-0.1, 0);
        point C on body2 at (0.1, 0);
        hinge B: B1 = B2;
        skate A: A along (1, 0);
        skate C: C along (1, 0);
    }
}

fn refusal<M: crate::model::Model>(d: Result<Design<M>, AnalysisError>) -> String {
    match d {
        Err(AnalysisError::Request { reason }) => reason,
        Err(e) => panic!("another error: {e}"),
        Ok(_) => panic!("not refused"),
    }
}

/// Refused by name, before any work: a model without drives, a drive
/// it does not have or named twice, rows that are not one per drive, a
/// coefficient the gait does not have, nothing free, bounds reversed or
/// not finite, a start outside its bounds.
#[test]
fn refusals_name_what_is_wrong() {
    let one = || DriveGait::new(&["D"], order1(-PI, 0.3));
    let undriven = || Problem::new(Undriven::default()).q("phi2", PI);
    let r = refusal(one().free("D.a1", 0.0, 0.5).unwrap().design(undriven));
    assert!(r.contains("has no drives") && r.contains("none to optimize"), "{r}");
    let r = refusal(DriveGait::new(&["E"], order1(-PI, 0.3)).free("E.a1", 0.0, 0.5).unwrap().design(|| roller(60.0)));
    assert!(r.contains("no drive `E`") && r.contains("D"), "{r}");
    let two = FourierGait::new(vec![vec![-PI, 0.3, 0.0], vec![0.0, 0.1, 0.0]], 1, 2.0).unwrap();
    let r = refusal(DriveGait::new(&["D", "D"], two.clone()).free("D.a1", 0.0, 0.5).unwrap().design(|| roller(60.0)));
    assert!(r.contains("`D` is named twice"), "{r}");
    let r = refusal(DriveGait::new(&["D"], two).free("D.a1", 0.0, 0.5).unwrap().design(|| roller(60.0)));
    assert!(r.contains("2 rows of coefficients for 1 drives"), "{r}");
    let r = one().free("D.a3", 0.0, 0.5).map(|_| ()).unwrap_err().to_string();
    assert!(r.contains("`D.a3` is not a coefficient") && r.contains("D.b1"), "{r}");
    let r = refusal(one().design(|| roller(60.0)));
    assert!(r.contains("every coefficient of the gait is held: nothing to optimize"), "{r}");
    let r = refusal(one().free("D.a1", 0.5, 0.1).unwrap().design(|| roller(60.0)));
    assert!(r.contains("`D.a1=0.5:0.1`") && r.contains("the lower below the upper"), "{r}");
    let r = refusal(one().free("D.a1", 0.0, f64::INFINITY).unwrap().design(|| roller(60.0)));
    assert!(r.contains("`D.a1=0:inf`") && r.contains("finite"), "{r}");
    let r = refusal(one().free("D.a1", f64::NAN, 0.5).unwrap().design(|| roller(60.0)));
    assert!(r.contains("D.a1") && r.contains("finite"), "{r}");
    let r = refusal(one().free("D.a1", 0.4, 0.5).unwrap().design(|| roller(60.0)));
    assert!(r.contains("the start, D.a1 = 0.3, is outside the bounds"), "{r}");
    // no first harmonic: the angles repeat every half period, or never
    let half = FourierGait::new(vec![vec![-PI, 0.0, 0.0, 0.2, 0.0]], 2, 2.0).unwrap();
    let r = refusal(DriveGait::new(&["D"], half).free("D.a2", 0.0, 0.5).unwrap().design(|| roller(60.0)));
    assert!(r.contains("repeat every 1 s, not with its period 2 s") && r.contains("first harmonic"), "{r}");
    let still = DriveGait::new(&["D"], order1(-PI, 0.0)).free("D.a0", -4.0, -3.0).unwrap();
    let r = refusal(still.design(|| roller(60.0)));
    assert!(r.contains("never change"), "{r}");
}

/// The prescribed angle of a row is the Fourier series, each coefficient
/// one harmonic's amplitude (linear in it, the structure fixed): its
/// value, rate and acceleration against the series' own.
#[test]
fn drive_angle_is_the_series() {
    let row = [-3.0, 0.3, -0.2, 0.05, 0.0];
    let w = super::drive_angle(&row, 2, PI);
    let Waveform::Harmonics(h) = &w else { panic!("{w:?}") };
    assert_eq!(h.len(), 5);
    for t in [0.0, 0.3, 1.7, 12.25] {
        let [u, ud, udd] = w.eval3(t);
        let (s1, c1) = (PI * t).sin_cos();
        let (s2, c2) = (2.0 * PI * t).sin_cos();
        let e = -3.0 + 0.3 * c1 - 0.2 * s1 + 0.05 * c2;
        let ed = PI * (-0.3 * s1 - 0.2 * c1) - 2.0 * PI * 0.05 * s2;
        let edd = -PI * PI * (0.3 * c1 - 0.2 * s1) - 4.0 * PI * PI * 0.05 * c2;
        assert!((u - e).abs() < 1e-14 && (ud - ed).abs() < 1e-13 && (udd - edd).abs() < 1e-12, "{t}");
    }
}

/// The shape's range as constraints ([`DriveGait::range`]): the roller's
/// order-2 gait (`a0`, `a1` free, the second harmonic within 0.1 rad,
/// `b1` held), its angle within 0.5 rad of the fork turned back at 40
/// samples of the period, its mean forward speed maximized. Measured
/// (2.6 s, 28 evaluations): 3.53 m/s, the range binding at its sample
/// `t = 1.9 s` and the second harmonic at two of its bounds, the
/// first-order conditions holding with their multipliers (residual
/// 2.6e-11). (With the second harmonic within 0.3 rad it reaches 8.2 m/s
/// at `a2 = 0.3`, in 65 s: its gaits far apart, each one's search from
/// the last failing, a run of 60 s for each.)
#[test]
fn roller_within_a_range_of_the_shape() {
    let start = FourierGait::new(vec![vec![-PI + 0.1, 0.3, 0.0, 0.05, -0.04]], 2, 2.0).unwrap();
    let gait = DriveGait::new(&["D"], start)
        .free("D.a0", -PI - 0.5, -PI + 0.5)
        .unwrap()
        .free("D.a1", 0.05, 0.6)
        .unwrap()
        .free("D.a2", -0.1, 0.1)
        .unwrap()
        .free("D.b2", -0.1, 0.1)
        .unwrap();
    let constraints = gait.range("D", -PI - 0.5, -PI + 0.5, 40).unwrap();
    assert_eq!(constraints.len(), 80);
    assert_eq!(constraints[2].text(), "D(t = 0.05 s) <= -2.641592653589793");
    let design = gait.design(|| roller(60.0)).unwrap();
    let goal = Goal { constraints, ..maximize(GaitQuantity::MeanForwardSpeed) };
    let t = Instant::now();
    let o = optimize(&design, &goal, &settings(), None, &mut |_| {}).unwrap();
    show("roller, order 2 within a range", &o, t.elapsed().as_secs_f64());
    assert!(o.converged && o.kkt.holds, "{}", o.termination);
    let binding: Vec<&str> = o.kkt.binding.iter().map(|b| b.name.as_str()).collect();
    assert_eq!(binding, ["D(t = 1.9 s) <= -2.641592653589793", "D.a2 <= 0.1", "D.b2 >= -0.1"]);
    // between the samples the angle passes the bound by at most |u''| dt^2 / 8
    let best = gait.gait_at(&o.values);
    let w = super::drive_angle(&best.coefficients[0], 2, best.omega());
    let top = (0..2000).map(|n| w.eval(n as f64 * 1e-3)).fold(f64::NEG_INFINITY, f64::max);
    let c = &best.coefficients[0];
    let curvature = best.omega().powi(2) * (c[1].hypot(c[2]) + 4.0 * c[3].hypot(c[4]));
    let between = curvature * 0.05f64.powi(2) / 8.0;
    assert!(top > -PI + 0.5 && top <= -PI + 0.5 + between, "{top}: {between:e} past the bound at most");
    let r = gait.range("E", -4.0, -3.0, 40).map(|_| ()).unwrap_err().to_string();
    assert!(r.contains("`E` is not a drive of this gait"), "{r}");
    let r = gait.range("D", -3.0, -4.0, 40).map(|_| ()).unwrap_err().to_string();
    assert!(r.contains("the lower below the upper"), "{r}");
    let r = gait.range("D", -4.0, -3.0, 0).map(|_| ()).unwrap_err().to_string();
    assert!(r.contains("give 1 to 1000"), "{r}");
}
