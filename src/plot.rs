//! PNG line charts for the CLI's figures.
//!
//! [`render_png`] draws a [`Chart`] (title, axis labels with units, a light
//! grid, a legend and one coloured line per [`Series`]) into a 1200 x 800 PNG
//! with plotters' bitmap backend. Text uses DejaVu Sans embedded from the
//! `dejavu` crate, so no system font (or fontconfig/freetype `-dev` package)
//! is needed at build or run time.
//!
//! [`png`] checks the data ranges before drawing anything (a range plotters
//! cannot draw is refused, see [`undrawable`]), draws on a worker thread
//! with a time limit ([`DRAW_TIMEOUT`]) and encodes the PNG in memory;
//! [`render_png`] writes it atomically, so a failed render never leaves a
//! half-written figure behind.

use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use image::ImageEncoder;
use plotters::coord::ranged1d::{KeyPointHint, NoDefaultFormatting, Ranged, ValueFormatter};
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use plotters::style::FontStyle;

/// Width of the rendered figure in pixels.
const WIDTH: u32 = 1200;
/// Height of the rendered figure in pixels.
const HEIGHT: u32 = 800;
/// Font family name the embedded DejaVu Sans is registered under.
const FONT: &str = "sans-serif";
/// Width of every series line in pixels.
const LINE_WIDTH: u32 = 2;
/// Font size of the title in pixels.
const TITLE_SIZE: u32 = 30;
/// Font size of the axis descriptions (the x and y labels) in pixels.
const DESC_SIZE: u32 = 22;
/// Font size of tick labels and legend entries in pixels.
const LABEL_SIZE: u32 = 18;
/// How far, as a fraction of the font size, plotters' `ab_glyph` text sits
/// above where plotters' layout expects it.
///
/// `ab_glyph` scales a font so that ascent - descent equals the font size
/// (1.164 em for DejaVu Sans), and plotters draws a glyph at
/// `size / 2 + glyph top` below the anchor while laying the line out as
/// `size / 1.24` tall. For DejaVu Sans digits and capitals that puts the ink
/// centre about 0.216 x size above the centre of the laid-out box, so
/// vertically centred text (y tick labels, legend entries) would sit visibly
/// high next to its tick or legend line, and top-anchored text (the title)
/// would be clipped at the image edge.
const AB_GLYPH_RISE: f64 = 0.216;
/// Fraction of the data range added on each side of the y axis (and of both
/// axes for equal-axes charts).
const PAD_FRACTION: f64 = 0.05;

/// Series colours, cycled when a chart has more series than entries
/// (the "tab10" palette: distinct and readable on white).
const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

/// One line of a chart.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Legend text for this line; an empty label gives the line no legend entry.
    pub label: String,
    /// Data points `(x, y)` in the units of the chart's axis labels, joined in
    /// order. Points with a non-finite coordinate are skipped and break the
    /// line into separate pieces; an isolated point is drawn as a dot.
    pub points: Vec<(f64, f64)>,
}

/// A 2-D line chart.
#[derive(Debug, Clone, PartialEq)]
pub struct Chart {
    /// Title drawn above the plot.
    pub title: String,
    /// Label of the x axis, including its unit, e.g. `"t [s]"`.
    pub x_label: String,
    /// Label of the y axis, including its unit, e.g. `"x [m]"`.
    pub y_label: String,
    /// The lines to draw, coloured in order from a fixed palette.
    pub series: Vec<Series>,
    /// Same scale on both axes (paths in the plane), data ranges padded so 1 m
    /// is the same number of pixels in x and y.
    pub equal_axes: bool,
    /// Logarithmic y axis; values <= `log_floor` are drawn at `log_floor`.
    pub log_y: bool,
    /// Smallest value shown on a logarithmic y axis, in the y axis' unit; must
    /// be finite and > 0 when `log_y` is set (ignored otherwise).
    pub log_floor: f64,
}

