//! The right-hand side of the index-1 DAE as a first-order ODE.
//!
//! State layout `y = [q (nq), qd (nq), W_1 .. W_k]` with `W_e` \[J\] the
//! work of effect `e`, integrated as a state (`W_e' = P_e`, its power) so
//! that the energy balance `T - T0 = sum W_e` holds to the integrator's
//! accuracy for any combination of effects (docs/physics.md §8; a Riemann
//! sum of the power would not). `y' = [qd, qdd, P_1 .. P_k]` with `qdd` from
//! the KKT system (docs/physics.md §5). A scene without effects has no work
//! states.

use crate::effects::Effect;
use crate::effects::law::{Law, apply_effects, hinges_only};
use crate::effects::skate_friction::SkateFrictionLaw;
use crate::error::SetupError;
use crate::error::SimError;
use crate::formulation::friction::{Released, SkateFriction, SkateMode, row_entries};
use crate::kkt::{AnyKktSolver, KktMethod, KktSolver, KktSystem};
use crate::model::info::ModelInfo;
use crate::model::{MinimalCall, Model};
use crate::names::{velocity_name, work_name};

/// Counters of the work done, for reports and benchmarks.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Counters {
    /// Right-hand-side evaluations.
    pub rhs_evals: u64,
    /// KKT solves (one per right-hand side here).
    pub kkt_solves: u64,
    /// KKT solves that found `G` rank-deficient and solved the
    /// regularized system ([`crate::kkt::KktSolver::was_singular`]): a
    /// singular position passed.
    pub singular_solves: u64,
}

/// Scratch space of the right-hand side, grouped by stage (MuJoCo mjData).
#[derive(Debug, Clone)]
struct Workspace {
    /// `G` values at the pattern entries (nnz).
    g_values: Vec<f64>,
    /// `G` dense row-major (nc x nq), only for the dense LU path (empty
    /// otherwise); entries outside the pattern stay 0.
    g: Vec<f64>,
    /// `gamma` (nc) \[m/s^2\].
    gamma: Vec<f64>,
    /// Generalized applied force (nq) \[N, N m\].
    f: Vec<f64>,
    /// Accelerations (nq).
    qdd: Vec<f64>,
    /// Multipliers (nc) \[N\].
    lambda: Vec<f64>,
    /// `u'(t)` of each drive at the last evaluation.
    drive_rates: Vec<f64>,
    /// The time of `waves` and `drive_waves` (NaN: none yet).
    wave_t: f64,
    /// Each effect's waveforms at `wave_t` ([`crate::effects::kind::Waveforms`]).
    waves: Vec<crate::effects::kind::Waveforms>,
    /// Each drive's `[u, u', u'']` at `wave_t`.
    drive_waves: Vec<[f64; 3]>,
    /// Baumgarte scratch: `G qd` (nc), `phi` (nh), unit weights (nq).
    gqd: Vec<f64>,
    phi: Vec<f64>,
    ones: Vec<f64>,
    /// The released rows' entries of `G` before they were zeroed (nnz,
    /// only with skates that have friction).
    g_saved: Vec<f64>,
    /// A right-hand side's scratch (ny, only with skates that have
    /// friction): evaluations for their modes.
    probe: Vec<f64>,
    /// A state a little further along the motion, and its right-hand
    /// side (ny each): the sticking skates' margin rates.
    ahead: Vec<f64>,
    ahead_rhs: Vec<f64>,
}

/// Baumgarte stabilization (Baumgarte 1972): the acceleration-level
/// constraints become `G qdd + gamma + 2 alpha G qd + beta^2 [C; 0] = 0`, so
/// a violation decays like a damped oscillator instead of drifting. `alpha`
/// \[1/s\] damps the velocity residual of every row, `beta` \[1/s\] pulls the
/// holonomic rows back to `C = 0`. The classic alternative to projection:
/// cheaper per step, but the residual stays at a level set by the step
/// size and `alpha`, `beta` rather than at rounding.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Baumgarte {
    /// Damping of `G qd` \[1/s\].
    pub alpha: f64,
    /// Stiffness of `C(q)` \[1/s\].
    pub beta: f64,
}

/// A model with its applied forces and KKT solver: `y' = F(t, y)`.
#[derive(Debug)]
pub struct Dynamics<M: Model> {
    /// The model (parameters fixed for the run).
    pub model: M,
    /// Its sizes, names and pattern of `G` (from [`Model::info`]).
    pub info: ModelInfo,
    /// Applied forces, exactly those the scene lists (changed in place
    /// between evaluations: see [`Dynamics::forget_waveforms`]).
    pub effects: Vec<Effect>,
    /// Drives (prescribed hinge angles), one per drive of the model; set
    /// with [`Dynamics::with_drives`]. Their work states follow the effects'.
    pub drives: Vec<crate::drive::Drive>,
    /// Mass-matrix diagonal (nq) \[kg, kg m^2\].
    pub mass: Vec<f64>,
    /// Work counters.
    pub counters: Counters,
    kkt: AnyKktSolver<M>,
    ws: Workspace,
    /// Optional Baumgarte stabilization of the constraints.
    pub baumgarte: Option<Baumgarte>,
    /// The events a run locates, records or stops at ([`crate::events`]);
    /// set with [`Dynamics::with_events`].
    pub events: Vec<crate::events::spec::Event>,
    /// The first `(t [s], estimate)` at which the KKT conditioning estimate
    /// passed [`CONDITION_WARNING`] (recorded once).
    pub ill_conditioned: Option<(f64, f64)>,
    /// The time \[s\] of the last KKT solve that found `G` rank-deficient
    /// (see [`Counters::singular_solves`]; NaN: none yet).
    pub last_singular: f64,
    /// The largest KKT conditioning estimate (pivot growth, infinite for a
    /// singular solve) since the caller last reset it: above
    /// [`NEAR_SINGULAR`] the state is close to a singular position.
    pub max_growth: f64,
    /// The KKT conditioning estimate of the last evaluation.
    pub last_growth: f64,
    /// The skates with Coulomb friction and their modes
    /// ([`crate::formulation::friction`]), one per effect of kind `skate-friction`.
    pub friction: Vec<SkateFriction>,
    /// The rows of the sliding skates, taken out of the KKT system.
    released: Released,
}

