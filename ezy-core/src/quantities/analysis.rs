//! The tables `ezy analyze` writes: periodic.csv, equilibria.csv,
//! branch.csv, growth.csv (`src/commands/analyze/report.rs`; the
//! definitions in `analysis::periodic`, `analysis::gait_means`,
//! `analysis::steady`, `analysis::growth`, `sensitivity::gait`).

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

/// The state's unit, a coordinate's or a rate's.
pub(super) const STATE_UNIT: &str = "m or rad; rates m/s or rad/s";

const SEYDEL_7: &str = "Seydel, Practical Bifurcation and Stability Analysis, 3rd ed., 2010, ch. 7";
const KELLY_MURRAY: &str = "Kelly & Murray, Geometric phases and robotic locomotion, J. Robotic Systems 12, 1995, §2";
const BIFURCATIONS: &str = "Seydel, Practical Bifurcation and Stability Analysis, 3rd ed., §5.2 and §7.4-7.6";
const KUZNETSOV_SWITCH: &str = "Kuznetsov, Elements of Applied Bifurcation Theory, 3rd ed., §3.2-3.5 and §10.2; Seydel, Practical Bifurcation and Stability Analysis, 3rd ed., §2.5-2.7 and §5.6";
const FERMI: &str = "Bizyaev, Borisov, Kozlov & Mamaev, Fermi-like acceleration and power-law energy growth in nonholonomic systems, Nonlinearity 32, 3209, 2019";

/// A hinge between two bodies: its angle.
const SHAPE: Column = c(
    "theta_<hinge>",
    "rad",
    "The angle of a hinge between two bodies, its first body's heading less its second's, wrapped",
    "theta_H = phi_a - phi_b wrapped to (-pi, pi]",
    "relative, so the same in every frame; at the row's state's time",
    "",
);

