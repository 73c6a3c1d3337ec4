//! Forward sensitivities of a run: `S(t) = dx(t)/dp` (2nq x np) of the
//! state `x = [q, qd]` with respect to named parameters `p` (a model's
//! parameter, an initial value, any number a problem is built from: an
//! effect's amplitude, a scene parameter).
//!
//! # Method
//!
//! The sensitivities obey the forward sensitivity equations
//! `S' = (df/dx) S + df/dp`, `S(0) = dx0/dp` (Hairer, Nørsett & Wanner,
//! *Solving ODEs I*, §I.14 and §II.6; the CVODES user guide, §2.6). They
//! are integrated together with the state by the same method as one
//! system `[x, S]` under one error control (the simultaneous corrector
//! method, CVODES's `CV_SIMULTANEOUS` with `errconS`; for an explicit
//! Runge-Kutta method it is the same as differentiating its steps, with
//! the step sizes the sensitivities' error asks for too).
//!
//! - `(df/dx) S` is exact: the model's generated terms (`G`, `gamma`) are
//!   differentiated in forward mode along each column of `S` (one pass of
//!   dual numbers through the code `model!` generated, per parameter), and
//!   `qdd`'s derivative follows from the KKT system
//!   `[M G^T; G 0] [qdd; mu] = [F; -gamma]` by implicit differentiation:
//!   `[M G^T; G 0] [dqdd; dmu] = [dF - dM qdd - dG^T mu; -dgamma - dG qdd]`.
//!   The applied forces' derivative along `S` is their Jacobian `dF/dx`
//!   times `S`: each law's exact Jacobian
//!   ([`crate::effects::ForceLaw::jacobian`]; every built-in law has
//!   one), central differences of its force alone for a law of the
//!   user's own without one (step `eps^(1/3) max(1, |x_j|)`, error about
//!   1e-10 relative); none of a law whose force depends on time alone
//!   ([`crate::effects::ForceLaw::time_only`]: a motor's torque).
//! - `df/dp` (a parameter's direct effect on the masses, the constraints,
//!   the forces and the drives) is a central difference of the right-hand
//!   side between the problems built at `p +- h`, `h = eps^(1/3) max(1,
//!   |p|)`, at the same state (never a difference of whole runs): of the
//!   forces, only the effects the parameter changes (an effect the same in
//!   every problem cancels exactly: a mass's column evaluates no force); where
//!   `p - h` cannot be built (a damping of 0), a one-sided difference of
//!   second order on `p`, `p + h`, `p + 2h`. [`Sensitivities::derivatives`]
//!   says which for each parameter. The waveforms of the problems at
//!   `p +- h` (a motor's harmonic torque, a drive's prescribed angle) are
//!   not evaluated as they are but linearized from the base problem's
//!   ([`crate::effects::Waveform::eval3_toward`]): a harmonic's amplitude,
//!   frequency and phase enter `df/dp` exactly, `-a t sin(omega t + phase)
//!   domega/dp` included, where a difference of the waveforms erred by
//!   `(h t)^2 / 6` relative (1.9e-6 at the 120 s of a gait's phase). A
//!   spring-damper is not differenced either: its law is differentiated
//!   toward each node's in its numbers (its ends' offsets and ground
//!   points, stiffness, rest length, damping;
//!   [`crate::effects::Law::apply_toward`], dual numbers), so `dF/dp` is
//!   exact but for the numbers' own difference (exact where they are
//!   linear in `p`, as a point's offset `a / 2`). A difference of its
//!   forces erred by `stiffness h^2` times its geometry's third
//!   derivative, across its line as well as along it, which a stiff
//!   coupler does not take up: `ezy sensitivity four-bar-stiff --wrt a`
//!   was 8.3e-7 off the differences of whole runs at 10 ms, growing like
//!   `t^2`, where it is now 2e-11; and the difference's rounding, the
//!   stiffness times `eps / h`, held DOP853 at 1e-13 to 6.6 million
//!   steps over those 10 ms (90 s), where it takes 2,400. What remains
//!   differenced (the masses, the model's geometry in the constraints,
//!   the other laws' gains and points) does not grow with `t` and no
//!   stiffness multiplies it: smooth in `p`, most of it linear, it errs
//!   by about `h^2`, 1e-10 relative, or by rounding, `eps / h`.
//! - `S(0)` is the same difference of the problems' consistent initial
//!   states (exact for an initial value the problem gives).
//! - The DAE's state is projected onto the constraints after each step
//!   (`crate::formulation::projection`, the run's projection), and `S`
//!   by that projection's derivative: a correction `v' = v - W^-1 G^T y`
//!   with `G v' = b` differentiates to `dv' = P (dv - W^-1 (dG^T y + dW
//!   (v' - v)))`, `P` the projection onto the tangent space of the
//!   constraint manifold in the same metric `W` (Hairer, Lubich & Wanner,
//!   *Geometric Numerical Integration*, §IV.4): positions first, `S_q <-
//!   S_q - W^-1 Cq^T (Cq W^-1 Cq^T)^-1 (Cq S_q + dC/dp)`, then the
//!   velocities with `G` and `d(G qd)/dq S_q + d(G qd)/dp`. The curvature
//!   term `W^-1 (dG^T y + dW (v' - v))`, `dG` along `S_q` and `p`, is what
//!   the step's drift `v - v'` costs: without it Euler's sensitivities
//!   (drift `dt^2` a step) were 2.7e-6 of their size off the discrete
//!   run's own derivative over 5 s (1.6e-4 at larger steps). The velocity
//!   step is linear, its derivative exact; the positions' Gauss-Newton
//!   steps are differentiated to first order in the drift (the further
//!   steps' multipliers are of its square).
//!
//! The sensitivities are integrated with Euler, RK4, DOPRI5, DOP853 or
//! RADAU5. RADAU5 takes `[x, S]` as one system:
//! its simplified Newton iteration on the augmented right-hand side, whose
//! Jacobian it takes by forward differences and factors dense (real and
//! complex LU of `2 nq (1 + np)` rows, refused past 1000: choose DOP853);
//! Newton converges to the same collocation solution whatever its
//! Jacobian's error, so the sensitivities are the method's own, under the
//! same error control as the state. On the reduced formulation the
//! independent components `z` and `S_z = dz/dp` are integrated, the
//! reduced run's own steps differentiated: each evaluation expands `S_z`
//! to the full `S_x` that keeps it and satisfies the linearized
//! constraints (the dependent coordinates' implicit derivative, Haug
//! 1989, §6.3), takes the DAE's sensitivity right-hand side there and
//! reads the independent components' rates from it (`reduced.rs`); no
//! projection, as the run makes none. The DAE's sensitivities would be
//! another run's (for a fixed step, another discrete run's), so each
//! formulation's are its own run's. A scene with events (a switch or stop changes the
//! motion where its time changes with `p`) is refused, as is a motion on
//! which a skate with friction slides.
//!
//! Per evaluation, each parameter costs a dual-number pass of the
//! constraint terms, its `df/dp` (the effects it changes at `p +- h`, or
//! the model's terms there), and one more KKT solve with the base's `G`;
//! each step, the tangent projection of its column. Nothing is allocated
//! per step but the samples kept (docs/dev/performance.md, "Sensitivities").

