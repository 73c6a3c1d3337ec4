//! The tables `ezy sensitivity` and `ezy optimize` write:
//! sensitivity.csv, optimum.csv, history.csv, grid.csv
//! (`src/commands/sensitivity.rs`, `src/commands/optimize.rs`; the
//! definitions in `sensitivity`, `design::optimize::quantity`).

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
