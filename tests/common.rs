//! Helpers shared by the integration tests.
#![allow(dead_code, reason = "each test module uses a part")]

use ezy_core::formulation::initial::InitialReport;
use ezy_core::kkt::KktMethod;
use ezy_core::{Dynamics, Model, Observer, Sample, SimError};

use ezy_scene::Scene;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

/// DOP853 at `rtol = atol = tol` with mass-weighted projection, output
/// every `every` [s] to `t_end` [s], no energy-balance guard: the tests'
/// reference runs.
pub fn dop853(t_end: f64, every: f64, tol: f64) -> ezy_core::RunSettings {
    ezy_core::RunSettings {
        dt: 1e-3,
        t_end,
        every,
        projection: ezy_core::ProjectionKind::MassWeighted,
        method: ezy_core::Method::Dop853,
        formulation: ezy_core::Formulation::Dae,
        rtol: tol,
        atol: tol,
        balance_limit: None,
        max_steps: None,
    }
}

/// A deterministic random generator for a test.
pub fn rng(seed: u64) -> StdRng {
    StdRng::seed_from_u64(seed)
}

/// A random state: positions in [-2, 2] m, angles in [-pi, pi], velocities in [-2, 2].
pub fn random_state<M: Model + Default>(rng: &mut StdRng) -> (Vec<f64>, Vec<f64>) {
    random_state_n(M::default().info().nq(), rng)
}

/// A random state of `nq` coordinates, as [`random_state`].
pub fn random_state_n(nq: usize, rng: &mut StdRng) -> (Vec<f64>, Vec<f64>) {
    let q = (0..nq).map(|_| rng.random_range(-2.0..2.0) * 1.6).collect();
    let qd = (0..nq).map(|_| rng.random_range(-2.0..2.0)).collect();
    (q, qd)
}

/// The default model with every real parameter scaled by a random factor
/// in [0.5, 1.5] (family counts stay at their defaults).
pub fn random_model<M: Model + Default>(rng: &mut StdRng) -> M {
    random_model_from(&M::default(), rng)
}

/// `base` with every real parameter scaled by a random factor in
/// [0.5, 1.5] (its family counts kept).
pub fn random_model_from<M: Model>(base: &M, rng: &mut StdRng) -> M {
    let mut m = base.clone();
    for (i, p) in m.info().params.iter().enumerate() {
        if p.count {
            continue;
        }
        let v = m.param(i);
        m.set_param(i, v * rng.random_range(0.5..1.5));
    }
    m
}

/// Keeps every sample: `(t, y = [q, qd, sum W], T, res_phi, res_vel)`,
/// and the run's notes.
#[derive(Default)]
pub struct Recorder {
    pub t: Vec<f64>,
    pub y: Vec<Vec<f64>>,
    pub kinetic: Vec<f64>,
    pub res_phi: Vec<f64>,
    pub res_vel: Vec<f64>,
    pub notes: Vec<String>,
}

impl<M: Model> Observer<M> for Recorder {
    type Error = std::convert::Infallible;
    fn observe(&mut self, _sys: &Dynamics<M>, s: &Sample<'_>) -> Result<(), Self::Error> {
        self.t.push(s.t);
        let mut y = s.q.to_vec();
        y.extend_from_slice(s.qd);
        y.push(s.work);
        self.y.push(y);
        self.kinetic.push(s.kinetic_energy);
        self.res_phi.push(s.residual_position);
        self.res_vel.push(s.residual_velocity);
        Ok(())
    }
    fn note(&mut self, text: &str) {
        self.notes.push(text.to_string());
    }
}

/// Largest absolute entry.
pub fn max_abs(v: impl IntoIterator<Item = f64>) -> f64 {
    v.into_iter().fold(0.0, |m, x| m.max(x.abs()))
}

/// The runs a switch (a skate's stick-slip, an event switching an
/// effect) is checked with: every method on the DAE, where each restarts
/// its own way, and a fixed and an adaptive one on the reduced
/// formulation (which hands over to the DAE while a skate slides).
pub const SWITCHING_RUNS: [(ezy_core::Method, ezy_core::Formulation); 6] = {
    use ezy_core::{Formulation::*, Method::*};
    [(Rk4, Dae), (Dopri5, Dae), (Dop853, Dae), (Radau5, Dae), (Rk4, Reduced), (Dop853, Reduced)]
};

/// The figures the `drive` scene writes.
pub const DRIVE_FIGURES: [&str; 7] = [
    "fig3_paths.png",
    "fig4_speed.png",
    "fig5_kinetic_energy.png",
    "fig6_torque.png",
    "fig7_energy_balance.png",
    "energy_gap.png",
    "residuals.png",
];

/// A model as `M` but without the minimal coordinates `model!` derived
/// for it: the reduced formulation takes the numeric partition.
#[derive(Debug, Clone, Default)]
pub struct Numeric<M>(pub M);

