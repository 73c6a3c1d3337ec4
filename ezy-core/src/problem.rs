//! A problem: a model with its parameters, the effects acting on it, its
//! drives, initial values by name and the run's settings; solved in
//! memory, without files (as a problem in diffsol or
//! DifferentialEquations.jl).
//!
//! The EzyRoller's `drive` scene (docs/physics.md §10.3), written in Rust:
//!
//! ```
//! use ezy_core::effects::{HingeMotor, Waveform};
//! use ezy_core::{Method, Problem};
//! # ezy_core::model! {
//! #     /// The EzyRoller.
//! #     pub struct EzyRoller {
//! #         param a = 0.2;
//! #         param b = 0.1;
//! #         param c = 0.12;
//! #         param m1 = 1.0;
//! #         param I1 = 0.1;
//! #         param m2 = 0.5;
//! #         param I2 = 0.01;
//! #         body body1(x1, y1, phi1) { mass: m1, inertia: I1 }
//! #         body body2(x2, y2, phi2) { mass: m2, inertia: I2 }
//! #         point A on body1 at (a, 0);
//! #         point B1 on body1 at (-b, 0);
//! #         point B2 on body2 at (c, 0);
//! #         point C on body2 at (0, 0);
//! #         hinge B: B1 = B2;
//! #         skate A: A along (1, 0);
//! #         skate C: C along (1, 0);
//! #     }
//! # }
//!
//! # fn main() -> Result<(), ezy_core::SimError> {
//! let motor = HingeMotor { hinge: "B".into(), torque: Waveform::cos(2.0, std::f64::consts::PI) };
//! let solution = Problem::new(EzyRoller::default())
//!     .effect("motor", motor)?
//!     .q("x1", 0.0)?
//!     .q("y1", 0.0)?
//!     .q("phi1", 0.0)?
//!     .q("phi2", 3.0)?
//!     .qd("x1", 0.0)?
//!     .qd("phi1", 0.0)?
//!     .t_end(2.0)
//!     .method(Method::Dop853)
//!     .tolerances(1e-9, 1e-9)
//!     .solve()?;
//! let x1 = solution.column("x1").expect("a coordinate");
//! println!("x1({}) = {} m", solution.t.last().unwrap(), x1.last().unwrap());
//! # assert_eq!(solution.t.len(), x1.len());
//! # Ok(())
//! # }
//! ```

use crate::drive::Drive;
use crate::effects::Effect;
use crate::effects::context::EffectContext;
use crate::effects::kind::resolve_kind;
use crate::effects::kind::{EffectKind, ForceLaw};
use crate::effects::law::Law;
use crate::effects::registry::EffectSpec;
use crate::effects::waveform::Waveform;
use crate::error::SetupError;
use crate::error::SimError;
use crate::events::spec::{Event, EventSpec};
use crate::formulation::dae::{Baumgarte, Dynamics};
use crate::formulation::initial::{Given, InitialReport, consistent_state_given};
use crate::kkt::KktMethod;
use crate::model::Model;
use crate::model::info::{ModelInfo, NameIndex};
use crate::names::fmt_value;
use crate::settings::RunSettings;
use crate::settings::{Formulation, Method, ProjectionKind};
use crate::simulate::observer::{Observer, RunError, Sample, Summary};
use crate::simulate::simulate;

/// A model with its effects, drives, initial values and settings: what a
/// run integrates. Build it in Rust ([`Problem::new`] and the builder
/// methods) or from a scene file (`Scene::problem`, crate `ezy-scene`); solve it in memory
/// ([`Problem::solve`]) or with an observer of your own
/// ([`Problem::solve_with`]).
#[derive(Debug, Clone)]
pub struct Problem<M: Model> {
    /// The model, its parameters fixed for the run.
    pub model: M,
    /// The effects, resolved against the model.
    pub effects: Vec<Effect>,
    /// The model's drives with their prescribed angles.
    pub drives: Vec<Drive>,
    /// The initial values given (the rest is solved for consistency).
    pub given: Given,
    /// Duration, method, tolerances, projection, formulation.
    pub settings: RunSettings,
    /// Baumgarte stabilization (`None`: projection only).
    pub baumgarte: Option<Baumgarte>,
    /// How the KKT system is solved.
    pub kkt: KktMethod,
    /// The events the run locates, records or stops at ([`crate::events`]).
    pub events: Vec<Event>,
    /// The most memory [`Problem::solve`] keeps its samples in \[MB\]
    /// (default [`DEFAULT_MAX_MEMORY_MB`]); [`Problem::solve_with`] leaves
    /// the samples to its observer and has none.
    pub max_output_mb: f64,
}

/// The default of [`Problem::max_output_mb`] \[MB\] (as `ezy run`'s output
/// budget).
pub const DEFAULT_MAX_MEMORY_MB: f64 = 1000.0;

