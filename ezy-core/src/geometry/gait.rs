//! Gaits: closed curves in shape space, and the net motion they give,
//! predicted from the connection and its curvature, reconstructed, and
//! simulated.

use super::{Geometry, GeometryError};
use crate::analysis::symmetry::Pose;
use crate::effects::waveform::{Harmonic, Periodicity, Waveform};
use crate::formulation::dae::Dynamics;
use crate::integrator::adaptive::{Tolerance, integrate};
use crate::integrator::dop853::Dop853;
use crate::model::Model;
use crate::problem::Problem;
use crate::settings::Method;
use crate::simulate::observer::{Observer, RunError, Sample};

mod text;

/// A gait: each shape coordinate's angle as a function of time \[rad\],
/// one period `period` \[s\] long, closed (`r(period) = r(0)`).
#[derive(Debug, Clone, PartialEq)]
pub struct Gait {
    /// One waveform per shape coordinate, in shape order.
    pub shape: Vec<Waveform>,
    /// The period \[s\].
    pub period: f64,
}

/// What a gait's cycle gives by the connection: net motions `(dx, dy,
/// dtheta)` \[m, m, rad\] of the reference body in its initial frame.
#[derive(Debug, Clone, PartialEq)]
pub struct GaitPrediction {
    /// The body-velocity integral `int xi dt` over the cycle along the
    /// reconstructed motion (for a kinematic system `-int A dr`, which
    /// Stokes's theorem makes the area integral of `-dA`): first order in
    /// the gait's size.
    pub first: [f64; 3],
    /// With two shape coordinates, the first order plus the Lie bracket's
    /// area integral `int int [A_1, A_2] dr_1 dr_2` over the area the gait
    /// encloses: the integral of the height functions `D(-A)`, second
    /// order (Hatton & Choset 2011, §6). For a mixed system, that of the
    /// motion at zero momentum. `None` with other shape counts.
    pub second: Option<[f64; 3]>,
    /// The net motion by integrating the reconstruction `g' = g xi` (and,
    /// for a mixed system, the momentum equation) over the cycle: exact
    /// to the integration tolerance (1e-12).
    pub reconstructed: [f64; 3],
    /// The momentum at the cycle's start and end (m each).
    pub momentum: (Vec<f64>, Vec<f64>),
    /// The reconstructed path: `(t, x, y, theta)` at 201 times over the
    /// cycle, in the initial body frame.
    pub path: Vec<[f64; 4]>,
    /// The smallest [`crate::geometry::Connection::rank_margin`] met
    /// along the gait (sampled at the path's times).
    pub rank_margin: f64,
}

/// A gait simulated by the full equations of motion (the model's drives
/// prescribing the shape).
#[derive(Debug, Clone, PartialEq)]
pub struct SimulatedGait {
    /// The net motion `(dx, dy, dtheta)` \[m, m, rad\] of the reference
    /// body over the cycle, in its initial frame.
    pub net: [f64; 3],
    /// `(t, x, y, theta)` at the run's samples.
    pub path: Vec<[f64; 4]>,
    /// The momentum at the end of the cycle ([`Geometry::momentum`]).
    pub momentum: Vec<f64>,
}

/// Number of intervals of the reconstructed path and of the gait's
/// samples (the trapezoidal rule on a periodic integrand converges
/// geometrically: Trefethen & Weideman, SIAM Review 56(3), 2014).
const SAMPLES: usize = 200;
/// Steps the gait's integrations take per oscillation of its fastest
/// harmonic (DOP853 at the tolerances `ezy geometry` uses: about 20,
/// measured on the kinematic snake).
pub const STEPS_PER_OSCILLATION: f64 = 20.0;
/// Most steps a gait's cycle may ask ([`STEPS_PER_OSCILLATION`] times its
/// fastest harmonic's oscillations over the period): 100,000, some 5 s of
/// the kinematic snake's prediction and simulation. A gait of `cos(1e6 t)`
/// would take hours.
pub const MAX_GAIT_STEPS: f64 = 1e5;
/// Gauss-Legendre nodes and weights on [0, 1], 6 points (exact for
/// polynomials of degree 11): the second order of [`Geometry::predict`]
/// and its gradient in `crate::design::gait`.
pub(crate) const GAUSS: [(f64, f64); 6] = [
    (0.033765242898423975, 0.08566224618958517),
    (0.16939530676686776, 0.18038078652406936),
    (0.38069040695840156, 0.23395696728634552),
    (0.6193095930415985, 0.23395696728634552),
    (0.8306046932331322, 0.18038078652406936),
    (0.966234757101576, 0.08566224618958517),
];

