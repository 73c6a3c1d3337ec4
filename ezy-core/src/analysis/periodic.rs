//! Periodic orbits of periodically forced scenes (gaits): shooting on the
//! period map modulo the symmetry, with the variational equations.

use faer::{Mat, c64};

use super::steady::Stability;
use super::symmetry::{act, act_jacobian, body_pose, field};
use super::{Analysis, AnalysisError, dense, newton};
use crate::analysis::symmetry::{Generator, Pose, Symmetry};
use crate::error::SimError;
use crate::integrator::Rhs;
use crate::integrator::adaptive::{self, Tolerance};
use crate::integrator::dop853::Dop853;
use crate::model::Model;

/// Most Newton iterations of the shooting (each integrates a period, and
/// up to three more when it damps its step): it converges in two to five
/// from a guess in the orbit's basin.
const MAX_SHOOTING: usize = 12;

/// Settings of the period map's integration and of the shooting Newton
/// iteration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PeriodicSettings {
    /// Tolerances of the DOP853 integration of the state and of the
    /// variational equations (the same error control for both).
    pub tolerance: Tolerance,
    /// Most steps (attempts) of one period's integration: a search that
    /// wanders off to fast motions, whose period takes ever more steps,
    /// ends here.
    pub max_steps: u64,
    /// The residual of the fixed-point equations (max norm, relative to
    /// `1 + |x0|`) at which Newton stops; it cannot be much below the
    /// integration's error.
    pub newton_tolerance: f64,
}

impl Default for PeriodicSettings {
    /// `rtol = atol = 1e-11`, 10^5 steps per period, Newton to 1e-9.
    fn default() -> Self {
        Self { tolerance: Tolerance { rtol: 1e-11, atol: 1e-11 }, max_steps: 100_000, newton_tolerance: 1e-9 }
    }
}

/// A periodic orbit `x(t0 + T) = shift . x(t0)` ([`Analysis::periodic_orbit`]).
#[derive(Debug, Clone)]
pub struct PeriodicOrbit {
    /// The phase \[s\]: the fixed point is the state at `t0`.
    pub t0: f64,
    /// The period `T` \[s\].
    pub period: f64,
    /// The fixed point `x(t0)` (2 nq), moved so that the reference body
    /// (the model's first) is at the origin with heading 0, as far as the
    /// symmetry allows.
    pub state: Vec<f64>,
    /// The symmetry the orbit is periodic modulo.
    pub symmetry: Symmetry,
    /// The rigid motion over one period: `x(t0 + T) = shift . x(t0)`.
    pub shift: Pose,
    /// Floquet multipliers of the period map on the constraint manifold
    /// modulo the symmetry, largest modulus first.
    pub multipliers: Vec<c64>,
    /// Dimension of the family of periodic orbits through this one,
    /// modulo the symmetry; as many multipliers are 1 along it and are left
    /// out of the classification.
    pub family: usize,
    /// The multipliers 1 that the scene's structure makes exact at every
    /// parameter value (a cyclic coordinate, a rate nothing else feels),
    /// left out of [`PeriodicOrbit::multipliers`], the family and the
    /// classification (see [`super::StructuralMultiplier`]).
    pub structural: Vec<super::structural::StructuralMultiplier>,
    /// The classification of [`PeriodicOrbit::multipliers`].
    pub stability: Stability,
    /// The reference body's displacement over one period in its frame at
    /// `t0`: forward, lateral \[m\].
    pub displacement: [f64; 2],
    /// The reference body's heading change over one period \[rad\].
    pub heading_change: f64,
    /// The reference body's heading at `t0` \[rad\] in the frame of the
    /// state the search started from (for `ezy analyze`, the scene's run
    /// at `t0`): [`PeriodicOrbit::world_displacement`] turns the
    /// displacement into that frame.
    pub world_heading: f64,
    /// The mean over one period of the reference body's speed,
    /// `(1/T) ∫ |v| dt` \[m/s\]: independent of `t0` and of the frame.
    pub mean_abs_speed: f64,
    /// The drift speed \[m/s\]: the root mean square over a period of the
    /// speed at which the period's rigid motion carries each point of the
    /// reference body's path about its centre, `|dheading| |p - c| / T`
    /// (`dheading` wrapped to (-pi, pi]), and `|displacement| / T` for a
    /// gait that does not turn: independent of `t0` (unlike
    /// [`PeriodicOrbit::mean_speed`] on a turning gait) and of the frame
    /// (`analysis::gait_means`; Kelly & Murray 1995, §2).
    pub drift_speed: f64,
    /// Newton iterations taken.
    pub iterations: usize,
    /// The final residual of the fixed-point equations (max norm).
    pub residual: f64,
    /// Accepted steps of the last period's integration (state and
    /// variational equations together).
    pub steps: u64,
    /// The headings that turn through whole revolutions over a period (a
    /// limit cycle's crank, [`Analysis::limit_cycle`]): the coordinate's
    /// index and its turns, `x(t0 + T) = shift . x(t0) + 2 pi turns` in
    /// it. Empty for a forced scene's orbit.
    pub windings: Vec<(usize, i64)>,
}