const ORBIT: &[Column] = &[
    c(
        "period",
        "s",
        "The orbit's period T: for a forced scene the period asked (the forcing's, or --period), for a limit cycle the period Newton found",
        "x(t0 + T) = h . x(t0), h a rigid motion of the plane (a limit cycle's crank also turned by whole turns)",
        "",
        "",
    ),
    c(
        "t0",
        "s",
        "The phase the orbit is taken at: the time of the scene's run whose state is the fixed point. A forced scene's gait is taken at the last whole forcing period of the run (at least one), a limit cycle at the run's end",
        "t0 = max(1, floor(t_end / T_f)) T_f (forced), t0 = t_end (limit cycle)",
        "the scene's time",
        "",
    ),
    c(
        "stability",
        "",
        "stable, unstable or neutral: every Floquet multiplier inside the unit circle, one outside it, or neither (some on it, none outside); the family's multipliers 1 left out",
        "stable: |mu_k| < 1 for every k beyond the family's (|ln |mu|| <= 1e-6 counts as on the circle)",
        "modulo the plane's rigid motions; the same at every t0",
        SEYDEL_7,
    ),
    c(
        "family",
        "",
        "Dimension of the family of periodic orbits through this one, modulo the symmetry: as many multipliers are 1 along it and are left out of the stability",
        "",
        "",
        "",
    ),
    c(
        "mean_speed",
        "m/s",
        "The reference body's (the model's first body's) net displacement over a period per period: the chord, not the path, so for a gait that turns it depends on t0 (drift_speed does not)",
        "|(dx, dy)| / T",
        "the same in every frame; from t0 to t0 + T",
        "",
    ),
    c(
        "mean_forward_speed",
        "m/s",
        "The reference body's displacement over a period along its heading at t0, per period",
        "dx / T",
        "the reference body's frame at t0",
        "",
    ),
    c(
        "dx",
        "m",
        "The reference body's displacement over one period, forward: along its heading at t0",
        "(p(t0 + T) - p(t0)) . e(t0), p the body's position, e(t0) its heading's unit vector at t0",
        "the reference body's frame at t0",
        "",
    ),
    c(
        "dy",
        "m",
        "The reference body's displacement over one period, lateral: to the left of its heading at t0",
        "(p(t0 + T) - p(t0)) . n(t0), n(t0) = e(t0) turned by +pi/2",
        "the reference body's frame at t0",
        "",
    ),
    c(
        "dheading",
        "rad",
        "The reference body's heading change over one period (the angle of the period's rigid motion)",
        "phi(t0 + T) - phi(t0)",
        "the same in every frame and at every t0",
        "",
    ),
    c(
        "mean_abs_speed",
        "m/s",
        "The mean over one period of the reference body's speed |v|: the length of its path over a period, per period",
        "(1/T) int_{t0}^{t0+T} |(x', y')| dt",
        "the same in every frame and at every t0",
        "",
    ),
    c(
        "drift_speed",
        "m/s",
        "The drift speed: the root mean square over a period of the speed at which the period's rigid motion carries each point of the reference body's path about its centre; for a gait that does not turn, |(dx, dy)| / T. Unlike mean_speed it does not depend on t0",
        "sqrt((1/T) int_{t0}^{t0+T} (|dth| |p(t) - c| / T)^2 dt), dth = dheading wrapped to (-pi, pi], c the centre of the rotation p -> R(dth) p + b that maps p(t) to p(t + T)",
        "the same in every frame and at every t0",
        KELLY_MURRAY,
    ),
    c(
        "dx_world",
        "m",
        "The displacement over one period in the frame of the scene's run, x component: where the run's reference body goes from t0 to t0 + T once it has settled on this orbit",
        "cos(psi) dx - sin(psi) dy, psi the reference body's heading at t0 in the run",
        "the scene's world frame (its run's), from t0 to t0 + T",
        "",
    ),
    c(
        "dy_world",
        "m",
        "The displacement over one period in the frame of the scene's run, y component",
        "sin(psi) dx + cos(psi) dy, psi the reference body's heading at t0 in the run",
        "the scene's world frame (its run's), from t0 to t0 + T",
        "",
    ),
    SHAPE,
    c(
        "<state>",
        STATE_UNIT,
        "The fixed point x(t0) = [q, qd]: each coordinate (x, y in m, a heading phi in rad) and its rate (the name with d appended), the reference body moved to the origin with heading 0 as far as the symmetry allows",
        "x(t0 + T) = h . x(t0)",
        "a frame whose origin and x axis are the reference body's position and heading at t0; at t0",
        "",
    ),
    c(
        "mu<k>_re",
        "",
        "The real part of the k-th Floquet multiplier of the period map on the constraint manifold modulo the symmetry, largest modulus first (the structural multipliers 1 of a cyclic coordinate or a free rate left out)",
        "mu_k: eigenvalues of d(h^-1 x(t0 + T))/dx0 on the tangent space modulo the group orbit",
        "modulo the plane's rigid motions; the same at every t0",
        SEYDEL_7,
    ),
    c("mu<k>_im", "", "The imaginary part of the k-th Floquet multiplier", "Im mu_k", "as mu<k>_re", SEYDEL_7),
    c(
        "turns_<state>",
        "",
        "A limit cycle's heading that turns through whole revolutions over a period (a crank): its turns per period",
        "x(t0 + T) = h . x(t0) + 2 pi turns in that coordinate",
        "over one period from t0",
        "",
    ),
];

/// The gait's power and efficiency (periodic.csv and branch.csv).
const POWER: &[Column] = &[
    c(
        "mean_power",
        "W",
        "The actuators' mean input power over a period: the effects driven by time (motors, driven wheels, forces and torques with a waveform) and the drives (a prescribed hinge angle's constraint torque times its rate)",
        "E / T, E = int_{t0}^{t0+T} sum over the actuators of force . velocity dt",
        "the same in every frame; over the period from t0",
        "",
    ),
    c(
        "efficiency",
        "m/J",
        "The mean speed per mean input power: the distance per energy put in (left out without input power)",
        "mean_speed / mean_power",
        "as mean_speed (from t0: depends on t0 for a gait that turns)",
        "",
    ),
];

const DERIVATIVES: &[Column] = &[c(
    "d<quantity>/d<parameter>",
    "the quantity's unit per the parameter's",
    "The derivative of a gait's quantity (period, mean_speed, mean_forward_speed, dx, dy, dheading, mean_power, efficiency) with respect to a parameter of --wrt, by the implicit function theorem on the shooting equations: the neighbouring gaits compared at the same phase of the forcing",
    "J dz/dp = -dR/dp in z = (x0, h), then the quantity's derivative along (dx0/dp, dh/dp, dT/dp, dE/dp)",
    "as the quantity, with t0 = k T_f + r moving as r T_f(p) / T_f",
    "Seydel, Practical Bifurcation and Stability Analysis, 3rd ed., §7.1-7.3",
)];

