//! Run settings and the limits every input is checked against (it
//! imports only [`crate::names`]). What a run is asked to do
//! ([`RunSettings`]: method, formulation, projection, step, tolerances,
//! budgets), the named values a scene file and the command
//! line spell by [`Choice::name`], and the largest magnitudes, rates and
//! angles ezy takes ([`MAX_MAGNITUDE`], [`MAX_RATE`], [`MAX_ANGLE`]).

use std::cell::Cell;

use crate::names::{fmt_value, name_list};

/// A setting with a few named values (the integrator, the projection,
/// the formulation): one list that scene files, the command line and
/// reports share. Scene files spell each value by [`Choice::name`]
/// (serde), the command line offers [`Choice::ALL`] with
/// [`Choice::help`].
pub trait Choice: Copy + PartialEq + Send + Sync + 'static {
    /// Every value, in the order help lists them.
    const ALL: &'static [Self];
    /// The value as scene files and the command line spell it.
    fn name(self) -> &'static str;
    /// One line on what it is.
    fn help(self) -> &'static str;
    /// The value spelled `name`.
    ///
    /// # Errors
    /// A message listing the names.
    fn parse(name: &str) -> Result<Self, String> {
        Self::ALL
            .iter()
            .copied()
            .find(|v| v.name() == name)
            .ok_or_else(|| format!("`{name}`: expected one of {}", name_list(Self::ALL.iter().map(|v| v.name()))))
    }
}

/// Settings of one run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunSettings {
    /// Step size `h` \[s\].
    pub dt: f64,
    /// Final time \[s\] (start is 0).
    pub t_end: f64,
    /// Output interval \[s\]; rounded to a whole number of steps. The final
    /// time is always output.
    pub every: f64,
    /// Projection after every step.
    pub projection: ProjectionKind,
    /// Integration method.
    pub method: Method,
    /// The DAE in all `q, qd`, or the reduced formulation in the
    /// independent ones ([`crate::formulation::reduced`]).
    pub formulation: Formulation,
    /// Relative tolerance of adaptive methods.
    pub rtol: f64,
    /// Absolute tolerance of adaptive methods.
    pub atol: f64,
    /// Limit of the relative energy balance `|T - T0 - W| / E`, `E` the
    /// run's own energy scale ([`crate::simulate::guard`]; `None`: no energy check).
    /// A fixed-step run beyond it stops with [`SimError::Diverged`](crate::error::SimError::Diverged) (its
    /// step is too large for the scene); an adaptive run, which met the
    /// tolerance it was asked for at every step, goes on with a note and
    /// [`Summary::energy_drift`](crate::simulate::Summary::energy_drift). Any run whose kinetic energy grows
    /// [`crate::simulate::guard::GROWTH_LIMIT`] times beyond the energy it was given
    /// stops with [`SimError::Diverged`](crate::error::SimError::Diverged).
    pub balance_limit: Option<f64>,
    /// Most step attempts (accepted and rejected) a run may take: a
    /// fixed-step run needing more is refused before it starts, an
    /// adaptive run stops with [`SimError::Budget`](crate::error::SimError::Budget) when it gets there
    /// (`None`: no limit).
    pub max_steps: Option<u64>,
}

/// Default step size of fixed-step methods \[s\].
pub const DEFAULT_DT: f64 = 1e-4;
/// Default relative and absolute tolerance of adaptive methods.
pub const DEFAULT_TOLERANCE: f64 = 1e-9;
/// Default output interval \[s\].
pub const DEFAULT_EVERY: f64 = 0.01;

impl Default for RunSettings {
    /// One second with the default method and tolerances
    /// ([`DEFAULT_DT`], [`DEFAULT_TOLERANCE`], [`DEFAULT_EVERY`]), the
    /// default projection and formulation, the energy balance guarded
    /// ([`BALANCE_LIMIT`]) and at most [`DEFAULT_MAX_STEPS`] steps: what a
    /// scene file without an `[integrator]` table asks for.
    fn default() -> Self {
        Self {
            dt: DEFAULT_DT,
            t_end: 1.0,
            every: DEFAULT_EVERY,
            projection: ProjectionKind::default(),
            method: Method::default(),
            formulation: Formulation::default(),
            rtol: DEFAULT_TOLERANCE,
            atol: DEFAULT_TOLERANCE,
            balance_limit: Some(BALANCE_LIMIT),
            max_steps: Some(DEFAULT_MAX_STEPS),
        }
    }
}