impl PeriodicOrbit {
    /// Mean speed of the reference body over a period, `|displacement| / T` \[m/s\].
    pub fn mean_speed(&self) -> f64 {
        self.displacement[0].hypot(self.displacement[1]) / self.period
    }

    /// Mean forward speed, the displacement along the reference body's
    /// heading at `t0` over `T` \[m/s\].
    pub fn mean_forward_speed(&self) -> f64 {
        self.displacement[0] / self.period
    }

    /// The names [`PeriodicOrbit::value`] knows, as `periodic.csv`
    /// writes them.
    pub const VALUE_NAMES: [&'static str; 10] = [
        "period",
        "mean_speed",
        "mean_forward_speed",
        "dx",
        "dy",
        "dheading",
        "mean_abs_speed",
        "drift_speed",
        "dx_world",
        "dy_world",
    ];

    /// The orbit's quantity `name` (one of [`PeriodicOrbit::VALUE_NAMES`],
    /// in the units `periodic.csv` gives them: s, m/s, m, rad); `None` for
    /// another name.
    pub fn value(&self, name: &str) -> Option<f64> {
        Some(match name {
            "period" => self.period,
            "mean_speed" => self.mean_speed(),
            "mean_forward_speed" => self.mean_forward_speed(),
            "dx" => self.displacement[0],
            "dy" => self.displacement[1],
            "dheading" => self.heading_change,
            "mean_abs_speed" => self.mean_abs_speed,
            "drift_speed" => self.drift_speed,
            "dx_world" => self.world_displacement()[0],
            "dy_world" => self.world_displacement()[1],
            _ => return None,
        })
    }

    /// The displacement over one period in the frame of the state the
    /// search started from (for `ezy analyze`, the scene's run: where the
    /// run's reference body goes from `t0` to `t0 + T` once it has settled
    /// on this orbit) \[m\]: [`PeriodicOrbit::displacement`] turned by
    /// [`PeriodicOrbit::world_heading`].
    pub fn world_displacement(&self) -> [f64; 2] {
        let (s, c) = self.world_heading.sin_cos();
        let [a, b] = self.displacement;
        [c * a - s * b, s * a + c * b]
    }
}

/// The state and its variational equations `Phi' = A(t, x) Phi`, `Phi(t0) = I`
/// (2nq + (2nq)^2, `Phi` row-major).
struct Variational<'a, M: Model> {
    analysis: &'a mut Analysis<M>,
    failed: Option<AnalysisError>,
}

impl<M: Model> Rhs for Variational<'_, M> {
    fn eval(&mut self, t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SimError> {
        let n2 = 2 * self.analysis.nq();
        let mut run = |an: &mut Analysis<M>| -> Result<(), AnalysisError> {
            an.check_stop()?;
            let x = &y[..n2];
            let p = an.point(t, x)?;
            let (a, _) = an.jacobians(t, x, &p)?;
            dy[..n2 / 2].copy_from_slice(&x[n2 / 2..]);
            dy[n2 / 2..n2].copy_from_slice(&p.qdd);
            let phi = &y[n2..];
            let dphi = &mut dy[n2..];
            for i in 0..n2 {
                for j in 0..n2 {
                    dphi[i * n2 + j] = (0..n2).map(|k| a[(i, k)] * phi[k * n2 + j]).sum();
                }
            }
            Ok(())
        };
        run(self.analysis).map_err(|e| into_sim(e, &mut self.failed))
    }
}

