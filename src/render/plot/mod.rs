//! Figures for the CLI: line charts, stacked panels, paths in the plane and
//! heat maps, as SVG, PNG or PDF.
//!
//! Every figure is drawn once, as SVG, with plotters' SVG backend
//! ([`chart_svg`], or a heat map's); [`encode`] turns that SVG into the
//! requested [`FigureFormat`]: the SVG itself; an anti-aliased PNG at any
//! resolution, rasterized by `resvg` (the renderer of the linebender
//! project, pure Rust); or a vector PDF, converted by `svg2pdf` (Typst's
//! converter, pure Rust, text as glyph outlines). Text is DejaVu Sans,
//! embedded from the `dejavu` crate for layout and rasterization, so no
//! system font, fontconfig or freetype is needed at build or run time.
//!
//! A figure is 960 x 640 CSS pixels (10 x 6.67 inches at 96 dpi). It is
//! drawn on a canvas of twice that many units (`SCALE`) so that lines,
//! dashes and markers sit on half-pixel positions, and the SVG's `width`
//! and `height` give the nominal size.
//!
//! Readability rules applied to every chart (see [`Chart`]): a series
//! that runs on top of an earlier one is drawn dashed (then dotted,
//! dash-dotted) with hollow markers, so neither hides the other; paths get
//! a start and an end marker, so a point that never moves still shows;
//! a chart of points alone (eigenvalues) is padded on both axes, so no
//! marker sits on the frame, and a point that falls on an earlier
//! series' marker is drawn as a ring around it, so neither hides the other;
//! the legend goes to the corner where it covers the fewest line segments;
//! logarithmic axes are true decades on either axis, labelled `10⁻⁶`;
//! a tick label never reads `-0`.
//!
//! [`chart_svg`] checks the data ranges before drawing anything (a range
//! plotters cannot draw is refused, see [`undrawable`]) and draws on a
//! worker thread with a time limit ([`DRAW_TIMEOUT`]).

//!
//! The module's files, by what they hold: `series` (the [`Chart`] as
//! data: its series and their strokes), `chart` (its drawing), `axis`
//! (linear and logarithmic axes, the ranges' padding, the drawing areas),
//! `lines` (a series as drawn: its pieces, dash, markers, the points the
//! drawing needs), `legend`, `heat_map`, `snap` (lines and rectangles on
//! whole pixels) and `raster` (PNG and PDF from the SVG).

pub(crate) mod axis;
pub(crate) mod chart;
pub(crate) mod heat_map;
mod legend;
mod lines;
pub(crate) mod raster;
pub(crate) mod series;
pub(crate) mod snap;
#[cfg(test)]
mod tests;

use std::ops::Range;
use std::sync::OnceLock;

pub use ezy_scene::FigureFormat;
use plotters::prelude::*;
use plotters::style::FontStyle;

// what users of the crate draw with (the code of the crate names each
// item in the module that defines it)
pub use chart::chart_svg;
pub use raster::encode;
pub use series::{Chart, Series, Stroke};

/// Nominal width of a figure \[CSS px\] (10 inches at 96 dpi).
pub(crate) const WIDTH: u32 = 960;
/// Nominal height of a figure \[CSS px\].
pub(crate) const HEIGHT: u32 = 640;
/// Drawing units per nominal pixel: the canvas is `SCALE` times the
/// nominal size, so integer drawing coordinates are half-pixel positions.
pub(crate) const SCALE: u32 = 2;
/// Font family name the embedded DejaVu Sans is registered under.
const FONT: &str = "sans-serif";
/// The family name resvg knows the embedded font by.
const FONT_NAME: &str = "DejaVu Sans";
/// Width of every series line \[canvas units\].
const LINE_WIDTH: u32 = 2 * SCALE;
/// Font sizes [canvas units, plotters' convention: the SVG font size is
/// 1/1.24 of it]: title, axis descriptions, tick labels and legend.
const TITLE_SIZE: u32 = 28 * SCALE;
const DESC_SIZE: u32 = 24 * SCALE;
const LABEL_SIZE: u32 = 20 * SCALE;
/// Fraction of the data range added on each side of the y axis (and of both
/// axes for equal-axes charts).
const PAD_FRACTION: f64 = 0.05;
/// Dash and gap lengths \[canvas units\] of the line styles after solid.
const DASHES: [(u32, u32); 3] = [(14 * SCALE, 7 * SCALE), (3 * SCALE, 5 * SCALE), (22 * SCALE, 6 * SCALE)];
/// Markers drawn along a dashed series (hollow, in the series' colour).
const MARKERS_PER_SERIES: usize = 14;

