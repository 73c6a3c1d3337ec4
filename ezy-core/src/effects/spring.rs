//! Translational spring-damper-actuators between two points (the TSDA of
//! multibody codes; one family, one kind: `spring-damper`). The spec
//! [`SpringDamper`] implements [`EffectKind`] and resolves to
//! [`SpringLaw`], its two ends ([`Anchor`]: a body point or a fixed
//! ground point) and its coefficients.

use num_dual::Dual64;
use serde::{Deserialize, Serialize};

use super::context::{CheckContext, EffectContext, SpecError, finite, non_negative, unknown, wave};
use super::jacobian::{Blocks, Var, dot, mat_vec, perp};
use super::kind::{EffectKind, ForceLaw, Reference, TimeScale, Waveforms};
use super::law::Law;
use super::waveform::{Periodicity, Waveform};
use crate::model::info::ModelInfo;
use crate::names::name_list;
use crate::scalar::Scalar;
use crate::settings::check_magnitude;

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}
fn is_zero_waveform(w: &Waveform) -> bool {
    *w == Waveform::Constant(0.0)
}

/// Translational spring-damper-actuator between two points
/// (`spring-damper`): with `L = |r_from - r_to|` and `e` the unit vector
/// from `to` to `from`, the tension `T = stiffness (L - rest_length) +
/// damping dL/dt + force(t)` \[N\] pulls the ends together: `-T e` on
/// `from`, `+T e` on `to`. Its power is `-T dL/dt`; its value column is
/// `T`. `from` and `to` name points or bodies (their centres of mass);
/// `to` may be a fixed ground point `"ground(x, y)"` \[m\], whose
/// coordinates are numbers or the names of model or scene parameters. A
/// length of zero stops the run (the force has no direction there).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpringDamper {
    /// A point or a body.
    pub from: String,
    /// A point, a body or `ground(x, y)`.
    pub to: String,
    /// Stiffness \[N/m\].
    pub stiffness: f64,
    /// Length of zero spring force \[m\].
    pub rest_length: f64,
    /// Damping along the line \[N s/m\].
    #[serde(default, skip_serializing_if = "is_zero")]
    pub damping: f64,
    /// Actuator force along the line \[N\] over time (positive pulls).
    #[serde(default, skip_serializing_if = "is_zero_waveform")]
    pub force: Waveform,
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
    /// world lever arm from the centre of mass \[m\], at `(q, qd)` (nq each).
    #[inline(always)]
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

    /// Adds a world force \[N\] at this end, lever arm `lever` \[m\], into
    /// `f` (nq; nothing for the ground).
    #[inline(always)]
    fn push(&self, lever: [f64; 2], force: [f64; 2], f: &mut [f64]) {
        if let Anchor::Body { body, .. } = *self {
            f[body[0]] += force[0];
            f[body[1]] += force[1];
            f[body[2]] += lever[0] * force[1] - lever[1] * force[0];
        }
    }
}

/// A spring-damper resolved against a model: the family's law struct, in
/// the hot enum as [`Law::Spring`].
#[derive(Debug, Clone, PartialEq)]
pub struct SpringLaw {
    /// `from` and `to`.
    pub ends: [Anchor; 2],
    /// \[N/m\].
    pub stiffness: f64,
    /// \[m\].
    pub rest_length: f64,
    /// \[N s/m\].
    pub damping: f64,
    /// Actuator force \[N\].
    pub force: Waveform,
}

impl SpringLaw {
    /// The waveforms' values at `t` \[s\] with each waveform's numbers
    /// moved toward `other`'s to first order ([`Waveform::eval3_toward`]):
    /// the forward sensitivities' right-hand side at `p +- h`
    /// ([`crate::sensitivity`]).
    pub fn waveforms_toward(&self, other: &Self, t: f64) -> Waveforms {
        [self.force.eval3_toward(&other.force, t)[0], 0.0, 0.0]
    }

