//! Figures as data: what a scene's `[[figures]]` entries say to draw
//! ([`FigureSpec`]: paths in the plane, or lines over a column in one or
//! two panels), the columns and functions of columns they plot
//! ([`Column`]), and the file format and resolution they are written in.
//! The drawing itself is the `ezy` crate's; the names the figures read
//! are checked against the output's columns in [`crate::check`].

use std::fmt;

use serde::{Deserialize, Serialize};

/// Default resolution of PNG figures \[dots per inch\]: 1440 x 960 pixels.
pub const DEFAULT_DPI: f64 = 144.0;
/// Smallest resolution of PNG figures \[dots per inch\] (240 x 160 pixels).
pub const MIN_DPI: f64 = 24.0;
/// Largest resolution of PNG figures \[dots per inch\] (6000 x 4000 pixels).
pub const MAX_DPI: f64 = 600.0;

/// File format of figures.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FigureFormat {
    /// Anti-aliased raster image at a chosen resolution (see
    /// [`crate::OutputSettings::dpi`]).
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

    pub(crate) fn is_png(&self) -> bool {
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
