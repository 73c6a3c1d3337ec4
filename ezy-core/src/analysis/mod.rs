//! Beyond simulation: exact linearization, steady motions (relative
//! equilibria) with their stability, and periodic gaits with their Floquet
//! multipliers.
//!
//! The analyses work on the state `x = [q, qd]` (2 nq) of the index-1 DAE
//! written as an ODE, `x' = f(t, x) = [qd, qdd(t, q, qd)]`, with `qdd` from
//! the KKT system `[M G^T; G 0] [qdd; mu] = [F; -gamma]` (docs/physics.md
//! §5), restricted to the tangent space of the constraint manifold
//! `{phi(q) = 0, G(q) qd = 0}` (the manifold is invariant, so its tangent
//! space is invariant under the linearization: Hairer & Wanner, *Solving
//! ODEs II*, §VII.1; for nonholonomic systems Bloch, *Nonholonomic
//! Mechanics and Control*, 2nd ed., §5.3 and §8.5).
//!
//! - [`Analysis::linearize`]: `A = df/dx` (2nq x 2nq) and `B = df/du` for
//!   named inputs. The model's generated terms (`G`, `gamma`) are
//!   differentiated exactly in forward mode (dual numbers through the
//!   code the `model!` macro generated); `qdd`'s derivative then follows
//!   exactly from the KKT system by implicit differentiation. Applied
//!   forces are differentiated exactly too, each law by its own
//!   [`ForceLaw::jacobian`] (every built-in law has one); the force of a
//!   law of the user's own without one is differentiated alone by central
//!   differences (step `eps^(1/3) max(1, |x_j|)`, error about 1e-10
//!   relative), and named by [`Analysis::differenced_laws`].
//! - [`Analysis::steady_motion`]: a relative equilibrium, a motion
//!   `x(t) = exp(t xi) x0` along the plane's rigid motions (going straight,
//!   turning steadily with fixed shape), found by Newton from a guess; its
//!   eigenvalues modulo the symmetry (Marsden & Ratiu, *Introduction to
//!   Mechanics and Symmetry*, §9; Zenkov, Bloch & Marsden, "The energy
//!   momentum method for the stability of nonholonomic systems", Dyn.
//!   Stab. Sys. 13, 1998). Without symmetry (a mechanism on the ground) it
//!   is an ordinary equilibrium.
//! - [`Analysis::periodic_orbit`]: a gait of a periodically forced scene,
//!   the fixed point of the period map modulo the symmetry, by shooting
//!   with Newton and the variational equations integrated alongside the
//!   state (Seydel, *Practical Bifurcation and Stability Analysis*, 3rd
//!   ed., §7.1-7.3); its Floquet multipliers, mean speed and the net
//!   displacement and heading change per period.
//!
//! - [`Analysis::gait_or_growth`]: the same where the guess is in a
//!   transient the search cannot converge from: the scene run on
//!   ([`Analysis::settle`]) until its motion settles, then the search
//!   again; or, where the motion gains energy without bound, that
//!   verdict with its growth measured ([`Growth`]: the kinetic energy's
//!   and the speed's power laws, each by its own fit). [`Analysis::gait`]
//!   is the same for a caller that needs an orbit (a growth is its error).
//!
//! - [`Analysis::limit_cycle`]: a periodic motion of an autonomous scene
//!   (a crank turning under a constant torque), its period an unknown
//!   fixed by a phase condition, headings that turn whole revolutions
//!   taken modulo 2 pi; [`Analysis::return_time`] reads a first period
//!   off a run.
//!
//! - [`arclength::follow_arclength`]: a branch of either as a parameter
//!   varies, by pseudo-arclength continuation through folds (points on
//!   the parameter's grid where the branch is a graph over it), with its
//!   changes of stability; [`arclength::locate_fold`] locates a fold,
//!   [`bifurcation::locate`] bisects a change of stability to the
//!   tolerance asked and names it (branch point, period doubling,
//!   Neimark-Sacker, Hopf) by its critical eigenvalue or multiplier;
//!   [`branch::follow`] is natural-parameter continuation.
//!
//! The plane's symmetry (translations, rotations) is found numerically
//! ([`Analysis::symmetry`]): a scene is invariant under a rigid motion when
//! its constraints and accelerations are equivariant at test states, so a
//! force law of the user's own is treated exactly as a built-in one.
//!
//! [`ForceLaw::jacobian`]: crate::effects::kind::ForceLaw::jacobian