    /// Whether [`SpringLaw::apply_toward`] can move this law's numbers
    /// toward `other`'s: each end on the same body in both (its offset
    /// may differ), or a ground point in both.
    pub fn moves_toward(&self, other: &Self) -> bool {
        self.ends.iter().zip(&other.ends).all(|(a, b)| match (a, b) {
            (Anchor::Body { body, .. }, Anchor::Body { body: other, .. }) => body == other,
            (Anchor::Ground(_), Anchor::Ground(_)) => true,
            _ => false,
        })
    }

    /// The derivative of the law's generalized force at `(q, qd)` (nq
    /// each) as its numbers move from this law's toward `other`'s (the
    /// same effect in a problem at a nearby parameter value): with
    /// `theta(s) = theta + s (theta_other - theta)` for the ends' body
    /// offsets and ground points, the stiffness, the rest length, the
    /// damping and the added force's value (`wave` this law's waveforms'
    /// values, `toward` the other's, [`SpringLaw::waveforms_toward`]),
    /// adds `dF/ds` at `s = 0` into `f` (nq) and returns `d(power)/ds`.
    /// Exact (forward-mode dual numbers through the law): the forward
    /// sensitivities' `dF/dp` as `sum w_k dF/ds_k` over their stencil
    /// ([`crate::sensitivity`]), where a difference of the forces
    /// themselves errs by `stiffness h^2` times the geometry's third
    /// derivative, across the line as well as along it (a stiff coupler:
    /// 8e-7 of `ezy sensitivity four-bar-stiff --wrt a` over 10 ms).
    /// Only for ends that [`SpringLaw::moves_toward`] `other`'s (a
    /// caller's check); a length of 0 gives NaN.
    pub fn apply_toward(
        &self,
        other: &Self,
        (wave, toward): (&Waveforms, &Waveforms),
        q: &[f64],
        qd: &[f64],
        f: &mut [f64],
    ) -> f64 {
        let lift = |a: f64, b: f64| Dual64::new(a, b - a);
        let zero = Dual64::from(0.0);
        // each end's world position, velocity and lever arm, and its body
        let end = |a: &Anchor, b: &Anchor| match (*a, *b) {
            (Anchor::Body { body, offset }, Anchor::Body { offset: to, .. }) => {
                let (s, c) = Scalar::sin_cos(q[body[2]]);
                let (ox, oy) = (lift(offset[0], to[0]), lift(offset[1], to[1]));
                let r = [ox * c - oy * s, ox * s + oy * c];
                let w = qd[body[2]];
                let position = [r[0] + q[body[0]], r[1] + q[body[1]]];
                let velocity = [r[1] * (-w) + qd[body[0]], r[0] * w + qd[body[1]]];
                (position, velocity, r, Some(body))
            }
            (Anchor::Ground(p), Anchor::Ground(to)) => {
                ([lift(p[0], to[0]), lift(p[1], to[1])], [zero, zero], [zero, zero], None)
            }
            _ => ([Dual64::from(f64::NAN); 2], [zero, zero], [zero, zero], None),
        };
        let (ra, va, la, ba) = end(&self.ends[0], &other.ends[0]);
        let (rb, vb, lb, bb) = end(&self.ends[1], &other.ends[1]);
        let d = [ra[0] - rb[0], ra[1] - rb[1]];
        let len = (d[0] * d[0] + d[1] * d[1]).sqrt();
        if len.re.is_nan() || len.re <= 0.0 {
            return f64::NAN;
        }
        let e = [d[0] / len, d[1] / len];
        let rate = e[0] * (va[0] - vb[0]) + e[1] * (va[1] - vb[1]);
        let (k, l0) = (lift(self.stiffness, other.stiffness), lift(self.rest_length, other.rest_length));
        let c = lift(self.damping, other.damping);
        let tension = k * (len - l0) + c * rate + lift(wave[0], toward[0]);
        for (body, lever, sign) in [(ba, la, -1.0), (bb, lb, 1.0)] {
            if let Some(body) = body {
                let force = [tension * e[0] * sign, tension * e[1] * sign];
                f[body[0]] += force[0].eps;
                f[body[1]] += force[1].eps;
                f[body[2]] += (lever[0] * force[1] - lever[1] * force[0]).eps;
            }
        }
        (-(tension * rate)).eps
    }

