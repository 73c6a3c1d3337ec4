//! Scenes: which model, which parameters, where it starts, which effects
//! act, how long, which integrator, which outputs and figures. A scene is a
//! small TOML file (the guide's "Scenes and effects" chapter documents the
//! format); the built-in scenes
//! are files in `models/scenes/`.
//!
//! Loading has two stages, each with errors that name the file, line and
//! column and the key: [`Scene::from_toml`] (syntax, types, unknown keys,
//! unknown effect kinds), then [`Scene::check`] against the model's names
//! (coordinates, parameters, hinges, skates, bodies, points, columns).

use std::fmt;
use std::path::Path;

use serde::de::{self, MapAccess, Visitor};
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use ezy_core::integrator::Method;
use ezy_core::model::{Model, ModelInfo};
use ezy_core::projection::ProjectionKind;

use crate::kinds::SceneEffect;

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
    ezy_core::simulate::DEFAULT_DT
}
fn default_tol() -> f64 {
    ezy_core::simulate::DEFAULT_TOLERANCE
}
fn default_every() -> f64 {
    ezy_core::simulate::DEFAULT_EVERY
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
    /// inches: 96 dpi gives 960 x 640 pixels); between [`MIN_DPI`] and
    /// [`MAX_DPI`]. The command line's `--dpi` wins.
    #[serde(default = "default_dpi", skip_serializing_if = "is_default_dpi")]
    pub dpi: f64,
}

impl Default for OutputSettings {
    fn default() -> Self {
        Self { every: default_every(), include: Vec::new(), figure_format: FigureFormat::Png, dpi: DEFAULT_DPI }
    }
}

/// Default resolution of PNG figures \[dots per inch\]: 1440 x 960 pixels.
pub const DEFAULT_DPI: f64 = 144.0;
/// Smallest resolution of PNG figures \[dots per inch\] (240 x 160 pixels).
pub const MIN_DPI: f64 = 24.0;
/// Largest resolution of PNG figures \[dots per inch\] (6000 x 4000 pixels).
pub const MAX_DPI: f64 = 600.0;
fn default_dpi() -> f64 {
    DEFAULT_DPI
}
fn is_default_dpi(d: &f64) -> bool {
    *d == DEFAULT_DPI
}

/// File format of figures.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FigureFormat {
    /// Anti-aliased raster image at a chosen resolution (see
    /// [`OutputSettings::dpi`]).
    #[default]
    Png,
    /// Scalable vector graphics: the figure as drawn, text as text.
    Svg,
    /// A one-page vector PDF of the SVG (text as glyph outlines).
    Pdf,
}

impl FigureFormat {
    /// Every format, in the order of [`FigureFormat::name`]'s list.
    pub const ALL: [FigureFormat; 3] = [Self::Png, Self::Svg, Self::Pdf];

    /// The format's name and file extension: `png`, `svg` or `pdf`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Png => "png",
            Self::Svg => "svg",
            Self::Pdf => "pdf",
        }
    }

    fn is_png(&self) -> bool {
        *self == Self::Png
    }

    /// `file` with its extension (`.png`, `.svg` or `.pdf`, if any) replaced
    /// by this format's: `fig3_paths.png` as SVG is `fig3_paths.svg`.
    pub fn file_name(self, file: &str) -> String {
        format!("{}.{}", figure_stem(file), self.name())
    }
}

/// `file` without a figure extension (`.png`, `.svg`, `.pdf`).
pub fn figure_stem(file: &str) -> &str {
    FigureFormat::ALL.iter().find_map(|f| file.strip_suffix(&format!(".{}", f.name()))).unwrap_or(file)
}

impl fmt::Display for FigureFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for FigureFormat {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|f| f.name() == s)
            .ok_or_else(|| format!("unknown figure format `{s}`; known: png, svg, pdf"))
    }
}

/// A column of the output table, or a quantity derived from columns. In a
/// scene file: `"x1"`, `"norm(x1d, y1d)"`, `"diff(phi2d, phi1d)"`,
/// `"from_start(T)"`, `"balance_gap(T, W)"`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "String", into = "String")]
pub enum Column {
    /// A CSV column by name.
    Named(String),
    /// `sqrt(a^2 + b^2)` of two columns (a speed from two velocity components).
    Norm(String, String),
    /// `a - b`.
    Diff(String, String),
    /// `a(t) - a(0)`.
    FromStart(String),
    /// `|a(t) - a(0) - b(t)|`: the gap of a balance such as `T - T0 = W`.
    BalanceGap(String, String),
}

impl Column {
    /// The table columns it reads.
    pub fn inputs(&self) -> Vec<&str> {
        match self {
            Self::Named(a) | Self::FromStart(a) => vec![a],
            Self::Norm(a, b) | Self::Diff(a, b) | Self::BalanceGap(a, b) => vec![a, b],
        }
    }
}

impl fmt::Display for Column {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Named(a) => write!(f, "{a}"),
            Self::Norm(a, b) => write!(f, "norm({a}, {b})"),
            Self::Diff(a, b) => write!(f, "diff({a}, {b})"),
            Self::FromStart(a) => write!(f, "from_start({a})"),
            Self::BalanceGap(a, b) => write!(f, "balance_gap({a}, {b})"),
        }
    }
}

impl From<Column> for String {
    fn from(c: Column) -> String {
        c.to_string()
    }
}

impl TryFrom<String> for Column {
    type Error = String;
    fn try_from(s: String) -> Result<Self, String> {
        s.parse()
    }
}

/// Splits `s` at the commas outside parentheses (a column's or a
/// metric's arguments: `norm(x1d, y1d), 100`).
pub fn split_outside_parentheses(s: &str) -> Vec<&str> {
    let (mut depth, mut start, mut out) = (0i32, 0, Vec::new());
    for (i, c) in s.char_indices() {
        match c {
            '(' => depth += 1,
            ')' => depth -= 1,
            ',' if depth == 0 => {
                out.push(&s[start..i]);
                start = i + 1;
            }
            _ => {}
        }
    }
    out.push(&s[start..]);
    out
}

/// Why the parentheses of `s` do not pair up, if they do not: an
/// unmatched `)` (with its position) or unclosed `(`.
pub fn unbalanced_parentheses(s: &str) -> Option<String> {
    let mut depth = 0usize;
    for (i, c) in s.chars().enumerate() {
        match c {
            '(' => depth += 1,
            ')' if depth == 0 => return Some(format!("the `)` at character {} closes no `(`", i + 1)),
            ')' => depth -= 1,
            _ => {}
        }
    }
    match depth {
        0 => None,
        1 => Some("a `(` is not closed".to_string()),
        n => Some(format!("{n} `(` are not closed")),
    }
}

impl std::str::FromStr for Column {
    type Err = String;
    /// A column name, or `FUNCTION(COLUMN, ...)` with FUNCTION one of
    /// `norm`, `diff`, `from_start`, `balance_gap` and column names as
    /// arguments (functions do not nest).
    ///
    /// # Errors
    /// The whole text and what is wrong with it: unbalanced parentheses,
    /// text after the closing one, an unknown function, a wrong number of
    /// arguments, an argument that is a function or not a name.
    fn from_str(s: &str) -> Result<Self, String> {
        let s = s.trim();
        let name_ok = |n: &str| !n.is_empty() && n.chars().all(|c| c.is_alphanumeric() || "_.-".contains(c));
        if let Some(why) = unbalanced_parentheses(s) {
            return Err(format!("`{s}`: {why}"));
        }
        let Some(open) = s.find('(') else {
            return if name_ok(s) {
                Ok(Self::Named(s.to_string()))
            } else {
                Err(format!("`{s}` is not a column name or a function of columns"))
            };
        };
        let (func, rest) = s.split_at(open);
        let func = func.trim();
        // the parenthesis that closes the first one must end the text
        let mut depth = 0usize;
        let close = rest
            .char_indices()
            .find(|&(_, c)| {
                match c {
                    '(' => depth += 1,
                    ')' => depth -= 1,
                    _ => {}
                }
                depth == 0
            })
            .map_or(rest.len(), |(i, _)| i);
        if rest[close + 1..].trim() != "" {
            return Err(format!(
                "`{s}`: `{}` follows the closing parenthesis of {func}(...); write FUNCTION(COLUMN, ...)",
                rest[close + 1..].trim()
            ));
        }
        let inner = &rest[1..close];
        let args: Vec<String> = split_outside_parentheses(inner).into_iter().map(|a| a.trim().to_string()).collect();
        let known = "known: norm, diff, from_start, balance_gap";
        if !name_ok(func) {
            return Err(format!("`{s}`: `{func}` is not a function name; {known}"));
        }
        if let Some(nested) = args.iter().find(|a| a.contains('(')) {
            return Err(format!(
                "`{s}`: the argument `{nested}` of {func} is a function; functions of columns do not nest: each argument is a column name"
            ));
        }
        if let Some(bad) = args.iter().find(|a| !name_ok(a)) {
            let what = if bad.is_empty() { "an empty argument".to_string() } else { format!("`{bad}`") };
            return Err(format!("`{s}`: {what} is not a column name (an argument of {func})"));
        }
        let want = |n: usize| {
            if args.len() == n { Ok(()) } else { Err(format!("`{s}`: {func} takes {n} column(s), got {}", args.len())) }
        };
        match func {
            "norm" => want(2).map(|_| Self::Norm(args[0].clone(), args[1].clone())),
            "diff" => want(2).map(|_| Self::Diff(args[0].clone(), args[1].clone())),
            "from_start" => want(1).map(|_| Self::FromStart(args[0].clone())),
            "balance_gap" => want(2).map(|_| Self::BalanceGap(args[0].clone(), args[1].clone())),
            other => Err(format!("`{s}`: unknown function `{other}`; {known}")),
        }
    }
}