impl Gait {
    /// A gait of these waveforms and period.
    ///
    /// # Errors
    /// [`GeometryError::Request`] for a period that is not a positive
    /// finite number, a waveform that is not valid, or one that does not
    /// repeat with the period (the curve would not close), or a gait whose
    /// fastest harmonic asks more than [`MAX_GAIT_STEPS`] steps over the
    /// period ([`Gait::steps`]), all before any work.
    pub fn new(shape: Vec<Waveform>, period: f64) -> Result<Self, GeometryError> {
        Self::new_named(shape, period, &|k| format!("gait coordinate {}", k + 1))
    }

    /// [`Gait::new`], naming coordinate `k` as `name(k)` in its errors.
    fn new_named(shape: Vec<Waveform>, period: f64, name: &dyn Fn(usize) -> String) -> Result<Self, GeometryError> {
        if !(period.is_finite() && period > 0.0 && period < 1e9) {
            return Err(GeometryError::Request {
                reason: format!("gait period {period}: must be a positive number of seconds below 1e9"),
            });
        }
        for (k, w) in shape.iter().enumerate() {
            w.validate().map_err(|e| GeometryError::Request { reason: format!("{}: {e}", name(k)) })?;
            match w.periodicity() {
                Periodicity::Constant => {}
                p @ Periodicity::Period(_) if p.whole_periods(period).is_some() => {}
                _ => {
                    return Err(GeometryError::Request {
                        reason: format!(
                            "{}: its waveform does not repeat with the period {period} s, so the curve does not close",
                            name(k)
                        ),
                    });
                }
            }
        }
        Self::check_steps(&shape, period, name)?;
        Ok(Self { shape, period })
    }

    /// The steps one cycle of the gait asks, from its fastest harmonic:
    /// [`STEPS_PER_OSCILLATION`] x `omega period / (2 pi)`, with the
    /// coordinate that has it and its angular frequency `omega` \[rad/s\].
    pub fn steps(shape: &[Waveform], period: f64) -> (f64, usize, f64) {
        let (k, omega) =
            shape.iter().map(Waveform::max_omega).enumerate().max_by(|a, b| a.1.total_cmp(&b.1)).unwrap_or((0, 0.0));
        (STEPS_PER_OSCILLATION * omega * period / (2.0 * std::f64::consts::PI), k, omega)
    }

    /// Refuses a gait whose cycle asks more than [`MAX_GAIT_STEPS`]
    /// ([`Gait::steps`]), naming the coordinate, its frequency and the count.
    fn check_steps(shape: &[Waveform], period: f64, name: &dyn Fn(usize) -> String) -> Result<(), GeometryError> {
        let (steps, k, omega) = Gait::steps(shape, period);
        if steps.is_nan() || steps > MAX_GAIT_STEPS {
            return Err(GeometryError::Request {
                reason: format!(
                    "{}: its fastest harmonic, angular frequency {} rad/s, oscillates {:.3e} times in the gait's period of {} s, about {:.1e} integration steps ({} per oscillation), more than the {:.0e} a gait may take; give slower harmonics (frequency at most {} here)",
                    name(k),
                    crate::names::fmt_value(omega),
                    omega * period / (2.0 * std::f64::consts::PI),
                    crate::names::fmt_value(period),
                    steps,
                    STEPS_PER_OSCILLATION,
                    MAX_GAIT_STEPS,
                    crate::names::fmt_value(
                        (MAX_GAIT_STEPS / STEPS_PER_OSCILLATION * 2.0 * std::f64::consts::PI / period).floor()
                    )
                ),
            });
        }
        Ok(())
    }

    /// Parses a gait written as `name=expression` pairs separated by
    /// commas, one per shape coordinate of `names`, each expression a
    /// trigonometric polynomial in `t` over one period `t` in \[0, 2 pi\]
    /// (`alpha1=0.8+0.3*cos(t),alpha2=-0.8+0.3*sin(t)`): numbers, `pi`,
    /// `t`, `+ - * /` with constants, parentheses, `cos` and `sin` of `k
    /// t + c` with `k` a whole number.
    ///
    /// # Errors
    /// [`GeometryError::Request`] naming the coordinate and the place in
    /// the text that does not parse, a name not among `names`, a
    /// coordinate missing or given twice.
    pub fn parse(names: &[String], spec: &str) -> Result<Self, GeometryError> {
        text::parse(names, spec)
    }

