//! Optimal maneuver planning: the inputs that drive a problem from its
//! initial state to a target at `t_end` with least effort
//! `sum_j int_0^T u_j(t)^2 dt`, or least [`Objective`] (the effort times
//! a weight plus a user's term of the run's samples at the nodes), by
//! direct multiple shooting.
//!
//! # The problem
//!
//! A [`Plan`] is given as a [`crate::design::Design`] is: a closure that
//! builds the [`Problem`] from the inputs, here piecewise-linear tables
//! ([`Table`]) of time, one per [`Input`]. The closure decides which
//! effect each input drives (a motor's torque, a body force; a law of the
//! user's own), so a user's model or law is planned exactly as a built-in
//! one. The target ([`Target`]) names components of `q` and `qd` at
//! `t_end` (`Target::at_rest`: every velocity zero); the inputs have bounds.
//!
//! # Method
//!
//! Direct multiple shooting (Bock & Plitt, "A multiple shooting algorithm
//! for direct solution of optimal control problems", IFAC 9th World
//! Congress, 1984; Betts, *Practical Methods for Optimal Control*, 2nd
//! ed., SIAM 2010, §4.4-4.5): `[0, T]` is cut into N equal segments; the
//! unknowns are the inputs' values at the N + 1 nodes (each input linear
//! between them) and the state at each inner node (with a node at every
//! segment; by default the segments form one shooting interval, below). Each segment is a run
//! of the user's problem from its node's state over its `h = T / N`
//! seconds, its clock from 0, its inputs the tables `[0, h] -> [u_k,
//! u_k+1]`; the equalities are the state's continuity at the inner nodes
//! and the target at the end. The effort of a piecewise-linear input is
//! exact: `int u^2 = h/3 (u_k^2 + u_k u_k+1 + u_k+1^2)` on each segment.
//!
//! The objective ([`Objective`], [`Plan::with_objective`]) is the effort
//! times a weight (1 by default) plus an optional term of the user's
//! own, `J_user(samples)`: a function of the nodes' times, states
//! `[q, qd]` and inputs ([`Samples`]) that returns its value and, if it
//! can, its gradient with respect to the samples; where it gives none,
//! ezy differences it with respect to the samples (no extra simulation)
//! and says so ([`Maneuver::objective_gradient`]). Its chain to the
//! unknowns takes the samples' exact sensitivities (the segments' end
//! states are differentiated anyway). With a user's term the target may
//! be empty (a free end).
//!
//! A node's state is not all of `[q, qd]` (2 nq) but its independent
//! components (2 nq - nh - nc: a partition chosen at the node's
//! warm-start state by Gaussian elimination with full pivoting on `C_q`
//! and `G`, as the reduced formulation's); the problem's consistent
//! initial state ([`crate::formulation::initial`]) completes the others,
//! so every segment starts on the constraints and the continuity of the
//! independent components is the continuity of the state (the run ends
//! on the constraints, projected). This projection rather than residual
//! equalities `phi(q_k) = 0`, `G qd_k = 0` on full node states: the
//! equalities would make the continuity rows dependent on them (a state
//! on the constraints matched in all 2 nq components over-determines it),
//! and SLSQP's least-squares subproblem wants independent equalities.
//! For the same reason the target's components that the constraints
//! determine from the others (at rest, a skate's lateral speed) are left
//! out of the equalities: they are chosen at the warm start's end, and
//! all the target's components are checked by the verification run.
//!
//! Shooting intervals may be coarser than the inputs' mesh
//! ([`PlanSettings::intervals`] M of the N segments; Bock & Plitt's
//! nodes need not be the control's): a node's state is an unknown only
//! where an interval starts, and the segments inside one are chained,
//! each started from the last one's whole end state (given in every
//! component; the consistent initial state projects it onto the
//! constraints, which it meets to the run's accuracy) and its
//! sensitivities multiplied along the chain, `dx_end/dw = S_x
//! dx_start/dw + S_u du/dw`. M = 1, the default, is single shooting:
//! N + 1 unknowns per input and only the target's equalities.
//!
//! Each segment's end state is differentiated with respect to its start's
//! independent components and its input nodes by the forward
//! sensitivities ([`crate::sensitivity`], exact to the integration's
//! accuracy), which give the constraints' Jacobian; the effort's gradient
//! is exact. The program is solved by SLSQP (Kraft 1988, the crate
//! `slsqp`, dense, quasi-Newton: as [`crate::design::optimize`]); its
//! equalities enter as pairs of inequalities within a hundredth of the
//! tolerance ([`PlanSettings::tolerance`]), as the crate takes no
//! equalities. It starts from a warm start: the problem run with the
//! inputs' guesses, segment by segment, its node states taken as the
//! nodes' unknowns.
//!
//! Dense SLSQP costs `O(n^2)` memory and `O(n^3)` a step in the `n`
//! unknowns: tens of segments. Hundreds want a sparse interior-point
//! method on the program's banded Jacobian (IPOPT's kind; Betts §4.6).
//! Clarabel (the crate `clarabel`) takes convex problems only, `min 1/2
//! x^T P x + q^T x` subject to `A x + s = b`, `s` in a convex cone, `P`
//! positive semidefinite: shooting's continuity equalities are
//! nonlinear, so it could solve the sparse convex subproblems of an SQP
//! method, not the program itself.
//!
//! # Path constraints
//!
//! [`Plan::with_path`] bounds a state component or a function of the
//! user's own of one node's sample at every node ([`PathConstraint`];
//! Betts §4.2): each finite bound an inequality of the program,
//! differentiated through the nodes' exact sensitivities as the
//! objective is, and in the violation, the status and the first-order
//! conditions (an active inequality's row joins the equalities'). Between
//! the nodes nothing is enforced; the verification run reports the
//! largest excess it samples ([`Verification::path_violation`]).
//!
//! # A free duration
//!
//! With [`PlanSettings::free_time`] the duration `T` is the last unknown,
//! within its bounds; the nodes move with it (`t_k = k T / N`, each
//! segment `h = T / N` long, its input tables stretched with it). The
//! objective may weigh it ([`Objective::time_weight`]; [`Objective::time`]
//! alone: least time). A segment's end depends on `h` exactly as
//! `dx/dh = f(x_end, u_k+1) - sum_j S_{u_j,k+1} (u_j,k+1 - u_j,k) / h`:
//! the state's rate at the end (the run extended), less the end's
//! sensitivity to its last input node times the inputs' stretch (a table
//! through fixed nodes on a longer segment is, at each time, the same
//! table with its last node moved back); the chain through the nodes
//! carries it on. The effort is linear in `h`. A user's objective or path
//! function is differenced with respect to the nodes' times (no extra
//! simulation). The least time of a bounded input is a bang-bang one:
//! piecewise linear through the nodes, it is as good as the mesh
//! (`O(1 / N)` above the continuous optimum: the tests' sleigh).
//!
//! # Verification
//!
//! The optimizer's own violation is of its segments; after the solve the
//! whole planned input is run through the ordinary simulation (the
//! problem built from the planned tables over `[0, T]`, one run from its
//! initial state) and its end compared with every component of the
//! target ([`Verification`]). That run steps across the inputs' kinks at
//! the nodes, where an adaptive method's error estimate is least
//! reliable: on the sleigh of the tests (DOP853 at 1e-12) it ends 2e-8
//! from the target where the segments' runs end 1e-10 from it (at
//! 1e-14, 2e-9): the verification measures the ordinary run's error as
//! well as the plan's.
//!
//! # Limits
//!
//! The problem's clock restarts at each segment: its other effects must
//! not depend on time (the inputs are its only time functions); the
//! verification run, on the whole horizon, would show a difference.
//! Drives (prescribed motions) and events are refused. A node's
//! partition is chosen at the warm start and kept during a search; where
//! the search ends with the whole state jumping at a node by more than
//! [`JUMP`] times the violation (the dependent components magnified by
//! an ill-conditioned partition: the EzyRoller's forward speed from its
//! two angular rates when its fork is straight), the nodes are
//! partitioned again there and the search restarted, at most
//! [`RESTARTS`] times; a plan that still jumps is not optimal
//! ([`Maneuver::state_jump`]). The nodes' states are kept within a box
//! ([`PlanSettings::state_box`]). SLSQP is a local method:
//! [`Status::Infeasible`] says that no point it and a minimization of
//! the violation reached met the target, with the least violation found,
//! not a proof. An optimal status needs feasibility, no jump, no node on
//! its box, and the first-order conditions' residual below
//! [`STATIONARY`]: an optimizer that stops where it started (a zero input
//! at rest, whose effort gradient is zero) is not optimal unless the
//! start meets the target.

