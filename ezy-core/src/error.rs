//! Errors of the runtime: a `thiserror` enum with data, no catch-all
//! string variant. It imports only [`crate::names`] (how numbers
//! and names are written) and [`crate::settings`] (the settings a message
//! advises, carried as data).

use crate::names::{fmt_value, name_list};
use crate::settings::{BALANCE_LIMIT, Message, Method, RunSettings, Setting, Spelling};

/// What can stop a simulation or its setup.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SimError {
    /// The input is wrong: a name, a scene key, an effect's or an event's
    /// key, a setting, initial values that cannot be made consistent;
    /// found before the first step ([`SetupError`]).
    #[error(transparent)]
    Setup(#[from] SetupError),
    /// The KKT solve failed.
    #[error("at t = {} s: {source}", fmt_value(*t))]
    Kkt {
        /// Time \[s\].
        t: f64,
        /// The linear-solver failure.
        source: KktError,
    },
    /// A state component or a derived quantity (kinetic energy, work,
    /// residual, an output column) became NaN or infinite.
    #[error("at t = {} s {quantity} became {value}; {advice}", fmt_value(*t))]
    NonFinite {
        /// Time \[s\] at the start of the failing step.
        t: f64,
        /// What became non-finite: "the state component `x1`", "the kinetic energy T".
        quantity: String,
        /// Its value (NaN or inf).
        value: f64,
        /// The step size \[s\].
        dt: f64,
        /// What to do, fitted to the method in use ([`advice`]); the
        /// settings it advises are data ([`Message::settings`]).
        advice: Message,
    },
    /// The integration left the accuracy any result could be used at.
    #[error("at t = {} s {quantity} reached {value:.3e} (limit {limit:.0e}); {advice}", fmt_value(*t))]
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
        /// What to do, fitted to the method in use ([`advice`]); the
        /// settings it advises are data ([`Message::settings`]).
        advice: Message,
    },
    /// An adaptive method's step size collapsed 1e4-fold next to a
    /// singular position of the constraints (the KKT conditioning above
    /// [`crate::formulation::dae::NEAR_SINGULAR`]) despite the measures `simulate`
    /// takes there (docs/physics.md §5.1): the tolerance is below what
    /// double precision resolves there. `h` is the step size asked for
    /// \[s\].
    #[error(
        "at t = {} s, next to a singular position of the constraints (G nearly rank-deficient), the step size fell to {h:e} s: there the rounding of the positions, amplified like 1 / distance, is above the tolerance rtol = {rtol:e}; a looser tolerance or a fixed-step method (rk4) passes it",
        fmt_value(*t)
    )]
    SingularTolerance {
        /// Time \[s\].
        t: f64,
        /// The step size \[s\].
        h: f64,
        /// The relative tolerance asked for.
        rtol: f64,
    },
    /// An adaptive method needed a step below the rounding level of `t`.
    #[error(
        "at t = {} s the step size fell to {h:e} s, the rounding level of t: the problem may be stiff, the tolerance too tight, or the forces or initial values too large",
        fmt_value(*t)
    )]
    StepSizeTooSmall {
        /// Time \[s\].
        t: f64,
        /// The step size \[s\].
        h: f64,
    },
    /// An effect could not be evaluated (a spring-damper of zero length).
    #[error("at t = {} s the effect `{effect}` {reason}", fmt_value(*t))]
    EffectFailed {
        /// Time \[s\].
        t: f64,
        /// The effect's name in the scene.
        effect: String,
        /// What went wrong, from [`crate::effects::Effect::failure`].
        reason: String,
    },
    /// Constraints that are not independent (a duplicated hinge, a
    /// redundant closed loop): the multipliers are not unique.
    #[error(
        "at t = {} s the constraint `{constraint}` (row {row} of G) depends on the constraints before it ({before}); the model has redundant constraints (the multipliers are not unique): remove `{constraint}` or a constraint it depends on",
        fmt_value(*t)
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
    /// Constraints that stayed dependent along the motion: every KKT solve
    /// of [`crate::simulate::SINGULAR_PERSIST_STEPS`] accepted steps in a row found
    /// `G` rank-deficient, so the run is not passing a singular position
    /// but staying in one (the multipliers are not unique along it).
    #[error(
        "from t = {t0} s to t = {t1} s the constraint `{constraint}` (row {row} of G) stayed dependent on the constraints before it ({before}) at every evaluation of {steps} steps in a row: the motion stays at a singular position instead of passing it, so the multipliers are not unique along it; start from other initial values, or remove `{constraint}` or a constraint it depends on"
    )]
    SingularPersists {
        /// When the steps began \[s\].
        t0: f64,
        /// When the run stopped \[s\].
        t1: f64,
        /// Accepted steps whose every solve was singular.
        steps: u64,
        /// Name of the dependent row, e.g. `H2.x`.
        constraint: String,
        /// Its row in `G`.
        row: usize,
        /// Names of the rows before it.
        before: String,
    },
    /// An event fired in each of [`crate::events::spec::CHATTER_STEPS`] accepted
    /// steps in a row: its quantity sits at its level within rounding or
    /// switches back at once, so the run stops instead of looping on it.
    #[error(
        "the event `{event}` chatters: it fired in each of {steps} steps in a row from t = {} s to t = {} s; its quantity stays at its level within rounding (a level it sits on rather than crosses) or switches back at once: give a level it crosses, or a direction",
        fmt_value(*t0), fmt_value(*t1)
    )]
    Chattering {
        /// The event's name.
        event: String,
        /// When the steps with an event began \[s\].
        t0: f64,
        /// When the run stopped \[s\].
        t1: f64,
        /// Steps in a row with an event.
        steps: u64,
    },
    /// A switch sends its quantity back across its level at once, where
    /// another switch (or the same) turns the forces back: a sliding mode
    /// (Filippov), in which the motion stays on the level with the two
    /// sets of forces blended. ezy does not follow one; every method
    /// refuses it at the first switch.
    #[error(
        "at t = {} s the switch `{event}` sends its quantity back across its level at once, where the switch `{undo}` turns the forces back: a sliding mode (the motion would stay on the level with both sets of forces blended, which ezy does not follow); give the two switches levels apart (hysteresis), or replace them by a force law that varies continuously",
        fmt_value(*t)
    )]
    SlidingMode {
        /// The switch that fired.
        event: String,
        /// The switch its quantity's return fires at once.
        undo: String,
        /// Time \[s\].
        t: f64,
    },
    /// A skate with friction switched between sticking and sliding
    /// [`crate::events::spec::CHATTER_STEPS`] times in a row at ever shorter
    /// intervals or, with a fixed step, every few steps
    /// ([`crate::formulation::friction::SwitchStreak`]), or its
    /// modes found no rest at one instant ([`crate::formulation::friction`]): the force
    /// that holds it sits at its limit `mu N`, so the run stops instead of
    /// switching without end.
    #[error(
        "{}; the lateral force sits at the friction limit mu N (take a mu away from that force, or model the contact as a force law)",
        if *switches == 0 {
            format!("skates `{skate}`: no choice of sticking and sliding is consistent at t = {} s (a Coulomb contact problem without a solution there)", fmt_value(*t0))
        } else {
            format!("skate `{skate}` chatters between sticking and sliding: {switches} switches at ever shorter intervals or a few steps apart from t = {} s to t = {} s", fmt_value(*t0), fmt_value(*t1))
        }
    )]
    SlipChattering {
        /// The skate (or skates) switching.
        skate: String,
        /// When the switching began \[s\].
        t0: f64,
        /// When the run stopped \[s\].
        t1: f64,
        /// Switches in a row.
        switches: u64,
    },
    /// A run recorded more events than it keeps
    /// ([`crate::events::spec::max_records`]).
    #[error(
        "at t = {} s the event `{event}` would be the run's record number {}, more than the {limit} it keeps (64 MiB of states): an event that fires this often records the motion, not events; give it a level it crosses less often, or sample the run with a shorter output interval instead",
        fmt_value(*t), limit + 1
    )]
    EventLimit {
        /// The event's name.
        event: String,
        /// Time \[s\].
        t: f64,
        /// The records kept.
        limit: usize,
    },
    /// A run would take more steps or write more output than its budget.
    #[error(
        "the run would take {} {what} ({detail}), more than the limit of {}; {}",
        fmt_value(round3(*estimate)), fmt_value(*limit), raise(*estimate, *setting)
    )]
    Budget {
        /// What is counted: "steps", "MB of output".
        what: &'static str,
        /// The estimate (or the count reached).
        estimate: f64,
        /// The limit.
        limit: f64,
        /// The setting that raises the limit ([`Setting::MaxSteps`],
        /// [`Setting::MaxOutputMb`]).
        setting: Setting,
        /// How the estimate was made.
        detail: String,
    },
    /// A failure with its likely cause in the model's numbers (see
    /// [`SimError::with_cause`]).
    #[error("{error}; {cause}")]
    Caused {
        /// The failure as the solver saw it.
        error: Box<SimError>,
        /// What in the model's masses and inertias explains it.
        cause: String,
    },
    /// The reduced formulation cannot be used or cannot go on (dependent
    /// constraints, a singular partition, Newton's method for the
    /// dependent coordinates failing).
    #[error("formulation reduced: {reason}")]
    Formulation {
        /// What failed, with the time, and the setting to take instead
        /// ([`Message::settings`]).
        reason: Message,
    },
}