/// Default of [`RunSettings::max_steps`] for scenes: 1e8 steps, about a
/// minute of RK4 on the EzyRoller (4 RHS of ~150 ns each per step) and
/// far more than any built-in scene needs (`drive`: 6e5).
pub const DEFAULT_MAX_STEPS: u64 = 100_000_000;

/// Smallest `rtol`/`atol` accepted: about 50 ulp of 1; tighter requests
/// only make the adaptive step hunt rounding noise.
pub const MIN_TOLERANCE: f64 = 1e-14;

/// Largest `rtol` accepted: 0.1, one correct digit. A looser request lets
/// an adaptive method take steps whose error is as large as the solution:
/// a result no check could tell from a wrong one.
pub const MAX_RTOL: f64 = 0.1;

/// Default limit of the relative energy balance `|T - T0 - W| / E` for
/// `ezy run` (`E`: the run's energy scale, [`crate::simulate::guard`]). Ideal
/// constraints do no work, so the balance is the integrator's own error:
/// 5.8e-14 of the `drive` scene's 13 J at its settings (RK4, h = 1e-4 s),
/// 4.1e-3 at h = 0.3 s; at h = 0.7 s it passes 1e-2 at t = 1.4 s.
pub const BALANCE_LIMIT: f64 = 1e-2;

impl RunSettings {
    /// Why `value` is not acceptable for the setting `name` (`dt`, `t_end`,
    /// `every` \[s\], `rtol`, `atol`), or `None` if it is. Tolerances are
    /// checked whatever the method, so a bad one never waits for the day
    /// an adaptive method is chosen.
    pub fn reject(name: &str, value: f64) -> Option<&'static str> {
        match name {
            "dt" if !(value.is_finite() && value > 0.0) => Some("the step must be a positive number of seconds"),
            "t_end" if !(value.is_finite() && value > 0.0) => Some("the duration must be a positive number of seconds"),
            "every" if !(value.is_finite() && value > 0.0) => {
                Some("the output interval must be a positive number of seconds")
            }
            "rtol" | "atol" if !(value.is_finite() && value > 0.0) => Some("a tolerance must be a positive number"),
            "rtol" | "atol" if value < MIN_TOLERANCE => {
                Some("a tolerance below 1e-14 cannot be met in double precision")
            }
            "rtol" if value > MAX_RTOL => Some(
                "a relative tolerance above 0.1 asks for less than one correct digit: the run could not be trusted",
            ),
            _ => None,
        }
    }

    /// Number of steps to reach `t_end` (the last one may be shorter).
    pub fn n_steps(&self) -> u64 {
        ((self.t_end / self.dt) - 1e-9).ceil().max(1.0) as u64
    }

    /// How many samples a run observes at most: one every `every` \[s\]
    /// to `t_end`, the start and the end (with a fixed step, on its grid).
    /// Computed in floating point, so that a request of `1e300` rows is
    /// sized before anything is allocated for it.
    pub fn output_rows(&self) -> f64 {
        if self.method.is_adaptive() {
            (self.t_end / self.every).floor() + 2.0
        } else {
            (self.t_end / self.dt).ceil() / (self.every / self.dt).round().max(1.0) + 2.0
        }
    }

    /// Steps between outputs.
    pub fn output_stride(&self) -> u64 {
        ((self.every / self.dt).round() as u64).max(1)
    }
}

/// The integration method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// Explicit Euler, order 1, fixed step.
    Euler,
    /// Classic Runge-Kutta, order 4, fixed step (the built-in scenes' default).
    #[default]
    Rk4,
    /// Dormand-Prince 5(4), adaptive.
    Dopri5,
    /// Dormand-Prince 8(5,3), adaptive.
    Dop853,
    /// Radau IIA of order 5, implicit and adaptive: for stiff problems.
    Radau5,
}

