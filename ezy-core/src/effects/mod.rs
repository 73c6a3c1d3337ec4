//! Applied forces (effects): documented force laws a scene lists by name.
//!
//! Each effect adds its generalized force into `f` (nq) and returns its
//! power `P = f_e . qd` \[W\]; the right-hand side integrates each power into
//! the effect's own work state `W_<name>` \[J\], so that `T - T0 = sum W`
//! holds for any combination (ideal constraints do no work; docs/physics.md §8).
//! Only the effects a scene lists are built; the right-hand side loops over
//! exactly those, so an effect the scene does not name costs nothing.
//!
//! Conventions (docs/physics.md §1, §8): a force `F` (world frame) at a body point with
//! body-frame offset `p` from the centre of mass acts on the body's
//! coordinates `(x, y, phi)` as `(F_x, F_y, r_x F_y - r_y F_x)` with
//! `r = R(phi) p`; its power is `F . v_P`. A hinge torque `tau` acts `+tau`
//! on the hinge's first body and `-tau` on its second (as the `drive` scene's motor),
//! and the hinge angle is `theta = phi_a - phi_b` (`phi_a` for a ground
//! hinge), so a hinge torque's power is `tau theta_dot`.

pub(crate) mod user;
pub(crate) mod waveform;

use std::sync::Arc;

use serde::{Deserialize, Serialize};
pub use user::{Controller, EffectKind, ForceLaw, UserSpec};
pub use waveform::{Harmonic, Periodicity, Spline, SplineData, Table, Waveform};

use crate::error::SimError;
use crate::model::Model;
use crate::model::info::{ModelInfo, NameIndex};
use crate::scalar::Scalar;

/// Standard gravity \[m/s^2\] (the default of [`EffectSpec::Slope`]).
pub const STANDARD_GRAVITY: f64 = 9.806_65;

fn default_gravity() -> f64 {
    STANDARD_GRAVITY
}
fn is_zero(v: &f64) -> bool {
    *v == 0.0
}
fn is_default_gravity(v: &f64) -> bool {
    *v == STANDARD_GRAVITY
}
fn is_zero_waveform(w: &Waveform) -> bool {
    *w == Waveform::Constant(0.0)
}
fn default_along() -> [f64; 2] {
    [1.0, 0.0]
}
fn is_default_along(a: &[f64; 2]) -> bool {
    *a == default_along()
}
fn default_field() -> [f64; 2] {
    [0.0, -STANDARD_GRAVITY]
}
fn is_default_field(g: &[f64; 2]) -> bool {
    *g == default_field()
}

/// The frame a force's components are given in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Frame {
    /// Fixed axes of the plane.
    #[default]
    World,
    /// The body's axes (x along its heading): the force turns with the body.
    Body,
}

/// An effect as a scene file writes it, by the model's names. In a scene
/// file each is a table `[effects.NAME]` with a `kind` key; every field is
/// in SI units. The built-in kinds, with their force laws, and the kinds
/// of the user's own ([`EffectSpec::User`]):
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
pub enum EffectSpec {
    /// Hinge motor: torque `tau(t)` \[N m\] given by a waveform, `+tau` on the
    /// hinge's first body, `-tau` on the second (the `drive` scene's motor,
    /// docs/physics.md §10.3, is `torque = { cos = { amplitude = 2, omega = pi } }`).
    HingeMotor {
        /// Hinge name.
        hinge: String,
        /// Torque \[N m\] over time.
        torque: Waveform,
    },
    /// Rotational spring at a hinge: `tau = -stiffness (theta - rest_angle)`,
    /// `theta = phi_a - phi_b` (linear torsion spring; its work is minus the
    /// change of `stiffness (theta - rest_angle)^2 / 2`).
    HingeSpring {
        /// Hinge name.
        hinge: String,
        /// Stiffness \[N m/rad\].
        stiffness: f64,
        /// Angle of zero torque \[rad\].
        #[serde(default, skip_serializing_if = "is_zero")]
        rest_angle: f64,
    },
    /// Viscous damper at a hinge: `tau = -damping theta_dot` (dissipates
    /// `damping theta_dot^2` \[W\]).
    HingeDamper {
        /// Hinge name.
        hinge: String,
        /// Damping \[N m s/rad\].
        damping: f64,
    },
    /// Position servo at a hinge (a PD controller, or a spring-damper whose
    /// rest angle moves): `tau = -stiffness (theta - angle(t)) - damping
    /// (theta_dot - angle'(t))` \[N m\]. With a large stiffness the hinge
    /// follows `angle(t)` closely and the scene is stiff: the fast modes
    /// have frequencies near `sqrt(stiffness / inertia)` (use
    /// `--integrator radau5`).
    HingeServo {
        /// Hinge name.
        hinge: String,
        /// Stiffness \[N m/rad\].
        stiffness: f64,
        /// Damping \[N m s/rad\].
        #[serde(default, skip_serializing_if = "is_zero")]
        damping: f64,
        /// Commanded hinge angle \[rad\] over time (its derivative is the
        /// commanded rate).
        angle: Waveform,
    },
    /// Viscous rolling resistance at a skate: a force `-damping v_t` along
    /// the blade, `v_t` the contact point's velocity along the blade \[m/s\].
    RollingViscous {
        /// Skate name.
        skate: String,
        /// Damping \[N s/m\].
        damping: f64,
    },
    /// Smoothed Coulomb rolling resistance at a skate:
    /// `-force v_t / sqrt(v_t^2 + smoothing^2)` along the blade, which tends
    /// to `-force sign(v_t)` for `|v_t| >> smoothing` and is smooth (so the
    /// fixed-step methods keep their order) at rest. `force` is the rolling
    /// resistance coefficient times the normal load.
    RollingCoulomb {
        /// Skate name.
        skate: String,
        /// Resistance force magnitude \[N\].
        force: f64,
        /// Speed below which the law is linear \[m/s\].
        smoothing: f64,
    },
    /// Driven wheel: a force `force(t)` \[N\] along the blade at a skate's
    /// contact point (a wheel driven by a motor in its hub).
    DrivenWheel {
        /// Skate name.
        skate: String,
        /// Force along the blade \[N\] over time.
        force: Waveform,
    },
    /// Coulomb friction at a skate (a knife edge that can slip,
    /// [`crate::formulation::friction`]): the skate holds while the lateral force it
    /// needs, `|lambda|`, is at most `mu N`; beyond that it slides
    /// sideways against the force `mu N`, and it sticks again where the
    /// slip velocity returns to zero with a holding force within the
    /// limit. Both switches are located events. The normal load `N` \[N\]
    /// is `normal`, or the static share `share` (0 < share <= 1) of the
    /// whole model's weight `m g`. Its value column is the lateral force
    /// on the skate \[N\] (along the blade's left normal); its work state
    /// the friction's work (negative: it dissipates).
    SkateFriction {
        /// Skate name.
        skate: String,
        /// Friction coefficient, from 0 to [`MAX_MU`] (1e9: see there).
        mu: f64,
        /// Normal load \[N\] (or give `share`).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        normal: Option<f64>,
        /// Share of the model's weight the skate carries (or give `normal`).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        share: Option<f64>,
        /// Gravitational acceleration for `share` \[m/s^2\].
        #[serde(default = "default_gravity", skip_serializing_if = "is_default_gravity")]
        g: f64,
    },
    /// A force `(fx(t), fy(t))` \[N\] at a body's centre of mass (`at` names a
    /// body) or at a named point (`at` names a point), in world or body axes.
    Force {
        /// A body (centre of mass) or a point.
        at: String,
        /// x component \[N\] over time.
        #[serde(default, skip_serializing_if = "is_zero_waveform")]
        fx: Waveform,
        /// y component \[N\] over time.
        #[serde(default, skip_serializing_if = "is_zero_waveform")]
        fy: Waveform,
        /// Axes of `fx`, `fy`.
        #[serde(default)]
        frame: Frame,
    },
    /// A torque `torque(t)` \[N m\] on a body.
    Torque {
        /// Body name.
        body: String,
        /// Torque \[N m\] over time.
        torque: Waveform,
    },
    /// Gravity on a plane inclined by `angle`: every body feels
    /// `m g sin(angle)` \[N\] along the downhill direction, at angle
    /// `downhill` from the x axis (the normal component is carried by the
    /// skates' contact and does no work). Work is minus the change of
    /// potential energy `m g sin(angle) (height along the uphill direction)`.
    Slope {
        /// Inclination of the plane, from -pi/2 to pi/2 \[rad\].
        angle: f64,
        /// Direction of steepest descent in the plane, from the x axis \[rad\].
        #[serde(default, skip_serializing_if = "is_zero")]
        downhill: f64,
        /// Gravitational acceleration \[m/s^2\].
        #[serde(default = "default_gravity", skip_serializing_if = "is_default_gravity")]
        g: f64,
    },
    /// Gravity in the plane of motion (a mechanism in a vertical plane): a
    /// uniform field `g = [gx, gy]` \[m/s^2\] (default `[0, -9.80665]`, down
    /// the y axis), the force `m g` at the centre of mass of every body, or
    /// of the bodies listed. Its work is minus the change of the potential
    /// energy `-m g . r`. (`slope` is the inclined plane under vehicles.)
    Gravity {
        /// The field \[m/s^2\].
        #[serde(default = "default_field", skip_serializing_if = "is_default_field")]
        g: [f64; 2],
        /// The bodies it acts on (default: all).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        bodies: Option<Vec<String>>,
    },
    /// Translational spring-damper-actuator between two points (the TSDA
    /// of multibody codes): with `L = |r_from - r_to|` and `e` the unit
    /// vector from `to` to `from`, the tension
    /// `T = stiffness (L - rest_length) + damping dL/dt + force(t)` \[N\]
    /// pulls the ends together: `-T e` on `from`, `+T e` on `to`. Its power
    /// is `-T dL/dt`; its value column is `T`. `from` and `to` name points
    /// or bodies (their centres of mass); `to` may be a fixed ground point
    /// `"ground(x, y)"` \[m\], whose coordinates are numbers or the names of
    /// model or scene parameters. A length of zero stops the run (the
    /// force has no direction there).
    SpringDamper {
        /// A point or a body.
        from: String,
        /// A point, a body or `ground(x, y)`.
        to: String,
        /// Stiffness \[N/m\].
        stiffness: f64,
        /// Length of zero spring force \[m\].
        rest_length: f64,
        /// Damping along the line \[N s/m\].
        #[serde(default, skip_serializing_if = "is_zero")]
        damping: f64,
        /// Actuator force along the line \[N\] over time (positive pulls).
        #[serde(default, skip_serializing_if = "is_zero_waveform")]
        force: Waveform,
    },
    /// Anisotropic viscous drag at a point (or a body's centre of mass):
    /// with `e` the unit direction `along` turned with the body and `n` its
    /// left normal, the force is `-c_along (v . e) e - c_across (v . n) n`
    /// for the point's velocity `v`. The ground contact of a snake robot
    /// or a wheel that may slip sideways: `c_across >> c_along` makes the
    /// body glide along `e` (a skate is the limit `c_across -> inf`, a
    /// constraint instead of a force). Its value column is the force's
    /// magnitude \[N\].
    AnisotropicDrag {
        /// A point or a body.
        at: String,
        /// Direction of easy motion in the body frame (default `[1, 0]`).
        #[serde(default = "default_along", skip_serializing_if = "is_default_along")]
        along: [f64; 2],
        /// Coefficient along `along` \[N s/m\].
        c_along: f64,
        /// Coefficient across it \[N s/m\].
        c_across: f64,
    },
    /// Linear (Stokes) drag on a body: force `-c v` at the centre of mass,
    /// torque `-c_rot phi_dot`.
    LinearDrag {
        /// Body name.
        body: String,
        /// Translational coefficient \[N s/m\].
        c: f64,
        /// Rotational coefficient \[N m s/rad\].
        #[serde(default, skip_serializing_if = "is_zero")]
        c_rot: f64,
    },
    /// Quadratic (form) drag on a body: force `-c |v| v` at the centre of
    /// mass, torque `-c_rot |phi_dot| phi_dot`.
    QuadraticDrag {
        /// Body name.
        body: String,
        /// Translational coefficient \[N s^2/m^2\].
        c: f64,
        /// Rotational coefficient \[N m s^2/rad^2\].
        #[serde(default, skip_serializing_if = "is_zero")]
        c_rot: f64,
    },
    /// A kind of the user's own ([`EffectKind`]), its value read and
    /// checked by its type. Serde skips it: a scene file reads a table of
    /// such a kind through the kinds an application registers (crate
    /// `ezy-scene`), which gives this value.
    #[serde(skip)]
    User(UserSpec),
}

