//! Pseudo-arclength continuation of steady motions and periodic orbits,
//! through folds, and folds located (Keller, "Numerical solution of
//! bifurcation and nonlinear eigenvalue problems", in *Applications of
//! Bifurcation Theory*, 1977; Seydel, *Practical Bifurcation and
//! Stability Analysis*, 3rd ed., §4.4-4.6 and §5.3).
//!
//! The unknowns are `w = [z, p]`: the solution's own unknowns `z` (a
//! steady motion's state and group velocity `[x, xi]`; a periodic orbit's
//! start and rigid shift `[x0, h]`) and the parameter `p`. Each point
//! solves the defining equations `R(z; p) = 0` (those of
//! [`Analysis::steady_motion`] or [`Analysis::periodic_orbit`], the state
//! held at the gauge: the reference body at the origin with heading 0)
//! with one more equation `n . (w - w_hat) = 0` through the predicted
//! point `w_hat`. Where the branch is a graph over `p` the row is
//! `n = e_p` and the points fall on the grid's values (natural
//! continuation); where the grid's next value is further along the
//! branch than the step allows, and through folds, `n` is the unit
//! tangent `t` (pseudo-arclength, whose matrix stays regular at a fold).
//! The tangent solves `[R_z R_p; n^T] t = [0; 1]` at each point found,
//! `R_p` by a forward difference of the scene built at `p + h`. Its
//! component `t_p = dp/ds` changes sign at a fold.

use faer::Mat;

use super::bifurcation::{Bifurcation, BifurcationKind, at_bifurcation, boundary_distance, critical, family};
use super::branch::{BranchEnd, BranchPoint, Follow, Solution, solve};
use super::cycle_phase::Phase;
use super::periodic::{gauge_coordinates, with_gauge};
use super::symmetry::{Generator, Symmetry, act};
use super::{Analysis, AnalysisError, dense, newton};
use crate::effects::waveform::OrbitTiming;
use crate::model::Model;
use crate::names::fmt_value;

/// Most Newton iterations of one corrector; a step that needs more is
/// retried at half the arclength.
const MAX_CORRECTOR: usize = 10;

/// Most bisections of a fold's bracket ([`locate_fold`]).
const MAX_FOLD_STEPS: usize = 60;

/// The farthest a fold's critical eigenvalue or multiplier may be from
/// the stability boundary ([`boundary_distance`]) for [`locate_fold`] to
/// call it one: a fold located to `|dp/ds| < 1e-9` has it within about
/// that of 0; 1e-2 leaves room for a steep branch's poorly resolved one
/// and none for a tangent that is wrong.
const FOLD_CRITICAL: f64 = 1e-2;

/// Smallest `cos` of the angle between consecutive tangents a step may
/// turn through (37 degrees); a step turning more is retried shorter (it
/// may have jumped to another part of the branch).
const MIN_TURN_COS: f64 = 0.8;

/// The parameter's step for the difference `R_p`, relative to `1 + |p|`.
const DIFFERENCE_STEP: f64 = 1e-6;

/// Largest turn (11 degrees: `cos` above this) after which the next
/// arclength step grows, by half.
const EASY_TURN_COS: f64 = 0.98;

/// The defining equations of a branch's solutions, their symmetry and
/// period fixed at the branch's first point (a limit cycle's free,
/// [`Follow::Cycle`]).
pub(super) struct Equations {
    follow: Follow,
    /// Steady motions: the motion's symmetry; periodic orbits: its rigid part.
    symmetry: Symmetry,
    /// The coordinates held at zero (the gauge, see [`gauge`]).
    gauge: Vec<usize>,
    /// A periodic orbit's cyclic coordinates (its structural multipliers'),
    /// held at zero too: their shift is a null direction of the shooting
    /// equations that the rigid gauge does not fix.
    cyclic: Vec<usize>,
    /// Unknowns left out of the tangent (set to 0 in it, so out of the
    /// arclength and the turn test): the rates that only their cyclic
    /// coordinate feels. Nothing else depends on them, so they are slaves
    /// of the rest, settled by the corrector in one linear step; in the
    /// tangent they dominated it (a rotor's spin at a fixed phase moves 20
    /// rad/s per rad/s of a forcing frequency) and let a step land on
    /// another part of the branch whose tangent looked alike.
    slaves: Vec<usize>,
    /// A periodic orbit's period in the forcing's periods ([`solve`]).
    pub(super) timing: OrbitTiming,
    /// Newton's tolerance on the residual (max norm).
    tol: f64,
    /// A limit cycle's phase condition ([`Follow::Cycle`]; unused otherwise).
    phase: Phase,
}

/// A point of the corrector: the unknowns `w = [z, p]`, the unit tangent
/// there (oriented along the row it was solved with) and the iterations.
pub(super) struct Corrected {
    pub(super) w: Vec<f64>,
    pub(super) tangent: Vec<f64>,
    iterations: usize,
}

/// The coordinates a solution's state is held at zero in: the reference
/// body's `x`, `y`, heading per generator of `symmetry` and a cyclic
/// coordinate's shift (each solution's state is moved there).
fn gauge(bodies: &[[usize; 3]], symmetry: Symmetry) -> Vec<usize> {
    let gens = symmetry.generators();
    let mut g = gauge_coordinates(bodies, &gens);
    g.extend(gens.iter().filter_map(|g| if let Generator::Shift(k) = *g { Some(k) } else { None }));
    g
}

/// A solution's unknowns `z`: `[x, xi]` of a steady motion, `[x0, h]` of
/// a periodic orbit.
pub(super) fn unknowns(s: &Solution) -> Vec<f64> {
    match s {
        Solution::Steady(m) => [&m.state[..], &m.xi].concat(),
        Solution::Periodic(o) => [o.state.clone(), o.symmetry.params(o.shift)].concat(),
    }
}

