//! One point of a gait optimization: the net motion of the Fourier gait
//! at the chosen order, its cost, the rank margin along it, each with its
//! exact gradient in the free coefficients.
//!
//! The first and second orders are quadratures over `n` equally spaced
//! times (the trapezoidal rule, geometrically convergent on a periodic
//! integrand: Trefethen & Weideman, SIAM Review 56(3), 2014) evaluated on
//! dual numbers, one pass per free coefficient: the gradient is the exact
//! derivative of the same quadrature, so it agrees with differences of
//! the value to their own accuracy. In the continuum the first order's
//! variation is the Stokes variation formula `delta oint -A dr = -oint
//! (dA)(delta r, r') dt` (`dA` the exterior derivative, the curvature less
//! its bracket: Hatton & Choset 2011, §5), which the tests check against.
//! The reconstruction `g' = g xi` is integrated (DOP853, 1e-12) with its
//! variational equations `s_j' = (df/dg) s_j + R(theta) dxi/dc_j`.

use num_dual::Dual64;

use super::fourier::shape_at;
use super::{GaitObjective, Order};
use crate::geometry::gait::GAUSS;
use crate::geometry::{Geometry, GeometryError};
use crate::integrator::adaptive::{Tolerance, integrate};
use crate::integrator::dop853::Dop853;
use crate::model::Model;

/// What a point's evaluation needs of the problem.
pub(super) struct Setup {
    /// Shape coordinates.
    pub ns: usize,
    /// `2 pi / T` \[rad/s\].
    pub omega: f64,
    /// `T` \[s\].
    pub period: f64,
    /// The flat coefficients with the fixed ones' values.
    pub base: Vec<f64>,
    /// Indices of the free coefficients in the flat vector.
    pub free: Vec<usize>,
    /// Quadrature samples per cycle.
    pub samples: usize,
    /// The metric of the cost (ns x ns, row-major, symmetric positive
    /// definite).
    pub metric: Vec<f64>,
    /// The objective.
    pub goal: GaitObjective,
    /// Whether the rank margin's gradients are needed (a margin
    /// constraint).
    pub margin_gradients: bool,
}

/// One evaluated point.
#[derive(Debug, Clone)]
pub(super) struct Point {
    /// The objective (as the goal defines it, before its sense).
    pub objective: f64,
    /// Its gradient in the free coefficients.
    pub gradient: Vec<f64>,
    /// The net motion `(dx, dy, dtheta)` at the goal's order.
    pub motion: [f64; 3],
    /// The cost: the path length in the metric \[rad\].
    pub cost: f64,
    /// Its gradient.
    pub cost_gradient: Vec<f64>,
    /// The rank margin at each sample, and (with a margin constraint) its
    /// gradient in the free coefficients.
    pub margins: Vec<(f64, Vec<f64>)>,
}

impl Setup {
    /// The flat coefficients at the free values `x`.
    pub fn full(&self, x: &[f64]) -> Vec<f64> {
        let mut c = self.base.clone();
        for (k, &j) in self.free.iter().enumerate() {
            c[j] = x[k];
        }
        c
    }

    /// The sample times.
    pub fn time(&self, n: usize) -> f64 {
        self.period * n as f64 / self.samples as f64
    }

    /// The coefficients as dual numbers, free coefficient `seed`'s
    /// direction carried (none for `None`).
    fn dual(&self, c: &[f64], seed: Option<usize>) -> Vec<Dual64> {
        let mut d: Vec<Dual64> = c.iter().map(|v| Dual64::from(*v)).collect();
        if let Some(k) = seed {
            d[self.free[k]].eps = 1.0;
        }
        d
    }

    /// The seeds of the passes: each free coefficient, or one pass for
    /// the value alone.
    fn seeds(&self) -> Vec<Option<usize>> {
        if self.free.is_empty() { vec![None] } else { (0..self.free.len()).map(Some).collect() }
    }
}