/// An analysis' error as the integrator's: a simulation error as it is;
/// any other kept in `failed` (the integration's caller returns it) and
/// passed on as a formulation error to stop the integration.
pub(crate) fn into_sim(e: AnalysisError, failed: &mut Option<AnalysisError>) -> SimError {
    match e {
        AnalysisError::Sim(e) => e,
        e => {
            let reason = e.to_string();
            *failed = Some(e);
            SimError::Formulation { reason: reason.into() }
        }
    }
}

impl<M: Model> Analysis<M> {
    /// The state at `t0 + period` from `x0` at `t0`, and the monodromy
    /// matrix `dx(t0 + T)/dx0` (2nq x 2nq) from the variational equations,
    /// integrated with the state by DOP853 under one error control; and the
    /// accepted steps.
    ///
    /// # Errors
    /// As [`crate::integrator::adaptive::integrate`]; as [`Analysis::rhs`].
    pub fn flow(
        &mut self,
        t0: f64,
        x0: &[f64],
        period: f64,
        settings: &PeriodicSettings,
    ) -> Result<(Vec<f64>, Mat<f64>, u64), AnalysisError> {
        let n2 = x0.len();
        let mut y0 = x0.to_vec();
        y0.extend((0..n2 * n2).map(|k| if k / n2 == k % n2 { 1.0 } else { 0.0 }));
        let mut var = Variational { analysis: self, failed: None };
        let end =
            adaptive::integrate::<Dop853, _>(&mut var, t0, &y0, t0 + period, &settings.tolerance, settings.max_steps);
        if let Some(e) = var.failed.take() {
            return Err(e);
        }
        let end = end?;
        let m = dense::from_rows(n2, n2, &end.y[n2..]);
        Ok((end.y[..n2].to_vec(), m, end.steps))
    }