/// The result of [`Problem::solve`]: the samples in memory.
#[derive(Debug, Clone)]
pub struct Solution {
    /// Times of the samples \[s\]: 0, every output interval, the end.
    pub t: Vec<f64>,
    /// Names of the state components `y = [q, qd, W_effects.., W_drives..]`
    /// (`x1`, `x1d`, `W_motor`): the columns of [`Solution::y`].
    pub names: Vec<String>,
    /// The state at each sample, one row of `names.len()` values per time.
    pub y: Vec<Vec<f64>>,
    /// Kinetic energy at each sample \[J\].
    pub kinetic_energy: Vec<f64>,
    /// The step loop's summary (steps, evaluations, residuals, balance).
    pub summary: Summary,
    /// What the initial-condition solve had to correct.
    pub initial: InitialReport,
}

impl Solution {
    /// The values of the state component `name` over time (one per
    /// [`Solution::t`]); `None` for a name the state does not have.
    pub fn column(&self, name: &str) -> Option<Vec<f64>> {
        let k = self.names.iter().position(|n| n == name)?;
        Some(self.y.iter().map(|row| row[k]).collect())
    }

    /// The final state, in the order of [`Solution::names`].
    pub fn final_state(&self) -> &[f64] {
        &self.summary.final_state
    }
}

/// Collects the samples of a run in memory.
struct Collect {
    t: Vec<f64>,
    y: Vec<Vec<f64>>,
    kinetic_energy: Vec<f64>,
}

impl<M: Model> Observer<M> for Collect {
    type Error = std::convert::Infallible;
    fn observe(&mut self, _sys: &Dynamics<M>, s: &Sample<'_>) -> Result<(), Self::Error> {
        self.t.push(s.t);
        let mut row = Vec::with_capacity(2 * s.q.len() + s.works.len());
        row.extend_from_slice(s.q);
        row.extend_from_slice(s.qd);
        row.extend_from_slice(s.works);
        self.y.push(row);
        self.kinetic_energy.push(s.kinetic_energy);
        Ok(())
    }
}

/// The index of `name` in `names`, the model's names of a `kind`
/// (`"parameter"`, `"drive"`).
///
/// # Errors
/// [`SetupError::UnknownName`] listing `names`.
pub fn lookup<S: AsRef<str>>(info: &ModelInfo, kind: &'static str, name: &str, names: &[S]) -> Result<usize, SimError> {
    names.iter().position(|n| n.as_ref() == name).ok_or_else(|| {
        SimError::Setup(SetupError::UnknownName {
            kind,
            name: name.into(),
            model: info.name,
            known: crate::names::name_list(names),
        })
    })
}

/// Refuses a model parameter (a length, a mass, an inertia; not a family
/// count, which [`Model::check_counts`] checks) that is not finite or
/// whose magnitude passes [`crate::settings::MAX_MAGNITUDE`] (1e34: see there; a
/// length of 1e300 m overflowed the KKT system at t = 0, a mass of 1e150
/// kg under gravity collapsed the first step).
///
/// # Errors
/// [`SetupError::Scene`] at `params.NAME`, naming the parameter, its value
/// and why.
pub fn check_params<M: Model>(model: &M, info: &ModelInfo) -> Result<(), SimError> {
    for (k, p) in info.params.iter().enumerate().filter(|(_, p)| !p.count) {
        let what = if p.unit.is_empty() { p.name.to_string() } else { format!("{} [{}]", p.name, p.unit) };
        crate::settings::check_magnitude(&what, model.param(k))
            .map_err(|message| SimError::Setup(SetupError::Scene { key: format!("params.{}", p.name), message }))?;
    }
    Ok(())
}

/// Refuses a mass diagonal with a negative, non-finite, vanishing-but-
/// nonzero or huge (past [`crate::settings::MAX_MAGNITUDE`]) entry, and a massless
/// part in a model too large for the dense LU path of the KKT matrix.
///
/// # Errors
/// [`SetupError::Setting`] naming the mass entry (`m1`, `I1`) and why.
pub fn check_masses<M: Model>(model: &M, info: &ModelInfo) -> Result<(), SimError> {
    let mut mass = vec![0.0; info.nq()];
    model.mass_diagonal(&mut mass);
    for (k, &m) in mass.iter().enumerate() {
        let reason = if !m.is_finite() || m < 0.0 {
            Some("must be a finite number, zero or positive")
        } else if m > crate::settings::MAX_MAGNITUDE {
            Some(
                "is out of range: ezy takes masses and inertias up to 1e34 (the energies and powers formed from a larger one overflow double precision)",
            )
        } else if m > 0.0 && !(1.0 / m).is_finite() {
            Some("is so small that its reciprocal overflows: give 0 for a massless body, or at least 1e-300")
        } else {
            None
        };
        if let Some(reason) = reason {
            return Err(SimError::Setup(SetupError::Setting { name: info.mass_entry_name(k), value: m, reason }));
        }
    }
    // a massless part takes the dense LU path of the whole KKT matrix,
    // O((nq + nc)^3) per right-hand side: refused for a large family
    if info.nq() + info.nc() > crate::kkt::DENSE_LU_MAX_ROWS
        && let Some(k) = mass.iter().position(|&m| m == 0.0)
    {
        return Err(SimError::Setup(SetupError::Setting {
            name: info.mass_entry_name(k),
            value: mass[k],
            reason: "a massless part needs the dense LU path of the KKT matrix, which ezy takes up to 1000 rows (nq + nc): this model has more; give every body a positive mass and inertia",
        }));
    }
    Ok(())
}