/// What is wrong with a run's input, found before its first step: the
/// part of [`SimError`] that a change of the scene, the model's names or
/// the settings fixes. The rest of [`SimError`] is met while solving (a
/// failed KKT solve, a state that blew up, a step size that collapsed,
/// an event that chatters), or either way ([`SimError::Budget`]: an
/// estimate before the run or a count reached in it;
/// [`SimError::Formulation`]: refused before the first step or unable to
/// go on).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SetupError {
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
    /// An event is not acceptable: a name the run does not have, a level
    /// that is not finite, a bad event name ([`crate::events`]).
    #[error("event `{event}`{}: {message}", if field.is_empty() { String::new() } else { format!(", key `{field}`") })]
    Event {
        /// The event's name.
        event: String,
        /// The key at fault (`when`, `crosses`; empty: the name).
        field: &'static str,
        /// What is wrong.
        message: String,
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

/// Errors of a KKT solve.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum KktError {
    /// The Schur complement `G M^-1 G^T` is not positive definite: the
    /// constraint rows are (numerically) dependent.
    #[error(
        "the constraint matrix G has dependent rows: row {row} depends on the rows before it (G M^-1 G^T, {n} x {n}, is not positive definite)"
    )]
    DependentConstraints {
        /// Size of the Schur complement (nc).
        n: usize,
        /// The first row of `G` found to depend on the rows before it.
        row: usize,
    },
    /// The system has non-finite entries: the state it was built from
    /// overflowed (a step far too large, or absurd initial values).
    #[error("the KKT system ({n} x {n}) has non-finite entries: the state overflowed")]
    NonFinite {
        /// Size of the factored matrix.
        n: usize,
    },
    /// The KKT matrix is singular (LU found a zero pivot).
    #[error("the KKT matrix ({n} x {n}) is singular")]
    SingularKkt {
        /// Size of the KKT matrix (nq + nc).
        n: usize,
    },
    /// The Schur path needs every mass-matrix entry positive.
    #[error("the Schur-complement path needs an invertible mass matrix; M[{index}] = {}", fmt_value(*value))]
    SingularMass {
        /// Coordinate index of the offending diagonal entry.
        index: usize,
        /// Its value \[kg\] or \[kg m^2\].
        value: f64,
    },
}