pub mod arclength;
pub mod bifurcation;
pub mod branch;
mod cycle;
pub mod cycle_branch;
pub(crate) mod cycle_phase;
pub(crate) mod dense;
pub(crate) mod gait_means;
mod growth;
mod linear;
mod newton;
pub(crate) mod periodic;
mod settle;
mod steady;
pub(crate) mod structural;
pub mod switching;
pub(crate) mod symmetry;

pub use bifurcation::{Bifurcation, BifurcationKind, NearMiss};
pub use branch::{BranchEnd, BranchPoint, Follow, Solution};
pub use faer::c64;
pub use growth::{Growth, GrowthFit, PowerLaw};
pub use linear::{Input, Linearization};
pub use periodic::{PeriodicOrbit, PeriodicSettings};
pub use settle::{GaitOrGrowth, MAX_SETTLE_PERIODS, Settle, Settling, Until};
pub use steady::{Stability, SteadyMotion};
pub use structural::StructuralMultiplier;
pub use symmetry::{Generator, Pose, Symmetry};

use faer::Mat;
use num_dual::Dual64;

use crate::effects::kind::Waveforms;
use crate::effects::law::{Law, apply_effects};
use crate::effects::waveform::Periodicity;
use crate::error::SimError;
use crate::formulation::dae::Dynamics;
use crate::model::Model;
use crate::model::info::scatter_dense;

/// Why an analysis failed.
#[derive(Debug, thiserror::Error)]
pub enum AnalysisError {
    /// The right-hand side failed (an effect without a force at a state).
    #[error(transparent)]
    Sim(#[from] SimError),
    /// Newton's method did not reach the tolerance.
    #[error(
        "the search for {what} did not converge: after {iterations} Newton iterations the residual is {residual:.3e} (tolerance {tolerance:.1e}); start from another guess"
    )]
    NotConverged {
        /// What was sought: "a steady motion", "a periodic orbit".
        what: &'static str,
        /// Iterations done.
        iterations: usize,
        /// The last residual (max norm).
        residual: f64,
        /// The tolerance it had to reach.
        tolerance: f64,
    },
    /// The search went where no orbit near the guess is: its period
    /// took ever more steps (a motion whose speed grows).
    #[error("{reason}")]
    Wandered {
        /// What happened, with the steps taken.
        reason: String,
    },
    /// There is no periodic orbit to find, for the reason measured: an
    /// energy that grows without bound (where an orbit is needed,
    /// [`Analysis::gait`]), a motion that does not settle.
    #[error("no periodic orbit: {reason}")]
    NoOrbit {
        /// Why, with what was measured.
        reason: String,
    },
    /// A linear-algebra step failed (a singular KKT system, an SVD or
    /// eigenvalue iteration that did not converge).
    #[error("{reason}")]
    Numerics {
        /// What failed.
        reason: String,
    },
    /// The stop hook ([`Analysis::stop_when`]) asked to stop.
    #[error("the analysis was stopped")]
    Stopped,
    /// A request that does not fit the scene: a steady motion of a
    /// time-dependent scene, a periodic orbit without a period, an input
    /// the model does not have.
    #[error("{reason}")]
    Request {
        /// What is wrong, naming the culprit.
        reason: String,
    },
}

/// Most bytes one dense matrix of an analysis may take (1 GB): the
/// analyses solve the KKT system and form Jacobians densely, so a model
/// beyond about 11,000 coordinates and constraints is refused
/// ([`Analysis::check_size`]) before the memory is taken.
pub const MAX_DENSE_BYTES: f64 = 1e9;

/// A model with its effects and drives, ready for the analyses: the
/// right-hand side of a run ([`Dynamics`]) seen as `x' = f(t, x)`.
///
/// Built from a [`crate::problem::Problem`] by [`crate::problem::Problem::analysis`], or from
/// a [`Dynamics`] by [`Analysis::new`].
#[derive(Debug)]
pub struct Analysis<M: Model> {
    sys: Dynamics<M>,
    /// `(x, y, phi)` indices of each body.
    bodies: Vec<[usize; 3]>,
    /// Scratch: effect and drive powers.
    power: Vec<f64>,
    /// Asked between Newton iterations and at every step of a period's
    /// integration: `true` stops the analysis.
    stop: Option<fn() -> bool>,
    /// The skate with friction nearest to sliding over the KKT solves
    /// since [`Analysis::watch_grip`] ([`Analysis::check_grip`]).
    grip: Option<Grip>,
    /// The first skate with friction seen sliding since
    /// [`Analysis::watch_grip`]: in a sliding mode, or at a state whose
    /// lateral slip velocity is not zero ([`Analysis::check_grip`]).
    slid: Option<Slide>,
    /// The effects whose force a linearization differentiated by
    /// differences, first met first ([`Analysis::differenced_laws`]).
    differenced: Vec<String>,
    /// Whether the last force Jacobian differenced any effect's force.
    last_differenced: bool,
    /// Every effect's force by differences, none exactly
    /// ([`Analysis::set_force_differences`]).
    force_differences: bool,
}

