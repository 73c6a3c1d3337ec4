//! Exact force Jacobians (`ForceLaw::jacobian`): every built-in law family
//! and each of its variants against central differences of its own force
//! (`apply_with`) at random states; the analyses' linearization and
//! monodromy matrix with the exact Jacobians against the ones by
//! differences (`Analysis::set_force_differences`); a law of the user's
//! own without a Jacobian differenced and named
//! (`Analysis::differenced_laws`), one with a Jacobian used as it is.
//!
//! The tolerance: a central difference with step `h = eps^(1/3) max(1,
//! |x_j|)` (at most 2e-5 here) has a rounding error of about `eps |f| / h`
//! and a truncation error of `h^2 |f'''| / 6`, together about 1e-10 of the
//! Jacobian's scale for these laws (the sharpest, the smoothed Coulomb
//! rolling resistance with `smoothing` 0.1 m/s, gives 8e-9); every entry
//! must agree to 1e-7 of the largest entry of the law's Jacobian. A wrong
//! sign or factor, a lever term or a turning direction forgotten, is an
//! error of the size of the entry itself.

use crate::common;

use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

use ezy::models::{ChaplyginSleigh, EzyRoller, scenes};
use ezy_core::analysis::{Analysis, PeriodicSettings};
use ezy_core::effects::{
    Anchor, BodyLaw, DragLaw, Effect, ForceLaw, Frame, HingeLaw, HingeRef, HingeTorque, Law, Periodicity, SpringLaw,
    Waveform, Waveforms,
};
use ezy_core::{Model, Problem};
use ezy_scene::Scene;
use rand::Rng;

use crate::optimize::Cart;

/// The EzyRoller with one effect of every built-in kind (tests/effects.rs
/// checks that it has every kind).
const ALL_EFFECTS: &str = include_str!("../data/all_effects.toml");

/// Relative agreement of exact and differenced Jacobians (see the module).
const RTOL: f64 = 1e-7;

/// The step of the central differences: `eps^(1/3) max(1, |x|)`.
fn step(x: f64) -> f64 {
    f64::EPSILON.cbrt() * x.abs().max(1.0)
}

/// `dF/dq` and `dF/dqd` (nq x nq each, row-major) of effect `e` at `(t,
/// q, qd)`: its exact Jacobian (asserted to be given), and central
/// differences of its `apply_with`.
fn both(e: &Effect, t: f64, q: &[f64], qd: &[f64]) -> ([Vec<f64>; 2], [Vec<f64>; 2]) {
    let nq = q.len();
    let wave = e.waveforms(t);
    let (mut dq, mut dqd) = (vec![0.0; nq * nq], vec![0.0; nq * nq]);
    assert!(e.jacobian(t, &wave, q, qd, &mut dq, &mut dqd), "{}: no exact Jacobian", e.name);
    let force = |q: &[f64], qd: &[f64]| {
        let mut f = vec![0.0; nq];
        e.apply_with(t, &wave, q, qd, &mut f);
        f
    };
    let (mut fq, mut fqd) = (vec![0.0; nq * nq], vec![0.0; nq * nq]);
    for j in 0..2 * nq {
        let (mut qp, mut qdp) = (q.to_vec(), qd.to_vec());
        let (mut qm, mut qdm) = (q.to_vec(), qd.to_vec());
        let h = if j < nq {
            let h = step(q[j]);
            qp[j] += h;
            qm[j] -= h;
            h
        } else {
            let h = step(qd[j - nq]);
            qdp[j - nq] += h;
            qdm[j - nq] -= h;
            h
        };
        let (fp, fm) = (force(&qp, &qdp), force(&qm, &qdm));
        let (block, col) = if j < nq { (&mut fq, j) } else { (&mut fqd, j - nq) };
        for i in 0..nq {
            block[i * nq + col] = (fp[i] - fm[i]) / (2.0 * h);
        }
    }
    ([dq, dqd], [fq, fqd])
}

