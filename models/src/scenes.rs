//! The built-in scenes (SPEC §3 and the Chaplygin sleigh of SPEC §5).

use std::f64::consts::{FRAC_PI_2, PI};

use ezy_core::{Column::*, EffectSpec, FigureKind, FigureSpec, InitValue::*, Method, ProjectionKind, Scene};

/// Every built-in scene, in the order `ezy list` shows them.
pub fn builtin() -> Vec<Scene> {
    vec![drive(), free(), sleigh()]
}

/// The built-in scene called `name`.
pub fn find(name: &str) -> Option<Scene> {
    builtin().into_iter().find(|s| s.name == name)
}

fn residual_figure() -> FigureSpec {
    FigureSpec {
        file: "residuals.png",
        title: "Constraint residuals after projection",
        x_label: "t [s]",
        y_label: "max residual [m], [m/s]",
        kind: FigureKind::Lines {
            x: Named("t"),
            ys: vec![("max |C(q)| [m]", Named("res_phi")), ("max |G(q) qd| [m/s]", Named("res_vel"))],
            log_y: true,
        },
    }
}

/// Seed questions f-j: the hinge motor drives the EzyRoller from rest.
pub fn drive() -> Scene {
    Scene {
        name: "drive",
        description: "EzyRoller from rest, hinge motor tau = M0 cos(omega t), 60 s (seed figures 3-7)",
        model: "ezyroller",
        t_end: 60.0,
        dt: 1e-4,
        every: 0.01,
        projection: ProjectionKind::default(),
        method: Method::Rk4,
        rtol: 1e-9,
        atol: 1e-9,
        q0: vec![("x1", Num(0.0)), ("y1", Num(0.0)), ("phi1", Num(0.0)), ("phi2", Num(PI))],
        qd0: vec![("x1", Num(0.0)), ("phi1", Num(0.0))],
        effects: vec![EffectSpec::HingeMotor { hinge: "B".into(), m0: 2.0, omega: PI }],
        figures: vec![
            FigureSpec {
                file: "fig3_paths.png",
                title: "Paths of the skate contact points A and C",
                x_label: "x [m]",
                y_label: "y [m]",
                kind: FigureKind::Paths(vec!["A", "C"]),
            },
            FigureSpec {
                file: "fig4_speed.png",
                title: "Speed and yaw rate of body 1",
                x_label: "t [s]",
                y_label: "speed [m/s], yaw rate [rad/s]",
                kind: FigureKind::Lines {
                    x: Named("t"),
                    ys: vec![("|(x1d, y1d)| [m/s]", Norm("x1d", "y1d")), ("phi1d [rad/s]", Named("phi1d"))],
                    log_y: false,
                },
            },
            FigureSpec {
                file: "fig5_kinetic_energy.png",
                title: "Kinetic energy",
                x_label: "t [s]",
                y_label: "T [J]",
                kind: FigureKind::Lines { x: Named("t"), ys: vec![("T [J]", Named("T"))], log_y: false },
            },
            FigureSpec {
                file: "fig6_torque.png",
                title: "Hinge torque and relative hinge rate",
                x_label: "t [s]",
                y_label: "torque [N m], rate [rad/s]",
                kind: FigureKind::Lines {
                    x: Named("t"),
                    ys: vec![("tau [N m]", Named("tau_B")), ("phi2d - phi1d [rad/s]", Diff("phi2d", "phi1d"))],
                    log_y: false,
                },
            },
            FigureSpec {
                file: "fig7_energy_balance.png",
                title: "Energy balance: T - T(0) and the work W of the motor",
                x_label: "t [s]",
                y_label: "energy [J]",
                kind: FigureKind::Lines {
                    x: Named("t"),
                    ys: vec![("T - T(0) [J]", FromStart("T")), ("W [J]", Named("W"))],
                    log_y: false,
                },
            },
            FigureSpec {
                file: "energy_gap.png",
                title: "Gap of the energy balance |T - T(0) - W| (W integrated as a state)",
                x_label: "t [s]",
                y_label: "|T - T(0) - W| [J]",
                kind: FigureKind::Lines {
                    x: Named("t"),
                    ys: vec![("|T - T(0) - W| [J]", BalanceGap("T", "W"))],
                    log_y: true,
                },
            },
            residual_figure(),
        ],
    }
}

/// Seed question e: no applied forces, 1 s; kinetic energy is conserved.
pub fn free() -> Scene {
    Scene {
        name: "free",
        description: "EzyRoller coasting without forces from x1d = 1 m/s with the fork at 90 degrees, 1 s (seed figure 2)",
        model: "ezyroller",
        t_end: 1.0,
        dt: 1e-4,
        every: 0.01,
        projection: ProjectionKind::default(),
        method: Method::Rk4,
        rtol: 1e-9,
        atol: 1e-9,
        q0: vec![("x1", Param("a")), ("y1", Num(0.0)), ("phi1", Num(0.0)), ("phi2", Num(FRAC_PI_2))],
        qd0: vec![("x1", Num(1.0)), ("phi1", Num(0.0))],
        effects: vec![],
        figures: vec![
            FigureSpec {
                file: "fig2_paths.png",
                title: "Paths of the centres of mass and the skate points",
                x_label: "x [m]",
                y_label: "y [m]",
                kind: FigureKind::Paths(vec!["body1", "body2", "A", "C"]),
            },
            FigureSpec {
                file: "kinetic_energy.png",
                title: "Kinetic energy (conserved)",
                x_label: "t [s]",
                y_label: "T [J]",
                kind: FigureKind::Lines { x: Named("t"), ys: vec![("T [J]", Named("T"))], log_y: false },
            },
            residual_figure(),
        ],
    }
}

/// The Chaplygin sleigh (SPEC §5) from forward speed 1 m/s and yaw rate 1 rad/s.
pub fn sleigh() -> Scene {
    Scene {
        name: "sleigh",
        description: "Chaplygin sleigh from u = 1 m/s, omega = 1 rad/s, 10 s (closed form of SPEC §5)",
        model: "chaplygin_sleigh",
        t_end: 10.0,
        dt: 1e-4,
        every: 0.01,
        projection: ProjectionKind::default(),
        method: Method::Rk4,
        rtol: 1e-9,
        atol: 1e-9,
        q0: vec![("x", Num(0.0)), ("y", Num(0.0)), ("phi", Num(0.0))],
        qd0: vec![("x", Num(1.0)), ("phi", Num(1.0))],
        effects: vec![],
        figures: vec![
            FigureSpec {
                file: "paths.png",
                title: "Path of the centre of mass and the skate",
                x_label: "x [m]",
                y_label: "y [m]",
                kind: FigureKind::Paths(vec!["sleigh", "P"]),
            },
            FigureSpec {
                file: "rates.png",
                title: "Velocity of the centre of mass and yaw rate",
                x_label: "t [s]",
                y_label: "[m/s], [rad/s]",
                kind: FigureKind::Lines {
                    x: Named("t"),
                    ys: vec![("|(xd, yd)| [m/s]", Norm("xd", "yd")), ("phid [rad/s]", Named("phid"))],
                    log_y: false,
                },
            },
            residual_figure(),
        ],
    }
}