impl Equations {
    /// The equations of the branch through `first` (a limit cycle's
    /// branch may start at a steady motion: [`super::cycle_branch::switch_at_hopf`]).
    pub(super) fn new(follow: Follow, first: &Solution) -> Self {
        let (symmetry, scale) = match first {
            Solution::Steady(m) => (m.symmetry, m.state.iter().fold(1.0f64, |a, v| a.max(v.abs()))),
            Solution::Periodic(o) => (o.symmetry, o.state.iter().fold(1.0f64, |a, v| a.max(v.abs()))),
        };
        let tol = match follow {
            // the steady search stops at 1e-12 (1 + |x| + |f|)
            Follow::Steady { .. } => 5e-13 * scale,
            // the shooting search's own: the period map is integrated to
            // about its 1e-11, so the residual has a floor near it
            Follow::Periodic { settings, .. } | Follow::Cycle { settings, .. } => settings.newton_tolerance * scale,
        };
        // a limit cycle is periodic modulo the plane's rigid motions
        let symmetry = if matches!(follow, Follow::Cycle { .. }) { symmetry.rigid() } else { symmetry };
        // the phase the branch's orbits are at
        let follow = match (follow, first) {
            // the orbit's own start and period (a later point's, its forcing's
            // multiples: `timing`, taken at the first evaluation)
            (Follow::Periodic { settings, .. }, Solution::Periodic(o)) => {
                Follow::Periodic { t0: o.t0, period: o.period, settings }
            }
            (Follow::Cycle { settings, .. }, Solution::Periodic(o)) => {
                Follow::Cycle { t0: o.t0, period: o.period, settings }
            }
            (f, _) => f,
        };
        let (cyclic, slaves) = match first {
            Solution::Periodic(o) => {
                let nq = o.state.len() / 2;
                let of = |rate: bool| o.structural.iter().filter(move |s| s.rate == rate).map(|s| s.coordinate);
                (of(false).collect(), of(true).map(|k| nq + k).collect())
            }
            Solution::Steady(_) => (Vec::new(), Vec::new()),
        };
        let phase = Phase::new(if let Solution::Periodic(o) = first { o.windings.clone() } else { Vec::new() });
        Equations { follow, symmetry, gauge: Vec::new(), cyclic, slaves, timing: OrbitTiming::default(), tol, phase }
    }

    /// The unknowns `z` of the solution `s` under these equations: a limit
    /// cycle's [`unknowns`] and its period.
    pub(super) fn unknowns(&self, s: &Solution) -> Vec<f64> {
        let mut z = unknowns(s);
        if let (Follow::Cycle { .. }, Solution::Periodic(o)) = (self.follow, s) {
            z.push(o.period);
        }
        z
    }

    /// The start and period at the scene `an` ([`solve`]'s rule).
    fn timing<M: Model>(&mut self, an: &Analysis<M>, t0: f64, period: f64) -> (f64, f64) {
        an.forcing().map_or((t0, period), |f| f.orbit_timing(&mut self.timing, t0, period))
    }

    /// `R(z)` at the scene `an`, the gauge rows last; with `jacobian`,
    /// `R_z` too (rows as `R`, columns as `z`).
    fn eval<M: Model>(
        &mut self,
        an: &mut Analysis<M>,
        z: &[f64],
        jacobian: bool,
    ) -> Result<(Vec<f64>, Option<Mat<f64>>), AnalysisError> {
        let n2 = 2 * an.nq();
        if self.gauge.is_empty() {
            let mut g = gauge(an.bodies(), self.symmetry);
            for &k in &self.cyclic {
                if !g.contains(&k) {
                    g.push(k);
                }
            }
            self.gauge = g;
        }
        let (x, g) = z.split_at(n2);
        let (mut r, j) = match self.follow {
            Follow::Steady { energy } => {
                let r = an.steady_residual(0.0, x, g, &self.symmetry.generators(), energy)?;
                let j = if jacobian {
                    let j = an.steady_jacobian(0.0, x, g, self.symmetry)?;
                    Some(if energy.is_some() { an.with_energy_row(j, x) } else { j })
                } else {
                    None
                };
                (r, j)
            }
            Follow::Periodic { t0, period, settings } => {
                let (t0, period) = self.timing(an, t0, period);
                let (xt, m) = if jacobian {
                    let (xt, m, _) = an.flow(t0, x, period, &settings)?;
                    (xt, Some(m))
                } else {
                    (an.end_state(t0, x, period, &settings)?.0, None)
                };
                let h = self.symmetry.pose(g);
                let mut r: Vec<f64> = xt.iter().zip(act(an.bodies(), h, x)).map(|(a, b)| a - b).collect();
                r.extend(an.residual_at(t0, x));
                let j = match m {
                    Some(m) => Some(an.shooting_jacobian(t0, x, &m, self.symmetry, g)?),
                    None => None,
                };
                (r, j)
            }
            Follow::Cycle { t0, settings, .. } => {
                self.phase.eval(an, (t0, &settings), self.symmetry, x, g, jacobian)?
            }
        };
        r.extend(self.gauge.iter().map(|&i| x[i]));
        Ok((r, j.map(|j| with_gauge(j, &self.gauge))))
    }