/// `periodic.csv`.
pub(super) const PERIODIC: Table = Table {
    file: "periodic.csv",
    command: "ezy analyze",
    about: "The periodic orbit of a periodically forced scene (a gait), or an autonomous scene's limit cycle, in one row: x(t0 + T) = h . x(t0) with h a rigid motion of the plane. The reference body is the model's first body. The power and efficiency where the gait is a forced scene's, the derivatives with --wrt",
    groups: &[ORBIT, POWER, DERIVATIVES],
};

const STEADY: &[Column] = &[
    c("motion", "", "The steady motion's number, from 1", "", "", ""),
    c(
        "stability",
        "",
        "stable, unstable or neutral: every eigenvalue beyond the family's with negative real part, one with positive real part, or neither",
        "stable: Re lambda_k < 0 for every k beyond the family's zeros (|Re lambda| <= 1e-7 max(1, max_j |lambda_j|) counts as 0)",
        "modulo the plane's rigid motions",
        "",
    ),
    c(
        "family",
        "",
        "Dimension of the family of steady motions through this one, modulo the symmetry (the sleigh's straight motions at every speed: 1): as many eigenvalues are 0 along it and are left out of the stability",
        "",
        "",
        "",
    ),
    c(
        "u",
        "m/s",
        "The reference body's (the model's first body's) forward velocity",
        "(x', y') . e, e its heading's unit vector",
        "the reference body's own frame; constant along the motion",
        "",
    ),
    c(
        "v",
        "m/s",
        "The reference body's lateral velocity (to the left of its heading)",
        "(x', y') . n, n = e turned by +pi/2",
        "the reference body's own frame; constant along the motion",
        "",
    ),
    c("omega", "rad/s", "The reference body's yaw rate", "phi'", "the same in every frame; constant", ""),
    c("speed", "m/s", "The reference body's speed", "sqrt(u^2 + v^2)", "the same in every frame; constant", ""),
    c(
        "curvature",
        "1/m",
        "The curvature of the reference body's path, signed (positive turning left); 0 where it does not translate",
        "omega / speed",
        "the same in every frame; constant",
        "",
    ),
    SHAPE,
    c(
        "<state>",
        STATE_UNIT,
        "The steady motion's state x0 = [q, qd] (x(t) = exp((t - t0) xi) x0): each coordinate and its rate, the reference body moved to the origin with heading 0 as far as the symmetry allows",
        "f(x0) = xi . X(x0), X the symmetry's fields",
        "a frame whose origin and x axis are the reference body's position and heading at the analysis' time",
        "",
    ),
    c(
        "lambda<k>_re",
        "1/s",
        "The real part of the k-th eigenvalue of the linearization on the constraint manifold modulo the symmetry, largest real part first",
        "lambda_k: eigenvalues of A - xi . dX/dx on the tangent space modulo the group orbit",
        "modulo the plane's rigid motions (in the frame moving with the motion)",
        "",
    ),
    c("lambda<k>_im", "1/s", "The imaginary part of the k-th eigenvalue", "Im lambda_k", "as lambda<k>_re", ""),
];

/// `equilibria.csv`.
pub(super) const EQUILIBRIA: Table = Table {
    file: "equilibria.csv",
    command: "ezy analyze",
    about: "The steady motions of a scene that does not change with time, one per row: relative equilibria x(t) = exp((t - t0) xi) x0, motions at constant speed and yaw rate (ordinary equilibria where the scene has no symmetry). The reference body is the model's first body",
    groups: &[STEADY],
};

