//! Drag (one family): linear (Stokes) and quadratic (form) drag on a
//! body, and anisotropic viscous drag at a body point (the ground under a
//! snake robot). Each kind is a spec struct implementing [`EffectKind`];
//! all resolve to [`DragLaw`]. Every drag law dissipates: its work
//! `W_<name>` only falls.

use serde::{Deserialize, Serialize};

use super::context::{Blade, CheckContext, EffectContext, SpecError, non_negative};
use super::jacobian::{Blocks, Var, dot, perp};
use super::kind::{EffectKind, ForceLaw, Reference, TimeScale, Waveforms};
use super::law::Law;
use super::waveform::Periodicity;

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}
fn default_along() -> [f64; 2] {
    [1.0, 0.0]
}
fn is_default_along(a: &[f64; 2]) -> bool {
    *a == default_along()
}

/// Linear (Stokes) drag on a body (`linear-drag`): force `-c v` at the
/// centre of mass, torque `-c_rot phi_dot`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinearDrag {
    /// Body name.
    pub body: String,
    /// Translational coefficient \[N s/m\].
    pub c: f64,
    /// Rotational coefficient \[N m s/rad\].
    #[serde(default, skip_serializing_if = "is_zero")]
    pub c_rot: f64,
}

/// Quadratic (form) drag on a body (`quadratic-drag`): force `-c |v| v` at
/// the centre of mass, torque `-c_rot |phi_dot| phi_dot`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct QuadraticDrag {
    /// Body name.
    pub body: String,
    /// Translational coefficient \[N s^2/m^2\].
    pub c: f64,
    /// Rotational coefficient \[N m s^2/rad^2\].
    #[serde(default, skip_serializing_if = "is_zero")]
    pub c_rot: f64,
}

/// Anisotropic viscous drag at a point or a body's centre of mass
/// (`anisotropic-drag`): with `e` the unit direction `along` turned with
/// the body and `n` its left normal, the force is `-c_along (v . e) e -
/// c_across (v . n) n` for the point's velocity `v`. The ground contact of
/// a snake robot or a wheel that may slip sideways: `c_across >> c_along`
/// makes the body glide along `e` (a skate is the limit `c_across -> inf`,
/// a constraint instead of a force). Its value column is the force's
/// magnitude \[N\].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AnisotropicDrag {
    /// A point or a body.
    pub at: String,
    /// Direction of easy motion in the body frame (default `[1, 0]`).
    #[serde(default = "default_along", skip_serializing_if = "is_default_along")]
    pub along: [f64; 2],
    /// Coefficient along `along` \[N s/m\].
    pub c_along: f64,
    /// Coefficient across it \[N s/m\].
    pub c_across: f64,
}

/// A drag law resolved against a model: the family's law, in the hot enum
/// as [`Law::Drag`].
#[derive(Debug, Clone, PartialEq)]
pub enum DragLaw {
    /// Drag at a body's centre of mass ([`LinearDrag`], [`QuadraticDrag`]).
    Body {
        /// Indices of the body's `(x, y, phi)`.
        body: [usize; 3],
        /// Translational coefficient.
        c: f64,
        /// Rotational coefficient.
        c_rot: f64,
        /// `|v| v` instead of `v`.
        quadratic: bool,
    },
    /// Anisotropic viscous drag at a body point ([`AnisotropicDrag`]).
    Anisotropic {
        /// The point and its unit direction of easy motion (body frame).
        blade: Blade,
        /// \[N s/m\].
        c_along: f64,
        /// \[N s/m\].
        c_across: f64,
    },
}

impl ForceLaw for DragLaw {
    #[inline]
    fn apply(&self, t: f64, q: &[f64], qd: &[f64], f: &mut [f64]) -> (f64, f64) {
        self.apply_with(t, &[0.0; 3], q, qd, f)
    }