/// Which coordinates (or hinge) an initial value's name gives: a
/// coordinate, `stem*` for every coordinate of a family, or `theta_<hinge>`.
///
/// # Errors
/// [`SetupError::UnknownName`] listing the model's coordinates.
pub fn initial_targets(info: &ModelInfo, name: &str) -> Result<crate::model::info::InitialName, SimError> {
    info.initial_name(name).ok_or_else(|| lookup(info, "coordinate", name, &info.coords).expect_err("not a coordinate"))
}

impl<M: Model> Problem<M> {
    /// `model` at its parameter values, without effects or initial values,
    /// with the default settings ([`RunSettings::default`]: one second).
    pub fn new(model: M) -> Self {
        Self {
            model,
            effects: Vec::new(),
            drives: Vec::new(),
            given: Given::default(),
            settings: RunSettings::default(),
            baumgarte: None,
            kkt: KktMethod::Auto,
            events: Vec::new(),
            max_output_mb: DEFAULT_MAX_MEMORY_MB,
        }
    }

    /// Sets the memory [`Problem::solve`] may keep its samples in \[MB\]:
    /// a run whose samples (one every `every` to `t_end`) would take more
    /// is refused before it starts.
    pub fn max_output_mb(mut self, mb: f64) -> Self {
        self.max_output_mb = mb;
        self
    }

    fn check_effect_name(&self, name: &str) -> Result<(), SimError> {
        crate::effects::registry::check_effect_name(name)
            .map_err(|message| SimError::Setup(SetupError::Scene { key: format!("effects.{name}"), message }))?;
        if self.effects.iter().any(|e| e.name == name) {
            return Err(SimError::Setup(SetupError::Scene {
                key: format!("effects.{name}"),
                message: format!("an effect called `{name}` is already given"),
            }));
        }
        Ok(())
    }

    /// Adds the effect `spec` (a built-in kind, or one of the user's own
    /// bound to its kind) as `name`, resolved against the model at its
    /// current parameters (set them first).
    ///
    /// # Errors
    /// [`SetupError::Scene`] for a bad or repeated name; [`SetupError::Effect`]
    /// for a name the model does not have or a bad number in `spec`.
    pub fn effect(mut self, name: &str, spec: impl Into<EffectSpec>) -> Result<Self, SimError> {
        self.check_effect_name(name)?;
        let effect = spec.into().resolve(name, &self.model)?;
        self.effects.push(effect);
        Ok(self)
    }

    /// Adds an effect of a kind of the user's own ([`EffectKind`]) as
    /// `name`, resolved against the model at its current parameters: what
    /// a scene's `[effects.NAME] kind = "..."` table of that kind gives,
    /// in Rust (its value column takes [`EffectKind::VALUE_PREFIX`]).
    ///
    /// # Errors
    /// [`SetupError::Scene`] for a bad or repeated name; [`SetupError::Effect`]
    /// with the field the kind's [`EffectKind::resolve`] refuses.
    pub fn kind<T: EffectKind>(mut self, name: &str, spec: &T) -> Result<Self, SimError> {
        self.check_effect_name(name)?;
        let info = self.model.info();
        let names = NameIndex::new(&info);
        let cx = EffectContext::new(&self.model, &names);
        let law = resolve_kind(spec, &cx).map_err(|e| {
            SimError::Setup(SetupError::Effect { effect: name.to_string(), field: e.field, message: e.message })
        })?;
        let law = Law::checked(name, law, cx.nq())?;
        self.effects.push(Effect {
            name: name.to_string(),
            value_column: format!("{}_{name}", T::VALUE_PREFIX),
            law,
            on: true,
        });
        Ok(self)
    }

    /// Adds a force law of the user's own as effect `name`: its work state
    /// `W_<name>` integrates the power it returns.
    ///
    /// # Errors
    /// [`SetupError::Scene`] for a bad or repeated name; [`SetupError::Effect`]
    /// for a coordinate index in [`ForceLaw::coords`] beyond nq.
    pub fn law(mut self, name: &str, law: impl ForceLaw) -> Result<Self, SimError> {
        self.check_effect_name(name)?;
        let law = Law::checked(name, law.into_law(), self.model.info().nq())?;
        self.effects.push(Effect { name: name.to_string(), value_column: format!("F_{name}"), law, on: true });
        Ok(self)
    }