/// Series colours, cycled when a chart has more series than entries
/// (the "tab10" palette: distinct and readable on white).
pub const PALETTE: [RGBColor; 10] = [
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

/// Why a chart could not be rendered.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The chart has no drawable point: every series (of a panel) is empty
    /// or holds only non-finite values.
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
    /// The figure format's encoder is not in this build: PDF output is the
    /// `pdf` feature (on by default; some 10 s of a fresh build's CPU
    /// time for svg2pdf and pdf-writer).
    #[error(
        "{format} figures need ezy's `{feature}` feature, which this build of ezy leaves out (it is on by default; a crate that depends on ezy with default-features = false adds features = [\"{feature}\"])"
    )]
    Unavailable {
        /// The format asked for (`pdf`).
        format: &'static str,
        /// The feature that provides it.
        feature: &'static str,
    },
    /// plotters failed while drawing, or the SVG could not be converted.
    #[error("chart {title:?}: {message}")]
    Draw {
        /// Title of the offending chart.
        title: String,
        /// plotters' (or the converter's) description of the failure.
        message: String,
    },
    /// A data range that cannot be drawn (see [`undrawable`]); nothing was
    /// drawn.
    #[error("chart {title:?}: the {axis} values from {start:e} to {end:e} cannot be plotted: {value:e} {reason}")]
    Range {
        /// Title of the offending chart.
        title: String,
        /// `"x"`, `"y"`, `"log10 x"` or `"log10 y"`.
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
    /// A PNG resolution outside [`ezy_scene::MIN_DPI`]..=[`ezy_scene::MAX_DPI`].
    #[error("a PNG resolution of {dpi} dpi is outside {}..={} dpi", ezy_scene::MIN_DPI, ezy_scene::MAX_DPI)]
    Dpi {
        /// The rejected resolution.
        dpi: f64,
    },
    /// Drawing took longer than [`DRAW_TIMEOUT`] and was given up.
    #[error("chart {title:?}: drawing did not finish within {seconds} s and was given up")]
    Timeout {
        /// Title of the offending chart.
        title: String,
        /// The limit in seconds.
        seconds: f64,
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

/// `chart` in `format` (PNG at `dpi`), returned as the file's bytes:
/// [`chart_svg`] then [`encode`].
///
/// # Errors
/// As [`chart_svg`] and [`encode`].
pub fn figure(chart: &Chart, format: FigureFormat, dpi: f64) -> Result<Vec<u8>, PlotError> {
    check_dpi(dpi)?;
    check_format(format)?;
    encode(&chart_svg(chart)?, format, dpi, &chart.title)
}

/// [`PlotError::Dpi`] for a resolution out of range.
fn check_dpi(dpi: f64) -> Result<(), PlotError> {
    if (ezy_scene::MIN_DPI..=ezy_scene::MAX_DPI).contains(&dpi) { Ok(()) } else { Err(PlotError::Dpi { dpi }) }
}

/// Whether this build writes PDF figures (ezy's `pdf` feature, on by
/// default).
pub const PDF: bool = cfg!(feature = "pdf");

/// Whether [`encode`] can write `format` in this build: every format but
/// PDF always, PDF with the `pdf` feature ([`PDF`]). What a command asks
/// before any work.
///
/// # Errors
/// [`PlotError::Unavailable`] for PDF without the `pdf` feature.
pub fn check_format(format: FigureFormat) -> Result<(), PlotError> {
    match format {
        FigureFormat::Pdf if !PDF => Err(PlotError::Unavailable { format: "pdf", feature: "pdf" }),
        _ => Ok(()),
    }
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
/// per process: plotters measures text with it to lay the chart out.
fn ensure_font() -> Result<(), PlotError> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        let regular = plotters::style::register_font(FONT, FontStyle::Normal, dejavu::sans::regular());
        let bold = plotters::style::register_font(FONT, FontStyle::Bold, dejavu::sans::bold());
        regular.is_ok() && bold.is_ok()
    });
    if ok { Ok(()) } else { Err(PlotError::Font) }
}

/// The title font.
fn title_font() -> TextStyle<'static> {
    // `FontDesc::style` keeps the already loaded glyph data, so the bold
    // face must be chosen when the font is created.
    (FONT, TITLE_SIZE, FontStyle::Bold).into_font().color(&BLACK)
}