    /// The world positions of the two ends at `q` (nq) \[m\], each with
    /// whether it is a fixed ground point (what `ezy animate` draws as a
    /// zig-zag).
    pub fn ends_at(&self, q: &[f64]) -> [([f64; 2], bool); 2] {
        let qd = vec![0.0; q.len()];
        self.ends.each_ref().map(|e| (e.state(q, &qd).0, matches!(e, Anchor::Ground(_))))
    }
}

impl ForceLaw for SpringLaw {
    #[inline]
    fn apply(&self, t: f64, q: &[f64], qd: &[f64], f: &mut [f64]) -> (f64, f64) {
        self.apply_with(t, &self.waveforms(t), q, qd, f)
    }

    #[inline(always)]
    fn apply_with(&self, _t: f64, wave: &Waveforms, q: &[f64], qd: &[f64], f: &mut [f64]) -> (f64, f64) {
        let [a, b] = &self.ends;
        let (ra, va, la) = a.state(q, qd);
        let (rb, vb, lb) = b.state(q, qd);
        let d = [ra[0] - rb[0], ra[1] - rb[1]];
        let len = d[0].hypot(d[1]);
        if len.is_nan() || len <= 0.0 {
            // no direction: the right-hand side reports it (see `failure`)
            return (f64::NAN, f64::NAN);
        }
        let e = [d[0] / len, d[1] / len];
        let rate = e[0] * (va[0] - vb[0]) + e[1] * (va[1] - vb[1]);
        let tension = self.stiffness * (len - self.rest_length) + self.damping * rate + wave[0];
        a.push(la, [-tension * e[0], -tension * e[1]], f);
        b.push(lb, [tension * e[0], tension * e[1]], f);
        (-tension * rate, tension)
    }

    #[inline(always)]
    fn waveforms(&self, t: f64) -> Waveforms {
        [self.force.eval(t), 0.0, 0.0]
    }

