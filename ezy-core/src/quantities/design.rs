//! The tables `ezy sensitivity`, `ezy optimize`, `ezy gait-optimize` and
//! `ezy plan` write: sensitivity.csv, optimum.csv, history.csv,
//! grid.csv, gait_optimum.csv, gait_history.csv, plan.csv,
//! plan_summary.csv (`src/commands/sensitivity.rs`,
//! `src/commands/optimize.rs`, `src/commands/gait_optimize.rs`,
//! `src/commands/plan.rs`; the definitions in `sensitivity`,
//! `design::optimize::quantity`, `design::gait`, `plan`).

use super::{Column, Table};

const fn c(
    name: &'static str,
    unit: &'static str,
    meaning: &'static str,
    formula: &'static str,
    frame: &'static str,
) -> Column {
    Column { name, unit, meaning, formula, frame, source: "" }
}

const SENSITIVITY_COLUMNS: &[Column] = &[
    c("t", "s", "The time of the run's output sample", "", "the scene's time"),
    c(
        "d<state>/d<parameter>",
        "the state component's unit per the parameter's",
        "The forward sensitivity: the derivative of a state component (a coordinate, or a rate: the name with d appended) at time t with respect to a parameter of --wrt, everything else the scene gives held, integrated with the run",
        "S(t) = dx(t)/dp, S' = (df/dx) S + df/dp, S(0) = dx(0)/dp",
        "the run's world frame (the frame of the state's columns); at t",
    ),
];

/// `sensitivity.csv`.
pub(super) const SENSITIVITY: Table = Table {
    file: "sensitivity.csv",
    command: "ezy sensitivity",
    about: "A run's state's derivatives with respect to parameters (--wrt), one row per output sample, parameter by parameter",
    groups: &[SENSITIVITY_COLUMNS],
};

/// Where an optimization takes a gait: the forcing's phase 0.
const GAIT_FRAME: &str = "the gait at the forcing's phase 0 (t0 = 0)";

/// The quantities an optimization takes, with its parameters.
const PARAMETERS: &[Column] =
    &[c("<parameter>", "the parameter's", "A parameter optimized (--over NAME=LO:HI): its value", "", "")];

/// Every quantity an objective or a constraint may be, the gait's as
/// periodic.csv defines them (their names `GaitQuantity::name`).
pub(crate) const OBJECTIVES: &[Column] = &[
    c(
        "gait.mean_speed",
        "m/s",
        "The gait's mean speed: the reference body's (the model's first body's) net displacement over a period per period (periodic.csv's mean_speed)",
        "|(dx, dy)| / T",
        GAIT_FRAME,
    ),
    c(
        "gait.mean_forward_speed",
        "m/s",
        "The displacement along the reference body's heading at the period's start, per period (periodic.csv's mean_forward_speed)",
        "dx / T",
        GAIT_FRAME,
    ),
    c(
        "gait.displacement",
        "m",
        "The length of the reference body's net displacement over a period",
        "|(dx, dy)| = mean_speed T",
        GAIT_FRAME,
    ),
    c(
        "gait.dx",
        "m",
        "The reference body's forward displacement per period (periodic.csv's dx)",
        "(p(t0 + T) - p(t0)) . e(t0)",
        "the reference body's frame at the period's start; the gait at the forcing's phase 0",
    ),
    c(
        "gait.dy",
        "m",
        "The reference body's lateral displacement per period (periodic.csv's dy)",
        "(p(t0 + T) - p(t0)) . n(t0)",
        "the reference body's frame at the period's start; the gait at the forcing's phase 0",
    ),
    c(
        "gait.dheading",
        "rad",
        "The reference body's heading change per period (periodic.csv's dheading)",
        "phi(t0 + T) - phi(t0)",
        "the same in every frame and at every phase",
    ),
    c(
        "gait.mean_power",
        "W",
        "The actuators' mean input power over a period (periodic.csv's mean_power)",
        "E / T",
        GAIT_FRAME,
    ),
    c(
        "gait.efficiency",
        "m/J",
        "The mean speed per mean input power (periodic.csv's efficiency)",
        "mean_speed / mean_power",
        GAIT_FRAME,
    ),
    c("gait.period", "s", "The gait's period T (periodic.csv's period)", "x(t0 + T) = h . x(t0)", ""),
    c(
        "<metric>",
        "its column's",
        "A function of a run over its output columns: final(COLUMN), mean(COLUMN, T0, T1), max(..), min(..) of a column or of norm(A, B); event_time(NAME), event_count(NAME)",
        "mean(c, t0, t1) = the mean of c over the output rows with t0 <= t <= t1",
        "the run's output (its world frame), over the times it names",
    ),
];

const EVALUATION: &[Column] = &[c("evaluation", "", "The evaluation's number, from 1, in the order taken", "", "")];

const GRADIENT: &[Column] = &[c(
    "d<objective>/d<parameter>",
    "the objective's unit per the parameter's",
    "The objective's derivative with respect to a parameter optimized at this evaluation (a gait's by the implicit function theorem, a run's by its sensitivities); empty where the evaluation failed",
    "",
    "as the objective",
)];