pub(crate) mod gait;
mod reduced;
mod rhs;
mod run;
mod stencil;

use std::sync::Arc;

use crate::analysis::AnalysisError;
use crate::error::SimError;
use crate::model::Model;
use crate::problem::Problem;

pub use gait::GaitSensitivities;
pub use stencil::Derivative;

/// Most parameters one sensitivity run takes: its state has
/// `2 nq (1 + np)` values and each evaluation solves the KKT system for
/// `np` right-hand sides.
pub const MAX_PARAMETERS: usize = 256;

/// How a problem is built for a value of a parameter.
pub type Build<M> = dyn Fn(f64) -> Result<Problem<M>, SimError> + Send + Sync;

/// A named parameter of a problem: its value and how the problem is
/// built at another value ([`Parameter::new`]; [`Parameter::model`] and
/// [`Parameter::initial_q`] / [`Parameter::initial_qd`] for a model's
/// parameters and initial values; `ezy_scene::Scene::parameter` for any
/// number of a scene).
#[derive(Clone)]
pub struct Parameter<M: Model> {
    /// The name its sensitivity columns carry (`dx1/d<name>`).
    pub name: String,
    /// Its value in the problem differentiated.
    pub value: f64,
    build: Arc<Build<M>>,
}

impl<M: Model> std::fmt::Debug for Parameter<M> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Parameter").field("name", &self.name).field("value", &self.value).finish_non_exhaustive()
    }
}

impl<M: Model> Parameter<M> {
    /// A parameter `name` at `value`, the problem at another value built
    /// by `build` (which must give the problem differentiated at `value`,
    /// and a problem of the same model size elsewhere).
    pub fn new(
        name: impl Into<String>,
        value: f64,
        build: impl Fn(f64) -> Result<Problem<M>, SimError> + Send + Sync + 'static,
    ) -> Self {
        Self { name: name.into(), value, build: Arc::new(build) }
    }