impl Choice for Method {
    const ALL: &'static [Self] = &[Self::Euler, Self::Rk4, Self::Dopri5, Self::Dop853, Self::Radau5];
    fn name(self) -> &'static str {
        Method::name(self)
    }
    fn help(self) -> &'static str {
        match self {
            Self::Euler => "Explicit Euler, order 1, fixed step dt",
            Self::Rk4 => "Classic Runge-Kutta, order 4, fixed step dt",
            Self::Dopri5 => "Dormand-Prince 5(4), adaptive to the tolerances rtol, atol",
            Self::Dop853 => "Dormand-Prince 8(5,3), adaptive to the tolerances rtol, atol",
            Self::Radau5 => "Radau IIA of order 5, implicit and adaptive to rtol, atol: for stiff scenes",
        }
    }
}

impl Method {
    /// Name as the CLI spells it.
    pub fn name(self) -> &'static str {
        match self {
            Self::Euler => "euler",
            Self::Rk4 => "rk4",
            Self::Dopri5 => "dopri5",
            Self::Dop853 => "dop853",
            Self::Radau5 => "radau5",
        }
    }
    /// Classical order of the propagated solution.
    pub fn order(self) -> u32 {
        match self {
            Self::Euler => 1,
            Self::Rk4 => 4,
            Self::Dopri5 => 5,
            Self::Dop853 => 8,
            Self::Radau5 => 5,
        }
    }
    /// Whether the step size is chosen by error control.
    pub fn is_adaptive(self) -> bool {
        matches!(self, Self::Dopri5 | Self::Dop853 | Self::Radau5)
    }
}

impl Formulation {
    /// Name as the CLI spells it.
    pub fn name(self) -> &'static str {
        match self {
            Self::Auto => "auto",
            Self::Dae => "dae",
            Self::Reduced => "reduced",
        }
    }

    /// Whether `Auto` takes the reduced formulation for `method` on a
    /// model with `nq` coordinates and `nc` constraint rows: an adaptive
    /// explicit method (DOPRI5, DOP853) and one degree of freedom in
    /// velocity (`nq - nc = 1`); [`simulate`](crate::simulate()) also
    /// requires the dependent coordinates to follow from one Newton step
    /// (all translations). Measured at equal accuracy (callgrind
    /// instructions of the integration, docs/physics.md §6.1): there the
    /// error control on the few independent components saves a third of
    /// the steps and the run 1.15-1.25x (`trailer`), while at two or more
    /// degrees of freedom the expansion (a Newton step, a dense LU of
    /// `G_D`) outweighs what it saves (`drive` 1.65x, `snake` 2.2-7x), and a
    /// fixed-step method saves no steps at all. (On the minimal
    /// coordinates `model!` derives, with no Newton step and no `G_D`,
    /// `Auto` takes the reduced formulation for DOPRI5, DOP853 and RK4 at
    /// any number of degrees of freedom: docs/physics.md §6.2.)
    pub fn auto_takes_reduced(method: Method, nq: usize, nc: usize) -> bool {
        matches!(method, Method::Dopri5 | Method::Dop853) && nq == nc + 1
    }
}

impl Choice for Formulation {
    const ALL: &'static [Self] = &[Self::Dae, Self::Reduced, Self::Auto];
    fn name(self) -> &'static str {
        Formulation::name(self)
    }
    fn help(self) -> &'static str {
        match self {
            Self::Dae => "The index-1 DAE in all q, qd, projected after every step",
            Self::Reduced => {
                "Only the independent q, qd are integrated, so no projection is needed or done: on the minimal coordinates model! derived where it could (the dependent ones in closed form), else on a partition whose dependent ones are recovered from the constraints at every evaluation (Wehage & Haug)"
            }
            Self::Auto => {
                "The fastest of the two for the run (the default): reduced for DOPRI5, DOP853 and RK4 on the minimal coordinates model! derived, and for DOPRI5 and DOP853 with one degree of freedom; else the DAE. The summary says which was taken"
            }
        }
    }
}

/// The integration formulation (`--formulation`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Formulation {
    /// The reduced formulation where it pays, else the DAE (the default): on the
    /// minimal coordinates `model!` derived ([`crate::model::info::MinimalLayout`]) for
    /// DOPRI5, DOP853 and RK4, else by [`Formulation::auto_takes_reduced`].
    #[default]
    Auto,
    /// The index-1 DAE in all `q, qd` with coordinate projection.
    Dae,
    /// Coordinate partitioning: only the independent `q_I, qd_I` are integrated.
    Reduced,
}