mod check;
mod nlp;
mod objective;
mod path;
mod shooting;
mod transcription;
mod verify;

#[cfg(test)]
mod tests;

use std::sync::Arc;
use std::time::Instant;

use crate::analysis::AnalysisError;
use crate::effects::waveform::{Extrapolate, Table, Waveform};
use crate::error::SimError;
use crate::model::Model;
use crate::problem::Problem;
pub use objective::{Objective, ObjectiveGradient, SampleGradient, Samples, UserObjective, UserValue};
pub use path::PathConstraint;
use transcription::Transcription;

/// How a problem is built from its inputs' tables (one per [`Input`], in
/// their order; each a [`Table`] of time \[s\] to the input's value).
pub type BuildInputs<M> = dyn Fn(&[Table]) -> Result<Problem<M>, SimError> + Send + Sync;

/// Most unknowns a plan takes (input nodes and nodes' state components):
/// SLSQP is dense, its work `O(n^2)` memory and `O(n^3)` a step, and its
/// quadratic subproblem (each equality a pair of inequalities) calls
/// nothing back: measured on the EzyRoller (2 cores), 590 unknowns stop
/// on Ctrl-C 2 s after the signal, 1395 not in 10 minutes. 500 keeps a
/// stop near a second and holds the EzyRoller's 50 segments (345).
pub const MAX_UNKNOWNS: usize = 500;