    /// Newton's method with minimum-norm steps on `R(z; p) = 0`,
    /// `n . (w - w_hat) = 0` from `w_hat` (`build` makes the scene at a
    /// `p`; [`newton::solve`], undamped), and the unit tangent at the
    /// point found.
    ///
    /// # Errors
    /// [`AnalysisError::NotConverged`] after [`MAX_CORRECTOR`] iterations
    /// or where the residual grows; `build`'s and the equations' errors.
    pub(super) fn correct<M: Model>(
        &mut self,
        build: &mut impl FnMut(f64) -> Result<Analysis<M>, AnalysisError>,
        w_hat: &[f64],
        n: &[f64],
    ) -> Result<Corrected, AnalysisError> {
        let rules = newton::Rules {
            what: "a point of the branch",
            max_iterations: MAX_CORRECTOR,
            tolerance: self.tol,
            // undamped: a step too long is the predictor's, retried shorter
            min_step: 1.0,
            take_last: true,
            // stalling at ten times the tolerance or above
            slow: None,
            grows: Some(10.0),
            cutoff: 1e-13,
        };
        let mut corrector =
            Corrector { eq: self, build, w_hat, n, w: w_hat.to_vec(), r: Vec::new(), tried: Vec::new() };
        let r = corrector.residual_at(w_hat)?;
        corrector.r.clone_from(&r);
        let (iterations, _) = newton::solve(&mut corrector, r, &rules)?;
        // the tangent: [R_z R_p; n^T] t = [0; 1] at the point found
        let a = newton::Equations::jacobian(&mut corrector)?;
        let mut e = vec![0.0; a.nrows()];
        e[a.nrows() - 1] = 1.0;
        let (mut t, _) = dense::min_norm_solve(a.as_ref(), &e, rules.cutoff)?;
        let w = corrector.w;
        for &k in &self.slaves {
            t[k] = 0.0;
        }
        let len = t.iter().map(|v| v * v).sum::<f64>().sqrt();
        let tangent = t.iter().map(|v| v / len).collect();
        Ok(Corrected { w, tangent, iterations })
    }

    /// Refuses a branch of steady motions whose tangent is not unique at
    /// its first point `w` (`first`'s unknowns and parameter): a member of
    /// a family of steady motions ([`super::steady::SteadyMotion::family`]:
    /// a sleigh's straight run at every speed) has as many more null
    /// directions of `[R_z R_p]` (the rank below `1e-8` of the largest
    /// singular value, as the family's count takes it), along which
    /// the corrector and the tangent pick the minimum norm's member, not
    /// the user's. The kinetic energy's row (`Follow::Steady { energy:
    /// Some(..) }`) fixes the member of a one-parameter family.
    ///
    /// # Errors
    /// [`AnalysisError::Request`] naming the fix, where the branch's
    /// solutions near `w` form more than a curve; the equations'.
    fn unique_tangent<M: Model>(
        &mut self,
        build: &mut impl FnMut(f64) -> Result<Analysis<M>, AnalysisError>,
        w: &[f64],
        first: &Solution,
    ) -> Result<(), AnalysisError> {
        let (Solution::Steady(m), Follow::Steady { energy }) = (first, self.follow) else { return Ok(()) };
        if m.family == 0 {
            return Ok(());
        }
        let nz = w.len() - 1;
        let n = vec![0.0; nz + 1];
        let mut corrector =
            Corrector { eq: self, build, w_hat: w, n: &n, w: w.to_vec(), r: Vec::new(), tried: Vec::new() };
        corrector.r = corrector.residual_at(w)?;
        let a = newton::Equations::jacobian(&mut corrector)?;
        let rank = dense::numerical_rank(a.as_ref().subrows(0, a.nrows() - 1), 1e-8)?;
        let free = (nz + 1).saturating_sub(rank + 1);
        if free == 0 {
            return Ok(());
        }
        let fix = match energy {
            None => "follow it with the member fixed by its kinetic energy (`Follow::Steady { energy: Some(..) }`; `ezy analyze --energy J`, or without it the motion's own)".to_string(),
            Some(e) => format!("its kinetic energy fixed at {e} J leaves {free} free"),
        };
        Err(AnalysisError::Request {
            reason: format!(
                "the steady motion is one of a family of {} dimension(s) beyond the symmetry, so the branch through it is not one curve ({free} more direction(s) along which every point solves): {fix}",
                m.family
            ),
        })
    }

    /// The solution at the corrected point `c`: the kind's own search from
    /// its state (converged already: it adds the stability); a limit
    /// cycle's from its period, its phase condition moved to it.
    pub(super) fn point<M: Model>(
        &mut self,
        build: &mut impl FnMut(f64) -> Result<Analysis<M>, AnalysisError>,
        c: &Corrected,
    ) -> Result<BranchPoint, AnalysisError> {
        let nz = c.w.len() - 1;
        let value = c.w[nz];
        let mut an = build(value)?;
        let n2 = 2 * an.nq();
        let follow = match self.follow {
            Follow::Cycle { t0, settings, .. } => Follow::Cycle { t0, period: c.w[nz - 1], settings },
            f => f,
        };
        let solution = solve(&mut an, follow, &c.w[..n2], &mut self.timing)?;
        if let Follow::Cycle { t0, .. } = follow {
            self.phase.move_to(&mut an, t0, solution.state())?;
        }
        Ok(BranchPoint { value, solution, dp_ds: Some(c.tangent[nz]) })
    }

    /// `[R_z R_p; n^T]` at `w = [z, p]` (rows as `R` and one more,
    /// columns as `w`; `R_p` by the corrector's forward difference). At a
    /// branch point `[R_z R_p]` has a null space of two, and with the row
    /// `n` the old branch's tangent, this matrix's null vector is the
    /// direction in it orthogonal to the old branch: the new branch's
    /// ([`super::switching`]).
    ///
    /// # Errors
    /// `build`'s and the equations' errors.
    pub(super) fn extended_jacobian<M: Model>(
        &mut self,
        build: &mut impl FnMut(f64) -> Result<Analysis<M>, AnalysisError>,
        w: &[f64],
        n: &[f64],
    ) -> Result<Mat<f64>, AnalysisError> {
        let mut corrector = Corrector { eq: self, build, w_hat: w, n, w: w.to_vec(), r: Vec::new(), tried: Vec::new() };
        corrector.r = corrector.residual_at(w)?;
        newton::Equations::jacobian(&mut corrector)
    }

