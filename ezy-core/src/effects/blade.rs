//! Force laws along a skate's blade (one family): viscous and smoothed
//! Coulomb rolling resistance, and a driven wheel. Each kind is a spec
//! struct implementing [`EffectKind`]; all resolve to [`BladeLaw`]: the
//! blade ([`Blade`]) and the force along it ([`BladeForce`]), a signed
//! force `F` \[N\] along the blade at the contact point, `v_t` being that
//! point's velocity along the blade \[m/s\] and `F v_t` the power \[W\].

use serde::{Deserialize, Serialize};

use super::context::{Blade, CheckContext, EffectContext, SpecError, non_negative, positive, wave};
use super::jacobian::{Blocks, dot, perp};
use super::kind::{EffectKind, ForceLaw, Reference, TimeScale, Waveforms};
use super::law::Law;
use super::waveform::{Periodicity, Waveform};

/// Viscous rolling resistance at a skate (`rolling-viscous`): a force
/// `-damping v_t` along the blade, `v_t` the contact point's velocity
/// along the blade \[m/s\].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RollingViscous {
    /// Skate name.
    pub skate: String,
    /// Damping \[N s/m\].
    pub damping: f64,
}

/// Smoothed Coulomb rolling resistance at a skate (`rolling-coulomb`):
/// `-force v_t / sqrt(v_t^2 + smoothing^2)` along the blade, which tends
/// to `-force sign(v_t)` for `|v_t| >> smoothing` and is smooth (so the
/// fixed-step methods keep their order) at rest. `force` is the rolling
/// resistance coefficient times the normal load.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RollingCoulomb {
    /// Skate name.
    pub skate: String,
    /// Resistance force magnitude \[N\].
    pub force: f64,
    /// Speed below which the law is linear \[m/s\].
    pub smoothing: f64,
}

/// Driven wheel (`driven-wheel`): a force `force(t)` \[N\] along the blade
/// at a skate's contact point (a wheel driven by a motor in its hub).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DrivenWheel {
    /// Skate name.
    pub skate: String,
    /// Force along the blade \[N\] over time.
    pub force: Waveform,
}

/// Force laws along a blade, the resolved form of the blade kinds.
#[derive(Debug, Clone, PartialEq)]
pub enum BladeForce {
    /// `F = -damping v_t` ([`RollingViscous`]).
    Viscous {
        /// \[N s/m\].
        damping: f64,
    },
    /// `F = -force v_t / sqrt(v_t^2 + smoothing^2)` ([`RollingCoulomb`]).
    Coulomb {
        /// \[N\].
        force: f64,
        /// \[m/s\].
        smoothing: f64,
    },
    /// `F = w(t)` ([`DrivenWheel`]).
    Driven(Waveform),
}

/// A blade law resolved against a model: the family's law struct, in the
/// hot enum as [`Law::Blade`].
#[derive(Debug, Clone, PartialEq)]
pub struct BladeLaw {
    /// The skate's blade.
    pub blade: Blade,
    /// The force along it.
    pub force: BladeForce,
}

impl BladeLaw {
    /// The waveforms' values at `t` \[s\] with each waveform's numbers
    /// moved toward `other`'s to first order ([`super::waveform::Waveform::eval3_toward`]):
    /// the forward sensitivities' right-hand side at `p +- h`
    /// ([`crate::sensitivity`]).
    pub fn waveforms_toward(&self, other: &Self, t: f64) -> Waveforms {
        match (&self.force, &other.force) {
            (BladeForce::Driven(a), BladeForce::Driven(b)) => [a.eval3_toward(b, t)[0], 0.0, 0.0],
            _ => other.waveforms(t),
        }
    }
}

impl ForceLaw for BladeLaw {
    #[inline]
    fn apply(&self, t: f64, q: &[f64], qd: &[f64], f: &mut [f64]) -> (f64, f64) {
        self.apply_with(t, &self.waveforms(t), q, qd, f)
    }

    #[inline(always)]
    fn apply_with(&self, _t: f64, wave: &Waveforms, q: &[f64], qd: &[f64], f: &mut [f64]) -> (f64, f64) {
        let bl = &self.blade;
        let (e, r, v) = bl.frame(q, qd);
        let vt = e[0] * v[0] + e[1] * v[1];
        let force = match &self.force {
            BladeForce::Viscous { damping } => -damping * vt,
            BladeForce::Coulomb { force, smoothing } => -force * vt / vt.hypot(*smoothing),
            BladeForce::Driven(_) => wave[0],
        };
        f[bl.body[0]] += force * e[0];
        f[bl.body[1]] += force * e[1];
        f[bl.body[2]] += force * (r[0] * e[1] - r[1] * e[0]);
        (force * vt, force)
    }

    #[inline(always)]
    fn waveforms(&self, t: f64) -> Waveforms {
        match &self.force {
            BladeForce::Driven(w) => [w.eval(t), 0.0, 0.0],
            _ => [0.0; 3],
        }
    }