    /// [`Gait::new`] for a gait written as text: coordinate `k` named
    /// `--gait: names[k]` in its errors.
    pub(crate) fn from_text(shape: Vec<Waveform>, period: f64, names: &[String]) -> Result<Self, GeometryError> {
        Self::new_named(shape, period, &|k| format!("--gait: {}", names[k]))
    }

    /// The shape `r` and its rate `r'` at time `t` (n_shape each).
    pub fn at(&self, t: f64) -> (Vec<f64>, Vec<f64>) {
        self.shape
            .iter()
            .map(|w| {
                let [v, d, _] = w.eval3(t);
                (v, d)
            })
            .unzip()
    }
}

/// `g^-1 h` for poses `(x, y, theta)`.
fn relative(g: [f64; 3], h: [f64; 3]) -> [f64; 3] {
    let pose = |p: [f64; 3]| Pose { theta: p[2], a: p[0], b: p[1] };
    let r = pose(g).inverse().compose(pose(h));
    [r.a, r.b, r.theta]
}

impl<M: Model> Geometry<M> {
    /// The net motion of one cycle of `gait` from momentum `p0` (m; empty
    /// for a kinematic system) by the connection: first and second
    /// order and reconstructed ([`GaitPrediction`]).
    ///
    /// # Errors
    /// [`GeometryError::Request`] for a gait of another shape count or a
    /// `p0` of another length; [`GeometryError::Singular`] naming the
    /// time where the gait meets the singular set; the forces' failure.
    pub fn predict(&mut self, gait: &Gait, p0: &[f64]) -> Result<GaitPrediction, GeometryError> {
        let (ns, m) = (self.n_shape(), self.n_momentum());
        if gait.shape.len() != ns || p0.len() != m || p0.iter().any(|v| !v.is_finite()) {
            return Err(GeometryError::Request {
                reason: format!(
                    "the gait gives {} shape coordinates and {} momenta; the model has {ns} ({}) and {m}",
                    gait.shape.len(),
                    p0.len(),
                    self.shape_names().join(", ")
                ),
            });
        }
        let period = gait.period;
        // the gait sampled: its rank margin, and a crossing of the
        // singular set (a sign change of the determinant fixing xi)
        let mut margin = f64::INFINITY;
        let mut last: Option<(f64, f64)> = None;
        for i in 0..=SAMPLES {
            self.check_stop()?;
            let t = period * i as f64 / SAMPLES as f64;
            let (r, _) = gait.at(t);
            let mg = self.rank_margin(&r)?;
            margin = margin.min(mg);
            if mg < 1e-9 {
                return Err(self.crossing(t, &r, mg));
            }
            let det = self.orientation(&r);
            if let Some((t0, d0)) =
                last.filter(|(_, d0)| d0.is_finite() && det.is_finite() && d0.signum() != det.signum())
            {
                // bisect the sign change to the crossing
                let (mut a, mut b) = (t0, t);
                for _ in 0..50 {
                    let mid = 0.5 * (a + b);
                    if self.orientation(&gait.at(mid).0).signum() == d0.signum() {
                        a = mid;
                    } else {
                        b = mid;
                    }
                }
                let r = gait.at(0.5 * (a + b)).0;
                return Err(self.crossing(0.5 * (a + b), &r, self.rank_margin(&r)?));
            }
            last = Some((t, det));
        }
        let second = if ns == 2 { Some(self.second_order(gait)?) } else { None };
        // state: pose (3), momentum (m), body-velocity integral (3)
        let n = 6 + m;
        let mut y = vec![0.0; n];
        y[3..3 + m].copy_from_slice(p0);
        let mut failure: Option<GeometryError> = None;
        let mut path = vec![[0.0, 0.0, 0.0, 0.0]];
        let tol = Tolerance { rtol: 1e-12, atol: 1e-12 };
        for i in 0..SAMPLES {
            self.check_stop()?;
            let (t0, t1) = (period * i as f64 / SAMPLES as f64, period * (i + 1) as f64 / SAMPLES as f64);
            let mut rhs = |t: f64, y: &[f64], dy: &mut [f64]| {
                if failure.is_some() {
                    dy.fill(0.0);
                    return;
                }
                match self.reduced_rhs(gait, t, y, dy) {
                    Ok(()) => {}
                    Err(e) => {
                        failure = Some(e);
                        dy.fill(0.0);
                    }
                }
            };
            let end = integrate::<Dop853, _>(&mut rhs, t0, &y, t1, &tol, 1_000_000)?;
            if let Some(e) = failure.take() {
                return Err(e);
            }
            y = end.y;
            path.push([t1, y[0], y[1], y[2]]);
        }
        let first = [y[3 + m], y[4 + m], y[5 + m]];
        Ok(GaitPrediction {
            first,
            second,
            reconstructed: [y[0], y[1], y[2]],
            momentum: (p0.to_vec(), y[3..3 + m].to_vec()),
            path,
            rank_margin: margin,
        })
    }