/// The largest difference between exact and differenced Jacobians of `e`
/// at `(t, q, qd)` and the largest entry of either (the scale).
fn error(e: &Effect, t: f64, q: &[f64], qd: &[f64]) -> (f64, f64) {
    let (exact, diff) = both(e, t, q, qd);
    let pairs = || exact.iter().flatten().zip(diff.iter().flatten());
    let err = pairs().map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    let scale = pairs().map(|(a, b)| a.abs().max(b.abs())).fold(0.0, f64::max);
    (err, scale)
}

/// An effect named `name` of law `law`, on.
fn effect(name: &str, law: Law) -> Effect {
    Effect { name: name.into(), value_column: format!("F_{name}"), law, on: true }
}

/// The effects of `all_effects.toml`, resolved on the EzyRoller (nq = 6:
/// body 1 `(x1, y1, phi1)` at 0..3, body 2 at 3..6), and more variants
/// built here: each hinge law at a ground hinge (one heading), a world
/// force and a spring-damper to the ground at off-centre points, and
/// anisotropic drag at a centre of mass.
fn every_law() -> Vec<Effect> {
    let scene = Scene::from_toml(ALL_EFFECTS, "all-effects.toml").unwrap();
    let mut out = common::setup::<EzyRoller>(&scene, &[]).unwrap().effects;
    let ground = HingeRef { index: 0, a: 5, b: None };
    let torques = [
        ("motor", HingeTorque::Motor(Waveform::Constant(1.5))),
        ("spring", HingeTorque::Spring { stiffness: 3.0, rest_angle: 0.4 }),
        ("damper", HingeTorque::Damper { damping: 0.7 }),
        ("servo", HingeTorque::Servo { stiffness: 5.0, damping: 0.3, angle: Waveform::Constant(0.2) }),
        ("bearing", HingeTorque::Friction { damping: 0.05, torque: 0.4, smoothing: 0.5 }),
    ];
    for (name, torque) in torques {
        out.push(effect(&format!("ground_{name}"), Law::Hinge(HingeLaw { hinge: ground, torque })));
    }
    let (b1, b2) = ([0, 1, 2], [3, 4, 5]);
    out.push(effect(
        "world_force_off_centre",
        Law::Body(BodyLaw::Force {
            body: b2,
            offset: [0.3, -0.2],
            fx: Waveform::Constant(1.5),
            fy: Waveform::Constant(-0.7),
            frame: Frame::World,
        }),
    ));
    let spring = |ends, force| {
        Law::Spring(SpringLaw {
            ends,
            stiffness: 7.0,
            rest_length: 0.2,
            damping: 0.9,
            force: Waveform::Constant(force),
        })
    };
    out.push(effect(
        "spring_point_to_ground",
        spring([Anchor::Body { body: b2, offset: [-0.4, 0.15] }, Anchor::Ground([0.5, -1.0])], -0.6),
    ));
    let centre = ezy_core::effects::Blade { body: b1, offset: [0.0, 0.0], dir: [0.6, 0.8] };
    out.push(effect(
        "anisotropic_at_centre",
        Law::Drag(DragLaw::Anisotropic { blade: centre, c_along: 0.4, c_across: 3.0 }),
    ));
    out
}

/// Whether every spring-damper of `effects` is at least 0.2 m long at `q`
/// (away from zero length, where it has no direction).
fn springs_long(effects: &[Effect], q: &[f64]) -> bool {
    effects.iter().filter_map(|e| e.spring_ends(q)).all(|[(a, _), (b, _)]| (a[0] - b[0]).hypot(a[1] - b[1]) > 0.2)
}