    /// Exact: the force `F(v_t) e` at the contact point, `v_t = e . v`,
    /// turns with the blade (`de/dphi = n`, the left normal) and varies
    /// with `v_t` by `dF/dv_t`: `-damping`, or `-force smoothing^2 /
    /// (v_t^2 + smoothing^2)^(3/2)` for the smoothed Coulomb law (smooth
    /// at rest, where it is `-force / smoothing`), or 0 for a driven wheel.
    fn jacobian(&self, _t: f64, wave: &Waveforms, q: &[f64], qd: &[f64], dq: &mut [f64], dqd: &mut [f64]) -> bool {
        let bl = &self.blade;
        let (e, r, v) = bl.frame(q, qd);
        let vt = dot(e, v);
        let (force, slope) = match &self.force {
            BladeForce::Viscous { damping } => (-damping * vt, -damping),
            BladeForce::Coulomb { force, smoothing } => {
                let h = vt.hypot(*smoothing);
                (-force * vt / h, -force * (smoothing / h) * (smoothing / h) / h)
            }
            BladeForce::Driven(_) => (wave[0], 0.0),
        };
        let n = perp(e);
        // along the heading at a fixed point velocity: dv_t = n . v
        let dn = slope * dot(n, v);
        let dphi = [dn * e[0] + force * n[0], dn * e[1] + force * n[1]];
        let dv = [[slope * e[0] * e[0], slope * e[0] * e[1]], [slope * e[1] * e[0], slope * e[1] * e[1]]];
        let w = qd[bl.body[2]];
        Blocks::new(q.len(), dq, dqd).point_force(bl.body, r, w, [force * e[0], force * e[1]], dphi, dv);
        true
    }

    fn coords(&self) -> Vec<usize> {
        self.blade.body.to_vec()
    }

    fn failure(&self, _q: &[f64]) -> String {
        super::kind::NOT_A_NUMBER.into()
    }

    fn periodicity(&self) -> Option<Periodicity> {
        Some(match &self.force {
            BladeForce::Driven(w) => w.periodicity(),
            _ => Periodicity::Constant,
        })
    }

    fn span(&self) -> (f64, f64) {
        match &self.force {
            BladeForce::Driven(w) => w.span(),
            _ => (f64::NEG_INFINITY, f64::INFINITY),
        }
    }

    fn forcing_omega(&self) -> f64 {
        match &self.force {
            BladeForce::Driven(w) => w.max_omega(),
            _ => 0.0,
        }
    }

    fn time_scale(&self, mass: &[f64]) -> Option<TimeScale> {
        match &self.force {
            BladeForce::Viscous { damping } => {
                let m = TimeScale::smallest_mass(mass, self.blade.body[..2].iter().copied());
                TimeScale::shorter(None, m, "damping", *damping, false)
            }
            _ => None,
        }
    }

    fn into_law(self) -> Law {
        Law::Blade(self)
    }
}

impl EffectKind for RollingViscous {
    type Law = BladeLaw;
    fn check(&self, cx: &CheckContext<'_>) -> Result<(), SpecError> {
        cx.skate("skate", &self.skate)?;
        non_negative("damping", self.damping)
    }
    fn resolve(&self, cx: &EffectContext<'_>) -> Result<BladeLaw, SpecError> {
        Ok(BladeLaw { blade: cx.skate("skate", &self.skate)?, force: BladeForce::Viscous { damping: self.damping } })
    }
}

impl Reference for RollingViscous {
    const KEYS: &'static str = "`skate`, `damping` [N s/m]";
    const LAW: &'static str = "`F = -damping v_t` along the blade, `v_t` the contact point's speed along it";
}

impl EffectKind for RollingCoulomb {
    type Law = BladeLaw;
    fn check(&self, cx: &CheckContext<'_>) -> Result<(), SpecError> {
        cx.skate("skate", &self.skate)?;
        non_negative("force", self.force)?;
        positive("smoothing", self.smoothing, "speed [m/s]")
    }
    fn resolve(&self, cx: &EffectContext<'_>) -> Result<BladeLaw, SpecError> {
        let force = BladeForce::Coulomb { force: self.force, smoothing: self.smoothing };
        Ok(BladeLaw { blade: cx.skate("skate", &self.skate)?, force })
    }
}

impl Reference for RollingCoulomb {
    const KEYS: &'static str = "`skate`, `force` [N], `smoothing` [m/s]";
    const LAW: &'static str = "`F = -force v_t / sqrt(v_t^2 + smoothing^2)` (smoothed Coulomb)";
}

impl EffectKind for DrivenWheel {
    type Law = BladeLaw;
    fn check(&self, cx: &CheckContext<'_>) -> Result<(), SpecError> {
        cx.skate("skate", &self.skate)?;
        wave("force", &self.force)
    }
    fn resolve(&self, cx: &EffectContext<'_>) -> Result<BladeLaw, SpecError> {
        Ok(BladeLaw { blade: cx.skate("skate", &self.skate)?, force: BladeForce::Driven(self.force.clone()) })
    }
}

impl Reference for DrivenWheel {
    const KEYS: &'static str = "`skate`, `force` (waveform) [N]";
    const LAW: &'static str = "`F = force(t)` along the blade at the contact point";
}
