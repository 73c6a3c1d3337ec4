//! Located events: a function `g(t, q, qd)` whose zero crossings a run
//! finds on its integrator's dense output, records, or stops at.
//!
//! An event watches a quantity of the run (a coordinate, a velocity, a
//! hinge angle, a point, an effect's value, the kinetic energy, the time,
//! or a function of the user's own) and fires when `g = quantity - level`
//! changes sign in its [`Direction`] within an accepted step. The crossing
//! is then located on the step's continuous extension (RK4 and Euler: the
//! cubic Hermite interpolant of the step's ends and their derivatives;
//! DOPRI5 and DOP853: their own dense output, of order 4 and 7; RADAU5: its
//! collocation polynomial, order 3) by the Anderson-Björck variant of
//! regula falsi (Hairer, Nørsett & Wanner, Solving ODEs I, §II.6 "Dense
//! output, discontinuities"; Anderson & Björck, BIT 12 (1972) 103-106) to
//! within a few units of rounding in `t`. Its accuracy in time is then the
//! interpolant's: about the local error over `|g'|` (measured in
//! docs/book's events chapter: 1e-12 s or better on the sleigh at rtol
//! 1e-12 for every method).
//!
//! The event's time is the end of the final bracket, where `g` has taken
//! its new sign (or is zero), so a run that goes on from there does not
//! find the same crossing again. Crossings that come and go within one
//! step (an even number of sign changes) are not seen; a step small enough
//! to resolve the quantity's motion sees them.
//!
//! A switch ([`Action::Switch`]) turns effects on or off where it fires:
//! the step is cut at the crossing and the integrator restarts there with
//! the new forces (no stage of the old ones carried over: Hairer, Nørsett
//! & Wanner I, §II.6), as a skate's stick-slip switch does
//! ([`crate::formulation::friction`]).
//!
//! An event that fires in each of [`CHATTER_STEPS`] accepted steps in a
//! row chatters (its quantity sits at the rounding level of its level, or
//! switches without end): the run stops with [`SimError::Chattering`]
//! instead of looping on it.

use std::fmt;
use std::sync::Arc;

use serde::{Deserialize, Serialize};

use crate::effects::Effect;
use crate::effects::context::HingeRef;
use crate::error::SetupError;
use crate::error::SimError;
use crate::model::info::ModelInfo;

/// Which sign changes of `g = quantity - level` fire an event.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Direction {
    /// From below the level to it or above (`g < 0` to `g >= 0`).
    Rising,
    /// From above the level to it or below (`g > 0` to `g <= 0`).
    Falling,
    /// Either way.
    #[default]
    Either,
}

impl Direction {
    /// The name a scene file spells: `rising`, `falling`, `either`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Rising => "rising",
            Self::Falling => "falling",
            Self::Either => "either",
        }
    }

    /// Whether `g` going from `left` to `right` is a crossing this way:
    /// `Some(true)` rising, `Some(false)` falling, `None` none (a start at
    /// exactly zero is no crossing).
    #[inline]
    pub fn crossing(self, left: f64, right: f64) -> Option<bool> {
        let rising = left < 0.0 && right >= 0.0;
        let falling = left > 0.0 && right <= 0.0;
        match self {
            Self::Rising if rising => Some(true),
            Self::Falling if falling => Some(false),
            Self::Either if rising || falling => Some(rising),
            _ => None,
        }
    }
}

/// What a run does at an event.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Action {
    /// Records it ([`Summary::events`](crate::simulate::Summary::events)) and goes on.
    #[default]
    Record,
    /// Records it and ends the run there: the state at the event is the
    /// last sample and the final state.
    Stop,
    /// Records it and switches the effects it names on or off
    /// ([`Event::switch_on`], [`Event::switch_off`]; scene keys
    /// `switch_on`, `switch_off`): the step is cut at the event, the
    /// samples before it keep the old forces, and the integrator restarts
    /// there. Explicit methods on the DAE formulation only (RADAU5 and
    /// the reduced formulation refuse it with the way out).
    Switch,
}

impl Action {
    /// The name a scene file spells: `record`, `stop`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Record => "record",
            Self::Stop => "stop",
            Self::Switch => "switch",
        }
    }
}