/// Stationarity (relative residual of `grad f + J^T lambda = 0`) below
/// which a feasible point is optimal.
pub const STATIONARY: f64 = 1e-5;

/// The largest jump of the whole state at a node, as a multiple of the
/// tolerance, that a solution may have (the equalities hold the
/// independent components to the tolerance; the dependent ones follow
/// through the node's partition, magnified by its conditioning).
pub const JUMP: f64 = 100.0;

/// Searches restarted with the nodes partitioned again where the state
/// jumped (see [`JUMP`]).
pub const RESTARTS: usize = 3;

/// The largest jump of a state component at the nodes of `p` and where.
fn state_jump(p: &transcription::Point, names: &[String]) -> (f64, String) {
    let mut out = (0.0, String::new());
    for k in 1..p.starts.len() {
        for (i, (a, b)) in p.ends[k - 1].iter().zip(&p.starts[k]).enumerate() {
            if (a - b).abs() > out.0 {
                out = ((a - b).abs(), format!("{} at node {k}", names[i]));
            }
        }
    }
    out
}

/// An input of a plan: a named piecewise-linear function of time within
/// bounds (its unit the quantity it drives: \[N\] for a force, \[N m\] for
/// a torque).
#[derive(Debug, Clone, PartialEq)]
pub struct Input {
    /// Its name.
    pub name: String,
    /// Lower bound (may be `-inf`).
    pub lower: f64,
    /// Upper bound (may be `inf`).
    pub upper: f64,
    /// The warm start's input: its values at the nodes (a constant, or
    /// a waveform where the target cannot be reached to first order from
    /// a constant: a vehicle propelled by oscillation).
    pub guess: Waveform,
}

impl Input {
    /// The input `name` within `[lower, upper]`, its guess 0 (or the
    /// bound nearest 0).
    pub fn new(name: impl Into<String>, lower: f64, upper: f64) -> Self {
        Self { name: name.into(), lower, upper, guess: Waveform::Constant(0.0f64.max(lower).min(upper)) }
    }

    /// The same input with the warm start's value `guess` throughout.
    #[must_use]
    pub fn guess(mut self, guess: f64) -> Self {
        self.guess = Waveform::Constant(guess);
        self
    }

    /// The same input with the warm start's values `guess(t_k)` at the nodes.
    #[must_use]
    pub fn guess_waveform(mut self, guess: Waveform) -> Self {
        self.guess = guess;
        self
    }
}

/// The state a plan ends in at `t_end`: components of `q` \[m or rad\]
/// and `qd` \[m/s or rad/s\] by coordinate name.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Target {
    /// `(coordinate, is a velocity, value)`.
    pub entries: Vec<(String, bool, f64)>,
    /// Every velocity zero.
    pub rest: bool,
}

impl Target {
    /// No component yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Coordinate `name` at `value` \[m or rad\].
    #[must_use]
    pub fn q(mut self, name: &str, value: f64) -> Self {
        self.entries.push((name.into(), false, value));
        self
    }

    /// Velocity of coordinate `name` at `value` \[m/s or rad/s\].
    #[must_use]
    pub fn qd(mut self, name: &str, value: f64) -> Self {
        self.entries.push((name.into(), true, value));
        self
    }

    /// At rest: every velocity zero (with any components given).
    #[must_use]
    pub fn at_rest(mut self) -> Self {
        self.rest = true;
        self
    }
}