    /// The reduced equations along a gait: `g' = g xi`, `p'`, and `xi`
    /// itself (for the body-velocity integral).
    fn reduced_rhs(&mut self, gait: &Gait, t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), GeometryError> {
        let m = self.n_momentum();
        let (r, rd) = gait.at(t);
        let q = self.place(&r);
        let terms = self.terms(&q, false).map_err(|mg| self.crossing(t, &r, mg))?;
        let p = &y[3..3 + m];
        let xi = self.xi(&terms, &rd, p);
        let (s, c) = y[2].sin_cos();
        dy[0] = c * xi[0] - s * xi[1];
        dy[1] = s * xi[0] + c * xi[1];
        dy[2] = xi[2];
        if m > 0 {
            let qd = self.velocities(&terms, &xi, &rd);
            let pd = self.momentum_rate(t, &q, &qd)?;
            dy[3..3 + m].copy_from_slice(&pd);
        }
        dy[3 + m..6 + m].copy_from_slice(&xi);
        Ok(())
    }

    /// The error of a gait that meets the singular set at time `t`.
    pub(crate) fn crossing(&self, t: f64, r: &[f64], margin: f64) -> GeometryError {
        let at: Vec<String> =
            self.shape_names().iter().zip(r).map(|(n, v)| format!("{n} = {}", crate::names::fmt_value(*v))).collect();
        GeometryError::Singular {
            reason: format!(
                "the gait meets the singular set at t = {} s ({}; rank margin {margin:.1e}): there the skates cannot fix the body velocity, so the connection has no value; move the gait away from it",
                crate::names::fmt_value(t),
                at.join(", ")
            ),
        }
    }

    /// `-int A dr + int int [A_1, A_2] dr_1 dr_2` over the area a gait of
    /// two shape coordinates encloses. The area integral by Green's
    /// theorem, `int int dP/dr_1 = oint P dr_2` with `P(r_1, r_2) =
    /// int_{c}^{r_1} [A_1, A_2](s, r_2) ds` (Gauss-Legendre), `c` the
    /// curve's mean `r_1`; both line integrals by the trapezoidal rule.
    fn second_order(&self, gait: &Gait) -> Result<[f64; 3], GeometryError> {
        let period = gait.period;
        let c1 = (0..SAMPLES).map(|i| gait.at(period * i as f64 / SAMPLES as f64).0[0]).sum::<f64>() / SAMPLES as f64;
        let mut total = [0.0; 3];
        let dt = period / SAMPLES as f64;
        for i in 0..SAMPLES {
            let t = period * i as f64 / SAMPLES as f64;
            let (r, rd) = gait.at(t);
            let a = self.connection_fast(&r).map_err(|_| self.crossing(t, &r, 0.0))?;
            // -A r' (the first order's integrand)
            for c in 0..3 {
                total[c] -= (a[c * 2] * rd[0] + a[c * 2 + 1] * rd[1]) * dt;
            }
            // P at r, along r_1 from c1
            let mut p = [0.0; 2];
            for (x, w) in GAUSS {
                let s = c1 + x * (r[0] - c1);
                let b = self.connection_fast(&[s, r[1]]).map_err(|_| self.crossing(t, &[s, r[1]], 0.0))?;
                let (a1, a2) = ([b[0], b[2], b[4]], [b[1], b[3], b[5]]);
                p[0] += w * (a2[2] * a1[1] - a1[2] * a2[1]);
                p[1] += w * (a1[2] * a2[0] - a2[2] * a1[0]);
            }
            total[0] += p[0] * (r[0] - c1) * rd[1] * dt;
            total[1] += p[1] * (r[0] - c1) * rd[1] * dt;
        }
        Ok(total)
    }

