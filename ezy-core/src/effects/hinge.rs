//! Hinge torque laws (one family, MuJoCo's `mj_passive` calls one
//! function per family): a motor, a spring, a damper, a position servo and
//! Coulomb-viscous friction at a hinge. Each kind is a spec struct (its
//! scene table, read by serde) implementing [`EffectKind`]; all resolve
//! to one law struct, [`HingeLaw`]: the hinge ([`HingeRef`]) and its
//! torque law ([`HingeTorque`]).
//!
//! A hinge torque `tau` \[N m\] acts `+tau` on the hinge's first body and
//! `-tau` on its second; the hinge angle is `theta = phi_a - phi_b`
//! (`phi_a` for a ground hinge), so the torque's power is `tau
//! theta_dot` (docs/physics.md §8). The torque is evaluated in one place,
//! [`HingeLaw::torque`]: the right-hand side's generalized force
//! ([`ForceLaw::apply_with`]) and the fused right-hand side on the
//! minimal coordinates, which takes the hinges' torques as such
//! ([`HingeLaw::torque_at`]), both call it.
//!
//! To add a hinge law: a spec struct with its [`EffectKind`] and
//! [`Reference`] here, a variant of [`HingeTorque`] with its arm in
//! [`HingeLaw::torque`] (and in [`HingeLaw`]'s time scale if it has a
//! linear coefficient), and one line in [`super::registry`].

use serde::{Deserialize, Serialize};

use super::context::{CheckContext, EffectContext, HingeRef, SpecError, angle, finite, non_negative, positive, wave};
use super::jacobian::{Blocks, Var};
use super::kind::{EffectKind, ForceLaw, Reference, TimeScale, Waveforms};
use super::law::Law;
use super::waveform::{Periodicity, Waveform};

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

/// Hinge motor (`hinge-motor`): torque `tau(t)` \[N m\] given by a
/// waveform, `+tau` on the hinge's first body, `-tau` on the second (the
/// `drive` scene's motor, docs/physics.md §10.3, is `torque = { cos = {
/// amplitude = 2, omega = pi } }`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HingeMotor {
    /// Hinge name.
    pub hinge: String,
    /// Torque \[N m\] over time.
    pub torque: Waveform,
}

/// Rotational spring at a hinge (`hinge-spring`): `tau = -stiffness (theta
/// - rest_angle)`, `theta = phi_a - phi_b` (linear torsion spring; its
/// work is minus the change of `stiffness (theta - rest_angle)^2 / 2`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HingeSpring {
    /// Hinge name.
    pub hinge: String,
    /// Stiffness \[N m/rad\].
    pub stiffness: f64,
    /// Angle of zero torque \[rad\].
    #[serde(default, skip_serializing_if = "is_zero")]
    pub rest_angle: f64,
}

/// Viscous damper at a hinge (`hinge-damper`): `tau = -damping theta_dot`
/// (dissipates `damping theta_dot^2` \[W\]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HingeDamper {
    /// Hinge name.
    pub hinge: String,
    /// Damping \[N m s/rad\].
    pub damping: f64,
}

/// Position servo at a hinge (`hinge-servo`; a PD controller, or a
/// spring-damper whose rest angle moves): `tau = -stiffness (theta -
/// angle(t)) - damping (theta_dot - angle'(t))` \[N m\]. With a large
/// stiffness the hinge follows `angle(t)` closely and the scene is stiff:
/// the fast modes have frequencies near `sqrt(stiffness / inertia)` (use
/// `--integrator radau5`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HingeServo {
    /// Hinge name.
    pub hinge: String,
    /// Stiffness \[N m/rad\].
    pub stiffness: f64,
    /// Damping \[N m s/rad\].
    #[serde(default, skip_serializing_if = "is_zero")]
    pub damping: f64,
    /// Commanded hinge angle \[rad\] over time (its derivative is the
    /// commanded rate).
    pub angle: Waveform,
}

