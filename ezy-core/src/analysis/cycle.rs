//! Limit cycles of autonomous scenes: the period an unknown, fixed by a
//! phase condition; headings that turn through whole revolutions per
//! cycle (a crank) taken modulo 2 pi.
//!
//! Shooting on `x(t0 + T; x0) = h . x0 + 2 pi w`, `phi(q0) = 0`,
//! `G(q0) qd0 = 0` and the phase condition `f(x*) . (x0 - x*) = 0` (a
//! Poincare section through the guess `x*` normal to the flow there), in
//! the unknowns `x0`, the rigid motion `h` and the period `T`; `w` counts
//! each heading's whole turns over a period, read off the guess's cycle.
//! The time shift along the cycle is a family of solutions that the phase
//! condition removes, and its multiplier 1 (the flow direction `f(x0)`) is
//! taken out with the symmetry's before the multipliers are classified
//! (Seydel, *Practical Bifurcation and Stability Analysis*, 3rd ed.,
//! §7.1-7.3; Doedel, Keller & Kernevez, "Numerical analysis and control of
//! bifurcation problems (II)", Int. J. Bifurcation and Chaos 1, 1991, on
//! the phase condition).

use faer::Mat;

use super::periodic::{PeriodicOrbit, PeriodicSettings, gait_geometry, gauge_coordinates, with_gauge};
use super::steady::Stability;
use super::symmetry::{Symmetry, act, act_jacobian, body_pose, fields};
use super::{Analysis, AnalysisError, dense, newton};
use crate::model::Model;

/// Most Newton iterations of the cycle's shooting.
const MAX_CYCLE_NEWTON: usize = 20;

/// Most samples [`Analysis::return_time`] takes of a motion.
const RETURN_SAMPLES: usize = 20_000;

impl<M: Model> Analysis<M> {
    /// `x - y` (2 nq) with each heading's difference wrapped to
    /// `(-pi, pi]`: two states a whole turn of a crank apart are the same.
    fn wrapped(&self, x: &[f64], y: &[f64]) -> Vec<f64> {
        let mut d: Vec<f64> = x.iter().zip(y).map(|(a, b)| a - b).collect();
        for b in self.bodies() {
            let v = d[b[2]];
            d[b[2]] = v - std::f64::consts::TAU * (v / std::f64::consts::TAU).round();
        }
        d
    }

    /// The time after which the motion from `x0` (2 nq) at `t0` \[s\] of
    /// an autonomous scene first comes back near `x0` (modulo `symmetry`
    /// and whole turns of the headings), within `max_time` \[s\]: the first
    /// local minimum of the distance to `x0` below a fifth of the largest
    /// distance before it, sampled every `max_time / 20000`; `None` where
    /// the motion does not come back (it settles to rest, or drifts).
    ///
    /// # Errors
    /// As [`Analysis::end_state`].
    pub fn return_time(
        &mut self,
        t0: f64,
        x0: &[f64],
        max_time: f64,
        settings: &PeriodicSettings,
    ) -> Result<Option<f64>, AnalysisError> {
        self.check_state(x0)?;
        let symmetry = self.symmetry(t0, x0)?.rigid();
        let bodies = self.bodies().to_vec();
        let gauged = |x: &[f64]| act(&bodies, symmetry.restrict(body_pose(&bodies, 0, x)).inverse(), x);
        let start = gauged(x0);
        let dist = |this: &Self, x: &[f64]| this.wrapped(&gauged(x), &start).iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let h = max_time / RETURN_SAMPLES as f64;
        let (mut x, mut far) = (x0.to_vec(), 0.0f64);
        let (mut d2, mut d1) = (0.0, 0.0);
        for k in 1..=RETURN_SAMPLES {
            x = self.end_state(t0 + (k - 1) as f64 * h, &x, h, settings)?.0;
            let d = dist(self, &x);
            // d1 a local minimum, well inside the excursion
            if k >= 3 && d1 < d2 && d1 <= d && d1 < 0.2 * far {
                // the minimum of the parabola through the three samples
                let denom = d2 - 2.0 * d1 + d;
                let shift = if denom > 0.0 { 0.5 * (d2 - d) / denom } else { 0.0 };
                return Ok(Some((k as f64 - 1.0 + shift.clamp(-1.0, 1.0)) * h));
            }
            far = far.max(d);
            (d2, d1) = (d1, d);
        }
        Ok(None)
    }