/// A key of an event's table and what is wrong with it.
pub type KeyError = (&'static str, String);

/// An event as a scene file or a library user writes it by name: `when`
/// names the quantity ([`Quantity::resolve`]), `crosses` its level.
///
/// ```toml
/// [events.ten_metres]
/// when = "x1"          # a column of the run
/// crosses = 10.0       # [the quantity's unit]
/// direction = "rising" # rising, falling or either (default)
/// action = "stop"      # record (default), stop or switch
///
/// [events.coast]
/// when = "x1"
/// crosses = 2.0
/// action = "switch"
/// switch_off = ["push"] # effects by name (and `switch_on`)
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EventSpec {
    /// The quantity watched, by its column name (`x1`, `phi1d`,
    /// `theta_B`, `A.x`, `C.vy`, `tau_motor`, `W_motor`, `T`, `t`).
    pub when: String,
    /// The level whose crossing fires the event, in the quantity's unit
    /// \[m, rad, m/s, N, J, s\] (default 0).
    #[serde(default)]
    pub crosses: f64,
    /// Which crossings fire it.
    #[serde(default)]
    pub direction: Direction,
    /// What the run does then.
    #[serde(default)]
    pub action: Action,
    /// With `action = "switch"`: the effects (by name) it turns on.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub switch_on: Vec<String>,
    /// With `action = "switch"`: the effects (by name) it turns off.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub switch_off: Vec<String>,
}

impl EventSpec {
    /// The event watching `when` for crossings of `crosses`, either way,
    /// recorded (set the other fields by struct update:
    /// `EventSpec { action: Action::Stop, ..EventSpec::new("x1", 10.0) }`).
    pub fn new(when: &str, crosses: f64) -> Self {
        Self {
            when: when.to_string(),
            crosses,
            direction: Direction::Either,
            action: Action::Record,
            switch_on: Vec::new(),
            switch_off: Vec::new(),
        }
    }

    /// The effects this spec switches on and off, as indices into
    /// `effects` (each effect's name and whether it is a skate's
    /// friction, in the run's order).
    ///
    /// # Errors
    /// The key (`switch_on`, `switch_off`, `action`) and why: a name that
    /// is no effect (listing them), a skate's friction, an effect in both
    /// lists, a list without `action = "switch"`, a switch without a list.
    pub fn switched(&self, effects: &[(&str, bool)]) -> Result<(Vec<usize>, Vec<usize>), KeyError> {
        let list = |field: &'static str, names: &[String]| -> Result<Vec<usize>, KeyError> {
            if !names.is_empty() && self.action != Action::Switch {
                return Err((
                    field,
                    format!("only `action = \"switch\"` switches effects, not `{}`", self.action.name()),
                ));
            }
            names
                .iter()
                .map(|n| match effects.iter().position(|(e, _)| e == n) {
                    None => Err((
                        field,
                        format!(
                            "`{n}` is no effect of this run; known: {}",
                            crate::names::name_list(effects.iter().map(|e| e.0))
                        ),
                    )),
                    Some(k) if effects[k].1 => Err((
                        field,
                        format!("`{n}` is a skate's friction: its skate's mode switches itself, an event cannot"),
                    )),
                    Some(k) => Ok(k),
                })
                .collect()
        };
        let (on, off) = (list("switch_on", &self.switch_on)?, list("switch_off", &self.switch_off)?);
        if let Some(k) = on.iter().find(|k| off.contains(k)) {
            return Err(("switch_off", format!("`{}` is switched on and off at once", effects[*k].0)));
        }
        if self.action == Action::Switch && on.is_empty() && off.is_empty() {
            return Err(("action", "a switch names the effects it turns on or off: `switch_on`, `switch_off`".into()));
        }
        Ok((on, off))
    }

    /// The event `name` of this spec for a run on a model with `info`,
    /// `effects` and the drives named `drives`.
    ///
    /// # Errors
    /// [`SetupError::Event`] at `when` for a quantity the run does not have
    /// (listing the names it has), at `crosses` for a level that is not
    /// finite, at `switch_on` or `switch_off` for a name that is no effect
    /// of the run (listing them), a skate's friction, an effect in both,
    /// a list without `action = "switch"` or a switch without a list; a
    /// bad name ([`check_event_name`]).
    pub fn resolve(
        &self,
        name: &str,
        info: &ModelInfo,
        effects: &[Effect],
        drives: &[crate::drive::Drive],
    ) -> Result<Event, SimError> {
        check_event_name(name)
            .map_err(|message| SimError::Setup(SetupError::Event { event: name.into(), field: "", message }))?;
        if !self.crosses.is_finite() {
            return Err(SimError::Setup(SetupError::Event {
                event: name.into(),
                field: "crosses",
                message: format!("the level must be a finite number, not {}", self.crosses),
            }));
        }
        let named: Vec<(&str, &str)> = effects.iter().map(|e| (e.name.as_str(), e.value_column.as_str())).collect();
        let drives: Vec<&str> = drives.iter().map(|d| d.name.as_str()).collect();
        let quantity = Quantity::resolve(&self.when, info, &named, &drives)
            .map_err(|message| SimError::Setup(SetupError::Event { event: name.into(), field: "when", message }))?;
        if let Quantity::EffectValue(k) = quantity
            && matches!(effects[k].law, crate::effects::law::Law::SkateFriction(_))
        {
            let message = friction_force_unwatched(&self.when, &effects[k].name);
            return Err(SimError::Setup(SetupError::Event { event: name.into(), field: "when", message }));
        }
        let named: Vec<(&str, bool)> = effects
            .iter()
            .map(|e| (e.name.as_str(), matches!(e.law, crate::effects::law::Law::SkateFriction(_))))
            .collect();
        let (switch_on, switch_off) = self
            .switched(&named)
            .map_err(|(field, message)| SimError::Setup(SetupError::Event { event: name.into(), field, message }))?;
        Ok(Event {
            name: name.to_string(),
            quantity,
            level: self.crosses,
            direction: self.direction,
            action: self.action,
            switch_on,
            switch_off,
        })
    }
}

