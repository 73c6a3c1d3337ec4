//! The scene document: the serde types a scene file reads into, one per
//! table ([`Scene`] and its sections), with their defaults. Reading them
//! from text with located errors is [`crate::file`](mod@crate::file); the figures' types
//! are in [`crate::view`], the output groups in [`crate::columns`], the
//! effects' tables in [`crate::kinds`].
//!
//! A scene is a small TOML file (the guide's "Scenes and effects" chapter
//! documents the format); the built-in scenes are files in
//! `models/scenes/`.

use std::fmt;

use serde::de::{self, MapAccess, Visitor};
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use ezy_core::settings::Method;
use ezy_core::settings::ProjectionKind;

use crate::kinds::SceneEffect;
use crate::view::{DEFAULT_DPI, FigureFormat, FigureSpec};

/// An initial value: a number (SI units of the coordinate) or the name of
/// a model parameter whose value it takes.
#[derive(Debug, Clone, PartialEq)]
pub enum InitValue {
    /// A number \[m\], \[rad\], \[m/s\] or \[rad/s\].
    Num(f64),
    /// The current value of the named model parameter.
    Param(String),
}

impl Serialize for InitValue {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Self::Num(v) => s.serialize_f64(*v),
            Self::Param(p) => s.serialize_str(p),
        }
    }
}

impl<'de> Deserialize<'de> for InitValue {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl Visitor<'_> for V {
            type Value = InitValue;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number or the name of a model parameter")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<InitValue, E> {
                Ok(InitValue::Num(v))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<InitValue, E> {
                Ok(InitValue::Num(v as f64))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<InitValue, E> {
                Ok(InitValue::Num(v as f64))
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<InitValue, E> {
                Ok(InitValue::Param(v.to_string()))
            }
        }
        d.deserialize_any(V)
    }
}

/// A number inside an effect or a drive that a scene parameter gives: the
/// file wrote the parameter's name in the number's place (`amplitude =
/// "M0"`), and [`Scene::set`] of that name changes it.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub struct Binding {
    /// Key path of the number from the file's root, array entries by index
    /// (`["effects", "motor", "torque", "cos", "amplitude"]`).
    pub path: Vec<String>,
    /// Name of the scene parameter (a key of `[scene_params]`).
    pub param: String,
}

/// A list of named items kept in file order, written as a TOML table
/// (`[effects.motor]`, `q = { x1 = 0.0, ... }`).
mod named_list {
    use super::*;

    pub fn serialize<S: Serializer, T: Serialize>(items: &[(String, T)], s: S) -> Result<S::Ok, S::Error> {
        s.collect_map(items.iter().map(|(k, v)| (k, v)))
    }

    pub fn deserialize<'de, D: Deserializer<'de>, T: Deserialize<'de>>(d: D) -> Result<Vec<(String, T)>, D::Error> {
        struct V<T>(std::marker::PhantomData<T>);
        impl<'de, T: Deserialize<'de>> Visitor<'de> for V<T> {
            type Value = Vec<(String, T)>;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a table of named entries")
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Self::Value, A::Error> {
                let mut out = Vec::new();
                while let Some((k, v)) = map.next_entry::<String, T>()? {
                    out.push((k, v));
                }
                Ok(out)
            }
        }
        d.deserialize_map(V(std::marker::PhantomData))
    }
}

/// Given coordinates and velocities; the rest follow from the constraints
/// (the consistent initial state of docs/physics.md §7).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Initial {
    /// Given coordinates by name, or hinge angles `theta_<hinge>` \[rad\]
    /// (`phi_a - phi_b`, `phi_a` for a hinge to the ground): a closed-loop
    /// mechanism assembles from its input angle.
    #[serde(default, with = "named_list")]
    pub q: Vec<(String, InitValue)>,
    /// Given velocities by coordinate name (`x1` gives `x1d`).
    #[serde(default, with = "named_list")]
    pub qd: Vec<(String, InitValue)>,
    /// Starting values of coordinates the constraints determine: the
    /// assembly branch nearest them is taken (a four-bar's open or
    /// crossed configuration), and the run says which.
    #[serde(default, with = "named_list", skip_serializing_if = "Vec::is_empty")]
    pub guess: Vec<(String, InitValue)>,
}