    /// The problem at `value`.
    ///
    /// # Errors
    /// Whatever the builder refuses (a value out of the parameter's range).
    pub fn problem(&self, value: f64) -> Result<Problem<M>, SimError> {
        (self.build)(value)
    }

    /// The model parameter `name` of `problem` (a mass, a length).
    ///
    /// # Errors
    /// [`crate::error::SetupError::UnknownName`] listing the model's parameters.
    pub fn model(problem: &Problem<M>, name: &str) -> Result<Self, SimError> {
        let info = problem.model.info();
        let k = info.param_index(name).ok_or_else(|| {
            SimError::Setup(crate::error::SetupError::UnknownName {
                kind: "model parameter",
                name: name.into(),
                model: info.name,
                known: info.params.iter().map(|p| p.name).collect::<Vec<_>>().join(", "),
            })
        })?;
        let base = problem.clone();
        Ok(Self::new(name, problem.model.param(k), move |v| {
            let mut p = base.clone();
            p.model.set_param(k, v);
            Ok(p)
        }))
    }

    /// The initial value of coordinate `name` \[m or rad\] (named
    /// `initial.q.<name>`): its value in the problem's consistent initial
    /// state; a coordinate the problem does not give becomes given.
    ///
    /// # Errors
    /// As [`Problem::q`]; as [`Problem::initial_state`].
    pub fn initial_q(problem: &Problem<M>, name: &str) -> Result<Self, SimError> {
        Self::initial(problem, name, false)
    }

    /// The initial velocity of coordinate `name` \[m/s or rad/s\] (named
    /// `initial.qd.<name>`), as [`Parameter::initial_q`].
    ///
    /// # Errors
    /// As [`Problem::qd`]; as [`Problem::initial_state`].
    pub fn initial_qd(problem: &Problem<M>, name: &str) -> Result<Self, SimError> {
        Self::initial(problem, name, true)
    }

    fn initial(problem: &Problem<M>, name: &str, velocity: bool) -> Result<Self, SimError> {
        let info = problem.model.info();
        let k = info.coords.iter().position(|c| *c == name).ok_or_else(|| {
            SimError::Setup(crate::error::SetupError::UnknownName {
                kind: "coordinate",
                name: name.into(),
                model: info.name,
                known: info.coords.join(", "),
            })
        })?;
        let (x0, _) = problem.initial_state()?;
        let nq = info.nq();
        let value = x0[if velocity { nq + k } else { k }];
        let base = problem.clone();
        let coord = name.to_string();
        let label = format!("initial.{}.{name}", if velocity { "qd" } else { "q" });
        Ok(Self::new(
            label,
            value,
            move |v| if velocity { base.clone().qd(&coord, v) } else { base.clone().q(&coord, v) },
        ))
    }
}

/// A run's state and its sensitivities at the output samples
/// ([`Problem::sensitivities`]).
#[derive(Debug, Clone)]
pub struct Sensitivities {
    /// Times of the samples \[s\]: 0, every output interval, the end.
    pub t: Vec<f64>,
    /// Names of the state components `[q, qd]` (2 nq): `x1`, ..., `x1d`.
    pub names: Vec<String>,
    /// The parameters, in the order of [`Sensitivities::s`]'s blocks.
    pub parameters: Vec<String>,
    /// The parameters' values.
    pub values: Vec<f64>,
    /// How each parameter's direct effect `df/dp` was differentiated.
    pub derivatives: Vec<Derivative>,
    /// The state at each sample (2 nq values).
    pub x: Vec<Vec<f64>>,
    /// The sensitivities at each sample: `np` blocks of 2 nq values,
    /// block `j` being `dx/dp_j` in the order of [`Sensitivities::names`].
    pub s: Vec<Vec<f64>>,
    /// Accepted steps.
    pub steps: u64,
    /// Rejected step attempts.
    pub rejected: u64,
    /// Evaluations of the augmented right-hand side.
    pub evaluations: u64,
    /// The formulation whose run was differentiated:
    /// [`crate::settings::Formulation::Dae`] (projected after each step, `S` onto
    /// the constraints' tangent space) or [`crate::settings::Formulation::Reduced`]
    /// (the independent components' steps; `auto` takes the DAE).
    pub formulation: crate::settings::Formulation,
    /// Times the reduced formulation re-chose its partition (its pivots
    /// fell; 0 on the DAE): `S_z` is rewritten in the new one and the
    /// method restarts, as the run does.
    pub repartitions: u64,
}