    /// Exact away from zero length (there `false`: the force has no
    /// direction, and its evaluation reports that). With `d = r_from -
    /// r_to`, `L = |d|`, `e = d / L`, `P = I - e e^T` and the relative
    /// velocity `u`: `dL = e . dd`, `de = P dd / L`, `d(dL/dt) = (P u / L) .
    /// dd + e . du`, so the force on `from`, `-T e`, has `d/dd = -(e (k e +
    /// c P u / L)^T + T P / L)` and `d/du = -c e e^T`; `to` takes its
    /// negative, each end's lever turning with its body.
    fn jacobian(&self, _t: f64, wave: &Waveforms, q: &[f64], qd: &[f64], dq: &mut [f64], dqd: &mut [f64]) -> bool {
        let [a, b] = &self.ends;
        let (ra, va, la) = a.state(q, qd);
        let (rb, vb, lb) = b.state(q, qd);
        let d = [ra[0] - rb[0], ra[1] - rb[1]];
        let len = d[0].hypot(d[1]);
        if len.is_nan() || len <= 0.0 {
            return false;
        }
        let e = [d[0] / len, d[1] / len];
        let u = [va[0] - vb[0], va[1] - vb[1]];
        let rate = dot(e, u);
        let (k, c) = (self.stiffness, self.damping);
        let tension = k * (len - self.rest_length) + c * rate + wave[0];
        let pu = [u[0] - rate * e[0], u[1] - rate * e[1]];
        // the gradient of the tension in `d`, and the force on `from` in
        // `d` and in `u`
        let g = [k * e[0] + c * pu[0] / len, k * e[1] + c * pu[1] / len];
        let delta = |i: usize, j: usize| if i == j { 1.0 } else { 0.0 };
        let projector = |i: usize, j: usize| delta(i, j) - e[i] * e[j];
        let mdd: [[f64; 2]; 2] =
            std::array::from_fn(|i| std::array::from_fn(|j| -(e[i] * g[j] + tension * projector(i, j) / len)));
        let mdu: [[f64; 2]; 2] = std::array::from_fn(|i| std::array::from_fn(|j| -c * e[i] * e[j]));
        let force_a = [-tension * e[0], -tension * e[1]];
        // the ends on bodies: indices, lever arm, and the sign of each in
        // `d` and of the force on it
        let ends = [(a, la, 1.0), (b, lb, -1.0)].map(|(end, lever, sign)| match end {
            Anchor::Body { body, .. } => Some((*body, lever, sign)),
            Anchor::Ground(_) => None,
        });
        let mut blocks = Blocks::new(q.len(), dq, dqd);
        for &(body, lever, sign) in ends.iter().flatten() {
            let w = qd[body[2]];
            let turn = perp(lever);
            // (column, dd, du) for this end's coordinates and velocities
            let columns = [
                (Var::Q(body[0]), [1.0, 0.0], [0.0, 0.0]),
                (Var::Q(body[1]), [0.0, 1.0], [0.0, 0.0]),
                (Var::Q(body[2]), turn, [-w * lever[0], -w * lever[1]]),
                (Var::Qd(body[0]), [0.0, 0.0], [1.0, 0.0]),
                (Var::Qd(body[1]), [0.0, 0.0], [0.0, 1.0]),
                (Var::Qd(body[2]), [0.0, 0.0], turn),
            ];
            for (col, dd, du) in columns {
                let (x, y) = (mat_vec(mdd, dd), mat_vec(mdu, du));
                let dfa = [sign * (x[0] + y[0]), sign * (x[1] + y[1])];
                for &(on, lever_on, sign_on) in ends.iter().flatten() {
                    blocks.force(on, lever_on, col, [sign_on * dfa[0], sign_on * dfa[1]]);
                }
            }
        }
        for &(on, lever_on, sign_on) in ends.iter().flatten() {
            blocks.lever(on, lever_on, [sign_on * force_a[0], sign_on * force_a[1]]);
        }
        true
    }

    fn coords(&self) -> Vec<usize> {
        self.ends
            .iter()
            .flat_map(|e| match e {
                Anchor::Body { body, .. } => body.to_vec(),
                Anchor::Ground(_) => Vec::new(),
            })
            .collect()
    }

    /// A spring-damper of zero length has no direction.
    fn failure(&self, q: &[f64]) -> String {
        let [(ra, _), (rb, _)] = self.ends_at(q);
        if (ra[0] - rb[0]).hypot(ra[1] - rb[1]) == 0.0 {
            return format!(
                "has length 0 m: its ends coincide at ({}, {}), so its force has no direction",
                ra[0], ra[1]
            );
        }
        super::kind::NOT_A_NUMBER.into()
    }

    fn periodicity(&self) -> Option<Periodicity> {
        Some(self.force.periodicity())
    }

    fn span(&self) -> (f64, f64) {
        self.force.span()
    }

    fn time_scale(&self, mass: &[f64]) -> Option<TimeScale> {
        let m = TimeScale::smallest_mass(
            mass,
            self.ends.iter().filter_map(|e| match e {
                Anchor::Body { body, .. } => Some(body[0]),
                Anchor::Ground(_) => None,
            }),
        );
        let best = TimeScale::shorter(None, m, "stiffness", self.stiffness, true);
        TimeScale::shorter(best, m, "damping", self.damping, false)
    }

    fn into_law(self) -> Law {
        Law::Spring(self)
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
            if known.is_empty() { "none".to_string() } else { name_list(known) }
        ));
    };
    let what = if a.parse::<f64>().is_ok() { "the ground coordinate".to_string() } else { format!("`{a}`") };
    check_magnitude(&what, v)?;
    Ok(v)
}