/// The mesh and the solver's limits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlanSettings {
    /// Segments N (the inputs have N + 1 nodes).
    pub segments: usize,
    /// Duration T \[s\].
    pub t_end: f64,
    /// Feasibility: the largest violation of a continuity or target
    /// equality a solution may have, in its state component's units
    /// \[m, rad, m/s, rad/s\].
    pub tolerance: f64,
    /// Most evaluations (each N segment runs with sensitivities).
    pub max_evaluations: usize,
    /// Most unknowns, at most [`MAX_UNKNOWNS`].
    pub max_unknowns: usize,
    /// The box the nodes' state components are kept in, as a multiple
    /// of each one's scale (the largest of 1 and its magnitudes over the
    /// warm start and the target \[its unit\]): a trust region against
    /// SLSQP's first quasi-Newton steps, which on a vehicle propelled by
    /// oscillation (the EzyRoller) jumped to headings of 1e5 rad. A
    /// solution with a node on its box is not optimal.
    pub state_box: f64,
    /// Shooting intervals M (1 ... N): the state is an unknown at the
    /// nodes that start one; inside an interval each segment starts
    /// from the last one's end (M = 1, the default: single shooting;
    /// M = N: a node at every segment). Single shooting is the default
    /// because it is the one that converges on the vehicles measured
    /// (docs/dev/planning.md: the EzyRoller's 50 segments optimal in 6 s
    /// with M = 1 and M = 2, infeasible with M = 5, 10 and 50, its nodes'
    /// partitions ill-conditioned); take M > 1 for dynamics unstable
    /// over the horizon, where a single run's sensitivities grow too fast.
    pub intervals: usize,
    /// A free duration: `T` an unknown within `[lower, upper]` \[s\]
    /// (`0 < lower <= t_end <= upper`), started at [`PlanSettings::t_end`];
    /// `None` (the default): `T = t_end`. The nodes move with it, `t_k =
    /// k T / N`; each segment's end is differentiated with respect to its
    /// duration exactly (see the module's docs). With
    /// [`Objective::time`], a minimum-time plan.
    pub free_time: Option<(f64, f64)>,
}

impl PlanSettings {
    /// `segments` segments over `t_end` seconds, tolerance 1e-8, 500
    /// evaluations, [`MAX_UNKNOWNS`], a state box of 10, single shooting.
    pub fn new(segments: usize, t_end: f64) -> Self {
        Self {
            segments,
            t_end,
            tolerance: 1e-8,
            max_evaluations: 500,
            max_unknowns: MAX_UNKNOWNS,
            state_box: 10.0,
            intervals: 1,
            free_time: None,
        }
    }

    /// The program's unknowns for `inputs` inputs on a model whose state
    /// has `independent` independent components (`2 nq - nh - nc`): the
    /// inputs' `N + 1` nodes each and the state at the `M - 1` inner
    /// nodes that start a shooting interval. Counted in `u128`, so no
    /// request overflows it; compare it with [`PlanSettings::max_unknowns`]
    /// before anything is allocated.
    pub fn unknowns(&self, inputs: usize, independent: usize) -> u128 {
        inputs as u128 * (self.segments as u128 + 1)
            + (self.intervals as u128).saturating_sub(1) * independent as u128
            + u128::from(self.free_time.is_some())
    }
}

/// A planning problem: inputs, target, mesh, and how the problem is built.
#[derive(Clone)]
pub struct Plan<M: Model> {
    /// The inputs.
    pub inputs: Vec<Input>,
    /// The target at `t_end`.
    pub target: Target,
    /// Mesh and limits.
    pub settings: PlanSettings,
    build: Arc<BuildInputs<M>>,
    /// Asked between segment runs and at each step of one
    /// ([`Plan::stop_when`]).
    stop: Option<fn() -> bool>,
    /// What is minimized ([`Plan::with_objective`]).
    objective: Objective,
    /// Bounds at the nodes ([`Plan::with_path`]).
    path: Vec<PathConstraint>,
}

impl<M: Model> std::fmt::Debug for Plan<M> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Plan")
            .field("inputs", &self.inputs)
            .field("target", &self.target)
            .field("settings", &self.settings)
            .field("objective", &self.objective)
            .field("path", &self.path)
            .finish_non_exhaustive()
    }
}

/// How a plan ended.
#[derive(Debug, Clone, PartialEq)]
pub enum Status {
    /// Feasible within the tolerance and stationary (the first-order
    /// conditions hold to [`STATIONARY`]).
    Optimal,
    /// Feasible but not shown stationary: the budget spent or SLSQP
    /// stopped early; the reason says which.
    NotConverged {
        /// Why, with the stationarity measured.
        reason: String,
    },
    /// No point met the constraints within the tolerance: the least
    /// violation found (the optimization's, then a minimization of the
    /// violation alone) and its constraint.
    Infeasible {
        /// The largest constraint's violation at the least violating point
        /// \[its state component's unit, or its path function's\].
        violation: f64,
        /// That constraint (`target x = 1`, `continuity of xd at node 3`,
        /// `path qd.x <= 0.6 at node 4 (t = 1 s)`).
        constraint: String,
    },
}

