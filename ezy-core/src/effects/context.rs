//! What a kind checks and resolves against: the model's names
//! ([`CheckContext`], for [`super::EffectKind::check`], before any model
//! is built), and with them the model's values at its parameters
//! ([`EffectContext`], for [`super::EffectKind::resolve`]); the handles
//! a law keeps of the model ([`HingeRef`], [`Blade`]); the range checks
//! the built-in kinds share, each a [`SpecError`] at the key.
//!
//! Data only: an [`EffectContext`] is made from the model's numbers
//! ([`EffectContext::from_values`]); `EffectContext::new` (with the
//! `Model` trait, a floor above) reads them from a model.

use super::waveform::Waveform;
use crate::names::{fmt_value, name_list};

use crate::model::info::{ModelInfo, NameIndex};
use crate::scalar::Scalar;
use crate::settings::{check_angle, check_magnitude};

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
    /// (for range checks in [`EffectKind::check`](super::EffectKind::check) and
    /// [`EffectKind::resolve`](super::EffectKind::resolve)).
    ///
    /// # Errors
    /// As described.
    pub fn check(ok: bool, field: &'static str, message: impl FnOnce() -> String) -> Result<(), SpecError> {
        if ok { Ok(()) } else { Err(SpecError { field, message: message() }) }
    }
}

/// The error for a name `name` under the key `field` that the model `model`
/// does not have, listing the model's names of that sort `known`; `kind`
/// says what sort (`hinge`, `skate`, `body`, `body or point`, `point or
/// body`).
pub(crate) fn unknown(field: &'static str, kind: &str, name: &str, model: &str, known: Vec<&str>) -> SpecError {
    let known = if known.is_empty() { "none".to_string() } else { name_list(known) };
    let plural = match kind {
        "body" => "bodies",
        "body or point" => "bodies and points",
        "point or body" => "points and bodies",
        "hinge" => "hinges",
        _ => "skates",
    };
    SpecError { field, message: format!("unknown {kind} `{name}` in model {model}; its {plural}: {known}") }
}

/// A number at most 1e34 in magnitude ([`check_magnitude`]).
pub(crate) fn finite(field: &'static str, v: f64) -> Result<(), SpecError> {
    check_magnitude(field, v).map_err(|message| SpecError { field, message })
}

/// An angle at most 1e6 rad ([`check_angle`]).
pub(crate) fn angle(field: &'static str, v: f64) -> Result<(), SpecError> {
    check_angle(field, v).map_err(|message| SpecError { field, message })
}

/// A coefficient of a dissipative law: zero or positive, and finite.
pub(crate) fn non_negative(field: &'static str, v: f64) -> Result<(), SpecError> {
    if v.is_finite() && v < 0.0 {
        Err(SpecError {
            field,
            message: format!("{field} = {} must be zero or positive (a dissipative law)", fmt_value(v)),
        })
    } else {
        finite(field, v)
    }
}

/// A positive rate or speed (a smoothing scale), `unit` its unit.
pub(crate) fn positive(field: &'static str, v: f64, unit: &str) -> Result<(), SpecError> {
    if v.is_finite() && v > 0.0 {
        finite(field, v)
    } else {
        Err(SpecError { field, message: format!("{field} = {v} must be a positive {unit}") })
    }
}

/// A waveform whose numbers are in range ([`Waveform::validate`]).
pub(crate) fn wave(field: &'static str, w: &Waveform) -> Result<(), SpecError> {
    w.validate().map_err(|message| SpecError { field, message })
}

/// What [`super::EffectKind::check`] checks against: the model's names
/// and the scene's parameters (a ground point's coordinates may name
/// them), with lookups that give a [`SpecError`] listing the model's
/// names.
#[derive(Debug, Clone, Copy)]
pub struct CheckContext<'a> {
    names: &'a NameIndex<'a>,
    scene_params: &'a [(String, f64)],
}

impl<'a> CheckContext<'a> {
    /// The context of the model `names` indexes, with the scene's
    /// parameters `scene_params` (name, value).
    pub fn new(names: &'a NameIndex<'a>, scene_params: &'a [(String, f64)]) -> Self {
        Self { names, scene_params }
    }