    /// Adds a closure as a feedback controller named `name`
    /// ([`crate::effects::kind::Controller`]): `law(t, q, qd, f)` adds its
    /// generalized force into `f` (nq) and returns its value column's
    /// value; it reads and writes only the entries `coords` (indices
    /// into `q`).
    ///
    /// # Errors
    /// As [`Problem::law`].
    pub fn controller<F>(self, name: &str, coords: Vec<usize>, law: F) -> Result<Self, SimError>
    where
        F: Fn(f64, &[f64], &[f64], &mut [f64]) -> f64 + Send + Sync + 'static,
    {
        self.law(name, crate::effects::kind::Controller::new(coords, law))
    }

    /// Adds the event `name` watching a quantity of the run by its column
    /// name (`spec.when`: `x1`, `theta_B`, `A.vy`, `tau_motor`, `T`, `t`;
    /// [`crate::events::spec::Quantity::resolve`]): located on the dense output,
    /// recorded in [`Summary::events`], and the run's end if its action
    /// is [`crate::events::spec::Action::Stop`]. Add the effects and drives it
    /// names first.
    ///
    /// # Errors
    /// [`SetupError::Event`] for a quantity the run does not have, a level
    /// that is not finite, a bad or repeated name.
    pub fn event(self, name: &str, spec: &EventSpec) -> Result<Self, SimError> {
        let info = self.model.info();
        let event = spec.resolve(name, &info, &self.effects, &self.drives)?;
        self.with_event(event)
    }

    /// Adds an event built in Rust ([`Event::from_fn`]: a function
    /// `g(t, q, qd)` of the user's own whose sign changes are the events).
    ///
    /// # Errors
    /// [`SetupError::Event`] for a repeated name.
    pub fn with_event(mut self, event: Event) -> Result<Self, SimError> {
        crate::events::spec::check_event_name(&event.name)
            .map_err(|message| SimError::Setup(SetupError::Event { event: event.name.clone(), field: "", message }))?;
        if self.events.iter().any(|e| e.name == event.name) {
            return Err(SimError::Setup(SetupError::Event {
                event: event.name.clone(),
                field: "",
                message: "an event of this name is already given".into(),
            }));
        }
        self.events.push(event);
        Ok(self)
    }

    /// Prescribes the angle of the model's drive `name` \[rad\].
    ///
    /// # Errors
    /// [`SetupError::UnknownName`] listing the model's drives; a bad waveform.
    pub fn drive(mut self, name: &str, angle: Waveform) -> Result<Self, SimError> {
        let info = self.model.info();
        let names: Vec<&str> = info.drives.iter().map(|d| d.name.as_str()).collect();
        let k = lookup(&info, "drive", name, &names)?;
        angle.validate().map_err(|reason| {
            SimError::Setup(SetupError::Scene { key: format!("drives.{name}.angle"), message: reason })
        })?;
        self.drives.retain(|d| d.name != name);
        self.drives.push(Drive { name: name.to_string(), row: info.drives[k].row, angle });
        // in the model's order, as the work states are
        let order = |d: &Drive| names.iter().position(|n| *n == d.name);
        self.drives.sort_by_key(order);
        Ok(self)
    }

    /// Gives the initial value of coordinate `name` (or of every
    /// coordinate of a family, `stem*`, or the hinge angle `theta_<hinge>`)
    /// \[m or rad\]; a later value overrides an earlier one.
    ///
    /// # Errors
    /// [`SetupError::UnknownName`] listing the model's coordinates.
    pub fn q(mut self, name: &str, value: f64) -> Result<Self, SimError> {
        let info = self.model.info();
        match initial_targets(&info, name)? {
            crate::model::info::InitialName::Coords(ks) => {
                ks.into_iter().for_each(|k| set(&mut self.given.q, k, value))
            }
            crate::model::info::InitialName::HingeAngle(h) => set(&mut self.given.angles, h, value),
        }
        Ok(self)
    }

    /// Gives the initial velocity of coordinate `name` (or `stem*`)
    /// \[m/s or rad/s\].
    ///
    /// # Errors
    /// [`SetupError::UnknownName`] listing the model's coordinates.
    pub fn qd(mut self, name: &str, value: f64) -> Result<Self, SimError> {
        let info = self.model.info();
        match initial_targets(&info, name)? {
            crate::model::info::InitialName::Coords(ks) => {
                ks.into_iter().for_each(|k| set(&mut self.given.qd, k, value))
            }
            crate::model::info::InitialName::HingeAngle(_) => {
                return Err(SimError::Setup(SetupError::Scene {
                    key: format!("initial.qd.{name}"),
                    message: "a hinge angle is given in positions only".into(),
                }));
            }
        }
        Ok(self)
    }

    /// Duration \[s\].
    #[must_use]
    pub fn t_end(mut self, t_end: f64) -> Self {
        self.settings.t_end = t_end;
        self
    }

    /// Integration method.
    #[must_use]
    pub fn method(mut self, method: Method) -> Self {
        self.settings.method = method;
        self
    }

