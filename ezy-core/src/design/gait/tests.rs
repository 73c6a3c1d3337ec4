//! Gait optimization on the three-link kinematic snake (the model of
//! `models/src/kinematic_snake.rs`, written here with `model!`: the
//! models crate is out of ezy-core's reach).

use super::*;
use crate::geometry::Geometry;

crate::model! {
    /// The three-link kinematic snake (as `ezy_models::KinematicSnake`).
    pub struct Snake {
        param l = 1.0;
        param m = 1.0;
        param I = 0.08333333333333333;
        body rear(x1, y1, phi1) { mass: m, inertia: I }
        body middle(x2, y2, phi2) { mass: m, inertia: I }
        body front(x3, y3, phi3) { mass: m, inertia: I }
        point S1 on rear at (0, 0);
        point R on rear at (l / 2, 0);
        point M0 on middle at (-l / 2, 0);
        point S2 on middle at (0, 0);
        point M1 on middle at (l / 2, 0);
        point F on front at (-l / 2, 0);
        point S3 on front at (0, 0);
        hinge alpha1: M0 = R;
        hinge alpha2: F = M1;
        drive D1: hinge alpha1;
        drive D2: hinge alpha2;
        skate S1: S1 along (1, 0);
        skate S2: S2 along (1, 0);
        skate S3: S3 along (1, 0);
    }
}

fn snake() -> Geometry<Snake> {
    Geometry::new(Snake::default(), None, None).unwrap()
}

use evaluate::{Setup, evaluate};
use std::f64::consts::PI;

/// A generic order-2 gait below the singular line `alpha1 = alpha2`.
fn order2() -> FourierGait {
    FourierGait::new(vec![vec![0.9, 0.5, 0.1, 0.05, -0.08], vec![-0.8, -0.12, 0.45, 0.07, 0.03]], 2, 2.0 * PI).unwrap()
}

fn objective(measure: Measure, per_cost: bool, order: Order) -> GaitObjective {
    GaitObjective { measure, per_cost, order }
}

/// The evaluation's setup for `problem` (all of `check`).
fn setup_of(g: &Geometry<Snake>, problem: &GaitOptimization) -> Setup {
    check(g, problem).unwrap()
}

/// The Fourier gait as waveforms runs through `predict` to the same net
/// motion as the optimization's own quadratures and reconstruction: the
/// first order to 1e-12 (measured 1.7e-15), the second (the same
/// quadrature) to 1e-13 (1.7e-16), the reconstruction (both DOP853 at
/// 1e-12, in one span and in 200) to 1e-10 (4.1e-15).
#[test]
fn the_optimizations_net_motion_is_predicts() {
    let mut g = snake();
    let start = order2();
    let p = g.predict(&start.gait().unwrap(), &[]).unwrap();
    let x = start.flat();
    let mut worst = [0.0f64; 3];
    for (k, order) in [Order::First, Order::Second, Order::Reconstructed].into_iter().enumerate() {
        let problem = GaitOptimization::new(start.clone(), objective(Measure::Along([1.0, 0.0]), false, order));
        let point = evaluate(&g, &setup_of(&g, &problem), &x, 0.0).unwrap();
        let want = [p.first, p.second.unwrap(), p.reconstructed][k];
        worst[k] = (0..3).map(|c| (point.motion[c] - want[c]).abs()).fold(0.0, f64::max);
    }
    println!(
        "net motion against predict: first {:.1e}, second {:.1e}, reconstructed {:.1e}",
        worst[0], worst[1], worst[2]
    );
    assert!(worst[0] < 1e-12 && worst[1] < 1e-13 && worst[2] < 1e-10, "{worst:?}");
}

/// Central differences of `f` at `x` in every direction, step `h`.
fn central(f: &dyn Fn(&[f64]) -> f64, x: &[f64], h: f64) -> Vec<f64> {
    (0..x.len())
        .map(|k| {
            let (mut a, mut b) = (x.to_vec(), x.to_vec());
            a[k] += h;
            b[k] -= h;
            (f(&a) - f(&b)) / (2.0 * h)
        })
        .collect()
}