/// The most skates with friction whose modes
/// [`Dynamics::settle_friction`] decides together at one instant: up to
/// `3^MAX_ENUMERATED` assignments (each sticks or slides either way),
/// tried by the number sliding, so usually a handful.
pub const MAX_ENUMERATED: usize = 8;

/// The `k`-element subsets of `0..m`, in lexicographic order.
fn subsets(m: usize, k: usize) -> Vec<Vec<usize>> {
    let mut out = Vec::new();
    let mut cur: Vec<usize> = (0..k).collect();
    if k > m {
        return out;
    }
    loop {
        out.push(cur.clone());
        // the rightmost index that can move on
        let Some(i) = (0..k).rev().find(|&i| cur[i] < m - k + i) else { return out };
        cur[i] += 1;
        for j in i + 1..k {
            cur[j] = cur[j - 1] + 1;
        }
    }
}

/// KKT conditioning estimate (pivot growth of the Schur complement, which
/// grows like `1 / s^2` at a distance `s` from a singular position) above
/// which a run treats the state as near a singular position: the
/// projection refines its positions to rounding and the adaptive step's
/// error estimate counts only its part tangent to the constraints (see
/// `simulate`). Measured over the first second of every built-in scene:
/// at most 1.1e2 away from singular positions; the N-four-bars reach 1e5
/// (N = 2) and 9e6 (N = 40) at their passages.
pub const NEAR_SINGULAR: f64 = 1e3;

/// Threshold of the (equilibrated) KKT conditioning estimate above which a
/// run warns: about 1e-6 relative accuracy is left in the multipliers and
/// accelerations. Near-dependent constraints (almost aligned skates) reach
/// it; mass ratios do not (the estimate is scale-independent).
pub const CONDITION_WARNING: f64 = 1e10;

impl<M: Model> Dynamics<M> {
    /// Number of coordinates nq.
    pub fn nq(&self) -> usize {
        self.mass.len()
    }

    /// Length of the state vector `y`: 2 nq + number of effects + number
    /// of drives.
    pub fn ny(&self) -> usize {
        2 * self.nq() + self.effects.len() + self.drives.len()
    }

    /// Total work of the effects `sum W_e` \[J\] in the state `y`.
    pub fn work(&self, y: &[f64]) -> f64 {
        y[2 * self.nq()..].iter().sum()
    }

    /// Names of all state components of `y` ([`state_names`]).
    pub fn state_names(&self) -> Vec<String> {
        state_names(&self.info.coords, &self.effects, &self.drives)
    }

    /// Name of state component `k` of `y` ([`state_names`]).
    pub fn state_name(&self, k: usize) -> String {
        let coords = &self.info.coords;
        let nq = self.nq();
        if k < nq {
            coords[k].to_string()
        } else if k < 2 * nq {
            velocity_name(&coords[k - nq])
        } else if k < 2 * nq + self.effects.len() {
            self.effects[k - 2 * nq].work_column()
        } else {
            work_name(&self.drives[k - 2 * nq - self.effects.len()].name)
        }
    }

    /// Builds the right-hand side; `method` picks the KKT path.
    pub fn new(model: M, effects: Vec<Effect>, method: KktMethod) -> Self {
        let info = model.info();
        let (nq, nc) = (info.nq(), info.nc());
        let mut mass = vec![0.0; nq];
        model.mass_diagonal(&mut mass);
        let kkt = AnyKktSolver::new(&model, &info, method, &mass);
        let dense = if kkt.needs_dense_g() { nc * nq } else { 0 };
        let friction = friction_table(&info, &effects);
        let ws = Workspace {
            g_values: vec![0.0; info.pattern.len()],
            g: vec![0.0; dense],
            gamma: vec![0.0; nc],
            f: vec![0.0; nq],
            qdd: vec![0.0; nq],
            lambda: vec![0.0; nc],
            gqd: vec![0.0; nc],
            phi: vec![0.0; info.n_holonomic],
            ones: vec![1.0; nq],
            drive_rates: Vec::new(),
            wave_t: f64::NAN,
            waves: vec![[0.0; 3]; effects.len()],
            drive_waves: Vec::new(),
            g_saved: if friction.is_empty() { Vec::new() } else { vec![0.0; info.pattern.len()] },
            probe: Vec::new(),
            ahead: Vec::new(),
            ahead_rhs: Vec::new(),
        };
        Self {
            model,
            info,
            effects,
            drives: Vec::new(),
            mass,
            counters: Counters::default(),
            kkt,
            ws,
            baumgarte: None,
            events: Vec::new(),
            ill_conditioned: None,
            last_singular: f64::NAN,
            max_growth: 0.0,
            last_growth: 0.0,
            friction,
            released: Released::default(),
        }
    }

