//! The tables `ezy geometry` writes: connection.csv, curvature.csv,
//! momentum.csv, gait.csv, gait-path.csv
//! (`src/commands/geometry/tables.rs`; the definitions in `geometry`).

use super::{Column, Table};

const fn c(
    name: &'static str,
    unit: &'static str,
    meaning: &'static str,
    formula: &'static str,
    frame: &'static str,
    source: &'static str,
) -> Column {
    Column { name, unit, meaning, formula, frame, source }
}

const CONNECTION_SOURCE: &str = "Ostrowski & Burdick, The geometric mechanics of undulatory robotic locomotion, IJRR 17(7), 1998; Hatton & Choset, Geometric motion planning, IJRR 30(8), 2011 (its sign convention)";
const MOMENTUM_SOURCE: &str =
    "Bloch, Krishnaprasad, Marsden & Murray, Nonholonomic mechanical systems with symmetry, ARMA 136, 1996";
const HATTON_CHOSET: &str = "Hatton & Choset, Geometric motion planning, IJRR 30(8), 2011";

/// What the geometry calls its reference body.
const BODY_FRAME: &str = "the reference body's own frame (--body; by default the body at the middle of the hinge tree)";

/// The shape coordinate of a row.
const SHAPE: Column = c(
    "<hinge>",
    "rad",
    "A shape coordinate: its hinge's angle, the hinge's first body's heading less its second's",
    "r_i = phi_a - phi_b",
    "relative, so the same in every frame; the row's shape",
    "",
);

const CONNECTION_COLUMNS: &[Column] = &[
    SHAPE,
    c(
        "A_<u|v|w>_<hinge>",
        "m/rad (u, v); rad/rad (w)",
        "The local connection's entry: minus the reference body's forward (u) or lateral (v) velocity or yaw rate (w) per unit rate of the shape coordinate, at zero momentum",
        "xi = (u, v, w) = -A(r) r' + Gamma(r) p; A = Omega^-1 Psi for a kinematic system",
        BODY_FRAME,
        CONNECTION_SOURCE,
    ),
    c(
        "Gamma_<u|v|w>_p_<u|v|w>",
        "(m/s or rad/s) per unit of the momentum component",
        "A mixed system's body velocity per unit of the nonholonomic momentum component p_u (kg m/s), p_v (kg m/s) or p_w (kg m^2/s), each conjugate to the body velocity it names",
        "Gamma = K (K^T I_loc K)^-1, K the locked motions the skates leave free, I_loc the locked inertia",
        BODY_FRAME,
        MOMENTUM_SOURCE,
    ),
    c(
        "rank_margin",
        "",
        "How far from singular the skates' constraints are at this shape: 0 on the singular set (where the connection is not defined), 1 far from it",
        "sigma_min / sigma_max among the 3 - m singular values of Omega(r)",
        "",
        "",
    ),
];

/// `connection.csv`.
pub(super) const CONNECTION: Table = Table {
    file: "connection.csv",
    command: "ezy geometry",
    about: "The local connection at each shape of the grid (or the one shape of --at) where the constraints are regular, one row per shape: xi = -A(r) r' + Gamma(r) p, with xi = (u, v, w) the reference body's velocity in its own frame, r the shape and p the nonholonomic momentum (mixed systems)",
    groups: &[CONNECTION_COLUMNS],
};

const CURVATURE_COLUMNS: &[Column] = &[
    SHAPE,
    c(
        "DA_<x|y|theta>_<hinge>_<hinge>",
        "m/rad^2 (x, y); rad/rad^2 (theta)",
        "The constraint curvature (height function) of a pair of shape coordinates: a small gait enclosing signed area S in their plane (counter-clockwise positive) moves the reference body by about D(-A) S",
        "D(-A)_ij = -(dA_j/dr_i - dA_i/dr_j) + [A_i, A_j]",
        "the reference body's frame at the gait's start; at the row's shape",
        "Hatton & Choset, Geometric motion planning, IJRR 30(8), 2011, §5",
    ),
];

/// `curvature.csv`.
pub(super) const CURVATURE: Table = Table {
    file: "curvature.csv",
    command: "ezy geometry",
    about: "With two or more shape coordinates: the height functions of every pair, one row per shape where the constraints are regular",
    groups: &[CURVATURE_COLUMNS],
};