/// The kinds a scene file may name, as it spells them.
pub const EFFECT_KINDS: &[&str] = &[
    "hinge-motor",
    "hinge-spring",
    "hinge-damper",
    "hinge-servo",
    "rolling-viscous",
    "rolling-coulomb",
    "driven-wheel",
    "skate-friction",
    "force",
    "torque",
    "slope",
    "linear-drag",
    "quadratic-drag",
    "gravity",
    "spring-damper",
    "anisotropic-drag",
];

/// Checks an effect's name: letters, digits and `_`, since it names the
/// columns `W_<name>` and `F_<name>`/`tau_<name>` (scene files and
/// [`crate::Problem`] alike).
///
/// # Errors
/// What is wrong with it.
pub fn check_effect_name(name: &str) -> Result<(), String> {
    if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
        return Err(format!("effect name `{name}` must be letters, digits and _ (it names the column W_{name})"));
    }
    Ok(())
}

/// A name in an effect that the model does not have, or a bad number.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SpecError {
    /// The effect's key that is wrong (`hinge`, `skate`, `torque`, ...;
    /// empty for the effect as a whole: a missing or unknown key).
    pub field: &'static str,
    /// What is wrong.
    pub message: String,
}

impl SpecError {
    /// `Ok` if `ok`, else an error at `field` with the message `message()`
    /// (for range checks in [`EffectKind::resolve`]).
    ///
    /// # Errors
    /// As described.
    pub fn check(ok: bool, field: &'static str, message: impl FnOnce() -> String) -> Result<(), SpecError> {
        if ok { Ok(()) } else { Err(SpecError { field, message: message() }) }
    }
}

fn unknown(field: &'static str, kind: &str, name: &str, model: &str, known: Vec<&str>) -> SpecError {
    let known = if known.is_empty() { "none".to_string() } else { crate::name_list(known) };
    let plural = match kind {
        "body" => "bodies",
        "body or point" => "bodies and points",
        "point or body" => "points and bodies",
        "hinge" => "hinges",
        _ => "skates",
    };
    SpecError { field, message: format!("unknown {kind} `{name}` in model {model}; its {plural}: {known}") }
}

/// The largest friction coefficient a skate takes, 1e9.
///
/// Measured coefficients between solids stay below about 16 (clean copper
/// on copper in vacuum, where the surfaces weld; engineering pairs 0.05 to
/// 1.5): a larger `mu` only says that the skate does not slide, which the
/// ideal skate (no friction effect) models exactly, and values up to 1e9
/// serve that end (friction that never acts: `tests/friction.rs`). The
/// friction force `mu N` is summed with the forces of the size of the
/// weight, which keep a relative accuracy of `mu eps` against it: 2.2e-7
/// (six digits) at 1e9, none at 1e16. And a slide ends within `v / (mu g)`:
/// at `mu = 1e9` and 1 m/s that is 1e-10 s, still 3e4 times the shortest
/// step at t = 1 s ([`crate::MAX_RATE`]). Measured on `sleigh-ice` (a
/// slide of 2 m/s): DOPRI5 ran to `mu = 1e13` and stopped from `1e14`
/// with "the step size fell"; at `mu = 1e300` every method stopped so,
/// RK4 with the friction's work `inf`, none naming `mu`.
pub const MAX_MU: f64 = 1e9;

fn finite(field: &'static str, v: f64) -> Result<(), SpecError> {
    crate::check_magnitude(field, v).map_err(|message| SpecError { field, message })
}

fn angle(field: &'static str, v: f64) -> Result<(), SpecError> {
    crate::check_angle(field, v).map_err(|message| SpecError { field, message })
}

fn non_negative(field: &'static str, v: f64) -> Result<(), SpecError> {
    if v.is_finite() && v < 0.0 {
        Err(SpecError {
            field,
            message: format!("{field} = {} must be zero or positive (a dissipative law)", crate::names::fmt_value(v)),
        })
    } else {
        finite(field, v)
    }
}

fn friction_coefficient(v: f64) -> Result<(), SpecError> {
    SpecError::check(!v.is_finite() || v <= MAX_MU, "mu", || {
        format!(
            "mu = {} is not a friction coefficient: give a number from 0 to {MAX_MU:e} (measured ones stay below about 16; for a skate that never slides, leave out its friction effect: the ideal skate)",
            crate::names::fmt_value(v)
        )
    })?;
    non_negative("mu", v)
}