    /// Sets the drives (prescribed hinge angles; see [`crate::drive`]).
    pub fn with_drives(mut self, drives: Vec<crate::drive::Drive>) -> Self {
        self.ws.drive_rates = vec![0.0; drives.len()];
        self.ws.drive_waves = vec![[0.0; 3]; drives.len()];
        self.ws.wave_t = f64::NAN;
        self.drives = drives;
        self
    }

    /// Sets the events a run watches ([`crate::events`]).
    pub fn with_events(mut self, events: Vec<crate::events::spec::Event>) -> Self {
        self.events = events;
        self
    }

    /// Forgets the waveform values kept from the last evaluation (the
    /// right-hand side reuses them while `t` repeats): needed only after
    /// changing [`Dynamics::effects`] or [`Dynamics::drives`] in place
    /// between two evaluations at one time. [`crate::simulate()`] calls it.
    pub fn forget_waveforms(&mut self) {
        self.ws.wave_t = f64::NAN;
    }

    /// The KKT path's conditioning estimate of the last solve (see
    /// [`crate::kkt::KktSolver::condition_estimate`]).
    pub fn condition_estimate(&self) -> Option<f64> {
        self.kkt.condition_estimate()
    }

    /// A run's failure `e` with its likely cause named: a force law faster
    /// than the run `settings` can follow ([`SimError::with_fast_law`]), a
    /// massless part or masses spread too far ([`SimError::with_cause`]).
    pub fn explain(&self, e: SimError, settings: &crate::settings::RunSettings) -> SimError {
        e.with_fast_law(&self.effects, &self.mass, settings).with_cause(&self.mass, |k| self.info.mass_entry_name(k))
    }