    /// The model's description.
    pub fn info(&self) -> &'a ModelInfo {
        self.names.info
    }

    /// The model's names, indexed.
    pub fn names(&self) -> &'a NameIndex<'a> {
        self.names
    }

    /// The scene's parameters (name, value).
    pub fn scene_params(&self) -> &'a [(String, f64)] {
        self.scene_params
    }

    /// The index in [`ModelInfo::hinges`] of the hinge called `name`, for
    /// the effect's key `field`.
    ///
    /// # Errors
    /// A [`SpecError`] at `field` listing the model's hinges.
    pub fn hinge(&self, field: &'static str, name: &str) -> Result<usize, SpecError> {
        let info = self.names.info;
        self.names.hinge(name).ok_or_else(|| {
            unknown(field, "hinge", name, info.name, info.hinges.iter().map(|h| h.name.as_str()).collect())
        })
    }

    /// The index in [`ModelInfo::skates`] of the skate called `name`, for
    /// the effect's key `field`.
    ///
    /// # Errors
    /// A [`SpecError`] at `field` listing the model's skates.
    pub fn skate(&self, field: &'static str, name: &str) -> Result<usize, SpecError> {
        let info = self.names.info;
        self.names.skate(name).ok_or_else(|| {
            unknown(field, "skate", name, info.name, info.skates.iter().map(|k| k.name.as_str()).collect())
        })
    }

    /// The index in [`ModelInfo::bodies`] of the body called `name`, for
    /// the effect's key `field`.
    ///
    /// # Errors
    /// A [`SpecError`] at `field` listing the model's bodies.
    pub fn body(&self, field: &'static str, name: &str) -> Result<usize, SpecError> {
        let info = self.names.info;
        self.names.body(name).ok_or_else(|| {
            unknown(field, "body", name, info.name, info.bodies.iter().map(|b| b.name.as_str()).collect())
        })
    }

    /// Whether `name` is a point or a body of the model, for the effect's
    /// key `field`; the error lists the model's points first, then its
    /// bodies.
    ///
    /// # Errors
    /// A [`SpecError`] at `field` listing the model's points and bodies.
    pub fn point_or_body(&self, field: &'static str, name: &str) -> Result<(), SpecError> {
        if self.names.point(name).is_some() || self.names.body(name).is_some() {
            return Ok(());
        }
        let info = self.names.info;
        let mut known: Vec<&str> = info.points.iter().map(|p| p.name.as_str()).collect();
        known.extend(info.bodies.iter().map(|b| b.name.as_str()));
        Err(unknown(field, "point or body", name, info.name, known))
    }

    /// As [`CheckContext::point_or_body`], the error listing the model's
    /// bodies first, then its points (where a body is the usual answer).
    ///
    /// # Errors
    /// A [`SpecError`] at `field` listing the model's bodies and points.
    pub fn body_or_point(&self, field: &'static str, name: &str) -> Result<(), SpecError> {
        if self.names.point(name).is_some() || self.names.body(name).is_some() {
            return Ok(());
        }
        let info = self.names.info;
        let mut known: Vec<&str> = info.bodies.iter().map(|b| b.name.as_str()).collect();
        known.extend(info.points.iter().map(|p| p.name.as_str()));
        Err(unknown(field, "body or point", name, info.name, known))
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
    /// The context of the model `names` indexes from its values: the
    /// body-frame point offsets `points` (2 x npoints, `[x0, y0, x1, ..]`)
    /// \[m\], the body-frame unit blade directions `blades` (2 x nskates),
    /// the mass diagonal `mass` (nq) \[kg, kg m^2\] and the parameter
    /// values `model_params` (in declaration order).
    ///
    /// # Panics
    /// If a length does not match the model's counts.
    pub fn from_values(
        names: &'a NameIndex<'a>,
        points: Vec<f64>,
        blades: Vec<f64>,
        mass: Vec<f64>,
        model_params: Vec<f64>,
    ) -> Self {
        let info = names.info;
        assert_eq!(points.len(), 2 * info.points.len(), "2 x npoints point offsets");
        assert_eq!(blades.len(), 2 * info.skates.len(), "2 x nskates blade directions");
        assert_eq!(mass.len(), info.nq(), "nq masses");
        assert_eq!(model_params.len(), info.params.len(), "a value per parameter");
        Self { names, points, blades, mass, model_params, scene_params: Vec::new() }
    }

    /// With the scene's parameters, which a ground point's coordinates may name.
    pub fn with_scene_params(mut self, scene_params: &[(String, f64)]) -> Self {
        self.scene_params = scene_params.to_vec();
        self
    }

    /// The names and scene parameters alone, what [`super::EffectKind::check`] takes.
    pub fn check_context(&self) -> CheckContext<'_> {
        CheckContext::new(self.names, &self.scene_params)
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

    /// The model's parameter values, in declaration order.
    pub fn model_params(&self) -> &[f64] {
        &self.model_params
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
        let index = self.check_context().hinge(field, name)?;
        Ok(HingeRef::of(self.names.info, index))
    }

    /// The indices of the `(x, y, phi)` of the body called `name`, for the
    /// effect's key `field`.
    ///
    /// # Errors
    /// A [`SpecError`] at `field` listing the model's bodies.
    pub fn body(&self, field: &'static str, name: &str) -> Result<[usize; 3], SpecError> {
        let b = self.check_context().body(field, name)?;
        Ok(self.names.info.bodies[b].coords)
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
        self.check_context().point_or_body(field, name)?;
        Ok((self.body(field, name)?, [0.0, 0.0]))
    }

    /// The blade of the skate called `name`, for the effect's key `field`.
    ///
    /// # Errors
    /// A [`SpecError`] at `field` listing the model's skates.
    pub fn skate(&self, field: &'static str, name: &str) -> Result<Blade, SpecError> {
        let k = self.check_context().skate(field, name)?;
        Ok(self.blade(k))
    }

    /// The blade of skate `k` of [`ModelInfo::skates`].
    pub fn blade(&self, k: usize) -> Blade {
        let info = self.names.info;
        let p = info.skates[k].point;
        Blade {
            body: info.bodies[info.points[p].body].coords,
            offset: [self.points[2 * p], self.points[2 * p + 1]],
            dir: [self.blades[2 * k], self.blades[2 * k + 1]],
        }
    }
}