const FAILURE: &[Column] =
    &[c("failure", "", "Why the evaluation failed (no gait found, a run stopped); empty where it did not", "", "")];

/// `optimum.csv`.
pub(super) const OPTIMUM: Table = Table {
    file: "optimum.csv",
    command: "ezy optimize",
    about: "The best point in one row: the parameters optimized, then the objective, then each constraint's quantity (--subject-to), in that order",
    groups: &[PARAMETERS, OBJECTIVES],
};

/// `history.csv`.
pub(super) const HISTORY: Table = Table {
    file: "history.csv",
    command: "ezy optimize",
    about: "Every evaluation of the optimization, one row each: the parameters, the objective, each constraint's quantity, the objective's gradient and why it failed (empty cells where it did)",
    groups: &[EVALUATION, PARAMETERS, OBJECTIVES, GRADIENT, FAILURE],
};

/// `grid.csv`.
pub(super) const GRID: Table = Table {
    file: "grid.csv",
    command: "ezy optimize",
    about: "The objective on a grid around the optimum (one or two parameters, --grid N points per axis), one row per point, as history.csv without the gradient",
    groups: &[EVALUATION, PARAMETERS, OBJECTIVES, FAILURE],
};

/// Where a plan's node is: its time on the mesh.
const NODE: &str = "the node at time t (the world frame of the state's columns)";

const PLAN_COLUMNS: &[Column] = &[
    c(
        "t",
        "s",
        "The time of a node of the plan's mesh: N + 1 nodes over [0, t_end] (--segments N)",
        "t_k = k t_end / N",
        "",
    ),
    c(
        "<input>",
        "the input's (N for a force, N m for a torque)",
        "An input planned (--input EFFECT.FIELD): its value at the node; the input is linear between nodes (the effect's time function replaced by this table)",
        "u(t) = u_k + (u_k+1 - u_k) (t - t_k) / (t_k+1 - t_k)",
        NODE,
    ),
    c(
        "<state>",
        "m or rad (a rate: m/s or rad/s)",
        "The plan's state at the node: each segment's start (its independent components the program's unknowns, the others completed on the constraints), and the last segment's end at t_end",
        "",
        NODE,
    ),
];

/// `plan.csv`.
pub(super) const PLAN: Table = Table {
    file: "plan.csv",
    command: "ezy plan",
    about: "The planned inputs at the nodes of the time mesh, one row per node: the time, each input's value, the state (the least violating point's where the plan is infeasible)",
    groups: &[PLAN_COLUMNS],
};

/// Where a plan's end is compared with its target.
const END: &str = "at t_end; the world frame of the state's columns";

const PLAN_SUMMARY_COLUMNS: &[Column] = &[
    c("status", "", "How the plan ended: optimal (feasible and stationary), not_converged, or infeasible", "", ""),
    c(
        "effort",
        "the inputs' units squared times s",
        "The effort the plan minimizes: the inputs squared integrated over [0, t_end], summed (exact for the piecewise-linear inputs)",
        "sum_j int_0^T u_j(t)^2 dt, int u^2 = h/3 (u_k^2 + u_k u_k+1 + u_k+1^2) on a segment",
        "over [0, t_end]",
    ),
    c(
        "violation",
        "the constraint's state component's",
        "The largest violation of the program's equalities (continuity at the inner nodes, the target at the end) at the point returned",
        "max_i |c_i(w)|",
        "",
    ),
    c("violated", "", "The equality with the largest violation (target x = 1, continuity of xd at node 3)", "", ""),
    c(
        "stationarity",
        "",
        "The relative residual of the first-order conditions at the point returned, on the unknowns not at a bound, in the scaled unknowns and equalities, lambda by least squares (optimal below 1e-5); without equalities (a free end under an objective of the user's own), |grad f| over the sum of its two terms' norms, the weighted effort's and the user's",
        "min_lambda |grad f + J^T lambda| / |grad f| (0 where grad f = 0); without equalities |grad f| / (|grad f_effort| + |grad f_user|)",
        "",
    ),
    c(
        "state_jump",
        "the state component's",
        "The largest jump of any state component from a segment's end to the next segment's start",
        "max_k,i |x_i(t_k^-) - x_i(t_k^+)|",
        "at the inner nodes",
    ),
    c("evaluations", "", "The program's evaluations (each runs every segment with its sensitivities)", "", ""),
    c("runs", "", "The segment runs, with and without sensitivities", "", ""),
    c(
        "unknowns",
        "",
        "The program's unknowns: the input nodes and the inner nodes' independent state components",
        "",
        "",
    ),
    c(
        "t_end",
        "s",
        "The plan's duration T: the scene's t_end, or with --free-time the one planned (the least with --minimize time)",
        "",
        "",
    ),
    c("equalities", "", "The program's equalities: continuity at the inner nodes and the target's components", "", ""),
    c(
        "inequalities",
        "",
        "The program's path inequalities (--path): one per finite bound at each node, nodes 1 to N for a state column (node 0 is the initial state)",
        "",
        "",
    ),
    c(
        "path_excess",
        "the bounded column's unit (m, rad, m/s or rad/s)",
        "The largest excess of a path constraint over the verification run, sampled 8 times per segment: between the nodes, where the plan does not enforce them; 0 where they hold, empty where the run failed",
        "max_j max(lo - y(t_j), y(t_j) - hi, 0)",
        "over [0, t_end]",
    ),
    c("path_excess_at", "", "Where path_excess is: the column, its value and the time", "", ""),
    c(
        "objective",
        "",
        "What the plan minimized, in words: effort (the default), or the effort times its weight plus a term of the caller's own of the samples at the nodes (Python's plan(objective=f), named by f), the weight 0 leaving the term alone",
        "",
        "",
    ),
    c(
        "objective_value",
        "the inputs' units squared times s (with a term of the caller's own, its unit)",
        "The objective's value at the point returned: the effort times its weight plus the caller's term",
        "effort_weight sum_j int_0^T u_j(t)^2 dt + J_user(t_k, q_k, qd_k, u_k)",
        "over [0, t_end]",
    ),
    c(
        "objective_gradient",
        "",
        "How the objective's gradient was had: exact (the effort's, and the caller's own gradient of the samples), or differenced (the caller's term gave none and was differenced with respect to the samples, no extra simulation); either way chained to the unknowns by the exact sensitivities",
        "",
        "",
    ),
    c(
        "target_<state>",
        "m or rad (a rate: m/s or rad/s)",
        "A component of the target (--to, --at-rest): its value",
        "",
        END,
    ),
    c(
        "run_error_<state>",
        "as target_<state>",
        "The verification's error: the planned inputs run through the ordinary simulation over [0, t_end] from the initial state, its end minus the target",
        "x(T) - x_target",
        END,
    ),
    c(
        "plan_error_<state>",
        "as target_<state>",
        "The plan's own error: its last segment's end minus the target",
        "x_N - x_target",
        END,
    ),
];