/// Which projection to apply after every step.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ProjectionKind {
    /// No projection: the constraints drift.
    None,
    /// `W = I`, the plain least-squares correction.
    Euclidean,
    /// `W = M`, the kinetic-energy metric (default, see module docs).
    #[default]
    #[serde(rename = "mass")]
    MassWeighted,
}

impl Choice for ProjectionKind {
    const ALL: &'static [Self] = &[Self::None, Self::Euclidean, Self::MassWeighted];
    fn name(self) -> &'static str {
        ProjectionKind::name(self)
    }
    fn help(self) -> &'static str {
        match self {
            Self::None => "No projection",
            Self::Euclidean => "Euclidean (the plain least-squares correction)",
            Self::MassWeighted => "Mass-weighted (kinetic-energy metric), the default",
        }
    }
}

impl ProjectionKind {
    /// Name as the CLI spells it.
    pub fn name(self) -> &'static str {
        match self {
            Self::None => "none",
            Self::Euclidean => "euclidean",
            Self::MassWeighted => "mass",
        }
    }
}

/// The largest magnitude ezy takes for a number of a model (a parameter,
/// a mass or an inertia) or of an effect (a coefficient, a load, a
/// waveform's amplitude), in SI units: 1e34.
///
/// Every entry of the right-hand side is a product of a few such numbers
/// and the state (a spring's power is stiffness x stretch x rate, the
/// gravity's m g v, an acceleration a force over a mass), and the adaptive
/// methods square the entries divided by the tolerance (down to
/// [`MIN_TOLERANCE`] = 1e-14) in their error norm and
/// their first step: past sqrt(1.8e308) x 1e-14 = 1.3e140 that square
/// overflows and the step collapses to 0 at t = 0 (measured: a spring of
/// 1e300 N/m, a mass of 1e150 kg under gravity, a torque of 1e300 N m
/// stopped with "the step size fell to 0e0 s"). A product of four numbers
/// up to 1e34 stays below 1e136. The numbers of a planar mechanism lie far
/// inside (the Sun's mass is 2e30 kg); a larger one is a slip of the
/// keyboard or a stand-in for "infinite", which ezy models otherwise (a
/// contact that never slides is the ideal skate, a rigid link a hinge).
/// The bound is necessary, not sufficient: a value inside it may still
/// make a scene too stiff to integrate.
pub const MAX_MAGNITUDE: f64 = 1e34;

/// The fastest rate \[1/s\] (an angular frequency \[rad/s\], a Baumgarte
/// rate) a run can follow: 1 / (16 eps) = 2.8e14 1/s. The shortest step an
/// integrator takes at time t is 16 eps max(t, min(t_end, 1 s)), the
/// rounding level of t (`simulate`'s floor, 3.6e-15 s at t = 1 s): a
/// quantity that changes by a radian, or decays by a factor e, within it
/// cannot be followed by any step.
pub const MAX_RATE: f64 = 1.0 / (16.0 * f64::EPSILON);

/// The largest magnitude of an angle a scene gives \[rad\] (a phase, a rest
/// angle, a direction): 1e6 rad (160,000 turns). An angle carries the
/// rounding eps |angle|, 2.2e-10 rad at 1e6 rad, about the tightest
/// tolerances runs ask for (1e-9 to 1e-12); a phase of 1e300 rad swamps
/// `omega t` entirely (the waveform is a constant).
pub const MAX_ANGLE: f64 = 1e6;

/// `Ok` if `v` is finite and at most [`MAX_MAGNITUDE`] in magnitude.
///
/// # Errors
/// A sentence naming `name = v` and why it is refused.
pub fn check_magnitude(name: &str, v: f64) -> Result<(), String> {
    check_bound(
        name,
        v,
        MAX_MAGNITUDE,
        "numbers",
        "the forces, powers and energies formed from a larger one overflow double precision",
    )
}