/// Coulomb-viscous friction at a hinge (`hinge-friction`; a bearing):
/// `tau = -(damping theta_dot + torque tanh(theta_dot / smoothing))`
/// \[N m\]. For `|theta_dot| >> smoothing` the Coulomb part is
/// `-torque sign(theta_dot)`; below `smoothing` it is linear, so the law
/// is smooth at rest (the fixed-step methods keep their order) and a
/// hinge coasting down comes to rest within about `smoothing` of the
/// rate where the pure Coulomb law would stop it (no stiction: Stribeck-
/// free). It dissipates `-tau theta_dot >= 0` \[W\] (its work, negative,
/// is in its `W_<name>`). A small `smoothing` makes the scene stiff near
/// rest: the linear part's damping is `torque / smoothing`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HingeFriction {
    /// Hinge name.
    pub hinge: String,
    /// Viscous coefficient `c_v` \[N m s/rad\], zero or positive.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub damping: f64,
    /// Coulomb friction torque `T_c` \[N m\], zero or positive.
    pub torque: f64,
    /// Rate `w_s` below which the Coulomb part is linear \[rad/s\], positive.
    pub smoothing: f64,
}

/// Torque laws at a hinge, the resolved form of the hinge kinds.
#[derive(Debug, Clone, PartialEq)]
pub enum HingeTorque {
    /// `tau = w(t)` ([`HingeMotor`]).
    Motor(Waveform),
    /// `tau = -stiffness (theta - rest_angle)` ([`HingeSpring`]).
    Spring {
        /// \[N m/rad\].
        stiffness: f64,
        /// \[rad\].
        rest_angle: f64,
    },
    /// `tau = -damping theta_dot` ([`HingeDamper`]).
    Damper {
        /// \[N m s/rad\].
        damping: f64,
    },
    /// `tau = -stiffness (theta - angle(t)) - damping (theta_dot - angle'(t))`
    /// ([`HingeServo`]).
    Servo {
        /// \[N m/rad\].
        stiffness: f64,
        /// \[N m s/rad\].
        damping: f64,
        /// Commanded angle \[rad\].
        angle: Waveform,
    },
    /// `tau = -(damping theta_dot + torque tanh(theta_dot / smoothing))`
    /// ([`HingeFriction`]).
    Friction {
        /// \[N m s/rad\].
        damping: f64,
        /// \[N m\].
        torque: f64,
        /// \[rad/s\].
        smoothing: f64,
    },
}

/// A hinge torque law resolved against a model: the family's law struct,
/// in the hot enum as [`Law::Hinge`].
#[derive(Debug, Clone, PartialEq)]
pub struct HingeLaw {
    /// The hinge (its index and its bodies' heading indices).
    pub hinge: HingeRef,
    /// The torque law.
    pub torque: HingeTorque,
}

impl HingeLaw {
    /// The values at time `t` \[s\] of the law's waveforms: a motor's
    /// torque \[N m\], a servo's target angle \[rad\] and rate \[rad/s\]
    /// (zeros for the other laws).
    #[inline(always)]
    pub fn waveforms(&self, t: f64) -> Waveforms {
        match &self.torque {
            HingeTorque::Motor(w) => [w.eval(t), 0.0, 0.0],
            HingeTorque::Servo { angle, .. } => angle.eval3(t),
            HingeTorque::Spring { .. } | HingeTorque::Damper { .. } | HingeTorque::Friction { .. } => [0.0; 3],
        }
    }

    /// The waveforms' values at `t` \[s\] with each waveform's numbers
    /// moved toward `other`'s to first order ([`super::waveform::Waveform::eval3_toward`]):
    /// the forward sensitivities' right-hand side at `p +- h`
    /// ([`crate::sensitivity`]).
    pub fn waveforms_toward(&self, other: &Self, t: f64) -> Waveforms {
        match (&self.torque, &other.torque) {
            (HingeTorque::Motor(a), HingeTorque::Motor(b)) => [a.eval3_toward(b, t)[0], 0.0, 0.0],
            (HingeTorque::Servo { angle: a, .. }, HingeTorque::Servo { angle: b, .. }) => a.eval3_toward(b, t),
            _ => other.waveforms(t),
        }
    }

