//! A force law of your own: a feedback steering controller for the
//! EzyRoller, used from a scene file (`kind = "steering"`) and from Rust.
//!
//! The controller is a PD law at a hinge: with the hinge angle
//! `theta = phi_a - phi_b` \[rad\] and its rate `theta_dot` \[rad/s\],
//!
//! ```text
//! tau = -k (theta - theta_ref(t)) - c theta_dot,   theta_ref(t) = offset + amplitude sin(omega t)
//! ```
//!
//! acting `+tau` on the hinge's first body and `-tau` on its second (the
//! sign convention of ezy's hinge effects); its power is `tau theta_dot`.
//! Swinging the steering fork this way drives the EzyRoller forward, as
//! the hinge motor of ezy's `drive` scene does, but here the torque
//! follows the state.
//!
//! Three pieces make a law of your own:
//! 1. [`Steering`]: the fields of its `[effects.NAME]` table (serde),
//! 2. [`SteeringLaw`]: the resolved law the right-hand side calls
//!    ([`ForceLaw`]),
//! 3. `impl EffectKind for Steering`: how the fields resolve against the
//!    model (names to indices, numbers checked),
//!
//! and one line registers it: `App::new().effect::<Steering>("steering")`.

use ezy::effects::{EffectContext, EffectKind, ForceLaw, HingeRef, SpecError};
use ezy::serde::{Deserialize, Serialize};

/// The fields of a `steering` effect as a scene file writes them.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(crate = "ezy::serde", deny_unknown_fields)]
pub struct Steering {
    /// The hinge it acts at.
    pub hinge: String,
    /// Stiffness `k` \[N m/rad\], zero or positive.
    pub k: f64,
    /// Damping `c` \[N m s/rad\], zero or positive.
    pub c: f64,
    /// Mean of the reference angle \[rad\].
    #[serde(default)]
    pub offset: f64,
    /// Amplitude of the reference angle \[rad\].
    pub amplitude: f64,
    /// Angular frequency of the reference angle \[rad/s\].
    pub omega: f64,
}

/// The steering law resolved against a model: the hinge and the gains.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SteeringLaw {
    /// The hinge (its bodies' heading indices in `q`).
    pub hinge: HingeRef,
    /// \[N m/rad\].
    pub k: f64,
    /// \[N m s/rad\].
    pub c: f64,
    /// \[rad\].
    pub offset: f64,
    /// \[rad\].
    pub amplitude: f64,
    /// \[rad/s\].
    pub omega: f64,
}

impl SteeringLaw {
    /// The torque `tau` \[N m\] at `(t, q, qd)`.
    pub fn torque(&self, t: f64, q: &[f64], qd: &[f64]) -> f64 {
        let (theta, rate) = (self.hinge.angle(q), self.hinge.rate(qd));
        let reference = self.offset + self.amplitude * (self.omega * t).sin();
        -self.k * (theta - reference) - self.c * rate
    }
}

impl ForceLaw for SteeringLaw {
    fn apply(&self, t: f64, q: &[f64], qd: &[f64], f: &mut [f64]) -> (f64, f64) {
        let tau = self.torque(t, q, qd);
        (self.hinge.add_torque(tau, qd, f), tau)
    }

    fn coords(&self) -> Vec<usize> {
        self.hinge.coords()
    }
}

impl EffectKind for Steering {
    type Law = SteeringLaw;
    /// Its value column is the torque, `tau_<name>` \[N m\].
    const VALUE_PREFIX: &'static str = "tau";

    fn resolve(&self, cx: &EffectContext<'_>) -> Result<SteeringLaw, SpecError> {
        let hinge = cx.hinge("hinge", &self.hinge)?;
        for (field, v) in [("k", self.k), ("c", self.c)] {
            SpecError::check(v.is_finite() && v >= 0.0, field, || {
                format!("{field} = {v} must be zero or positive (a restoring, dissipative controller)")
            })?;
        }
        for (field, v) in [("offset", self.offset), ("amplitude", self.amplitude), ("omega", self.omega)] {
            SpecError::check(v.is_finite(), field, || format!("{field} = {v} must be finite"))?;
        }
        let Steering { k, c, offset, amplitude, omega, .. } = *self;
        Ok(SteeringLaw { hinge, k, c, offset, amplitude, omega })
    }
}

/// The application: ezy's built-in vehicles and scenes, the effect kind
/// `steering`, and the scene `steer` (the default of `run`), embedded so
/// the program runs from any directory.
pub fn app() -> ezy::App {
    ezy::App::new()
        .effect::<Steering>("steering")
        .scene("scenes/steer.toml", include_str!("../scenes/steer.toml"))
        .default_scene("steer")
}

/// The `steer` scene built in Rust, no scene file: the EzyRoller, the
/// controller as a closure at the hinge B (the same law as [`Steering`]
/// with `k`, `c` and the reference `-pi + 0.5 sin(pi t)`), the same
/// initial values and settings (DOP853 at 1e-11, 10 s, output every
/// 0.01 s).
///
/// # Errors
/// An [`ezy_core::SimError`](ezy::ezy_core::SimError) from building the problem.
pub fn steer_in_rust(k: f64, c: f64) -> Result<ezy::Problem<ezy::models::EzyRoller>, ezy::ezy_core::SimError> {
    use std::f64::consts::PI;
    let model = ezy::models::EzyRoller::default();
    let info = ezy::Model::info(&model);
    let phi = |name: &str| info.coords.iter().position(|c| *c == name).expect("the EzyRoller's heading");
    let (a, b) = (phi("phi1"), phi("phi2"));
    ezy::Problem::new(model)
        .controller("steer", vec![a, b], move |t, q, qd, f| {
            let theta = q[a] - q[b];
            let rate = qd[a] - qd[b];
            let tau = -k * (theta - (-PI + 0.5 * (PI * t).sin())) - c * rate;
            f[a] += tau;
            f[b] -= tau;
            tau
        })?
        .q("x1", 0.0)?
        .q("y1", 0.0)?
        .q("phi1", 0.0)?
        .q("phi2", PI)?
        .qd("x1", 0.0)?
        .qd("phi1", 0.0)
        .map(|p| {
            p.t_end(10.0)
                .method(ezy::ezy_core::Method::Dop853)
                .tolerances(1e-11, 1e-11)
                .projection(ezy::ezy_core::ProjectionKind::MassWeighted)
                .every(0.01)
        })
}