/// Central differences on steps 1e-3 and 5e-4 extrapolated (Richardson):
/// truncation like h^4 (1e-12), rounding the value's error over the step
/// (1e-16 / 5e-4 for a quadrature, the integration's 1e-12 / 5e-4 for
/// the reconstruction).
fn richardson(f: &dyn Fn(&[f64]) -> f64, x: &[f64]) -> Vec<f64> {
    let (a, b) = (central(f, x, 1e-3), central(f, x, 5e-4));
    a.iter().zip(&b).map(|(a, b)| (4.0 * b - a) / 3.0).collect()
}

/// `max |a - b| / max |b|`.
fn relative(a: &[f64], b: &[f64]) -> f64 {
    let top = b.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max) / top
}

/// Every objective's exact gradient in the ten coefficients of an order-2
/// gait (all three orders; dx, a displacement per path length in a
/// metric, dtheta) against central differences of its value
/// ([`richardson`]), and the path length's and the rank margin's: to 1e-7
/// relative (of the largest component; measured at most 7e-12, the
/// reconstruction's variational equations integrated in the same DOP853
/// run as its value).
#[test]
fn exact_gradients_match_central_differences() {
    let g = snake();
    let start = order2();
    let x = start.flat();
    let mut report = Vec::new();
    for order in [Order::First, Order::Second, Order::Reconstructed] {
        for (measure, per_cost) in
            [(Measure::Along([1.0, 0.0]), false), (Measure::Along([0.6, -0.8]), true), (Measure::Rotation, false)]
        {
            let mut problem = GaitOptimization::new(start.clone(), objective(measure, per_cost, order));
            problem.metric = Some(vec![2.0, 0.3, 0.3, 1.0]);
            problem.margin = Some(0.01);
            let setup = setup_of(&g, &problem);
            let p = evaluate(&g, &setup, &x, 0.0).unwrap();
            let f = |y: &[f64]| evaluate(&g, &setup, y, 0.0).unwrap().objective;
            let fd = richardson(&f, &x);
            let err = relative(&p.gradient, &fd);
            report.push(format!("{}: {err:.1e}", problem.objective.name()));
            assert!(err < 1e-7, "{}: {err:e}\n{:?}\n{fd:?}", problem.objective.name(), p.gradient);
            if order == Order::First && per_cost {
                let fd = richardson(&|y| evaluate(&g, &setup, y, 0.0).unwrap().cost, &x);
                let err = relative(&p.cost_gradient, &fd);
                report.push(format!("path length: {err:.1e}"));
                assert!(err < 1e-7, "cost: {err:e}");
                // the margin at a few samples
                for n in [0, 37, 150] {
                    let fd = richardson(&|y| evaluate(&g, &setup, y, 0.0).unwrap().margins[n].0, &x);
                    let err = relative(&p.margins[n].1, &fd);
                    report.push(format!("rank margin at sample {n}: {err:.1e}"));
                    assert!(err < 1e-7, "margin {n}: {err:e}");
                }
            }
        }
    }
    println!("{}", report.join("\n"));
}

/// The first order's gradient is the Stokes variation `delta oint -A dr =
/// -oint (dA_j/dr_i - dA_i/dr_j) delta r_i r'_j dt` (the exterior
/// derivative of the connection contracted with the variation and the
/// velocity; only `dA`, no bracket), evaluated here from
/// [`Geometry::curvature`]'s `dA/dr` by the trapezoidal rule on 400
/// samples: agreement to 1e-10 of the gradient.
#[test]
fn the_first_orders_gradient_is_the_stokes_variation() {
    let g = snake();
    let start = order2();
    let x = start.flat();
    let problem = GaitOptimization::new(start.clone(), objective(Measure::Along([1.0, 0.0]), false, Order::First));
    let setup = setup_of(&g, &problem);
    let p = evaluate(&g, &setup, &x, 0.0).unwrap();
    let (n, ns, per) = (400, 2, start.per_coordinate());
    let mut stokes = vec![0.0; x.len()];
    for s in 0..n {
        let t = start.period * s as f64 / n as f64;
        let (r, rd) = fourier::shape_at(&x, ns, start.omega(), t);
        let c = g.curvature(&r).unwrap();
        // dA_x,j / dr_i: block i, row 0, column j
        let da = |i: usize, j: usize| c.da[i * 3 * ns + j];
        for (k, st) in stokes.iter_mut().enumerate() {
            let (i, b) = (k / per, fourier::basis(k % per, start.omega(), t).0);
            let v: f64 = (0..ns).map(|j| (da(i, j) - da(j, i)) * rd[j]).sum();
            *st -= v * b * start.period / n as f64;
        }
    }
    let err = relative(&p.gradient, &stokes);
    println!("first order's gradient against the Stokes variation: {err:.1e}");
    assert!(err < 1e-10, "{err:e}\n{:?}\n{stokes:?}", p.gradient);
}