/// One line of a line figure.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Line {
    /// Legend label, with unit.
    pub label: String,
    /// Values.
    pub y: Column,
    /// The panel it is drawn in: 1 (the upper, or only, one, labelled
    /// `y_label`) or 2 (a lower panel with its own vertical axis
    /// `y2_label` and the same horizontal axis), for quantities in
    /// different units.
    #[serde(default = "one", skip_serializing_if = "is_one")]
    pub panel: u8,
}

fn one() -> u8 {
    1
}
fn is_one(p: &u8) -> bool {
    *p == 1
}

fn default_x() -> Column {
    Column::Named("t".into())
}
fn is_t(c: &Column) -> bool {
    *c == default_x()
}
fn is_false(b: &bool) -> bool {
    !b
}

/// One figure of a scene: either paths in the plane (`paths`, equal
/// axes, start and end marked) or lines over `x` (`lines`, in one or two
/// stacked panels).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FigureSpec {
    /// File name in the output directory, e.g. `fig3_paths.png`; the
    /// extension is that of the figure format ([`FigureFormat::file_name`]).
    pub file: String,
    /// Title.
    pub title: String,
    /// Horizontal axis label with unit.
    pub x_label: String,
    /// Vertical axis label with unit.
    pub y_label: String,
    /// Paths of named points or of bodies' centres of mass (by body name).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub paths: Vec<String>,
    /// Horizontal axis of a line figure.
    #[serde(default = "default_x", skip_serializing_if = "is_t")]
    pub x: Column,
    /// Lines of a line figure.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub lines: Vec<Line>,
    /// Vertical axis label with unit of the lower panel (lines with
    /// `panel = 2`); required when there are such lines.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub y2_label: Option<String>,
    /// Logarithmic vertical axis (of both panels).
    #[serde(default, skip_serializing_if = "is_false")]
    pub log_y: bool,
    /// Output columns (such as `sliding_C`, a skate with friction that
    /// slides) whose nonzero stretches of time are shaded, in a line
    /// figure over `t`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub shade: Vec<String>,
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
}

/// A semantic error in a scene: the key path (`["effects", "motor",
/// "hinge"]`) and what is wrong.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SceneError {
    /// Path of the offending key from the file's root; array entries by index.
    pub path: Vec<String>,
    /// What is wrong and what was expected.
    pub message: String,
}

/// Largest family count a scene may set (a model of a million elements
/// needs gigabytes; larger counts are surely typos).
pub const MAX_COUNT: f64 = 1e6;

/// Longest figure file name \[bytes\]: file systems take 255, and the
/// run's temporary names add a few.
pub const MAX_FIGURE_NAME: usize = 200;

/// Largest scene file read \[bytes\]: 1 MiB. The largest built-in scene
/// is under 4 KiB; a spline of 10,000 knots fits easily.
pub const MAX_SCENE_BYTES: u64 = 1 << 20;

/// Checks the value of a family count `name` (`count N = ..;` in the model).
///
/// # Errors
/// A [`SceneError`] at `params.NAME` unless `value` is a whole number in
/// `1..=MAX_COUNT`.
pub fn check_count(name: &str, value: f64) -> Result<(), SceneError> {
    if (1.0..=MAX_COUNT).contains(&value) && value.fract() == 0.0 {
        Ok(())
    } else {
        Err(SceneError::at(
            &["params", name],
            format!(
                "{name} = {} is a count of elements: it must be a whole number from 1 to {}",
                ezy_core::fmt_value(value),
                ezy_core::fmt_value(MAX_COUNT)
            ),
        ))
    }
}

impl SceneError {
    fn at(path: &[&str], message: impl Into<String>) -> Self {
        Self { path: path.iter().map(|s| s.to_string()).collect(), message: message.into() }
    }
    /// The path written as TOML would (`effects.motor.hinge`, `figures[2].lines[0].y`).
    pub fn key(&self) -> String {
        let mut out = String::new();
        for p in &self.path {
            if p.parse::<usize>().is_ok() {
                out.push_str(&format!("[{p}]"));
            } else {
                if !out.is_empty() {
                    out.push('.');
                }
                out.push_str(p);
            }
        }
        out
    }
}

/// A scene file that cannot be used: where and why.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{}", self.render())]
pub struct SceneFileError {
    /// The file (or `<builtin NAME>`).
    pub file: String,
    /// Line, from 1 (0: the file as a whole, e.g. it cannot be read).
    pub line: usize,
    /// Column, from 1.
    pub column: usize,
    /// The key at fault, when known.
    pub key: Option<String>,
    /// What is wrong and what was expected.
    pub message: String,
    /// Further mistakes the same check found in other parts of the file
    /// ([`Scene::check_all`]), each shown on a line of its own.
    pub also: Vec<SceneFileError>,
}

impl SceneFileError {
    /// `FILE:LINE:COLUMN: `KEY`: MESSAGE`, or `FILE: MESSAGE` for the file
    /// as a whole; then each of [`SceneFileError::also`] on its own line.
    fn render(&self) -> String {
        let key = self.key.as_ref().map(|k| format!("`{k}`: ")).unwrap_or_default();
        let mut out = if self.line == 0 {
            format!("{}: {key}{}", self.file, self.message)
        } else {
            format!("{}:{}:{}: {key}{}", self.file, self.line, self.column, self.message)
        };
        for e in &self.also {
            out.push('\n');
            out.push_str(&e.render());
        }
        out
    }

    /// The first of `errors` with the others as [`SceneFileError::also`]
    /// (`None` for none).
    pub fn collect(errors: impl IntoIterator<Item = SceneFileError>) -> Option<SceneFileError> {
        let mut errors = errors.into_iter();
        let mut first = errors.next()?;
        first.also.extend(errors);
        Some(first)
    }
}

/// Line and column (from 1) of byte offset `pos` in `src`.
fn line_column(src: &str, pos: usize) -> (usize, usize) {
    let before = &src[..pos.min(src.len())];
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, column)
}

/// Byte span of the value at `path` in the TOML text `src`: the deepest
/// prefix of the path that exists (so a missing key points at its table).
fn locate(src: &str, path: &[String]) -> Option<std::ops::Range<usize>> {
    use toml::de::{DeTable, DeValue};
    let root = DeTable::parse(src).ok()?;
    let mut span = None;
    let mut table = Some(root.get_ref());
    let mut array = None;
    for p in path {
        let next = if let Some(t) = table {
            t.iter().find(|(k, _)| k.get_ref().as_ref() == p.as_str()).map(|(_, v)| v)
        } else if let (Some(a), Ok(i)) = (array, p.parse::<usize>()) {
            let a: &toml::de::DeArray<'_> = a;
            a.get(i)
        } else {
            None
        };
        let Some(v) = next else { break };
        span = Some(v.span());
        (table, array) = match v.get_ref() {
            DeValue::Table(t) => (Some(t), None),
            DeValue::Array(a) => (None, Some(a)),
            _ => (None, None),
        };
    }
    span
}

impl Scene {
    /// Parses a scene file. `file` only names it in errors.
    ///
    /// A number inside `[effects.NAME]` (except the name keys
    /// [`crate::NAME_KEYS`]) or `[drives.NAME]` may be written as
    /// the name of a scene parameter (`amplitude = "M0"` with
    /// `[scene_params] M0 = 2.0`): it takes that parameter's value, exactly
    /// as written there, and the place is recorded in [`Scene::bindings`].
    ///
    /// # Errors
    /// [`SceneFileError`] at the line and column of a syntax error, a value
    /// of the wrong type, an unknown or missing key, or an unknown effect
    /// kind (the message lists the known ones). An error inside an effect's
    /// fields is placed at the effect's `[effects.NAME]` header, with that
    /// key (serde reads an internally tagged table as a whole). A name in a
    /// number's place that is not a scene parameter, and a scene parameter
    /// that is not a number, are placed at the value itself (the message
    /// lists the scene parameters).
    pub fn from_toml(src: &str, file: &str) -> Result<Scene, SceneFileError> {
        let located = |e: toml::de::Error| {
            let start = e.span().map_or(0, |s| s.start);
            let (line, column) = line_column(src, start);
            // Inside an `[effects.NAME]` table (an internally tagged enum,
            // which serde buffers) the span is the table's header: name it.
            let rest = &src[start.min(src.len())..];
            let at_line_start = start == 0 || src[..start.min(src.len())].ends_with('\n');
            let key = rest
                .strip_prefix('[')
                .filter(|r| at_line_start && r.starts_with(|c: char| c.is_alphabetic()))
                .and_then(|r| r.split_once(']'))
                .map(|(k, _)| k.trim().to_string());
            SceneFileError {
                file: file.to_string(),
                line,
                column,
                key,
                message: e.message().trim().to_string(),
                also: Vec::new(),
            }
        };
        let mut root = toml::de::DeTable::parse(src).map_err(located)?;
        refuse_misplaced_arrays(root.get_ref(), &mut Vec::new()).map_err(|e| Self::locate_error(src, file, e))?;
        let bindings = bind_scene_params(root.get_mut()).map_err(|e| Self::locate_error(src, file, e))?;
        // the tree keeps the spans of the text, so errors are placed as before
        let mut scene = Scene::deserialize(toml::de::Deserializer::from(root)).map_err(located)?;
        scene.bindings = bindings;
        Ok(scene)
    }