    /// Relative and absolute tolerance of the adaptive methods.
    #[must_use]
    pub fn tolerances(mut self, rtol: f64, atol: f64) -> Self {
        self.settings.rtol = rtol;
        self.settings.atol = atol;
        self
    }

    /// Step size of the fixed-step methods \[s\].
    #[must_use]
    pub fn dt(mut self, dt: f64) -> Self {
        self.settings.dt = dt;
        self
    }

    /// Output interval \[s\].
    #[must_use]
    pub fn every(mut self, every: f64) -> Self {
        self.settings.every = every;
        self
    }

    /// Projection after every step.
    #[must_use]
    pub fn projection(mut self, projection: ProjectionKind) -> Self {
        self.settings.projection = projection;
        self
    }

    /// The DAE or the reduced formulation.
    #[must_use]
    pub fn formulation(mut self, formulation: Formulation) -> Self {
        self.settings.formulation = formulation;
        self
    }

    /// How the KKT system is solved (default [`KktMethod::Auto`]).
    #[must_use]
    pub fn kkt(mut self, kkt: KktMethod) -> Self {
        self.kkt = kkt;
        self
    }

    /// Names of the state components `y = [q, qd, W_effects..,
    /// W_drives..]` (as [`Dynamics::state_name`] gives them).
    pub fn state_names(&self) -> Vec<String> {
        crate::formulation::dae::state_names(&self.model.info().coords, &self.effects, &self.drives)
    }

    /// The consistent initial state `y0 = [q, qd, W = 0 ...]` and what
    /// the solve had to correct.
    ///
    /// # Errors
    /// [`SetupError::Scene`] at `params.NAME` for a model parameter out of
    /// range ([`check_params`]); [`SetupError::Setting`] for a bad mass;
    /// [`SetupError::Scene`] for a drive without an angle or one that is not
    /// smooth over the run
    /// ([`crate::drive::check_angle`]); [`SetupError::Effect`] for an
    /// effect's table that ends within the run ([`crate::effects::ForceLaw::span`]);
    /// [`SetupError::Initial`] if no consistent
    /// state is near the given one.
    pub fn initial_state(&self) -> Result<(Vec<f64>, InitialReport), SimError> {
        let info = self.model.info();
        check_params(&self.model, &info)?;
        check_masses(&self.model, &info)?;
        check_given(&info, &self.given)?;
        if let Some(missing) = info.drives.iter().find(|d| !self.drives.iter().any(|g| g.name == d.name)) {
            return Err(SimError::Setup(SetupError::Scene {
                key: "drives".into(),
                message: format!(
                    "model {} drives hinge `{}` by `{}`: give its angle",
                    info.name, info.hinges[missing.hinge].name, missing.name
                ),
            }));
        }
        for d in &self.drives {
            crate::drive::check_angle(&d.angle, self.settings.t_end).map_err(|message| {
                SimError::Setup(SetupError::Scene { key: format!("drives.{}.angle", d.name), message })
            })?;
        }
        crate::simulate::check_spans(&self.effects, self.settings.t_end)?;
        // skates with friction may start sliding: their rows are left out
        // of the velocity solve where the given values determine the
        // velocities without them (else every row holds: they stick)
        let released: Vec<usize> = self
            .effects
            .iter()
            .filter_map(|e| match e.law {
                crate::effects::law::Law::SkateFriction(ref fr) => Some(info.skates[fr.skate].row),
                _ => None,
            })
            .collect();
        let free = (!released.is_empty())
            .then(|| {
                let given = Given { released, ..self.given.clone() };
                consistent_state_given(&self.model, &self.drives, &given).ok()
            })
            .flatten();
        let (q, qd, report) = match free {
            Some(state) => state,
            None => consistent_state_given(&self.model, &self.drives, &self.given)?,
        };
        let mut y0 = q;
        y0.extend_from_slice(&qd);
        y0.resize(y0.len() + self.effects.len() + self.drives.len(), 0.0);
        Ok((y0, report))
    }

    /// The right-hand side (model, effects, drives, KKT path, Baumgarte)
    /// and the consistent initial state: what [`simulate`] integrates.
    ///
    /// # Errors
    /// As [`Problem::initial_state`]; [`SetupError::Setting`] for Baumgarte
    /// rates the run cannot take (not finite, negative, past
    /// [`crate::settings::MAX_RATE`], or past a fixed step's stability
    /// limit); [`SetupError::Effect`] for an effect a fixed step cannot
    /// follow ([`Problem::check_fixed_step`]).
    pub fn into_system(self) -> Result<(Dynamics<M>, Vec<f64>, InitialReport), SimError> {
        self.check_forcing()?;
        let settings = self.settings;
        let (mut sys, y0, report) = self.into_parts()?;
        check_slides(&mut sys, &y0, &settings)?;
        Ok((sys, y0, report))
    }