impl<M: ezy_core::Model> ezy_core::Model for Numeric<M> {
    fn info(&self) -> ezy_core::ModelInfo {
        self.0.info()
    }
    fn equations(&self) -> ezy_core::Equations {
        self.0.equations()
    }
    fn param(&self, index: usize) -> f64 {
        self.0.param(index)
    }
    fn set_param(&mut self, index: usize, value: f64) {
        self.0.set_param(index, value);
    }
    fn mass_diagonal(&self, out: &mut [f64]) {
        self.0.mass_diagonal(out);
    }
    fn local_geometry(&self, points: &mut [f64], blades: &mut [f64]) {
        self.0.local_geometry(points, blades);
    }
    fn phi<S: ezy_core::Scalar>(&self, q: &[S], phi: &mut [S]) {
        self.0.phi(q, phi);
    }
    fn holonomic_jacobian<S: ezy_core::Scalar>(&self, q: &[S], values: &mut [S]) {
        self.0.holonomic_jacobian(q, values);
    }
    fn constraint_matrix<S: ezy_core::Scalar>(&self, q: &[S], values: &mut [S]) {
        self.0.constraint_matrix(q, values);
    }
    fn phi_and_constraint_matrix<S: ezy_core::Scalar>(&self, q: &[S], phi: &mut [S], values: &mut [S]) {
        self.0.phi_and_constraint_matrix(q, phi, values);
    }
    fn constraint_terms<S: ezy_core::Scalar>(&self, q: &[S], qd: &[S], values: &mut [S], gamma: &mut [S]) {
        self.0.constraint_terms(q, qd, values, gamma);
    }
    fn points<S: ezy_core::Scalar>(&self, q: &[S], out: &mut [S]) {
        self.0.points(q, out);
    }
    fn point_velocities<S: ezy_core::Scalar>(&self, q: &[S], qd: &[S], out: &mut [S]) {
        self.0.point_velocities(q, qd, out);
    }
}

/// What the tests read of a scene set up for model `M`: the problem's
/// parts, the scene as run and the consistent initial state.
#[derive(Debug)]
pub struct Setup<M: Model> {
    /// The model with the scene's parameters.
    pub model: M,
    /// The scene after the overrides, families expanded.
    pub scene: Scene,
    /// The resolved effects.
    pub effects: Vec<ezy_core::Effect>,
    /// The drives with their angles.
    pub drives: Vec<ezy_core::drive::Drive>,
    /// Consistent initial state `y0 = [q, qd, W = 0 ...]`.
    pub y0: Vec<f64>,
    /// What the initial-condition solve corrected.
    pub initial: InitialReport,
}

/// [`ezy_scene::Scene::problem`] with the overrides `sets`, and its initial state.
pub fn setup<M: Model + Default>(scene: &Scene, sets: &[(String, f64)]) -> Result<Setup<M>, SimError> {
    let (p, scene) = scene.problem::<M>(sets)?;
    let (y0, initial) = p.initial_state()?;
    Ok(Setup { model: p.model, scene, effects: p.effects, drives: p.drives, y0, initial })
}

/// The right-hand side of `scene` on model `M` with the overrides `sets`
/// and KKT path `kkt`, and its consistent initial state.
pub fn build<M: Model + Default>(
    scene: &Scene,
    sets: &[(String, f64)],
    kkt: KktMethod,
) -> Result<(Dynamics<M>, Vec<f64>), SimError> {
    let (sys, y0, _) = scene.problem::<M>(sets)?.0.kkt(kkt).into_system()?;
    Ok((sys, y0))
}

/// The double pendulum's small oscillations about hanging straight down,
/// in the bars' absolute angles from the vertical (Goldstein, *Classical
/// Mechanics*, small oscillations): `M theta'' + K theta = 0` with `M =
/// [[I1 + m1 L1^2/4 + m2 L1^2, m2 L1 L2/2], [m2 L1 L2/2, I2 + m2 L2^2/4]]`,
/// `K = diag((m1/2 + m2) g L1, m2 g L2/2)`, `I_i = m_i L_i^2/12`. Returns
/// `M`, `K` and the roots `w^2` of `det(K - w^2 M) = 0`, smaller first.
pub fn double_pendulum_modes(m: &ezy::models::DoublePendulum) -> ([[f64; 2]; 2], [f64; 2], [f64; 2]) {
    let g = ezy_core::effects::STANDARD_GRAVITY;
    let (l1, l2, m1, m2) = (m.L1, m.L2, m.m1, m.m2);
    let (i1, i2) = (m1 * l1 * l1 / 12.0, m2 * l2 * l2 / 12.0);
    let mm =
        [[i1 + m1 * l1 * l1 / 4.0 + m2 * l1 * l1, m2 * l1 * l2 / 2.0], [m2 * l1 * l2 / 2.0, i2 + m2 * l2 * l2 / 4.0]];
    let kk = [(m1 / 2.0 + m2) * g * l1, m2 * g * l2 / 2.0];
    let (a, b, c) = (mm[0][0] * mm[1][1] - mm[0][1] * mm[0][1], -(kk[0] * mm[1][1] + kk[1] * mm[0][0]), kk[0] * kk[1]);
    let disc = (b * b - 4.0 * a * c).sqrt();
    (mm, kk, [(-b - disc) / (2.0 * a), (-b + disc) / (2.0 * a)])
}

/// The Chaplygin sleigh's closed form (docs/physics.md §9) from the
/// forward speed `u0` [m/s] and yaw rate `w0` [rad/s] of the model's
/// default parameters: `(U, k, s0)` with `U = sqrt(2 E / m)` [m/s],
/// `k = m a / (I + m a^2)` [1/m] and `s0 = atanh(u0 / U)`, so that
/// `u(t) = U tanh(k U t + s0)` and
/// `omega(t) = w0 cosh(s0) / cosh(k U t + s0)`.
pub fn sleigh_closed_form(u0: f64, w0: f64) -> (f64, f64, f64) {
    let m = ezy::models::ChaplyginSleigh::default();
    let energy = 0.5 * (m.m * u0 * u0 + (m.I + m.m * m.a * m.a) * w0 * w0);
    let big_u = (2.0 * energy / m.m).sqrt();
    (big_u, m.m * m.a / (m.I + m.m * m.a * m.a), (u0 / big_u).atanh())
}