    /// The limit cycle of an autonomous scene through the section at
    /// `guess` (2 nq) at `t0` \[s\], with a period near `period` \[s\],
    /// modulo `symmetry`: Newton's method in the state, the rigid motion
    /// and the period (the module's equations), damped, its Jacobian from
    /// the variational equations. Headings that turn through whole
    /// revolutions over the guess's cycle (a crank) are taken modulo
    /// their turns ([`PeriodicOrbit::windings`]). The multipliers leave
    /// out the flow direction's 1 and the symmetry's.
    ///
    /// # Errors
    /// [`AnalysisError::Request`] for a period that is not positive and
    /// finite, a guess of the wrong length, a scene whose accelerations
    /// change with time at a fixed state, or one whose period takes too
    /// many steps (a stiff scene);
    /// [`AnalysisError::NotConverged`]; as [`Analysis::flow`].
    pub fn limit_cycle(
        &mut self,
        t0: f64,
        period: f64,
        guess: &[f64],
        symmetry: Symmetry,
        settings: &PeriodicSettings,
    ) -> Result<PeriodicOrbit, AnalysisError> {
        self.check_size()?;
        let symmetry = symmetry.rigid();
        let n2 = 2 * self.nq();
        self.check_search(period, guess)?;
        self.check_autonomous(t0, guess)?;
        let bodies = self.bodies().to_vec();
        let gens = symmetry.generators();
        let k = gens.len();
        let gauge = gauge_coordinates(&bodies, &gens);
        let placement = symmetry.restrict(body_pose(&bodies, 0, guess));
        let x0 = act(&bodies, placement.inverse(), guess);
        // the section: through the guess, normal to the flow there
        let anchor = x0.clone();
        let normal = self.rhs(t0, &anchor)?;
        self.check_cost(t0, &x0, period, settings)?;
        let (xt, m, steps) = self.flow(t0, &x0, period, settings)?;
        // whole turns of each heading over the guess's cycle
        let windings: Vec<(usize, i64)> = bodies
            .iter()
            .map(|b| (b[2], ((xt[b[2]] - x0[b[2]]) / std::f64::consts::TAU).round() as i64))
            .filter(|&(_, w)| w != 0)
            .collect();
        let h0 = symmetry.restrict(body_pose(&bodies, 0, &xt).compose(body_pose(&bodies, 0, &x0).inverse()));
        let p = symmetry.params(h0);
        let norm = |r: &[f64]| r.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let tol = settings.newton_tolerance * (1.0 + norm(&x0));
        let mut search = Cycle {
            an: self,
            t0,
            settings,
            symmetry,
            bodies: &bodies,
            gauge: &gauge,
            windings: &windings,
            section: (&anchor, &normal),
            x0,
            p,
            period,
            xt,
            m,
            steps,
        };
        let r = search.residual(&search.x0, &search.xt, &search.p);
        // a step damped to 1/8 is taken (the period map's noise)
        let rules = newton::Rules {
            what: "a limit cycle",
            max_iterations: MAX_CYCLE_NEWTON,
            tolerance: tol,
            min_step: 0.125,
            take_last: true,
            slow: None,
            grows: None,
            cutoff: 1e-12,
        };
        let (iterations, r) = newton::solve(&mut search, r, &rules)?;
        let Cycle { x0, p, period, xt, m, steps, .. } = search;
        let h = symmetry.pose(&p);
        // multipliers of x0 -> h^-1 x(t0 + T; x0) modulo the symmetry and
        // the flow
        let dp = dense::mul(act_jacobian(&bodies, h.inverse(), n2).as_ref(), m.as_ref());
        let pt = self.point(t0, &x0)?;
        let (_, c) = self.jacobians(t0, &x0, &pt)?;
        let tangent = dense::null_space(c.as_ref(), super::linear::RANK_RTOL)?;
        let f = self.rhs(t0, &x0)?;
        let group = fields(&bodies, &gens, &x0);
        let along = Mat::from_fn(n2, k + 1, |i, c| if c < k { group[(i, c)] } else { f[i] });
        let along = dense::mul(tangent.as_ref(), dense::mul(tangent.transpose(), along.as_ref()).as_ref());
        let along = dense::orthonormal_range(along.as_ref(), 1e-10)?;
        let q = dense::complement(tangent.as_ref(), along.as_ref())?;
        let multipliers = dense::eigenvalues(dense::congruence(q.as_ref(), dp.as_ref()).as_ref(), true)?;
        let j = self.cycle_jacobian(t0, (&x0, &xt), &m, symmetry, &p, (period, &normal))?;
        let rank = dense::numerical_rank(with_gauge(j, &gauge).as_ref(), 1e-8)?;
        let family = (n2 + k + 1).saturating_sub(rank);
        let stability = Stability::of_multipliers(&multipliers, family);
        let world_heading = placement.theta + bodies.first().map_or(0.0, |b| x0[b[2]]);
        let (state, shift, d) = gait_geometry(&bodies, symmetry, &x0, h);
        let means = self.gait_means(t0, &state, period, shift.theta, settings)?;
        Ok(PeriodicOrbit {
            t0,
            period,
            state,
            symmetry,
            shift,
            multipliers,
            family,
            structural: Vec::new(),
            stability,
            displacement: d,
            heading_change: shift.theta,
            world_heading,
            mean_abs_speed: means.mean_abs_speed,
            drift_speed: means.drift_speed,
            iterations,
            residual: norm(&r),
            steps,
            windings,
        })
    }

