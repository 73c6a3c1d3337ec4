//! A chart as data: the [`Chart`] (lines over x in one or two panels, or
//! paths in the plane), its [`Series`] and how each is stroked
//! ([`Stroke`]); `chart` draws it, `axis`, `lines` and `legend` read it.

/// How a series' line is stroked.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Stroke {
    /// Solid, unless the series runs on top of an earlier series of its
    /// panel (within 1 % of the panel's range at more than a fifth of its
    /// points, compared point by point, so both need the same number of
    /// drawable points; paths are compared by nearest point): then the
    /// first dash style none of those series has, with markers.
    #[default]
    Auto,
    /// Always solid.
    Solid,
    /// Solid pieces that are no path (a drawing between breaks, `NaN`
    /// points: a vehicle's bodies at several times): no start and end
    /// markers on a path chart.
    Pieces,
    /// Dash style `k` (0: dashed, 1: dotted, 2: long dashes), with markers.
    Dash(usize),
    /// No line: a filled diamond at every point (points given, not
    /// computed); a point on a marker of an earlier series of its panel
    /// is drawn as a hollow diamond around that marker instead (larger
    /// for each marker it would cover), so both stay visible.
    Points,
}

/// One line of a chart.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Series {
    /// Legend text for this line; an empty label gives the line no legend entry.
    pub label: String,
    /// Data points `(x, y)` in the units of the chart's axis labels, joined in
    /// order. Points with a non-finite coordinate are skipped and break the
    /// line into separate pieces; an isolated point is drawn as a dot.
    pub points: Vec<(f64, f64)>,
    /// The panel it is drawn in: 0 (upper) or 1 (lower, see [`Chart::lower`]).
    pub panel: usize,
    /// Stroke style.
    pub stroke: Stroke,
    /// Colour: an index into [`PALETTE`](super::PALETTE) (`None`: the series' own index).
    pub color: Option<usize>,
}

impl Series {
    /// A series in the upper panel with an automatic stroke.
    pub fn new(label: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Self { label: label.into(), points, ..Self::default() }
    }
}

/// A 2-D chart: lines over x in one or two stacked panels sharing the x
/// axis, or paths in the plane with equal axes.
#[derive(Debug, Clone, PartialEq)]
pub struct Chart {
    /// Title drawn above the plot.
    pub title: String,
    /// Label of the x axis, including its unit, e.g. `"t [s]"`.
    pub x_label: String,
    /// Label of the (upper) y axis, including its unit, e.g. `"x [m]"`.
    pub y_label: String,
    /// The lines to draw, coloured in order from [`PALETTE`](super::PALETTE).
    pub series: Vec<Series>,
    /// Label of the lower panel's y axis: `Some` draws the series with
    /// `panel = 1` in a second panel below the first, for quantities in
    /// another unit.
    pub lower: Option<String>,
    /// Same scale on both axes (paths in the plane), data ranges padded so 1 m
    /// is the same number of pixels in x and y; each series' first point
    /// gets a filled circle and its last a filled square.
    pub equal_axes: bool,
    /// With `equal_axes`: mark each path's start and end (off for points
    /// in a plane that are not paths, such as eigenvalues).
    pub path_ends: bool,
    /// Logarithmic x axis; values <= 0 are not drawn.
    pub log_x: bool,
    /// Logarithmic y axis (both panels); values <= `log_floor` are drawn at `log_floor`.
    pub log_y: bool,
    /// Smallest value shown on a logarithmic y axis, in the y axis' unit; must
    /// be finite and > 0 when `log_y` is set (ignored otherwise).
    pub log_floor: f64,
    /// Legend to the right of the plot instead of inside it (for long
    /// legends that would cover the data wherever they sat).
    pub legend_outside: bool,
    /// Stretches of x `(from, to)` shaded in every panel (a skate that
    /// slides), behind the lines.
    pub shade: Vec<(f64, f64)>,
}

impl Chart {
    /// A linear chart in one panel with no series yet.
    pub fn new(title: impl Into<String>, x_label: impl Into<String>, y_label: impl Into<String>) -> Self {
        Self {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            series: Vec::new(),
            lower: None,
            equal_axes: false,
            path_ends: true,
            log_x: false,
            log_y: false,
            log_floor: 1e-18,
            legend_outside: false,
            shade: Vec::new(),
        }
    }
}

/// Number of panels: 2 with a lower panel, else 1.
pub(super) fn panels(chart: &Chart) -> usize {
    if chart.lower.is_some() { 2 } else { 1 }
}