impl SpringDamper {
    /// Checks the end `e` under the key `field`: a ground point's
    /// coordinates (model parameters taken as 0: only their names are
    /// checked here), or a point or body of the model.
    fn check_end(cx: &CheckContext<'_>, field: &'static str, e: &str) -> Result<(), SpecError> {
        match ground_point(e) {
            Some(args) => {
                for a in args {
                    ground_coord(a, cx.info(), cx.scene_params(), |_| 0.0)
                        .map_err(|message| SpecError { field, message })?;
                }
                Ok(())
            }
            None if cx.names().point(e).is_some() || cx.names().body(e).is_some() => Ok(()),
            None => {
                let info = cx.info();
                let mut known: Vec<&str> = info.points.iter().map(|p| p.name.as_str()).collect();
                known.extend(info.bodies.iter().map(|b| b.name.as_str()));
                Err(unknown(field, "point or body", e, info.name, known))
            }
        }
    }

    /// The end `e` under the key `field`, resolved: a ground point (a
    /// model parameter it names is checked here, at its value) or a body
    /// point.
    fn end(cx: &EffectContext<'_>, field: &'static str, e: &str) -> Result<Anchor, SpecError> {
        Ok(match ground_point(e) {
            Some([x, y]) => {
                let scene_params = cx.check_context().scene_params();
                let v = |a| {
                    ground_coord(a, cx.info(), scene_params, |i| cx.model_params()[i])
                        .map_err(|message| SpecError { field, message })
                };
                Anchor::Ground([v(x)?, v(y)?])
            }
            None => {
                let (body, offset) = cx.point(field, e)?;
                Anchor::Body { body, offset }
            }
        })
    }
}

impl EffectKind for SpringDamper {
    type Law = SpringLaw;
    fn check(&self, cx: &CheckContext<'_>) -> Result<(), SpecError> {
        let (from, to) = (&self.from, &self.to);
        if ground_point(from).is_some() {
            return Err(SpecError {
                field: "from",
                message: format!("`{from}`: `from` is a point or a body of the model; a ground point goes in `to`"),
            });
        }
        Self::check_end(cx, "from", from)?;
        Self::check_end(cx, "to", to)?;
        if from == to {
            return Err(SpecError {
                field: "to",
                message: format!("`{to}`: a spring-damper joins two different points"),
            });
        }
        finite("stiffness", self.stiffness)?;
        let rest_length = self.rest_length;
        if !(rest_length.is_finite() && rest_length >= 0.0) {
            return Err(SpecError {
                field: "rest_length",
                message: format!("rest_length = {rest_length} must be zero or positive [m]"),
            });
        }
        finite("rest_length", rest_length)?;
        non_negative("damping", self.damping)?;
        wave("force", &self.force)
    }
    fn resolve(&self, cx: &EffectContext<'_>) -> Result<SpringLaw, SpecError> {
        Ok(SpringLaw {
            ends: [Self::end(cx, "from", &self.from)?, Self::end(cx, "to", &self.to)?],
            stiffness: self.stiffness,
            rest_length: self.rest_length,
            damping: self.damping,
            force: self.force.clone(),
        })
    }
}