    /// Parses and checks a scene file against the model `info`.
    ///
    /// # Errors
    /// As [`Scene::from_toml`] and [`Scene::check_all`], located in the
    /// file (every part's mistake, [`SceneFileError::also`]).
    pub fn load(src: &str, file: &str, info: &ModelInfo) -> Result<Scene, SceneFileError> {
        let scene = Self::from_toml(src, file)?;
        let errors = scene.check_all(info).into_iter().map(|e| Self::locate_error(src, file, e));
        match SceneFileError::collect(errors) {
            Some(e) => Err(e),
            None => Ok(scene),
        }
    }

    /// Places a [`SceneError`] in the file text.
    pub fn locate_error(src: &str, file: &str, e: SceneError) -> SceneFileError {
        let (line, column) = locate(src, &e.path).map_or((1, 1), |s| line_column(src, s.start));
        SceneFileError {
            file: file.to_string(),
            line,
            column,
            key: Some(e.key()),
            message: e.message,
            also: Vec::new(),
        }
    }

    /// Reads and parses a scene file from disk.
    ///
    /// # Errors
    /// [`SceneFileError`] (line 0) if the file cannot be read, is not a
    /// regular file (a FIFO, a device, a directory) or is larger than
    /// [`MAX_SCENE_BYTES`], else as [`Scene::from_toml`].
    pub fn read(path: &Path) -> Result<(Scene, String), SceneFileError> {
        let file = path.display().to_string();
        let error = |message: String| SceneFileError {
            file: file.clone(),
            line: 0,
            column: 0,
            key: None,
            message,
            also: Vec::new(),
        };
        // a regular file only, and at most one byte past the cap: a huge
        // file, a device or a FIFO is refused without being held in memory
        // or waited on
        let src = crate::files::read_capped_text(path, MAX_SCENE_BYTES, "the scene file").map_err(error)?;
        Ok((Self::from_toml(&src, &file)?, src))
    }

    /// Writes the scene as TOML, with the name of its scene parameter in
    /// the place of every bound number (so that [`Scene::from_toml`] gives
    /// the same scene back).
    ///
    /// # Panics
    /// Never for a scene: every field has a TOML form.
    pub fn to_toml(&self) -> String {
        if self.bindings.is_empty() {
            return toml::to_string(self).expect("a scene serializes to TOML");
        }
        let mut tree = toml::Value::try_from(self).expect("a scene serializes to TOML");
        for b in &self.bindings {
            set_path(&mut tree, &b.path, toml::Value::String(b.param.clone()))
                .expect("a binding's path leads through tables and arrays");
        }
        toml::to_string(&tree).expect("a scene serializes to TOML")
    }

    /// Whether output group `g` is asked for.
    pub fn includes(&self, g: OutputGroup) -> bool {
        self.output.include.contains(&g)
    }

    /// The output columns of this scene for a model with `info`, in order:
    /// `t`, coordinates, `<coord>d`, then the groups asked for (see
    /// [`OutputGroup`]).
    pub fn columns(&self, info: &ModelInfo) -> Vec<String> {
        let mut cols = vec!["t".to_string()];
        cols.extend(info.coords.iter().map(|c| c.to_string()));
        cols.extend(info.coords.iter().map(|c| ezy_core::dynamics::velocity_name(c)));
        for g in OutputGroup::ALL {
            if !self.includes(g) {
                continue;
            }
            match g {
                OutputGroup::Energy => {
                    cols.push("T".into());
                    cols.push("W".into());
                    cols.extend(self.effects.iter().map(|(n, _)| ezy_core::dynamics::work_name(n)));
                    cols.extend(info.drives.iter().map(|d| ezy_core::dynamics::work_name(&d.name)));
                }
                OutputGroup::Points => {
                    for p in &info.points {
                        cols.push(format!("{}.x", p.name));
                        cols.push(format!("{}.y", p.name));
                    }
                }
                OutputGroup::PointVelocities => {
                    for p in &info.points {
                        cols.push(format!("{}.vx", p.name));
                        cols.push(format!("{}.vy", p.name));
                    }
                }
                OutputGroup::Effects => {
                    for (n, e) in &self.effects {
                        cols.push(e.value_column(n));
                        // a skate with friction: its slip velocity [m/s] and mode
                        if let crate::kinds::SceneEffect::Builtin(ezy_core::EffectSpec::SkateFriction(
                            ezy_core::effects::SkateFriction { skate, .. },
                        )) = e
                        {
                            cols.push(format!("v_slip_{skate}"));
                            cols.push(format!("sliding_{skate}"));
                        }
                    }
                }
                OutputGroup::ConstraintForces => {
                    // one per row of G: forces [N], torques [N m] for the
                    // rows that lock an angle (a slider's heading, a drive)
                    let mut torque = vec![false; info.nc()];
                    for d in &info.drives {
                        torque[d.row] = true;
                    }
                    for s in info.sliders.iter().filter(|s| s.heading) {
                        torque[s.row + 1] = true;
                    }
                    for (row, name) in info.constraints.iter().enumerate() {
                        cols.push(format!("{}_{name}", if torque[row] { "tau" } else { "F" }));
                    }
                }
                OutputGroup::Accelerations => {
                    cols.extend(info.coords.iter().map(|c| format!("{c}dd")));
                }
                OutputGroup::Residuals => {
                    cols.push("res_phi".into());
                    cols.push("res_vel".into());
                }
            }
        }
        cols
    }