/// A target component at the end of the verification run and of the plan.
#[derive(Debug, Clone, PartialEq)]
pub struct TargetError {
    /// The state component (`x`, `xd`).
    pub name: String,
    /// Its target value.
    pub target: f64,
    /// The verification run's end minus the target.
    pub run: f64,
    /// The plan's last segment's end minus the target.
    pub plan: f64,
}

/// The whole planned input run by the ordinary simulation.
#[derive(Debug, Clone, PartialEq)]
pub struct Verification {
    /// Its end state `[q, qd]` (2 nq).
    pub end: Vec<f64>,
    /// Every target component (those the equalities left out too).
    pub errors: Vec<TargetError>,
    /// The largest `|run|` of [`Verification::errors`].
    pub max_run_error: f64,
    /// The largest `|plan|`.
    pub max_plan_error: f64,
    /// The run's steps.
    pub steps: u64,
    /// The largest violation of a path constraint over the run, sampled
    /// eight times per segment (between the nodes, where the plan does
    /// not enforce them), and where (`qd.x = 0.61 at t = 1.2 s`); 0 and
    /// empty where none is violated or there are none.
    pub path_violation: (f64, String),
}

/// A plan's result ([`Plan::solve`]).
#[derive(Debug, Clone)]
pub struct Maneuver {
    /// How it ended.
    pub status: Status,
    /// SLSQP's termination in words.
    pub termination: String,
    /// The nodes' times \[s\] (N + 1).
    pub t: Vec<f64>,
    /// The duration `T` \[s\]: the settings' `t_end`, or with a free
    /// duration the one planned.
    pub t_end: f64,
    /// The bounds of a free duration \[s\] (`None`: fixed).
    pub free_time: Option<(f64, f64)>,
    /// The planned inputs over `[0, T]`, one per input (the least
    /// violating point's where infeasible).
    pub inputs: Vec<Table>,
    /// The effort `sum_j int u_j^2 dt` \[input unit^2 s\] (unweighted).
    pub effort: f64,
    /// The objective minimized, `effort_weight * effort + J_user`
    /// \[input unit^2 s, or the user's term's unit\].
    pub objective: f64,
    /// The objective in words ([`Objective::describe`]: `effort`,
    /// `0 x effort + name`).
    pub objective_name: String,
    /// The user's term `J_user` at the point returned, if the objective
    /// has one.
    pub user_objective: Option<f64>,
    /// How the objective's gradient was had: exact, or the user's term
    /// differenced with respect to the samples at some evaluation.
    pub objective_gradient: ObjectiveGradient,
    /// The largest constraint violation at the point returned (an
    /// equality's, or a path inequality's excess), and its constraint.
    pub violation: (f64, String),
    /// Relative residual of the first-order conditions (see [`STATIONARY`]).
    pub stationarity: f64,
    /// Whether the first-order check read the multipliers' signs (an
    /// active inequality's, a bound's): false where they are not
    /// determined (a vertex: fewer free unknowns than active rows, as a
    /// bang-bang input's) or there are none, when
    /// [`Maneuver::stationarity`] is the residual alone.
    pub signs_checked: bool,
    /// The largest jump of any state component (independent or not) from
    /// a segment's end to the next one's start \[its unit\], and where:
    /// the continuity of the whole state, which the equalities on the
    /// independent components give only where the node's partition is
    /// well conditioned.
    pub state_jump: (f64, String),
    /// The state's names (2 nq).
    pub names: Vec<String>,
    /// The state at each node (N + 1 of 2 nq): each segment's start, and the last one's end.
    pub states: Vec<Vec<f64>>,
    /// The verification run, or why it failed.
    pub verification: Result<Verification, String>,
    /// Unknowns and equalities of the program.
    pub unknowns: usize,
    /// Equalities.
    pub equalities: usize,
    /// Path inequalities (one per finite bound per node).
    pub inequalities: usize,
    /// A path constraint's function was differenced with respect to its
    /// node's sample at some evaluation.
    pub path_differenced: bool,
    /// Evaluations of the program (N segment runs each).
    pub evaluations: usize,
    /// Segment runs.
    pub runs: usize,
    /// Wall time of the solve \[s\].
    pub seconds: f64,
    /// The stop hook ended the search ([`Plan::stop_when`]): the best
    /// point so far, not verified, never optimal.
    pub stopped: bool,
}