fn wave(field: &'static str, w: &Waveform) -> Result<(), SpecError> {
    w.validate().map_err(|message| SpecError { field, message })
}

impl EffectSpec {
    /// The kind as a scene file spells it.
    pub fn kind(&self) -> &str {
        match self {
            Self::User(u) => u.kind(),
            Self::HingeMotor { .. } => "hinge-motor",
            Self::HingeSpring { .. } => "hinge-spring",
            Self::HingeDamper { .. } => "hinge-damper",
            Self::HingeServo { .. } => "hinge-servo",
            Self::RollingViscous { .. } => "rolling-viscous",
            Self::RollingCoulomb { .. } => "rolling-coulomb",
            Self::DrivenWheel { .. } => "driven-wheel",
            Self::SkateFriction { .. } => "skate-friction",
            Self::Force { .. } => "force",
            Self::Torque { .. } => "torque",
            Self::Slope { .. } => "slope",
            Self::Gravity { .. } => "gravity",
            Self::SpringDamper { .. } => "spring-damper",
            Self::AnisotropicDrag { .. } => "anisotropic-drag",
            Self::LinearDrag { .. } => "linear-drag",
            Self::QuadraticDrag { .. } => "quadratic-drag",
        }
    }

    /// Name of the output column of the effect called `name`: `tau_<name>`
    /// \[N m\] for torques (hinge laws, body torques), `F_<name>` \[N\] for
    /// forces (the signed force along the blade for skate laws, the
    /// magnitude otherwise).
    pub fn value_column(&self, name: &str) -> String {
        match self {
            Self::HingeMotor { .. }
            | Self::HingeSpring { .. }
            | Self::HingeDamper { .. }
            | Self::HingeServo { .. }
            | Self::Torque { .. } => {
                format!("tau_{name}")
            }
            Self::User(u) => format!("{}_{name}", u.value_prefix()),
            _ => format!("F_{name}"),
        }
    }

    /// Checks names against the model and numbers against their ranges.
    ///
    /// # Errors
    /// [`SpecError`] naming the field, the bad name and the model's names.
    pub fn check(&self, info: &ModelInfo) -> Result<(), SpecError> {
        self.check_in(&NameIndex::new(info), &[])
    }