/// The circle of radius 0.6 (the kinematic-snake scene's) whose centre
/// maximizes the second-order lateral motion `dy` (the least drift to the
/// right of the circles below the singular line): SLSQP on the two
/// centre coefficients, the amplitudes held, finds the centre a dense
/// scan of `predict`'s own second order finds (13 x 13 points 0.15 apart
/// over [0.3, 2.1] x [-2.1, -0.3], then twice 11 x 11 points a fifth of
/// the last step apart about the best: resolution 0.006), to the scan's
/// resolution, with a value at least the scan's best; the objective's
/// gradient in the centre equals central differences to 1e-7 (measured
/// 2e-12); the optimization converges with the KKT conditions holding,
/// in under a second (release build: 21 evaluations, 0.2 to 0.35 s on a
/// shared machine).
#[test]
fn a_circles_best_centre_is_the_dense_scans() {
    let g = snake();
    let radius = 0.6;
    let circle = |c: [f64; 2]| FourierGait::circle(c, radius, 0.0, 2.0 * PI).unwrap();
    let goal = objective(Measure::Along([0.0, 1.0]), false, Order::Second);
    let problem = GaitOptimization::new(circle([0.7, -0.6]), goal).centre_only();
    // the gradient at the start against differences
    let setup = setup_of(&g, &problem);
    let x0 = [0.7, -0.6];
    let p = evaluate(&g, &setup, &x0, 0.0).unwrap();
    let fd = richardson(&|y| evaluate(&g, &setup, y, 0.0).unwrap().objective, &x0);
    let gradient_error = relative(&p.gradient, &fd);
    assert!(gradient_error < 1e-7, "{gradient_error:e}");
    let clock = std::time::Instant::now();
    let opt = optimize_gait(&g, &problem).unwrap();
    let elapsed = clock.elapsed().as_secs_f64();
    // the scan
    let mut scan = snake();
    let mut value =
        |c: [f64; 2]| scan.predict(&circle(c).gait().unwrap(), &[]).map_or(f64::NEG_INFINITY, |p| p.second.unwrap()[1]);
    let (mut best, mut best_value, mut step) = ([0.0; 2], f64::NEG_INFINITY, 0.15);
    for i in 0..13 {
        for j in 0..13 {
            let c = [0.3 + step * j as f64, -0.3 - step * i as f64];
            let v = value(c);
            if v > best_value {
                (best, best_value) = (c, v);
            }
        }
    }
    for _ in 0..2 {
        let (centre, fine) = (best, step / 5.0);
        for i in -5..=5 {
            for j in -5..=5 {
                let c = [centre[0] + fine * j as f64, centre[1] + fine * i as f64];
                let v = value(c);
                if v > best_value {
                    (best, best_value) = (c, v);
                }
            }
        }
        step = fine;
    }
    let gap = [(opt.values[0] - best[0]).abs(), (opt.values[1] - best[1]).abs()];
    println!(
        "circle centre: optimum ({:.6}, {:.6}) dy = {:.12} in {} evaluations, {elapsed:.3} s ({}); scan ({:.4}, {:.4}) dy = {best_value:.12}, resolution {step}; gradient against differences {gradient_error:.1e}; {}",
        opt.values[0],
        opt.values[1],
        opt.objective,
        opt.history.len(),
        opt.termination,
        best[0],
        best[1],
        opt.kkt.describe()
    );
    assert!(opt.converged && opt.kkt.holds, "{opt:?}");
    assert!(gap[0] <= step && gap[1] <= step, "{gap:?}");
    assert!(opt.objective >= best_value - 1e-12, "{} < {best_value}", opt.objective);
    assert!(opt.objective > opt.start_objective);
    assert!(elapsed < 1.0, "{elapsed} s");
}