/// A skate with friction seen sliding: in a sliding mode, or at a state
/// whose lateral slip velocity is not zero.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Slide {
    /// Index into [`Dynamics::friction`].
    skate: usize,
    /// Time \[s\].
    t: f64,
    /// The lateral slip velocity `G_row qd` \[m/s\].
    slip: f64,
}

/// The worst grip of a skate with friction seen over some KKT solves: the
/// lateral force holding it against its friction limit.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Grip {
    /// Index into [`Dynamics::friction`].
    skate: usize,
    /// Time \[s\].
    t: f64,
    /// `|lambda|`, the lateral force holding the skate \[N\].
    force: f64,
}

/// `v` to 4 significant digits, short.
fn sig(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return crate::names::fmt_value(v);
    }
    let scale = 10f64.powi(3 - v.abs().log10().floor() as i32);
    crate::names::fmt_value((v * scale).round() / scale)
}

/// Relative excess of a skate's holding force over its friction limit
/// `mu N` that the analyses accept as rounding (the KKT solve's error is
/// far below it; a skate that slides needs more).
const GRIP_RTOL: f64 = 1e-9;

/// What the KKT solve gives at one state.
#[derive(Debug, Clone)]
pub(crate) struct Point {
    /// `qdd` (nq).
    pub qdd: Vec<f64>,
    /// The KKT multipliers `mu` (nc) of `[M G^T; G 0] [qdd; mu] = [F; -gamma]`.
    pub mu: Vec<f64>,
    /// `G` (nc x nq).
    pub g: Mat<f64>,
    /// The KKT matrix ((nq + nc) x (nq + nc)).
    pub kkt: Mat<f64>,
}

impl<M: Model> Analysis<M> {
    /// Wraps a right-hand side (its model, effects and drives).
    pub fn new(sys: Dynamics<M>) -> Self {
        let bodies = sys.info.bodies.iter().map(|b| b.coords).collect();
        let power = vec![0.0; sys.effects.len()];
        Self {
            sys,
            bodies,
            power,
            stop: None,
            grip: None,
            slid: None,
            differenced: Vec::new(),
            last_differenced: false,
            force_differences: false,
        }
    }

    /// Sets a hook asked between Newton iterations and at every step of a
    /// period's integration; when it returns `true` the analysis ends with
    /// [`AnalysisError::Stopped`] (a signal handler's flag: `ezy` stops on
    /// Ctrl-C within a step).
    pub fn stop_when(&mut self, stop: fn() -> bool) {
        self.stop = Some(stop);
    }

    /// The names of the effects whose force the analyses so far
    /// differentiated by central differences, in the order first met:
    /// those whose law has no exact Jacobian
    /// ([`crate::effects::kind::ForceLaw::jacobian`] returned `false`: a
    /// law of the user's own that does not implement it). Empty when every force was differentiated exactly (every
    /// built-in law is), and before the first linearization; every
    /// analysis linearizes ([`Analysis::linearize`], a steady motion's
    /// Newton iteration and eigenvalues, a periodic orbit's variational
    /// equations), so after one this is what its output should state.
    pub fn differenced_laws(&self) -> Vec<String> {
        self.differenced.clone()
    }

    /// With `all`, every effect's force is differentiated by central
    /// differences and none exactly (as before the laws' exact
    /// Jacobians): for tests comparing the two. Not noted in
    /// [`Analysis::differenced_laws`].
    #[doc(hidden)]
    pub fn set_force_differences(&mut self, all: bool) {
        self.force_differences = all;
    }

    /// Whether the last linearization differentiated any effect's force by
    /// differences.
    pub(crate) fn last_differenced(&self) -> bool {
        self.last_differenced
    }

    /// Starts watching the skates with friction over the KKT solves that
    /// follow ([`Analysis::check_grip`]).
    pub(crate) fn watch_grip(&mut self) {
        self.grip = None;
        self.slid = None;
    }