impl Reference for SpringDamper {
    const KEYS: &'static str = "`from` (point or body), `to` (point, body or `\"ground(x, y)\"`, the coordinates numbers or model or scene parameters), `stiffness` [N/m], `rest_length` [m], `damping` [N s/m] (0), `force` (waveform) [N] (0)";
    const LAW: &'static str = "tension `T = stiffness (L - rest_length) + damping dL/dt + force(t)`, `L = |r_from - r_to|`: `-T e` on `from`, `+T e` on `to`, `e` the unit vector from `to` to `from`; value column `F_<name>` = `T`; a length of 0 stops the run naming the time and the point";
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The law with its numbers moved by `s` toward `to`'s.
    fn between(from: &SpringLaw, to: &SpringLaw, s: f64) -> SpringLaw {
        let m = |a: f64, b: f64| a + s * (b - a);
        let end = |a: &Anchor, b: &Anchor| match (*a, *b) {
            (Anchor::Body { body, offset }, Anchor::Body { offset: o, .. }) => {
                Anchor::Body { body, offset: [m(offset[0], o[0]), m(offset[1], o[1])] }
            }
            (Anchor::Ground(p), Anchor::Ground(g)) => Anchor::Ground([m(p[0], g[0]), m(p[1], g[1])]),
            _ => unreachable!(),
        };
        SpringLaw {
            ends: [end(&from.ends[0], &to.ends[0]), end(&from.ends[1], &to.ends[1])],
            stiffness: m(from.stiffness, to.stiffness),
            rest_length: m(from.rest_length, to.rest_length),
            damping: m(from.damping, to.damping),
            force: Waveform::Constant(0.0),
        }
    }

    /// `apply_toward` against differences of the force (and power) of
    /// the laws between, in `s`, of fourth order (`s = +-1e-3, +-2e-3`:
    /// truncation about 1e-13 of the force's scale): between two bodies,
    /// and from a body to a ground point that moves, every number moved
    /// at once (a stiff spring's, 6e7 N/m).
    #[test]
    fn apply_toward_is_the_derivative_of_the_force_along_the_numbers() {
        let q = [0.04, 0.03, 0.5, 0.31, 0.15, 1.46];
        let qd = [-0.06, 0.11, 2.6, 0.06, -0.01, -0.39];
        let body = |body: [usize; 3], offset: [f64; 2]| Anchor::Body { body, offset };
        let base = |to: Anchor| SpringLaw {
            ends: [body([0, 1, 2], [0.05, 0.0]), to],
            stiffness: 6e7,
            rest_length: 0.35,
            damping: 6000.0,
            force: Waveform::Constant(0.0),
        };
        for (from, to) in [
            (body([3, 4, 5], [0.15, 0.0]), body([3, 4, 5], [0.151, -0.002])),
            (Anchor::Ground([0.4, 0.35]), Anchor::Ground([0.398, 0.351])),
        ] {
            let a = base(from);
            let mut b = base(to);
            b.ends[0] = body([0, 1, 2], [0.0503, 0.001]);
            (b.stiffness, b.rest_length, b.damping) = (6.01e7, 0.3502, 6010.0);
            assert!(a.moves_toward(&b));
            let (wave, toward) = ([0.7, 0.0, 0.0], [0.9, 0.0, 0.0]);
            let mut exact = [0.0; 6];
            let dpower = a.apply_toward(&b, (&wave, &toward), &q, &qd, &mut exact);
            let at = |s: f64| {
                let mut f = [0.0; 6];
                let w = [wave[0] + s * (toward[0] - wave[0]), 0.0, 0.0];
                let (p, _) = between(&a, &b, s).apply_with(0.0, &w, &q, &qd, &mut f);
                (f, p)
            };
            let d = 1e-3;
            let (p1, m1, p2, m2) = (at(d), at(-d), at(2.0 * d), at(-2.0 * d));
            let diff = |u: f64, v: f64, x: f64, y: f64| (8.0 * (u - v) - (x - y)) / (12.0 * d);
            let scale = exact.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for (i, got) in exact.iter().enumerate() {
                let want = diff(p1.0[i], m1.0[i], p2.0[i], m2.0[i]);
                assert!((got - want).abs() <= 1e-9 * scale, "force {i}: {got} against {want}");
            }
            let want = diff(p1.1, m1.1, p2.1, m2.1);
            assert!((dpower - want).abs() <= 1e-9 * want.abs().max(1.0), "power: {dpower} against {want}");
            // a law whose end changes body or kind is not moved
            assert!(!a.moves_toward(&base(body([0, 1, 2], [0.0, 0.0]))));
        }
    }
}