/// Why a chart could not be rendered.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The chart has no drawable point: every series is empty or holds only
    /// non-finite values.
    #[error("chart {title:?} has no finite data points to plot")]
    Empty {
        /// Title of the offending chart.
        title: String,
    },
    /// `log_y` was requested with a floor that is not a finite positive number.
    #[error("chart {title:?}: log_floor must be finite and > 0 for a log y axis, got {floor}")]
    InvalidLogFloor {
        /// Title of the offending chart.
        title: String,
        /// The rejected floor.
        floor: f64,
    },
    /// The embedded DejaVu Sans font could not be registered with plotters.
    #[error("could not register the embedded DejaVu Sans font with plotters")]
    Font,
    /// plotters failed while drawing or encoding the figure.
    #[error("chart {title:?}: {message}")]
    Draw {
        /// Title of the offending chart.
        title: String,
        /// plotters' description of the failure.
        message: String,
    },
    /// A data range that cannot be drawn (see [`undrawable`]); nothing was
    /// drawn.
    #[error("chart {title:?}: the {axis} values from {start:e} to {end:e} cannot be plotted: {value:e} {reason}")]
    Range {
        /// Title of the offending chart.
        title: String,
        /// `"x"`, `"y"` or `"log10 y"`.
        axis: &'static str,
        /// Smallest value on the axis.
        start: f64,
        /// Largest value on the axis.
        end: f64,
        /// The offending value.
        value: f64,
        /// Why.
        reason: &'static str,
    },
    /// Drawing took longer than [`DRAW_TIMEOUT`] and was given up.
    #[error("chart {title:?}: drawing did not finish within {seconds} s and was given up")]
    Timeout {
        /// Title of the offending chart.
        title: String,
        /// The limit in seconds.
        seconds: f64,
    },
    /// A file-system operation on the figure failed.
    #[error("writing {path}: {source}")]
    Io {
        /// The file the operation was on.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
}

/// Largest magnitude of a plotted coordinate (in plot coordinates: `log10`
/// of the value on a logarithmic axis). plotters loops forever once the
/// length of a padded axis range overflows (measured: a y range from 0 to
/// 1.5e308 is drawn, 0 to 1.7e308 or -1e308 to 1e308 never returns); spans
/// down to one unit in the last place are drawn at any magnitude up to
/// 1e120. 1e100 leaves a wide margin and is far beyond any physical
/// quantity in SI units.
pub const MAX_MAGNITUDE: f64 = 1e100;
/// Largest length of an axis range after padding (and, for equal axes,
/// equalizing): a second guard before plotters sees the range.
const MAX_AXIS_LENGTH: f64 = 1e300;
/// Longest a single figure may take to draw before it is given up
/// ([`PlotError::Timeout`]): a safety net should plotters loop on a range
/// the checks let through.
pub const DRAW_TIMEOUT: std::time::Duration = std::time::Duration::from_secs(30);

/// Render `chart` as a 1200 x 800 PNG at `path`.
///
/// The PNG is encoded in memory ([`png`]) and written with
/// [`crate::transaction::write_atomically`]: into a uniquely named hidden
/// temporary file next to `path`, created exclusively, renamed onto `path`
/// only when complete; on failure any existing file at `path` is left as it
/// was. The parent directory must exist.
///
/// # Errors
/// As [`png`]; [`PlotError::Io`] if the file cannot be written or renamed.
pub fn render_png(chart: &Chart, path: &Path) -> Result<(), PlotError> {
    let bytes = png(chart)?;
    crate::transaction::write_atomically(path, &bytes).map_err(|e| match e {
        crate::transaction::TransactionError::Io { path, source } => PlotError::Io { path, source },
        other => PlotError::Io { path: path.to_path_buf(), source: std::io::Error::other(other.to_string()) },
    })
}

/// Render `chart` as a 1200 x 800 PNG, returned as the file's bytes.
///
/// The data ranges are checked before anything is drawn, and the drawing
/// runs on a worker thread given at most [`DRAW_TIMEOUT`].
///
/// # Errors
/// [`PlotError::Empty`] if no series has a finite point,
/// [`PlotError::InvalidLogFloor`] for a log axis with a bad floor,
/// [`PlotError::Range`] for a range that cannot be drawn (a coordinate
/// beyond [`MAX_MAGNITUDE`]), [`PlotError::Font`] if the embedded font cannot be loaded,
/// [`PlotError::Draw`] if plotters or the PNG encoder fails and
/// [`PlotError::Timeout`] if drawing takes longer than [`DRAW_TIMEOUT`].
pub fn png(chart: &Chart) -> Result<Vec<u8>, PlotError> {
    png_within(chart, DRAW_TIMEOUT)
}