/// `Ok` if `v` is finite and at most [`MAX_ANGLE`] in magnitude.
///
/// # Errors
/// A sentence naming `name = v` and why it is refused.
pub fn check_angle(name: &str, v: f64) -> Result<(), String> {
    check_bound(
        name,
        v,
        MAX_ANGLE,
        "angles [rad]",
        "beyond, the angle's rounding (eps |angle|) passes the tolerances a run keeps",
    )
}

/// `Ok` if `v` is finite and at most [`MAX_RATE`] in magnitude.
///
/// # Errors
/// A sentence naming `name = v` and why it is refused.
pub fn check_rate(name: &str, v: f64) -> Result<(), String> {
    check_bound(
        name,
        v,
        MAX_RATE,
        "rates [1/s]",
        "a faster one changes within the rounding level of t (16 eps t, the shortest step), so no step can follow it",
    )
}

fn check_bound(name: &str, v: f64, bound: f64, what: &str, why: &str) -> Result<(), String> {
    if !v.is_finite() {
        return Err(format!("{name} = {v} must be finite"));
    }
    if v.abs() <= bound {
        return Ok(());
    }
    Err(format!(
        "{name} = {} is out of range: ezy takes {what} up to {:e} in magnitude ({why})",
        fmt_value(v),
        round_bound(bound),
    ))
}

/// A bound as a message writes it (2.8e14, not 281474976710656).
fn round_bound(b: f64) -> f64 {
    format!("{b:.1e}").parse().unwrap_or(b)
}

/// A run setting an error, a note or a help text advises changing,
/// carried as data: how it is spelled is chosen where the text is
/// rendered ([`Spelling`]). A library spells it by its name (`` `dt` ``,
/// `` `formulation = dae` ``: the fields of [`RunSettings`] and the keys
/// of a scene's `[integrator]`), the command line by its flags (`--dt`,
/// `--formulation dae`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Setting {
    /// The fixed step size \[s\].
    Dt,
    /// The relative tolerance.
    Rtol,
    /// The step budget.
    MaxSteps,
    /// The output budget \[MB\].
    MaxOutputMb,
    /// The integration method, with the value advised.
    Method(Method),
    /// The formulation, with the value advised.
    Formulation(Formulation),
    /// Baumgarte stabilization.
    Baumgarte,
}

/// How a [`Setting`] is written when a text is rendered: by the names a
/// library and a scene file use ([`Spelling::Library`], the default), or
/// by the `ezy` command line's flags ([`Spelling::Flags`]). The choice
/// belongs to the code that renders, for the extent of one call
/// ([`Spelling::scope`], on the calling thread): no switch outlives it,
/// so a library in the same process as a command line keeps its own
/// spelling. `{:#}` on a [`Setting`] or a [`Message`] asks for the flags
/// whatever the scope.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Spelling {
    /// `` `dt` ``, `` `formulation = dae` ``.
    #[default]
    Library,
    /// `--dt`, `--formulation dae`.
    Flags,
}

thread_local! {
    static SPELLING: Cell<Spelling> = const { Cell::new(Spelling::Library) };
}

impl Spelling {
    /// The spelling in force on this thread.
    pub fn current() -> Self {
        SPELLING.with(Cell::get)
    }

    /// Runs `f` with `self` as this thread's spelling, and restores the
    /// one before when `f` returns or unwinds. A command line wraps its
    /// command in `Spelling::Flags.scope`, and each worker thread it
    /// starts in the spelling it captured with [`Spelling::current`].
    pub fn scope<R>(self, f: impl FnOnce() -> R) -> R {
        struct Restore(Spelling);
        impl Drop for Restore {
            fn drop(&mut self) {
                SPELLING.with(|s| s.set(self.0));
            }
        }
        let _restore = Restore(SPELLING.with(|s| s.replace(self)));
        f()
    }
}

impl Setting {
    /// The flag, the library's name (a field of [`RunSettings`],
    /// a key of a scene's `[integrator]`) and the value advised.
    fn names(self) -> (&'static str, &'static str, Option<&'static str>) {
        match self {
            Self::Dt => ("--dt", "dt", None),
            Self::Rtol => ("--rtol", "rtol", None),
            Self::MaxSteps => ("--max-steps", "max_steps", None),
            Self::MaxOutputMb => ("--max-output-mb", "max_output_mb", None),
            Self::Method(m) => ("--integrator", "method", Some(m.name())),
            Self::Formulation(x) => ("--formulation", "formulation", Some(x.name())),
            Self::Baumgarte => ("--baumgarte", "baumgarte", None),
        }
    }
}