    /// Refuses what the KKT solves since [`Analysis::watch_grip`] found: a
    /// skate with friction whose holding force passed its limit `mu N`.
    /// The analyses take every skate as holding (an ideal knife edge); a
    /// motion on which one slides is not that (Coulomb friction switches
    /// the skate's row off; a run follows it, an analysis does not).
    ///
    /// # Errors
    /// [`AnalysisError::Request`] naming the skate, its force, its limit,
    /// the time and `what` was analysed.
    pub(crate) fn check_grip(&self, what: &str) -> Result<(), AnalysisError> {
        if let Some(g) = self.slid {
            let fr = &self.sys.friction[g.skate];
            return Err(AnalysisError::Request {
                reason: format!(
                    "skate `{}` slides on {what}: at t = {} s its lateral slip velocity is {} m/s (effect `{}`); the analyses, sensitivities, fits and linearizations take every skate as holding and do not follow a stick-slip switch (the jump of the sensitivities there), so a motion on which one slides is not theirs (run it: `ezy run` follows the slide)",
                    fr.name,
                    sig(g.t),
                    sig(g.slip),
                    self.sys.effects[fr.effect].name
                ),
            });
        }
        let Some(g) = self.grip else { return Ok(()) };
        let fr = &self.sys.friction[g.skate];
        if g.force <= fr.limit * (1.0 + GRIP_RTOL) {
            return Ok(());
        }
        Err(AnalysisError::Request {
            reason: format!(
                "skate `{}` slides on {what}: holding it takes a lateral force of {} N (at t = {} s), more than its friction limit mu N = {} N (effect `{}`); the analyses take every skate as holding, so a motion on which one slides is not theirs to analyse (run it: `ezy run` follows the slide)",
                fr.name,
                sig(g.force),
                sig(g.t),
                sig(fr.limit),
                self.sys.effects[fr.effect].name
            ),
        })
    }

    /// Refuses a scene with what the analyses cannot follow: an event
    /// that switches effects (the analyses take the forces as the scene
    /// starts them, and no switch).
    ///
    /// # Errors
    /// [`AnalysisError::Request`] naming the event.
    pub fn check_scope(&self) -> Result<(), AnalysisError> {
        if let Some(e) = self.sys.events.iter().find(|e| e.action == crate::events::spec::Action::Switch) {
            return Err(AnalysisError::Request {
                reason: format!(
                    "event `{}` switches effects during a run; the analyses take the forces as the scene starts them and follow no switch: remove the event (or give the effects as they are after it)",
                    e.name
                ),
            });
        }
        Ok(())
    }

    /// [`AnalysisError::Stopped`] if the stop hook says so.
    pub(crate) fn check_stop(&self) -> Result<(), AnalysisError> {
        match self.stop {
            Some(stop) if stop() => Err(AnalysisError::Stopped),
            _ => Ok(()),
        }
    }

    /// The right-hand side analysed.
    pub fn dynamics(&self) -> &Dynamics<M> {
        &self.sys
    }

    /// Number of coordinates nq (the state has 2 nq components).
    pub fn nq(&self) -> usize {
        self.sys.nq()
    }

    /// Names of the state components `[q, qd]` (2 nq): `x1`, ..., `x1d`, ....
    pub fn state_names(&self) -> Vec<String> {
        let mut names = self.sys.state_names();
        names.truncate(2 * self.nq());
        names
    }

    /// How the scene's forcing depends on time: the combined
    /// [`Periodicity`] of its effects' waveforms and its drives' angles;
    /// `None` when an effect is a law of the user's own (whose time
    /// dependence ezy cannot see: give the period).
    pub fn forcing(&self) -> Option<Periodicity> {
        let mut parts = Vec::new();
        for e in &self.sys.effects {
            parts.push(e.periodicity()?);
        }
        parts.extend(self.sys.drives.iter().map(|d| d.angle.periodicity()));
        Some(Periodicity::combine(parts))
    }

    /// `x' = f(t, x)` (2 nq each).
    ///
    /// # Errors
    /// As [`Analysis::check_state`]; [`AnalysisError::Numerics`] if the
    /// KKT system is singular at `x`; [`AnalysisError::Sim`] if an effect
    /// fails.
    pub fn rhs(&mut self, t: f64, x: &[f64]) -> Result<Vec<f64>, AnalysisError> {
        self.check_state(x)?;
        let nq = self.nq();
        let p = self.point(t, x)?;
        let mut f = x[nq..2 * nq].to_vec();
        f.extend_from_slice(&p.qdd);
        Ok(f)
    }