impl Maneuver {
    /// Whether it is [`Status::Optimal`].
    pub fn optimal(&self) -> bool {
        self.status == Status::Optimal
    }
}

impl<M: Model> Plan<M> {
    /// The plan of `inputs` to `target` on the mesh of `settings`, the
    /// problem built from the inputs' tables by `build`, minimizing the
    /// effort ([`Objective::effort`]).
    ///
    /// # Errors
    /// [`AnalysisError::Request`] naming the culprit: no input, a name
    /// given twice, a bound that is NaN or a lower above its upper, a
    /// guess not finite or outside its bounds at a node, no target component or a
    /// value not finite, no segments, a `t_end` not finite and > 0, a
    /// tolerance not in (0, 1), a state box not finite and >= 1, fewer
    /// than 2 evaluations, a limit on
    /// unknowns past [`MAX_UNKNOWNS`] or segments past it.
    pub fn new(
        inputs: Vec<Input>,
        target: Target,
        settings: PlanSettings,
        build: impl Fn(&[Table]) -> Result<Problem<M>, SimError> + Send + Sync + 'static,
    ) -> Result<Self, AnalysisError> {
        Self::with_objective(inputs, target, settings, Objective::effort(), build)
    }

    /// As [`Plan::new`], minimizing `objective`: the effort times its
    /// weight plus the user's term of the samples (see [`Samples`]). With
    /// a user's term the target may be empty (no component: a free end).
    ///
    /// # Errors
    /// As [`Plan::new`] (no target only without a user's term), and
    /// [`AnalysisError::Request`] for an effort weight not finite and
    /// >= 0, or 0 without a user's term.
    pub fn with_objective(
        inputs: Vec<Input>,
        target: Target,
        settings: PlanSettings,
        objective: Objective,
        build: impl Fn(&[Table]) -> Result<Problem<M>, SimError> + Send + Sync + 'static,
    ) -> Result<Self, AnalysisError> {
        check::request(&inputs, &target, &settings, &objective)?;
        Ok(Self { inputs, target, settings, build: Arc::new(build), stop: None, objective, path: Vec::new() })
    }

    /// The same plan with the path constraints `path`: bounds on a state
    /// component or a function of the user's own at every node (see
    /// [`PathConstraint`]; Betts 2010 §4.2), in addition to the inputs'
    /// bounds and the target.
    ///
    /// # Errors
    /// [`AnalysisError::Request`] for a bound that is NaN, a lower above
    /// its upper, both infinite, or a name given twice with the same
    /// bound kind. A coordinate the model does not have and a state
    /// component's bound the initial state violates are refused by
    /// [`Plan::solve`], which builds the model.
    pub fn with_path(mut self, path: Vec<PathConstraint>) -> Result<Self, AnalysisError> {
        for p in &path {
            p.check().map_err(|reason| AnalysisError::Request { reason })?;
        }
        self.path = path;
        Ok(self)
    }

    /// The path constraints.
    pub fn path(&self) -> &[PathConstraint] {
        &self.path
    }

    /// What the plan minimizes.
    pub fn objective(&self) -> &Objective {
        &self.objective
    }

    /// The same plan asking `stop` (a signal handler's flag: `ezy` stops
    /// on Ctrl-C) before each segment run and at every step of one: a
    /// stop ends the search at once with the best point so far
    /// ([`Maneuver::stopped`]; no verification run), or with
    /// [`AnalysisError::Stopped`] before the first point is evaluated.
    #[must_use]
    pub fn stop_when(mut self, stop: fn() -> bool) -> Self {
        self.stop = Some(stop);
        self
    }

    /// Whether the stop hook says stop.
    fn stopping(&self) -> bool {
        self.stop.is_some_and(|s| s())
    }

    /// The tables over `[0, T]` through `w`'s input nodes.
    fn tables<N: Model>(&self, tr: &Transcription<N>, w: &[f64]) -> Vec<Table> {
        (0..self.inputs.len())
            .map(|j| Table { t: tr.mesh_at(w), value: tr.input_nodes(w, j).to_vec(), extrapolate: Extrapolate::Hold })
            .collect()
    }

    /// The nodes' times \[s\].
    fn mesh(&self) -> Vec<f64> {
        let (n, t) = (self.settings.segments, self.settings.t_end);
        (0..=n).map(|k| if k == n { t } else { t * k as f64 / n as f64 }).collect()
    }