/// Spread of the positive masses and inertias above which a solve's
/// failure is blamed on them as well (see [`SimError::with_cause`]): the
/// Schur complement `G M^-1 G^T` mixes columns scaled by `1/m`, and rows
/// that differ only in columns `1e12` times lighter than the others are
/// separated by fewer than four digits of double precision.
pub const MASS_SPREAD_WARNING: f64 = 1e12;

impl SimError {
    /// The failure with its likely cause in the masses and inertias
    /// `mass` (nq, the mass diagonal; `names[k]` names entry `k`, e.g.
    /// `m (mass of body link1)`):
    ///
    /// - constraints found dependent, or a KKT matrix with non-finite or
    ///   dependent entries, while the positive entries of `mass` span more
    ///   than [`MASS_SPREAD_WARNING`]: the rows may be independent in exact
    ///   arithmetic, but double precision cannot tell them apart;
    /// - a singular KKT matrix with massless parts: nothing determines the
    ///   accelerations of the massless coordinates.
    ///
    /// Other failures are returned as they are.
    pub fn with_cause(self, mass: &[f64], names: impl Fn(usize) -> String) -> Self {
        let positive = || mass.iter().enumerate().filter(|(_, m)| **m > 0.0 && m.is_finite());
        let lightest = positive().min_by(|a, b| a.1.total_cmp(b.1));
        let heaviest = positive().max_by(|a, b| a.1.total_cmp(b.1));
        let dependent = matches!(
            &self,
            SimError::DependentConstraints { .. }
                | SimError::SingularPersists { .. }
                | SimError::Kkt { source: KktError::DependentConstraints { .. } | KktError::NonFinite { .. }, .. }
        );
        let singular = matches!(&self, SimError::Kkt { source: KktError::SingularKkt { .. }, .. });
        let cause = match (lightest, heaviest) {
            (Some((i, lo)), Some((j, hi))) if dependent && hi / lo > MASS_SPREAD_WARNING => format!(
                "but the masses and inertias span a factor {:.1e}, from {} = {} to {} = {}: more than double precision separates, so rows that differ only in the light coordinates look dependent; bring the masses and inertias within a factor {MASS_SPREAD_WARNING:e} of each other",
                hi / lo,
                names(i),
                fmt_value(*lo),
                names(j),
                fmt_value(*hi)
            ),
            _ if singular && mass.contains(&0.0) => {
                // x and y share their mass: each name once
                let mut zero: Vec<String> = (0..mass.len()).filter(|&k| mass[k] == 0.0).map(&names).collect();
                zero.dedup();
                format!(
                    "the massless parts ({}) leave accelerations that no constraint determines: give them a mass and an inertia, or constrain them fully",
                    name_list(zero)
                )
            }
            _ => return self,
        };
        SimError::Caused { error: Box::new(self), cause }
    }
}