impl Sensitivities {
    /// The column names of the sensitivities, parameter by parameter:
    /// `d<state>/d<param>` (`dx1/dM0`, ..., `dx1d/dM0`, `dx1/domega`, ...).
    pub fn columns(&self) -> Vec<String> {
        self.parameters.iter().flat_map(|p| self.names.iter().map(move |n| format!("d{n}/d{p}"))).collect()
    }

    /// A column over the samples: a state component by name (`x1`) or a
    /// sensitivity `d<state>/d<param>` (`dx1/dM0`); `None` for a name
    /// neither.
    pub fn column(&self, name: &str) -> Option<Vec<f64>> {
        if let Some(i) = self.names.iter().position(|n| n == name) {
            return Some(self.x.iter().map(|row| row[i]).collect());
        }
        let k = self.columns().iter().position(|c| c == name)?;
        Some(self.s.iter().map(|row| row[k]).collect())
    }
}

impl<M: Model> Problem<M> {
    /// The run's state and its sensitivities with respect to the
    /// parameters `names`: the model's parameters by name (`m1`) and the
    /// initial values `initial.q.<coord>`, `initial.qd.<coord>` (any other
    /// number through [`Problem::sensitivities_with`]).
    ///
    /// # Errors
    /// As [`Problem::sensitivities_with`]; [`AnalysisError::Sim`] with
    /// [`crate::error::SetupError::UnknownName`] for a name that is none of these.
    pub fn sensitivities(&self, names: &[&str]) -> Result<Sensitivities, AnalysisError> {
        let params = names.iter().map(|n| self.parameter(n)).collect::<Result<Vec<_>, _>>()?;
        self.sensitivities_with(&params)
    }

    /// The parameter `name` of this problem: a model parameter, or
    /// `initial.q.<coord>` / `initial.qd.<coord>`.
    ///
    /// # Errors
    /// [`crate::error::SetupError::UnknownName`] listing the model's parameters.
    pub fn parameter(&self, name: &str) -> Result<Parameter<M>, SimError> {
        if let Some(c) = name.strip_prefix("initial.q.") {
            return Parameter::initial_q(self, c);
        }
        if let Some(c) = name.strip_prefix("initial.qd.") {
            return Parameter::initial_qd(self, c);
        }
        Parameter::model(self, name)
    }

    /// The run's state and its sensitivities with respect to `params`,
    /// integrated together by the problem's method under its tolerances,
    /// sampled at its output interval (see the module's docs for the
    /// method).
    ///
    /// # Errors
    /// [`AnalysisError::Request`] for no parameters or more than
    /// [`MAX_PARAMETERS`], a name given twice, a non-finite value, a
    /// parameter whose problems differ in size, RADAU5 on more than 1000
    /// states `2 nq (1 + np)`, Baumgarte stabilization, a scene with
    /// events, samples past
    /// [`Problem::max_output_mb`], or a skate with friction that slides;
    /// [`AnalysisError::Sim`] for a problem that cannot be built or a run
    /// that fails (a singular position, a step budget spent);
    /// [`AnalysisError::Stopped`] from [`Problem::sensitivities_stop_when`]'s hook.
    pub fn sensitivities_with(&self, params: &[Parameter<M>]) -> Result<Sensitivities, AnalysisError> {
        run::sensitivities(self, params, None, None)
    }

    /// [`Problem::sensitivities_with`] sampled at the times `times` \[s\]
    /// (sorted, each once, finite, >= 0: a measurement's times), from the
    /// dense output of the adaptive methods or by fixed steps that end at
    /// each time; the run ends at the last. `stop` as in
    /// [`Problem::sensitivities_stop_when`].
    ///
    /// # Errors
    /// As [`Problem::sensitivities_with`]; [`AnalysisError::Request`] for
    /// times that are none, not finite, negative or unsorted, naming the
    /// first at fault.
    pub fn sensitivities_at(
        &self,
        params: &[Parameter<M>],
        times: &[f64],
        stop: Option<fn() -> bool>,
    ) -> Result<Sensitivities, AnalysisError> {
        run::sensitivities(self, params, stop, Some(times))
    }

    /// [`Problem::sensitivities_with`], asking `stop` at every step
    /// whether to end (with [`AnalysisError::Stopped`]).
    ///
    /// # Errors
    /// As [`Problem::sensitivities_with`].
    pub fn sensitivities_stop_when(
        &self,
        params: &[Parameter<M>],
        stop: fn() -> bool,
    ) -> Result<Sensitivities, AnalysisError> {
        run::sensitivities(self, params, Some(stop), None)
    }
}