    /// One cycle of `gait` simulated by the full equations of motion:
    /// `problem` (the model with the scene's effects, or bare) with the
    /// model's drives on the shape hinges prescribing the gait, started at
    /// the gait's first shape with momentum `p0` (the reference frame at
    /// the origin), integrated by DOP853 at tolerance `tol` (rtol = atol).
    ///
    /// # Errors
    /// [`GeometryError::Request`] when a shape hinge has no drive (the
    /// model cannot prescribe the gait: give it `drive D: hinge H;`);
    /// as [`Geometry::state`]; the run's error.
    pub fn simulate(
        &self,
        gait: &Gait,
        problem: Problem<M>,
        p0: &[f64],
        tol: f64,
    ) -> Result<SimulatedGait, GeometryError> {
        let info = &self.info;
        let mut problem = problem;
        for (k, &h) in self.shape_hinges().iter().enumerate() {
            let drive = info.drives.iter().find(|d| d.hinge == h).ok_or_else(|| GeometryError::Request {
                reason: format!(
                    "hinge `{}` has no drive, so the model cannot prescribe the gait; simulate a model with `drive D: hinge {};`",
                    info.hinges[h].name, info.hinges[h].name
                ),
            })?;
            problem = problem.drive(&drive.name, gait.shape[k].clone())?;
        }
        let (r, rd) = gait.at(0.0);
        let (q, qd) = self.state(&r, &rd, p0)?;
        for (k, name) in info.coords.iter().enumerate() {
            problem = problem.q(name, q[k])?.qd(name, qd[k])?;
        }
        let [i, j, k] = info.bodies[self.body].coords;
        let mut seen = Seen { body: [i, j, k], stop: self.stop, path: Vec::new(), last: Vec::new() };
        problem
            .t_end(gait.period)
            .every(gait.period / SAMPLES as f64)
            .method(Method::Dop853)
            .tolerances(tol, tol)
            .solve_with(&mut seen)
            .map_err(|e| match e {
                RunError::Sim(e) => GeometryError::Sim(e),
                RunError::Output(()) => GeometryError::Stopped,
            })?;
        let start = seen.path.first().map_or([0.0; 3], |p| [p[1], p[2], p[3]]);
        let path: Vec<[f64; 4]> = seen
            .path
            .iter()
            .map(|p| {
                let d = relative(start, [p[1], p[2], p[3]]);
                [p[0], d[0], d[1], d[2]]
            })
            .collect();
        let nq = info.nq();
        let momentum = self.momentum(&seen.last[..nq], &seen.last[nq..])?;
        let end = path.last().copied().unwrap_or([0.0; 4]);
        Ok(SimulatedGait { net: [end[1], end[2], end[3]], path, momentum })
    }
}

/// What a gait's simulation keeps: the reference body's pose at each
/// sample and the last state; it stops the run when the hook says so.
struct Seen {
    /// The reference body's `(x, y, phi)` indices.
    body: [usize; 3],
    /// The stop hook.
    stop: Option<fn() -> bool>,
    /// `(t, x, y, theta)` per sample.
    path: Vec<[f64; 4]>,
    /// The last sample's `[q, qd]`.
    last: Vec<f64>,
}

impl<M: Model> Observer<M> for Seen {
    type Error = ();
    fn observe(&mut self, _sys: &Dynamics<M>, s: &Sample<'_>) -> Result<(), ()> {
        let [i, j, k] = self.body;
        self.path.push([s.t, s.q[i], s.q[j], s.q[k]]);
        self.last.clear();
        self.last.extend_from_slice(s.q);
        self.last.extend_from_slice(s.qd);
        Ok(())
    }
    fn poll(&mut self, _t: f64) -> Result<(), ()> {
        match self.stop {
            Some(stop) if stop() => Err(()),
            _ => Ok(()),
        }
    }
}

/// A harmonic's share of a gait written as text.
pub(crate) fn harmonic(amplitude: f64, omega: f64, phase: f64) -> Harmonic {
    Harmonic { amplitude, omega, phase, phase_step: 0.0 }
}
