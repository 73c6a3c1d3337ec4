//! Applied forces (effects). Only the effects a scene lists are built and
//! evaluated; each contributes to the generalized force `f` (nq) and its
//! power `f . qd` is integrated into the work `W`.

use crate::SimError;
use crate::model::ModelInfo;

/// An effect as a scene names it (by hinge/body name), before resolution
/// against a model.
#[derive(Debug, Clone, PartialEq)]
pub enum EffectSpec {
    /// Hinge motor `tau(t) = m0 cos(omega t)`: `+tau` on the hinge's first
    /// body, `-tau` on the second (SPEC §3, seed code; SPEC §4 item 5).
    HingeMotor {
        /// Hinge name.
        hinge: String,
        /// Amplitude `M0` [N m].
        m0: f64,
        /// Angular frequency `omega` [rad/s].
        omega: f64,
    },
}

impl EffectSpec {
    /// Names of the effect's parameters as `--set` accepts them.
    pub fn param_names(&self) -> &'static [&'static str] {
        match self {
            Self::HingeMotor { .. } => &["M0", "omega"],
        }
    }

    /// Sets a parameter by name; `false` if the effect has no such parameter.
    pub fn set_param(&mut self, name: &str, value: f64) -> bool {
        match (self, name) {
            (Self::HingeMotor { m0, .. }, "M0") => *m0 = value,
            (Self::HingeMotor { omega, .. }, "omega") => *omega = value,
            _ => return false,
        }
        true
    }

    /// Resolves names against `info`.
    ///
    /// # Errors
    /// [`SimError::UnknownName`] for a hinge the model does not have.
    pub fn resolve(&self, info: &ModelInfo) -> Result<Effect, SimError> {
        match self {
            Self::HingeMotor { hinge, m0, omega } => {
                let h = info.hinge_index(hinge).ok_or_else(|| SimError::UnknownName {
                    kind: "hinge",
                    name: hinge.clone(),
                    model: info.name,
                    known: info.hinges.iter().map(|h| h.name).collect::<Vec<_>>().join(", "),
                })?;
                let hi = &info.hinges[h];
                Ok(Effect::HingeMotor {
                    phi_a: info.bodies[hi.body_a].coords[2],
                    phi_b: hi.body_b.map(|b| info.bodies[b].coords[2]),
                    m0: *m0,
                    omega: *omega,
                    column: format!("tau_{}", hi.name),
                })
            }
        }
    }
}

/// An effect resolved to coordinate indices, ready for the right-hand side.
#[derive(Debug, Clone, PartialEq)]
pub enum Effect {
    /// See [`EffectSpec::HingeMotor`].
    HingeMotor {
        /// Index of the first body's heading in `q`.
        phi_a: usize,
        /// Index of the second body's heading, `None` for the ground.
        phi_b: Option<usize>,
        /// Amplitude [N m].
        m0: f64,
        /// Angular frequency [rad/s].
        omega: f64,
        /// Output column name, `tau_<hinge>`.
        column: String,
    },
}

impl Effect {
    /// Adds this effect's generalized force at `(t, q, qd)` into `f` (nq).
    #[inline]
    pub fn apply(&self, t: f64, _q: &[f64], _qd: &[f64], f: &mut [f64]) {
        match self {
            Self::HingeMotor { phi_a, phi_b, m0, omega, .. } => {
                let tau = m0 * (omega * t).cos();
                f[*phi_a] += tau;
                if let Some(b) = phi_b {
                    f[*b] -= tau;
                }
            }
        }
    }

    /// Name of the effect's output column.
    pub fn column(&self) -> &str {
        match self {
            Self::HingeMotor { column, .. } => column,
        }
    }

    /// The effect's scalar output at time t (the motor torque [N m]).
    pub fn output(&self, t: f64) -> f64 {
        match self {
            Self::HingeMotor { m0, omega, .. } => m0 * (omega * t).cos(),
        }
    }
}