    /// Checks every name against the model and every number against its
    /// range, before any work.
    ///
    /// # Errors
    /// The first [`SceneError`], with the key path and the known names.
    pub fn check(&self, info: &ModelInfo) -> Result<(), SceneError> {
        match self.check_all(info).into_iter().next() {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }

    /// As [`Scene::check`], collecting the first error of each part
    /// that can be checked apart: the name, the parameters, the initial
    /// values, the settings, each effect, the drives, the output columns,
    /// each figure and each drawn body (a scene with mistakes in three
    /// parts gets three errors, in the order of the file's sections).
    pub fn check_all(&self, info: &ModelInfo) -> Vec<SceneError> {
        fn keep(errors: &mut Vec<SceneError>, r: Result<(), SceneError>) {
            errors.extend(r.err());
        }
        let mut errors = Vec::new();
        let known = |names: Vec<&str>| if names.is_empty() { "none".to_string() } else { ezy_core::name_list(names) };
        keep(
            &mut errors,
            (|| {
                if self.name.is_empty() || !self.name.chars().all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
                {
                    return Err(SceneError::at(
                        &["name"],
                        format!(
                            "scene name `{}` must be letters, digits, - and _ (it names the output directory)",
                            self.name
                        ),
                    ));
                }
                Ok(())
            })(),
        );
        let params: Vec<&str> = info.params.iter().map(|p| p.name).collect();
        keep(
            &mut errors,
            (|| {
                for (name, v) in &self.params {
                    if info.param_index(name).is_none() {
                        return Err(SceneError::at(
                            &["params", name],
                            format!(
                                "unknown parameter `{name}` in model {}; its parameters: {}",
                                info.name,
                                known(params.clone())
                            ),
                        ));
                    }
                    if !v.is_finite() {
                        return Err(SceneError::at(&["params", name], format!("{name} = {v} must be finite")));
                    }
                    if info.params[info.param_index(name).expect("known")].count {
                        check_count(name, *v)?;
                    } else {
                        ezy_core::check_magnitude(name, *v).map_err(|m| SceneError::at(&["params", name], m))?;
                    }
                }
                for (name, v) in &self.scene_params {
                    let path = ["scene_params", name.as_str()];
                    if !is_identifier(name) {
                        return Err(SceneError::at(
                            &path,
                            format!(
                                "scene parameter `{name}` must be an identifier: a letter or _, then letters, digits and _"
                            ),
                        ));
                    }
                    if info.param_index(name).is_some() {
                        return Err(SceneError::at(
                            &path,
                            format!(
                                "`{name}` is both a scene parameter and a parameter of model {}: rename the scene parameter (a model parameter is changed in [params])",
                                info.name
                            ),
                        ));
                    }
                    if !v.is_finite() {
                        return Err(SceneError::at(&path, format!("{name} = {v} must be finite")));
                    }
                    // the numbers it gives are checked where they stand, by their key;
                    // past this bound no key takes it
                    ezy_core::check_magnitude(name, *v).map_err(|m| SceneError::at(&path, m))?;
                }
                if let Some(b) = self.bindings.iter().find(|b| !self.scene_params.iter().any(|(n, _)| *n == b.param)) {
                    let names: Vec<&str> = self.scene_params.iter().map(|(n, _)| n.as_str()).collect();
                    return Err(SceneError {
                        path: b.path.clone(),
                        message: format!(
                            "`{}` is not a scene parameter; declared in [scene_params]: {}",
                            b.param,
                            known_or_none(&names)
                        ),
                    });
                }
                Ok(())
            })(),
        );
        keep(
            &mut errors,
            (|| {
                for (group, list) in [("q", &self.initial.q), ("qd", &self.initial.qd), ("guess", &self.initial.guess)]
                {
                    for (name, v) in list {
                        let known_name = match info.initial_name(name) {
                            Some(ezy_core::InitialName::HingeAngle(_)) => group == "q",
                            Some(ezy_core::InitialName::Coords(_)) => true,
                            None => false,
                        };
                        if !known_name {
                            let angles = if group == "q" {
                                format!(
                                    ", or a hinge angle `theta_<hinge>` (hinges: {})",
                                    known_or_none(&info.hinges.iter().map(|h| h.name.as_str()).collect::<Vec<_>>())
                                )
                            } else {
                                String::new()
                            };
                            return Err(SceneError::at(
                                &["initial", group, name],
                                format!(
                                    "unknown coordinate `{name}` in model {} (`stem*` names a family's coordinates){angles}; its coordinates: {}",
                                    info.name,
                                    ezy_core::name_list(&info.coords)
                                ),
                            ));
                        }
                        match v {
                            InitValue::Num(x) if !x.is_finite() => {
                                return Err(SceneError::at(
                                    &["initial", group, name],
                                    format!("{name} = {x} must be finite"),
                                ));
                            }
                            InitValue::Param(p) if info.param_index(p).is_none() => {
                                return Err(SceneError::at(
                                    &["initial", group, name],
                                    format!(
                                        "`{p}` is neither a number nor a parameter of model {}; its parameters: {}",
                                        info.name,
                                        known(params.clone())
                                    ),
                                ));
                            }
                            _ => {}
                        }
                    }
                }
                Ok(())
            })(),
        );
        let positive = |path: &[&str], v: f64, what: &str| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(SceneError::at(path, format!("{what} must be a positive number, got {}", ezy_core::fmt_value(v))))
            }
        };
        keep(
            &mut errors,
            (|| {
                positive(&["t_end"], self.t_end, "the duration [s]")?;
                positive(&["integrator", "dt"], self.integrator.dt, "the step [s]")?;
                positive(&["integrator", "rtol"], self.integrator.rtol, "the relative tolerance")?;
                positive(&["integrator", "atol"], self.integrator.atol, "the absolute tolerance")?;
                for (key, v) in [("rtol", self.integrator.rtol), ("atol", self.integrator.atol)] {
                    if v < ezy_core::simulate::MIN_TOLERANCE {
                        return Err(SceneError::at(
                            &["integrator", key],
                            format!(
                                "a tolerance below {:e} cannot be met in double precision, got {v:e}",
                                ezy_core::simulate::MIN_TOLERANCE
                            ),
                        ));
                    }
                }
                if self.integrator.rtol > ezy_core::simulate::MAX_RTOL {
                    return Err(SceneError::at(
                        &["integrator", "rtol"],
                        format!(
                            "a relative tolerance above {} asks for less than one correct digit, got {:e}",
                            ezy_core::simulate::MAX_RTOL,
                            self.integrator.rtol
                        ),
                    ));
                }
                positive(&["output", "every"], self.output.every, "the output interval [s]")?;
                if !(MIN_DPI..=MAX_DPI).contains(&self.output.dpi) {
                    return Err(SceneError::at(
                        &["output", "dpi"],
                        format!("the PNG resolution is between {MIN_DPI} and {MAX_DPI} dpi, got {}", self.output.dpi),
                    ));
                }
                Ok(())
            })(),
        );
        let names = ezy_core::model::NameIndex::new(info);
        for (name, e) in &self.effects {
            keep(
                &mut errors,
                (|| {
                    ezy_core::effects::check_effect_name(name).map_err(|m| SceneError::at(&["effects", name], m))?;
                    e.check_in(&names, &self.scene_params).map_err(|err| {
                        let path: &[&str] =
                            if err.field.is_empty() { &["effects", name] } else { &["effects", name, err.field] };
                        SceneError::at(path, err.message)
                    })?;
                    Ok(())
                })(),
            );
        }
        keep(
            &mut errors,
            (|| {
                let model_drives: std::collections::HashSet<&str> =
                    info.drives.iter().map(|d| d.name.as_str()).collect();
                let scene_drives: std::collections::HashSet<&str> =
                    self.drives.iter().map(|(n, _)| n.as_str()).collect();
                for (name, d) in &self.drives {
                    if !model_drives.contains(name.as_str()) {
                        let known: Vec<&str> = info.drives.iter().map(|d| d.name.as_str()).collect();
                        return Err(SceneError::at(
                            &["drives", name],
                            format!(
                                "unknown drive `{name}` in model {}; its drives: {}",
                                info.name,
                                known_or_none(&known)
                            ),
                        ));
                    }
                    d.angle.validate().map_err(|m| SceneError::at(&["drives", name, "angle"], m))?;
                }
                self.check_drives_cover(self.t_end)?;
                if let Some(missing) = info.drives.iter().find(|m| !scene_drives.contains(m.name.as_str())) {
                    return Err(SceneError::at(
                        &["drives"],
                        format!(
                            "model {} drives hinge `{}` by `{}`: give its angle, [drives.{}] angle = ...",
                            info.name, info.hinges[missing.hinge].name, missing.name, missing.name
                        ),
                    ));
                }
                Ok(())
            })(),
        );
        let effect_columns: Vec<(String, String)> =
            self.effects.iter().map(|(n, e)| (n.clone(), e.value_column(n))).collect();
        let effect_columns: Vec<(&str, &str)> = effect_columns.iter().map(|(n, v)| (n.as_str(), v.as_str())).collect();
        let drive_names: Vec<&str> = info.drives.iter().map(|d| d.name.as_str()).collect();
        let switchable: Vec<(&str, bool)> = self
            .effects
            .iter()
            .map(|(n, e)| (n.as_str(), matches!(e, SceneEffect::Builtin(ezy_core::EffectSpec::SkateFriction(_)))))
            .collect();
        for (name, event) in &self.events {
            keep(
                &mut errors,
                (|| {
                    ezy_core::events::check_event_name(name).map_err(|m| SceneError::at(&["events", name], m))?;
                    if !event.crosses.is_finite() {
                        return Err(SceneError::at(
                            &["events", name, "crosses"],
                            format!("the level must be a finite number, not {}", event.crosses),
                        ));
                    }
                    let quantity =
                        ezy_core::events::Quantity::resolve(&event.when, info, &effect_columns, &drive_names)
                            .map_err(|m| SceneError::at(&["events", name, "when"], m))?;
                    if let ezy_core::events::Quantity::EffectValue(k) = quantity
                        && let Some(&(effect, true)) = switchable.get(k)
                    {
                        let m = ezy_core::events::friction_force_unwatched(&event.when, effect);
                        return Err(SceneError::at(&["events", name, "when"], m));
                    }
                    event.switched(&switchable).map_err(|(key, m)| SceneError::at(&["events", name, key], m))?;
                    Ok(())
                })(),
            );
        }
        keep(
            &mut errors,
            (|| {
                let all = Scene {
                    output: OutputSettings { include: OutputGroup::ALL.to_vec(), ..self.output.clone() },
                    ..self.clone()
                };
                let all_columns = all.columns(info);
                let mut seen = std::collections::HashSet::with_capacity(all_columns.len());
                for c in &all_columns {
                    if !seen.insert(c.as_str()) {
                        let culprit = self
                            .effects
                            .iter()
                            .find(|(n, e)| c == &format!("W_{n}") || c == &e.value_column(n))
                            .map(|(n, _)| n.clone());
                        return Err(match culprit {
                            Some(n) => SceneError::at(
                                &["effects", &n],
                                format!(
                                    "effect `{n}` makes the column `{c}`, which the model's drives or rows also make: rename the effect"
                                ),
                            ),
                            None => SceneError::at(&["model"], format!("two output columns are called `{c}`")),
                        });
                    }
                }
                Ok(())
            })(),
        );
        let columns = self.columns(info);
        for (i, fig) in self.figures.iter().enumerate() {
            keep(
                &mut errors,
                (|| {
                    let i = i.to_string();
                    let stem = figure_stem(&fig.file);
                    if stem.len() == fig.file.len()
                        || stem.is_empty()
                        || fig.file.contains(['/', '\\'])
                        || fig.file.contains(char::is_control)
                    {
                        return Err(SceneError::at(
                            &["figures", &i, "file"],
                            format!(
                                "`{}` must be a file name ending in .png, .svg or .pdf, without directories or control characters",
                                fig.file.escape_debug()
                            ),
                        ));
                    }
                    // a file name longer than file systems take, hidden, the CSV's, or one
                    // another figure already writes (in any format): refused here, before any work
                    let earlier = self.figures[..i.parse::<usize>().expect("an index")]
                        .iter()
                        .any(|f| figure_stem(&f.file) == stem);
                    if fig.file.len() > MAX_FIGURE_NAME || fig.file.starts_with('.') || earlier {
                        let why = if earlier {
                            "another figure of this scene writes that file".to_string()
                        } else if fig.file.starts_with('.') {
                            "a figure file name must not start with `.`".to_string()
                        } else {
                            format!(
                                "a figure file name has at most {MAX_FIGURE_NAME} bytes, this one {}",
                                fig.file.len()
                            )
                        };
                        return Err(SceneError::at(&["figures", &i, "file"], format!("`{}`: {why}", fig.file)));
                    }
                    if fig.paths.is_empty() == fig.lines.is_empty() {
                        return Err(SceneError::at(
                            &["figures", &i],
                            "a figure has either `paths` (bodies or points) or `lines`, not both and not neither",
                        ));
                    }
                    let missing = |col: &str| -> Option<String> {
                        if columns.iter().any(|c| c == col) {
                            return None;
                        }
                        let hint = self.column_hint(info, col);
                        Some(format!("no column `{col}` in this scene's output{hint}"))
                    };
                    for (j, p) in fig.paths.iter().enumerate() {
                        let path = ["figures", &i, "paths", &j.to_string()];
                        let path: Vec<&str> = path.iter().map(|s| s.as_ref()).collect();
                        if let Some(b) = info.bodies.iter().find(|b| b.name == *p) {
                            let _ = b;
                        } else if info.point_index(p).is_some() {
                            if let Some(m) = missing(&format!("{p}.x")) {
                                return Err(SceneError::at(&path, m));
                            }
                        } else {
                            let mut names: Vec<&str> = info.bodies.iter().map(|b| b.name.as_str()).collect();
                            names.extend(info.points.iter().map(|p| p.name.as_str()));
                            return Err(SceneError::at(
                                &path,
                                format!("unknown body or point `{p}` in model {}; known: {}", info.name, known(names)),
                            ));
                        }
                    }
                    for (j, c) in fig.shade.iter().enumerate() {
                        let at = ["figures", i.as_str(), "shade", &j.to_string()];
                        if !fig.paths.is_empty() || fig.x.to_string() != "t" {
                            return Err(SceneError::at(&at, "`shade` marks stretches of time: a line figure over t"));
                        }
                        if let Some(m) = missing(c) {
                            return Err(SceneError::at(&at, m));
                        }
                    }
                    let j_x = ["figures", i.as_str(), "x"];
                    for c in fig.x.inputs() {
                        if let Some(m) = missing(c) {
                            return Err(SceneError::at(&j_x, m));
                        }
                    }
                    if !fig.lines.is_empty() && fig.lines.iter().all(|l| l.panel == 2) {
                        return Err(SceneError::at(
                            &["figures", &i, "lines"],
                            "every line is in panel 2: the upper panel (1) needs at least one line",
                        ));
                    }
                    for (j, line) in fig.lines.iter().enumerate() {
                        let j = j.to_string();
                        if !(1..=2).contains(&line.panel) {
                            return Err(SceneError::at(
                                &["figures", &i, "lines", &j, "panel"],
                                format!("panel is 1 (upper) or 2 (lower), got {}", line.panel),
                            ));
                        }
                        if line.panel == 2 && fig.y2_label.is_none() {
                            return Err(SceneError::at(
                                &["figures", &i, "lines", &j, "panel"],
                                "a line in panel 2 needs the figure's `y2_label` (the lower panel's axis label, with unit)",
                            ));
                        }
                        for c in line.y.inputs() {
                            if let Some(m) = missing(c) {
                                return Err(SceneError::at(&["figures", &i, "lines", &j, "y"], m));
                            }
                        }
                    }
                    Ok(())
                })(),
            );
        }
        for (body, outline) in &self.draw {
            keep(
                &mut errors,
                (|| {
                    let Some(b) = info.bodies.iter().position(|x| x.name == *body) else {
                        return Err(SceneError::at(
                            &["draw", body],
                            format!(
                                "unknown body `{body}` in model {}; known: {}",
                                info.name,
                                known(info.bodies.iter().map(|b| b.name.as_str()).collect())
                            ),
                        ));
                    };
                    for (j, p) in outline.iter().enumerate() {
                        let on_body = p == "cm" || info.point_index(p).is_some_and(|k| info.points[k].body == b);
                        if !on_body {
                            let names: Vec<&str> = std::iter::once("cm")
                                .chain(info.points.iter().filter(|q| q.body == b).map(|q| q.name.as_str()))
                                .collect();
                            return Err(SceneError::at(
                                &["draw", body, &j.to_string()],
                                format!("`{p}` is not a point of body {body}; its points: {}", known(names)),
                            ));
                        }
                    }
                    Ok(())
                })(),
            );
        }
        errors
    }

    /// For a column the output does not have: the group that would add it.
    fn column_hint(&self, info: &ModelInfo, col: &str) -> String {
        let all = Scene {
            output: OutputSettings { include: OutputGroup::ALL.to_vec(), ..self.output.clone() },
            ..self.clone()
        };
        for g in OutputGroup::ALL {
            let one = Scene { output: OutputSettings { include: vec![g], ..self.output.clone() }, ..self.clone() };
            if one.columns(info).iter().any(|c| c == col) && !self.includes(g) {
                return format!(" (add \"{}\" to output.include)", g.name());
            }
        }
        format!("; its columns would be: {}", ezy_core::name_list(all.columns(info)))
    }

    /// Applies a command-line override `name = value`: a scene parameter
    /// (`M0`: every number bound to it changes, see [`Scene::bindings`]), a
    /// model parameter (`m2`), or a number inside an effect or a drive,
    /// `ITEM.KEY` with the full key path (`motor.torque.cos.amplitude`) or
    /// its last key when that is unambiguous (`motor.amplitude`); a key left
    /// at its default (`gravity.g`) is set by its name; an event's level,
    /// `EVENT.crosses`. A number set by its
    /// key is no longer bound to a scene parameter. Apply it before
    /// [`Scene::expand_families`] (which bakes a bound `phase` or
    /// `phase_step` of a family's waveform into each element's phase).
    ///
    /// # Errors
    /// [`ezy_core::SimError::UnknownName`] listing the model parameters, the
    /// scene parameters and the effects' and drives' numeric keys;
    /// [`ezy_core::SimError::Setting`] for a value that is not finite;
    /// [`ezy_core::SimError::Scene`] for a name that is both a scene and a
    /// model parameter, an ambiguous key, or a binding whose number is gone.
    pub fn set(&mut self, info: &ModelInfo, name: &str, value: f64) -> Result<(), ezy_core::SimError> {
        if !value.is_finite() {
            return Err(ezy_core::SimError::Setting { name: name.into(), value, reason: "must be a finite number" });
        }
        if let Some(k) = self.scene_params.iter().position(|(n, _)| n == name) {
            if info.param_index(name).is_some() {
                return Err(ezy_core::SimError::Scene {
                    key: format!("scene_params.{name}"),
                    message: format!(
                        "`{name}` is both a scene parameter and a parameter of model {}: rename the scene parameter",
                        info.name
                    ),
                });
            }
            self.scene_params[k].1 = value;
            let bound: Vec<Vec<String>> =
                self.bindings.iter().filter(|b| b.param == name).map(|b| b.path.clone()).collect();
            for path in bound {
                self.set_bound(&path, value)?;
            }
            return Ok(());
        }
        if info.param_index(name).is_some() {
            match self.params.iter_mut().find(|(n, _)| n == name) {
                Some((_, v)) => *v = value,
                None => self.params.push((name.to_string(), value)),
            }
            return Ok(());
        }
        if let Some((item, key)) = name.split_once('.') {
            let changed = if let Some((_, spec)) = self.effects.iter_mut().find(|(n, _)| n == item) {
                set_number(&*spec, key, value, name)?.map(|(changed, leaf)| {
                    *spec = changed.inherit_kind(spec);
                    ("effects", leaf)
                })
            } else if let Some((_, spec)) = self.drives.iter_mut().find(|(n, _)| n == item) {
                set_number(&*spec, key, value, name)?.map(|(changed, leaf)| {
                    *spec = changed;
                    ("drives", leaf)
                })
            } else {
                None
            };
            // an event's level: `EVENT.crosses`
            if changed.is_none()
                && key == "crosses"
                && let Some((_, spec)) = self.events.iter_mut().find(|(n, _)| n == item)
            {
                spec.crosses = value;
                return Ok(());
            }
            if let Some((section, leaf)) = changed {
                // the number is now the one given, no longer a scene parameter's
                let mut path = vec![section.to_string(), item.to_string()];
                path.extend(leaf.split('.').map(str::to_string));
                self.bindings.retain(|b| b.path != path);
                return Ok(());
            }
        }
        let mut known: Vec<String> = info.params.iter().map(|p| p.name.to_string()).collect();
        known.extend(self.scene_params.iter().map(|(n, _)| n.clone()));
        for (n, spec) in &self.effects {
            let tree = toml::Value::try_from(spec).expect("an effect serializes");
            known.extend(numeric_leaves(&tree).into_iter().map(|l| format!("{n}.{l}")));
        }
        for (n, spec) in &self.drives {
            let tree = toml::Value::try_from(spec).expect("a drive serializes");
            known.extend(numeric_leaves(&tree).into_iter().map(|l| format!("{n}.{l}")));
        }
        known.extend(self.events.iter().map(|(n, _)| format!("{n}.crosses")));
        Err(ezy_core::SimError::UnknownName {
            kind: "parameter",
            name: name.to_string(),
            model: info.name,
            known: known.join(", "),
        })
    }

    /// The numbers of effect or drive `item`, each with its full key path
    /// (`torque.cos.amplitude`) in the order the scene gives them: what
    /// [`Scene::set`] changes as `ITEM.KEY`. `None` if the scene has no
    /// effect or drive of that name.
    pub fn numbers(&self, item: &str) -> Option<Vec<(String, f64)>> {
        let tree = if let Some((_, spec)) = self.effects.iter().find(|(n, _)| n == item) {
            toml::Value::try_from(spec).ok()?
        } else {
            let (_, spec) = self.drives.iter().find(|(n, _)| n == item)?;
            toml::Value::try_from(spec).ok()?
        };
        Some(numeric_values(&tree))
    }

    /// Sets the bound number at `path` (`effects.ITEM...` or `drives.ITEM...`).
    fn set_bound(&mut self, path: &[String], value: f64) -> Result<(), ezy_core::SimError> {
        let fail = |message: String| ezy_core::SimError::Scene {
            key: SceneError { path: path.to_vec(), message: String::new() }.key(),
            message,
        };
        let (section, item, leaf) = match path {
            [section, item, leaf @ ..] if !leaf.is_empty() => (section.as_str(), item, leaf),
            _ => return Err(fail("a scene parameter is bound to no number here".into())),
        };
        let changed =
            match section {
                "effects" => self.effects.iter_mut().find(|(n, _)| n == item).map(|(_, spec)| {
                    with_number(&*spec, leaf, value).map(|changed| *spec = changed.inherit_kind(spec))
                }),
                "drives" => self
                    .drives
                    .iter_mut()
                    .find(|(n, _)| n == item)
                    .map(|(_, spec)| with_number(&*spec, leaf, value).map(|changed| *spec = changed)),
                _ => None,
            };
        match changed {
            Some(r) => r.map_err(fail),
            None => Err(fail(format!("a scene parameter is bound to `{item}`, which the scene does not have"))),
        }
    }

    /// Checks that every prescribed angle is smooth over `[0, t_end]`: no
    /// `table` (its slope jumps at the knots), and a `spline` whose knots
    /// cover the run (outside them the angle is held, and its rate would
    /// jump to zero).
    ///
    /// # Errors
    /// [`SceneError`] at the drive's `angle`.
    pub fn check_drives_cover(&self, t_end: f64) -> Result<(), SceneError> {
        for (name, d) in &self.drives {
            ezy_core::drive::check_angle(&d.angle, t_end)
                .map_err(|m| SceneError::at(&["drives", name.as_str(), "angle"], m))?;
        }
        Ok(())
    }

    /// The model's drives with the scene's prescribed angles, in the
    /// model's order (a checked scene gives every one).
    pub fn resolve_drives(&self, info: &ModelInfo) -> Vec<ezy_core::drive::Drive> {
        let by_name: std::collections::HashMap<&str, &DriveSpec> =
            self.drives.iter().map(|(n, d)| (n.as_str(), d)).collect();
        info.drives
            .iter()
            .filter_map(|d| {
                let spec = by_name.get(d.name.as_str())?;
                Some(ezy_core::drive::Drive { name: d.name.to_string(), row: d.row, angle: spec.angle.clone() })
            })
            .collect()
    }

    /// The run settings this scene asks for: its integrator, tolerances,
    /// projection, `t_end` and output interval, with the default energy
    /// balance guard ([`ezy_core::simulate::BALANCE_LIMIT`]). Callers override
    /// fields with struct update syntax.
    pub fn run_settings(&self) -> ezy_core::RunSettings {
        ezy_core::RunSettings {
            dt: self.integrator.dt,
            t_end: self.t_end,
            every: self.output.every,
            projection: self.integrator.projection,
            method: self.integrator.method,
            formulation: self.integrator.formulation,
            rtol: self.integrator.rtol,
            atol: self.integrator.atol,
            balance_limit: Some(ezy_core::simulate::BALANCE_LIMIT),
            max_steps: Some(ezy_core::simulate::DEFAULT_MAX_STEPS),
        }
    }

    /// The scene with its family effects expanded for a model with `info`:
    /// an effect whose `hinge` or `skate` is written `NAME[*]` becomes one
    /// effect per element of that family (`J[*]`: `J2`, `J3`, ...), named
    /// by the effect's name and the element's index (`gait` on `J3`:
    /// `gait3`); in its waveforms, `phase_step` \[rad\] is added to the
    /// phase once per element along the family (a travelling wave, e.g.
    /// the serpenoid gait `tau_i = A sin(omega t + i delta)`). An event
    /// that switches a family effect (`switch_off = ["gait"]`) switches
    /// each of its elements; an element may be named alone (`gait3`). The
    /// elements' numbers stay bound to the scene parameters that gave them
    /// ([`Scene::bindings`]), except a `phase_step` and the `phase` it
    /// shifts, which differ per element: apply [`Scene::set`] first.
    ///
    /// # Errors
    /// A [`SceneError`] at the effect for a family the model does not
    /// have, a `phase_step` on an effect that is not over a family, or an
    /// expanded name that another effect already has.
    pub fn expand_families(&self, info: &ModelInfo) -> Result<Scene, SceneError> {
        let mut out = self.clone();
        out.effects.clear();
        // every name given or made so far (a family of 10,000 makes as many)
        let mut taken: std::collections::HashSet<String> = self.effects.iter().map(|(n, _)| n.clone()).collect();
        // each family effect's elements, for the events that switch it
        let mut families: Vec<(&str, Vec<String>)> = Vec::new();
        for (name, spec) in &self.effects {
            let tree = toml::Value::try_from(spec).expect("an effect serializes");
            let field = ["hinge", "skate", "at"]
                .into_iter()
                .find(|f| tree.get(f).and_then(toml::Value::as_str).is_some_and(|v| v.ends_with("[*]")));
            let Some(field) = field else {
                if has_phase_step(&tree) {
                    return Err(SceneError::at(
                        &["effects", name],
                        "`phase_step` only applies to an effect over a family (`hinge = \"J[*]\"` or `skate = \"S[*]\"`)",
                    ));
                }
                out.effects.push((name.clone(), spec.clone()));
                continue;
            };
            let bound = take_bindings(&mut out.bindings, "effects", name);
            let pattern = tree[field].as_str().expect("checked").to_string();
            let stem = pattern.trim_end_matches("[*]");
            let all: Vec<&str> = match field {
                "hinge" => info.hinges.iter().map(|h| h.name.as_str()).collect(),
                "skate" => info.skates.iter().map(|s| s.name.as_str()).collect(),
                // `at`: a point family, else a body family
                _ => {
                    let points: Vec<&str> = info.points.iter().map(|p| p.name.as_str()).collect();
                    if points.iter().any(|n| ezy_core::model::is_element_of(n, stem)) {
                        points
                    } else {
                        info.bodies.iter().map(|b| b.name.as_str()).collect()
                    }
                }
            };
            let elements: Vec<&str> = all.iter().copied().filter(|n| ezy_core::model::is_element_of(n, stem)).collect();
            if elements.is_empty() {
                return Err(SceneError::at(
                    &["effects", name, field],
                    format!(
                        "`{pattern}`: model {} has no {field} family `{stem}`; its {field}s: {}",
                        info.name,
                        known_or_none(&all)
                    ),
                ));
            }
            for (k, element) in elements.iter().enumerate() {
                let mut t = tree.clone();
                t[field] = toml::Value::String(element.to_string());
                apply_phase_step(&mut t, k as f64);
                let element_spec: SceneEffect = t.try_into().map_err(|e: toml::de::Error| {
                    SceneError::at(&["effects", name], format!("expanding over `{pattern}`: {}", e.message()))
                })?;
                let element_spec = element_spec.inherit_kind(spec);
                let expanded = format!("{name}{}", &element[stem.len()..]);
                if !taken.insert(expanded.clone()) {
                    return Err(SceneError::at(
                        &["effects", name],
                        format!("expanding over `{pattern}` gives an effect `{expanded}`, a name already taken"),
                    ));
                }
                rebind(&bound, &tree, &expanded, &mut out.bindings);
                out.effects.push((expanded.clone(), element_spec));
                match families.last_mut() {
                    Some((n, members)) if *n == name.as_str() => members.push(expanded),
                    _ => families.push((name.as_str(), vec![expanded])),
                }
            }
        }
        // an event switching a family effect switches each of its elements
        for (_, event) in &mut out.events {
            for list in [&mut event.switch_on, &mut event.switch_off] {
                if list.iter().any(|n| families.iter().any(|(f, _)| f == n)) {
                    *list = list
                        .iter()
                        .flat_map(|n| match families.iter().find(|(f, _)| f == n) {
                            Some((_, members)) => members.clone(),
                            None => vec![n.clone()],
                        })
                        .collect();
                }
            }
        }
        // drives: `[drives."D[*]"]` gives every element of the drive family D
        out.drives.clear();
        let mut given: std::collections::HashSet<String> = self.drives.iter().map(|(n, _)| n.clone()).collect();
        for (name, spec) in &self.drives {
            let tree = toml::Value::try_from(spec).expect("a drive serializes");
            let Some(stem) = name.strip_suffix("[*]") else {
                if has_phase_step(&tree) {
                    return Err(SceneError::at(
                        &["drives", name],
                        "`phase_step` only applies to a drive family (`[drives.\"D[*]\"]`)",
                    ));
                }
                out.drives.push((name.clone(), spec.clone()));
                continue;
            };
            let bound = take_bindings(&mut out.bindings, "drives", name);
            let elements: Vec<&str> = info
                .drives
                .iter()
                .map(|d| d.name.as_str())
                .filter(|n| ezy_core::model::is_element_of(n, stem))
                .collect();
            if elements.is_empty() {
                let all: Vec<&str> = info.drives.iter().map(|d| d.name.as_str()).collect();
                return Err(SceneError::at(
                    &["drives", name],
                    format!("model {} has no drive family `{stem}`; its drives: {}", info.name, known_or_none(&all)),
                ));
            }
            for (k, element) in elements.iter().enumerate() {
                if !given.insert(element.to_string()) {
                    return Err(SceneError::at(
                        &["drives", name],
                        format!("`{name}` and `[drives.{element}]` both give the angle of drive `{element}`"),
                    ));
                }
                let mut t = tree.clone();
                apply_phase_step(&mut t, k as f64);
                let spec: DriveSpec = t.try_into().map_err(|e: toml::de::Error| {
                    SceneError::at(&["drives", name], format!("expanding over `{name}`: {}", e.message()))
                })?;
                rebind(&bound, &tree, element, &mut out.bindings);
                out.drives.push((element.to_string(), spec));
            }
        }
        out.bindings.sort();
        Ok(out)
    }

    /// Binds the scene's effects of kinds of the user's own
    /// ([`SceneEffect::User`]) to the kinds `kinds` registers, so that
    /// [`Scene::check`] reads their fields and resolving builds their laws.
    ///
    /// # Errors
    /// A [`SceneError`] at `effects.NAME.kind` for a kind neither built in
    /// nor in `kinds`, listing the known kinds.
    pub fn bind_kinds(&mut self, kinds: &crate::EffectKinds) -> Result<(), SceneError> {
        for (name, spec) in &mut self.effects {
            spec.bind(kinds).map_err(|e| SceneError::at(&["effects", name, e.field], e.message))?;
        }
        Ok(())
    }

    /// Resolves the scene's effects against `model`.
    ///
    /// # Errors
    /// As [`SceneEffect::resolve_in`].
    pub fn resolve_effects<M: Model>(&self, model: &M) -> Result<Vec<ezy_core::Effect>, ezy_core::SimError> {
        let info = model.info();
        let names = ezy_core::model::NameIndex::new(&info);
        let cx = ezy_core::effects::EffectContext::new(model, &names).with_scene_params(&self.scene_params);
        self.effects.iter().map(|(n, e)| e.resolve_in(n, &cx)).collect()
    }
}

