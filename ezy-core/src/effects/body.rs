//! Body loads and gravity (one family): a force at a body point, a torque
//! on a body, gravity along an inclined plane (`slope`) and gravity in the
//! plane of motion (`gravity`). Each kind is a spec struct implementing
//! [`EffectKind`]; all resolve to [`BodyLaw`].
//!
//! A force `F` (world frame) at a body point with body-frame offset `p`
//! from the centre of mass acts on the body's coordinates `(x, y, phi)` as
//! `(F_x, F_y, r_x F_y - r_y F_x)` with `r = R(phi) p`; its power is
//! `F . v_P` (docs/physics.md §1, §8).

use serde::{Deserialize, Serialize};

use super::context::{CheckContext, EffectContext, SpecError, angle, finite, wave};
use super::jacobian::{Blocks, Var, perp};
use super::kind::{EffectKind, ForceLaw, Reference, Waveforms};
use super::law::Law;
use super::waveform::{Periodicity, Waveform};
use crate::names::fmt_value;
use crate::scalar::Scalar;
use crate::settings::check_magnitude;

/// Standard gravity \[m/s^2\] (the default of [`Slope`] and [`Gravity`]).
pub const STANDARD_GRAVITY: f64 = 9.806_65;

pub(crate) fn default_gravity() -> f64 {
    STANDARD_GRAVITY
}
pub(crate) fn is_default_gravity(v: &f64) -> bool {
    *v == STANDARD_GRAVITY
}
fn is_zero(v: &f64) -> bool {
    *v == 0.0
}
fn is_zero_waveform(w: &Waveform) -> bool {
    *w == Waveform::Constant(0.0)
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

/// A force (`force`): `(fx(t), fy(t))` \[N\] at a body's centre of mass
/// (`at` names a body) or at a named point (`at` names a point), in world
/// or body axes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Force {
    /// A body (centre of mass) or a point.
    pub at: String,
    /// x component \[N\] over time.
    #[serde(default, skip_serializing_if = "is_zero_waveform")]
    pub fx: Waveform,
    /// y component \[N\] over time.
    #[serde(default, skip_serializing_if = "is_zero_waveform")]
    pub fy: Waveform,
    /// Axes of `fx`, `fy`.
    #[serde(default)]
    pub frame: Frame,
}

/// A torque (`torque`): `torque(t)` \[N m\] on a body.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Torque {
    /// Body name.
    pub body: String,
    /// Torque \[N m\] over time.
    pub torque: Waveform,
}

/// Gravity on a plane inclined by `angle` (`slope`): every body feels `m g
/// sin(angle)` \[N\] along the downhill direction, at angle `downhill` from
/// the x axis (the normal component is carried by the skates' contact and
/// does no work). Work is minus the change of potential energy `m g
/// sin(angle) (height along the uphill direction)`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Slope {
    /// Inclination of the plane, from -pi/2 to pi/2 \[rad\].
    pub angle: f64,
    /// Direction of steepest descent in the plane, from the x axis \[rad\].
    #[serde(default, skip_serializing_if = "is_zero")]
    pub downhill: f64,
    /// Gravitational acceleration \[m/s^2\].
    #[serde(default = "default_gravity", skip_serializing_if = "is_default_gravity")]
    pub g: f64,
}

/// Gravity in the plane of motion (`gravity`; a mechanism in a vertical
/// plane): a uniform field `g = [gx, gy]` \[m/s^2\] (default `[0,
/// -9.80665]`, down the y axis), the force `m g` at the centre of mass of
/// every body, or of the bodies listed. Its work is minus the change of
/// the potential energy `-m g . r`. (`slope` is the inclined plane under
/// vehicles.)
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Gravity {
    /// The field \[m/s^2\].
    #[serde(default = "default_field", skip_serializing_if = "is_default_field")]
    pub g: [f64; 2],
    /// The bodies it acts on (default: all).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bodies: Option<Vec<String>>,
}

/// A body load resolved against a model: the family's law, in the hot
/// enum as [`Law::Body`].
#[derive(Debug, Clone, PartialEq)]
pub enum BodyLaw {
    /// A force at a body point ([`Force`]).
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
    /// A torque on a body ([`Torque`]).
    Torque {
        /// Heading index of the body.
        phi: usize,
        /// \[N m\].
        torque: Waveform,
    },
    /// A uniform field on bodies' centres of mass ([`Slope`], [`Gravity`]).
    Field {
        /// `(x index, y index, mass [kg])` per body.
        bodies: Vec<(usize, usize, f64)>,
        /// Force per unit mass \[N/kg\]: `g sin(angle) (cos, sin)(downhill)`
        /// on a slope, `g` in the plane.
        force_per_kg: [f64; 2],
    },
}

/// Adds a world force `force` \[N\] at body-frame offset `p` \[m\] of
/// `body` into `f` (nq); returns the point's velocity `v_P` (world)
/// \[m/s\] for the power.
#[inline(always)]
fn point_force(body: [usize; 3], p: [f64; 2], force: [f64; 2], q: &[f64], qd: &[f64], f: &mut [f64]) -> [f64; 2] {
    let (s, c) = Scalar::sin_cos(q[body[2]]);
    let r = [c * p[0] - s * p[1], s * p[0] + c * p[1]];
    let w = qd[body[2]];
    f[body[0]] += force[0];
    f[body[1]] += force[1];
    f[body[2]] += r[0] * force[1] - r[1] * force[0];
    [qd[body[0]] - w * r[1], qd[body[1]] + w * r[0]]
}