/// Every built-in law family and variant (hinge: motor, spring, damper,
/// servo, friction, between bodies and at the ground; blade: viscous and
/// smoothed Coulomb rolling resistance, driven wheel; body: force in world
/// and body axes at a centre and at points, torque, slope, gravity; drag:
/// linear, quadratic, anisotropic at a point and at a centre;
/// spring-damper between bodies and to the ground;
/// skate friction): its exact Jacobian against central differences of
/// its force at 40 random states and times, to 1e-7 of the Jacobian's
/// largest entry. Measured: 8e-9 at worst (the smoothed Coulomb law),
/// 3e-10 or below for the others.
#[test]
fn every_built_in_law_matches_differences_of_its_force() {
    let effects = every_law();
    let mut rng = common::rng(68);
    // per effect: the largest relative error, with its error and scale
    let mut worst: Vec<(f64, f64, f64)> = vec![(0.0, 0.0, 0.0); effects.len()];
    let mut time_only = std::collections::BTreeSet::new();
    let mut states = 0;
    while states < 40 {
        let (q, qd) = common::random_state_n(6, &mut rng);
        if !springs_long(&effects, &q) {
            continue;
        }
        states += 1;
        let t = rng.random_range(0.0..2.0);
        for (e, w) in effects.iter().zip(&mut worst) {
            let (err, scale) = error(e, t, &q, &qd);
            // a law that says its force depends on time alone (which the
            // sensitivities then skip): both Jacobians 0, exactly
            if e.law.as_force_law().time_only() {
                assert_eq!(scale, 0.0, "{}: time_only, but its force moves with the state", e.name);
                time_only.insert(e.name.clone());
            }
            assert!(
                err <= RTOL * scale,
                "{}: exact and differenced Jacobians differ by {err:e} (scale {scale:e})",
                e.name
            );
            let rel = if scale > 0.0 { err / scale } else { 0.0 };
            if rel >= w.0 {
                *w = (rel, err, scale);
            }
        }
    }
    for (e, (rel, err, scale)) in effects.iter().zip(&worst) {
        eprintln!("{:>24}: max |exact - differences| {err:.1e}, relative {rel:.1e} (scale {scale:.2e})", e.name);
    }
    // the motors, a body torque and a field say so (the flag is not idle)
    assert!(time_only.len() >= 3, "time_only laws: {time_only:?}");
}

/// The laws that are not smooth everywhere, at their corners: the hinge
/// friction's `tanh` and the smoothed Coulomb law are smooth at rest, and
/// their exact slopes there (`-(damping + torque / smoothing)`, `-force /
/// smoothing` along the blade) match differences to 1e-7; the quadratic
/// drag's `|v| v` is differentiable at rest with derivative 0, which the
/// exact Jacobian gives, while the central difference there is `-c h`
/// (first order: `|v| v` has no second derivative at 0).
#[test]
fn laws_at_rest_have_their_smooth_derivatives() {
    let effects = every_law();
    let q = [0.3, -0.2, 0.4, 1.1, 0.1, 2.9];
    let rest = [0.0; 6];
    let t = 0.7;
    for name in ["bearing", "coulomb", "rolling", "air"] {
        let e = effects.iter().find(|e| e.name == name).unwrap();
        let (err, scale) = error(e, t, &q, &rest);
        assert!(err <= RTOL * scale, "{name} at rest: {err:e} of {scale:e}");
    }
    // the bearing's slope at rest
    let bearing = effects.iter().find(|e| e.name == "bearing").unwrap();
    let (exact, _) = both(bearing, t, &q, &rest);
    assert!((exact[1][2 * 6 + 2] + (0.05 + 0.4 / 0.5)).abs() < 1e-15, "{}", exact[1][2 * 6 + 2]);
    // quadratic drag (`form`, c = 0.3, c_rot = 0.1 on body 2) at rest
    let form = effects.iter().find(|e| e.name == "form").unwrap();
    let (exact, diff) = both(form, t, &q, &rest);
    assert!(exact.iter().flatten().all(|v| *v == 0.0), "{exact:?}");
    let h = step(0.0);
    let largest = diff.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(largest <= 0.3 * h * (1.0 + 1e-9), "differences at rest {largest:e}, c h = {:e}", 0.3 * h);
}

/// A spring-damper between two points of one body is a pair of internal
/// forces: its generalized force is zero at every state, and so is its
/// exact Jacobian, whose terms (each end's force along each of the
/// body's coordinates and velocities, added into the same entries) are of
/// the size `k l^2`, `T l` and cancel to rounding: below 1e-12 of the
/// stiffness at 20 random states.
#[test]
fn a_spring_within_one_body_has_a_zero_jacobian() {
    let ends =
        [Anchor::Body { body: [0, 1, 2], offset: [0.3, -0.1] }, Anchor::Body { body: [0, 1, 2], offset: [-0.2, 0.25] }];
    let law = SpringLaw { ends, stiffness: 7.0, rest_length: 0.2, damping: 0.9, force: Waveform::Constant(0.3) };
    let e = effect("spring_within_one_body", Law::Spring(law));
    let mut rng = common::rng(6);
    for _ in 0..20 {
        let (q, qd) = common::random_state_n(6, &mut rng);
        let (exact, _) = both(&e, 0.0, &q, &qd);
        let largest = exact.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(largest < 1e-12 * 7.0, "{largest:e}");
    }
}