    /// The torque `tau` \[N m\] at `(q, qd)` (nq each) with the waveforms'
    /// values `wave` ([`HingeLaw::waveforms`]), and the hinge's rate
    /// `theta_dot = qd[a] - qd[b]` \[rad/s\]: the torque's power is `tau
    /// theta_dot`. The one evaluation of every hinge law.
    #[inline(always)]
    pub fn torque(&self, wave: &Waveforms, q: &[f64], qd: &[f64]) -> (f64, f64) {
        let rate = self.hinge.rate(qd);
        let theta = || self.hinge.angle(q);
        let tau = match &self.torque {
            HingeTorque::Motor(_) => wave[0],
            HingeTorque::Spring { stiffness, rest_angle } => -stiffness * (theta() - rest_angle),
            HingeTorque::Damper { damping } => -damping * rate,
            HingeTorque::Servo { stiffness, damping, .. } => {
                let [target, target_rate, _] = *wave;
                -stiffness * (theta() - target) - damping * (rate - target_rate)
            }
            HingeTorque::Friction { damping, torque, smoothing } => {
                -(damping * rate + torque * (rate / smoothing).tanh())
            }
        };
        (tau, rate)
    }

    /// The torque's exact slopes at `qd` (nq): `(dtau/dtheta \[N m/rad\],
    /// dtau/dtheta_dot \[N m s/rad\])` at fixed waveform values (a
    /// motor's torque and a servo's target are functions of time alone).
    /// The friction's `tanh` is smooth: its slope at rest is the linear
    /// part's, `-(damping + torque / smoothing)`.
    #[inline]
    pub fn slopes(&self, qd: &[f64]) -> (f64, f64) {
        match &self.torque {
            HingeTorque::Motor(_) => (0.0, 0.0),
            HingeTorque::Spring { stiffness, .. } => (-stiffness, 0.0),
            HingeTorque::Damper { damping } => (0.0, -damping),
            HingeTorque::Servo { stiffness, damping, .. } => (-stiffness, -damping),
            HingeTorque::Friction { damping, torque, smoothing } => {
                let th = (self.hinge.rate(qd) / smoothing).tanh();
                (0.0, -(damping + torque / smoothing * (1.0 - th * th)))
            }
        }
    }

    /// [`HingeLaw::torque`] at time `t` \[s\], its waveforms evaluated
    /// here (a motor's torque is its waveform's value: one dispatch):
    /// what the fused right-hand side calls for each hinge effect.
    #[inline(always)]
    pub fn torque_at(&self, t: f64, q: &[f64], qd: &[f64]) -> (f64, f64) {
        match &self.torque {
            HingeTorque::Motor(w) => (w.eval(t), self.hinge.rate(qd)),
            _ => self.torque(&self.waveforms(t), q, qd),
        }
    }
}

impl ForceLaw for HingeLaw {
    #[inline]
    fn apply(&self, t: f64, q: &[f64], qd: &[f64], f: &mut [f64]) -> (f64, f64) {
        self.apply_with(t, &self.waveforms(t), q, qd, f)
    }

    #[inline(always)]
    fn apply_with(&self, _t: f64, wave: &Waveforms, q: &[f64], qd: &[f64], f: &mut [f64]) -> (f64, f64) {
        let (tau, rate) = self.torque(wave, q, qd);
        f[self.hinge.a] += tau;
        if let Some(b) = self.hinge.b {
            f[b] -= tau;
        }
        (tau * rate, tau)
    }

    #[inline(always)]
    fn waveforms(&self, t: f64) -> Waveforms {
        HingeLaw::waveforms(self, t)
    }