    /// The Jacobian of the cycle's equations in `(x0, p, T)`: the
    /// shooting Jacobian, the period's column `f(x(t0 + T))` and the
    /// phase condition's row `f(x*)`.
    pub(crate) fn cycle_jacobian(
        &mut self,
        t0: f64,
        (x0, xt): (&[f64], &[f64]),
        m: &Mat<f64>,
        symmetry: Symmetry,
        p: &[f64],
        (period, normal): (f64, &[f64]),
    ) -> Result<Mat<f64>, AnalysisError> {
        let n2 = x0.len();
        let s = self.shooting_jacobian(t0, x0, m, symmetry, p)?;
        let fe = self.rhs(t0 + period, xt)?;
        let (rows, cols) = (s.nrows(), s.ncols());
        let mut j = Mat::<f64>::zeros(rows + 1, cols + 1);
        j.as_mut().submatrix_mut(0, 0, rows, cols).copy_from(s.as_ref());
        for (i, v) in fe.iter().enumerate() {
            j[(i, cols)] = *v;
        }
        for (i, v) in normal.iter().enumerate().take(n2) {
            j[(rows, i)] = *v;
        }
        Ok(j)
    }
}

/// The cycle's equations of [`Analysis::limit_cycle`] at their current
/// point `(x0, p, T)`, for the analyses' Newton ([`newton::solve`]).
struct Cycle<'a, M: Model> {
    an: &'a mut Analysis<M>,
    t0: f64,
    settings: &'a PeriodicSettings,
    symmetry: Symmetry,
    bodies: &'a [[usize; 3]],
    gauge: &'a [usize],
    /// Whole turns of each heading over the guess's cycle.
    windings: &'a [(usize, i64)],
    /// The section: a point on it and its normal.
    section: (&'a [f64], &'a [f64]),
    /// The current point, the state a period on, the monodromy matrix
    /// and its integration's steps.
    x0: Vec<f64>,
    p: Vec<f64>,
    period: f64,
    xt: Vec<f64>,
    m: Mat<f64>,
    steps: u64,
}

impl<M: Model> Cycle<'_, M> {
    /// The cycle's equations (the module's docs) at `x0`, `x(t0 + T)` and
    /// the rigid motion's parameters `p`.
    fn residual(&self, x0: &[f64], xt: &[f64], p: &[f64]) -> Vec<f64> {
        let mut r: Vec<f64> = xt.iter().zip(act(self.bodies, self.symmetry.pose(p), x0)).map(|(a, b)| a - b).collect();
        for &(i, w) in self.windings {
            r[i] -= std::f64::consts::TAU * w as f64;
        }
        r.extend(self.an.residual_at(self.t0, x0));
        let (anchor, normal) = self.section;
        r.push(normal.iter().zip(x0.iter().zip(anchor)).map(|(n, (a, b))| n * (a - b)).sum());
        r
    }

    /// The current point moved by `lambda dz`.
    fn moved(&self, dz: &[f64], lambda: f64) -> (Vec<f64>, Vec<f64>, f64) {
        let (n2, k) = (self.x0.len(), self.p.len());
        let (x, p) = (newton::moved(&self.x0, dz, lambda), newton::moved(&self.p, &dz[n2..], lambda));
        (x, p, self.period + lambda * dz[n2 + k])
    }
}

impl<M: Model> newton::Equations for Cycle<'_, M> {
    fn jacobian(&mut self) -> Result<Mat<f64>, AnalysisError> {
        let section = (self.period, self.section.1);
        let j = self.an.cycle_jacobian(self.t0, (&self.x0, &self.xt), &self.m, self.symmetry, &self.p, section)?;
        Ok(with_gauge(j, self.gauge))
    }

    fn gauge_rows(&self) -> usize {
        self.gauge.len()
    }

    fn trial(&mut self, dz: &[f64], lambda: f64, _last: bool) -> Result<Option<Vec<f64>>, AnalysisError> {
        self.an.check_stop()?;
        let (x, p, period) = self.moved(dz, lambda);
        // a period that is not positive, or a run that fails: not lower
        let trial = if period > 0.0 { self.an.end_state(self.t0, &x, period, self.settings).ok() } else { None };
        Ok(trial.map(|(y, _)| self.residual(&x, &y, &p)))
    }

    fn take(&mut self, dz: &[f64], lambda: f64) -> Result<(), AnalysisError> {
        let (x, p, period) = self.moved(dz, lambda);
        let (y, m, steps) = self.an.flow(self.t0, &x, period, self.settings)?;
        (self.x0, self.p, self.period, self.xt, self.m, self.steps) = (x, p, period, y, m, steps);
        Ok(())
    }
}