/// An effect switched off has a zero Jacobian, given exactly.
#[test]
fn an_effect_switched_off_adds_nothing() {
    let mut effects = every_law();
    let (q, qd) = ([0.3, -0.2, 0.4, 1.1, 0.1, 2.9], [0.5, -0.3, 0.7, 0.2, 0.6, -1.3]);
    for e in &mut effects {
        e.on = false;
        let (mut dq, mut dqd) = (vec![0.0; 36], vec![0.0; 36]);
        assert!(e.jacobian(0.5, &e.waveforms(0.5), &q, &qd, &mut dq, &mut dqd), "{}", e.name);
        assert!(dq.iter().chain(&dqd).all(|v| *v == 0.0), "{}", e.name);
    }
}

/// `A` at `(t, x)` with the exact force Jacobians and with every force by
/// differences: the largest difference and the largest entry of `A`, and
/// the analysis' differenced laws after the exact one.
fn linearizations<M: Model>(an: &mut Analysis<M>, t: f64, x: &[f64]) -> (f64, f64) {
    an.set_force_differences(false);
    let exact = an.linearize(t, x, &[]).unwrap();
    assert!(!exact.forces_by_differences);
    an.set_force_differences(true);
    let diff = an.linearize(t, x, &[]).unwrap();
    an.set_force_differences(false);
    assert!(diff.forces_by_differences);
    assert!(an.differenced_laws().is_empty(), "{:?}", an.differenced_laws());
    let n = x.len();
    let mut err = 0.0f64;
    for i in 0..n {
        for j in 0..n {
            err = err.max((exact.a[(i, j)] - diff.a[(i, j)]).abs());
        }
    }
    (err, exact.a.norm_max())
}

/// `x0` moved off any special state: `x_i + 0.05 sin(1.7 i)`.
fn perturbed(x0: &[f64]) -> Vec<f64> {
    x0.iter().enumerate().map(|(i, v)| v + 0.05 * (1.7 * i as f64).sin()).collect()
}

/// The linearization `A = df/dx` with the laws' exact Jacobians against
/// the one with every force differenced (as before them), to 1e-7 of
/// `A`'s largest entry, on `drive-rolling-resistance` (a motor and
/// viscous rolling resistance), `sleigh-drag` (linear drag) and the
/// EzyRoller under every built-in kind but skate friction (which the
/// analyses refuse where the skate slides): measured 5e-13, 1.3e-12 and
/// 1e-11 of the largest entry. No law is named as differenced.
#[test]
fn linearization_agrees_with_the_one_by_differences() {
    let scene = scenes::get("drive-rolling-resistance");
    let (mut an, x0) = scene.problem::<EzyRoller>(&[]).unwrap().0.analysis().unwrap();
    let (err, scale) = linearizations(&mut an, 0.37, &perturbed(&x0));
    eprintln!("drive-rolling-resistance: A exact against differences {err:.1e} of {scale:.2e}");
    assert!(err <= RTOL * scale, "{err:e} of {scale:e}");

    let (mut an, x0) = scenes::get("sleigh-drag").problem::<ChaplyginSleigh>(&[]).unwrap().0.analysis().unwrap();
    let (err, scale) = linearizations(&mut an, 0.0, &perturbed(&x0));
    eprintln!("sleigh-drag: A exact against differences {err:.1e} of {scale:.2e}");
    assert!(err <= RTOL * scale, "{err:e} of {scale:e}");

    let mut scene = Scene::from_toml(ALL_EFFECTS, "all-effects.toml").unwrap();
    scene.effects.retain(|(name, _)| name != "slip_C");
    let (mut an, x0) = scene.problem::<EzyRoller>(&[]).unwrap().0.analysis().unwrap();
    let (err, scale) = linearizations(&mut an, 0.8, &perturbed(&x0));
    eprintln!("all effects: A exact against differences {err:.1e} of {scale:.2e}");
    assert!(err <= RTOL * scale, "{err:e} of {scale:e}");
}