    /// The periodic orbit of period `period` \[s\] nearest `guess` (2 nq)
    /// at phase `t0` \[s\], modulo `symmetry`: Newton's method with
    /// minimum-norm steps on `x(t0 + T; x0) = h . x0`, `phi(q0) = 0`,
    /// `G(q0) qd0 = 0` in the unknowns `x0` and the rigid motion `h` (in
    /// the symmetry group), its Jacobian from the variational equations
    /// (not from differences of whole runs). The Floquet multipliers are
    /// the eigenvalues of `d(h^-1 x(t0 + T))/dx0` on the constraint
    /// manifold's tangent space at `x0` modulo the group orbit.
    ///
    /// # Errors
    /// [`AnalysisError::Request`] for a period that is not positive and
    /// finite or a guess of the wrong length, a period the explicit
    /// integrator crosses only in more than a tenth of
    /// `settings.max_steps` steps (a stiff scene), or a skate with
    /// friction that slides on the orbit found (its holding force past
    /// `mu N`); [`AnalysisError::NotConverged`];
    /// as [`Analysis::flow`].
    pub fn periodic_orbit(
        &mut self,
        t0: f64,
        period: f64,
        guess: &[f64],
        symmetry: Symmetry,
        settings: &PeriodicSettings,
    ) -> Result<PeriodicOrbit, AnalysisError> {
        self.check_size()?;
        // modulo the plane's rigid motions (a cyclic coordinate's shift is
        // not taken out of a period map)
        let cyclic = symmetry.cyclic;
        let symmetry = symmetry.rigid();
        let n2 = 2 * self.nq();
        self.check_search(period, guess)?;
        let bodies = self.bodies().to_vec();
        let gens = symmetry.generators();
        let k = gens.len();
        // the guess moved to the gauge (the reference body at the origin
        // with heading 0, as far as the symmetry allows), held there by
        // one row per generator: the group orbit of a solution is a family
        // of solutions, and without these rows its directions make the
        // Newton matrix singular at the orbit and nearly so near it (the
        // rotation's direction is singular only where the residual
        // vanishes, so a minimum-norm step takes large steps along it)
        let gauge = gauge_coordinates(&bodies, &gens);
        let placement = symmetry.restrict(body_pose(&bodies, 0, guess));
        let x0 = act(&bodies, placement.inverse(), guess);
        self.check_cost(t0, &x0, period, settings)?;
        // the skates' grip over the last period integrated (the orbit's,
        // once the search has converged)
        self.watch_grip();
        let (xt, m, steps) = self.flow(t0, &x0, period, settings)?;
        // a search that wanders off to ever faster motion (a scene without
        // a periodic orbit, whose speed grows) ends when a period takes
        // many times the steps the guess's period took
        let first_steps = steps;
        let budget = PeriodicSettings { max_steps: settings.max_steps.min(20 * steps + 1000), ..*settings };
        let settings = &budget;
        let h0 = symmetry.restrict(body_pose(&bodies, 0, &xt).compose(body_pose(&bodies, 0, &x0).inverse()));
        let p = symmetry.params(h0);
        let norm = |r: &[f64]| r.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let tol = settings.newton_tolerance * (1.0 + norm(&x0));
        let mut search = Shooting {
            an: self,
            t0,
            period,
            settings,
            symmetry,
            bodies: &bodies,
            gauge: &gauge,
            x0,
            p,
            m,
            steps,
            first_steps,
            iterations: 0,
        };
        let r = search.residual(&search.x0, &xt, &search.p);
        // the trials integrate the state alone, the step taken its
        // variational equations too; a step damped to 1/8 is taken (the
        // period map's residual carries the integration's noise); three
        // slow damped steps in a row: the guess is outside the region
        // Newton converges from (a transient; the caller may settle it)
        let rules = newton::Rules {
            what: "a periodic orbit",
            max_iterations: MAX_SHOOTING,
            tolerance: tol,
            min_step: 0.125,
            take_last: true,
            slow: Some(3),
            grows: None,
            cutoff: 1e-12,
        };
        let (iterations, r) = newton::solve(&mut search, r, &rules)?;
        let Shooting { x0, p, m, steps, .. } = search;
        self.check_grip("this periodic orbit")?;
        let h = symmetry.pose(&p);
        // Floquet multipliers of x0 -> h^-1 x(t0 + T; x0) modulo the orbit
        let dp = dense::mul(act_jacobian(&bodies, h.inverse(), n2).as_ref(), m.as_ref());
        let pt = self.point(t0, &x0)?;
        let (_, c) = self.jacobians(t0, &x0, &pt)?;
        let tangent = dense::null_space(c.as_ref(), super::linear::RANK_RTOL)?;
        // modulo the structural multipliers too (a cyclic coordinate's and
        // a free rate's): they are 1 at every parameter value
        let (extra, structural) = super::structural::directions(&dp, &tangent, cyclic);
        let (q, removed) = self.quotient_basis_with(&tangent, &x0, symmetry, &extra)?;
        let reduced = dense::congruence(q.as_ref(), dp.as_ref());
        let multipliers = dense::eigenvalues(reduced.as_ref(), true)?;
        let j = self.shooting_jacobian(t0, &x0, &m, symmetry, &p)?;
        let rank = dense::numerical_rank(j.as_ref(), 1e-8)?;
        // the shooting equations' null directions: the family, the group
        // orbit, and each cyclic coordinate's shift (its rate's is not one:
        // it turns the angle on)
        let shifts = structural.iter().filter(|s| !s.rate).count();
        let orbit = removed - extra.len() + shifts;
        let family = (n2 + k - rank).saturating_sub(orbit);
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
            structural,
            stability,
            displacement: d,
            heading_change: shift.theta,
            world_heading,
            mean_abs_speed: means.mean_abs_speed,
            drift_speed: means.drift_speed,
            iterations,
            residual: norm(&r),
            steps,
            windings: Vec::new(),
        })
    }

    /// Refuses a search's request: a period that is not positive and
    /// finite, a guess (2 nq) of the wrong length or off the scene's
    /// limits ([`Analysis::check_state`]).
    pub(crate) fn check_search(&self, period: f64, guess: &[f64]) -> Result<(), AnalysisError> {
        if !(period.is_finite() && period > 0.0) {
            return Err(AnalysisError::Request {
                reason: format!("the period must be positive and finite, not {period}"),
            });
        }
        let n2 = 2 * self.nq();
        if guess.len() != n2 {
            return Err(AnalysisError::Request {
                reason: format!("the guess has {} components; the model needs 2 nq = {n2}", guess.len()),
            });
        }
        self.check_state(guess)
    }

    /// The Jacobian of the shooting equations in `(x0, p)`:
    /// `[[M - d(h x0)/dx0, -d(h x0)/dp]; [C(x0), 0]]`.
    pub(crate) fn shooting_jacobian(
        &mut self,
        t0: f64,
        x0: &[f64],
        m: &Mat<f64>,
        symmetry: Symmetry,
        p: &[f64],
    ) -> Result<Mat<f64>, AnalysisError> {
        let n2 = x0.len();
        let bodies = self.bodies().to_vec();
        let gens = symmetry.generators();
        let h = symmetry.pose(p);
        let pt = self.point(t0, x0)?;
        let (_, c) = self.jacobians(t0, x0, &pt)?;
        let dact = act_jacobian(&bodies, h, n2);
        let rows = n2 + c.nrows();
        let mut j = Mat::<f64>::zeros(rows, n2 + gens.len());
        for r in 0..n2 {
            for col in 0..n2 {
                j[(r, col)] = m[(r, col)] - dact[(r, col)];
            }
        }
        // d(h x0)/dp: a translation's field, or the rotation's field at
        // the rotated state (the translation is added after the rotation)
        let rotated = act(&bodies, Pose { theta: h.theta, ..Pose::IDENTITY }, x0);
        for (kk, g) in gens.iter().enumerate() {
            let v = if *g == Generator::Rotate { field(&bodies, *g, &rotated) } else { field(&bodies, *g, x0) };
            for (r, vi) in v.into_iter().enumerate() {
                j[(r, n2 + kk)] = -vi;
            }
        }
        for r in 0..c.nrows() {
            for col in 0..n2 {
                j[(n2 + r, col)] = c[(r, col)];
            }
        }
        Ok(j)
    }
}