    /// The generalized applied force `F` (nq) at `(t, q, qd)`.
    pub(crate) fn forces(&mut self, t: f64, q: &[f64], qd: &[f64]) -> Result<Vec<f64>, AnalysisError> {
        if self.sys.effects.is_empty() {
            return Ok(vec![0.0; q.len()]);
        }
        self.sys.applied_forces(t, q, qd, &mut self.power)?;
        Ok(self.sys.applied_force().to_vec())
    }

    /// `G` dense (nc x nq) from its values at the pattern.
    pub(crate) fn dense_g(&self, values: &[f64]) -> Mat<f64> {
        let (nc, nq) = (self.sys.info.nc(), self.nq());
        let mut g = vec![0.0; nc * nq];
        scatter_dense(&self.sys.info.pattern, values, nq, &mut g);
        dense::from_rows(nc, nq, &g)
    }

    /// Checks that the model is small enough for the analyses' dense
    /// matrices: the KKT matrix `(nq + nc)^2` and the state Jacobian
    /// `(2 nq)^2`, each at most [`MAX_DENSE_BYTES`]; and that the scene
    /// has nothing they cannot follow ([`Analysis::check_scope`]).
    ///
    /// # Errors
    /// [`AnalysisError::Request`] with the size it would take; as
    /// [`Analysis::check_scope`].
    pub fn check_size(&self) -> Result<(), AnalysisError> {
        self.check_scope()?;
        let (nq, nc) = (self.nq(), self.sys.info.nc());
        let n = (nq + nc).max(2 * nq);
        let bytes = 8.0 * n as f64 * n as f64;
        if bytes > MAX_DENSE_BYTES {
            return Err(AnalysisError::Request {
                reason: format!(
                    "the analyses hold dense matrices of {n} x {n} values for a model of {nq} coordinates and {nc} constraints: {:.1} GB each, more than the {:.1} GB they may take (a family's size sets it: analyse a smaller one)",
                    bytes / 1e9,
                    MAX_DENSE_BYTES / 1e9
                ),
            });
        }
        Ok(())
    }

    /// Checks that `x` is a state of the model: `2 nq` finite values, the
    /// coordinates `q` then the velocities `qd` (and that the model fits
    /// the analyses, [`Analysis::check_size`]).
    ///
    /// # Errors
    /// [`AnalysisError::Request`] naming the length or the first value
    /// that is not finite (by its state name); as
    /// [`Analysis::check_size`].
    pub fn check_state(&self, x: &[f64]) -> Result<(), AnalysisError> {
        self.check_size()?;
        let n = 2 * self.nq();
        if x.len() != n {
            return Err(AnalysisError::Request {
                reason: format!(
                    "a state of {} values given to a model of {n} (its {} coordinates q, then their velocities qd)",
                    x.len(),
                    n / 2
                ),
            });
        }
        if let Some(k) = x.iter().position(|v| !v.is_finite()) {
            let name = self.state_names().get(k).cloned().unwrap_or_default();
            return Err(AnalysisError::Request { reason: format!("the state's `{name}` is {}: not a number", x[k]) });
        }
        Ok(())
    }

    /// The constraint residuals at `(t, x)`: `phi(q)` less the drives'
    /// angles (nh), then `G(q) qd` less the drives' rates (nc).
    ///
    /// # Errors
    /// As [`Analysis::check_state`].
    pub fn constraint_residual(&self, t: f64, x: &[f64]) -> Result<Vec<f64>, AnalysisError> {
        self.check_state(x)?;
        Ok(self.residual_at(t, x))
    }

    /// [`Analysis::constraint_residual`] of a state known to fit.
    pub(crate) fn residual_at(&self, t: f64, x: &[f64]) -> Vec<f64> {
        let info = &self.sys.info;
        let mut out = vec![0.0; info.n_holonomic + info.nc()];
        self.residual_into(t, x, &mut vec![0.0; info.pattern.len()], &mut out);
        out
    }

    /// [`Analysis::residual_at`] into `out` (nh + nc), `values` scratch
    /// for `G` at its pattern: allocates nothing.
    pub(crate) fn residual_into(&self, t: f64, x: &[f64], values: &mut [f64], out: &mut [f64]) {
        let info = &self.sys.info;
        let (nq, nh) = (self.nq(), info.n_holonomic);
        let (q, qd) = (&x[..nq], &x[nq..2 * nq]);
        let (phi, v) = out.split_at_mut(nh);
        phi.fill(0.0);
        values.fill(0.0);
        self.sys.model.phi(q, phi);
        crate::drive::shift_positions(&self.sys.drives, t, phi);
        self.sys.model.constraint_matrix(q, values);
        v.fill(0.0);
        for (&(r, c), &g) in info.pattern.iter().zip(values.iter()) {
            v[r] += g * qd[c];
        }
        crate::drive::shift_velocities(&self.sys.drives, t, v);
    }