    /// Name of the KKT path in use.
    pub fn kkt_name(&self) -> &'static str {
        self.kkt.name()
    }

    /// Evaluates `dy = F(t, y)` (both of length [`Dynamics::ny`]).
    ///
    /// # Errors
    /// [`SimError::Kkt`] if the KKT system is singular at this state.
    #[inline]
    pub fn rhs(&mut self, t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SimError> {
        let nq = self.nq();
        let (q, rest) = y.split_at(nq);
        let qd = &rest[..nq];
        let ws = &mut self.ws;
        self.model.constraint_terms(q, qd, &mut ws.g_values, &mut ws.gamma);
        if !self.friction.is_empty() {
            release_sliding(&mut self.friction, &self.info.pattern, qd, ws);
        }
        if self.kkt.needs_dense_g() {
            for (&(r, c), &v) in self.info.pattern.iter().zip(&ws.g_values) {
                ws.g[r * nq + c] = v;
            }
        }
        self.refresh_waveforms(t);
        let ws = &mut self.ws;
        for ((d, rate), w) in self.drives.iter().zip(&mut ws.drive_rates).zip(&ws.drive_waves) {
            ws.gamma[d.row] -= w[2];
            *rate = w[1];
        }
        if let Some(Baumgarte { alpha, beta }) = self.baumgarte {
            self.model.g_winv_mul(&self.info.pattern, &ws.g_values, &ws.ones, qd, &mut ws.gqd);
            self.model.phi(q, &mut ws.phi);
            for (d, rate) in self.drives.iter().zip(&ws.drive_rates) {
                ws.gqd[d.row] -= rate;
            }
            crate::drive::shift_positions(&self.drives, t, &mut ws.phi);
            for (g, v) in ws.gamma.iter_mut().zip(&ws.gqd) {
                *g += 2.0 * alpha * v;
            }
            for (g, c) in ws.gamma.iter_mut().zip(&ws.phi) {
                *g += beta * beta * c;
            }
        }
        let (dq, rest) = dy.split_at_mut(nq);
        let (dqd, power) = rest.split_at_mut(nq);
        let (power, drive_power) = power.split_at_mut(self.effects.len());
        self.effect_forces(t, q, qd, power)?;
        let ws = &mut self.ws;
        if !self.friction.is_empty() {
            friction_forces(&self.friction, &self.info.pattern, ws, power);
        }
        let sys = KktSystem {
            mass: &self.mass,
            g: &ws.g,
            g_values: &ws.g_values,
            f: &ws.f,
            gamma: &ws.gamma,
            released: self.released.rows(),
        };
        self.kkt
            .solve(&sys, &mut ws.qdd, &mut ws.lambda)
            .map_err(|source| SimError::from_kkt(&self.info, t, source))?;
        for fr in &mut self.friction {
            if fr.mode.is_sliding() {
                ws.lambda[fr.row] = fr.sliding_lambda();
            }
            let pattern = &self.info.pattern;
            fr.slip_rate = fr.entries.clone().map(|e| ws.g_saved[e] * ws.qdd[pattern[e].1]).sum::<f64>() + fr.gamma;
        }
        let growth = if self.kkt.was_singular() { f64::INFINITY } else { self.kkt.condition_estimate().unwrap_or(1.0) };
        self.max_growth = self.max_growth.max(growth);
        self.last_growth = growth;
        if self.kkt.was_singular() {
            note_singular(&mut self.counters, &mut self.last_singular, t);
        } else if self.ill_conditioned.is_none()
            && let Some(c) = self.kkt.condition_estimate()
            && c > CONDITION_WARNING
        {
            self.ill_conditioned = Some((t, c));
        }
        self.counters.rhs_evals += 1;
        self.counters.kkt_solves += 1;
        dq.copy_from_slice(qd);
        dqd.copy_from_slice(&ws.qdd);
        // a drive's torque is -lambda_row; its power tau u'(t)
        for ((d, rate), p) in self.drives.iter().zip(&ws.drive_rates).zip(drive_power) {
            *p = -ws.lambda[d.row] * rate;
        }
        Ok(())
    }

    /// Each effect's and drive's waveforms at `t`, kept while `t` repeats
    /// (stages often share one: RK4's midpoints, a step's end and the next
    /// step's start); effects or drives replaced in place are noticed by
    /// their count (or by [`Dynamics::forget_waveforms`]).
    #[inline(always)]
    fn refresh_waveforms(&mut self, t: f64) {
        let ws = &mut self.ws;
        if ws.waves.len() != self.effects.len() || ws.drive_waves.len() != self.drives.len() {
            // cold: once
            ws.waves = vec![[f64::NAN; 3]; self.effects.len()];
            ws.drive_waves = vec![[f64::NAN; 3]; self.drives.len()];
            ws.drive_rates = vec![0.0; self.drives.len()];
            ws.wave_t = f64::NAN;
        }
        if t.to_bits() == ws.wave_t.to_bits() {
            return;
        }
        for (d, w) in self.drives.iter().zip(&mut ws.drive_waves) {
            *w = d.angle.eval3(t);
        }
        for (e, w) in self.effects.iter().zip(&mut ws.waves) {
            *w = e.waveforms(t);
        }
        ws.wave_t = t;
    }

    /// [`Dynamics::refresh_waveforms`] as a call of its own, for
    /// [`Dynamics::minimal_rhs`], which is inlined into the reduced
    /// formulation's evaluation.
    #[inline(never)]
    fn refresh_waveforms_outlined(&mut self, t: f64) {
        self.refresh_waveforms(t);
    }

    /// The effects' generalized force into the workspace's `f` (nq), each
    /// effect's power into `power`, from the waveforms at `t`.
    #[inline(always)]
    fn effect_forces(&mut self, t: f64, q: &[f64], qd: &[f64], power: &mut [f64]) -> Result<(), SimError> {
        // `f` is only ever written here: without effects it stays zero and
        // is not touched (the `free` scene pays nothing for the library).
        if self.effects.is_empty() {
            return Ok(());
        }
        let ws = &mut self.ws;
        ws.f.fill(0.0);
        apply_effects(&self.effects, &ws.waves, t, q, qd, &mut ws.f, power)
    }

    /// Whether every effect is a hinge law (or there is none): the fused
    /// right-hand side then takes them as the hinges' torques
    /// ([`Dynamics::minimal_rhs`]).
    pub(crate) fn hinges_only(&self) -> bool {
        hinges_only(&self.effects)
    }

    /// The right-hand side on the model's minimal coordinates in one pass
    /// ([`Model::minimal_rhs`] with the constants `k` of
    /// [`Model::minimal_constants`]): from the reduced state `z = [p, u,
    /// W]` at `t`, the full `q, qd` into `y[..2 nq]` (the work states
    /// untouched) and `dz = [pd, u', P]` (the effects' powers last). With
    /// `lean` (a stage, whose full state no one reads), `y` may keep only
    /// the headings ([`Model::minimal_rhs_lean`]). `hinges_only`: every
    /// effect is a hinge law, or there is none ([`Dynamics::hinges_only`],
    /// asked once by the caller: a run switches its effects on and off,
    /// never changes their laws).
    ///
    /// # Errors
    /// [`SimError::EffectFailed`] if an effect gives no force at a finite
    /// state; [`SimError::Formulation`] if Maggi's `B^T M B` cannot be
    /// factored.
    #[expect(
        clippy::too_many_arguments,
        reason = "a stage's evaluation takes its state as flat borrowed slices: no struct is built per call"
    )]
    #[inline(always)]
    pub(crate) fn minimal_rhs(
        &mut self,
        t: f64,
        k: &[f64],
        z: &[f64],
        y: &mut [f64],
        dz: &mut [f64],
        lean: bool,
        hinges_only: bool,
    ) -> Result<(), SimError> {
        let nq = self.nq();
        // a scene whose effects are all hinge torques (or none) hands them
        // over as such (`waves` empty): see `Model::minimal_rhs_effects`
        if !hinges_only {
            self.refresh_waveforms_outlined(t);
        }
        let waves: &[crate::effects::kind::Waveforms] = if hinges_only { &[] } else { &self.ws.waves };
        let mut call = MinimalCall { t, k, z, y: &mut y[..2 * nq], dz, effects: &self.effects, waves, lean };
        self.model.minimal_rhs_effects(&mut call).map_err(|e| minimal_rhs_failed(t, e))
    }

    /// Computes the generalized applied force `f` (nq) \[N, N m\] of the effects at
    /// `(t, q, qd)` (nq each), with each effect's power \[W\] written to
    /// `power` (one per effect): the right-hand side's forces without the
    /// KKT solve, for formulations that project them themselves
    /// ([`crate::formulation::reduced`]'s minimal coordinates); read it with
    /// [`Dynamics::applied_force`].
    ///
    /// # Errors
    /// [`SimError::EffectFailed`] if an effect gives no force at a finite state.
    #[inline]
    pub fn applied_forces(&mut self, t: f64, q: &[f64], qd: &[f64], power: &mut [f64]) -> Result<(), SimError> {
        self.refresh_waveforms(t);
        self.effect_forces(t, q, qd, power)
    }

    /// The effects' waveforms' values (one per effect) at the time of the
    /// last [`Dynamics::rhs`] or [`Dynamics::applied_forces`] call.
    pub(crate) fn waves(&self) -> &[crate::effects::kind::Waveforms] {
        &self.ws.waves
    }

    /// The generalized applied force `f` (nq) \[N, N m\] of the last
    /// [`Dynamics::rhs`] or [`Dynamics::applied_forces`] call (zero without
    /// effects).
    pub fn applied_force(&self) -> &[f64] {
        &self.ws.f
    }

    /// Solves the KKT system of the last [`Dynamics::rhs`] call (its `G`,
    /// its released rows) with another right-hand side `[f; -gamma]`
    /// (nq, nc) into `qdd` (nq) and `lambda` (nc): what the forward
    /// sensitivities ([`crate::sensitivity`]) solve for each parameter.
    ///
    /// # Errors
    /// [`SimError::Kkt`] when the system is singular.
    pub fn solve_kkt_again(
        &mut self,
        t: f64,
        f: &[f64],
        gamma: &[f64],
        qdd: &mut [f64],
        lambda: &mut [f64],
    ) -> Result<(), SimError> {
        let ws = &self.ws;
        let sys =
            KktSystem { mass: &self.mass, g: &ws.g, g_values: &ws.g_values, f, gamma, released: self.released.rows() };
        self.kkt.solve(&sys, qdd, lambda).map_err(|source| SimError::from_kkt(&self.info, t, source))
    }

    /// Constraint forces `lambda` (nc) \[N\] of the last [`Dynamics::rhs`] call.
    pub fn lambda(&self) -> &[f64] {
        &self.ws.lambda
    }

    /// Kinetic energy `T = qd^T M qd / 2` \[J\].
    pub fn kinetic_energy(&self, qd: &[f64]) -> f64 {
        0.5 * self.mass.iter().zip(qd).map(|(m, v)| m * v * v).sum::<f64>()
    }
    /// The constraint rows released by sliding skates (taken out of the
    /// KKT system and the velocity projection; [`crate::formulation::friction`]).
    pub fn released_rows(&self) -> &[usize] {
        self.released.rows()
    }

    /// Sets the mode of skate-friction entry `k` of [`Dynamics::friction`]
    /// (and the released rows with it).
    pub fn set_skate_mode(&mut self, k: usize, mode: SkateMode) {
        self.friction[k].mode = mode;
        self.refresh_released();
    }

    /// The released rows from the skates' modes.
    fn refresh_released(&mut self) {
        let rows: Vec<usize> = self.friction.iter().filter(|f| f.mode.is_sliding()).map(|f| f.row).collect();
        self.released.set(&self.info.pattern, &rows);
    }

    /// The index in [`Dynamics::effects`] of the effect named `name`.
    pub fn effect_index(&self, name: &str) -> Option<usize> {
        self.effects.iter().position(|e| e.name == name)
    }

    /// Whether the run's set of forces or rows can change at an instant:
    /// skates with friction, or events that switch effects
    /// ([`crate::events::spec::Action::Switch`]). Such a run cuts its steps
    /// there and restarts: explicit methods on the DAE formulation.
    pub fn switches(&self) -> bool {
        !self.friction.is_empty() || self.events.iter().any(|e| e.action == crate::events::spec::Action::Switch)
    }

    /// Each skate-friction entry's margin ([`SkateFriction::margin`]) at
    /// the state of the last [`Dynamics::rhs`] call, into `out` (one per
    /// entry of [`Dynamics::friction`]).
    pub fn slip_margins(&self, out: &mut [f64]) {
        for (o, fr) in out.iter_mut().zip(&self.friction) {
            *o = fr.margin(self.ws.lambda[fr.row]);
        }
    }

    /// Each skate-friction entry's slip velocity `v = G_row qd` \[m/s\] at
    /// `(t, y)` and the rate `mu N (G_row M^-1 G_row^T) / |v|` \[1/s\] at
    /// which its friction, were it sliding, stops that slip (its limit
    /// over the slip's momentum on the skate's row alone: the others only
    /// make it slower), one pair per entry of [`Dynamics::friction`].
    ///
    /// # Errors
    /// As [`Dynamics::rhs`].
    pub fn slide_rates_at(&mut self, t: f64, y: &[f64]) -> Result<Vec<(f64, f64)>, SimError> {
        let mut probe = std::mem::take(&mut self.ws.probe);
        probe.resize(y.len(), 0.0);
        let res = self.rhs(t, y, &mut probe);
        self.ws.probe = probe;
        res?;
        let (pattern, g, mass) = (&self.info.pattern, &self.ws.g_saved, &self.mass);
        let inv = |e: usize| if mass[pattern[e].1] > 0.0 { g[e] * g[e] / mass[pattern[e].1] } else { 0.0 };
        Ok(self
            .friction
            .iter()
            .map(|fr| (fr.slip, fr.limit * fr.entries.clone().map(inv).sum::<f64>() / fr.slip.abs()))
            .collect())
    }

    /// Evaluates the right-hand side at `(t, y)` (into a scratch of its
    /// own) and writes the skates' margins into `out`
    /// ([`Dynamics::slip_margins`]).
    ///
    /// # Errors
    /// As [`Dynamics::rhs`].
    pub fn slip_margins_at(&mut self, t: f64, y: &[f64], out: &mut [f64]) -> Result<(), SimError> {
        let mut probe = std::mem::take(&mut self.ws.probe);
        probe.resize(y.len(), 0.0);
        let res = self.rhs(t, y, &mut probe);
        self.ws.probe = probe;
        res?;
        self.slip_margins(out);
        Ok(())
    }

    /// Each skate-friction entry's margin and its rate along the motion at
    /// `(t, y)`, into `m` and `r` (one per entry of
    /// [`Dynamics::friction`]): a sliding skate's rate is `s dv/dt` from
    /// the evaluation itself; a sticking one's, `d(mu N - |lambda|)/dt`,
    /// by a forward difference along the motion, the right-hand side
    /// evaluated again at `(t + delta, y + delta y')` with `delta = 1e-6
    /// h` (at least a few units of rounding of `t`): its truncation,
    /// `delta m''/2`, and its rounding, `eps |lambda| / delta`, both far
    /// below what a step of size `h` \[s\] resolves. One evaluation, two
    /// while a skate sticks.
    ///
    /// # Errors
    /// As [`Dynamics::rhs`].
    pub fn slip_samples_at(&mut self, t: f64, h: f64, y: &[f64], m: &mut [f64], r: &mut [f64]) -> Result<(), SimError> {
        let mut probe = std::mem::take(&mut self.ws.probe);
        probe.resize(y.len(), 0.0);
        let res = self.rhs(t, y, &mut probe).and_then(|()| self.slip_samples_after(t, h, y, &probe, m, r));
        self.ws.probe = probe;
        res
    }

    /// [`Dynamics::slip_samples_at`] right after [`Dynamics::rhs`] was
    /// evaluated at `(t, y)` with the result `dy` (ny): that evaluation
    /// not repeated.
    ///
    /// # Errors
    /// As [`Dynamics::rhs`].
    pub fn slip_samples_after(
        &mut self,
        t: f64,
        h: f64,
        y: &[f64],
        dy: &[f64],
        m: &mut [f64],
        r: &mut [f64],
    ) -> Result<(), SimError> {
        self.slip_margins(m);
        for (rate, fr) in r.iter_mut().zip(&self.friction) {
            *rate = match fr.mode {
                SkateMode::Sliding { sign } => sign * fr.slip_rate,
                SkateMode::Sticking => 0.0,
            };
        }
        if self.friction.iter().any(|f| !f.mode.is_sliding()) {
            let delta = (1e-6 * h.abs()).max(64.0 * f64::EPSILON * t.abs().max(1.0));
            let (mut ahead, mut ahead_rhs) =
                (std::mem::take(&mut self.ws.ahead), std::mem::take(&mut self.ws.ahead_rhs));
            ahead.clear();
            ahead.extend(y.iter().zip(dy).map(|(y, d)| y + delta * d));
            ahead_rhs.resize(y.len(), 0.0);
            let res = self.rhs(t + delta, &ahead, &mut ahead_rhs);
            (self.ws.ahead, self.ws.ahead_rhs) = (ahead, ahead_rhs);
            res?;
            for ((rate, fr), &m0) in r.iter_mut().zip(&self.friction).zip(m.iter()) {
                if !fr.mode.is_sliding() {
                    *rate = (fr.margin(self.ws.lambda[fr.row]) - m0) / delta;
                }
            }
        }
        Ok(())
    }

    /// The smallest margin that counts as a violation of each skate's
    /// mode at the state of the last evaluation, into `out`, for a run
    /// whose continuous extension is accurate to the relative tolerance
    /// `rtol` (an adaptive method's; 0 for a fixed step): `r mu N` \[N\]
    /// while sticking, `r max(1, |qd|)` \[m/s\] while sliding (as
    /// [`Dynamics::start_friction`] tells a slip from rounding), `r =
    /// max(1e-10, rtol)`. A margin that starts at zero (a slide begun at
    /// the limit) dips by the interpolant's error on the first step, which
    /// is no switch.
    pub fn slip_tolerances(&self, qd: &[f64], rtol: f64, out: &mut [f64]) {
        let r = rtol.max(1e-10);
        let v = r * crate::formulation::projection::max_abs(qd).max(1.0);
        for (o, fr) in out.iter_mut().zip(&self.friction) {
            *o = if fr.mode.is_sliding() { v } else { r * fr.limit.abs() };
        }
    }

    /// Brings the skates with friction into the modes their state at `(t,
    /// y)` calls for (module docs of [`crate::formulation::friction`]). The skates
    /// whose mode no longer holds (a margin at or below zero: a sticking
    /// one at its limit, a sliding one whose slip reached zero) are
    /// *undetermined*; the first consistent assignment of them is taken,
    /// with as few sliding as can be: each sticking skate needs `|lambda|
    /// < mu N` (its force within the limit), each undetermined sliding one
    /// the rate of its slip in its direction (`s dv/dt >= 0`). The
    /// assignments are tried by the number of sliding skates, then in
    /// order; a sticking skate that every assignment pushes past its limit
    /// joins the undetermined, up to [`MAX_ENUMERATED`]. (The planar multi-contact Coulomb problem as a
    /// linear complementarity problem solved by enumeration: Pfeiffer &
    /// Glocker 1996, ch. 6; Stewart 2000 §3.) Returns the switches,
    /// `(entry, old mode, new mode)`.
    ///
    /// # Errors
    /// As [`Dynamics::rhs`]; [`SimError::SlipChattering`] (the skates'
    /// names) when no assignment is consistent.
    pub fn settle_friction(&mut self, t: f64, y: &[f64]) -> Result<Vec<(usize, SkateMode, SkateMode)>, SimError> {
        let n = self.friction.len();
        let mut margins = vec![0.0; n];
        self.slip_margins_at(t, y, &mut margins)?;
        let old: Vec<SkateMode> = self.friction.iter().map(|f| f.mode).collect();
        // undetermined: those whose mode no longer holds; a sticking skate
        // pushed past its limit by another's switch joins them
        let mut free: Vec<usize> = (0..n).filter(|&k| margins[k] <= 0.0).collect();
        if free.is_empty() {
            return Ok(Vec::new());
        }
        // a slide that begins at the limit itself starts with a slip rate
        // of zero, up to rounding (of the accelerations' size)
        let consistent = |sys: &Self, margins: &[f64], free: &[usize]| {
            let rounding = 1e-10 * (1.0 + crate::formulation::projection::max_abs(&sys.ws.qdd));
            (0..n).all(|k| match sys.friction[k].mode {
                SkateMode::Sticking => margins[k] > 0.0,
                SkateMode::Sliding { sign } => !free.contains(&k) || sign * sys.friction[k].slip_rate >= -rounding,
            })
        };
        let mut found = false;
        while !found && free.len() <= MAX_ENUMERATED {
            let m = free.len();
            let mut pushed: Vec<usize> = Vec::new();
            'search: for sliding in 0..=m {
                for subset in subsets(m, sliding) {
                    for signs in 0..1u32 << sliding {
                        for (j, &k) in free.iter().enumerate() {
                            self.friction[k].mode = match subset.iter().position(|&i| i == j) {
                                None => SkateMode::Sticking,
                                Some(i) => SkateMode::Sliding { sign: if signs >> i & 1 == 0 { 1.0 } else { -1.0 } },
                            };
                        }
                        self.refresh_released();
                        self.slip_margins_at(t, y, &mut margins)?;
                        if consistent(self, &margins, &free) {
                            found = true;
                            break 'search;
                        }
                        pushed.extend((0..n).filter(|&k| {
                            !free.contains(&k) && !self.friction[k].mode.is_sliding() && margins[k] <= 0.0
                        }));
                    }
                }
            }
            if !found {
                pushed.sort_unstable();
                pushed.dedup();
                if pushed.is_empty() {
                    break;
                }
                for &k in &free {
                    self.friction[k].mode = old[k];
                }
                free.extend(pushed);
            }
        }
        if !found {
            for (k, &mode) in old.iter().enumerate() {
                self.friction[k].mode = mode;
            }
            self.refresh_released();
            let names: Vec<String> = free.iter().map(|&k| self.friction[k].name.clone()).collect();
            return Err(SimError::SlipChattering { skate: names.join("`, `"), t0: t, t1: t, switches: 0 });
        }
        Ok((0..n).filter(|&k| self.friction[k].mode != old[k]).map(|k| (k, old[k], self.friction[k].mode)).collect())
    }

    /// The modes at the start of a run from `(t, y)`: a skate with
    /// friction whose lateral velocity is not zero (above `1e-10 max(1,
    /// |qd|)`, the initial state's rounding) slides that way, the others
    /// stick; then [`Dynamics::settle_friction`]. Returns the skates that
    /// start sliding, `(entry, Sticking, its mode)`.
    ///
    /// # Errors
    /// [`SetupError::Effect`] for a second friction effect on one skate; as
    /// [`Dynamics::settle_friction`].
    pub fn start_friction(&mut self, t: f64, y: &[f64]) -> Result<Vec<(usize, SkateMode, SkateMode)>, SimError> {
        self.friction = friction_table(&self.info, &self.effects);
        self.ws.g_saved.resize(if self.friction.is_empty() { 0 } else { self.info.pattern.len() }, 0.0);
        self.released = Released::default();
        for (i, a) in self.friction.iter().enumerate() {
            if let Some(b) = self.friction[..i].iter().find(|b| b.skate == a.skate) {
                return Err(SimError::Setup(SetupError::Effect {
                    effect: self.effects[a.effect].name.clone(),
                    field: "skate",
                    message: format!(
                        "skate `{}` already has friction (effect `{}`): one friction law per skate",
                        a.name, self.effects[b.effect].name
                    ),
                }));
            }
        }
        if self.friction.is_empty() {
            return Ok(Vec::new());
        }
        let nq = self.nq();
        let (q, qd) = (&y[..nq], &y[nq..2 * nq]);
        self.model.constraint_matrix(q, &mut self.ws.g_values);
        let tol = 1e-10 * crate::formulation::projection::max_abs(qd).max(1.0);
        for k in 0..self.friction.len() {
            let fr = &self.friction[k];
            let v: f64 = fr.entries.clone().map(|e| self.ws.g_values[e] * qd[self.info.pattern[e].1]).sum();
            if v.abs() > tol {
                self.set_skate_mode(k, SkateMode::Sliding { sign: v.signum() });
            }
        }
        self.settle_friction(t, y)?;
        // the modes it starts in, from sticking
        Ok(self
            .friction
            .iter()
            .enumerate()
            .filter(|(_, f)| f.mode.is_sliding())
            .map(|(k, f)| (k, SkateMode::Sticking, f.mode))
            .collect())
    }

    /// The lateral force on skate-friction entry `k`'s contact point
    /// \[N\] (along the blade's left normal) at the last
    /// [`Dynamics::rhs`] call: `-lambda`, the ground's reaction while it
    /// sticks, `-s mu N` while it slides.
    pub fn skate_force(&self, k: usize) -> f64 {
        -self.ws.lambda[self.friction[k].row]
    }
}