/// [`png`] with a given time limit.
fn png_within(chart: &Chart, limit: std::time::Duration) -> Result<Vec<u8>, PlotError> {
    if chart.log_y && !(chart.log_floor.is_finite() && chart.log_floor > 0.0) {
        return Err(PlotError::InvalidLogFloor { title: chart.title.clone(), floor: chart.log_floor });
    }
    let lines = chart_lines(chart);
    let (x_range, y_range) = data_bounds(&lines).ok_or_else(|| PlotError::Empty { title: chart.title.clone() })?;
    // Values plotters cannot draw are refused before anything is drawn;
    // `draw` checks the padded ranges again.
    for (axis, r) in [("x", &x_range), (y_axis_name(chart), &y_range)] {
        check_range(&chart.title, axis, r, undrawable)?;
    }
    ensure_font()?;
    let draw_error = |message| PlotError::Draw { title: chart.title.clone(), message };
    // The worker owns a copy of the chart: if it never returns, the caller
    // still does (and the process ends it on exit).
    let owned = chart.clone();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::Builder::new()
        .name("ezy-plot".into())
        .spawn(move || {
            let lines = chart_lines(&owned);
            let result = match data_bounds(&lines) {
                Some((x, y)) => draw(&owned, &lines, x, y),
                None => Err(PlotError::Empty { title: owned.title.clone() }),
            };
            let _ = tx.send(result);
        })
        .map_err(|e| draw_error(format!("cannot start the drawing thread: {e}")))?;
    let pixels = match rx.recv_timeout(limit) {
        Ok(r) => r?,
        Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {
            return Err(PlotError::Timeout { title: chart.title.clone(), seconds: limit.as_secs_f64() });
        }
        Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
            return Err(draw_error("plotters panicked while drawing".into()));
        }
    };
    let mut bytes = Vec::new();
    image::codecs::png::PngEncoder::new(&mut bytes)
        .write_image(&pixels, WIDTH, HEIGHT, image::ColorType::Rgb8)
        .map_err(|e| draw_error(format!("encoding the PNG: {e}")))?;
    Ok(bytes)
}

/// Why a data range cannot be drawn, if it cannot: a bound that is not
/// finite or beyond [`MAX_MAGNITUDE`]. Returns the offending value and the
/// reason.
pub fn undrawable(range: &Range<f64>) -> Option<(f64, &'static str)> {
    for v in [range.start, range.end] {
        if !v.is_finite() {
            return Some((v, "is not a finite number"));
        }
        if v.abs() > MAX_MAGNITUDE {
            return Some((v, "is too large to plot (magnitude above 1e100)"));
        }
    }
    None
}

/// [`undrawable`] for an axis' final range, which padding may have widened
/// beyond [`MAX_MAGNITUDE`] but whose length must stay finite.
fn undrawable_axis(range: &Range<f64>) -> Option<(f64, &'static str)> {
    let len = range.end - range.start;
    if !(range.start.is_finite() && range.end.is_finite() && len.is_finite() && len <= MAX_AXIS_LENGTH) {
        return Some((len, "is the length of the padded axis, too long to plot"));
    }
    None
}

/// `"y"`, or `"log10 y"` for a logarithmic y axis (whose plot coordinate
/// is the value's `log10`).
fn y_axis_name(chart: &Chart) -> &'static str {
    if chart.log_y { "log10 y" } else { "y" }
}

fn check_range(
    title: &str,
    axis: &'static str,
    range: &Range<f64>,
    test: fn(&Range<f64>) -> Option<(f64, &'static str)>,
) -> Result<(), PlotError> {
    match test(range) {
        None => Ok(()),
        Some((value, reason)) => {
            Err(PlotError::Range { title: title.into(), axis, start: range.start, end: range.end, value, reason })
        }
    }
}

/// Register DejaVu Sans (regular and bold) for the "sans-serif" family once
/// per process.
fn ensure_font() -> Result<(), PlotError> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        let regular = plotters::style::register_font(FONT, FontStyle::Normal, dejavu::sans::regular());
        let bold = plotters::style::register_font(FONT, FontStyle::Bold, dejavu::sans::bold());
        regular.is_ok() && bold.is_ok()
    });
    if ok { Ok(()) } else { Err(PlotError::Font) }
}

/// One series prepared for drawing: its drawable pieces in plot coordinates
/// (y is `log10` of the value for a log axis).
struct Line<'a> {
    /// Legend text (empty: no legend entry).
    label: &'a str,
    /// Maximal runs of consecutive drawable points.
    pieces: Vec<Vec<(f64, f64)>>,
}

/// Split every series into runs of drawable points in plot coordinates.
fn chart_lines(chart: &Chart) -> Vec<Line<'_>> {
    let floor_log = chart.log_floor.log10();
    chart
        .series
        .iter()
        .map(|s| {
            let mut pieces: Vec<Vec<(f64, f64)>> = Vec::new();
            let mut current = Vec::new();
            for &(x, y) in &s.points {
                let y = if chart.log_y {
                    // NaN fails the comparison and stays NaN; -inf and zeros go to the floor.
                    if y <= chart.log_floor { floor_log } else { y.log10() }
                } else {
                    y
                };
                if x.is_finite() && y.is_finite() {
                    current.push((x, y));
                } else if !current.is_empty() {
                    pieces.push(std::mem::take(&mut current));
                }
            }
            if !current.is_empty() {
                pieces.push(current);
            }
            Line { label: &s.label, pieces }
        })
        .collect()
}