/// Checks an event's name: 1 to 64 characters of letters, digits, `_`
/// and `-` (it names a row of `events.csv` and a sweep metric's argument).
///
/// # Errors
/// Why the name is not acceptable.
pub fn check_event_name(name: &str) -> Result<(), String> {
    let ok =
        !name.is_empty() && name.len() <= 64 && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
    if ok {
        Ok(())
    } else {
        Err(format!(
            "the event name `{}` must be 1 to 64 letters, digits, `_` or `-`",
            name.escape_default().to_string().chars().take(80).collect::<String>()
        ))
    }
}

/// A function of the user's own, `g(t, q, qd)` (nq each), for
/// [`Quantity::User`]: its sign changes are the events.
pub type EventFn = Arc<dyn Fn(f64, &[f64], &[f64]) -> f64 + Send + Sync>;

/// What an event watches.
#[derive(Clone)]
pub enum Quantity {
    /// The time `t` \[s\].
    Time,
    /// Component `k` of the state `y = [q, qd, W_effects.., W_drives..]`.
    State(usize),
    /// A hinge angle `theta_<hinge>` \[rad\] ([`HingeRef::angle`]).
    HingeAngle(HingeRef),
    /// A hinge rate `theta_<hinge>d` \[rad/s\].
    HingeRate(HingeRef),
    /// Coordinate `axis` (0: x, 1: y) of point `index` of
    /// [`ModelInfo::points`] \[m\] (`A.x`).
    Point {
        /// Index in [`ModelInfo::points`].
        index: usize,
        /// 0 for x, 1 for y.
        axis: usize,
    },
    /// Velocity component `axis` of point `index` \[m/s\] (`A.vx`).
    PointVelocity {
        /// Index in [`ModelInfo::points`].
        index: usize,
        /// 0 for x, 1 for y.
        axis: usize,
    },
    /// The value column of effect `k` (`tau_motor`, `F_drag`).
    EffectValue(usize),
    /// The kinetic energy `T` \[J\].
    KineticEnergy,
    /// A function of the user's own.
    User(EventFn),
}

impl fmt::Debug for Quantity {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Time => f.write_str("Time"),
            Self::State(k) => write!(f, "State({k})"),
            Self::HingeAngle(h) => write!(f, "HingeAngle({h:?})"),
            Self::HingeRate(h) => write!(f, "HingeRate({h:?})"),
            Self::Point { index, axis } => write!(f, "Point({index}, {axis})"),
            Self::PointVelocity { index, axis } => write!(f, "PointVelocity({index}, {axis})"),
            Self::EffectValue(k) => write!(f, "EffectValue({k})"),
            Self::KineticEnergy => f.write_str("KineticEnergy"),
            Self::User(_) => f.write_str("User(..)"),
        }
    }
}