    /// The slaves' components of `t` set to 0 and `t` made a unit vector
    /// (as the tangent is: [`Equations::slaves`]).
    pub(super) fn unit_tangent(&self, mut t: Vec<f64>) -> Vec<f64> {
        for &k in &self.slaves {
            t[k] = 0.0;
        }
        let len = t.iter().map(|v| v * v).sum::<f64>().sqrt();
        t.iter().map(|v| v / len).collect()
    }

    /// `w`'s cyclic coordinates held at zero, as the branch's points hold them.
    pub(super) fn at_gauge(&self, mut w: Vec<f64>) -> Vec<f64> {
        for &k in &self.cyclic {
            w[k] = 0.0;
        }
        w
    }
}

/// One corrector's equations, `[R(z; p); n . (w - w_hat)] = 0` in
/// `w = [z, p]`, at its current point `w`.
struct Corrector<'a, B> {
    eq: &'a mut Equations,
    build: &'a mut B,
    w_hat: &'a [f64],
    n: &'a [f64],
    w: Vec<f64>,
    /// The residual at `w` (the state integrated alone: the base of
    /// `R_p`'s difference and the step's right-hand side).
    r: Vec<f64>,
    /// The residual at the last trial's point, `r` once taken.
    tried: Vec<f64>,
}

impl<B> Corrector<'_, B> {
    /// `[R(z; p); n . (w - w_hat)]` at `w`.
    fn residual_at<M: Model>(&mut self, w: &[f64]) -> Result<Vec<f64>, AnalysisError>
    where
        B: FnMut(f64) -> Result<Analysis<M>, AnalysisError>,
    {
        let nz = w.len() - 1;
        let (mut r, _) = self.eq.eval(&mut (self.build)(w[nz])?, &w[..nz], false)?;
        r.push(self.n.iter().zip(w.iter().zip(self.w_hat)).map(|(n, (a, b))| n * (a - b)).sum());
        Ok(r)
    }
}

impl<M: Model, B: FnMut(f64) -> Result<Analysis<M>, AnalysisError>> newton::Equations for Corrector<'_, B> {
    /// `[R_z R_p; n^T]` at `w`.
    fn jacobian(&mut self) -> Result<Mat<f64>, AnalysisError> {
        let nz = self.w.len() - 1;
        let p = self.w[nz];
        let mut an = (self.build)(p)?;
        an.check_stop()?;
        let (_, j) = self.eq.eval(&mut an, &self.w[..nz], true)?;
        let j = j.expect("asked for");
        // R_p by a forward difference: its error only slows Newton (the
        // residual is exact) and moves a fold's t_p = 0 by O(h), which
        // moves the fold's parameter by O(h^2); the step is 1e-6, well
        // above the period map's integration error (1e-11 relative) over
        // it. Both ends are integrated alike, the state alone (the
        // variational equations' error control takes other steps, whose
        // difference in the state, over h, would swamp R_p).
        let h = DIFFERENCE_STEP * (1.0 + p.abs());
        let (rh, _) = self.eq.eval(&mut (self.build)(p + h)?, &self.w[..nz], false)?;
        let m = j.nrows();
        let mut a = Mat::<f64>::zeros(m + 1, nz + 1);
        a.as_mut().submatrix_mut(0, 0, m, nz).copy_from(j.as_ref());
        for i in 0..m {
            a[(i, nz)] = (rh[i] - self.r[i]) / h;
        }
        for (c, v) in self.n.iter().enumerate() {
            a[(m, c)] = *v;
        }
        Ok(a)
    }

    fn trial(&mut self, dw: &[f64], lambda: f64, _last: bool) -> Result<Option<Vec<f64>>, AnalysisError> {
        let w = newton::moved(&self.w, dw, lambda);
        self.tried = self.residual_at(&w)?;
        Ok(Some(self.tried.clone()))
    }

    fn take(&mut self, dw: &[f64], lambda: f64) -> Result<(), AnalysisError> {
        self.w = newton::moved(&self.w, dw, lambda);
        self.r = std::mem::take(&mut self.tried);
        Ok(())
    }
}

/// Follows a branch of solutions from `start`'s solution at `values[0]`
/// through the range of `values` (a grid, increasing or decreasing) by
/// pseudo-arclength continuation with a tangent predictor (module
/// docs): the points fall on the grid's values where the branch is a
/// graph over the parameter (the next value within twice the step that has worked and the longest step, its search converging), and between them, on arclength steps, where it
/// turns steeply or folds back (at most ten times the first
/// grid step's arclength each, halved where Newton fails or the tangent
/// turns by more than 37 degrees, grown by half after one of at most
/// three iterations turning less than 11 degrees). A branch that folds
/// goes on through the fold and back over the grid's values it has
/// passed, on its other side, until the parameter leaves the range; at
/// most `4 values.len() + 64` points. A branch that comes back to its
/// first point without leaving the range is closed (the
/// bodies' headings compared modulo a turn) and stopped there,
/// [`BranchEnd::Closed`]. Each point's `dp_ds` is its
/// tangent's parameter component: a sign change between two points is a
/// fold ([`locate_fold`]). A grid of one value gives the one solution.
///
/// A steady motion one of a family of them (a sleigh's straight run at
/// every speed) has a tangent that is not unique unless a row fixes the
/// family's member: its kinetic energy, `Follow::Steady { energy:
/// Some(..) }`; without one the branch is refused at its first point.
///
/// # Errors
/// The branch so far and, when it ended early, [`BranchEnd::Failed`]
/// with the parameter's value and the error that ended it (a corrector
/// that fails at the shortest step, `1e-6` of the longest; the most
/// points taken; [`AnalysisError::Request`] for a family's member
/// without the row that fixes it).
pub fn follow_arclength<M: Model>(
    values: &[f64],
    start: &[f64],
    follow: Follow,
    build: impl FnMut(f64) -> Result<Analysis<M>, AnalysisError>,
    progress: impl FnMut(usize),
) -> (Vec<BranchPoint>, BranchEnd) {
    follow_arclength_from(values, 0, start, follow, build, progress)
}