impl std::fmt::Display for Setting {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (flag, name, value) = self.names();
        let flags = f.alternate() || Spelling::current() == Spelling::Flags;
        match (flags, value) {
            (true, None) => f.write_str(flag),
            (true, Some(v)) => write!(f, "{flag} {v}"),
            (false, None) => write!(f, "`{name}`"),
            (false, Some(v)) => write!(f, "`{name} = {v}`"),
        }
    }
}

/// A sentence that may advise settings, kept as parts so the settings
/// stay data ([`Message::settings`]) and are spelled where the text is
/// rendered ([`Spelling`]). Built from text and settings in order:
/// `Message::text("take ").setting(Setting::Rtol).then(" smaller")`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Message {
    parts: Vec<Part>,
}

/// A piece of a [`Message`].
#[derive(Debug, Clone, PartialEq)]
pub enum Part {
    /// Words, written as they are.
    Text(String),
    /// A setting, written in the spelling in force.
    Setting(Setting),
}

impl Message {
    /// A message that starts with `text`.
    pub fn text(text: impl Into<String>) -> Self {
        Self { parts: vec![Part::Text(text.into())] }
    }

    /// `self` followed by `text`.
    #[must_use]
    pub fn then(mut self, text: impl Into<String>) -> Self {
        self.parts.push(Part::Text(text.into()));
        self
    }

    /// `self` followed by `setting`.
    #[must_use]
    pub fn setting(mut self, setting: Setting) -> Self {
        self.parts.push(Part::Setting(setting));
        self
    }

    /// `self` followed by `other`'s parts.
    #[must_use]
    pub fn join(mut self, other: Message) -> Self {
        self.parts.extend(other.parts);
        self
    }

    /// The parts, in order.
    pub fn parts(&self) -> &[Part] {
        &self.parts
    }

    /// The settings the message advises, in order.
    pub fn settings(&self) -> impl Iterator<Item = Setting> + '_ {
        self.parts.iter().filter_map(|p| match p {
            Part::Setting(s) => Some(*s),
            Part::Text(_) => None,
        })
    }
}

impl From<String> for Message {
    fn from(text: String) -> Self {
        Self::text(text)
    }
}

impl From<&str> for Message {
    fn from(text: &str) -> Self {
        Self::text(text)
    }
}

impl std::fmt::Display for Message {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        for part in &self.parts {
            match part {
                Part::Text(t) => f.write_str(t)?,
                Part::Setting(s) if f.alternate() => write!(f, "{s:#}")?,
                Part::Setting(s) => write!(f, "{s}")?,
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A spelling holds for its call only, on its thread only, and is
    /// restored after a panic inside it.
    #[test]
    fn a_spelling_is_scoped_to_its_call_and_thread() {
        let m =
            Message::text("take a smaller ").setting(Setting::Dt).then(" or ").setting(Setting::Method(Method::Dop853));
        assert_eq!(m.to_string(), "take a smaller `dt` or `method = dop853`");
        let flags = Spelling::Flags.scope(|| {
            let other = std::thread::scope(|s| s.spawn(|| m.to_string()).join().unwrap());
            assert_eq!(other, "take a smaller `dt` or `method = dop853`", "another thread keeps its own");
            let inner = Spelling::Library.scope(|| m.to_string());
            assert_eq!(inner, "take a smaller `dt` or `method = dop853`", "a nested scope wins");
            m.to_string()
        });
        assert_eq!(flags, "take a smaller --dt or --integrator dop853");
        assert_eq!(format!("{m:#}"), flags, "`{{:#}}` asks for flags");
        assert_eq!(Spelling::current(), Spelling::Library);
        let unwound = std::panic::catch_unwind(|| Spelling::Flags.scope(|| panic!("inside")));
        assert!(unwound.is_err());
        assert_eq!(Spelling::current(), Spelling::Library, "restored after a panic");
        assert_eq!(m.settings().collect::<Vec<_>>(), [Setting::Dt, Setting::Method(Method::Dop853)]);
    }
}