/// The point at the free coefficients `x`: the objective with its
/// gradient, the cost, the rank margins; `side` the sign of the
/// orientation determinant the gait must keep (that of the start).
///
/// # Errors
/// [`GeometryError::Singular`] where the gait meets the singular set or
/// crosses to its other side; a reconstruction's failure.
pub(super) fn evaluate<M: Model>(g: &Geometry<M>, setup: &Setup, x: &[f64], side: f64) -> Result<Point, GeometryError> {
    let c = setup.full(x);
    let margins = margins(g, setup, &c, side)?;
    let nf = setup.free.len();
    let (mut motion, mut dmotion) = ([0.0; 3], vec![[0.0; 3]; nf]);
    let (mut cost, mut dcost) = (0.0, vec![0.0; nf]);
    for seed in setup.seeds() {
        let d = setup.dual(&c, seed);
        let (m, l) = match setup.goal.order {
            Order::First => quadrature(g, setup, &d, false)?,
            Order::Second => quadrature(g, setup, &d, true)?,
            Order::Reconstructed => ([Dual64::from(0.0); 3], cost_of(setup, &d)),
        };
        motion = m.map(|v| v.re);
        cost = l.re;
        if let Some(k) = seed {
            dmotion[k] = m.map(|v| v.eps);
            dcost[k] = l.eps;
        }
    }
    if setup.goal.order == Order::Reconstructed {
        (motion, dmotion) = reconstruct(g, setup, &c)?;
    }
    let (objective, gradient) = setup.goal.value(motion, &dmotion, cost, &dcost);
    Ok(Point { objective, gradient, motion, cost, cost_gradient: dcost, margins })
}

/// The rank margin at each sample (with its gradient in the free
/// coefficients when the setup asks), refusing a gait that meets the
/// singular set or is not on the start's `side` of it (the sign of the
/// orientation determinant; 0 to take any).
fn margins<M: Model>(
    g: &Geometry<M>,
    setup: &Setup,
    c: &[f64],
    side: f64,
) -> Result<Vec<(f64, Vec<f64>)>, GeometryError> {
    let mut out = Vec::with_capacity(setup.samples);
    let mut first_side = side;
    for n in 0..setup.samples {
        g.check_stop()?;
        let t = setup.time(n);
        let (r, _) = shape_at(c, setup.ns, setup.omega, t);
        let (m, dm) =
            if setup.margin_gradients { g.rank_margin_gradient(&r) } else { (g.rank_margin(&r)?, Vec::new()) };
        if m.is_nan() || m < 1e-9 {
            return Err(g.crossing(t, &r, m));
        }
        let det = g.orientation(&r);
        if det.is_finite() && det != 0.0 {
            if first_side == 0.0 {
                first_side = det.signum();
            } else if det.signum() != first_side {
                return Err(g.crossing(t, &r, m));
            }
        }
        // d margin / d c_j = sum_i d margin / d r_i * basis_j(t)
        let grad = if setup.margin_gradients {
            let per = c.len() / setup.ns;
            setup.free.iter().map(|&j| dm[j / per] * super::fourier::basis(j % per, setup.omega, t).0).collect()
        } else {
            Vec::new()
        };
        out.push((m, grad));
    }
    Ok(out)
}

/// The sign of the orientation determinant along the gait of flat
/// coefficients `c` (its first finite value's), 0 where none is.
pub(super) fn side_of<M: Model>(g: &Geometry<M>, setup: &Setup, c: &[f64]) -> f64 {
    (0..setup.samples)
        .map(|n| g.orientation(&shape_at(c, setup.ns, setup.omega, setup.time(n)).0))
        .find(|d| d.is_finite() && *d != 0.0)
        .map_or(0.0, f64::signum)
}

/// The path length `int sqrt(r'^T G r') dt` (trapezoidal rule; a sample
/// at rest adds nothing, its derivative taken as 0).
fn cost_of(setup: &Setup, c: &[Dual64]) -> Dual64 {
    let ns = setup.ns;
    let dt = setup.period / setup.samples as f64;
    let mut total = Dual64::from(0.0);
    for n in 0..setup.samples {
        let (_, rd) = shape_at(c, ns, setup.omega, setup.time(n));
        let mut q = Dual64::from(0.0);
        for i in 0..ns {
            for j in 0..ns {
                q += rd[i] * rd[j] * setup.metric[i * ns + j];
            }
        }
        if q.re > 0.0 {
            total += crate::scalar::Scalar::sqrt(q) * dt;
        }
    }
    total
}