const BRANCH_HEAD: &[Column] = &[
    c("<parameter>", "the parameter's", "The value of the parameter followed (--continue NAME=LO:HI:N)", "", "", ""),
    c(
        "stability",
        "",
        "stable, unstable or neutral: the row's steady motion's (by its eigenvalues) or periodic orbit's (by its multipliers), as in equilibria.csv and periodic.csv",
        "",
        "modulo the plane's rigid motions",
        "",
    ),
    c(
        "speed",
        "m/s",
        "The reference body's speed: a steady motion's sqrt(u^2 + v^2), a periodic orbit's mean speed |(dx, dy)| / T",
        "",
        "the same in every frame; a periodic row's from its t0 (it depends on t0 for a gait that turns)",
        "",
    ),
    c(
        "turning_rate",
        "rad/s",
        "How fast the row's motion turns: a steady motion's yaw rate, a periodic orbit's heading change per period over its period (0 for a motion that goes straight; opposite on a symmetry-breaking pitchfork's two arms)",
        "omega (steady); dheading / T (periodic)",
        "the same in every frame",
        "",
    ),
    c("period", "s", "A periodic row's period T", "x(t0 + T) = h . x(t0)", "", ""),
    c(
        "t0",
        "s",
        "A periodic row's phase: a forced scene's branch takes its orbits at the forcing's phase 0 (whole forcing periods), so its states are not at periodic.csv's t0 where the parameter changes the forcing's frequency; a limit cycle's at the run's end; a bifurcation's row at the phase it was located at",
        "",
        "the scene's time",
        "",
    ),
    SHAPE,
    c(
        "<state>",
        STATE_UNIT,
        "The row's state: a steady motion's x0, a periodic orbit's fixed point x(t0), the reference body moved to the origin with heading 0 as far as the symmetry allows",
        "",
        "a frame whose origin and x axis are the reference body's position and heading at the row's time (t0 for a periodic row)",
        "",
    ),
    c(
        "lambda<k>_re",
        "1/s",
        "A steady branch's k-th eigenvalue, real part (as equilibria.csv)",
        "",
        "modulo the plane's rigid motions",
        "",
    ),
    c("lambda<k>_im", "1/s", "A steady branch's k-th eigenvalue, imaginary part", "", "as lambda<k>_re", ""),
    c(
        "mu<k>_re",
        "",
        "A periodic branch's k-th Floquet multiplier, real part (as periodic.csv)",
        "",
        "modulo the plane's rigid motions",
        SEYDEL_7,
    ),
    c("mu<k>_im", "", "A periodic branch's k-th Floquet multiplier, imaginary part", "", "as mu<k>_re", SEYDEL_7),
];

const BIFURCATION: &[Column] = &[
    c(
        "bifurcation",
        "",
        "On a bifurcation's row, its kind: fold, branch point, period doubling, Neimark-Sacker or Hopf; with --switch, a branch point told transcritical or pitchfork by the branches born there (empty on the other rows)",
        "",
        "",
        BIFURCATIONS,
    ),
    c(
        "critical_re",
        "1/s for an eigenvalue, none for a multiplier",
        "On a bifurcation's row, the real part of the eigenvalue (steady branch) or multiplier (periodic branch) that crosses there",
        "",
        "modulo the plane's rigid motions",
        BIFURCATIONS,
    ),
    c(
        "critical_im",
        "1/s for an eigenvalue, none for a multiplier",
        "On a bifurcation's row, the imaginary part of the critical eigenvalue or multiplier",
        "",
        "modulo the plane's rigid motions",
        BIFURCATIONS,
    ),
];

/// `branch.csv`.
pub(super) const BRANCH: Table = Table {
    file: "branch.csv",
    command: "ezy analyze --continue",
    about: "The branch of steady motions or periodic orbits followed through a parameter: one row per value, and one per bifurcation located (after the point of its bracket). The power and efficiency of a forced scene's gaits",
    groups: &[BRANCH_HEAD, POWER, BIFURCATION],
};

/// `branch-<k>.csv`.
pub(super) const BORN: Table = Table {
    file: "branch-<k>.csv",
    command: "ezy analyze --continue --switch",
    about: "The k-th branch born at a bifurcation of the branch followed (branches.csv says which), followed to the range's end on its side: its columns as branch.csv's",
    groups: &[BRANCH_HEAD, POWER, BIFURCATION],
};