    /// As [`EffectSpec::check`], with the model's names already indexed
    /// (for the many effects of a family) and the scene's parameters (a
    /// ground point's coordinates may name them).
    ///
    /// # Errors
    /// As [`EffectSpec::check`].
    pub fn check_in(&self, names: &NameIndex<'_>, scene_params: &[(String, f64)]) -> Result<(), SpecError> {
        let info = names.info;
        let model = info.name;
        let hinge = |h: &str| {
            names.hinge(h).map(|_| ()).ok_or_else(|| {
                unknown("hinge", "hinge", h, model, info.hinges.iter().map(|h| h.name.as_str()).collect())
            })
        };
        let skate = |s: &str| {
            names.skate(s).map(|_| ()).ok_or_else(|| {
                unknown("skate", "skate", s, model, info.skates.iter().map(|k| k.name.as_str()).collect())
            })
        };
        let body = |field, b: &str| {
            names
                .body(b)
                .map(|_| ())
                .ok_or_else(|| unknown(field, "body", b, model, info.bodies.iter().map(|k| k.name.as_str()).collect()))
        };
        match self {
            // read and checked by its type; its names are checked as it resolves
            Self::User(_) => Ok(()),
            Self::HingeMotor { hinge: h, torque } => {
                hinge(h)?;
                wave("torque", torque)
            }
            Self::HingeSpring { hinge: h, stiffness, rest_angle } => {
                hinge(h)?;
                finite("stiffness", *stiffness)?;
                angle("rest_angle", *rest_angle)
            }
            Self::HingeDamper { hinge: h, damping } => {
                hinge(h)?;
                non_negative("damping", *damping)
            }
            Self::HingeServo { hinge: h, stiffness, damping, angle } => {
                hinge(h)?;
                finite("stiffness", *stiffness)?;
                non_negative("damping", *damping)?;
                wave("angle", angle)
            }
            Self::RollingViscous { skate: s, damping } => {
                skate(s)?;
                non_negative("damping", *damping)
            }
            Self::RollingCoulomb { skate: s, force, smoothing } => {
                skate(s)?;
                non_negative("force", *force)?;
                if smoothing.is_finite() && *smoothing > 0.0 {
                    finite("smoothing", *smoothing)
                } else {
                    Err(SpecError {
                        field: "smoothing",
                        message: format!("smoothing = {smoothing} must be a positive speed [m/s]"),
                    })
                }
            }
            Self::DrivenWheel { skate: s, force } => {
                skate(s)?;
                wave("force", force)
            }
            Self::SkateFriction { skate: s, mu, normal, share, g } => {
                skate(s)?;
                friction_coefficient(*mu)?;
                match (normal, share) {
                    (Some(n), None) => non_negative("normal", *n),
                    (None, Some(share)) => {
                        SpecError::check(share.is_finite() && *share > 0.0 && *share <= 1.0, "share", || {
                            format!(
                                "share = {} must be a fraction of the weight, 0 < share <= 1",
                                crate::names::fmt_value(*share)
                            )
                        })?;
                        SpecError::check(g.is_finite() && *g > 0.0, "g", || {
                            format!("g = {} must be a positive acceleration [m/s^2]", crate::names::fmt_value(*g))
                        })?;
                        finite("g", *g)
                    }
                    (Some(_), Some(_)) => Err(SpecError {
                        field: "share",
                        message: "give the normal load either as `normal` [N] or as `share` of the weight, not both"
                            .into(),
                    }),
                    (None, None) => Err(SpecError {
                        field: "normal",
                        message: "a skate with friction needs its normal load: `normal` [N], or `share` of the weight"
                            .into(),
                    }),
                }
            }
            Self::Force { at, fx, fy, .. } => {
                if names.point(at).is_none() && names.body(at).is_none() {
                    let mut known: Vec<&str> = info.bodies.iter().map(|b| b.name.as_str()).collect();
                    known.extend(info.points.iter().map(|p| p.name.as_str()));
                    return Err(unknown("at", "body or point", at, model, known));
                }
                wave("fx", fx)?;
                wave("fy", fy)
            }
            Self::Torque { body: b, torque } => {
                body("body", b)?;
                wave("torque", torque)
            }
            Self::Slope { angle: inclination, downhill, g } => {
                // an inclination: from level (0) to vertical (pi/2), either way
                SpecError::check(
                    inclination.is_finite() && inclination.abs() <= std::f64::consts::FRAC_PI_2,
                    "angle",
                    || {
                        format!(
                            "angle = {} is not the inclination of a plane: give an angle from -pi/2 to pi/2 [rad] (its direction is `downhill`)",
                            crate::names::fmt_value(*inclination)
                        )
                    },
                )?;
                angle("downhill", *downhill)?;
                finite("g", *g)
            }
            Self::Gravity { g, bodies } => {
                if !(g[0].is_finite() && g[1].is_finite()) {
                    return Err(SpecError { field: "g", message: format!("g = {g:?} must be finite [m/s^2]") });
                }
                for (i, c) in g.iter().enumerate() {
                    crate::check_magnitude(&format!("g[{i}]"), *c)
                        .map_err(|message| SpecError { field: "g", message })?;
                }
                for b in bodies.iter().flatten() {
                    body("bodies", b)?;
                }
                Ok(())
            }
            Self::AnisotropicDrag { at, along, c_along, c_across } => {
                if names.point(at).is_none() && names.body(at).is_none() {
                    let mut known: Vec<&str> = info.points.iter().map(|p| p.name.as_str()).collect();
                    known.extend(info.bodies.iter().map(|b| b.name.as_str()));
                    return Err(unknown("at", "point or body", at, model, known));
                }
                let length = along[0].hypot(along[1]);
                if !(length.is_finite() && length > 0.0) {
                    return Err(SpecError {
                        field: "along",
                        message: format!("along = {along:?} must be a finite nonzero direction"),
                    });
                }
                non_negative("c_along", *c_along)?;
                non_negative("c_across", *c_across)
            }
            Self::SpringDamper { from, to, stiffness, rest_length, damping, force } => {
                let end = |field: &'static str, e: &str| -> Result<(), SpecError> {
                    match ground_point(e) {
                        Some(args) => {
                            for a in args {
                                ground_coord(a, info, scene_params, |_| 0.0)
                                    .map_err(|message| SpecError { field, message })?;
                            }
                            Ok(())
                        }
                        None if names.point(e).is_some() || names.body(e).is_some() => Ok(()),
                        None => {
                            let mut known: Vec<&str> = info.points.iter().map(|p| p.name.as_str()).collect();
                            known.extend(info.bodies.iter().map(|b| b.name.as_str()));
                            Err(unknown(field, "point or body", e, model, known))
                        }
                    }
                };
                if ground_point(from).is_some() {
                    return Err(SpecError {
                        field: "from",
                        message: format!(
                            "`{from}`: `from` is a point or a body of the model; a ground point goes in `to`"
                        ),
                    });
                }
                end("from", from)?;
                end("to", to)?;
                if from == to {
                    return Err(SpecError {
                        field: "to",
                        message: format!("`{to}`: a spring-damper joins two different points"),
                    });
                }
                finite("stiffness", *stiffness)?;
                if !(rest_length.is_finite() && *rest_length >= 0.0) {
                    return Err(SpecError {
                        field: "rest_length",
                        message: format!("rest_length = {rest_length} must be zero or positive [m]"),
                    });
                }
                finite("rest_length", *rest_length)?;
                non_negative("damping", *damping)?;
                wave("force", force)
            }
            Self::LinearDrag { body: b, c, c_rot } | Self::QuadraticDrag { body: b, c, c_rot } => {
                body("body", b)?;
                non_negative("c", *c)?;
                non_negative("c_rot", *c_rot)
            }
        }
    }

    /// Resolves names to coordinate indices and body-frame geometry of
    /// `model` (at its current parameters). For many effects of one model
    /// build an [`EffectContext`] once and call [`EffectSpec::resolve_in`].
    ///
    /// # Errors
    /// [`SimError::Effect`] for a name the model does not have or a bad
    /// number (a spec that passed [`EffectSpec::check`] never fails).
    pub fn resolve<M: Model>(&self, name: &str, model: &M) -> Result<Effect, SimError> {
        let info = model.info();
        self.resolve_in(name, &EffectContext::new(model, &NameIndex::new(&info)))
    }

    /// As [`EffectSpec::resolve`], with what it needs of the model computed
    /// once for all of a scene's effects.
    ///
    /// # Errors
    /// As [`EffectSpec::resolve`].
    pub fn resolve_in(&self, name: &str, cx: &EffectContext<'_>) -> Result<Effect, SimError> {
        let names = cx.names;
        let info = names.info;
        if let Err(e) = self.check_in(names, &cx.scene_params) {
            return Err(SimError::Effect { effect: name.to_string(), field: e.field, message: e.message });
        }
        let (points, blades, mass) = (&cx.points, &cx.blades, &cx.mass);
        let body_of = |b: &str| info.bodies[names.body(b).expect("checked")].coords;
        let hinge = |h: &str| {
            let index = names.hinge(h).expect("checked");
            let hi = &info.hinges[index];
            (index, info.bodies[hi.body_a].coords[2], hi.body_b.map(|b| info.bodies[b].coords[2]))
        };
        let blade = |s: &str| {
            let k = names.skate(s).expect("checked");
            let p = info.skates[k].point;
            Blade {
                body: info.bodies[info.points[p].body].coords,
                offset: [points[2 * p], points[2 * p + 1]],
                dir: [blades[2 * k], blades[2 * k + 1]],
            }
        };
        let law = match self.clone() {
            Self::HingeMotor { hinge: h, torque } => {
                let (hinge, a, b) = hinge(&h);
                Law::Hinge { hinge, a, b, law: HingeLaw::Motor(torque) }
            }
            Self::HingeSpring { hinge: h, stiffness, rest_angle } => {
                let (hinge, a, b) = hinge(&h);
                Law::Hinge { hinge, a, b, law: HingeLaw::Spring { stiffness, rest_angle } }
            }
            Self::HingeDamper { hinge: h, damping } => {
                let (hinge, a, b) = hinge(&h);
                Law::Hinge { hinge, a, b, law: HingeLaw::Damper { damping } }
            }
            Self::HingeServo { hinge: h, stiffness, damping, angle } => {
                let (hinge, a, b) = hinge(&h);
                Law::Hinge { hinge, a, b, law: HingeLaw::Servo { stiffness, damping, angle } }
            }
            Self::RollingViscous { skate, damping } => Law::Blade(blade(&skate), BladeLaw::Viscous { damping }),
            Self::RollingCoulomb { skate, force, smoothing } => {
                Law::Blade(blade(&skate), BladeLaw::Coulomb { force, smoothing })
            }
            Self::DrivenWheel { skate, force } => Law::Blade(blade(&skate), BladeLaw::Driven(force)),
            Self::SkateFriction { skate, mu, normal, share, g } => {
                let index = names.skate(&skate).expect("checked");
                // the weight of the whole model: each body's mass once
                let weight = || g * info.bodies.iter().map(|b| mass[b.coords[0]]).sum::<f64>();
                let normal = normal.unwrap_or_else(|| share.unwrap_or(1.0) * weight());
                Law::SkateFriction { skate: index, blade: blade(&skate), limit: mu * normal }
            }
            Self::Force { at, fx, fy, frame } => {
                let (body, offset) = match names.point(&at) {
                    Some(p) => (info.bodies[info.points[p].body].coords, [points[2 * p], points[2 * p + 1]]),
                    None => (body_of(&at), [0.0, 0.0]),
                };
                Law::Force { body, offset, fx, fy, frame }
            }
            Self::Torque { body, torque } => Law::Torque { phi: body_of(&body)[2], torque },
            Self::Gravity { g, bodies } => Law::Slope {
                bodies: info
                    .bodies
                    .iter()
                    .filter(|b| bodies.as_ref().is_none_or(|list| list.contains(&b.name)))
                    .map(|b| (b.coords[0], b.coords[1], mass[b.coords[0]]))
                    .collect(),
                force_per_kg: g,
            },
            Self::AnisotropicDrag { at, along, c_along, c_across } => {
                let (body, offset) = match names.point(&at) {
                    Some(p) => (info.bodies[info.points[p].body].coords, [points[2 * p], points[2 * p + 1]]),
                    None => (body_of(&at), [0.0, 0.0]),
                };
                let len = along[0].hypot(along[1]);
                Law::Anisotropic {
                    blade: Blade { body, offset, dir: [along[0] / len, along[1] / len] },
                    c_along,
                    c_across,
                }
            }
            Self::SpringDamper { from, to, stiffness, rest_length, damping, force } => {
                let end = |field: &'static str, e: &str| -> Result<Anchor, SimError> {
                    Ok(match ground_point(e) {
                        Some([x, y]) => {
                            // a model parameter it names is checked here, at its value
                            let v = |a| {
                                ground_coord(a, info, &cx.scene_params, |i| cx.model_params[i])
                                    .map_err(|message| SimError::Effect { effect: name.to_string(), field, message })
                            };
                            Anchor::Ground([v(x)?, v(y)?])
                        }
                        None => match names.point(e) {
                            Some(p) => Anchor::Body {
                                body: info.bodies[info.points[p].body].coords,
                                offset: [points[2 * p], points[2 * p + 1]],
                            },
                            None => Anchor::Body { body: body_of(e), offset: [0.0, 0.0] },
                        },
                    })
                };
                Law::SpringDamper {
                    ends: [end("from", &from)?, end("to", &to)?],
                    stiffness,
                    rest_length,
                    damping,
                    force,
                }
            }
            Self::Slope { angle, downhill, g } => Law::Slope {
                bodies: info.bodies.iter().map(|b| (b.coords[0], b.coords[1], mass[b.coords[0]])).collect(),
                force_per_kg: [g * angle.sin() * downhill.cos(), g * angle.sin() * downhill.sin()],
            },
            Self::LinearDrag { body, c, c_rot } => Law::Drag { body: body_of(&body), c, c_rot, quadratic: false },
            Self::QuadraticDrag { body, c, c_rot } => Law::Drag { body: body_of(&body), c, c_rot, quadratic: true },
            Self::User(u) => {
                let law = u.resolve(cx).map_err(|e| SimError::Effect {
                    effect: name.to_string(),
                    field: e.field,
                    message: e.message,
                })?;
                Law::user(name, law, cx.nq())?
            }
        };
        Ok(Effect { name: name.to_string(), value_column: self.value_column(name), law, on: true })
    }
}