    /// The warm start: the problem `first` (built with the guesses) run
    /// segment by segment, each from the last one's end; the node
    /// states (N + 1 of 2 nq).
    fn warm_start(&self, first: &Problem<M>, h: f64, guess: &[f64]) -> Result<Vec<Vec<f64>>, AnalysisError> {
        let n2 = 2 * first.model.info().nq();
        let mut x = vec![first.initial_state()?.0[..n2].to_vec()];
        let nodes = self.settings.segments + 1;
        for k in 0..self.settings.segments {
            let u: Vec<f64> = guess.chunks_exact(nodes).flat_map(|g| [g[k], g[k + 1]]).collect();
            let start = if k == 0 {
                None
            } else {
                let node = shooting::node_start(&first.model, &x[k], k)?;
                let z = node.comps.iter().map(|&c| x[k][c]).collect();
                Some((Arc::new(node), z))
            };
            if self.stopping() {
                return Err(AnalysisError::Stopped);
            }
            let (_, end) = shooting::SegmentSpec::new(&self.build, h, u, start).simulate()?;
            x.push(end);
        }
        Ok(x)
    }

    /// The bounds of the unknowns: the inputs' own, the nodes' states
    /// within their box.
    fn bounds<N: Model>(&self, tr: &Transcription<N>, sc: &nlp::Scales) -> Vec<(f64, f64)> {
        let (b, nodes) = (self.settings.state_box, self.settings.segments + 1);
        (0..tr.n)
            .map(|c| match (self.inputs.get(c / nodes), self.settings.free_time) {
                (Some(i), _) if c < tr.n_inputs() => (i.lower, i.upper),
                (_, Some(range)) if c == tr.col_t() => range,
                _ => (-b * sc.w[c], b * sc.w[c]),
            })
            .collect()
    }