    /// The rate in time of [`Analysis::residual_at`] at a fixed state
    /// (nh + nc): a drive's rows `-u'(t)` (positions) and `-u''(t)`
    /// (velocities), zero elsewhere.
    pub(crate) fn residual_rate(&self, t: f64) -> Vec<f64> {
        let nh = self.sys.info.n_holonomic;
        let mut rate = vec![0.0; nh + self.sys.info.nc()];
        for d in &self.sys.drives {
            let [_, u1, u2] = d.angle.eval3(t);
            rate[d.row] -= u1;
            rate[nh + d.row] -= u2;
        }
        rate
    }

    /// Solves the KKT system at `(t, x)`.
    pub(crate) fn point(&mut self, t: f64, x: &[f64]) -> Result<Point, AnalysisError> {
        let info = &self.sys.info;
        let (nq, nc) = (self.nq(), info.nc());
        let (q, qd) = (&x[..nq], &x[nq..2 * nq]);
        let mut values = vec![0.0; info.pattern.len()];
        let mut gamma = vec![0.0; nc];
        self.sys.model.constraint_terms(q, qd, &mut values, &mut gamma);
        for d in &self.sys.drives {
            gamma[d.row] -= d.angle.eval3(t)[2];
        }
        let g = self.dense_g(&values);
        self.note_slip(t, qd, &g);
        let f = self.forces(t, q, qd)?;
        let mass = &self.sys.mass;
        let n = nq + nc;
        let kkt = Mat::from_fn(n, n, |i, j| match (i < nq, j < nq) {
            (true, true) => {
                if i == j {
                    mass[i]
                } else {
                    0.0
                }
            }
            (true, false) => g[(j - nq, i)],
            (false, true) => g[(i - nq, j)],
            (false, false) => 0.0,
        });
        let rhs = Mat::from_fn(n, 1, |i, _| if i < nq { f[i] } else { -gamma[i - nq] });
        let sol = dense::solve(kkt.as_ref(), rhs.as_ref(), "the KKT matrix [M G^T; G 0]")?;
        let qdd = (0..nq).map(|i| sol[(i, 0)]).collect();
        let mu: Vec<f64> = (nq..n).map(|i| sol[(i, 0)]).collect();
        self.note_grip(t, &mu);
        Ok(Point { qdd, mu, g, kkt })
    }

    /// Notes the skates' holding forces in the multipliers `mu` (nc) of a
    /// KKT solve at `t` ([`Analysis::check_grip`]).
    /// Notes a skate with friction whose lateral slip velocity `G_row qd`
    /// at `(t, qd)` is not zero (beyond 1e-6 of the velocities' size, far
    /// above what a search or an integration leaves in a holding skate): it
    /// slides there ([`Analysis::check_grip`]); `g` the dense `G` (nc x nq).
    fn note_slip(&mut self, t: f64, qd: &[f64], g: &Mat<f64>) {
        if self.slid.is_some() {
            return;
        }
        let scale = qd.iter().fold(1.0f64, |m, v| m.max(v.abs()));
        for (k, fr) in self.sys.friction.iter().enumerate() {
            let slip = (0..qd.len()).map(|c| g[(fr.row, c)] * qd[c]).sum::<f64>();
            if slip.is_nan() || slip.abs() > 1e-6 * scale {
                self.slid = Some(Slide { skate: k, t, slip });
                return;
            }
        }
    }

    pub(crate) fn note_grip(&mut self, t: f64, mu: &[f64]) {
        // each skate's holding force over its limit (a NaN force first)
        let ratio = |force: f64, limit: f64| if force == 0.0 { 0.0 } else { force / limit };
        for (k, fr) in self.sys.friction.iter().enumerate() {
            if fr.mode.is_sliding() && self.slid.is_none() {
                // a run's own mode (the sensitivities integrate the run)
                self.slid = Some(Slide { skate: k, t, slip: fr.slip });
            }
            let force = mu[fr.row].abs();
            let worse = self.grip.is_none_or(|g| {
                let r = ratio(force, fr.limit);
                r.is_nan() || r > ratio(g.force, self.sys.friction[g.skate].limit)
            });
            if worse {
                self.grip = Some(Grip { skate: k, t, force });
            }
        }
    }

    /// The right-hand side analysed, to evaluate (the forward
    /// sensitivities run on it).
    pub(crate) fn dynamics_mut(&mut self) -> &mut Dynamics<M> {
        &mut self.sys
    }