/// The coordinates that fix a state's place on its group orbit: per
/// generator of the rigid motions, the reference body's (the model's
/// first) x, y or heading.
pub(crate) fn gauge_coordinates(bodies: &[[usize; 3]], generators: &[Generator]) -> Vec<usize> {
    generators
        .iter()
        .filter_map(|g| match g {
            Generator::TranslateX => Some(bodies[0][0]),
            Generator::TranslateY => Some(bodies[0][1]),
            Generator::Rotate => Some(bodies[0][2]),
            Generator::Shift(_) => None,
        })
        .collect()
}

/// `j` (m x n) with a row per gauge coordinate below it: `dx0[i] = 0`.
pub(crate) fn with_gauge(j: Mat<f64>, gauge: &[usize]) -> Mat<f64> {
    let m = j.nrows();
    let mut out = Mat::<f64>::zeros(m + gauge.len(), j.ncols());
    out.as_mut().subrows_mut(0, m).copy_from(j.as_ref());
    for (k, &i) in gauge.iter().enumerate() {
        out[(m + k, i)] = 1.0;
    }
    out
}

/// A gait's fixed point `x0` and shift `h` seen from the reference body
/// (the model's first) moved to the origin with heading 0, as far as the
/// symmetry allows: `x0' = g x0`, `h' = g h g^-1`; and the reference body's
/// displacement over a period in its frame at the start (forward,
/// lateral) \[m\].
pub(crate) fn gait_geometry(
    bodies: &[[usize; 3]],
    symmetry: Symmetry,
    x0: &[f64],
    h: Pose,
) -> (Vec<f64>, Pose, [f64; 2]) {
    let g = symmetry.restrict(body_pose(bodies, 0, x0)).inverse();
    let state = act(bodies, g, x0);
    let shift = g.compose(h).compose(g.inverse());
    let start = body_pose(bodies, 0, &state);
    let end = shift.point([start.a, start.b]);
    let d = Pose { theta: -start.theta, ..Pose::IDENTITY }.vector([end[0] - start.a, end[1] - start.b]);
    (state, shift, d)
}