/// [`follow_arclength`] from `start`'s solution at the grid's value
/// `values[at]`, toward its last, within the range of all of
/// `values`: the branch goes on over the grid's values before `first`
/// where it turns back to them, and a branch from inside the range can
/// close (a loop through two folds: from `x = 1` at `p = 0` around
/// `x^2 + p^2 = 1` within `[-2, 2]`). An `at` past the grid's end
/// gives no branch; at its last value, the one solution.
///
/// # Errors
/// As [`follow_arclength`].
pub fn follow_arclength_from<M: Model>(
    values: &[f64],
    at: usize,
    start: &[f64],
    follow: Follow,
    mut build: impl FnMut(f64) -> Result<Analysis<M>, AnalysisError>,
    mut progress: impl FnMut(usize),
) -> (Vec<BranchPoint>, BranchEnd) {
    let Some(&p0) = values.get(at) else { return (Vec::new(), BranchEnd::Reached) };
    progress(0);
    let failed = |value: f64, error: AnalysisError| BranchEnd::Failed { value, error };
    let mut timing = OrbitTiming::default();
    let mut angles = Vec::new();
    let first = match build(p0).and_then(|mut an| {
        angles = an.bodies().iter().map(|b| b[2]).collect();
        solve(&mut an, follow, start, &mut timing)
    }) {
        Ok(s) => s,
        Err(e) => return (Vec::new(), failed(p0, e)),
    };
    let last_value = values[values.len() - 1];
    if at + 1 == values.len() || last_value == p0 {
        return (vec![BranchPoint { value: p0, solution: first, dp_ds: None }], BranchEnd::Reached);
    }
    let mut eq = Equations::new(follow, &first);
    eq.timing = timing;
    let (lo, hi) = (values[0].min(last_value), values[0].max(last_value));
    let spacing = (hi - lo) / (values.len() - 1) as f64;
    let nz = eq.unknowns(&first).len();
    let mut e_p = vec![0.0; nz + 1];
    let d0 = (last_value - p0).signum();
    e_p[nz] = d0;
    let w0: Vec<f64> = [eq.unknowns(&first), vec![p0]].concat();
    // the tangent at the first point, oriented toward the range
    let c = match eq.unique_tangent(&mut build, &w0, &first).and_then(|()| eq.correct(&mut build, &w0, &e_p)) {
        Ok(c) => c,
        Err(e) => return (vec![BranchPoint { value: p0, solution: first, dp_ds: None }], failed(p0, e)),
    };
    let mut points = vec![BranchPoint { value: p0, solution: first, dp_ds: Some(c.tangent[nz]) }];
    let mut closing = Closing::new(&w0, &c.tangent, angles);
    let (mut w, mut t) = (w0, c.tangent);
    // the longest step: ten times the first grid step's arclength; where
    // the branch starts near-vertical in the parameter (|dp/ds| < 0.1: a
    // branch born at a pitchfork or period doubling) the grid says nothing
    // of the state's step, and a step is at most a tenth of the state's
    // scale (ten grid steps' arclength were 385 rad on the forced
    // pendulum's doubled branch, and its corrector jumped off the range)
    let scale = w.iter().take(nz).fold(1.0f64, |m, v| m.max(v.abs()));
    let mut ds_max = 10.0 * spacing / t[nz].abs().max(1e-3);
    if t[nz].abs() < 0.1 {
        ds_max = ds_max.min(0.1 * scale);
    }
    let ds_min = 1e-6 * ds_max;
    let mut ds = 0.1 * ds_max;
    let mut failed_at: Option<f64> = None;
    let most = 4 * values.len() + 64;
    let next_grid = |p: f64, d: f64| -> Option<f64> {
        // the next grid value beyond p in the direction d
        let k = (p - p0) / (spacing * d0);
        let k = if d * d0 > 0.0 { (k + 1e-9).floor() + 1.0 } else { (k - 1e-9).ceil() - 1.0 };
        let v = p0 + k * spacing * d0;
        // the grid's own value there (a decimal grid's 0.6, where the
        // sum gave 0.6000000000000001)
        let n = values.len() - 1;
        let j = ((v - values[0]) / (last_value - values[0]) * n as f64).round().clamp(0.0, n as f64) as usize;
        let v = if (values[j] - v).abs() <= 1e-9 * spacing { values[j] } else { v };
        (v >= lo - 1e-12 * spacing && v <= hi + 1e-12 * spacing).then_some(v.clamp(lo, hi))
    };
    while points.len() < most {
        progress(points.len());
        let p = w[nz];
        let d = t[nz].signum();
        // the range's end in this direction reached: the branch is done
        let Some(target) = next_grid(p, d) else { return (points, BranchEnd::Reached) };
        let mut to_value = vec![0.0; nz + 1];
        to_value[nz] = d;
        let s_grid = (target - p) / t[nz];
        let end = if d > 0.0 { hi } else { lo };
        // (within twice the step that has worked, not failed from here)
        let natural = s_grid > 0.0 && s_grid <= ds_max.min(2.0 * ds) && failed_at != Some(target);
        let (s, row, value) = if natural {
            // natural: the grid's next value within the step
            (s_grid, to_value, Some(target))
        } else if (p + ds * t[nz] - end) * d >= -1e-12 * spacing {
            // an arclength step that would leave the range ends on its end
            ((end - p) / t[nz], to_value, Some(end))
        } else {
            (ds, t.clone(), None)
        };
        let mut w_hat: Vec<f64> = w.iter().zip(&t).map(|(a, b)| a + s * b).collect();
        if let Some(v) = value {
            w_hat[nz] = v;
        }
        let step = eq.correct(&mut build, &w_hat, &row).and_then(|c| {
            let turn: f64 = c.tangent.iter().zip(&t).map(|(a, b)| a * b).sum();
            if turn < MIN_TURN_COS {
                return Err(AnalysisError::NotConverged {
                    what: "a point of the branch (the tangent turned too far)",
                    iterations: c.iterations,
                    residual: 0.0,
                    tolerance: eq.tol,
                });
            }
            // an arclength step whose point falls behind the range's other
            // end jumped (a fold crossed and the whole range gone back over
            // in one step): retried shorter
            let back = if d > 0.0 { lo } else { hi };
            if value.is_none() && (c.w[nz] - back) * d < -1e-12 * spacing {
                return Err(AnalysisError::NotConverged {
                    what: "a point of the branch (the corrector left the range behind the step)",
                    iterations: c.iterations,
                    residual: 0.0,
                    tolerance: eq.tol,
                });
            }
            Ok(c)
        });
        match step {
            Ok(c) if value.is_none() && (c.w[nz] - end) * d > 0.0 => {
                // the corrector took the parameter past the range: end on it
                ds = (end - p) / t[nz];
            }
            Ok(mut c) => {
                // a grid value or the range's end exactly (Newton holds it
                // to rounding)
                if let Some(v) = value {
                    c.w[nz] = v;
                }
                // the step passed the first point again: the loop closes there
                if let Some(back) = closing.passes(&mut eq, &mut build, &w, &c) {
                    let n = points.len();
                    return match eq.point(&mut build, &back) {
                        Ok(b) => (points.into_iter().chain([b]).collect(), BranchEnd::Closed { points: n }),
                        Err(e) => (points, failed(back.w[nz], e)),
                    };
                }
                let point = match eq.point(&mut build, &c) {
                    Ok(b) => b,
                    Err(e) => return (points, failed(c.w[nz], e)),
                };
                // grown after an easy step that turned little
                let turn: f64 = c.tangent.iter().zip(&t).map(|(a, b)| a * b).sum();
                if c.iterations <= 3 && turn > EASY_TURN_COS {
                    ds = (1.5 * ds).min(ds_max);
                }
                // the state moved to the gauge by the search: its unknowns
                let mut wn = eq.unknowns(&point.solution);
                for &k in &eq.cyclic {
                    wn[k] = 0.0;
                }
                wn.push(c.w[nz]);
                points.push(point);
                closing.reached(&wn);
                (w, t, failed_at) = (wn, c.tangent, None);
            }
            Err(AnalysisError::Stopped) => return (points, failed(p, AnalysisError::Stopped)),
            Err(e) => {
                // a natural step that failed is not tried again: arclength
                // steps shorter than it go on
                if value.is_some() {
                    failed_at = value;
                }
                ds = 0.5 * ds.min(s);
                if ds < ds_min {
                    return (points, failed(p, e));
                }
            }
        }
    }
    let reason = format!(
        "the branch took {most} points without leaving the range or coming back to its start ({}): ended",
        why_no_end(&points)
    );
    (points, failed(w[nz], AnalysisError::Request { reason }))
}