/// What resolving effects needs of a model at its current parameters,
/// computed once for all of a scene's effects: the name maps, the
/// body-frame point offsets and blade directions, the mass diagonal.
#[derive(Debug)]
pub struct EffectContext<'a> {
    names: &'a NameIndex<'a>,
    /// Body-frame point offsets (2 x npoints) \[m\].
    points: Vec<f64>,
    /// Body-frame unit blade directions (2 x nskates).
    blades: Vec<f64>,
    /// Mass diagonal (nq) \[kg, kg m^2\].
    mass: Vec<f64>,
    /// The model's parameter values, in declaration order.
    model_params: Vec<f64>,
    /// The scene's parameters (a ground point's coordinates may name them).
    scene_params: Vec<(String, f64)>,
}

impl<'a> EffectContext<'a> {
    /// The context of `model`, whose names `names` indexes.
    pub fn new<M: Model>(model: &M, names: &'a NameIndex<'a>) -> Self {
        let info = names.info;
        let mut points = vec![0.0; 2 * info.points.len()];
        let mut blades = vec![0.0; 2 * info.skates.len()];
        model.local_geometry(&mut points, &mut blades);
        let mut mass = vec![0.0; info.nq()];
        model.mass_diagonal(&mut mass);
        let model_params = (0..info.params.len()).map(|i| model.param(i)).collect();
        Self { names, points, blades, mass, model_params, scene_params: Vec::new() }
    }

    /// With the scene's parameters, which a ground point's coordinates may name.
    pub fn with_scene_params(mut self, scene_params: &[(String, f64)]) -> Self {
        self.scene_params = scene_params.to_vec();
        self
    }

    /// The model's description.
    pub fn info(&self) -> &ModelInfo {
        self.names.info
    }

    /// Number of generalized coordinates nq.
    pub fn nq(&self) -> usize {
        self.mass.len()
    }

    /// The mass diagonal (nq) \[kg, kg m^2\].
    pub fn mass(&self) -> &[f64] {
        &self.mass
    }

    /// The value of a model parameter, else of a scene parameter, called `name`.
    pub fn param(&self, name: &str) -> Option<f64> {
        match self.names.info.param_index(name) {
            Some(i) => Some(self.model_params[i]),
            None => self.scene_params.iter().find(|(n, _)| n == name).map(|(_, v)| *v),
        }
    }

    /// The hinge called `name`, for the effect's key `field`.
    ///
    /// # Errors
    /// A [`SpecError`] at `field` listing the model's hinges.
    pub fn hinge(&self, field: &'static str, name: &str) -> Result<HingeRef, SpecError> {
        let info = self.names.info;
        let index = self.names.hinge(name).ok_or_else(|| {
            unknown(field, "hinge", name, info.name, info.hinges.iter().map(|h| h.name.as_str()).collect())
        })?;
        Ok(HingeRef::of(info, index))
    }

    /// The indices of the `(x, y, phi)` of the body called `name`, for the
    /// effect's key `field`.
    ///
    /// # Errors
    /// A [`SpecError`] at `field` listing the model's bodies.
    pub fn body(&self, field: &'static str, name: &str) -> Result<[usize; 3], SpecError> {
        let info = self.names.info;
        let b = self.names.body(name).ok_or_else(|| {
            unknown(field, "body", name, info.name, info.bodies.iter().map(|b| b.name.as_str()).collect())
        })?;
        Ok(info.bodies[b].coords)
    }

    /// The point called `name` (or a body's centre of mass): its body's
    /// `(x, y, phi)` indices and its body-frame offset \[m\], for the
    /// effect's key `field`.
    ///
    /// # Errors
    /// A [`SpecError`] at `field` listing the model's points and bodies.
    pub fn point(&self, field: &'static str, name: &str) -> Result<([usize; 3], [f64; 2]), SpecError> {
        let info = self.names.info;
        if let Some(p) = self.names.point(name) {
            return Ok((info.bodies[info.points[p].body].coords, [self.points[2 * p], self.points[2 * p + 1]]));
        }
        match self.names.body(name) {
            Some(b) => Ok((info.bodies[b].coords, [0.0, 0.0])),
            None => {
                let mut known: Vec<&str> = info.points.iter().map(|p| p.name.as_str()).collect();
                known.extend(info.bodies.iter().map(|b| b.name.as_str()));
                Err(unknown(field, "point or body", name, info.name, known))
            }
        }
    }

    /// The blade of the skate called `name`, for the effect's key `field`.
    ///
    /// # Errors
    /// A [`SpecError`] at `field` listing the model's skates.
    pub fn skate(&self, field: &'static str, name: &str) -> Result<Blade, SpecError> {
        let info = self.names.info;
        let k = self.names.skate(name).ok_or_else(|| {
            unknown(field, "skate", name, info.name, info.skates.iter().map(|k| k.name.as_str()).collect())
        })?;
        let p = info.skates[k].point;
        Ok(Blade {
            body: info.bodies[info.points[p].body].coords,
            offset: [self.points[2 * p], self.points[2 * p + 1]],
            dir: [self.blades[2 * k], self.blades[2 * k + 1]],
        })
    }
}

/// A hinge as a force law uses it: its index in [`ModelInfo::hinges`]
/// and the indices in `q` of its bodies' headings; its angle is
/// `theta = q[a] - q[b]` \[rad\] (`q[a]` for a ground hinge).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct HingeRef {
    /// Index of the hinge in [`ModelInfo::hinges`].
    pub index: usize,
    /// Heading index of the first body.
    pub a: usize,
    /// Heading index of the second body (`None` for the ground).
    pub b: Option<usize>,
}

impl HingeRef {
    /// Hinge `index` of [`ModelInfo::hinges`] with its bodies' heading indices.
    pub fn of(info: &ModelInfo, index: usize) -> Self {
        let h = &info.hinges[index];
        HingeRef { index, a: info.bodies[h.body_a].coords[2], b: h.body_b.map(|b| info.bodies[b].coords[2]) }
    }

    /// The hinge angle `theta = q[a] - q[b]` \[rad\] (`q[a]` for a ground
    /// hinge), `q` (nq).
    #[inline]
    pub fn angle(&self, q: &[f64]) -> f64 {
        q[self.a] - self.b.map_or(0.0, |b| q[b])
    }

    /// Its rate `theta_dot` \[rad/s\], `qd` (nq).
    #[inline]
    pub fn rate(&self, qd: &[f64]) -> f64 {
        self.angle(qd)
    }

    /// Adds a hinge torque `tau` \[N m\] into `f` (nq): `+tau` on the
    /// first body's heading, `-tau` on the second's (docs/physics.md §8).
    /// Returns its power `tau theta_dot` \[W\], what
    /// [`ForceLaw::apply`] returns for the ledger.
    #[inline]
    pub fn add_torque(&self, tau: f64, qd: &[f64], f: &mut [f64]) -> f64 {
        f[self.a] += tau;
        if let Some(b) = self.b {
            f[b] -= tau;
        }
        tau * self.rate(qd)
    }

    /// The coordinates a hinge torque reads and acts on (the two
    /// headings, or one): what [`ForceLaw::coords`] returns for it.
    pub fn coords(&self) -> Vec<usize> {
        std::iter::once(self.a).chain(self.b).collect()
    }
}

/// The two coordinates of `ground(x, y)`, as written (`None` for another name).
fn ground_point(s: &str) -> Option<[&str; 2]> {
    let inner = s.trim().strip_prefix("ground")?.trim_start().strip_prefix('(')?.strip_suffix(')')?;
    let (x, y) = inner.split_once(',')?;
    Some([x.trim(), y.trim()])
}

/// A ground point's coordinate \[m\]: a number, or the name of a model
/// parameter (its value `model_param(index)`) or of a scene parameter.
fn ground_coord(
    a: &str,
    info: &ModelInfo,
    scene_params: &[(String, f64)],
    model_param: impl Fn(usize) -> f64,
) -> Result<f64, String> {
    let v = if let Ok(v) = a.parse::<f64>() {
        if !v.is_finite() {
            return Err(format!("the ground coordinate {a} must be finite [m]"));
        }
        v
    } else if let Some(i) = info.param_index(a) {
        model_param(i)
    } else if let Some((_, v)) = scene_params.iter().find(|(n, _)| n == a) {
        *v
    } else {
        let mut known: Vec<&str> = info.params.iter().map(|p| p.name).collect();
        known.extend(scene_params.iter().map(|(n, _)| n.as_str()));
        return Err(format!(
            "`{a}` in a ground point is neither a number nor a parameter of model {} or of the scene; known: {}",
            info.name,
            if known.is_empty() { "none".to_string() } else { crate::name_list(known) }
        ));
    };
    let what = if a.parse::<f64>().is_ok() { "the ground coordinate".to_string() } else { format!("`{a}`") };
    crate::check_magnitude(&what, v)?;
    Ok(v)
}