/// The shooting equations of [`Analysis::periodic_orbit`] at their
/// current point, for the analyses' Newton ([`newton::solve`]).
struct Shooting<'a, M: Model> {
    an: &'a mut Analysis<M>,
    t0: f64,
    period: f64,
    settings: &'a PeriodicSettings,
    symmetry: Symmetry,
    bodies: &'a [[usize; 3]],
    gauge: &'a [usize],
    /// The fixed point's guess, the rigid motion's parameters, the
    /// monodromy matrix there and its integration's steps.
    x0: Vec<f64>,
    p: Vec<f64>,
    m: Mat<f64>,
    steps: u64,
    /// The steps the first guess's period took (a search that wanders off
    /// takes many times as many).
    first_steps: u64,
    iterations: usize,
}

impl<M: Model> Shooting<'_, M> {
    /// `[x(t0 + T) - h . x0; the constraints at x0]`.
    fn residual(&self, x0: &[f64], xt: &[f64], p: &[f64]) -> Vec<f64> {
        let h = self.symmetry.pose(p);
        let mut r: Vec<f64> = xt.iter().zip(act(self.bodies, h, x0)).map(|(a, b)| a - b).collect();
        r.extend(self.an.residual_at(self.t0, x0));
        r
    }

    /// The current point moved by `lambda dz`.
    fn moved(&self, dz: &[f64], lambda: f64) -> (Vec<f64>, Vec<f64>) {
        (newton::moved(&self.x0, dz, lambda), newton::moved(&self.p, &dz[self.x0.len()..], lambda))
    }
}

impl<M: Model> newton::Equations for Shooting<'_, M> {
    fn jacobian(&mut self) -> Result<Mat<f64>, AnalysisError> {
        self.iterations += 1;
        let j = self.an.shooting_jacobian(self.t0, &self.x0, &self.m, self.symmetry, &self.p)?;
        Ok(with_gauge(j, self.gauge))
    }

    fn gauge_rows(&self) -> usize {
        self.gauge.len()
    }

    fn trial(&mut self, dz: &[f64], lambda: f64, last: bool) -> Result<Option<Vec<f64>>, AnalysisError> {
        let (x, p) = self.moved(dz, lambda);
        self.an.watch_grip();
        match self.an.end_state(self.t0, &x, self.period, self.settings) {
            Ok((xt, _)) => Ok(Some(self.residual(&x, &xt, &p))),
            Err(AnalysisError::Stopped) => Err(AnalysisError::Stopped),
            Err(AnalysisError::Sim(SimError::Budget { .. })) if last => Err(AnalysisError::Wandered {
                reason: format!(
                    "the search for a periodic orbit wandered off after {} Newton iterations: a period now takes more than {} steps, where the guess's took {}; the scene may have no periodic orbit near the guess (its speed may grow without bound), or start from a guess nearer one",
                    self.iterations, self.settings.max_steps, self.first_steps
                ),
            }),
            Err(e) if last => Err(e),
            // a step that fails to integrate counts as not falling
            Err(_) => Ok(None),
        }
    }

    fn take(&mut self, dz: &[f64], lambda: f64) -> Result<(), AnalysisError> {
        let (x, p) = self.moved(dz, lambda);
        let (_, m, steps) = self.an.flow(self.t0, &x, self.period, self.settings)?;
        (self.x0, self.p, self.m, self.steps) = (x, p, m, steps);
        Ok(())
    }
}