/// The monodromy matrix of one period of `drive-rolling-resistance` from
/// its start (the variational equations, whose `A` holds the force
/// Jacobians at every step) with the exact Jacobians against the one with
/// every force differenced, to 1e-7 of its largest entry (both integrated
/// at 1e-11: measured 5e-13; the end states agree to 1e-9).
#[test]
fn monodromy_matrix_agrees_with_the_one_by_differences() {
    let (mut an, x0) = scenes::get("drive-rolling-resistance").problem::<EzyRoller>(&[]).unwrap().0.analysis().unwrap();
    let settings = PeriodicSettings::default();
    let (end, exact, _) = an.flow(0.0, &x0, 2.0, &settings).unwrap();
    an.set_force_differences(true);
    let (end_diff, diff, _) = an.flow(0.0, &x0, 2.0, &settings).unwrap();
    let n = x0.len();
    let err = (0..n * n).map(|k| (exact[(k / n, k % n)] - diff[(k / n, k % n)]).abs()).fold(0.0, f64::max);
    let scale = exact.norm_max();
    eprintln!("monodromy exact against differences {err:.1e} of {scale:.2e}");
    assert!(err <= RTOL * scale, "{err:e} of {scale:e}");
    assert!(end.iter().zip(&end_diff).all(|(a, b)| (a - b).abs() < 1e-9), "{end:?} {end_diff:?}");
}

/// A stiffening spring and a damper on the cart (`crate::optimize::Cart`,
/// x along its rail): `-k x - k3 x^3 - c xd` \[N\], counting its
/// evaluations; with or without its exact Jacobian, or one that writes
/// into the blocks and then says it has none (its writes must be dropped).
#[derive(Debug)]
struct Stiffening {
    k: f64,
    k3: f64,
    c: f64,
    jacobian: Jac,
    applied: Arc<AtomicUsize>,
    differentiated: Arc<AtomicUsize>,
}

/// What [`Stiffening`]'s `jacobian` does.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Jac {
    /// The default: none.
    None,
    /// The exact one.
    Exact,
    /// Writes nonsense and returns `false`.
    Liar,
}

impl ForceLaw for Stiffening {
    fn apply(&self, _t: f64, q: &[f64], qd: &[f64], f: &mut [f64]) -> (f64, f64) {
        self.applied.fetch_add(1, Ordering::Relaxed);
        let fx = -self.k * q[0] - self.k3 * q[0].powi(3) - self.c * qd[0];
        f[0] += fx;
        (fx * qd[0], fx)
    }
    fn coords(&self) -> Vec<usize> {
        vec![0]
    }
    fn periodicity(&self) -> Option<Periodicity> {
        Some(Periodicity::Constant)
    }
    fn jacobian(&self, _t: f64, _w: &Waveforms, q: &[f64], _qd: &[f64], dq: &mut [f64], dqd: &mut [f64]) -> bool {
        self.differentiated.fetch_add(1, Ordering::Relaxed);
        match self.jacobian {
            Jac::None => false,
            Jac::Exact => {
                // (0, 0) of each (nq x nq) block: f[0] along q[0], qd[0]
                dq[0] += -self.k - 3.0 * self.k3 * q[0] * q[0];
                dqd[0] += -self.c;
                true
            }
            Jac::Liar => {
                dq.iter_mut().chain(dqd.iter_mut()).for_each(|v| *v += 1e3);
                false
            }
        }
    }
}