const MOMENTUM_COLUMNS: &[Column] = &[
    SHAPE,
    c(
        "p_<u|v|w>:<factor>*<factor>",
        "the momentum's unit per second per the factors' units",
        "A coefficient of the momentum equation without forces: the share of the product of two factors (a shape rate, the hinge's name with d appended, or a momentum component) in the rate of the momentum component before the colon",
        "p_j' = sum over a <= b of c_ab z_a z_b, z = [r', p], p = V^T M qd",
        "the reference body's free directions at the row's shape",
        MOMENTUM_SOURCE,
    ),
];

/// `momentum.csv`.
pub(super) const MOMENTUM: Table = Table {
    file: "momentum.csv",
    command: "ezy geometry",
    about: "A mixed system's momentum equation (the forces left out), one row per shape",
    groups: &[MOMENTUM_COLUMNS],
};

const GAIT_COLUMNS: &[Column] = &[
    c(
        "method",
        "",
        "How the net motion is found: first-order (the body-velocity integral), second-order (with the curvature's area integral; two shape coordinates), reconstructed (integrating g' = g xi and the momentum), simulated (the full equations of motion, drives prescribing the shape)",
        "",
        "",
        HATTON_CHOSET,
    ),
    c(
        "dx",
        "m",
        "The reference body's net forward displacement over one cycle of the gait",
        "x of g(0)^-1 g(T)",
        "the reference body's frame at the cycle's start (t = 0)",
        HATTON_CHOSET,
    ),
    c(
        "dy",
        "m",
        "The reference body's net lateral displacement over one cycle",
        "y of g(0)^-1 g(T)",
        "the reference body's frame at the cycle's start (t = 0)",
        HATTON_CHOSET,
    ),
    c(
        "dtheta",
        "rad",
        "The reference body's net rotation over one cycle",
        "theta of g(0)^-1 g(T)",
        "the same in every frame",
        HATTON_CHOSET,
    ),
    c(
        "p_<u|v|w>_end",
        "kg m/s (p_u, p_v); kg m^2/s (p_w)",
        "A momentum component at the cycle's end (reconstructed and simulated rows; empty on the others)",
        "p = K^T E^T M qd",
        "the reference body's free directions; at the cycle's end",
        MOMENTUM_SOURCE,
    ),
];

/// `gait.csv`.
pub(super) const GAIT: Table = Table {
    file: "gait.csv",
    command: "ezy geometry",
    about: "A gait's net motion over one cycle (--gait, or the scene's drives), one row per method",
    groups: &[GAIT_COLUMNS],
};

const PATH_COLUMNS: &[Column] = &[
    c("t", "s", "The time in the cycle, from 0 to the gait's period", "", "the cycle's time", ""),
    c("<hinge>", "rad", "The gait's shape coordinate at t", "r_i(t)", "relative; at t", ""),
    c(
        "x_reconstructed",
        "m",
        "The reference body's position x by the reconstruction",
        "g' = g xi",
        "the reference body's frame at the cycle's start; at t",
        "",
    ),
    c(
        "y_reconstructed",
        "m",
        "The reference body's position y by the reconstruction",
        "g' = g xi",
        "the reference body's frame at the cycle's start; at t",
        "",
    ),
    c(
        "theta_reconstructed",
        "rad",
        "The reference body's heading by the reconstruction",
        "g' = g xi",
        "relative to its heading at the cycle's start; at t",
        "",
    ),
    c(
        "x_simulated",
        "m",
        "The reference body's position x in the simulation (where it ran)",
        "",
        "the reference body's frame at the cycle's start; at the row's sample",
        "",
    ),
    c(
        "y_simulated",
        "m",
        "The reference body's position y in the simulation",
        "",
        "the reference body's frame at the cycle's start; at the row's sample",
        "",
    ),
    c(
        "theta_simulated",
        "rad",
        "The reference body's heading in the simulation",
        "",
        "relative to its heading at the cycle's start; at the row's sample",
        "",
    ),
];

/// `gait-path.csv`.
pub(super) const GAIT_PATH: Table = Table {
    file: "gait-path.csv",
    command: "ezy geometry",
    about: "The gait's path over one cycle, one row per time (201 over the cycle): the shape and the reference body's pose, reconstructed and simulated",
    groups: &[PATH_COLUMNS],
};