/// Removes and returns the bindings to numbers of `section.item` (a family
/// item about to be expanded).
fn take_bindings(bindings: &mut Vec<Binding>, section: &str, item: &str) -> Vec<Binding> {
    let bound = bindings.iter().filter(|b| is_bound_in(section, item, b)).cloned().collect();
    bindings.retain(|b| !is_bound_in(section, item, b));
    bound
}

/// Binds the numbers of the family item's element `element` as `bound`
/// bound the item's (`tree` is the item, serialized), except a
/// `phase_step` and the `phase` it shifts, which differ per element.
fn rebind(bound: &[Binding], tree: &toml::Value, element: &str, bindings: &mut Vec<Binding>) {
    for b in bound.iter().filter(|b| !shifted_by_phase_step(tree, &b.path[2..])) {
        let mut path = b.path.clone();
        path[1] = element.to_string();
        bindings.push(Binding { path, param: b.param.clone() });
    }
}

/// Whether binding `b` is to a number of `section.item`.
fn is_bound_in(section: &str, item: &str, b: &Binding) -> bool {
    b.path.len() > 2 && b.path[0] == section && b.path[1] == item
}

/// Whether the number at key path `leaf` of the serialized effect `tree` is
/// a `phase_step`, or a `phase` next to a `phase_step` (family expansion
/// changes both).
fn shifted_by_phase_step(tree: &toml::Value, leaf: &[String]) -> bool {
    let Some((last, parents)) = leaf.split_last() else { return false };
    if last == "phase_step" {
        return true;
    }
    let mut node = tree;
    for p in parents {
        let next = match node {
            toml::Value::Table(t) => t.get(p),
            toml::Value::Array(a) => p.parse::<usize>().ok().and_then(|i| a.get(i)),
            _ => None,
        };
        match next {
            Some(n) => node = n,
            None => return false,
        }
    }
    last == "phase" && node.get("phase_step").is_some()
}