    /// [`Problem::into_system`] without the checks of the run's step
    /// against the effects: for the analyses, which do not step.
    fn into_parts(self) -> Result<(Dynamics<M>, Vec<f64>, InitialReport), SimError> {
        self.check_counts()?;
        self.check_baumgarte()?;
        let (y0, report) = self.initial_state()?;
        let mut sys =
            Dynamics::new(self.model, self.effects, self.kkt).with_drives(self.drives).with_events(self.events);
        sys.baumgarte = self.baumgarte;
        Ok((sys, y0, report))
    }

    /// Refuses Baumgarte rates the run cannot take: not finite or
    /// negative, faster than [`crate::settings::MAX_RATE`] (no step follows them), or,
    /// for a fixed-step method, past its stability limit. The drift `C` of
    /// the constraints obeys `C'' + 2 alpha C' + beta^2 C = 0`, whose
    /// eigenvalues `-alpha +- sqrt(alpha^2 - beta^2)` are at most
    /// `max(2 alpha, beta)` in magnitude; explicit Euler is stable on the
    /// negative real axis up to `h |lambda| = 2`, RK4 up to 2.785 (Hairer &
    /// Wanner II, §IV.2): past that each step multiplies the drift it should
    /// damp (measured on `drive`, RK4 at h = 1e-4 s without projection:
    /// alpha = beta = 1e4 (h |lambda| = 2) keeps |C| at 6e-13 m, 1e5 broke
    /// the energy balance, 1e300 overflowed the KKT system at t = 5e-5 s).
    fn check_baumgarte(&self) -> Result<(), SimError> {
        let Some(Baumgarte { alpha, beta }) = self.baumgarte else { return Ok(()) };
        let name = |which: &str| format!("{} {which}", crate::settings::Setting::Baumgarte);
        for (which, v) in [("alpha", alpha), ("beta", beta)] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(SimError::Setup(SetupError::Setting {
                    name: name(which),
                    value: v,
                    reason: "must be a finite rate >= 0 [1/s]",
                }));
            }
            if v > crate::settings::MAX_RATE {
                return Err(SimError::Setup(SetupError::Setting {
                    name: name(which),
                    value: v,
                    reason: "is faster than any step can follow: ezy takes rates up to 2.8e14 1/s (a decay within the rounding level of t, 16 eps t, the shortest step)",
                }));
            }
        }
        let limit = match self.settings.method {
            Method::Euler => 2.0,
            Method::Rk4 => 2.785,
            _ => return Ok(()),
        };
        let (which, value) = if 2.0 * alpha >= beta { ("alpha", alpha) } else { ("beta", beta) };
        if (2.0 * alpha).max(beta) * self.settings.dt > limit {
            return Err(SimError::Setup(SetupError::Setting {
                name: name(which),
                value,
                reason: "the drift's fastest rate, max(2 alpha, beta), times the step dt passes the fixed-step method's stability limit (2 for euler, 2.785 for rk4): the stabilization would amplify the drift it should damp; give smaller rates, a smaller step or an adaptive method",
            }));
        }
        Ok(())
    }

    /// Refuses, for a fixed-step method (RK4, Euler), an effect its step
    /// cannot follow, before any work: a forcing past the step's Nyquist
    /// frequency, and a skate whose friction stops the slide the run starts
    /// with faster than the step can follow (the slide's stopping rate at the start). The
    /// adaptive methods choose their steps and are not checked.
    ///
    /// # Errors
    /// [`SetupError::Effect`] naming the effect, the rate or frequency,
    /// the step and the step that would do; as
    /// [`Problem::into_system`] where a skate with friction makes the
    /// check solve for the initial state.
    pub fn check_fixed_step(&self) -> Result<(), SimError> {
        self.check_forcing()?;
        let friction = self.effects.iter().any(|e| matches!(e.law, Law::SkateFriction(_)));
        if self.settings.method.is_adaptive() || !friction {
            return Ok(());
        }
        let (mut sys, y0, _) = self.clone().into_parts()?;
        check_slides(&mut sys, &y0, &self.settings)
    }

    /// A forcing of angular frequency `omega` with `omega dt > pi` under a
    /// fixed step (fewer than two steps per period: the samples the stages
    /// take of it alias it to a slower forcing, and the run goes on as if
    /// driven by that one; Nyquist): an effect's, or a drive's prescribed
    /// angle's.
    fn check_forcing(&self) -> Result<(), SimError> {
        let method = self.settings.method;
        if method.is_adaptive() {
            return Ok(());
        }
        // the step the run takes (a run shorter than dt is one step)
        let dt = self.settings.dt.min(self.settings.t_end);
        let pi = std::f64::consts::PI;
        let effects = self.effects.iter().map(|e| (e.forcing_omega(), Some(e.name.as_str()), "its forcing"));
        let drives = self.drives.iter().map(|d| (d.angle.max_omega(), None, d.name.as_str()));
        for (omega, effect, drive) in effects.chain(drives) {
            if omega * dt <= pi {
                continue;
            }
            let what = if effect.is_some() {
                "its forcing".to_string()
            } else {
                format!("drive `{drive}`'s prescribed angle")
            };
            let message = format!(
                "{what}'s angular frequency omega = {} rad/s times the fixed step dt = {} s of {} is {}, past pi: fewer than two steps per period (Nyquist), so {} samples the forcing as a slower one and the run follows that one instead; give {} below pi / omega = {} s (20 steps per period: {} s) or an adaptive method ({})",
                fmt_value(omega),
                if dt < self.settings.dt {
                    // the step asked, longer than the run, which is one step
                    format!("{} (the whole run: {dt})", fmt_value(self.settings.dt))
                } else {
                    fmt_value(dt)
                },
                method.name(),
                fmt_value(round3(omega * dt)),
                method.name(),
                crate::settings::Setting::Dt,
                fmt_value(round3(pi / omega)),
                fmt_value(round3(2.0 * pi / (20.0 * omega))),
                crate::settings::Setting::Method(Method::Dop853)
            );
            return Err(SimError::Setup(match effect {
                Some(name) => SetupError::Effect { effect: name.to_string(), field: "omega", message },
                None => SetupError::Scene { key: format!("drives.{drive}.angle"), message },
            }));
        }
        Ok(())
    }

    /// The model's family counts checked before anything is set up at
    /// them ([`Model::check_counts`]: elements that exist, names that
    /// differ, at most [`crate::model::info::MAX_COORDS`] coordinates).
    fn check_counts(&self) -> Result<(), SimError> {
        self.model
            .check_counts()
            .map_err(|message| SimError::Setup(SetupError::Scene { key: "params".into(), message }))
    }

    /// The problem's right-hand side ready for the analyses
    /// (linearization, steady motions, periodic orbits) and its consistent
    /// initial state `[q, qd]` (2 nq).
    ///
    /// # Errors
    /// As [`Problem::into_system`]; the right-hand side's failure at the
    /// initial state (a singular KKT matrix: a massless body), with its
    /// cause ([`SimError::with_cause`]).
    pub fn analysis(self) -> Result<(crate::analysis::Analysis<M>, Vec<f64>), SimError> {
        let (mut sys, mut y0, _) = self.into_parts()?;
        // the right-hand side once at the start, as a run's first step
        // takes it: a singular KKT matrix (a massless body) is refused
        // naming its cause, before an analysis differentiates through it
        // (linearizing the sleigh at m = 0 ended in "the eigenvalue
        // iteration did not converge")
        let mut dy = vec![0.0; y0.len()];
        sys.rhs(0.0, &y0, &mut dy).map_err(|e| e.with_cause(&sys.mass, |k| sys.info.mass_entry_name(k)))?;
        y0.truncate(2 * sys.nq());
        Ok((crate::analysis::Analysis::new(sys), y0))
    }

    /// Integrates the problem and keeps every output sample in memory.
    ///
    /// # Errors
    /// As [`Problem::initial_state`]; [`SetupError::Scene`] at `params`
    /// when the model's family counts are not well formed or give more
    /// than [`crate::model::info::MAX_COORDS`] coordinates; [`SimError::Budget`] before
    /// any work when the samples would take more than
    /// [`Problem::max_output_mb`]; the [`SimError`] that stopped the run
    /// (a bad setting, a singular position the method cannot pass, a step
    /// budget spent, a diverging run).
    pub fn solve(self) -> Result<Solution, SimError> {
        self.check_counts()?;
        let names = self.state_names();
        // each sample: its time, its kinetic energy, a row of the state
        let rows = self.settings.output_rows();
        let mb = rows * (8.0 * names.len() as f64 + 40.0) / 1e6;
        if mb.is_nan() || self.max_output_mb.is_nan() || mb > self.max_output_mb {
            return Err(SimError::Budget {
                what: "MB of samples in memory",
                estimate: mb,
                limit: self.max_output_mb,
                setting: crate::settings::Setting::MaxOutputMb,
                detail: format!("{rows:.2e} samples of {} values to t_end = {} s", names.len(), {
                    let t = self.settings.t_end;
                    if (1e-3..1e6).contains(&t.abs()) { format!("{t}") } else { format!("{t:e}") }
                })
                .replace(".00e", "e"),
            });
        }
        let mut out = Collect { t: Vec::new(), y: Vec::new(), kinetic_energy: Vec::new() };
        let (summary, initial) = self.solve_with(&mut out).map_err(|e| match e {
            RunError::Sim(e) => e,
            RunError::Output(never) => match never {},
        })?;
        Ok(Solution { t: out.t, names, y: out.y, kinetic_energy: out.kinetic_energy, summary, initial })
    }

    /// Integrates the problem, showing every output sample to `observer`.
    ///
    /// # Errors
    /// As [`Problem::solve`], or the observer's error.
    pub fn solve_with<O: Observer<M>>(self, observer: &mut O) -> Result<(Summary, InitialReport), RunError<O::Error>> {
        let settings = self.settings;
        let (mut sys, y0, initial) = self.into_system()?;
        let summary = simulate(&mut sys, &y0, &settings, observer).map_err(|e| match e {
            RunError::Sim(e) => RunError::Sim(sys.explain(e, &settings)),
            e => e,
        })?;
        Ok((summary, initial))
    }
}