/// Why a branch of `points` did not reach its range's end in the points
/// allowed: it folds back and forth, or (a limit cycle's) its period
/// grows while the parameter stalls, the cycle ending at an orbit of
/// infinite period (a homoclinic orbit, or a saddle-node on the cycle:
/// Kuznetsov §6.2 and §7.1: `four-bar`'s cycle from 0.783 s at 0.3 N m to
/// 1.85 s at 0.24352 N m, the steps creeping), or its steps shrank.
fn why_no_end(points: &[BranchPoint]) -> String {
    let folds =
        points.windows(2).filter(|w| matches!((w[0].dp_ds, w[1].dp_ds), (Some(a), Some(b)) if a * b < 0.0)).count();
    if folds >= 2 {
        return format!("it turns back and forth: {folds} folds");
    }
    let periods: Vec<f64> = points
        .iter()
        .filter_map(|p| match &p.solution {
            Solution::Periodic(o) => Some(o.period),
            Solution::Steady(_) => None,
        })
        .collect();
    let (first, last) = (points[0].value, points[points.len() - 1].value);
    let tail = &points[points.len() / 2..];
    let moved = (tail[tail.len() - 1].value - tail[0].value).abs();
    let growing = periods.len() == points.len() && periods.windows(2).rev().take(10).all(|w| w[1] > w[0]);
    if growing && periods[periods.len() - 1] > 1.5 * periods[0] {
        return format!(
            "its period grows, from {} s at {} to {} s at {}, while the parameter moves by {:.1e} over its last {} \
             points: the cycle ends at an orbit of infinite period (a homoclinic orbit, or a saddle-node on the cycle) \
             near {}",
            fmt_value(periods[0]),
            fmt_value(first),
            fmt_value(periods[periods.len() - 1]),
            fmt_value(last),
            moved,
            tail.len(),
            fmt_value(last)
        );
    }
    format!("its steps shrank: the parameter moved by {:.1e} over its last {} points", moved, tail.len())
}

/// Largest distance from the first point, relative to the step's chord,
/// at which a step's chord passing it closes the branch: a chord of an
/// arc that turns by at most 37 degrees ([`MIN_TURN_COS`]) sags from it
/// by at most `1 - cos(37/2 deg)` of half the chord, 0.026 of the chord;
/// twice that.
const CLOSE_SAG: f64 = 0.05;

/// How far, relative to `1 + |w0|` (max norm), the point corrected on the
/// hyperplane through the first point may lie from it for the branch to
/// be the same there: ten thousand times the corrector's tolerance
/// (`5e-13` relative), the Jacobian's conditioning room.
const CLOSE_TOL: f64 = 1e-8;

/// Smallest `|dp/ds|` of the first point's tangent at which the branch is
/// closed on the hyperplane of the first point's parameter value (the
/// tangent within 84 degrees of the parameter's axis); closer to a fold,
/// on the one normal to the tangent.
const STEEP: f64 = 0.1;