    /// The point a search ends with: its best where feasible, else its
    /// least violating.
    fn point<'e>(&self, ended: &'e nlp::Ended) -> &'e transcription::Point {
        if nlp::violation(&ended.best).0 <= self.settings.tolerance { &ended.best } else { &ended.least }
    }

    /// How the search ended at `point`: infeasible, a state jump or a
    /// node on its box, stationary or not.
    fn verdict<N: Model>(
        &self,
        tr: &Transcription<N>,
        point: &transcription::Point,
        (bounds, stationarity, jump): (&[(f64, f64)], f64, &(f64, String)),
        termination: &str,
    ) -> Status {
        let (v, row) = nlp::violation(point);
        let boxed = (tr.n_inputs()..tr.n)
            .filter(|&c| !(tr.free_time && c == tr.col_t()))
            .find(|&c| point.w[c].abs() >= (1.0 - 1e-9) * bounds[c].1);
        let not = |reason: String| Status::NotConverged { reason: format!("{termination}; {reason}") };
        if v > self.settings.tolerance {
            Status::Infeasible { violation: v, constraint: tr.row_name(row) }
        } else if jump.0 > JUMP * self.settings.tolerance {
            not(format!(
                "the state jumps by {:.1e} in {} where the equalities on the nodes' independent components hold: a node's partition is ill-conditioned at this point",
                jump.0, jump.1
            ))
        } else if let Some(c) = boxed {
            not(format!(
                "a node's state is at its box (unknown {c}, {} x its scale: PlanSettings::state_box)",
                self.settings.state_box
            ))
        } else if stationarity <= STATIONARY {
            Status::Optimal
        } else {
            not(format!("the first-order conditions' residual is {stationarity:.1e} (optimal below {STATIONARY:.0e})"))
        }
    }

    /// The inputs of least objective to the target (see the module's
    /// docs; the effort by default).
    ///
    /// # Errors
    /// [`AnalysisError::Request`] for a target name the model does not
    /// have, a problem with drives or events, more unknowns than
    /// [`PlanSettings::max_unknowns`] (before anything of their size is
    /// allocated), inputs that do not act on the problem (every segment's
    /// end insensitive to them at the warm start); the problem's or a
    /// run's failure ([`AnalysisError::Sim`]) at the warm start. Not an
    /// infeasible target (that is [`Status::Infeasible`]), nor runs that
    /// fail during the search (five in a row end it at the best point,
    /// said in [`Maneuver::termination`]). A user's objective that fails,
    /// or returns a value or gradient entry that is not finite, at any
    /// point ends the solve with [`AnalysisError::Request`] naming it
    /// (and the sample of a gradient's entry).
    pub fn solve(&self) -> Result<Maneuver, AnalysisError> {
        let clock = Instant::now();
        let (n_seg, h) = (self.settings.segments, self.settings.t_end / self.settings.segments as f64);
        let names: Vec<String> = self.inputs.iter().map(|i| i.name.clone()).collect();
        let mesh = self.mesh();
        let guess: Vec<f64> = self.inputs.iter().flat_map(|i| mesh.iter().map(|&t| i.guess.eval(t))).collect();
        let first = check::problem(self, &guess)?;
        let target = check::target(&first, &self.target)?;
        let mut x = self.warm_start(&first, h, &guess)?;
        let mut tr = Transcription::new(&self.build, names, (n_seg, h, self.settings.intervals), &first.model, &x)?;
        tr.runs = n_seg;
        tr.stop = self.stop;
        tr.objective = self.objective.clone();
        tr.t.clone_from(&mesh);
        if self.settings.free_time.is_some() {
            tr.free_time();
        }
        let mut w = guess;
        w.resize(tr.n, 0.0);
        tr.gather(&x, &mut w);
        if tr.free_time {
            w[tr.col_t()] = self.settings.t_end;
        }
        // the user's term at the warm start: the objective's scale
        let user0 = match &self.objective.user {
            Some((name, f)) => objective::value_only(&**f, name, &tr.samples(&w, &x[..1], &x[1..]))
                .map_err(|reason| AnalysisError::Request { reason })?,
            None => 0.0,
        };
        tr.set_target(check::independent(&first.model, &x[n_seg], &target));
        let path = path::resolve(&first.model, &self.path, &x[0])?;
        tr.set_path(path.clone());
        let (mut evaluations, mut termination) = (0, Vec::new());
        let (ended, sc, bounds) = loop {
            let sc = check::scales(self, &tr, (&x, user0), &target);
            let bounds = self.bounds(&tr, &sc);
            let budget = self.settings.max_evaluations - evaluations;
            let ended = nlp::solve(&mut tr, &sc, &w, &bounds, (self.settings.tolerance, budget))?;
            evaluations += ended.evaluations;
            termination.push(ended.termination.clone());
            let point = self.point(&ended);
            let jump = state_jump(point, &tr.names);
            // a jump in an independent component is a violation; one in
            // a dependent component past it, the partition's conditioning
            let limit = JUMP * self.settings.tolerance.max(nlp::violation(point).0);
            if ended.stopped
                || jump.0 <= limit
                || termination.len() > RESTARTS
                || evaluations + 2 > self.settings.max_evaluations
            {
                break (ended, sc, bounds);
            }
            // the nodes partitioned again where the search ended
            x = point.starts.clone();
            x.push(point.ends.last().cloned().unwrap_or_default());
            w = point.w.clone();
            tr.repartition(&first.model, &x)?;
            tr.gather(&x, &mut w);
            termination.push(format!("the nodes partitioned again (the state jumped {:.1e} in {})", jump.0, jump.1));
        };
        let termination = termination.join("; ");
        let point = self.point(&ended);
        let (stationarity, signs_checked) = nlp::stationarity(point, &sc, &bounds, self.settings.tolerance);
        let (v, row) = nlp::violation(point);
        let jump = state_jump(point, &tr.names);
        let status = match self.verdict(&tr, point, (&bounds, stationarity, &jump), &termination) {
            Status::Optimal if ended.stopped => {
                Status::NotConverged { reason: format!("{termination}: the best point when it stopped") }
            }
            s => s,
        };
        let tables = self.tables(&tr, &point.w);
        let mesh = tr.mesh_at(&point.w);
        let t_end = mesh.last().copied().unwrap_or(self.settings.t_end);
        let last = point.ends.last().cloned().unwrap_or_default();
        let verification = if ended.stopped {
            Err("stopped before the verification run".into())
        } else {
            verify::verify(&*self.build, &tables, (t_end, n_seg), (&target, &path), &last)
        };
        let mut states = point.starts.clone();
        states.push(last);
        Ok(Maneuver {
            status,
            termination,
            t: mesh,
            t_end,
            free_time: self.settings.free_time,
            inputs: tables,
            effort: point.effort,
            objective: point.objective,
            objective_name: self.objective.describe(),
            user_objective: point.user,
            objective_gradient: if tr.differenced { ObjectiveGradient::Differenced } else { ObjectiveGradient::Exact },
            violation: (v, tr.row_name(row)),
            stationarity,
            signs_checked,
            state_jump: jump,
            names: tr.names.clone(),
            states,
            verification,
            unknowns: tr.n,
            equalities: tr.rows.len(),
            inequalities: tr.path_rows.len(),
            path_differenced: tr.path_differenced,
            evaluations,
            runs: tr.runs,
            seconds: clock.elapsed().as_secs_f64(),
            stopped: ended.stopped,
        })
    }
}