/// Sets entry `k` of a list of `(index, value)` pairs.
/// The given initial values checked ([`ModelInfo::check_initial`]): a
/// heading or hinge angle past [`crate::settings::MAX_ANGLE`] (whose
/// rounding would swamp the run's turning: the sleigh started at 1e17 rad
/// did not turn).
fn check_given(info: &ModelInfo, given: &Given) -> Result<(), SimError> {
    use crate::model::info::InitialName;
    let coords = [("q", &given.q), ("qd", &given.qd), ("guess", &given.guess)];
    let hinges = given
        .angles
        .iter()
        .map(|&(h, v)| ("q", InitialName::HingeAngle(h), format!("theta_{}", info.hinges[h].name), v));
    let all = coords
        .into_iter()
        .flat_map(|(g, list)| {
            list.iter().map(move |&(k, v)| (g, InitialName::Coords(vec![k]), info.coords[k].clone(), v))
        })
        .chain(hinges);
    for (group, target, name, v) in all {
        info.check_initial(group, &target, &name, v).map_err(|message| {
            SimError::Setup(SetupError::Scene { key: format!("initial.{group}.{name}"), message })
        })?;
    }
    Ok(())
}

fn set(list: &mut Vec<(usize, f64)>, k: usize, value: f64) {
    match list.iter_mut().find(|(j, _)| *j == k) {
        Some((_, v)) => *v = value,
        None => list.push((k, value)),
    }
}