/// The efficiency of Ramasamy & Hatton (2019), `dx` per unit path length
/// (first order), over ellipses (order 1; `alpha1`'s `b1` held at 0 to
/// fix the phase, which only shifts time), from a circle of radius 0.4
/// about (0.9, -0.9). The kinematic snake's height functions grow
/// without bound toward the singular set `alpha1 = alpha2`, and so does
/// the efficiency: the search without a margin runs into it and ends not
/// converged at its best point (never an error, never the start). With a
/// rank margin of 0.2 it converges to a KKT point: the stationarity
/// residual below 1e-8 of the objective's scaled gradient (measured
/// 8.1e-9), the margin binding by name, the efficiency 2.9 times the
/// start's. A search cut short (two evaluations, or SLSQP stopped by a
/// huge `xtol`) is not converged; the optimum as a start is its own.
#[test]
fn the_efficient_gait_is_a_kkt_point_and_the_start_is_not() {
    let g = snake();
    let goal = objective(Measure::Along([1.0, 0.0]), true, Order::First);
    let mut problem = GaitOptimization::new(FourierGait::circle([0.9, -0.9], 0.4, 0.0, 2.0 * PI).unwrap(), goal);
    problem.free[2] = false;
    // without a margin: into the singular set
    let free = optimize_gait(&g, &problem).unwrap();
    println!("without a margin: {} ({:.4} from {:.4})", free.termination, free.objective, free.start_objective);
    assert!(!free.converged && free.termination.contains("singular set"), "{}", free.termination);
    assert!(free.objective > free.start_objective);
    // with one
    problem.margin = Some(0.2);
    let clock = std::time::Instant::now();
    let opt = optimize_gait(&g, &problem).unwrap();
    let elapsed = clock.elapsed().as_secs_f64();
    println!(
        "with a margin of 0.2: {:?}, dx/L = {:.10} from {:.10}, dx = {:.6} m, L = {:.6} rad, least margin {:.6}, {} evaluations, {elapsed:.3} s, {}; {}",
        opt.gait.coefficients,
        opt.objective,
        opt.start_objective,
        opt.motion[0],
        opt.cost,
        opt.rank_margin,
        opt.history.len(),
        opt.termination,
        opt.kkt.describe()
    );
    assert!(opt.converged && opt.kkt.holds, "{opt:?}");
    // the objective's scale: its scaled gradient, the larger of the
    // start's (0.1 by the scaling) and the optimum's (the KKT check's
    // tolerance is 1e-4 of it); measured 8.1e-9 of it
    let scale = opt.kkt.tolerance / 1e-4;
    println!("KKT residual {:.2e} of the objective's scale", opt.kkt.residual / scale);
    assert!(opt.kkt.residual < 1e-8 * scale, "{}", opt.kkt.describe());
    assert!(opt.kkt.binding.iter().any(|b| b.name.starts_with("rank margin >= 0.2")), "{}", opt.kkt.describe());
    assert!((opt.rank_margin - 0.2).abs() < 1e-6, "{}", opt.rank_margin);
    assert!(opt.objective > 2.0 * opt.start_objective);
    // a search cut short is not converged, though SLSQP's word would be
    // taken at a step shorter than a huge xtol
    let mut short = problem.clone();
    short.max_evaluations = 2;
    let cut = optimize_gait(&g, &short).unwrap();
    assert!(!cut.converged && !cut.kkt.holds, "{cut:?}");
    let mut coarse = problem.clone();
    coarse.xtol = 0.9;
    let early = optimize_gait(&g, &coarse).unwrap();
    println!("xtol 0.9: {} after {} evaluations", early.termination, early.history.len());
    assert!(!early.converged || early.kkt.holds, "{early:?}");
    assert!(!early.converged, "{}", early.termination);
    // the optimum as the start: it is its own optimum, converged
    let mut again = problem.clone();
    again.start = opt.gait.clone();
    let same = optimize_gait(&g, &again).unwrap();
    assert!(same.converged && (same.objective - opt.objective).abs() < 1e-9 * opt.objective, "{same:?}");
}

crate::model! {
    /// One body on a skate: no hinge, so no shape.
    pub struct Blade {
        body b(x, y, phi) { mass: 1.0, inertia: 0.1 }
        point P on b at (0, 0);
        skate S: P along (1, 0);
    }
}