    /// The exact Jacobian `A = df/dx` (2nq x 2nq) at `(t, x)` and the
    /// Jacobian `C` ((nh + nc) x 2nq) of the constraint residuals
    /// ([`Analysis::constraint_residual`]), from the KKT solution `p` at
    /// that state.
    pub(crate) fn jacobians(&mut self, t: f64, x: &[f64], p: &Point) -> Result<(Mat<f64>, Mat<f64>), AnalysisError> {
        let dforces = self.force_jacobian(t, x)?;
        let info = &self.sys.info;
        let (nq, nh, nc) = (self.nq(), info.n_holonomic, info.nc());
        let n2 = 2 * nq;
        let (q, qd) = (&x[..nq], &x[nq..n2]);
        let nnz = info.pattern.len();
        let mut rhs = Mat::<f64>::zeros(nq + nc, n2);
        let mut c = Mat::<f64>::zeros(nh + nc, n2);
        let mut qdual: Vec<Dual64> = q.iter().map(|&v| Dual64::from(v)).collect();
        let mut qddual: Vec<Dual64> = qd.iter().map(|&v| Dual64::from(v)).collect();
        let (mut gv, mut gm) = (vec![Dual64::from(0.0); nnz], vec![Dual64::from(0.0); nc]);
        for j in 0..n2 {
            let seed = |v: &mut [Dual64], k: usize, on: bool| v[k].eps = if on { 1.0 } else { 0.0 };
            if j < nq {
                seed(&mut qdual, j, true);
            } else {
                seed(&mut qddual, j - nq, true);
            }
            self.sys.model.constraint_terms(&qdual, &qddual, &mut gv, &mut gm);
            if j < nq {
                seed(&mut qdual, j, false);
            } else {
                seed(&mut qddual, j - nq, false);
            }
            // dG along direction j (zero for velocity directions), d gamma
            let mut dg = vec![0.0; nc * nq];
            for (&(r, col), v) in info.pattern.iter().zip(&gv) {
                dg[r * nq + col] = v.eps;
            }
            for i in 0..nq {
                let dgt_mu: f64 = (0..nc).map(|r| dg[r * nq + i] * p.mu[r]).sum();
                let df = dforces.as_ref().map_or(0.0, |d| d[(i, j)]);
                rhs[(i, j)] = df - dgt_mu;
            }
            for r in 0..nc {
                let dg_qdd: f64 = (0..nq).map(|k| dg[r * nq + k] * p.qdd[k]).sum();
                rhs[(nq + r, j)] = -gm[r].eps - dg_qdd;
                // velocity residual G(q) qd: d/dq = dG qd, d/dqd = G
                c[(nh + r, j)] = if j < nq { (0..nq).map(|k| dg[r * nq + k] * qd[k]).sum() } else { p.g[(r, j - nq)] };
            }
            if j < nq {
                for r in 0..nh {
                    c[(r, j)] = p.g[(r, j)];
                }
            }
        }
        let dsol = dense::solve(p.kkt.as_ref(), rhs.as_ref(), "the KKT matrix [M G^T; G 0]")?;
        let a =
            Mat::from_fn(n2, n2, |i, j| if i < nq { if j == i + nq { 1.0 } else { 0.0 } } else { dsol[(i - nq, j)] });
        Ok((a, c))
    }

    /// `dF/dx` (nq x 2nq) of the applied forces (`None` without effects:
    /// zero): each effect's exact Jacobian ([`ForceLaw::jacobian`]) where
    /// its law gives one, and the forces of the others alone by central
    /// differences ([`Analysis::difference_forces`]), their names noted
    /// ([`Analysis::differenced_laws`]).
    ///
    /// [`ForceLaw::jacobian`]: crate::effects::kind::ForceLaw::jacobian
    fn force_jacobian(&mut self, t: f64, x: &[f64]) -> Result<Option<Mat<f64>>, AnalysisError> {
        self.last_differenced = false;
        if self.sys.effects.is_empty() {
            return Ok(None);
        }
        let nq = self.nq();
        let (mut dq, mut dqd) = (vec![0.0; nq * nq], vec![0.0; nq * nq]);
        self.force_blocks(t, x, &|_| true, &mut dq, &mut dqd)?;
        Ok(Some(Mat::from_fn(nq, 2 * nq, |i, j| if j < nq { dq[i * nq + j] } else { dqd[i * nq + j - nq] })))
    }

