//! The right-hand side of the EzyRoller with no effect code at all: `G`,
//! `gamma`, the Schur-complement KKT solve with `f = 0`, nothing else.
//! Shared by `tests/effects.rs` (bit-identity of the `free` scene) and
//! `benches/effects.rs` (absent effects cost nothing).

use ezy_core::Model;
use ezy_core::SimError;
use ezy_core::integrator::Rhs;
use ezy_core::kkt::{KktSolver, KktSystem, SchurCholesky};
use ezy_models::EzyRoller;

/// `y' = [qd, qdd]` from the bare model: no effects, no work states.
pub struct BareRhs {
    model: EzyRoller,
    kkt: SchurCholesky<EzyRoller>,
    mass: Vec<f64>,
    g_values: Vec<f64>,
    gamma: Vec<f64>,
    f: Vec<f64>,
    lambda: Vec<f64>,
    info: ezy_core::ModelInfo,
}

impl BareRhs {
    /// For `model` (all masses positive).
    pub fn new(model: EzyRoller) -> Self {
        let mut mass = vec![0.0; 6];
        model.mass_diagonal(&mut mass);
        let info = model.info();
        Self {
            kkt: SchurCholesky::new(&model, &info, &mass).expect("positive masses"),
            model,
            mass,
            g_values: vec![0.0; info.pattern.len()],
            info,
            gamma: vec![0.0; 4],
            f: vec![0.0; 6],
            lambda: vec![0.0; 4],
        }
    }
}

impl Rhs for BareRhs {
    #[inline]
    fn eval(&mut self, _t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SimError> {
        let (q, qd) = y.split_at(6);
        self.model.constraint_terms(q, qd, &mut self.g_values, &mut self.gamma);
        let sys = KktSystem {
            mass: &self.mass,
            g: &[],
            g_values: &self.g_values,
            f: &self.f,
            gamma: &self.gamma,
            released: &[],
        };
        let (dq, dqd) = dy.split_at_mut(6);
        self.kkt.solve(&sys, dqd, &mut self.lambda).map_err(|e| SimError::from_kkt(&self.info, 0.0, e))?;
        dq.copy_from_slice(qd);
        Ok(())
    }
}