/// What gait optimization refuses, each by name: a start that meets the
/// singular set (the time and shape where), a range whose lower bound is
/// above its upper or not finite, a margin outside (0, 1), a metric that
/// is not positive definite (the cost would not bound the gait), an
/// efficiency from a gait of zero length, no free coefficient, a start
/// beyond the coefficient limit, and a model without shape coordinates.
#[test]
fn refusals_are_named() {
    let g = snake();
    let goal = objective(Measure::Along([1.0, 0.0]), true, Order::First);
    let good = FourierGait::circle([0.9, -0.9], 0.4, 0.0, 2.0 * PI).unwrap();
    let refused = |p: &GaitOptimization| optimize_gait(&g, p).unwrap_err().to_string();
    // a circle about the singular line
    let crossing = GaitOptimization::new(FourierGait::circle([0.3, 0.2], 0.5, 0.0, 2.0 * PI).unwrap(), goal);
    let e = optimize_gait(&g, &crossing).unwrap_err();
    assert!(matches!(e, GeometryError::Singular { .. }), "{e}");
    let e = e.to_string();
    assert!(e.starts_with("the start: the gait meets the singular set at t = ") && e.contains("alpha1 = "), "{e}");
    for (bounds, word) in [
        ((1.0, -1.0), "the range of alpha2: [1, -1]"),
        ((f64::NAN, 1.0), "the range of alpha2: [NaN, 1]"),
        ((-1.0, f64::INFINITY), "the range of alpha2: [-1, inf]"),
    ] {
        let mut p = GaitOptimization::new(good.clone(), goal);
        p.bounds = vec![None, Some(bounds)];
        let e = refused(&p);
        assert!(e.contains(word) && e.contains("finite bounds, the lower below the upper"), "{e}");
    }
    let mut p = GaitOptimization::new(good.clone(), goal);
    p.margin = Some(1.5);
    assert!(refused(&p).contains("rank margin 1.5"));
    p.margin = None;
    p.metric = Some(vec![1.0, 1.0, 1.0, 1.0]);
    let e = refused(&p);
    assert!(e.contains("not positive definite") && e.contains("would not bound it"), "{e}");
    let mut p =
        GaitOptimization::new(FourierGait::new(vec![vec![0.9, 0.0, 0.0], vec![-0.9, 0.0, 0.0]], 1, 1.0).unwrap(), goal);
    p.free = vec![false, true, true, false, true, true];
    assert!(refused(&p).contains("zero path length"));
    let mut p = GaitOptimization::new(good.clone(), goal);
    p.free = vec![false; 6];
    assert!(refused(&p).contains("nothing to optimize"));
    p = GaitOptimization::new(good.clone(), goal);
    p.coefficient_limit = 0.5;
    assert!(refused(&p).contains("alpha1.a0 = 0.9 is beyond the coefficient limit"), "{}", refused(&p));
    let blade = Geometry::new(Blade::default(), None, None).unwrap();
    let e = optimize_gait(&blade, &GaitOptimization::new(good, goal)).unwrap_err().to_string();
    assert!(e.contains("has no shape coordinates"), "{e}");
}

crate::model! {
    /// Two links hinged, a skate on the first: the constraints leave the
    /// locked motion two free directions (a mixed system).
    pub struct Sleighs {
        body a(x1, y1, phi1) { mass: 1.0, inertia: 0.1 }
        body b(x2, y2, phi2) { mass: 1.0, inertia: 0.1 }
        point P on a at (0, 0);
        point H on a at (0.5, 0);
        point Q on b at (-0.5, 0);
        hinge h: Q = H;
        skate S: P along (1, 0);
    }
}

/// A mixed system (momentum free) is refused by name: its net motion
/// depends on more than the gait's curve.
#[test]
fn a_mixed_system_is_refused() {
    let g = Geometry::new(Sleighs::default(), None, None).unwrap();
    assert!(!g.is_kinematic());
    let start = FourierGait::new(vec![vec![0.2, 0.3, 0.0]], 1, 1.0).unwrap();
    let e = optimize_gait(&g, &GaitOptimization::new(start, objective(Measure::Rotation, false, Order::First)))
        .unwrap_err()
        .to_string();
    assert!(e.contains("momentum component(s) free") && e.contains("kinematic systems"), "{e}");
}

