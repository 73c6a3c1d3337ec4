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
/// first order to 1e-12 (measured 4e-15), the second (the same
/// quadrature) to 1e-13, the reconstruction (both DOP853 at 1e-12, in
/// one span and in 200) to 1e-10 (measured 3e-12).
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

#[test]
#[ignore = "exploration"]
fn explore_scan() {
    let mut g = snake();
    for comp in [1usize, 3] {
        println!("component {comp}");
        for i in 0..16 {
            let mut line = String::new();
            for j in 0..16 {
                let c = [0.3 + 0.15 * j as f64, -0.3 - 0.15 * i as f64];
                let gait = FourierGait::circle(c, 0.6, 0.0, 2.0 * std::f64::consts::PI).unwrap().gait().unwrap();
                match g.predict(&gait, &[]) {
                    Ok(p) => line.push_str(&format!(
                        "{:7.4}",
                        if comp == 1 { p.second.unwrap()[1] } else { p.reconstructed[0] }
                    )),
                    Err(_) => line.push_str("    ---"),
                }
            }
            println!("{line}");
        }
    }
}