/// RK4's stability bound on the negative real axis, `h |lambda| <=
/// 2.785` (Hairer & Wanner II, §IV.2); explicit Euler's is 2.
const RK4_BOUND: f64 = 2.785;

/// Refuses, under a fixed step, a skate with friction that starts the run
/// sliding at `v` and whose friction `mu N` stops that slide at the rate
/// `mu N (G M^-1 G^T) / |v|` ([`Dynamics::slide_rates_at`]) faster than the
/// method is stable: rate times `dt` past 2.785 for RK4, 2 for Euler. The
/// friction is not regularized: a sliding skate's row is released and the
/// force `mu N` switches off where the slip returns to zero, located on the
/// step's continuous extension; a step far longer than the slide carries
/// every stage's force `mu N` past the stop (measured on `sleigh-ice` at dt
/// = 1e-4 s, a slide of 2 m/s: `max |T - T0 - W|` 2.6e-9 J at mu = 1e3,
/// rate dt 0.5; 1.7e-5 J at 1e4, rate dt 5; 1.6e3 J at 1e6). A skate that
/// starts holding (slip within rounding of the velocities) is not checked:
/// friction no force reaches changes nothing of a fixed-step run.
fn check_slides<M: Model>(sys: &mut Dynamics<M>, y0: &[f64], settings: &RunSettings) -> Result<(), SimError> {
    let bound = match settings.method {
        Method::Rk4 => RK4_BOUND,
        Method::Euler => 2.0,
        _ => return Ok(()),
    };
    if sys.friction.is_empty() {
        return Ok(());
    }
    let nq = sys.nq();
    let floor = 1e-10 * crate::formulation::projection::max_abs(&y0[nq..2 * nq]).max(1.0);
    let rates = sys.slide_rates_at(0.0, y0)?;
    let dt = settings.dt.min(settings.t_end);
    for (fr, &(slip, rate)) in sys.friction.iter().zip(&rates) {
        if slip.abs() > floor && rate * dt > bound {
            return Err(SimError::Setup(SetupError::Effect {
                effect: sys.effects[fr.effect].name.clone(),
                field: "mu",
                message: format!(
                    "skate `{}` starts sliding at {} m/s against its friction mu N = {} N, which stops the slide within {} s: the rate mu N (G M^-1 G^T) / |v| = {} 1/s times the fixed step dt = {} s of {} is {}, past the method's stability bound {bound} on the real axis, so its stages carry the friction far past the stop and the energy ledger breaks; give {} below {} s or an adaptive method ({})",
                    fr.name,
                    fmt_value(round3(slip.abs())),
                    fmt_value(round3(fr.limit)),
                    fmt_value(round3(1.0 / rate)),
                    fmt_value(round3(rate)),
                    fmt_value(dt),
                    settings.method.name(),
                    fmt_value(round3(rate * dt)),
                    crate::settings::Setting::Dt,
                    fmt_value(round3(bound / rate)),
                    crate::settings::Setting::Method(Method::Dop853)
                ),
            }));
        }
    }
    Ok(())
}

/// `v` to three significant digits (a bound or a product a message
/// quotes).
fn round3(v: f64) -> f64 {
    format!("{v:.2e}").parse().unwrap_or(v)
}