/// The reconstructed `dx` over ellipses (order 1, the phase held) under
/// every kind of constraint at once: a path-length budget of 4 rad, a
/// rank margin of 0.2, `alpha1` within [0.1, 1.9] and `alpha2` within
/// [-1.9, -0.1] over the cycle. It converges to a KKT point whose binding
/// constraints are named (the budget, the margin and two ranges),
/// feasible within 1e-9 at the quadrature's samples, and 3.4 times the
/// start's `dx`. The ranges are held at the 200 samples only: between
/// them the curve may pass a bound by `|r''| dt^2 / 8` (8e-5 rad here,
/// 1.5e-5 measured on 400 points).
#[test]
fn constraints_bind_by_name() {
    let g = snake();
    let goal = objective(Measure::Along([1.0, 0.0]), false, Order::Reconstructed);
    let mut problem = GaitOptimization::new(FourierGait::circle([0.9, -0.9], 0.4, 0.0, 2.0 * PI).unwrap(), goal);
    problem.free[2] = false;
    problem.budget = Some(4.0);
    problem.margin = Some(0.2);
    problem.bounds = vec![Some((0.1, 1.9)), Some((-1.9, -0.1))];
    let clock = std::time::Instant::now();
    let opt = optimize_gait(&g, &problem).unwrap();
    let elapsed = clock.elapsed().as_secs_f64();
    println!(
        "constrained: {:?}, dx = {:.8} from {:.8}, L = {:.9}, least margin {:.6}, {} evaluations, {elapsed:.3} s, {}; {}",
        opt.gait.coefficients,
        opt.objective,
        opt.start_objective,
        opt.cost,
        opt.rank_margin,
        opt.history.len(),
        opt.termination,
        opt.kkt.describe()
    );
    assert!(opt.converged && opt.kkt.holds, "{opt:?}");
    assert!(opt.kkt.binding.iter().any(|b| b.name == "path length <= 4"), "{}", opt.kkt.describe());
    assert!(opt.cost <= 4.0 * (1.0 + 1e-9) && opt.rank_margin >= 0.2 * (1.0 - 1e-9));
    let gait = opt.gait.gait().unwrap();
    for n in 0..=400 {
        let (r, _) = gait.at(2.0 * PI * n as f64 / 400.0);
        assert!(r[0] >= 0.1 - 1e-4 && r[0] <= 1.9 + 1e-4 && r[1] >= -1.9 - 1e-4 && r[1] <= -0.1 + 1e-4, "{r:?}");
    }
    assert!(opt.objective > opt.start_objective);
}

/// A gait typed as text becomes the Fourier series whose coefficients
/// are read off it (sines as `b_k`, shifted cosines split), at the order
/// asked and the period asked; a frequency that is not a whole multiple
/// and an order below the text's highest harmonic are refused by name.
#[test]
fn a_gait_typed_as_text_is_its_fourier_series() {
    use crate::effects::Waveform;
    use crate::geometry::Gait;
    let names = vec!["alpha1".to_string(), "alpha2".to_string()];
    let gait = Gait::parse(&names, "alpha1=0.8+0.3*cos(t)+0.1*sin(2*t),alpha2=-0.8+0.5*cos(t+pi/2)").expect("a gait");
    let f = FourierGait::from_gait(&gait, None, None, &names).unwrap();
    assert_eq!((f.order, f.period), (2, gait.period));
    let want = [[0.8, 0.3, 0.0, 0.0, 0.1], [-0.8, 0.0, -0.5, 0.0, 0.0]];
    for (row, w) in f.coefficients.iter().zip(want) {
        for (a, b) in row.iter().zip(w) {
            assert!((a - b).abs() <= 1e-15, "{row:?} vs {w:?}");
        }
    }
    // the series at the text's own times is the text's waveform
    let back = f.gait().unwrap();
    for i in 0..20 {
        let t = gait.period * f64::from(i) / 20.0;
        let (a, b) = (gait.at(t).0, back.at(t).0);
        assert!((a[0] - b[0]).abs() <= 1e-14 && (a[1] - b[1]).abs() <= 1e-14, "t = {t}: {a:?} vs {b:?}");
    }
    let f = FourierGait::from_gait(&gait, Some(3), Some(2.0), &names).unwrap();
    assert_eq!((f.order, f.period, f.coefficients[0].len()), (3, 2.0, 7));
    let e = FourierGait::from_gait(&gait, Some(1), None, &names).unwrap_err().to_string();
    assert!(e.contains("order 1") && e.contains("from 2"), "{e}");
    let slow = Gait { shape: vec![Waveform::cos(0.3, 1.5), Waveform::Constant(0.0)], period: gait.period };
    let e = FourierGait::from_gait(&slow, None, None, &names).unwrap_err().to_string();
    assert!(e.contains("alpha1") && e.contains("whole multiple"), "{e}");
}