/// Whether a branch comes back to its first point `w0` (tangent `t0`):
/// a step's chord from `w` to the next point passes within [`CLOSE_SAG`]
/// of its length from `w0`, the next tangent pointing the way `t0` does,
/// after the branch has been further from `w0` than twice that chord;
/// then the point corrected on the hyperplane through `w0` normal to `t0`
/// (or to the parameter's axis, [`STEEP`]) from the chord's nearest point
/// must be `w0` to [`CLOSE_TOL`] (a branch
/// that passes near its start on another sheet is not closed). The bodies'
/// headings `angles` (indices into `w`) are compared modulo a turn: a
/// pendulum's equilibria around a full turn close.
struct Closing {
    w0: Vec<f64>,
    t0: Vec<f64>,
    angles: Vec<usize>,
    /// The largest distance from `w0` of the points so far.
    away: f64,
}

impl Closing {
    fn new(w0: &[f64], t0: &[f64], angles: Vec<usize>) -> Self {
        Closing { w0: w0.to_vec(), t0: t0.to_vec(), angles, away: 0.0 }
    }

    /// `w - w0`, its headings wrapped to within half a turn.
    fn offset(&self, w: &[f64]) -> Vec<f64> {
        let mut d: Vec<f64> = w.iter().zip(&self.w0).map(|(a, b)| a - b).collect();
        for &k in &self.angles {
            d[k] -= std::f64::consts::TAU * (d[k] / std::f64::consts::TAU).round();
        }
        d
    }

    /// A point `w` of the branch taken.
    fn reached(&mut self, w: &[f64]) {
        self.away = self.away.max(norm(&self.offset(w)));
    }

    /// The point at `w0` (its headings a whole number of turns from
    /// `w0`'s, as the branch has carried them), where the step from `w`
    /// to `c` passes it; `None` where it does not.
    fn passes<M: Model>(
        &self,
        eq: &mut Equations,
        build: &mut impl FnMut(f64) -> Result<Analysis<M>, AnalysisError>,
        w: &[f64],
        c: &Corrected,
    ) -> Option<Corrected> {
        let chord: Vec<f64> = c.w.iter().zip(w).map(|(a, b)| a - b).collect();
        let len = norm(&chord);
        let a = self.offset(w);
        let along = dot(&self.t0, &c.tangent);
        if len == 0.0 || self.away <= 2.0 * len || along <= 0.0 {
            return None;
        }
        let sigma = (-dot(&a, &chord) / (len * len)).clamp(0.0, 1.0);
        let near: Vec<f64> = a.iter().zip(&chord).map(|(x, y)| x + sigma * y).collect();
        if norm(&near) > CLOSE_SAG * len {
            return None;
        }
        // w0 as the branch carries it (whole turns on), and the hyperplane
        // through it normal to t0, from the chord's nearest point; where the
        // branch crosses the parameter's value there steeply, that value's
        // (the closing point at the first's value exactly)
        let nz = w.len() - 1;
        let target: Vec<f64> = w.iter().zip(&a).map(|(x, o)| x - o).collect();
        let from: Vec<f64> = w.iter().zip(&chord).map(|(x, y)| x + sigma * y).collect();
        let mut n = self.t0.clone();
        if self.t0[nz].abs() > STEEP {
            n = vec![0.0; nz + 1];
            n[nz] = 1.0;
        }
        let gap: Vec<f64> = target.iter().zip(&from).map(|(x, y)| x - y).collect();
        let lift = dot(&n, &gap);
        let w_hat: Vec<f64> = from.iter().zip(&n).map(|(x, t)| x + lift * t).collect();
        let mut back = eq.correct(build, &w_hat, &n).ok()?;
        if n[nz] == 1.0 {
            // Newton holds it to rounding
            back.w[nz] = target[nz];
        }
        let scale = 1.0 + self.w0.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let miss = back.w.iter().zip(&target).fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
        (miss < CLOSE_TOL * scale).then_some(back)
    }
}

/// The Euclidean norm of `v`.
fn norm(v: &[f64]) -> f64 {
    dot(v, v).sqrt()
}