/// Whether a serialized effect has a nonzero `phase_step` anywhere.
fn has_phase_step(v: &toml::Value) -> bool {
    match v {
        toml::Value::Table(t) => t.iter().any(|(k, v)| {
            (k == "phase_step" && v.as_float().or(v.as_integer().map(|i| i as f64)) != Some(0.0)) || has_phase_step(v)
        }),
        toml::Value::Array(a) => a.iter().any(has_phase_step),
        _ => false,
    }
}

/// `phase += k * phase_step` in every harmonic of a serialized effect,
/// and `phase_step` removed.
fn apply_phase_step(v: &mut toml::Value, k: f64) {
    match v {
        toml::Value::Table(t) => {
            if let Some(step) = t.remove("phase_step") {
                let step = step.as_float().or(step.as_integer().map(|i| i as f64)).unwrap_or(0.0);
                let phase =
                    t.get("phase").and_then(|p| p.as_float().or(p.as_integer().map(|i| i as f64))).unwrap_or(0.0);
                t.insert("phase".into(), toml::Value::Float(phase + k * step));
            }
            for (_, v) in t.iter_mut() {
                apply_phase_step(v, k);
            }
        }
        toml::Value::Array(a) => a.iter_mut().for_each(|v| apply_phase_step(v, k)),
        _ => {}
    }
}