/// One end of a spring-damper.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Anchor {
    /// A point of a body: the body's `(x, y, phi)` indices and the point's
    /// body-frame offset \[m\] (zero for the centre of mass).
    Body {
        /// Indices of the body's `(x, y, phi)` in `q`.
        body: [usize; 3],
        /// Body-frame offset from the centre of mass \[m\].
        offset: [f64; 2],
    },
    /// A fixed point of the ground \[m\].
    Ground([f64; 2]),
}

impl Anchor {
    /// World position \[m\], velocity \[m/s\] and, for a body point, the
    /// world lever arm from the centre of mass \[m\].
    #[inline]
    fn state(&self, q: &[f64], qd: &[f64]) -> ([f64; 2], [f64; 2], [f64; 2]) {
        match *self {
            Anchor::Ground(p) => (p, [0.0, 0.0], [0.0, 0.0]),
            Anchor::Body { body, offset } => {
                let (s, c) = Scalar::sin_cos(q[body[2]]);
                let r = [c * offset[0] - s * offset[1], s * offset[0] + c * offset[1]];
                let w = qd[body[2]];
                ([q[body[0]] + r[0], q[body[1]] + r[1]], [qd[body[0]] - w * r[1], qd[body[1]] + w * r[0]], r)
            }
        }
    }

    /// Adds a world force at this end into `f` (nothing for the ground).
    #[inline]
    fn push(&self, lever: [f64; 2], force: [f64; 2], f: &mut [f64]) {
        if let Anchor::Body { body, .. } = *self {
            f[body[0]] += force[0];
            f[body[1]] += force[1];
            f[body[2]] += lever[0] * force[1] - lever[1] * force[0];
        }
    }
}

/// A skate's blade on its body: coordinates, contact-point offset and unit
/// blade direction in the body frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Blade {
    /// Indices of the body's `(x, y, phi)` in `q`.
    pub body: [usize; 3],
    /// Contact point in the body frame \[m\].
    pub offset: [f64; 2],
    /// Unit blade direction in the body frame.
    pub dir: [f64; 2],
}

/// Torque laws at a hinge (see [`EffectSpec`]).
#[derive(Debug, Clone, PartialEq)]
pub enum HingeLaw {
    /// `tau = w(t)`.
    Motor(Waveform),
    /// `tau = -stiffness (theta - rest_angle)`.
    Spring {
        /// \[N m/rad\].
        stiffness: f64,
        /// \[rad\].
        rest_angle: f64,
    },
    /// `tau = -damping theta_dot`.
    Damper {
        /// \[N m s/rad\].
        damping: f64,
    },
    /// `tau = -stiffness (theta - angle(t)) - damping (theta_dot - angle'(t))`.
    Servo {
        /// \[N m/rad\].
        stiffness: f64,
        /// \[N m s/rad\].
        damping: f64,
        /// Commanded angle \[rad\].
        angle: Waveform,
    },
}

impl HingeLaw {
    /// The rate `theta_dot = qd[a] - qd[b]` \[rad/s\] of the hinge whose
    /// bodies' headings are `q[a]` and `q[b]` (`b` `None` for the ground).
    #[inline(always)]
    pub fn rate(a: usize, b: Option<usize>, qd: &[f64]) -> f64 {
        qd[a] - b.map_or(0.0, |b| qd[b])
    }

    /// The values at time `t` \[s\] of the law's waveforms: a motor's
    /// torque \[N m\], a servo's target angle \[rad\] and rate \[rad/s\]
    /// (zeros for a spring or a damper).
    #[inline(always)]
    pub fn waveforms(&self, t: f64) -> Waveforms {
        match self {
            HingeLaw::Motor(w) => [w.eval(t), 0.0, 0.0],
            HingeLaw::Servo { angle, .. } => angle.eval3(t),
            HingeLaw::Spring { .. } | HingeLaw::Damper { .. } => [0.0; 3],
        }
    }

    /// The torque `tau` \[N m\] of the hinge whose bodies' headings are
    /// `q[a]` and `q[b]` (`b` `None` for the ground) at `(q, qd)` (nq each),
    /// with the waveforms' values `wave` ([`HingeLaw::waveforms`]), and the
    /// hinge's rate `theta_dot = qd[a] - qd[b]` \[rad/s\]: the torque's
    /// power is `tau theta_dot`.
    #[inline(always)]
    pub fn torque(&self, wave: &Waveforms, a: usize, b: Option<usize>, q: &[f64], qd: &[f64]) -> (f64, f64) {
        let rate = Self::rate(a, b, qd);
        let theta = || q[a] - b.map_or(0.0, |b| q[b]);
        let tau = match self {
            HingeLaw::Motor(_) => wave[0],
            HingeLaw::Spring { stiffness, rest_angle } => -stiffness * (theta() - rest_angle),
            HingeLaw::Damper { damping } => -damping * rate,
            HingeLaw::Servo { stiffness, damping, .. } => {
                let [target, target_rate, _] = *wave;
                -stiffness * (theta() - target) - damping * (rate - target_rate)
            }
        };
        (tau, rate)
    }
}

/// Force laws along a blade (see [`EffectSpec`]).
#[derive(Debug, Clone, PartialEq)]
pub enum BladeLaw {
    /// `F = -damping v_t`.
    Viscous {
        /// \[N s/m\].
        damping: f64,
    },
    /// `F = -force v_t / sqrt(v_t^2 + smoothing^2)`.
    Coulomb {
        /// \[N\].
        force: f64,
        /// \[m/s\].
        smoothing: f64,
    },
    /// `F = w(t)`.
    Driven(Waveform),
}

/// A resolved force law (indices into `q`, body-frame geometry).
#[derive(Debug, Clone, PartialEq)]
pub enum Law {
    /// A torque pair at a hinge: `+tau` on `q[a]` (first body's heading),
    /// `-tau` on `q[b]` (second body's, `None` for the ground).
    Hinge {
        /// Index of the hinge in [`ModelInfo::hinges`] (where a fused
        /// right-hand side, [`Model::minimal_rhs`], takes its torque).
        hinge: usize,
        /// Heading index of the first body.
        a: usize,
        /// Heading index of the second body.
        b: Option<usize>,
        /// The torque law.
        law: HingeLaw,
    },
    /// A force along a skate's blade at its contact point.
    Blade(Blade, BladeLaw),
    /// A force at a body point.
    Force {
        /// Indices of the body's `(x, y, phi)`.
        body: [usize; 3],
        /// Point of application in the body frame \[m\].
        offset: [f64; 2],
        /// x component \[N\].
        fx: Waveform,
        /// y component \[N\].
        fy: Waveform,
        /// Axes of the components.
        frame: Frame,
    },
    /// A torque on a body.
    Torque {
        /// Heading index of the body.
        phi: usize,
        /// \[N m\].
        torque: Waveform,
    },
    /// Gravity along an inclined plane on every body.
    Slope {
        /// `(x index, y index, mass [kg])` per body.
        bodies: Vec<(usize, usize, f64)>,
        /// Downhill force per unit mass `g sin(angle) (cos, sin)(downhill)` \[N/kg\].
        force_per_kg: [f64; 2],
    },
    /// Anisotropic viscous drag at a body point (see [`EffectSpec::AnisotropicDrag`]).
    Anisotropic {
        /// The point and its unit direction of easy motion (body frame).
        blade: Blade,
        /// \[N s/m\].
        c_along: f64,
        /// \[N s/m\].
        c_across: f64,
    },
    /// A spring-damper-actuator between two ends (see [`EffectSpec::SpringDamper`]).
    SpringDamper {
        /// `from` and `to`.
        ends: [Anchor; 2],
        /// \[N/m\].
        stiffness: f64,
        /// \[m\].
        rest_length: f64,
        /// \[N s/m\].
        damping: f64,
        /// Actuator force \[N\].
        force: Waveform,
    },
    /// Coulomb friction at a skate ([`crate::formulation::friction`]): applied by
    /// [`crate::Dynamics`] itself, which holds the skate's mode; its own
    /// force here is nothing.
    SkateFriction {
        /// Index of the skate in [`ModelInfo::skates`].
        skate: usize,
        /// The skate's blade.
        blade: Blade,
        /// The friction limit `mu N` \[N\].
        limit: f64,
    },
    /// A law of the user's own ([`ForceLaw`]).
    User(UserLaw),
    /// Drag at a body's centre of mass.
    Drag {
        /// Indices of the body's `(x, y, phi)`.
        body: [usize; 3],
        /// Translational coefficient.
        c: f64,
        /// Rotational coefficient.
        c_rot: f64,
        /// `|v| v` instead of `v`.
        quadratic: bool,
    },
}