/// The skates with friction among `effects` on the model `info`, each
/// sticking ([`SkateFriction`]).
fn friction_table(info: &ModelInfo, effects: &[Effect]) -> Vec<SkateFriction> {
    effects
        .iter()
        .enumerate()
        .filter_map(|(effect, e)| match e.law {
            Law::SkateFriction(SkateFrictionLaw { skate, limit, .. }) => {
                let row = info.skates[skate].row;
                Some(SkateFriction {
                    effect,
                    skate,
                    name: info.skates[skate].name.clone(),
                    row,
                    entries: row_entries(&info.pattern, row),
                    limit,
                    mode: SkateMode::Sticking,
                    slip: 0.0,
                    slip_rate: 0.0,
                    gamma: 0.0,
                })
            }
            _ => None,
        })
        .collect()
}

/// Each skate's slip velocity `G_row qd`; the sliding ones' rows of `G`
/// saved and zeroed with their `gamma` (taken out of the KKT system).
#[inline(never)]
fn release_sliding(friction: &mut [SkateFriction], pattern: &[(usize, usize)], qd: &[f64], ws: &mut Workspace) {
    for fr in friction {
        let entries = fr.entries.clone();
        fr.slip = entries.clone().map(|e| ws.g_values[e] * qd[pattern[e].1]).sum();
        fr.gamma = ws.gamma[fr.row];
        ws.g_saved[entries.clone()].copy_from_slice(&ws.g_values[entries.clone()]);
        if fr.mode.is_sliding() {
            ws.g_values[entries].fill(0.0);
            ws.gamma[fr.row] = 0.0;
        }
    }
}