fn default_dt() -> f64 {
    ezy_core::settings::DEFAULT_DT
}
fn default_tol() -> f64 {
    ezy_core::settings::DEFAULT_TOLERANCE
}
fn default_every() -> f64 {
    ezy_core::settings::DEFAULT_EVERY
}

/// Integrator settings of a scene (the CLI flags override them).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IntegratorSettings {
    /// `euler`, `rk4`, `dopri5` or `dop853`.
    #[serde(default)]
    pub method: Method,
    /// Step size of the fixed-step methods \[s\].
    #[serde(default = "default_dt")]
    pub dt: f64,
    /// Relative tolerance of the adaptive methods.
    #[serde(default = "default_tol")]
    pub rtol: f64,
    /// Absolute tolerance of the adaptive methods.
    #[serde(default = "default_tol")]
    pub atol: f64,
    /// Projection after every step: `none`, `euclidean` or `mass`.
    #[serde(default)]
    pub projection: ProjectionKind,
    /// `dae`, `reduced` or `auto` ([`ezy_core::Formulation`]).
    #[serde(default)]
    pub formulation: ezy_core::Formulation,
}

impl Default for IntegratorSettings {
    fn default() -> Self {
        Self {
            method: Method::default(),
            dt: default_dt(),
            rtol: default_tol(),
            atol: default_tol(),
            projection: ProjectionKind::default(),
            formulation: ezy_core::Formulation::default(),
        }
    }
}

/// Optional groups of output columns; `t`, the coordinates and the
/// velocities are always written. A group not listed is not computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum OutputGroup {
    /// `T` \[J\], `W` (total work) \[J\] and `W_<effect>` per effect \[J\].
    Energy,
    /// `<point>.x`, `<point>.y` \[m\] for every named point.
    Points,
    /// `<point>.vx`, `<point>.vy` \[m/s\] for every named point, from the
    /// generated point velocities.
    PointVelocities,
    /// One value per effect: `tau_<effect>` \[N m\] or `F_<effect>` \[N\].
    Effects,
    /// Constraint forces from the multipliers: `F_<hinge>.x`, `F_<hinge>.y`
    /// \[N\] (on the hinge's first body) and `F_<skate>` \[N\] (lateral, along
    /// the blade normal). Costs one KKT solve per output row.
    ConstraintForces,
    /// The accelerations `qdd`: `<coord>dd` \[m/s^2, rad/s^2\]. Costs one
    /// KKT solve per output row (shared with the constraint forces).
    Accelerations,
    /// `res_phi` = max|C(q)| \[m\] and `res_vel` = max|G(q) qd| \[m/s\].
    Residuals,
}

impl OutputGroup {
    /// Every group, in column order.
    pub const ALL: [OutputGroup; 7] = [
        Self::Energy,
        Self::Points,
        Self::PointVelocities,
        Self::Effects,
        Self::ConstraintForces,
        Self::Accelerations,
        Self::Residuals,
    ];

    /// Name as a scene file spells it.
    pub fn name(self) -> &'static str {
        match self {
            Self::Energy => "energy",
            Self::Points => "points",
            Self::PointVelocities => "point-velocities",
            Self::Effects => "effects",
            Self::ConstraintForces => "constraint-forces",
            Self::Accelerations => "accelerations",
            Self::Residuals => "residuals",
        }
    }
}

/// Output settings of a scene.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputSettings {
    /// Output interval \[s\] (rounded to whole steps for fixed-step methods;
    /// the final time is always written).
    #[serde(default = "default_every")]
    pub every: f64,
    /// Optional column groups to compute and write.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub include: Vec<OutputGroup>,
    /// File format of the figures of `ezy run` and `ezy sweep` (`"png"`,
    /// `"svg"` or `"pdf"`); the command line's `--format` wins. `ezy
    /// precision` writes PNG.
    #[serde(default, skip_serializing_if = "FigureFormat::is_png")]
    pub figure_format: FigureFormat,
    /// Resolution of PNG figures \[dots per inch\] (a figure is 10 x 6.67
    /// inches: 96 dpi gives 960 x 640 pixels); between [`crate::MIN_DPI`]
    /// and [`crate::MAX_DPI`]. The command line's `--dpi` wins.
    #[serde(default = "default_dpi", skip_serializing_if = "is_default_dpi")]
    pub dpi: f64,
}