impl Law {
    /// A law of the user's own for the effect `name` on a model with `nq`
    /// coordinates.
    ///
    /// # Errors
    /// [`SimError::Effect`] if [`ForceLaw::coords`] lists a coordinate
    /// beyond the model's (the right-hand side and RADAU5's coupling index
    /// `q` with them).
    pub fn user(name: &str, law: Arc<dyn ForceLaw>, nq: usize) -> Result<Law, SimError> {
        if let Some(k) = law.coords().into_iter().find(|&k| k >= nq) {
            return Err(SimError::Effect {
                effect: name.to_string(),
                field: "",
                message: format!("the law's coords() lists coordinate {k}, but the model has {nq}"),
            });
        }
        Ok(Law::User(UserLaw(law)))
    }
}

/// A resolved law of the user's own, shared by the copies of its
/// effect (two are equal when they are the same law).
#[derive(Debug, Clone)]
pub struct UserLaw(pub Arc<dyn ForceLaw>);

impl PartialEq for UserLaw {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.0, &other.0)
    }
}

/// An effect resolved against a model, ready for the right-hand side.
#[derive(Debug, Clone, PartialEq)]
pub struct Effect {
    /// The scene's name for it (`W_<name>` is its work column).
    pub name: String,
    /// Name of its output column (see [`EffectSpec::value_column`]).
    pub value_column: String,
    /// The force law.
    pub law: Law,
    /// Whether it acts. An effect switched off (by an event's
    /// `switch_off`, [`crate::events::spec::Action::Switch`], or by a library
    /// user before the run) adds no force, its power is 0 (its work state
    /// holds) and its value column reads 0. `simulate` restores each
    /// effect's setting at the run's end.
    pub on: bool,
}

/// The time scale of a linear force law on the masses it acts on: what
/// a step must resolve (an explicit method is stable only for steps of
/// about this size or below).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimeScale {
    /// The time scale \[s\]: `sqrt(m / |k|)` for a stiffness `k`, `m / c`
    /// for a damping `c`.
    pub seconds: f64,
    /// The key of the effect that sets it (`stiffness`, `damping`, `c`,
    /// `c_rot`, `c_along`, `c_across`).
    pub key: &'static str,
    /// Its value.
    pub value: f64,
    /// The mass or inertia it acts on: the smallest positive entry of the
    /// mass diagonal at the law's coordinates \[kg or kg m^2\].
    pub mass: f64,
}

impl Effect {
    /// The shortest time scale of the effect's linear terms (hinge
    /// springs, dampers and servos, viscous skate and drag laws,
    /// spring-dampers) against the mass diagonal `mass` (nq); `None` for
    /// other laws and for laws on massless coordinates only. Used to name
    /// a law too fast for the run when the step size collapses
    /// ([`SimError::with_fast_law`]).
    pub fn time_scale(&self, mass: &[f64]) -> Option<TimeScale> {
        let smallest = |idx: &mut dyn Iterator<Item = usize>| {
            idx.filter_map(|k| mass.get(k).copied()).filter(|m| *m > 0.0 && m.is_finite()).min_by(f64::total_cmp)
        };
        let mut best: Option<TimeScale> = None;
        let mut consider = |m: Option<f64>, key: &'static str, value: f64, stiffness: bool| {
            let Some(m) = m else { return };
            if value == 0.0 || !value.is_finite() {
                return;
            }
            let seconds = if stiffness { (m / value.abs()).sqrt() } else { m / value.abs() };
            if best.is_none_or(|b| seconds < b.seconds) {
                best = Some(TimeScale { seconds, key, value, mass: m });
            }
        };
        match &self.law {
            Law::Hinge { a, b, law, .. } => {
                let m = smallest(&mut std::iter::once(*a).chain(*b));
                match law {
                    HingeLaw::Spring { stiffness, .. } => consider(m, "stiffness", *stiffness, true),
                    HingeLaw::Damper { damping } => consider(m, "damping", *damping, false),
                    HingeLaw::Servo { stiffness, damping, .. } => {
                        consider(m, "stiffness", *stiffness, true);
                        consider(m, "damping", *damping, false);
                    }
                    HingeLaw::Motor(_) => {}
                }
            }
            Law::Blade(blade, BladeLaw::Viscous { damping }) => {
                consider(smallest(&mut blade.body[..2].iter().copied()), "damping", *damping, false);
            }
            Law::Anisotropic { blade, c_along, c_across } => {
                let m = smallest(&mut blade.body[..2].iter().copied());
                consider(m, "c_along", *c_along, false);
                consider(m, "c_across", *c_across, false);
            }
            Law::SpringDamper { ends, stiffness, damping, .. } => {
                let m = smallest(&mut ends.iter().filter_map(|e| match e {
                    Anchor::Body { body, .. } => Some(body[0]),
                    Anchor::Ground(_) => None,
                }));
                consider(m, "stiffness", *stiffness, true);
                consider(m, "damping", *damping, false);
            }
            Law::Drag { body, c, c_rot, quadratic: false } => {
                consider(smallest(&mut body[..2].iter().copied()), "c", *c, false);
                consider(smallest(&mut std::iter::once(body[2])), "c_rot", *c_rot, false);
            }
            _ => {}
        }
        best
    }
}

/// Adds a world force `(fx_w, fy_w)` at body-frame offset `p` of `body` into
/// `f`; returns the point's velocity `v_P` (world) for the power.
#[inline]
fn point_force(body: [usize; 3], p: [f64; 2], force: [f64; 2], q: &[f64], qd: &[f64], f: &mut [f64]) -> [f64; 2] {
    let (s, c) = Scalar::sin_cos(q[body[2]]);
    let r = [c * p[0] - s * p[1], s * p[0] + c * p[1]];
    let w = qd[body[2]];
    f[body[0]] += force[0];
    f[body[1]] += force[1];
    f[body[2]] += r[0] * force[1] - r[1] * force[0];
    [qd[body[0]] - w * r[1], qd[body[1]] + w * r[0]]
}

/// What an effect's force takes from the time alone: the values of its
/// waveforms at one time ([`Effect::waveforms`]), so that stages at one
/// time (RK4's two midpoints, a step's end and the next step's start)
/// evaluate them once.
pub type Waveforms = [f64; 3];

impl Effect {
    /// Adds this effect's generalized force at `(t, q, qd)` into `f` (nq)
    /// and returns `(power [W], value)`, `value` being the effect's output
    /// quantity ([`Effect::value_column`]).
    #[inline]
    pub fn apply(&self, t: f64, q: &[f64], qd: &[f64], f: &mut [f64]) -> (f64, f64) {
        self.apply_with(t, &self.waveforms(t), q, qd, f)
    }

    /// How the effect's force depends on time at a fixed state: through
    /// its waveforms (a motor's torque, a servo's angle, a force's
    /// components); `None` for a law of the user's own, which ezy cannot
    /// see into.
    pub fn periodicity(&self) -> Option<Periodicity> {
        let of = |w: &Waveform| w.periodicity();
        Some(match &self.law {
            Law::Hinge { law: HingeLaw::Motor(w) | HingeLaw::Servo { angle: w, .. }, .. }
            | Law::Blade(_, BladeLaw::Driven(w))
            | Law::Torque { torque: w, .. }
            | Law::SpringDamper { force: w, .. } => of(w),
            Law::Force { fx, fy, .. } => Periodicity::combine([of(fx), of(fy)]),
            Law::User(_) => return None,
            _ => Periodicity::Constant,
        })
    }

    /// The values at time `t` \[s\] of the effect's waveforms: a motor's
    /// torque, a servo's target angle and rate, a driven blade's force, a
    /// force's two components, a torque, a spring-damper's added tension
    /// (zeros for an effect without one).
    #[inline(always)]
    pub fn waveforms(&self, t: f64) -> Waveforms {
        match &self.law {
            Law::Hinge { law, .. } => law.waveforms(t),
            Law::Blade(_, BladeLaw::Driven(w)) | Law::Torque { torque: w, .. } | Law::SpringDamper { force: w, .. } => {
                [w.eval(t), 0.0, 0.0]
            }
            Law::Force { fx, fy, .. } => [fx.eval(t), fy.eval(t), 0.0],
            _ => [0.0; 3],
        }
    }