/// A hinge as a force law uses it: its index in [`ModelInfo::hinges`]
/// and the indices in `q` of its bodies' headings; its angle is
/// `theta = q[a] - q[b]` \[rad\] (`q[a]` for a ground hinge).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct HingeRef {
    /// Index of the hinge in [`ModelInfo::hinges`] (where a fused
    /// right-hand side, `Model::minimal_rhs`, takes its torque).
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
    #[inline(always)]
    pub fn angle(&self, q: &[f64]) -> f64 {
        q[self.a] - self.b.map_or(0.0, |b| q[b])
    }

    /// Its rate `theta_dot` \[rad/s\], `qd` (nq).
    #[inline(always)]
    pub fn rate(&self, qd: &[f64]) -> f64 {
        self.angle(qd)
    }

    /// Adds a hinge torque `tau` \[N m\] into `f` (nq): `+tau` on the
    /// first body's heading, `-tau` on the second's (docs/physics.md §8).
    /// Returns its power `tau theta_dot` \[W\], what
    /// [`super::ForceLaw::apply`] returns for the ledger.
    #[inline(always)]
    pub fn add_torque(&self, tau: f64, qd: &[f64], f: &mut [f64]) -> f64 {
        f[self.a] += tau;
        if let Some(b) = self.b {
            f[b] -= tau;
        }
        tau * self.rate(qd)
    }

    /// The coordinates a hinge torque reads and acts on (the two
    /// headings, or one): what [`super::ForceLaw::coords`] returns for it.
    pub fn coords(&self) -> Vec<usize> {
        std::iter::once(self.a).chain(self.b).collect()
    }
}

/// A skate's blade on its body: coordinates, contact-point offset and unit
/// blade direction in the body frame (or any body point with a direction:
/// the anisotropic drag's).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Blade {
    /// Indices of the body's `(x, y, phi)` in `q`.
    pub body: [usize; 3],
    /// Contact point in the body frame \[m\].
    pub offset: [f64; 2],
    /// Unit blade direction in the body frame.
    pub dir: [f64; 2],
}

impl Blade {
    /// At `(q, qd)` (nq each): the blade's world direction `e`, the world
    /// lever arm `r` \[m\] of its point from the centre of mass and the
    /// point's world velocity `v` \[m/s\].
    #[inline(always)]
    pub fn frame(&self, q: &[f64], qd: &[f64]) -> ([f64; 2], [f64; 2], [f64; 2]) {
        let (s, c) = Scalar::sin_cos(q[self.body[2]]);
        let e = [c * self.dir[0] - s * self.dir[1], s * self.dir[0] + c * self.dir[1]];
        let r = [c * self.offset[0] - s * self.offset[1], s * self.offset[0] + c * self.offset[1]];
        let w = qd[self.body[2]];
        let v = [qd[self.body[0]] - w * r[1], qd[self.body[1]] + w * r[0]];
        (e, r, v)
    }
}