    /// Adds `dF/dq` into `dq` and `dF/dqd` into `dqd` (nq x nq each,
    /// row-major) of the force of the effects `select` picks (by index)
    /// at `(t, x)`, as [`Analysis::force_jacobian`] takes them: exact
    /// where a law gives its Jacobian, central differences of its force
    /// alone where not (noted).
    ///
    /// # Errors
    /// [`AnalysisError::Sim`] when a differenced law fails at a state.
    pub(crate) fn force_blocks(
        &mut self,
        t: f64,
        x: &[f64],
        select: &dyn Fn(usize) -> bool,
        dq: &mut [f64],
        dqd: &mut [f64],
    ) -> Result<(), AnalysisError> {
        let nq = self.nq();
        let (q, qd) = (&x[..nq], &x[nq..2 * nq]);
        // a law of the user's own adds into blocks of its own, kept only
        // where it says it gave its Jacobian (one that wrote and then
        // returned `false` would leave part of one behind)
        let mut own: Option<(Vec<f64>, Vec<f64>)> = None;
        let mut rest = Vec::new();
        for (k, e) in self.sys.effects.iter().enumerate().filter(|(k, _)| select(*k)) {
            let wave = e.waveforms(t);
            let exact = !self.force_differences
                && if matches!(e.law, Law::User(_)) {
                    let (udq, udqd) = own.get_or_insert_with(|| (vec![0.0; nq * nq], vec![0.0; nq * nq]));
                    udq.fill(0.0);
                    udqd.fill(0.0);
                    let exact = e.jacobian(t, &wave, q, qd, udq, udqd);
                    if exact {
                        dq.iter_mut().zip(udq.iter()).for_each(|(d, u)| *d += u);
                        dqd.iter_mut().zip(udqd.iter()).for_each(|(d, u)| *d += u);
                    }
                    exact
                } else {
                    e.jacobian(t, &wave, q, qd, dq, dqd)
                };
            if !exact {
                rest.push((k, wave));
            }
        }
        if !rest.is_empty() {
            self.last_differenced = true;
            if !self.force_differences {
                for (k, _) in &rest {
                    let name = &self.sys.effects[*k].name;
                    if !self.differenced.contains(name) {
                        self.differenced.push(name.clone());
                    }
                }
            }
            self.difference_forces(t, x, &rest, dq, dqd)?;
        }
        Ok(())
    }

    /// Adds the central differences of the force of the effects `which`
    /// (each an index into the effects with its waveforms at `t`) alone at
    /// `(t, x)` into `dq = dF/dq` and `dqd = dF/dqd` (nq x nq each,
    /// row-major): step `eps^(1/3) max(1, |x_j|)` in each of the 2 nq
    /// components, error about 1e-10 relative (Nocedal & Wright,
    /// *Numerical Optimization*, 2nd ed., §8.1).
    fn difference_forces(
        &self,
        t: f64,
        x: &[f64],
        which: &[(usize, Waveforms)],
        dq: &mut [f64],
        dqd: &mut [f64],
    ) -> Result<(), AnalysisError> {
        let nq = self.nq();
        let mut xp = x[..2 * nq].to_vec();
        let (mut fp, mut fm) = (vec![0.0; nq], vec![0.0; nq]);
        for j in 0..2 * nq {
            let h = f64::EPSILON.cbrt() * x[j].abs().max(1.0);
            xp[j] = x[j] + h;
            self.forces_of(t, &xp, which, &mut fp)?;
            xp[j] = x[j] - h;
            self.forces_of(t, &xp, which, &mut fm)?;
            xp[j] = x[j];
            let (block, col) = if j < nq { (&mut *dq, j) } else { (&mut *dqd, j - nq) };
            for i in 0..nq {
                block[i * nq + col] += (fp[i] - fm[i]) / (2.0 * h);
            }
        }
        Ok(())
    }

    /// The generalized force `f` (nq) of the effects `which` (as in
    /// [`Analysis::difference_forces`]) alone at `(t, x)`, added in the
    /// order the right-hand side adds them.
    pub(crate) fn forces_of(
        &self,
        t: f64,
        x: &[f64],
        which: &[(usize, Waveforms)],
        f: &mut [f64],
    ) -> Result<(), SimError> {
        let nq = f.len();
        f.fill(0.0);
        let mut power = [0.0];
        for (k, wave) in which {
            let (e, w) = (std::slice::from_ref(&self.sys.effects[*k]), std::slice::from_ref(wave));
            apply_effects(e, w, t, &x[..nq], &x[nq..2 * nq], f, &mut power)?;
        }
        Ok(())
    }
}