    /// Exact ([`HingeLaw::slopes`]): the torque pair `(+tau, -tau)` on the
    /// headings `(a, b)` and `theta = q[a] - q[b]` give `s_i s_j dtau`
    /// with `s = +1` at `a`, `-1` at `b`.
    fn jacobian(&self, _t: f64, _wave: &Waveforms, q: &[f64], qd: &[f64], dq: &mut [f64], dqd: &mut [f64]) -> bool {
        let (k, c) = self.slopes(qd);
        let mut blocks = Blocks::new(q.len(), dq, dqd);
        let ends = std::iter::once((self.hinge.a, 1.0)).chain(self.hinge.b.map(|b| (b, -1.0)));
        for (i, si) in ends.clone() {
            for (j, sj) in ends.clone() {
                blocks.add(i, Var::Q(j), si * sj * k);
                blocks.add(i, Var::Qd(j), si * sj * c);
            }
        }
        true
    }

    fn coords(&self) -> Vec<usize> {
        self.hinge.coords()
    }

    fn failure(&self, _q: &[f64]) -> String {
        super::kind::NOT_A_NUMBER.into()
    }

    fn time_only(&self) -> bool {
        matches!(self.torque, HingeTorque::Motor(_))
    }

    fn periodicity(&self) -> Option<Periodicity> {
        Some(match &self.torque {
            HingeTorque::Motor(w) | HingeTorque::Servo { angle: w, .. } => w.periodicity(),
            _ => Periodicity::Constant,
        })
    }

    fn span(&self) -> (f64, f64) {
        match &self.torque {
            HingeTorque::Motor(w) | HingeTorque::Servo { angle: w, .. } => w.span(),
            _ => (f64::NEG_INFINITY, f64::INFINITY),
        }
    }

    fn forcing_omega(&self) -> f64 {
        match &self.torque {
            HingeTorque::Motor(w) | HingeTorque::Servo { angle: w, .. } => w.max_omega(),
            _ => 0.0,
        }
    }

    fn time_scale(&self, mass: &[f64]) -> Option<TimeScale> {
        let m = TimeScale::smallest_mass(mass, self.hinge.coords());
        match &self.torque {
            HingeTorque::Spring { stiffness, .. } => TimeScale::shorter(None, m, "stiffness", *stiffness, true),
            HingeTorque::Damper { damping } => TimeScale::shorter(None, m, "damping", *damping, false),
            HingeTorque::Servo { stiffness, damping, .. } => {
                let best = TimeScale::shorter(None, m, "stiffness", *stiffness, true);
                TimeScale::shorter(best, m, "damping", *damping, false)
            }
            HingeTorque::Friction { damping, torque, smoothing } => {
                // near rest the Coulomb part is a damping torque / smoothing
                let best = TimeScale::shorter(None, m, "damping", *damping, false);
                let coulomb = TimeScale::shorter(None, m, "smoothing", torque / smoothing, false)
                    .map(|ts| TimeScale { value: *smoothing, ..ts });
                [best, coulomb].into_iter().flatten().reduce(|a, b| if b.seconds < a.seconds { b } else { a })
            }
            HingeTorque::Motor(_) => None,
        }
    }

    fn into_law(self) -> Law {
        Law::Hinge(self)
    }
}

/// The hinge law `torque` at the hinge called `name` (key `hinge`).
fn at_hinge(cx: &EffectContext<'_>, name: &str, torque: HingeTorque) -> Result<HingeLaw, SpecError> {
    Ok(HingeLaw { hinge: cx.hinge("hinge", name)?, torque })
}

impl EffectKind for HingeMotor {
    type Law = HingeLaw;
    const VALUE_PREFIX: &'static str = "tau";
    fn check(&self, cx: &CheckContext<'_>) -> Result<(), SpecError> {
        cx.hinge("hinge", &self.hinge)?;
        wave("torque", &self.torque)
    }
    fn resolve(&self, cx: &EffectContext<'_>) -> Result<HingeLaw, SpecError> {
        at_hinge(cx, &self.hinge, HingeTorque::Motor(self.torque.clone()))
    }
}

impl Reference for HingeMotor {
    const KEYS: &'static str = "`hinge`, `torque` (waveform) [N m]";
    const LAW: &'static str = "`tau = torque(t)`";
}