/// `plan_summary.csv`.
pub(super) const PLAN_SUMMARY: Table = Table {
    file: "plan_summary.csv",
    command: "ezy plan",
    about: "How a plan ended, in one row: its status, effort, violation, stationarity and size, then each target component's value and its error at the verification run's end and at the plan's",
    groups: &[PLAN_SUMMARY_COLUMNS],
};

/// The Fourier series of a gait.
const FOURIER: &str = "r_i(t) = a_i0 + sum_k (a_ik cos(k omega t) + b_ik sin(k omega t)), omega = 2 pi / T";

const GAIT_OPTIMUM_COLUMNS: &[Column] = &[
    c(
        "coefficient",
        "",
        "A coefficient of the gait's Fourier series: the shape coordinate and a0 (the constant), a<k> (cos(k omega t)) or b<k> (sin(k omega t))",
        FOURIER,
        "",
    ),
    c("start", "rad", "The coefficient's value in the start gait (--gait)", "", "over one period of the gait"),
    c(
        "optimum",
        "rad",
        "The coefficient's value in the best gait found (a coefficient held keeps its start)",
        "",
        "over one period of the gait",
    ),
    c("free", "", "Whether the search varied the coefficient (false: held, as --centre-only holds all but a0)", "", ""),
];

/// `gait_optimum.csv`.
pub(super) const GAIT_OPTIMUM: Table = Table {
    file: "gait_optimum.csv",
    command: "ezy gait-optimize",
    about: "The best gait found, one row per coefficient of its Fourier series: the start's value, the optimum's, and whether it was free",
    groups: &[GAIT_OPTIMUM_COLUMNS],
};

const GAIT_HISTORY_COLUMNS: &[Column] = &[
    c(
        "<coefficient>",
        "rad",
        "A free coefficient of the gait's Fourier series at this evaluation: <hinge>.a0, <hinge>.a<k> or <hinge>.b<k>",
        FOURIER,
        "over one period of the gait",
    ),
    c(
        "objective",
        "m, rad, or per rad of path",
        "The objective at this evaluation: the net motion per cycle (dx, dy, dtheta or along a direction, in the reference body's initial frame) at the order asked, divided by the path length with --per-length; empty where it failed",
        "dx = -oint A_x dr (first order), with the bracket's area integral (second), or g' = g xi integrated (reconstructed)",
        "the reference body's frame at the cycle's start",
    ),
    c("failure", "", "Why the evaluation failed (the gait met the singular set); empty where it did not", "", ""),
];

/// `gait_history.csv`.
pub(super) const GAIT_HISTORY: Table = Table {
    file: "gait_history.csv",
    command: "ezy gait-optimize",
    about: "Every evaluation of the gait optimization, one row each: its free coefficients, the objective and why it failed",
    groups: &[EVALUATION, GAIT_HISTORY_COLUMNS],
};