const BRANCHES_COLUMNS: &[Column] = &[
    c(
        "branch",
        "",
        "The branch's number: 0 the branch followed (branch.csv), k a branch born (branch-<k>.csv)",
        "",
        "",
        "",
    ),
    c("file", "", "The branch's table", "", "", ""),
    c("parent", "", "The number of the branch it is born from (empty for branch 0)", "", "", ""),
    c(
        "born_at",
        "as the parameter",
        "The parameter's value at the bifurcation the branch is born at",
        "",
        "",
        BIFURCATIONS,
    ),
    c(
        "bifurcation",
        "",
        "The bifurcation it is born at, as the branches born tell it: transcritical (the new branch crosses the old on both sides), pitchfork (two arms on one side), period doubling, Hopf; or branch point where they are too near to tell",
        "",
        "",
        KUZNETSOV_SWITCH,
    ),
    c(
        "criticality",
        "",
        "supercritical where the branches born are as stable as the parent on its stable side (they take over the stability it loses), subcritical otherwise; empty for a transcritical point",
        "",
        "",
        KUZNETSOV_SWITCH,
    ),
    c(
        "symmetry_breaking",
        "",
        "true for a pitchfork whose parent does not turn while its two arms turn opposite ways (the plane's reflection broken)",
        "",
        "",
        "",
    ),
    c(
        "side",
        "",
        "The side (+1 or -1) of the new branch's direction at the bifurcation it was sought on, 1e-2 of the state's scale away",
        "",
        "",
        "",
    ),
    c("points", "", "The branch's points (its table's rows other than bifurcations')", "", "", ""),
    c("from", "as the parameter", "The parameter's value at the branch's first point", "", "", ""),
    c("to", "as the parameter", "The parameter's value at the branch's last point", "", "", ""),
    c("ended", "", "How the branch ended: the range's end, or why it stopped before it", "", "", ""),
];

/// `branches.csv`.
pub(super) const BRANCHES: Table = Table {
    file: "branches.csv",
    command: "ezy analyze --continue --switch",
    about: "The branches of a bifurcation diagram: the branch followed and each branch born at one of its bifurcations, one row each",
    groups: &[BRANCHES_COLUMNS],
};

const GROWTH_COLUMNS: &[Column] = &[
    c(
        "window",
        "",
        "The window of the stroboscopic samples (the ends of the forcing's periods): second_half of the run, its third_quarter or its fourth_quarter",
        "",
        "",
        "",
    ),
    c("t_start", "s", "The window's first sample's time", "", "the scene's time from t = 0", ""),
    c("t_end", "s", "The window's last sample's time", "", "the scene's time from t = 0", ""),
    c("samples", "", "The samples in the window (ends of forcing periods)", "", "", ""),
    c(
        "T_start",
        "J",
        "The kinetic energy at the window's first sample",
        "qd^T M qd / 2",
        "the world frame; at t_start",
        "",
    ),
    c("T_end", "J", "The kinetic energy at the window's last sample", "qd^T M qd / 2", "the world frame; at t_end", ""),
    c(
        "energy_exponent",
        "",
        "The exponent a of the kinetic energy's power law T ~ c t^a over the window, by least squares of the logarithms",
        "ln T_k = ln c + a ln t_k",
        "over the window's samples",
        FERMI,
    ),
    c(
        "energy_exponent_se",
        "",
        "The standard error of energy_exponent",
        "sqrt(s^2 / sum (ln t_k - mean ln t)^2), s^2 the residuals' sum of squares over n - 2",
        "",
        "",
    ),
    c(
        "energy_residual",
        "",
        "The root mean square of the energy's log fit's residuals (a relative error of T)",
        "rms(ln T_k - ln c - a ln t_k)",
        "",
        "",
    ),
    c(
        "speed_start",
        "m/s",
        "The reference body's (the model's first body's) speed at the window's first sample",
        "|(x', y')|",
        "the same in every frame; at t_start",
        "",
    ),
    c(
        "speed_end",
        "m/s",
        "The reference body's speed at the window's last sample",
        "|(x', y')|",
        "the same in every frame; at t_end",
        "",
    ),
    c(
        "speed_exponent",
        "",
        "The exponent b of the speed's power law v ~ c t^b over the window, by its own least squares of the logarithms (empty where the body stands still at a period end)",
        "ln v_k = ln c + b ln t_k",
        "over the window's samples",
        FERMI,
    ),
    c("speed_exponent_se", "", "The standard error of speed_exponent", "as energy_exponent_se", "", ""),
    c(
        "speed_residual",
        "",
        "The root mean square of the speed's log fit's residuals (a relative error of v)",
        "rms(ln v_k - ln c - b ln t_k)",
        "",
        "",
    ),
];

/// `growth.csv`.
pub(super) const GROWTH: Table = Table {
    file: "growth.csv",
    command: "ezy analyze",
    about: "Written instead of periodic.csv where a periodically forced scene has no gait because its energy grows without bound: the growth's power laws over three windows of the samples at the ends of the forcing's periods, one row each",
    groups: &[GROWTH_COLUMNS],
};