    #[inline(always)]
    fn apply_with(&self, _t: f64, _wave: &Waveforms, q: &[f64], qd: &[f64], f: &mut [f64]) -> (f64, f64) {
        match self {
            DragLaw::Anisotropic { blade: bl, c_along, c_across } => {
                let (e, r, v) = bl.frame(q, qd);
                let (vt, vn) = (e[0] * v[0] + e[1] * v[1], e[0] * v[1] - e[1] * v[0]);
                // -c_along vt e - c_across vn n, n = (-e_y, e_x)
                let force = [-c_along * vt * e[0] + c_across * vn * e[1], -c_along * vt * e[1] - c_across * vn * e[0]];
                f[bl.body[0]] += force[0];
                f[bl.body[1]] += force[1];
                f[bl.body[2]] += r[0] * force[1] - r[1] * force[0];
                (force[0] * v[0] + force[1] * v[1], force[0].hypot(force[1]))
            }
            DragLaw::Body { body, c, c_rot, quadratic } => {
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

    /// Exact. Anisotropic: `F = -K v`, `K = c_along e e^T + c_across n
    /// n^T` turning with the body (`dK/dphi = (c_along - c_across) (n e^T
    /// + e n^T)`). Quadratic: `d(-c |v| v)/dv = -c (|v| I + v v^T / |v|)`
    /// and `d(-c_rot |w| w)/dw = -2 c_rot |w|`, both 0 at rest (the limit:
    /// `|v| v` is differentiable there, its derivative 0).
    fn jacobian(&self, _t: f64, _wave: &Waveforms, q: &[f64], qd: &[f64], dq: &mut [f64], dqd: &mut [f64]) -> bool {
        let mut blocks = Blocks::new(q.len(), dq, dqd);
        match self {
            DragLaw::Anisotropic { blade: bl, c_along, c_across } => {
                let (e, r, v) = bl.frame(q, qd);
                let n = perp(e);
                let (vt, vn) = (dot(e, v), dot(n, v));
                let k = |i: usize, j: usize| c_along * e[i] * e[j] + c_across * n[i] * n[j];
                let force = [-(k(0, 0) * v[0] + k(0, 1) * v[1]), -(k(1, 0) * v[0] + k(1, 1) * v[1])];
                let dk = c_along - c_across;
                let dphi = [-dk * (n[0] * vt + e[0] * vn), -dk * (n[1] * vt + e[1] * vn)];
                let dv = [[-k(0, 0), -k(0, 1)], [-k(1, 0), -k(1, 1)]];
                blocks.point_force(bl.body, r, qd[bl.body[2]], force, dphi, dv);
            }
            DragLaw::Body { body, c, c_rot, quadratic } => {
                let v = [qd[body[0]], qd[body[1]]];
                let w = qd[body[2]];
                let (dv, dw) = if *quadratic {
                    // -c (|v| I + v v^T / |v|), 0 at rest
                    let speed = v[0].hypot(v[1]);
                    let delta = |i: usize, j: usize| if i == j { 1.0 } else { 0.0 };
                    let d = |i: usize, j: usize| {
                        if speed > 0.0 { -c * (delta(i, j) * speed + v[i] * v[j] / speed) } else { 0.0 }
                    };
                    ([[d(0, 0), d(0, 1)], [d(1, 0), d(1, 1)]], -2.0 * c_rot * w.abs())
                } else {
                    ([[-c, 0.0], [0.0, -c]], -c_rot)
                };
                for (i, row) in dv.iter().enumerate() {
                    for (j, d) in row.iter().enumerate() {
                        blocks.add(body[i], Var::Qd(body[j]), *d);
                    }
                }
                blocks.add(body[2], Var::Qd(body[2]), dw);
            }
        }
        true
    }

    fn coords(&self) -> Vec<usize> {
        match self {
            DragLaw::Body { body, .. } => body.to_vec(),
            DragLaw::Anisotropic { blade, .. } => blade.body.to_vec(),
        }
    }

    fn failure(&self, _q: &[f64]) -> String {
        super::kind::NOT_A_NUMBER.into()
    }

    fn periodicity(&self) -> Option<Periodicity> {
        Some(Periodicity::Constant)
    }

    fn time_scale(&self, mass: &[f64]) -> Option<TimeScale> {
        match self {
            DragLaw::Anisotropic { blade, c_along, c_across } => {
                let m = TimeScale::smallest_mass(mass, blade.body[..2].iter().copied());
                let best = TimeScale::shorter(None, m, "c_along", *c_along, false);
                TimeScale::shorter(best, m, "c_across", *c_across, false)
            }
            DragLaw::Body { body, c, c_rot, quadratic: false } => {
                let best =
                    TimeScale::shorter(None, TimeScale::smallest_mass(mass, body[..2].iter().copied()), "c", *c, false);
                TimeScale::shorter(best, TimeScale::smallest_mass(mass, [body[2]]), "c_rot", *c_rot, false)
            }
            DragLaw::Body { quadratic: true, .. } => None,
        }
    }

    fn into_law(self) -> Law {
        Law::Drag(self)
    }
}

/// The checks of [`LinearDrag`] and [`QuadraticDrag`].
fn check_body_drag(cx: &CheckContext<'_>, body: &str, c: f64, c_rot: f64) -> Result<(), SpecError> {
    cx.body("body", body)?;
    non_negative("c", c)?;
    non_negative("c_rot", c_rot)
}

impl EffectKind for LinearDrag {
    type Law = DragLaw;
    fn check(&self, cx: &CheckContext<'_>) -> Result<(), SpecError> {
        check_body_drag(cx, &self.body, self.c, self.c_rot)
    }
    fn resolve(&self, cx: &EffectContext<'_>) -> Result<DragLaw, SpecError> {
        Ok(DragLaw::Body { body: cx.body("body", &self.body)?, c: self.c, c_rot: self.c_rot, quadratic: false })
    }
}

impl Reference for LinearDrag {
    const KEYS: &'static str = "`body`, `c` [N s/m], `c_rot` [N m s/rad] (0)";
    const LAW: &'static str = "`F = -c v`, `tau = -c_rot phi_dot`";
}

impl EffectKind for QuadraticDrag {
    type Law = DragLaw;
    fn check(&self, cx: &CheckContext<'_>) -> Result<(), SpecError> {
        check_body_drag(cx, &self.body, self.c, self.c_rot)
    }
    fn resolve(&self, cx: &EffectContext<'_>) -> Result<DragLaw, SpecError> {
        Ok(DragLaw::Body { body: cx.body("body", &self.body)?, c: self.c, c_rot: self.c_rot, quadratic: true })
    }
}

impl Reference for QuadraticDrag {
    const KEYS: &'static str = "`body`, `c` [N s^2/m^2], `c_rot` [N m s^2/rad^2] (0)";
    const LAW: &'static str = "`F = -c |v| v`, `tau = -c_rot |phi_dot| phi_dot`";
}

impl EffectKind for AnisotropicDrag {
    type Law = DragLaw;
    fn check(&self, cx: &CheckContext<'_>) -> Result<(), SpecError> {
        cx.point_or_body("at", &self.at)?;
        let along = self.along;
        let length = along[0].hypot(along[1]);
        if !(length.is_finite() && length > 0.0) {
            return Err(SpecError {
                field: "along",
                message: format!("along = {along:?} must be a finite nonzero direction"),
            });
        }
        non_negative("c_along", self.c_along)?;
        non_negative("c_across", self.c_across)
    }
    fn resolve(&self, cx: &EffectContext<'_>) -> Result<DragLaw, SpecError> {
        let (body, offset) = cx.point("at", &self.at)?;
        let along = self.along;
        let len = along[0].hypot(along[1]);
        Ok(DragLaw::Anisotropic {
            blade: Blade { body, offset, dir: [along[0] / len, along[1] / len] },
            c_along: self.c_along,
            c_across: self.c_across,
        })
    }
}

impl Reference for AnisotropicDrag {
    const KEYS: &'static str = "`at` (point or body, or a point family `\"S[*]\"`), `along` (body-frame direction, `[1, 0]`), `c_along`, `c_across` [N s/m]";
    const LAW: &'static str = "`F = -c_along (v . e) e - c_across (v . n) n` at the point, `e` = `along` turned with the body, `n` its normal: the ground under a snake robot or a wheel that slips sideways (a skate is the limit `c_across -> inf`); value column `|F|`";
}