fn known_or_none(names: &[&str]) -> String {
    if names.is_empty() { "none".to_string() } else { ezy_core::name_list(names) }
}

/// `spec` with the number at `key` set to `value`, and the full dotted path
/// of that number: `key` is a full dotted path or the unambiguous last part
/// of one, or a top-level key the serialization left out (a default) that
/// `spec`'s type accepts. `None` if no number matches.
///
/// # Errors
/// [`ezy_core::SimError::Scene`] when `key` matches several numbers.
fn set_number<T: Serialize + serde::de::DeserializeOwned>(
    spec: &T,
    key: &str,
    value: f64,
    name: &str,
) -> Result<Option<(T, String)>, ezy_core::SimError> {
    let mut tree = toml::Value::try_from(spec).expect("a scene item serializes");
    let leaves = numeric_leaves(&tree);
    let matches: Vec<&String> = leaves.iter().filter(|l| *l == key || l.ends_with(&format!(".{key}"))).collect();
    match matches[..] {
        [path] => {
            let unreachable = || ezy_core::SimError::Scene {
                key: name.to_string(),
                message: format!("`{path}` cannot be set: a key on its way contains a `.`"),
            };
            let mut node = &mut tree;
            for part in path.split('.') {
                node = match node {
                    toml::Value::Table(t) => t.get_mut(part).ok_or_else(unreachable)?,
                    toml::Value::Array(a) => {
                        part.parse::<usize>().ok().and_then(|i| a.get_mut(i)).ok_or_else(unreachable)?
                    }
                    _ => return Err(unreachable()),
                };
            }
            *node = number_like(node, value);
            let changed = tree.try_into().map_err(|e: toml::de::Error| ezy_core::SimError::Scene {
                key: name.to_string(),
                message: e.message().trim().to_string(),
            })?;
            Ok(Some((changed, path.clone())))
        }
        [] => {
            // a key at its default is not serialized: try it as a new key
            if let toml::Value::Table(t) = &mut tree
                && !key.contains('.')
                && !t.contains_key(key)
            {
                t.insert(key.to_string(), toml::Value::Float(value));
                return Ok(tree.try_into().ok().map(|changed| (changed, key.to_string())));
            }
            Ok(None)
        }
        _ => Err(ezy_core::SimError::Scene {
            key: name.to_string(),
            message: format!(
                "`{key}` matches several numbers ({}); give the full key",
                matches.iter().map(|m| m.as_str()).collect::<Vec<_>>().join(", ")
            ),
        }),
    }
}

