//! Errors of the runtime (DESIGN.md: a `thiserror` enum with data, no
//! catch-all string variant).

use crate::kkt::KktError;

/// What can stop a simulation or its setup.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SimError {
    /// The KKT solve failed.
    #[error("at t = {t} s: {source}")]
    Kkt {
        /// Time \[s\].
        t: f64,
        /// The linear-solver failure.
        source: KktError,
    },
    /// A state component became NaN or infinite.
    #[error(
        "at t = {t} s the state component `{quantity}` became {value}; the step h = {dt} s is too large for this scene, try a smaller --dt"
    )]
    NonFinite {
        /// Time \[s\] at the start of the failing step.
        t: f64,
        /// Name of the component (`x1`, `phi2d`, `W`).
        quantity: String,
        /// Its value (NaN or inf).
        value: f64,
        /// The step size \[s\].
        dt: f64,
    },
    /// The integration left the accuracy any result could be used at.
    #[error(
        "at t = {t} s {quantity} reached {value:.3e} (limit {limit:.0e}): the step h = {dt} s is far too large for this scene; try a smaller --dt or an adaptive method (--integrator dop853)"
    )]
    Diverged {
        /// Time \[s\].
        t: f64,
        /// What exceeded its limit.
        quantity: &'static str,
        /// Its value.
        value: f64,
        /// The limit.
        limit: f64,
        /// The step size \[s\].
        dt: f64,
    },
    /// An adaptive method needed a step below the rounding level of `t`.
    #[error("at t = {t} s the step size fell to {h:e} s; the problem may be stiff or the tolerance too tight")]
    StepSizeTooSmall {
        /// Time \[s\].
        t: f64,
        /// The step size \[s\].
        h: f64,
    },
    /// A name (coordinate, parameter, hinge) is not in the model.
    #[error("unknown {kind} `{name}` in model {model}; known: {known}")]
    UnknownName {
        /// What was looked up: "coordinate", "parameter", "hinge", ...
        kind: &'static str,
        /// The name given.
        name: String,
        /// Model name.
        model: &'static str,
        /// Comma-separated known names.
        known: String,
    },
    /// A scene key is wrong (after command-line overrides).
    #[error("scene key `{key}`: {message}")]
    Scene {
        /// The key, e.g. `effects.motor.torque`.
        key: String,
        /// What is wrong.
        message: String,
    },
    /// An effect names something the model does not have, or a bad number.
    #[error("effect `{effect}`, key `{field}`: {message}")]
    Effect {
        /// The effect's name in the scene.
        effect: String,
        /// The key at fault.
        field: &'static str,
        /// What is wrong.
        message: String,
    },
    /// Consistent initial conditions could not be found.
    #[error("initial conditions: {reason}")]
    Initial {
        /// What is wrong, with the offending names and sizes.
        reason: String,
    },
    /// Constraints that are not independent (a duplicated hinge, a
    /// redundant closed loop): the multipliers are not unique.
    #[error(
        "at t = {t} s the constraint `{constraint}` (row {row} of G) depends on the constraints before it ({before}); the model has redundant constraints (the multipliers are not unique): remove `{constraint}` or a constraint it depends on"
    )]
    DependentConstraints {
        /// Time \[s\].
        t: f64,
        /// Name of the dependent row, e.g. `H2.x`.
        constraint: String,
        /// Its row in `G`.
        row: usize,
        /// Names of the rows before it.
        before: String,
    },
    /// A setting is out of range.
    #[error("invalid setting {name} = {}: {reason}", fmt_value(*value))]
    Setting {
        /// Setting name (`--dt`, `--t-end`, parameter name).
        name: String,
        /// Value given.
        value: f64,
        /// Why it is rejected.
        reason: &'static str,
    },
}

impl SimError {
    /// A KKT failure at time `t`, with dependent rows named from the model's `info`.
    pub fn from_kkt(info: &crate::ModelInfo, t: f64, source: KktError) -> Self {
        match source {
            KktError::DependentConstraints { row, .. } if row < info.nc() => {
                let names = &info.constraints;
                SimError::DependentConstraints {
                    t,
                    constraint: names[row].clone(),
                    row,
                    before: names[..row].join(", "),
                }
            }
            source => SimError::Kkt { t, source },
        }
    }
}

/// A number as a person would write it: plain for ordinary magnitudes,
/// scientific for very small or very large ones.
fn fmt_value(v: f64) -> String {
    if v != 0.0 && v.is_finite() && (v.abs() < 1e-3 || v.abs() >= 1e6) { format!("{v:e}") } else { format!("{v}") }
}