/// The sliding skates' Coulomb forces `-G_row^T s mu N` added into `f`,
/// and each friction effect's power (`-mu N |v|` sliding, 0 sticking).
#[inline(never)]
fn friction_forces(friction: &[SkateFriction], pattern: &[(usize, usize)], ws: &mut Workspace, power: &mut [f64]) {
    for fr in friction {
        let lambda = fr.sliding_lambda();
        for e in fr.entries.clone() {
            ws.f[pattern[e].1] -= ws.g_saved[e] * lambda;
        }
        power[fr.effect] = -lambda * fr.slip;
    }
}

/// Names of the state components `y = [q, qd, W_effects.., W_drives..]`
/// of a run on a model with coordinates `coords`, effects `effects` and
/// drives `drives`: `x1`, `x1d`, `W_motor` (what [`Dynamics::state_name`]
/// gives one at a time, and the columns of a [`crate::Solution`]).
pub fn state_names<S: AsRef<str>>(coords: &[S], effects: &[Effect], drives: &[crate::drive::Drive]) -> Vec<String> {
    let mut names: Vec<String> = coords.iter().map(|c| c.as_ref().to_string()).collect();
    names.extend(coords.iter().map(|c| velocity_name(c.as_ref())));
    names.extend(effects.iter().map(|e| e.work_column()));
    names.extend(drives.iter().map(|d| work_name(&d.name)));
    names
}

/// Counts a KKT solve at `t` \[s\] that found `G` rank-deficient
/// (kept out of the right-hand side's line: rare).
#[cold]
#[inline(never)]
fn note_singular(counters: &mut Counters, last: &mut f64, t: f64) {
    counters.singular_solves += 1;
    *last = t;
}

/// [`Dynamics::minimal_rhs`]'s error at `t` \[s\], out of the
/// evaluation's line.
#[cold]
#[inline(never)]
fn minimal_rhs_failed(t: f64, e: crate::model::MinimalRhsError<SimError>) -> SimError {
    match e {
        crate::model::MinimalRhsError::Forces(e) => e,
        crate::model::MinimalRhsError::Maggi(source) => SimError::Formulation {
            reason: format!(
                "at t = {} s Maggi's equations on the minimal coordinates cannot be solved: {source}",
                crate::names::fmt_value(t)
            )
            .into(),
        },
    }
}

impl<M: Model> crate::integrator::Rhs for Dynamics<M> {
    #[inline]
    fn eval(&mut self, t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SimError> {
        self.rhs(t, y, dy)
    }
}