/// `value` as the TOML number that replaces `old`: an integer where `old`
/// is one and `value` is whole (a count field of a user's effect kind
/// stays an integer), a float otherwise.
fn number_like(old: &toml::Value, value: f64) -> toml::Value {
    if old.is_integer() && value.fract() == 0.0 && value.abs() < 9e15 {
        toml::Value::Integer(value as i64)
    } else {
        toml::Value::Float(value)
    }
}

/// `spec` with the number at the key path `path` set to `value` (a number
/// at its default, left out of the serialization, is added).
///
/// # Errors
/// What is wrong, when the path leads to no number of `spec`'s type.
fn with_number<T: Serialize + serde::de::DeserializeOwned>(spec: &T, path: &[String], value: f64) -> Result<T, String> {
    let mut tree = toml::Value::try_from(spec).map_err(|e| e.to_string())?;
    let old = path.iter().try_fold(&tree, |node, part| match node {
        toml::Value::Table(t) => t.get(part),
        toml::Value::Array(a) => a.get(part.parse::<usize>().ok()?),
        _ => None,
    });
    let new = old.map_or(toml::Value::Float(value), |old| number_like(old, value));
    set_path(&mut tree, path, new).ok_or("the key path leads to no number")?;
    tree.try_into().map_err(|e: toml::de::Error| e.message().trim().to_string())
}

/// Dotted paths of the numbers in a TOML tree (`torque.cos.amplitude`,
/// `torque.harmonics.1.omega`).
fn numeric_leaves(v: &toml::Value) -> Vec<String> {
    numeric_values(v).into_iter().map(|(leaf, _)| leaf).collect()
}

/// Every number in `v` with its dotted key path (array items by index).
fn numeric_values(v: &toml::Value) -> Vec<(String, f64)> {
    fn walk(v: &toml::Value, prefix: &str, out: &mut Vec<(String, f64)>) {
        let join = |k: &str| if prefix.is_empty() { k.to_string() } else { format!("{prefix}.{k}") };
        match v {
            toml::Value::Float(x) => out.push((prefix.to_string(), *x)),
            toml::Value::Integer(i) => out.push((prefix.to_string(), *i as f64)),
            toml::Value::Table(t) => t.iter().for_each(|(k, v)| walk(v, &join(k), out)),
            toml::Value::Array(a) => a.iter().enumerate().for_each(|(i, v)| walk(v, &join(&i.to_string()), out)),
            _ => {}
        }
    }
    let mut out = Vec::new();
    walk(v, "", &mut out);
    out
}

/// Whether `name` is an identifier: an ASCII letter or `_`, then ASCII
/// letters, digits and `_`.
fn is_identifier(name: &str) -> bool {
    let mut chars = name.chars();
    chars.next().is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// In the parsed file `root`: replaces every string in a number's place
/// inside `[effects.NAME]` (keys other than [`crate::NAME_KEYS`])
/// and `[drives.NAME]` by the value of the scene parameter it names, the
/// very token written in `[scene_params]` (so the number is bit for bit the
/// one written there), keeping the string's span for later errors.
/// Returns the places, sorted by path.
///
/// # Errors
/// A [`SceneError`] at a scene parameter that is not a number, or at a
/// string that names no scene parameter (listing the declared ones).
/// The keys whose value is an array in a scene file; an array anywhere
/// else stands where a table or a single value belongs, and serde would
/// read a struct from it by position (`integrator = ["euler", 0.01]`).
const ARRAY_KEYS: &[&str] = &[
    "include",
    "paths",
    "lines",
    "shade",
    "switch_on",
    "switch_off",
    "figures",
    "harmonics",
    "t",
    "value",
    "g",
    "bodies",
    "along",
];

/// Refuses an array at a key not in [`ARRAY_KEYS`], and an array as an
/// element of an array (the arrays of a scene hold tables or values).
fn refuse_misplaced_arrays(table: &toml::de::DeTable<'_>, path: &mut Vec<String>) -> Result<(), SceneError> {
    use toml::de::DeValue;
    fn walk(v: &DeValue<'_>, path: &mut Vec<String>, array_ok: bool) -> Result<(), SceneError> {
        match v {
            DeValue::Table(t) => refuse_misplaced_arrays(t, path),
            DeValue::Array(a) if array_ok => {
                for (i, v) in a.iter().enumerate() {
                    path.push(i.to_string());
                    walk(v.get_ref(), path, false)?;
                    path.pop();
                }
                Ok(())
            }
            DeValue::Array(_) => Err(SceneError {
                path: path.clone(),
                message: "an array is not allowed here: write a table (`{ key = value, ... }`) or a single value"
                    .into(),
            }),
            _ => Ok(()),
        }
    }
    for (k, v) in table.iter() {
        let key = k.get_ref().as_ref();
        path.push(key.to_string());
        // the entries of `[draw]` are arrays of point names under body names
        let in_draw = path.len() == 2 && path[0] == "draw";
        walk(v.get_ref(), path, in_draw || ARRAY_KEYS.contains(&key))?;
        path.pop();
    }
    Ok(())
}

fn bind_scene_params(root: &mut toml::de::DeTable<'_>) -> Result<Vec<Binding>, SceneError> {
    use toml::de::DeValue;
    let mut declared: Vec<(String, DeValue<'_>)> = Vec::new();
    if let Some((_, table)) = root.iter().find(|(k, _)| k.get_ref().as_ref() == "scene_params")
        && let DeValue::Table(table) = table.get_ref()
    {
        for (k, v) in table.iter() {
            let name = k.get_ref().to_string();
            match v.get_ref() {
                DeValue::Integer(_) | DeValue::Float(_) => declared.push((name, v.get_ref().clone())),
                other => {
                    return Err(SceneError::at(
                        &["scene_params", &name],
                        format!("scene parameter `{name}` must be a number, not a {}", other.type_str()),
                    ));
                }
            }
        }
    }
    let mut bindings = Vec::new();
    for section in ["effects", "drives"] {
        let Some((_, items)) = root.iter_mut().find(|(k, _)| k.get_ref().as_ref() == section) else { continue };
        let DeValue::Table(items) = items.get_mut() else { continue };
        for (item, v) in items.iter_mut() {
            let mut path = vec![section.to_string(), item.get_ref().to_string()];
            bind_numbers(v, &mut path, section == "effects", &declared, &mut bindings)?;
        }
    }
    bindings.sort();
    Ok(bindings)
}

/// The recursion of [`bind_scene_params`] at `v` (key path `path`);
/// `effect_table` skips the name keys of an effect's own table.
fn bind_numbers<'i>(
    v: &mut toml::Spanned<toml::de::DeValue<'i>>,
    path: &mut Vec<String>,
    effect_table: bool,
    declared: &[(String, toml::de::DeValue<'i>)],
    out: &mut Vec<Binding>,
) -> Result<(), SceneError> {
    use toml::de::DeValue;
    match v.get_mut() {
        DeValue::String(name) => {
            let name = name.to_string();
            let Some((_, value)) = declared.iter().find(|(n, _)| *n == name) else {
                let names: Vec<&str> = declared.iter().map(|(n, _)| n.as_str()).collect();
                return Err(SceneError {
                    path: path.clone(),
                    message: format!(
                        "`{name}` is neither a number nor a scene parameter; declared in [scene_params]: {}",
                        known_or_none(&names)
                    ),
                });
            };
            *v.get_mut() = value.clone();
            out.push(Binding { path: path.clone(), param: name });
        }
        DeValue::Table(t) => {
            for (k, v) in t.iter_mut() {
                let k = k.get_ref().as_ref();
                if effect_table && crate::NAME_KEYS.contains(&k) {
                    continue;
                }
                path.push(k.to_string());
                bind_numbers(v, path, false, declared, out)?;
                path.pop();
            }
        }
        DeValue::Array(a) => {
            for (i, v) in a.iter_mut().enumerate() {
                path.push(i.to_string());
                bind_numbers(v, path, false, declared, out)?;
                path.pop();
            }
        }
        _ => {}
    }
    Ok(())
}

/// Sets the value at `path` (keys; array entries by index) in `tree`,
/// making the tables on the way that are missing (a number at its default
/// is not serialized). `None` if the path runs into a non-table or past an
/// array's end.
fn set_path(tree: &mut toml::Value, path: &[String], value: toml::Value) -> Option<()> {
    let Some((last, parents)) = path.split_last() else {
        *tree = value;
        return Some(());
    };
    let mut node = tree;
    for part in parents {
        node = match node {
            toml::Value::Table(t) => t.entry(part.clone()).or_insert_with(|| toml::Value::Table(Default::default())),
            toml::Value::Array(a) => a.get_mut(part.parse::<usize>().ok()?)?,
            _ => return None,
        };
    }
    match node {
        toml::Value::Table(t) => {
            t.insert(last.clone(), value);
        }
        toml::Value::Array(a) => *a.get_mut(last.parse::<usize>().ok()?)? = value,
        _ => return None,
    }
    Some(())
}