impl Default for OutputSettings {
    fn default() -> Self {
        Self { every: default_every(), include: Vec::new(), figure_format: FigureFormat::Png, dpi: DEFAULT_DPI }
    }
}

fn default_dpi() -> f64 {
    DEFAULT_DPI
}
fn is_default_dpi(d: &f64) -> bool {
    *d == DEFAULT_DPI
}

/// The prescribed angle of a drive (a hinge whose angle follows time).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DriveSpec {
    /// The hinge angle `phi_a - phi_b` \[rad\] over time; its first and
    /// second derivatives enter the constraints (use `spline` for tables).
    pub angle: ezy_core::effects::Waveform,
}

/// A scene (such as those of docs/physics.md §10.3), as a scene file writes it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Name, e.g. `drive` (output goes to `out/<name>/`).
    pub name: String,
    /// One line: what it shows, with a sentence of physics.
    pub description: String,
    /// Registry key of the model, e.g. `ezyroller`.
    pub model: String,
    /// Duration \[s\].
    pub t_end: f64,
    /// Overrides of model parameters (SI units of each parameter).
    #[serde(default, with = "named_list", skip_serializing_if = "Vec::is_empty")]
    pub params: Vec<(String, f64)>,
    /// The scene's own named numbers (`[scene_params]`, e.g. `M0 = 2.0`),
    /// in the unit of the fields that use them; a number inside an effect
    /// or a drive may be written as the name of one (`amplitude = "M0"`).
    #[serde(default, with = "named_list", skip_serializing_if = "Vec::is_empty")]
    pub scene_params: Vec<(String, f64)>,
    /// Given initial coordinates and velocities.
    #[serde(default)]
    pub initial: Initial,
    /// Integrator settings.
    #[serde(default)]
    pub integrator: IntegratorSettings,
    /// Output interval and optional columns.
    #[serde(default)]
    pub output: OutputSettings,
    /// Applied forces by name, in order (`[effects.NAME]` tables).
    #[serde(default, with = "named_list", skip_serializing_if = "Vec::is_empty")]
    pub effects: Vec<(String, SceneEffect)>,
    /// Prescribed angles of the model's drives, by drive name
    /// (`[drives.NAME] angle = ...`); every drive of the model needs one.
    #[serde(default, with = "named_list", skip_serializing_if = "Vec::is_empty")]
    pub drives: Vec<(String, DriveSpec)>,
    /// Events by name (`[events.NAME] when = "x1" crosses = 10.0`): located
    /// on the dense output, written to `events.csv`, and the run's end
    /// for `action = "stop"` ([`ezy_core::events`]).
    #[serde(default, with = "named_list", skip_serializing_if = "Vec::is_empty")]
    pub events: Vec<(String, ezy_core::EventSpec)>,
    /// Figures to draw.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub figures: Vec<FigureSpec>,
    /// How `ezy animate` draws bodies: body name -> the points its outline
    /// joins, in order (`body1 = ["A", "B1"]`; `"cm"` is the centre of
    /// mass). A body not listed is drawn through all its points.
    #[serde(default, with = "named_list", skip_serializing_if = "Vec::is_empty")]
    pub draw: Vec<(String, Vec<String>)>,
    /// Which numbers of the effects and drives the scene parameters give,
    /// sorted by path ([`Scene::from_toml`] finds them, [`Scene::set`]
    /// keeps them, [`Scene::to_toml`] writes the names back). The numbers
    /// themselves are in `effects` and `drives`, already substituted.
    #[serde(skip)]
    pub bindings: Vec<Binding>,
    /// Where the file wrote `[params]` and `[initial]` numbers with units
    /// (`"200 g"`), kept to check their dimensions against the model; the
    /// numbers themselves are in SI.
    #[serde(skip)]
    pub units: Vec<crate::units::UnitUse>,
}