/// Smallest and largest x and y over all drawable points, or `None` if there
/// are none.
fn data_bounds(lines: &[Line<'_>]) -> Option<(Range<f64>, Range<f64>)> {
    let mut points = lines.iter().flat_map(|l| l.pieces.iter().flatten());
    let &(x0, y0) = points.next()?;
    let (mut x, mut y) = (x0..x0, y0..y0);
    for &(px, py) in points {
        x = x.start.min(px)..x.end.max(px);
        y = y.start.min(py)..y.end.max(py);
    }
    Some((x, y))
}

/// Widen `r` by `fraction` of its length on each side; a zero-length range is
/// widened by 10 % of its magnitude (or by 1 around zero) so it has an extent.
fn pad(r: Range<f64>, fraction: f64) -> Range<f64> {
    let len = r.end - r.start;
    let margin = if len > 0.0 {
        len * fraction
    } else {
        let m = r.start.abs() * 0.1;
        if m > 0.0 { m } else { 1.0 }
    };
    (r.start - margin)..(r.end + margin)
}

/// Widen `x` or `y` about its centre so that both have the same data units per
/// pixel on a plotting area of `w` x `h` pixels.
fn equalize(x: Range<f64>, y: Range<f64>, (w, h): (u32, u32)) -> (Range<f64>, Range<f64>) {
    let (w, h) = (f64::from(w.max(1)), f64::from(h.max(1)));
    let per_px = ((x.end - x.start) / w).max((y.end - y.start) / h);
    let centred = |r: &Range<f64>, px: f64| {
        let c = 0.5 * (r.start + r.end);
        (c - 0.5 * per_px * px)..(c + 0.5 * per_px * px)
    };
    (centred(&x, w), centred(&y, h))
}

/// A logarithmic y axis in plot coordinates: values are `log10(y)` mapped
/// linearly, bold ticks sit on whole decades (and on 2 and 5 times them when
/// the axis spans few decades) and are labelled like `1e-6` or `5e-3`.
///
/// plotters' own `log_scale()` is not used because it drops every tick below
/// `f64::EPSILON` (its zero test is absolute), which hides the 1e-16 region
/// that solver residuals live in.
struct LogDecadeAxis {
    /// Linear map of `log10(value)` onto pixels.
    linear: RangedCoordf64,
    /// Positions (`log10` of the value) that get a tick and a label.
    bold: Vec<f64>,
    /// Positions of the unlabelled grid lines (`log10` of the value).
    light: Vec<f64>,
}

impl LogDecadeAxis {
    /// Axis over `log10` values `range`, widened outward to whole decades so
    /// that at least two decades are labelled; at most ~12 labels, the
    /// decades in between (or the 2..9 multiples when there are few decades)
    /// get light grid lines.
    fn new(range: Range<f64>) -> Self {
        let (lo, hi) = (range.start.floor() as i64, range.end.ceil() as i64);
        let hi = hi.max(lo + 1);
        let range = lo as f64..hi as f64;
        let decades = (hi - lo + 1) as usize;
        let step = decades.div_ceil(12).max(1) as i64;
        let labelled = |k: &i64| k.rem_euclid(step) == 0;
        let mut bold: Vec<f64> = (lo..=hi).filter(labelled).map(|k| k as f64).collect();
        let light = if decades <= 8 {
            (lo..hi).flat_map(|k| (2..10).map(move |m| k as f64 + f64::from(m).log10())).collect()
        } else {
            (lo..=hi).filter(|k| !labelled(k)).map(|k| k as f64).collect()
        };
        if decades <= 3 {
            // Few decades: also label 2 and 5 times each decade.
            bold.extend((lo..hi).flat_map(|k| [2.0f64, 5.0].map(|m| k as f64 + m.log10())));
            bold.sort_by(f64::total_cmp);
        }
        Self { linear: range.into(), bold, light }
    }
}

impl Ranged for LogDecadeAxis {
    type FormatOption = NoDefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        self.linear.map(value, limit)
    }

    fn key_points<Hint: KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        if hint.weight().allow_light_points() { self.light.clone() } else { self.bold.clone() }
    }

    fn range(&self) -> Range<f64> {
        self.linear.range()
    }
}

impl ValueFormatter<f64> for LogDecadeAxis {
    /// `log10` value `v` as `<m>e<k>`, e.g. `1e-6` or `5e-3`.
    fn format(value: &f64) -> String {
        let k = (value + 1e-9).floor();
        let m = 10f64.powf(value - k).round();
        format!("{m}e{k}")
    }
}