/// The cart (mass 2 kg) under [`Stiffening`] with `jacobian`, linearized
/// at `x = 0.4 m`, `xd = 0.3 m/s`: `A`'s rows of `xdd`, the analysis'
/// differenced laws, whether the linearization says it differenced, and
/// the counts of the law's evaluations and Jacobians during the
/// linearization.
fn cart_linearized(jacobian: Jac) -> ([f64; 2], Vec<String>, bool, usize, usize) {
    let (applied, differentiated) = (Arc::new(AtomicUsize::new(0)), Arc::new(AtomicUsize::new(0)));
    let law = Stiffening {
        k: 8.0,
        k3: 5.0,
        c: 0.5,
        jacobian,
        applied: applied.clone(),
        differentiated: differentiated.clone(),
    };
    let p = Problem::new(Cart::default()).law("stiffening", law).unwrap().q("x", 0.0).unwrap().qd("x", 0.0).unwrap();
    let (mut an, _) = p.analysis().unwrap();
    let x = [0.4, 0.0, 0.0, 0.3, 0.0, 0.0];
    applied.store(0, Ordering::Relaxed);
    let lin = an.linearize(0.0, &x, &[]).unwrap();
    let a = [lin.a[(3, 0)], lin.a[(3, 3)]];
    (
        a,
        an.differenced_laws(),
        lin.forces_by_differences,
        applied.load(Ordering::Relaxed),
        differentiated.load(Ordering::Relaxed),
    )
}

/// A law of the user's own: without `jacobian` its force is differenced
/// (4 nq = 12 more evaluations), it is named by `differenced_laws` and
/// the linearization says so, and `A` agrees with the closed form
/// `xdd = (-k x - k3 x^3 - c xd) / m` to 1e-8 (measured 2e-11); with an
/// exact `jacobian` it is used as it is (one evaluation, the force at the
/// state; nothing named) and `A` agrees to rounding (1e-14); a law that
/// writes into the blocks and returns `false` is differenced, its writes
/// dropped.
#[test]
fn a_users_law_is_differenced_without_a_jacobian_and_exact_with_one() {
    let m = 2.0;
    let want = [(-8.0 - 3.0 * 5.0 * 0.4 * 0.4) / m, -0.5 / m];
    let (a, named, said, applied, differentiated) = cart_linearized(Jac::None);
    eprintln!("without a Jacobian: A {a:?} want {want:?}, {applied} evaluations");
    assert_eq!(named, vec!["stiffening".to_string()]);
    assert!(said);
    assert!(differentiated >= 1);
    assert!(applied >= 12, "{applied} evaluations");
    assert!((a[0] - want[0]).abs() < 1e-8 * want[0].abs() && (a[1] - want[1]).abs() < 1e-8 * want[1].abs(), "{a:?}");

    let (a, named, said, applied, differentiated) = cart_linearized(Jac::Exact);
    eprintln!("with its Jacobian: A {a:?} want {want:?}, {applied} evaluations");
    assert!(named.is_empty(), "{named:?}");
    assert!(!said);
    assert!(differentiated >= 1);
    assert!(applied < 12, "{applied} evaluations: differenced");
    assert!((a[0] - want[0]).abs() < 1e-14 * want[0].abs() && (a[1] - want[1]).abs() < 1e-14 * want[1].abs(), "{a:?}");

    let (a, named, said, _, _) = cart_linearized(Jac::Liar);
    assert_eq!(named, vec!["stiffening".to_string()]);
    assert!(said);
    assert!((a[0] - want[0]).abs() < 1e-8 * want[0].abs() && (a[1] - want[1]).abs() < 1e-8 * want[1].abs(), "{a:?}");
}

/// The SpringDamper of tests/optimize.rs (no `jacobian`) on the cart:
/// differenced, named, and its `A` the closed form `-k / m`, `-c / m`.
#[test]
fn the_optimize_tests_spring_damper_is_differenced() {
    let p = crate::optimize::cart(crate::optimize::K, 0.5, None, 0.2, 1.0).unwrap();
    let (mut an, x0) = p.analysis().unwrap();
    let lin = an.linearize(0.0, &x0, &[]).unwrap();
    assert_eq!(an.differenced_laws(), vec!["spring".to_string()]);
    assert!(lin.forces_by_differences);
    let (k, m) = (crate::optimize::K, crate::optimize::M);
    assert!((lin.a[(3, 0)] + k / m).abs() < 1e-8 * k / m, "{}", lin.a[(3, 0)]);
    assert!((lin.a[(3, 3)] + 0.5 / m).abs() < 1e-8, "{}", lin.a[(3, 3)]);
}