/// `a . b`.
fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Locates the fold between the branch points `a` and `b` (from
/// [`follow_arclength`]) whose tangents' parameter components
/// [`BranchPoint::dp_ds`] have opposite signs: the root of `dp/ds` along
/// the chord from `a` to `b` by the Illinois variant of regula falsi,
/// each trial point corrected on the hyperplane through it normal to the
/// chord, until `|dp/ds| < 1e-9` (the parameter then within `1e-18 /
/// kappa` of the fold's, `kappa` the branch's curvature there) or the
/// chord's bracket is below `tol` relative. `None` where the signs agree
/// or either point has none.
///
/// # Errors
/// The corrector's error inside the bracket; `build`'s.
pub fn locate_fold<M: Model>(
    a: &BranchPoint,
    b: &BranchPoint,
    follow: Follow,
    mut build: impl FnMut(f64) -> Result<Analysis<M>, AnalysisError>,
    tol: f64,
) -> Result<Option<Bifurcation>, AnalysisError> {
    let (Some(sa), Some(sb)) = (a.dp_ds, b.dp_ds) else { return Ok(None) };
    if sa.signum() == sb.signum() {
        return Ok(None);
    }
    let mut eq = Equations::new(follow, &a.solution);
    let wa: Vec<f64> = [eq.unknowns(&a.solution), vec![a.value]].concat();
    let wb: Vec<f64> = [eq.unknowns(&b.solution), vec![b.value]].concat();
    let nz = wa.len() - 1;
    let chord: Vec<f64> = wb.iter().zip(&wa).map(|(x, y)| x - y).collect();
    let len = chord.iter().map(|v| v * v).sum::<f64>().sqrt();
    let n: Vec<f64> = chord.iter().map(|v| v / len).collect();
    // dp/ds oriented along the chord, at sigma in [0, 1]
    let mut at = |sigma: f64| -> Result<Corrected, AnalysisError> {
        let w_hat: Vec<f64> = wa.iter().zip(&chord).map(|(x, c)| x + sigma * c).collect();
        eq.correct(&mut build, &w_hat, &n)
    };
    // the tangents oriented along the chord
    let (mut s0, mut f0, mut p0) = (0.0, at(0.0)?.tangent[nz], a.value);
    let (mut s1, mut f1, mut p1) = (1.0, at(1.0)?.tangent[nz], b.value);
    if f0.signum() == f1.signum() {
        return Ok(None);
    }
    let mut solves = 2;
    let mut side = 0;
    let mut best = None;
    for _ in 0..MAX_FOLD_STEPS {
        let s = (s0 * f1 - s1 * f0) / (f1 - f0);
        let c = at(s)?;
        solves += 1;
        let f = c.tangent[nz];
        let done = f.abs() < 1e-9 || (s1 - s0).abs() * len < tol;
        if f.signum() == f0.signum() {
            (s0, f0, p0) = (s, f, c.w[nz]);
            if side == -1 {
                f1 *= 0.5;
            }
            side = -1;
        } else {
            (s1, f1, p1) = (s, f, c.w[nz]);
            if side == 1 {
                f0 *= 0.5;
            }
            side = 1;
        }
        best = Some(c);
        if done {
            break;
        }
    }
    let c = best.expect("one step at least");
    let bracket = [p0, p1];
    let point = eq.point(&mut build, &c)?;
    let crit = critical(&point.solution, &a.solution, &b.solution);
    // a fold's Newton matrix is singular: an eigenvalue 0 or multiplier
    // 1 there, or the tangents' signs were not the branch's (a step too
    // long for a limit cycle's phase condition through its previous
    // point turned `four-bar`'s tangent at 0.316 N m with its nearest
    // multiplier 0.046)
    if let Some(&z) = crit.first()
        && boundary_distance(&point.solution, z) > FOLD_CRITICAL
    {
        return Err(AnalysisError::Numerics {
            reason: format!(
                "the tangent's parameter component changes sign between {} and {}, but where it vanishes ({}) \
                 no eigenvalue or multiplier is on the stability boundary (the nearest {:.6} {:+.6}i): not a fold, \
                 the tangent is not resolved there (a finer grid resolves it)",
                fmt_value(a.value),
                fmt_value(b.value),
                fmt_value(point.value),
                z.re,
                z.im
            ),
        });
    }
    Ok(Some(Bifurcation {
        value: point.value,
        bracket,
        kind: BifurcationKind::Fold,
        critical: crit,
        solution: at_bifurcation(point.solution, family(&a.solution).min(family(&b.solution))),
        solves,
    }))
}

/// A point on the other branch through the branch point or period
/// doubling `b` (from [`super::bifurcation::locate`], on a branch followed
/// as `follow` says): at a branch point the new branch leaves along the
/// null direction `phi` of the defining equations' Jacobian in the
/// unknowns (the critical eigenvector, e.g. a straight gait's turning
/// mode), so the point is sought from `z* + offset phi` on the
/// hyperplane `phi . (z - z*) = offset`, the parameter free (Seydel §5.6,
/// "branch switching by a parallel predictor"; Kuznetsov §10.2). At a
/// period doubling the same is done for the orbit of twice the period,
/// for which the doubling is a branch point (its multiplier -1 squared
/// is +1). `offset` is in the state's units (1e-3 to 1e-2 of its scale:
/// past the Newton matrix's near-singularity, inside the new branch's
/// quadratic bend). Returns the new branch's point and how to follow it
/// ([`follow_arclength`], from the point's value and state).
///
/// # Errors
/// [`AnalysisError::Request`] for a bifurcation of another kind or a
/// limit cycle; the corrector's, where no other branch is within reach
/// (a null direction that is the followed branch's own); `build`'s.
pub fn switch_branch<M: Model>(
    b: &Bifurcation,
    follow: Follow,
    mut build: impl FnMut(f64) -> Result<Analysis<M>, AnalysisError>,
    offset: f64,
) -> Result<(BranchPoint, Follow), AnalysisError> {
    let follow = match (b.kind, follow, &b.solution) {
        // a forced orbit's phase and period as the branch holds them, taken
        // at the bifurcation's own orbit
        (BifurcationKind::BranchPoint, Follow::Periodic { settings, .. }, Solution::Periodic(o)) => {
            Follow::Periodic { t0: o.t0, period: o.period, settings }
        }
        (BifurcationKind::BranchPoint, f, _) => f,
        (BifurcationKind::PeriodDoubling, Follow::Periodic { settings, .. }, Solution::Periodic(o)) => {
            Follow::Periodic { t0: o.t0, period: 2.0 * o.period, settings }
        }
        (kind, _, _) => {
            return Err(AnalysisError::Request {
                reason: format!(
                    "a branch is switched at a branch point or a period doubling, not at a {}",
                    kind.name()
                ),
            });
        }
    };
    // the solution at the bifurcation, under the equations to switch on
    let mut timing = OrbitTiming::default();
    let at = build(b.value).and_then(|mut an| solve(&mut an, follow, b.solution.state(), &mut timing))?;
    let mut eq = Equations::new(follow, &at);
    eq.timing = timing;
    let z = eq.unknowns(&at);
    let mut an = build(b.value)?;
    let (_, j) = eq.eval(&mut an, &z, true)?;
    let (_, phi) = dense::smallest_right_singular(j.expect("asked for").as_ref())?;
    let mut w_hat: Vec<f64> = z.iter().zip(&phi).map(|(a, v)| a + offset * v).collect();
    w_hat.push(b.value);
    let mut n = phi;
    n.push(0.0);
    let c = eq.correct(&mut build, &w_hat, &n)?;
    let point = eq.point(&mut build, &c)?;
    Ok((point, follow))
}