impl BodyLaw {
    /// The waveforms' values at `t` \[s\] with each waveform's numbers
    /// moved toward `other`'s to first order ([`Waveform::eval3_toward`]):
    /// the forward sensitivities' right-hand side at `p +- h`
    /// ([`crate::sensitivity`]).
    pub fn waveforms_toward(&self, other: &Self, t: f64) -> Waveforms {
        match (self, other) {
            (BodyLaw::Force { fx: ax, fy: ay, .. }, BodyLaw::Force { fx: bx, fy: by, .. }) => {
                [ax.eval3_toward(bx, t)[0], ay.eval3_toward(by, t)[0], 0.0]
            }
            (BodyLaw::Torque { torque: a, .. }, BodyLaw::Torque { torque: b, .. }) => {
                [a.eval3_toward(b, t)[0], 0.0, 0.0]
            }
            _ => other.waveforms(t),
        }
    }
}

impl ForceLaw for BodyLaw {
    #[inline]
    fn apply(&self, t: f64, q: &[f64], qd: &[f64], f: &mut [f64]) -> (f64, f64) {
        self.apply_with(t, &self.waveforms(t), q, qd, f)
    }

    #[inline(always)]
    fn apply_with(&self, _t: f64, wave: &Waveforms, q: &[f64], qd: &[f64], f: &mut [f64]) -> (f64, f64) {
        match self {
            BodyLaw::Force { body, offset, frame, .. } => {
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
            BodyLaw::Torque { phi, .. } => {
                let tau = wave[0];
                f[*phi] += tau;
                (tau * qd[*phi], tau)
            }
            BodyLaw::Field { bodies, force_per_kg } => {
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
        }
    }

    #[inline(always)]
    fn waveforms(&self, t: f64) -> Waveforms {
        match self {
            BodyLaw::Force { fx, fy, .. } => [fx.eval(t), fy.eval(t), 0.0],
            BodyLaw::Torque { torque, .. } => [torque.eval(t), 0.0, 0.0],
            BodyLaw::Field { .. } => [0.0; 3],
        }
    }

    /// Exact. A torque and a field depend on time alone: nothing. A force
    /// at a body point turns its lever with the body (`-(r . F)` on the
    /// heading's row and column); in body axes the force turns too
    /// (`dF/dphi = (-F_y, F_x)`), and the two cancel: its moment is the
    /// body-frame `p x (fx, fy)`, whatever the heading.
    fn jacobian(&self, _t: f64, wave: &Waveforms, q: &[f64], _qd: &[f64], dq: &mut [f64], dqd: &mut [f64]) -> bool {
        if let BodyLaw::Force { body, offset, frame, .. } = self {
            let (s, c) = Scalar::sin_cos(q[body[2]]);
            let r = [c * offset[0] - s * offset[1], s * offset[0] + c * offset[1]];
            let (x, y) = (wave[0], wave[1]);
            let force = match frame {
                Frame::World => [x, y],
                Frame::Body => [c * x - s * y, s * x + c * y],
            };
            let mut blocks = Blocks::new(q.len(), dq, dqd);
            if *frame == Frame::Body {
                blocks.force(*body, r, Var::Q(body[2]), perp(force));
            }
            blocks.lever(*body, r, force);
        }
        true
    }

    fn time_only(&self) -> bool {
        matches!(self, BodyLaw::Torque { .. } | BodyLaw::Field { .. })
    }

    fn coords(&self) -> Vec<usize> {
        match self {
            BodyLaw::Force { body, .. } => body.to_vec(),
            BodyLaw::Torque { .. } | BodyLaw::Field { .. } => Vec::new(),
        }
    }

    fn failure(&self, _q: &[f64]) -> String {
        super::kind::NOT_A_NUMBER.into()
    }

    fn periodicity(&self) -> Option<Periodicity> {
        Some(match self {
            BodyLaw::Force { fx, fy, .. } => Periodicity::combine([fx.periodicity(), fy.periodicity()]),
            BodyLaw::Torque { torque, .. } => torque.periodicity(),
            BodyLaw::Field { .. } => Periodicity::Constant,
        })
    }

    fn span(&self) -> (f64, f64) {
        match self {
            BodyLaw::Force { fx, fy, .. } => {
                let ((a, b), (c, d)) = (fx.span(), fy.span());
                (a.max(c), b.min(d))
            }
            BodyLaw::Torque { torque, .. } => torque.span(),
            BodyLaw::Field { .. } => (f64::NEG_INFINITY, f64::INFINITY),
        }
    }

    fn forcing_omega(&self) -> f64 {
        match self {
            BodyLaw::Force { fx, fy, .. } => fx.max_omega().max(fy.max_omega()),
            BodyLaw::Torque { torque, .. } => torque.max_omega(),
            BodyLaw::Field { .. } => 0.0,
        }
    }

    fn constant_force_coords(&self) -> Vec<usize> {
        match self {
            BodyLaw::Torque { phi, .. } => vec![*phi],
            BodyLaw::Field { bodies, .. } => bodies.iter().flat_map(|&(x, y, _)| [x, y]).collect(),
            BodyLaw::Force { .. } => Vec::new(),
        }
    }

    fn into_law(self) -> Law {
        Law::Body(self)
    }
}

impl EffectKind for Force {
    type Law = BodyLaw;
    fn check(&self, cx: &CheckContext<'_>) -> Result<(), SpecError> {
        cx.body_or_point("at", &self.at)?;
        wave("fx", &self.fx)?;
        wave("fy", &self.fy)
    }
    fn resolve(&self, cx: &EffectContext<'_>) -> Result<BodyLaw, SpecError> {
        let (body, offset) = cx.point("at", &self.at)?;
        Ok(BodyLaw::Force { body, offset, fx: self.fx.clone(), fy: self.fy.clone(), frame: self.frame })
    }
}

impl Reference for Force {
    const KEYS: &'static str = "`at` (body or point), `fx`, `fy` (waveforms) [N], `frame` = `world` or `body`";
    const LAW: &'static str = "`(fx, fy)` at the centre of mass or the point";
}

impl EffectKind for Torque {
    type Law = BodyLaw;
    const VALUE_PREFIX: &'static str = "tau";
    fn check(&self, cx: &CheckContext<'_>) -> Result<(), SpecError> {
        cx.body("body", &self.body)?;
        wave("torque", &self.torque)
    }
    fn resolve(&self, cx: &EffectContext<'_>) -> Result<BodyLaw, SpecError> {
        Ok(BodyLaw::Torque { phi: cx.body("body", &self.body)?[2], torque: self.torque.clone() })
    }
}

impl Reference for Torque {
    const KEYS: &'static str = "`body`, `torque` (waveform) [N m]";
    const LAW: &'static str = "`tau = torque(t)` on the body";
}

/// `(x index, y index, mass [kg])` of each body of the model `cx`
/// describes that `keep` keeps.
fn masses(cx: &EffectContext<'_>, keep: impl Fn(&str) -> bool) -> Vec<(usize, usize, f64)> {
    let mass = cx.mass();
    cx.info().bodies.iter().filter(|b| keep(&b.name)).map(|b| (b.coords[0], b.coords[1], mass[b.coords[0]])).collect()
}

impl EffectKind for Slope {
    type Law = BodyLaw;
    fn check(&self, _cx: &CheckContext<'_>) -> Result<(), SpecError> {
        // an inclination: from level (0) to vertical (pi/2), either way
        let inclination = self.angle;
        SpecError::check(inclination.is_finite() && inclination.abs() <= std::f64::consts::FRAC_PI_2, "angle", || {
            format!(
                "angle = {} is not the inclination of a plane: give an angle from -pi/2 to pi/2 [rad] (its direction is `downhill`)",
                fmt_value(inclination)
            )
        })?;
        angle("downhill", self.downhill)?;
        finite("g", self.g)
    }
    fn resolve(&self, cx: &EffectContext<'_>) -> Result<BodyLaw, SpecError> {
        let (g, angle, downhill) = (self.g, self.angle, self.downhill);
        Ok(BodyLaw::Field {
            bodies: masses(cx, |_| true),
            force_per_kg: [g * angle.sin() * downhill.cos(), g * angle.sin() * downhill.sin()],
        })
    }
}

impl Reference for Slope {
    const KEYS: &'static str = "`angle` [rad], `downhill` [rad] (0), `g` [m/s^2] (9.80665)";
    const LAW: &'static str = "`m g sin(angle)` on every body along `(cos, sin)(downhill)`";
}

impl EffectKind for Gravity {
    type Law = BodyLaw;
    fn check(&self, cx: &CheckContext<'_>) -> Result<(), SpecError> {
        let g = self.g;
        if !(g[0].is_finite() && g[1].is_finite()) {
            return Err(SpecError { field: "g", message: format!("g = {g:?} must be finite [m/s^2]") });
        }
        for (i, c) in g.iter().enumerate() {
            check_magnitude(&format!("g[{i}]"), *c).map_err(|message| SpecError { field: "g", message })?;
        }
        for b in self.bodies.iter().flatten() {
            cx.body("bodies", b)?;
        }
        Ok(())
    }
    fn resolve(&self, cx: &EffectContext<'_>) -> Result<BodyLaw, SpecError> {
        let listed = |name: &str| self.bodies.as_ref().is_none_or(|list| list.iter().any(|b| b == name));
        Ok(BodyLaw::Field { bodies: masses(cx, listed), force_per_kg: self.g })
    }
}

impl Reference for Gravity {
    const KEYS: &'static str = "`g = [gx, gy]` [m/s^2] (`[0, -9.80665]`), `bodies` (all)";
    const LAW: &'static str = "`m g` at every listed body's centre of mass (a mechanism in a vertical plane); its work is minus the change of `-m g . r`";
}