impl EffectKind for HingeSpring {
    type Law = HingeLaw;
    const VALUE_PREFIX: &'static str = "tau";
    fn check(&self, cx: &CheckContext<'_>) -> Result<(), SpecError> {
        cx.hinge("hinge", &self.hinge)?;
        finite("stiffness", self.stiffness)?;
        angle("rest_angle", self.rest_angle)
    }
    fn resolve(&self, cx: &EffectContext<'_>) -> Result<HingeLaw, SpecError> {
        let (stiffness, rest_angle) = (self.stiffness, self.rest_angle);
        at_hinge(cx, &self.hinge, HingeTorque::Spring { stiffness, rest_angle })
    }
}

impl Reference for HingeSpring {
    const KEYS: &'static str = "`hinge`, `stiffness` [N m/rad], `rest_angle` [rad] (0)";
    const LAW: &'static str = "`tau = -stiffness (theta - rest_angle)`";
}

impl EffectKind for HingeDamper {
    type Law = HingeLaw;
    const VALUE_PREFIX: &'static str = "tau";
    fn check(&self, cx: &CheckContext<'_>) -> Result<(), SpecError> {
        cx.hinge("hinge", &self.hinge)?;
        non_negative("damping", self.damping)
    }
    fn resolve(&self, cx: &EffectContext<'_>) -> Result<HingeLaw, SpecError> {
        at_hinge(cx, &self.hinge, HingeTorque::Damper { damping: self.damping })
    }
}

impl Reference for HingeDamper {
    const KEYS: &'static str = "`hinge`, `damping` [N m s/rad]";
    const LAW: &'static str = "`tau = -damping theta_dot`";
}

impl EffectKind for HingeServo {
    type Law = HingeLaw;
    const VALUE_PREFIX: &'static str = "tau";
    fn check(&self, cx: &CheckContext<'_>) -> Result<(), SpecError> {
        cx.hinge("hinge", &self.hinge)?;
        finite("stiffness", self.stiffness)?;
        non_negative("damping", self.damping)?;
        wave("angle", &self.angle)
    }
    fn resolve(&self, cx: &EffectContext<'_>) -> Result<HingeLaw, SpecError> {
        let (stiffness, damping, angle) = (self.stiffness, self.damping, self.angle.clone());
        at_hinge(cx, &self.hinge, HingeTorque::Servo { stiffness, damping, angle })
    }
}

impl Reference for HingeServo {
    const KEYS: &'static str = "`hinge`, `stiffness` [N m/rad], `damping` [N m s/rad] (0), `angle` (waveform) [rad]";
    const LAW: &'static str = "`tau = -stiffness (theta - angle(t)) - damping (theta_dot - angle'(t))`: a position servo (PD controller) tracking `angle(t)`";
}

impl EffectKind for HingeFriction {
    type Law = HingeLaw;
    const VALUE_PREFIX: &'static str = "tau";
    fn check(&self, cx: &CheckContext<'_>) -> Result<(), SpecError> {
        cx.hinge("hinge", &self.hinge)?;
        non_negative("damping", self.damping)?;
        non_negative("torque", self.torque)?;
        positive("smoothing", self.smoothing, "rate [rad/s]")
    }
    fn resolve(&self, cx: &EffectContext<'_>) -> Result<HingeLaw, SpecError> {
        let (damping, torque, smoothing) = (self.damping, self.torque, self.smoothing);
        at_hinge(cx, &self.hinge, HingeTorque::Friction { damping, torque, smoothing })
    }
}

impl Reference for HingeFriction {
    const KEYS: &'static str = "`hinge`, `damping` [N m s/rad] (0), `torque` [N m], `smoothing` [rad/s]";
    const LAW: &'static str = "`tau = -(damping theta_dot + torque tanh(theta_dot / smoothing))`: Coulomb-viscous friction in a bearing, smooth at rest (no stiction); dissipates, its work `W_<name>` <= 0";
}