/// Draw the figure into an RGB pixel buffer.
///
/// # Errors
/// [`PlotError::Range`] if the axes' final ranges cannot be drawn (checked
/// before any data is drawn), [`PlotError::Draw`] with plotters' message.
fn draw(chart: &Chart, lines: &[Line<'_>], x_data: Range<f64>, y_data: Range<f64>) -> Result<Vec<u8>, PlotError> {
    let mut pixels = vec![0u8; 3 * WIDTH as usize * HEIGHT as usize];
    draw_into(&mut pixels, chart, lines, x_data, y_data).map_err(|e| match e {
        Failed::Range(e) => e,
        Failed::Draw(message) => PlotError::Draw { title: chart.title.clone(), message },
    })?;
    Ok(pixels)
}

/// Why [`draw_into`] stopped.
enum Failed {
    /// A final axis range that cannot be drawn.
    Range(PlotError),
    /// plotters' message.
    Draw(String),
}

impl From<String> for Failed {
    fn from(e: String) -> Self {
        Self::Draw(e)
    }
}

fn draw_into(
    pixels: &mut [u8],
    chart: &Chart,
    lines: &[Line<'_>],
    x_data: Range<f64>,
    y_data: Range<f64>,
) -> Result<(), Failed> {
    let root = BitMapBackend::with_buffer(pixels, (WIDTH, HEIGHT)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    // The top margin keeps the title's ascenders inside the image (see
    // `AB_GLYPH_RISE`).
    // `FontDesc::style` keeps the already loaded glyph data, so the bold face
    // must be chosen when the font is created.
    let title_font = (FONT, TITLE_SIZE, FontStyle::Bold).into_font().color(&BLACK);
    let body =
        root.margin(rise(TITLE_SIZE) + 6, 0, 0, 0).titled(&chart.title, title_font).map_err(|e| e.to_string())?;

    let builder = || {
        let mut b = ChartBuilder::on(&body);
        b.margin_left(10).margin_right(30).margin_top(10).margin_bottom(10);
        b.x_label_area_size(70).y_label_area_size(110);
        b
    };

    // Work out the data ranges. For equal axes this needs the plotting area's
    // size, which a throw-away layout (nothing is drawn without a caption)
    // gives exactly.
    let (x_range, y_range) = if chart.equal_axes {
        let probe = builder().build_cartesian_2d(0.0..1.0, 0.0..1.0).map_err(|e| e.to_string())?;
        let dim = probe.plotting_area().dim_in_pixel();
        equalize(pad(x_data, PAD_FRACTION), pad(y_data, PAD_FRACTION), dim)
    } else {
        // Time-like x axes end exactly at the data; only a zero range is widened.
        let x = if x_data.end > x_data.start { x_data } else { pad(x_data, 0.0) };
        (x, pad(y_data, PAD_FRACTION))
    };
    for (axis, r) in [("x", &x_range), (y_axis_name(chart), &y_range)] {
        check_range(&chart.title, axis, r, undrawable_axis).map_err(Failed::Range)?;
    }

    if chart.log_y {
        let mut ctx = builder().build_cartesian_2d(x_range, LogDecadeAxis::new(y_range)).map_err(|e| e.to_string())?;
        draw_contents(&mut ctx, chart, lines)?;
    } else {
        let mut ctx = builder().build_cartesian_2d(x_range, y_range).map_err(|e| e.to_string())?;
        draw_contents(&mut ctx, chart, lines)?;
    }
    root.present().map_err(|e| e.to_string())?;
    Ok(())
}

/// Padding inside the legend box in pixels.
const LEGEND_MARGIN: u32 = 12;
/// Width reserved for a legend entry's sample line, in pixels.
const LEGEND_SAMPLE: u32 = 42;

/// The plot corner whose legend box would cover the fewest line segments
/// (upper right, then upper left, lower right, lower left on ties).
fn legend_corner<'a, Y>(
    ctx: &ChartContext<'a, BitMapBackend<'a>, Cartesian2d<RangedCoordf64, Y>>,
    lines: &[Line<'_>],
) -> SeriesLabelPosition
where
    Y: Ranged<ValueType = f64>,
{
    let area = ctx.plotting_area();
    let font = TextStyle::from((FONT, LABEL_SIZE).into_font());
    let labels = lines.iter().filter(|l| !l.label.is_empty());
    let text_w = labels.clone().filter_map(|l| area.estimate_text_size(l.label, &font).ok()).map(|(w, _)| w).max();
    // Same layout as plotters' legend: 5 px from the corner, `margin` inside,
    // lines about 1.25 x the font size apart.
    let w = (text_w.unwrap_or(0) + LEGEND_SAMPLE + 2 * LEGEND_MARGIN) as i32;
    let h = (labels.count() as f64 * 1.25 * f64::from(LABEL_SIZE)) as i32 + 2 * LEGEND_MARGIN as i32;
    let (xr, yr) = area.get_pixel_range();
    let (left, right) = (xr.start + 5, xr.end - 5 - w);
    let (top, bottom) = (yr.start + 5, yr.end - 5 - h);
    let corners = [
        (SeriesLabelPosition::UpperRight, right, top),
        (SeriesLabelPosition::UpperLeft, left, top),
        (SeriesLabelPosition::LowerRight, right, bottom),
        (SeriesLabelPosition::LowerLeft, left, bottom),
    ];
    let pixels: Vec<Vec<(f64, f64)>> = lines
        .iter()
        .flat_map(|l| &l.pieces)
        .map(|piece| {
            piece
                .iter()
                .map(|p| {
                    let (x, y) = ctx.backend_coord(p);
                    (f64::from(x), f64::from(y))
                })
                .collect()
        })
        .collect();
    corners
        .into_iter()
        .min_by_key(|&(_, x0, y0)| {
            let rect = (f64::from(x0), f64::from(y0), f64::from(x0 + w), f64::from(y0 + h));
            pixels
                .iter()
                .map(|piece| match piece.as_slice() {
                    [p] => usize::from(segment_hits_rect(*p, *p, rect)),
                    _ => piece.windows(2).filter(|s| segment_hits_rect(s[0], s[1], rect)).count(),
                })
                .sum::<usize>()
        })
        .map_or(SeriesLabelPosition::UpperRight, |(pos, _, _)| pos)
}

/// Whether the segment `a`-`b` touches the axis-aligned rectangle
/// `(x0, y0, x1, y1)` (Liang-Barsky clipping).
fn segment_hits_rect(a: (f64, f64), b: (f64, f64), (x0, y0, x1, y1): (f64, f64, f64, f64)) -> bool {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [(-dx, a.0 - x0), (dx, x1 - a.0), (-dy, a.1 - y0), (dy, y1 - a.1)] {
        if p == 0.0 {
            if q < 0.0 {
                return false;
            }
        } else {
            let t = q / p;
            if p < 0.0 {
                t0 = t0.max(t);
            } else {
                t1 = t1.min(t);
            }
            if t0 > t1 {
                return false;
            }
        }
    }
    true
}

/// Pixels by which `ab_glyph` text of font size `size` renders above
/// plotters' layout (see [`AB_GLYPH_RISE`]).
fn rise(size: u32) -> i32 {
    (AB_GLYPH_RISE * f64::from(size)).round() as i32
}

/// Draw grid, axes, the series and the legend into an already laid-out chart.
fn draw_contents<'a, Y>(
    ctx: &mut ChartContext<'a, BitMapBackend<'a>, Cartesian2d<RangedCoordf64, Y>>,
    chart: &Chart,
    lines: &[Line<'_>],
) -> Result<(), String>
where
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    let grid_light = RGBColor(235, 235, 235);
    let grid_bold = RGBColor(200, 200, 200);
    let mut mesh = ctx.configure_mesh();
    mesh.x_desc(chart.x_label.as_str())
        .y_desc(chart.y_label.as_str())
        .axis_desc_style((FONT, DESC_SIZE))
        .label_style((FONT, LABEL_SIZE))
        .y_label_offset(rise(LABEL_SIZE))
        .x_labels(12)
        .y_labels(10)
        .light_line_style(grid_light)
        .bold_line_style(grid_bold);
    mesh.draw().map_err(|e| e.to_string())?;

    let mut any_label = false;
    for (i, line) in lines.iter().enumerate() {
        let color = PALETTE[i % PALETTE.len()];
        // plotters joins thick polyline segments with mitres, which spike far
        // beyond the data where a noisy series (a residual on a log axis)
        // reverses direction sharply; such charts are drawn 1 px wide.
        let style = color.stroke_width(if chart.log_y { 1 } else { LINE_WIDTH });
        for piece in &line.pieces {
            if let [p] = piece.as_slice() {
                ctx.draw_series(std::iter::once(Circle::new(*p, 3, color.filled()))).map_err(|e| e.to_string())?;
            } else {
                ctx.draw_series(LineSeries::new(piece.iter().copied(), style)).map_err(|e| e.to_string())?;
            }
        }
        if !line.label.is_empty() {
            any_label = true;
            // An empty series carries the legend entry, so a line that is
            // broken into pieces (or has no drawable point) is listed once.
            ctx.draw_series(LineSeries::new(std::iter::empty(), style))
                .map_err(|e| e.to_string())?
                .label(line.label)
                .legend(move |(x, y)| {
                    // Raise the sample line to the text's visual centre.
                    let y = y - rise(LABEL_SIZE);
                    PathElement::new(vec![(x, y), (x + 30, y)], style)
                });
        }
    }
    if any_label {
        let position = legend_corner(ctx, lines);
        ctx.configure_series_labels()
            .position(position)
            .margin(LEGEND_MARGIN)
            .legend_area_size(LEGEND_SAMPLE)
            .label_font((FONT, LABEL_SIZE))
            .background_style(WHITE.filled())
            .border_style(BLACK)
            .draw()
            .map_err(|e| e.to_string())?;
    }
    Ok(())
}

/// A heat map: a value per point of a grid of two parameters, drawn as
/// coloured cells (viridis, dark for low) with a colour bar.
#[derive(Debug, Clone, PartialEq)]
pub struct HeatMap {
    /// Title drawn above the map.
    pub title: String,
    /// Label of the x axis (the first parameter), with unit.
    pub x_label: String,
    /// Label of the y axis (the second parameter), with unit.
    pub y_label: String,
    /// Label of the colour bar (the value), with unit.
    pub value_label: String,
    /// The x values, ascending (cell centres).
    pub xs: Vec<f64>,
    /// The y values, ascending (cell centres).
    pub ys: Vec<f64>,
    /// `values[ix * ys.len() + iy]`; a value that is not finite (a failed
    /// run) is drawn as a grey cell.
    pub values: Vec<f64>,
}

/// Cell edges around ascending centres: midway between neighbours, half a
/// spacing beyond the ends.
fn cell_edges(c: &[f64]) -> Vec<f64> {
    if c.len() == 1 {
        let m = if c[0] == 0.0 { 0.5 } else { 0.05 * c[0].abs() };
        return vec![c[0] - m, c[0] + m];
    }
    let mut e = Vec::with_capacity(c.len() + 1);
    e.push(c[0] - 0.5 * (c[1] - c[0]));
    e.extend(c.windows(2).map(|w| 0.5 * (w[0] + w[1])));
    e.push(c[c.len() - 1] + 0.5 * (c[c.len() - 1] - c[c.len() - 2]));
    e
}

/// Render `map` as a 1200 x 800 PNG, returned as the file's bytes.
///
/// # Errors
/// [`PlotError::Empty`] if no value is finite or the grid is empty or not
/// ascending, [`PlotError::Range`] for values beyond [`MAX_MAGNITUDE`],
/// [`PlotError::Font`], [`PlotError::Draw`] as for [`png`].
pub fn heatmap_png(map: &HeatMap) -> Result<Vec<u8>, PlotError> {
    let ascending = |v: &[f64]| !v.is_empty() && v.windows(2).all(|w| w[0] < w[1]) && v.iter().all(|x| x.is_finite());
    let finite: Vec<f64> = map.values.iter().copied().filter(|v| v.is_finite()).collect();
    if !ascending(&map.xs)
        || !ascending(&map.ys)
        || map.values.len() != map.xs.len() * map.ys.len()
        || finite.is_empty()
    {
        return Err(PlotError::Empty { title: map.title.clone() });
    }
    let lo = finite.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = finite.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let (xe, ye) = (cell_edges(&map.xs), cell_edges(&map.ys));
    for (axis, r) in [("x", xe[0]..xe[xe.len() - 1]), ("y", ye[0]..ye[ye.len() - 1]), ("value", lo..hi)] {
        check_range(&map.title, axis, &r, undrawable)?;
    }
    ensure_font()?;
    let draw_error = |message: String| PlotError::Draw { title: map.title.clone(), message };
    let mut pixels = vec![0u8; 3 * WIDTH as usize * HEIGHT as usize];
    {
        let root = BitMapBackend::with_buffer(&mut pixels, (WIDTH, HEIGHT)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| draw_error(e.to_string()))?;
        let title_font = (FONT, TITLE_SIZE, FontStyle::Bold).into_font().color(&BLACK);
        let body = root
            .margin(rise(TITLE_SIZE) + 6, 0, 0, 0)
            .titled(&map.title, title_font)
            .map_err(|e| draw_error(e.to_string()))?;
        let (main, bar) = body.split_horizontally(WIDTH - 190);
        let (span, flat) = if hi > lo { (hi - lo, false) } else { (1.0, true) };
        let colour = |v: f64| -> RGBColor {
            if !v.is_finite() {
                return RGBColor(190, 190, 190);
            }
            let h = if flat { 0.5 } else { ((v - lo) / span) as f32 };
            ViridisRGB::get_color_normalized(h, 0.0, 1.0)
        };
        let mut ctx = ChartBuilder::on(&main)
            .margin_left(10)
            .margin_right(10)
            .margin_top(10)
            .margin_bottom(10)
            .x_label_area_size(70)
            .y_label_area_size(110)
            .build_cartesian_2d(xe[0]..xe[xe.len() - 1], ye[0]..ye[ye.len() - 1])
            .map_err(|e| draw_error(e.to_string()))?;
        ctx.configure_mesh()
            .disable_mesh()
            .x_desc(map.x_label.as_str())
            .y_desc(map.y_label.as_str())
            .axis_desc_style((FONT, DESC_SIZE))
            .label_style((FONT, LABEL_SIZE))
            .y_label_offset(rise(LABEL_SIZE))
            .x_labels(10)
            .y_labels(10)
            .draw()
            .map_err(|e| draw_error(e.to_string()))?;
        let cells = (0..map.xs.len()).flat_map(|i| (0..map.ys.len()).map(move |j| (i, j)));
        ctx.draw_series(cells.map(|(i, j)| {
            Rectangle::new([(xe[i], ye[j]), (xe[i + 1], ye[j + 1])], colour(map.values[i * map.ys.len() + j]).filled())
        }))
        .map_err(|e| draw_error(e.to_string()))?;
        // the colour bar: 100 bands from lo to hi
        let mut cb = ChartBuilder::on(&bar)
            .margin_left(10)
            .margin_right(40)
            .margin_top(10)
            .margin_bottom(80)
            .y_label_area_size(110)
            .build_cartesian_2d(0.0..1.0, if flat { lo - 0.5..hi + 0.5 } else { lo..hi })
            .map_err(|e| draw_error(e.to_string()))?;
        cb.configure_mesh()
            .disable_mesh()
            .disable_x_axis()
            .y_desc(map.value_label.as_str())
            .axis_desc_style((FONT, DESC_SIZE))
            .label_style((FONT, LABEL_SIZE))
            .y_label_offset(rise(LABEL_SIZE))
            .y_labels(8)
            .draw()
            .map_err(|e| draw_error(e.to_string()))?;
        let (b0, b1) = if flat { (lo - 0.5, hi + 0.5) } else { (lo, hi) };
        cb.draw_series((0..100).map(|k| {
            let (y0, y1) = (b0 + (b1 - b0) * f64::from(k) / 100.0, b0 + (b1 - b0) * f64::from(k + 1) / 100.0);
            Rectangle::new([(0.0, y0), (1.0, y1)], colour(0.5 * (y0 + y1)).filled())
        }))
        .map_err(|e| draw_error(e.to_string()))?;
        root.present().map_err(|e| draw_error(e.to_string()))?;
    }
    let mut bytes = Vec::new();
    image::codecs::png::PngEncoder::new(&mut bytes)
        .write_image(&pixels, WIDTH, HEIGHT, image::ColorType::Rgb8)
        .map_err(|e| draw_error(format!("encoding the PNG: {e}")))?;
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch_dir(name: &str) -> PathBuf {
        let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_nanos());
        let dir = std::env::temp_dir().join(format!("ezy-plot-{name}-{}-{nanos}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("create scratch dir");
        dir
    }

    fn chart(series: Vec<Series>) -> Chart {
        Chart {
            title: "test".into(),
            x_label: "t [s]".into(),
            y_label: "x [m]".into(),
            series,
            equal_axes: false,
            log_y: false,
            log_floor: 1e-16,
        }
    }

    #[test]
    fn renders_png_file() {
        let dir = scratch_dir("render");
        let path = dir.join("small.png");
        let c = chart(vec![
            Series { label: "ramp".into(), points: vec![(0.0, 0.0), (1.0, 2.0), (2.0, 1.0)] },
            Series { label: "constant".into(), points: vec![(0.0, 1.0), (2.0, 1.0)] },
        ]);
        render_png(&c, &path).expect("render");
        let bytes = std::fs::read(&path).expect("read png");
        assert!(bytes.starts_with(&[0x89, b'P', b'N', b'G', 0x0D, 0x0A, 0x1A, 0x0A]));
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1, "temporary file left behind");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn empty_chart_is_an_error() {
        let dir = scratch_dir("empty");
        let path = dir.join("empty.png");
        let c = chart(vec![Series { label: "a".into(), points: vec![] }, Series { label: "b".into(), points: vec![] }]);
        assert!(matches!(render_png(&c, &path), Err(PlotError::Empty { .. })));
        assert!(!path.exists());
        let none = chart(vec![]);
        assert!(matches!(render_png(&none, &path), Err(PlotError::Empty { .. })));
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn undrawable_ranges_are_refused_before_drawing() {
        for (x, y) in [(1e101, 0.0), (0.0, -1e300), (0.0, 1.7e308), (0.0, f64::MAX)] {
            let c = chart(vec![Series { label: "a".into(), points: vec![(0.0, 0.0), (x, y)] }]);
            let t = std::time::Instant::now();
            assert!(matches!(png(&c), Err(PlotError::Range { .. })), "{x} {y}");
            assert!(t.elapsed().as_secs_f64() < 1.0);
        }
        // tiny spans at any magnitude are drawn (a conserved energy)
        let c = chart(vec![Series { label: "T".into(), points: vec![(0.0, 23.1875), (1.0, 23.1875 + 4e-15)] }]);
        assert!(png(&c).is_ok());
        let c = chart(vec![Series { label: "a".into(), points: vec![(0.0, 1e100), (1.0, -1e100)] }]);
        assert!(png(&c).is_ok());
    }

    #[test]
    fn a_drawing_that_takes_too_long_is_given_up() {
        let c = chart(vec![Series { label: "a".into(), points: vec![(0.0, 0.0), (1.0, 1.0)] }]);
        assert!(matches!(png_within(&c, std::time::Duration::ZERO), Err(PlotError::Timeout { .. })));
    }
}