    /// [`Effect::apply`] with the waveforms' values `wave` at the time `t`
    /// \[s\] of the state ([`Effect::waveforms`]).
    #[inline(always)]
    pub fn apply_with(&self, t: f64, wave: &Waveforms, q: &[f64], qd: &[f64], f: &mut [f64]) -> (f64, f64) {
        if !self.on {
            return (0.0, 0.0);
        }
        match &self.law {
            Law::User(law) => law.0.apply(t, q, qd, f),
            Law::Hinge { a, b, law, .. } => {
                let (tau, rate) = law.torque(wave, *a, *b, q, qd);
                f[*a] += tau;
                if let Some(b) = b {
                    f[*b] -= tau;
                }
                (tau * rate, tau)
            }
            Law::Blade(bl, law) => {
                let (s, c) = Scalar::sin_cos(q[bl.body[2]]);
                let e = [c * bl.dir[0] - s * bl.dir[1], s * bl.dir[0] + c * bl.dir[1]];
                let r = [c * bl.offset[0] - s * bl.offset[1], s * bl.offset[0] + c * bl.offset[1]];
                let w = qd[bl.body[2]];
                let v = [qd[bl.body[0]] - w * r[1], qd[bl.body[1]] + w * r[0]];
                let vt = e[0] * v[0] + e[1] * v[1];
                let force = match law {
                    BladeLaw::Viscous { damping } => -damping * vt,
                    BladeLaw::Coulomb { force, smoothing } => -force * vt / vt.hypot(*smoothing),
                    BladeLaw::Driven(_) => wave[0],
                };
                f[bl.body[0]] += force * e[0];
                f[bl.body[1]] += force * e[1];
                f[bl.body[2]] += force * (r[0] * e[1] - r[1] * e[0]);
                (force * vt, force)
            }
            Law::Force { body, offset, frame, .. } => {
                let (x, y) = (wave[0], wave[1]);
                let force = match frame {
                    Frame::World => [x, y],
                    Frame::Body => {
                        let (s, c) = Scalar::sin_cos(q[body[2]]);
                        [c * x - s * y, s * x + c * y]
                    }
                };
                let v = point_force(*body, *offset, force, q, qd, f);
                (force[0] * v[0] + force[1] * v[1], force[0].hypot(force[1]))
            }
            Law::Torque { phi, .. } => {
                let tau = wave[0];
                f[*phi] += tau;
                (tau * qd[*phi], tau)
            }
            Law::Slope { bodies, force_per_kg } => {
                let mut power = 0.0;
                let mut total = 0.0;
                for &(ix, iy, m) in bodies {
                    let fx = m * force_per_kg[0];
                    let fy = m * force_per_kg[1];
                    f[ix] += fx;
                    f[iy] += fy;
                    power += fx * qd[ix] + fy * qd[iy];
                    total += m;
                }
                (power, total * force_per_kg[0].hypot(force_per_kg[1]))
            }
            Law::Anisotropic { blade: bl, c_along, c_across } => {
                let (s, c) = Scalar::sin_cos(q[bl.body[2]]);
                let e = [c * bl.dir[0] - s * bl.dir[1], s * bl.dir[0] + c * bl.dir[1]];
                let r = [c * bl.offset[0] - s * bl.offset[1], s * bl.offset[0] + c * bl.offset[1]];
                let w = qd[bl.body[2]];
                let v = [qd[bl.body[0]] - w * r[1], qd[bl.body[1]] + w * r[0]];
                let (vt, vn) = (e[0] * v[0] + e[1] * v[1], e[0] * v[1] - e[1] * v[0]);
                // -c_along vt e - c_across vn n, n = (-e_y, e_x)
                let force = [-c_along * vt * e[0] + c_across * vn * e[1], -c_along * vt * e[1] - c_across * vn * e[0]];
                f[bl.body[0]] += force[0];
                f[bl.body[1]] += force[1];
                f[bl.body[2]] += r[0] * force[1] - r[1] * force[0];
                (force[0] * v[0] + force[1] * v[1], force[0].hypot(force[1]))
            }
            Law::SpringDamper { ends: [a, b], stiffness, rest_length, damping, .. } => {
                let (ra, va, la) = a.state(q, qd);
                let (rb, vb, lb) = b.state(q, qd);
                let d = [ra[0] - rb[0], ra[1] - rb[1]];
                let len = d[0].hypot(d[1]);
                if len.is_nan() || len <= 0.0 {
                    // no direction: the right-hand side reports it (see `Effect::failure`)
                    return (f64::NAN, f64::NAN);
                }
                let e = [d[0] / len, d[1] / len];
                let rate = e[0] * (va[0] - vb[0]) + e[1] * (va[1] - vb[1]);
                let tension = stiffness * (len - rest_length) + damping * rate + wave[0];
                a.push(la, [-tension * e[0], -tension * e[1]], f);
                b.push(lb, [tension * e[0], tension * e[1]], f);
                (-tension * rate, tension)
            }
            // applied by the dynamics, which knows the skate's mode
            Law::SkateFriction { .. } => (0.0, 0.0),
            Law::Drag { body, c, c_rot, quadratic } => {
                let v = [qd[body[0]], qd[body[1]]];
                let w = qd[body[2]];
                let (k, k_rot) = if *quadratic { (c * v[0].hypot(v[1]), c_rot * w.abs()) } else { (*c, *c_rot) };
                let force = [-k * v[0], -k * v[1]];
                f[body[0]] += force[0];
                f[body[1]] += force[1];
                f[body[2]] -= k_rot * w;
                (force[0] * v[0] + force[1] * v[1] - k_rot * w * w, force[0].hypot(force[1]))
            }
        }
    }

    /// The coordinates a force that depends on time alone acts on (a body
    /// torque, gravity or a slope): its power is `f . qd`, so `dP/dqd = f`
    /// there. Empty for every other effect ([`Effect::coords`]).
    pub fn constant_force_coords(&self) -> Vec<usize> {
        match &self.law {
            Law::Torque { phi, .. } => vec![*phi],
            Law::Slope { bodies, .. } => bodies.iter().flat_map(|&(x, y, _)| [x, y]).collect(),
            _ => Vec::new(),
        }
    }

    /// The coordinates this effect's force depends on or acts on (its
    /// coupling in the Jacobian of the applied forces; empty for a force
    /// that depends on time alone).
    pub fn coords(&self) -> Vec<usize> {
        let mut out: Vec<usize> = match &self.law {
            Law::Hinge { a, b, .. } => std::iter::once(*a).chain(*b).collect(),
            Law::Blade(bl, _) | Law::Anisotropic { blade: bl, .. } | Law::SkateFriction { blade: bl, .. } => {
                bl.body.to_vec()
            }
            Law::Force { body, .. } | Law::Drag { body, .. } => body.to_vec(),
            Law::Torque { .. } | Law::Slope { .. } => Vec::new(),
            Law::User(law) => law.0.coords(),
            Law::SpringDamper { ends, .. } => ends
                .iter()
                .flat_map(|e| match e {
                    Anchor::Body { body, .. } => body.to_vec(),
                    Anchor::Ground(_) => Vec::new(),
                })
                .collect(),
        };
        out.sort_unstable();
        out.dedup();
        out
    }

    /// Why this effect's power came out NaN at `q` (for the error that
    /// stops the run): a spring-damper of zero length has no direction.
    pub fn failure(&self, q: &[f64]) -> String {
        if let Law::User(law) = &self.law {
            return law.0.failure(q);
        }
        if let Law::SpringDamper { ends: [a, b], .. } = &self.law {
            let qd = vec![0.0; q.len()];
            let (ra, _, _) = a.state(q, &qd);
            let (rb, _, _) = b.state(q, &qd);
            if (ra[0] - rb[0]).hypot(ra[1] - rb[1]) == 0.0 {
                return format!(
                    "has length 0 m: its ends coincide at ({}, {}), so its force has no direction",
                    ra[0], ra[1]
                );
            }
        }
        "gave a force or power that is not a number (its inputs are not finite)".into()
    }

    /// For a spring-damper: the world positions of its two ends at `q`
    /// \[m\], each with whether it is a fixed ground point (what `ezy
    /// animate` draws as a zig-zag); `None` for every other effect.
    pub fn spring_ends(&self, q: &[f64]) -> Option<[([f64; 2], bool); 2]> {
        let Law::SpringDamper { ends, .. } = &self.law else { return None };
        let qd = vec![0.0; q.len()];
        Some(ends.each_ref().map(|e| (e.state(q, &qd).0, matches!(e, Anchor::Ground(_)))))
    }

    /// Name of the effect's work column, `W_<name>` \[J\].
    pub fn work_column(&self) -> String {
        crate::names::work_name(&self.name)
    }
}