impl Quantity {
    /// The quantity a column name stands for in a run on a model with
    /// `info`, the effects `(name, value column)` and the drives named
    /// `drives` (in the run's order): `t`, a state component (`x1`, `x1d`,
    /// `W_motor`), `theta_<hinge>` and `theta_<hinge>d`, a point's
    /// `<point>.x`, `.y`, `.vx`, `.vy`, an effect's value column
    /// (`tau_motor`), `T`.
    ///
    /// # Errors
    /// A message listing the names the run has.
    pub fn resolve(
        name: &str,
        info: &ModelInfo,
        effects: &[(&str, &str)],
        drives: &[&str],
    ) -> Result<Quantity, String> {
        let mut states: Vec<String> = info.coords.clone();
        states.extend(info.coords.iter().map(|c| crate::names::velocity_name(c)));
        states.extend(effects.iter().map(|(n, _)| crate::names::work_name(n)));
        states.extend(drives.iter().map(|d| crate::names::work_name(d)));
        if let Some(k) = states.iter().position(|s| s == name) {
            return Ok(Quantity::State(k));
        }
        match name {
            "t" => return Ok(Quantity::Time),
            "T" => return Ok(Quantity::KineticEnergy),
            _ => {}
        }
        let hinge = |h: &str| info.hinge_index(h).map(|index| HingeRef::of(info, index));
        if let Some(h) = name.strip_prefix("theta_") {
            if let Some(r) = hinge(h) {
                return Ok(Quantity::HingeAngle(r));
            }
            if let Some(r) = h.strip_suffix('d').and_then(hinge) {
                return Ok(Quantity::HingeRate(r));
            }
        }
        if let Some((p, axis)) = name.rsplit_once('.')
            && let Some(index) = info.point_index(p)
        {
            match axis {
                "x" => return Ok(Quantity::Point { index, axis: 0 }),
                "y" => return Ok(Quantity::Point { index, axis: 1 }),
                "vx" => return Ok(Quantity::PointVelocity { index, axis: 0 }),
                "vy" => return Ok(Quantity::PointVelocity { index, axis: 1 }),
                _ => {}
            }
        }
        if let Some(k) = effects.iter().position(|(_, v)| *v == name) {
            return Ok(Quantity::EffectValue(k));
        }
        let mut known = vec!["t".to_string(), "T".to_string()];
        known.extend(states);
        known.extend(info.hinges.iter().flat_map(|h| [format!("theta_{}", h.name), format!("theta_{}d", h.name)]));
        known.extend(info.points.iter().flat_map(|p| ["x", "y", "vx", "vy"].map(|a| format!("{}.{a}", p.name))));
        known.extend(effects.iter().map(|(_, v)| v.to_string()));
        Err(format!("`{name}` is no quantity of this run; known: {}", crate::names::name_list(known)))
    }
}

/// Why an event cannot watch a skate's friction force `column` (of the
/// skate-friction effect `effect`): the force is set by the skate's mode
/// (its multiplier while it sticks, `mu N` while it slides), which only
/// the right-hand side knows, and it jumps at each switch.
pub fn friction_force_unwatched(column: &str, effect: &str) -> String {
    format!(
        "`{column}` is the friction force of effect `{effect}`, which the skate's mode sets (its constraint force while it sticks, mu N while it slides) and which jumps at each switch: an event cannot watch it; the switches themselves are events of the run (`slip_*`, `stick_*` in events.csv)"
    )
}

/// An event of a run (see the [module](self) documentation).
#[derive(Debug, Clone)]
pub struct Event {
    /// Its name (a row of `events.csv`).
    pub name: String,
    /// What it watches.
    pub quantity: Quantity,
    /// The level whose crossing fires it, in the quantity's unit.
    pub level: f64,
    /// Which crossings fire it.
    pub direction: Direction,
    /// What the run does then.
    pub action: Action,
    /// With [`Action::Switch`]: the effects it turns on (indices into
    /// [`Dynamics::effects`](crate::formulation::dae::Dynamics::effects)).
    pub switch_on: Vec<usize>,
    /// With [`Action::Switch`]: the effects it turns off (indices into
    /// [`Dynamics::effects`](crate::formulation::dae::Dynamics::effects)).
    pub switch_off: Vec<usize>,
}