/// The first order `-oint A dr` (and with `second`, the bracket's area
/// integral as [`Geometry::predict`] takes it: by Green's theorem about
/// the mean of `r_1`), and the cost, on the dual coefficients `c`.
fn quadrature<M: Model>(
    g: &Geometry<M>,
    setup: &Setup,
    c: &[Dual64],
    second: bool,
) -> Result<([Dual64; 3], Dual64), GeometryError> {
    let ns = setup.ns;
    let dt = setup.period / setup.samples as f64;
    let zero = Dual64::from(0.0);
    let mut total = [zero; 3];
    let connection = |r: &[Dual64], t: f64| {
        g.terms(&g.place(r), false)
            .map(|t| t.a)
            .map_err(|m| g.crossing(t, &r.iter().map(|v| v.re).collect::<Vec<_>>(), m))
    };
    let c1 = if second {
        (0..setup.samples).map(|n| shape_at(c, ns, setup.omega, setup.time(n)).0[0]).fold(zero, |a, b| a + b)
            / setup.samples as f64
    } else {
        zero
    };
    for n in 0..setup.samples {
        let t = setup.time(n);
        let (r, rd) = shape_at(c, ns, setup.omega, t);
        let a = connection(&r, t)?;
        for (comp, tot) in total.iter_mut().enumerate() {
            let s = (0..ns).map(|k| a[comp * ns + k] * rd[k]).fold(zero, |x, y| x + y);
            *tot -= s * dt;
        }
        if second {
            let mut p = [zero; 2];
            for (x, w) in GAUSS {
                let s = c1 + (r[0] - c1) * x;
                let b = connection(&[s, r[1]], t)?;
                let (a1, a2) = ([b[0], b[2], b[4]], [b[1], b[3], b[5]]);
                p[0] += (a2[2] * a1[1] - a1[2] * a2[1]) * w;
                p[1] += (a1[2] * a2[0] - a2[2] * a1[0]) * w;
            }
            total[0] += p[0] * (r[0] - c1) * rd[1] * dt;
            total[1] += p[1] * (r[0] - c1) * rd[1] * dt;
        }
    }
    Ok((total, cost_of(setup, c)))
}

/// The reconstructed net motion `g(T)` of `g' = g xi`, `g(0) = e`, and
/// its derivatives in the free coefficients by the variational equations
/// integrated with it (DOP853 at rtol = atol = 1e-12, the tolerance of
/// [`Geometry::predict`]).
fn reconstruct<M: Model>(
    g: &Geometry<M>,
    setup: &Setup,
    c: &[f64],
) -> Result<([f64; 3], Vec<[f64; 3]>), GeometryError> {
    let nf = setup.free.len();
    let ns = setup.ns;
    let seeds = setup.seeds();
    let duals: Vec<Vec<Dual64>> = seeds.iter().map(|s| setup.dual(c, *s)).collect();
    let mut failure: Option<GeometryError> = None;
    let mut rhs = |t: f64, y: &[f64], dy: &mut [f64]| {
        dy.fill(0.0);
        if failure.is_some() {
            return;
        }
        let (s, co) = y[2].sin_cos();
        for (p, d) in duals.iter().enumerate() {
            let (r, rd) = shape_at(d, ns, setup.omega, t);
            let a = match g.terms(&g.place(&r), false) {
                Ok(terms) => terms.a,
                Err(m) => {
                    failure = Some(g.crossing(t, &r.iter().map(|v| v.re).collect::<Vec<_>>(), m));
                    return;
                }
            };
            let xi: [Dual64; 3] = std::array::from_fn(|comp| {
                -(0..ns).map(|k| a[comp * ns + k] * rd[k]).fold(Dual64::from(0.0), |x, y| x + y)
            });
            if p == 0 {
                let v = xi.map(|v| v.re);
                dy[0] = co * v[0] - s * v[1];
                dy[1] = s * v[0] + co * v[1];
                dy[2] = v[2];
            }
            if nf > 0 {
                let v = xi.map(|v| v.re);
                let e = xi.map(|v| v.eps);
                let sj = &y[3 + 3 * p..6 + 3 * p];
                // d/dtheta of R(theta) xi, times s_theta, plus R(theta) dxi
                dy[3 + 3 * p] = (-s * v[0] - co * v[1]) * sj[2] + co * e[0] - s * e[1];
                dy[4 + 3 * p] = (co * v[0] - s * v[1]) * sj[2] + s * e[0] + co * e[1];
                dy[5 + 3 * p] = e[2];
            }
        }
    };
    let y0 = vec![0.0; 3 + 3 * nf];
    let tol = Tolerance { rtol: 1e-12, atol: 1e-12 };
    let end = integrate::<Dop853, _>(&mut rhs, 0.0, &y0, setup.period, &tol, 1_000_000)?;
    if let Some(e) = failure {
        return Err(e);
    }
    let y = end.y;
    Ok(([y[0], y[1], y[2]], (0..nf).map(|k| [y[3 + 3 * k], y[4 + 3 * k], y[5 + 3 * k]]).collect()))
}