/// What to do when a run's numbers blow up, for the method in use: at
/// t = 0 the scene's numbers themselves are out of range; an adaptive
/// method met its tolerance, so the solution itself grows (forces,
/// initial values); a fixed-step method's step `dt` \[s\] may be too large,
/// unless the energy balance held up to the last accepted state
/// (`balance`: `|T - T0 - W|` relative to the run's energy scale there,
/// [`crate::simulate::guard`]; `None`: no step accepted or not known): then the
/// forces did the work, the solution itself grows and a smaller step
/// would not help.
pub fn advice(method: Method, t: f64, dt: f64, balance: Option<f64>) -> Message {
    Message::text(if t == 0.0 && dt == 0.0 {
        "the scene's initial values or parameters are out of the range double precision can hold".into()
    } else if method.is_adaptive() {
        "the adaptive method met its tolerance up to here, so the solution itself grows without bound: check the scene's forces, parameters and initial values".into()
    } else if let Some(b) = balance.filter(|b| *b <= BALANCE_LIMIT) {
        format!(
            "the energy balance held to {b:.1e} of the run's energy up to here (the forces did the work), so the solution itself grows without bound and a smaller step would not help: check the scene's forces, parameters and initial values"
        )
    } else {
        return Message::text(format!("the step h = {} s is too large for this scene: try a smaller ", fmt_value(dt)))
            .setting(Setting::Dt)
            .then(" or an adaptive method (")
            .setting(Setting::Method(Method::Dop853))
            .then(")");
    })
}

/// How to get past a budget: the setting with the estimate, or, for an
/// estimate no machine could run, a change of settings.
fn raise(estimate: f64, setting: Setting) -> String {
    if estimate.is_finite() && estimate < 1e15 {
        let value = fmt_value(ceil3(estimate));
        if Spelling::current() == Spelling::Flags {
            format!("pass {setting} {value} (or larger) to run it anyway")
        } else {
            format!("set {setting} to {value} (or larger) to run it anyway")
        }
    } else {
        "no budget makes this feasible: change the step, duration or output interval".into()
    }
}

/// `v` to three significant digits (an estimate's precision).
fn round3(v: f64) -> f64 {
    format!("{v:.2e}").parse().unwrap_or(v)
}

/// The smallest number of three significant digits `>= v` (v > 0).
fn ceil3(v: f64) -> f64 {
    let scale = 10f64.powf(v.log10().floor() - 2.0);
    let up = (v / scale).ceil() * scale;
    format!("{up:.2e}").parse().unwrap_or(up)
}

impl RunSettings {
    /// Checks the settings.
    ///
    /// # Errors
    /// [`SetupError::Setting`] naming the first bad setting.
    pub fn validate(&self) -> Result<(), SimError> {
        for (name, value) in
            [("dt", self.dt), ("t_end", self.t_end), ("every", self.every), ("rtol", self.rtol), ("atol", self.atol)]
        {
            if let Some(reason) = Self::reject(name, value) {
                return Err(SimError::Setup(SetupError::Setting { name: name.into(), value, reason }));
            }
        }
        if let Some(max) = self.max_steps
            && !self.method.is_adaptive()
        {
            let needed = (self.t_end / self.dt).ceil();
            if needed > max as f64 {
                return Err(SimError::Budget {
                    what: "steps",
                    estimate: needed,
                    limit: max as f64,
                    setting: Setting::MaxSteps,
                    detail: format!("t_end / dt = {:e} s / {:e} s", self.t_end, self.dt),
                });
            }
        }
        Ok(())
    }
}