impl Event {
    /// The event `name` firing when `g(t, q, qd)` (nq each) changes sign
    /// (a function of the user's own), either way, recorded.
    ///
    /// # Errors
    /// A bad name ([`check_event_name`]), as [`SetupError::Event`].
    pub fn from_fn(
        name: &str,
        g: impl Fn(f64, &[f64], &[f64]) -> f64 + Send + Sync + 'static,
    ) -> Result<Event, SimError> {
        check_event_name(name)
            .map_err(|message| SimError::Setup(SetupError::Event { event: name.into(), field: "", message }))?;
        Ok(Event {
            name: name.to_string(),
            quantity: Quantity::User(Arc::new(g)),
            level: 0.0,
            direction: Direction::Either,
            action: Action::Record,
            switch_on: Vec::new(),
            switch_off: Vec::new(),
        })
    }

    /// The same event, firing only on crossings in `direction`.
    #[must_use]
    pub fn direction(mut self, direction: Direction) -> Self {
        self.direction = direction;
        self
    }

    /// The same event with `action`.
    #[must_use]
    pub fn action(mut self, action: Action) -> Self {
        self.action = action;
        self
    }

    /// The same event as a switch ([`Action::Switch`]) that turns the
    /// effects `on` on and the effects `off` off (indices into
    /// [`Dynamics::effects`](crate::formulation::dae::Dynamics::effects); [`Dynamics::effect_index`](crate::formulation::dae::Dynamics::effect_index) finds one by
    /// name). `simulate` checks the indices before the first step.
    #[must_use]
    pub fn switching(mut self, on: &[usize], off: &[usize]) -> Self {
        self.action = Action::Switch;
        self.switch_on = on.to_vec();
        self.switch_off = off.to_vec();
        self
    }
}

/// An event that happened.
#[derive(Debug, Clone, PartialEq)]
pub struct EventRecord {
    /// The event's name.
    pub name: String,
    /// Its time \[s\].
    pub t: f64,
    /// Whether its quantity rose through the level (`false`: fell).
    pub rising: bool,
    /// The state there, `y = [q, qd, W..]` (ny), consistent with the
    /// constraints (projected, or expanded by the reduced formulation).
    pub y: Vec<f64>,
}

/// Accepted steps in a row in each of which one event fired after which
/// the run stops with [`SimError::Chattering`]: a quantity whose motion
/// the steps resolve crosses a level far less often; one that sits at its
/// level within rounding, or switches back at once, does so at every step.
pub const CHATTER_STEPS: u64 = 64;

/// Most bytes of event records a run keeps \[B\] (64 MiB): more events
/// stop the run with [`SimError::EventLimit`] before the memory is taken.
pub const MAX_EVENT_BYTES: usize = 64 << 20;

/// Most event records a run with states of length `ny` keeps
/// ([`MAX_EVENT_BYTES`] over a record's size).
pub fn max_records(ny: usize) -> usize {
    MAX_EVENT_BYTES / (8 * (ny + 2) + 64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn directions() {
        assert_eq!(Direction::Rising.crossing(-1.0, 0.0), Some(true));
        assert_eq!(Direction::Rising.crossing(0.0, 1.0), None);
        assert_eq!(Direction::Rising.crossing(1.0, -1.0), None);
        assert_eq!(Direction::Falling.crossing(1.0, -1.0), Some(false));
        assert_eq!(Direction::Either.crossing(1.0, 0.0), Some(false));
        assert_eq!(Direction::Either.crossing(-2.0, 3.0), Some(true));
        assert_eq!(Direction::Either.crossing(2.0, 3.0), None);
    }

    #[test]
    fn event_names() {
        assert!(check_event_name("ten_metres").is_ok());
        assert!(check_event_name("").is_err());
        assert!(check_event_name("a b").is_err());
        assert!(check_event_name("x\u{1b}[31m").is_err());
        assert!(check_event_name(&"a".repeat(65)).is_err());
    }
}
