//! Figures for the CLI: line charts, stacked panels, paths in the plane and
//! heat maps, as SVG, PNG or PDF.
//!
//! Every figure is drawn once, as SVG, with plotters' SVG backend
//! ([`chart_svg`], [`heatmap_svg`]); [`encode`] turns that SVG into the
//! requested [`FigureFormat`]: the SVG itself; an anti-aliased PNG at any
//! resolution, rasterized by `resvg` (the renderer of the linebender
//! project, pure Rust); or a vector PDF, converted by `svg2pdf` (Typst's
//! converter, pure Rust, text as glyph outlines). Text is DejaVu Sans,
//! embedded from the `dejavu` crate for layout and rasterization, so no
//! system font, fontconfig or freetype is needed at build or run time.
//!
//! A figure is 960 x 640 CSS pixels (10 x 6.67 inches at 96 dpi). It is
//! drawn on a canvas of twice that many units ([`SCALE`]) so that lines,
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

use std::ops::Range;
use std::sync::OnceLock;

pub use ezy_scene::FigureFormat;
use plotters::coord::ranged1d::{KeyPointHint, NoDefaultFormatting, Ranged, ValueFormatter};
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use plotters::style::FontStyle;

/// Nominal width of a figure \[CSS px\] (10 inches at 96 dpi).
pub const WIDTH: u32 = 960;
/// Nominal height of a figure \[CSS px\].
pub const HEIGHT: u32 = 640;
/// Drawing units per nominal pixel: the canvas is `SCALE` times the
/// nominal size, so integer drawing coordinates are half-pixel positions.
pub const SCALE: u32 = 2;
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
    /// Colour: an index into [`PALETTE`] (`None`: the series' own index).
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
    /// The lines to draw, coloured in order from [`PALETTE`].
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

/// Turns an SVG drawn by this module into `format`: the SVG text itself,
/// a PNG of `WIDTH x HEIGHT x dpi / 96` pixels (anti-aliased, white
/// background, rasterized by resvg with the embedded DejaVu Sans) or a
/// one-page PDF of `WIDTH x HEIGHT` points at 96 dpi (svg2pdf, text as
/// glyph outlines). `title` names the figure in errors.
///
/// # Errors
/// [`PlotError::Dpi`] for a resolution out of range,
/// [`PlotError::Unavailable`] for PDF in a build without the `pdf`
/// feature, [`PlotError::Draw`] if the SVG cannot be parsed or converted.
pub fn encode(svg: &str, format: FigureFormat, dpi: f64, title: &str) -> Result<Vec<u8>, PlotError> {
    check_dpi(dpi)?;
    check_format(format)?;
    let fail = |message: String| PlotError::Draw { title: title.into(), message };
    if format == FigureFormat::Svg {
        return Ok(svg.as_bytes().to_vec());
    }
    // the raster starts white: its white background is not drawn again
    let svg = if format == FigureFormat::Png {
        std::borrow::Cow::Owned(for_raster(&without_white_background(svg), dpi))
    } else {
        std::borrow::Cow::Borrowed(svg)
    };
    let tree = resvg::usvg::Tree::from_str(&svg, svg_options()).map_err(|e| fail(format!("reading the SVG: {e}")))?;
    match format {
        FigureFormat::Svg => unreachable!("returned above"),
        FigureFormat::Png => {
            // opaque on white: RGB, a quarter smaller than tiny-skia's RGBA
            let p = raster(&tree, dpi)?;
            let (width, height) = (p.width(), p.height());
            let rgb = rgb_in_place(p.take());
            // fast compression (fdeflate) after the Paeth filter on every
            // row: 8 % faster than choosing the filter row by row, the
            // files 8 % larger (see the guide's performance chapter)
            let mut bytes = Vec::new();
            let mut encoder = png::Encoder::new(&mut bytes, width, height);
            encoder.set_color(png::ColorType::Rgb);
            encoder.set_depth(png::BitDepth::Eight);
            encoder.set_compression(png::Compression::Fast);
            encoder.set_filter(png::FilterType::Paeth);
            encoder
                .write_header()
                .and_then(|mut writer| writer.write_image_data(&rgb))
                .map_err(|e| fail(format!("encoding the PNG: {e}")))?;
            recycle_canvas(rgb);
            Ok(bytes)
        }
        FigureFormat::Pdf => pdf(&tree).map_err(fail),
    }
}

/// `svg` without the opaque white rectangle over its whole canvas that
/// plotters draws first (`root.fill(&WHITE)`), if it has one: a raster
/// already starts white (0.3 ms of a simple figure's 5.5 ms).
fn without_white_background(svg: &str) -> std::borrow::Cow<'_, str> {
    let Some(start) = svg.find("\n<rect ").map(|at| at + 1) else { return std::borrow::Cow::Borrowed(svg) };
    let end = svg[start..].find('\n').map_or(svg.len(), |at| start + at + 1);
    let rect = &svg[start..end];
    let (w, h) = ((WIDTH * SCALE).to_string(), (HEIGHT * SCALE).to_string());
    let whole = [("x", "0"), ("y", "0"), ("width", w.as_str()), ("height", h.as_str()), ("fill", "#FFFFFF")]
        .iter()
        .all(|(name, value)| attribute(rect, name) == Some(value))
        && opaque_fill_only(rect);
    // only plotters' first element: nothing is drawn before it
    if whole && svg[..start].matches('<').count() == 1 {
        std::borrow::Cow::Owned(format!("{}{}", &svg[..start], &svg[end..]))
    } else {
        std::borrow::Cow::Borrowed(svg)
    }
}

/// An SVG drawn by this module, ready to rasterize at `dpi`: its thin
/// lines along an axis snapped ([`snap`] with [`Snap::Lines`]), each a
/// pixel wide on a pixel's centre ([`one_pixel_crisp_lines`]).
fn for_raster(svg: &str, dpi: f64) -> String {
    one_pixel_crisp_lines(&snap(svg, Snap::Lines), dpi)
}

/// `svg` for a raster at `dpi`: every line drawn without anti-aliasing
/// ([`snap`]) that is narrower than a pixel there made
/// one pixel wide and moved onto the centre of the pixel column (or row)
/// it lies in. The rasterizer paints such a line on the pixels whose
/// centres it covers, and a line of one drawing unit (0.75 px at 144 dpi,
/// 0.5 px at 96 dpi) centred on a pixel's edge covers none: at 144 dpi
/// every grid line and tick mark at a multiple of 4 units was missing,
/// a quarter of them, at 96 dpi half. One pixel wide on a pixel's centre,
/// a line covers that pixel and no other (its edges on pixel edges, far
/// from the centres it could round onto), and the lines that were drawn
/// before are drawn on the same pixels as before. The SVG and PDF
/// figures keep the lines as they were drawn.
fn one_pixel_crisp_lines(svg: &str, dpi: f64) -> String {
    // pixels per drawing unit at `dpi` (the canvas is SCALE units a
    // nominal pixel, and a nominal pixel 1/96 in)
    let s = dpi / (96.0 * f64::from(SCALE));
    let thin = |element: &str| {
        ["<line", "<polyline", "<path"]
            .iter()
            .any(|tag| element.strip_prefix(tag).is_some_and(|r| r.starts_with(CRISP)))
            && attribute(element, "stroke-width").and_then(|w| w.parse::<f64>().ok()).is_some_and(|w| w * s < 1.0)
    };
    let mut out = String::with_capacity(svg.len() + svg.len() / 4);
    for element in svg.split_inclusive('\n') {
        match thin(element).then(|| on_pixel_centres(element, s)).flatten() {
            Some(moved) => out.push_str(&moved),
            None => out.push_str(element),
        }
    }
    out
}

/// A snapped line's geometry attribute (`x1` for a `<line>`'s four),
/// its points \[units\] and its segments (pairs of indices into them).
type Geometry<'a> = (&'a str, Vec<(f64, f64)>, Vec<(usize, usize)>);

/// The thin snapped line `element` (plotters' `<line>` or `<polyline>`,
/// or a `<path>` of [`CrispRun`]) one pixel wide at `s` pixels a unit,
/// each segment along an axis moved across itself onto the centre of
/// the pixel it lies in; `None` if its geometry cannot be read.
fn on_pixel_centres(element: &str, s: f64) -> Option<String> {
    let centre = |v: f64| ((v * s).floor() + 0.5) / s;
    let number = |v: &str| v.trim().parse::<f64>().ok();
    let pair = |p: &str| {
        let (x, y) = p.split_once([',', ' '])?;
        Some((number(x)?, number(y)?))
    };
    // the points, and which of them are segments' ends
    let (attr, mut points, segments): Geometry<'_> = if element.starts_with("<line") {
        let [x1, y1, x2, y2] = ["x1", "y1", "x2", "y2"].map(|a| attribute(element, a).and_then(number));
        ("x1", vec![(x1?, y1?), (x2?, y2?)], vec![(0, 1)])
    } else if element.starts_with("<polyline") {
        let points: Option<Vec<_>> = attribute(element, "points")?.split_whitespace().map(pair).collect();
        let points = points?;
        let n = points.len();
        ("points", points, (1..n).map(|i| (i - 1, i)).collect())
    } else {
        // "M x y L x y" a segment
        let mut points = Vec::new();
        for segment in attribute(element, "d")?.split('M').filter(|p| !p.trim().is_empty()) {
            let (a, b) = segment.split_once('L')?;
            points.extend([pair(a)?, pair(b)?]);
        }
        let n = points.len();
        ("d", points, (0..n / 2).map(|k| (2 * k, 2 * k + 1)).collect())
    };
    let (mut across_x, mut across_y) = (vec![false; points.len()], vec![false; points.len()]);
    for (a, b) in segments {
        if points[a].0 == points[b].0 {
            across_x[a] = true;
            across_x[b] = true;
        }
        if points[a].1 == points[b].1 {
            across_y[a] = true;
            across_y[b] = true;
        }
    }
    for (i, p) in points.iter_mut().enumerate() {
        if across_x[i] {
            p.0 = centre(p.0);
        }
        if across_y[i] {
            p.1 = centre(p.1);
        }
    }
    // the element up to its geometry, which plotters writes last
    let cut = element.find(&format!(" {attr}=\""))?;
    let head = element[..cut].replacen(
        &format!(" stroke-width=\"{}\"", attribute(element, "stroke-width")?),
        &format!(" stroke-width=\"{}\"", 1.0 / s),
        1,
    );
    let geometry = match attr {
        "x1" => {
            let [(x1, y1), (x2, y2)] = [points[0], points[1]];
            format!(" x1=\"{x1}\" y1=\"{y1}\" x2=\"{x2}\" y2=\"{y2}\"")
        }
        "points" => format!(" points=\"{}\"", points.iter().map(|(x, y)| format!("{x},{y} ")).collect::<String>()),
        _ => format!(
            " d=\"{}\"",
            points.chunks(2).map(|ab| format!("M{} {}L{} {}", ab[0].0, ab[0].1, ab[1].0, ab[1].1)).collect::<String>()
        ),
    };
    // what followed the geometry's last attribute (the element's end)
    let last = if attr == "x1" { "y2" } else { attr };
    let from = cut + element[cut..].find(&format!(" {last}=\""))? + last.len() + 3;
    let tail = &element[from + element[from..].find('"')? + 1..];
    Some(format!("{head}{geometry}{tail}"))
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

/// The PDF of `tree`. Its text is first turned into outlines: usvg
/// lays it out with the embedded DejaVu Sans and writes each glyph as a
/// path (`WriteOptions::preserve_text` false), and the SVG read back has
/// no text left. svg2pdf is then built without its `text` feature, whose
/// font subsetter (write-fonts, read-fonts, skrifa) was some 60 s of a
/// fresh build's CPU time. The page looks the same; its text cannot be
/// selected or searched.
#[cfg(feature = "pdf")]
fn pdf(tree: &resvg::usvg::Tree) -> Result<Vec<u8>, String> {
    let tree = outlined(tree)?;
    let page = svg2pdf::PageOptions { dpi: 96.0 };
    svg2pdf::to_pdf(&tree, svg2pdf::ConversionOptions::default(), page).map_err(|e| format!("converting to PDF: {e}"))
}

/// `tree` with every text node replaced by its glyphs' outlines (paths).
#[cfg_attr(not(feature = "pdf"), allow(dead_code))]
fn outlined(tree: &resvg::usvg::Tree) -> Result<resvg::usvg::Tree, String> {
    let svg = tree.to_string(&resvg::usvg::WriteOptions { preserve_text: false, ..Default::default() });
    resvg::usvg::Tree::from_str(&svg, svg_options()).map_err(|e| format!("reading the outlined SVG: {e}"))
}

#[cfg(not(feature = "pdf"))]
fn pdf(_: &resvg::usvg::Tree) -> Result<Vec<u8>, String> {
    // check_format refuses PDF before this is reached
    Err("PDF output needs ezy's `pdf` feature".into())
}

/// RGBA bytes made RGB by dropping every fourth byte, in the same buffer
/// (the pixel `i`'s three bytes move to `3 i`, never past where they were
/// read).
fn rgb_in_place(mut rgba: Vec<u8>) -> Vec<u8> {
    /// Pixels moved at a time once a block's target ends before its
    /// source begins (from pixel `3 BLOCK` on): disjoint slices, which
    /// the compiler turns into straight copies without bounds checks.
    const BLOCK: usize = 64;
    let pixels = rgba.len() / 4;
    let mut i = 0;
    while i < pixels {
        if i >= 3 * BLOCK && i + BLOCK <= pixels {
            let (head, tail) = rgba.split_at_mut(4 * i);
            let to = &mut head[3 * i..3 * (i + BLOCK)];
            for (d, s) in to.chunks_exact_mut(3).zip(tail[..4 * BLOCK].chunks_exact(4)) {
                d.copy_from_slice(&s[..3]);
            }
            i += BLOCK;
        } else {
            let (r, g, b) = (rgba[4 * i], rgba[4 * i + 1], rgba[4 * i + 2]);
            rgba[3 * i..3 * i + 3].copy_from_slice(&[r, g, b]);
            i += 1;
        }
    }
    rgba.truncate(3 * pixels);
    rgba
}

/// Largest image buffer \[bytes\] kept for a next figure: a 144 dpi
/// figure's is 5.5 MB, the largest allowed `--dpi`'s some 100 MB.
const KEEP_CANVAS: usize = 32 << 20;

/// How many image buffers are kept at most (one per figure-drawing thread).
const KEEP_CANVASES: usize = 4;

/// Image buffers of earlier PNGs, reused by the next ones: a fresh buffer
/// of 5.5 MB is some 1,300 page faults, and a run's figures took 8,500 of
/// them (a sixth of their CPU time). At most [`KEEP_CANVASES`] of at most
/// [`KEEP_CANVAS`] bytes each stay allocated for the life of the process.
static CANVASES: std::sync::Mutex<Vec<Vec<u8>>> = std::sync::Mutex::new(Vec::new());

/// A pool of image buffers: [`CANVASES`], or a test's own.
type Pool = std::sync::Mutex<Vec<Vec<u8>>>;

/// Keeps `buffer` for a next figure's image (see [`CANVASES`]).
fn recycle_canvas(buffer: Vec<u8>) {
    recycle_into(&CANVASES, buffer);
}

/// Keeps `buffer` in `pool` if it is small enough and the pool not full.
fn recycle_into(pool: &Pool, buffer: Vec<u8>) {
    if buffer.capacity() <= KEEP_CANVAS {
        let mut kept = pool.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        if kept.len() < KEEP_CANVASES {
            kept.push(buffer);
        }
    }
}

/// `bytes` of opaque white (premultiplied RGBA), in a kept buffer if
/// there is one.
fn white_canvas(bytes: usize) -> Vec<u8> {
    white_from(&CANVASES, bytes)
}

/// [`white_canvas`] from `pool`.
fn white_from(pool: &Pool, bytes: usize) -> Vec<u8> {
    let kept = pool.lock().unwrap_or_else(std::sync::PoisonError::into_inner).pop();
    let mut data = kept.unwrap_or_default();
    data.clear();
    data.resize(bytes, 255);
    data
}

/// Fills `pool` up to `wanted` buffers (at most [`KEEP_CANVASES`]) of
/// `bytes` each, every page touched. All are made before any is kept:
/// made and kept one at a time, the second was the first taken back
/// out, and a run with two drawing threads kept one buffer where it
/// asked for two (the second thread's first figure then faulted in a
/// fresh 5.5 MB image, some 1,350-1,800 page faults and 5-8 ms).
fn stock(pool: &Pool, wanted: usize, bytes: usize) {
    let have = pool.lock().map_or(0, |kept| kept.len());
    let fresh: Vec<Vec<u8>> = (have..wanted.min(KEEP_CANVASES)).map(|_| vec![255; bytes]).collect();
    for buffer in fresh {
        recycle_into(pool, buffer);
    }
}

/// The image size \[pixels\] of a figure's SVG tree at `dpi`.
fn image_size(width: f32, height: f32, dpi: f64) -> (u32, u32) {
    let s = (dpi / 96.0) as f32;
    (((width * s).round() as u32).max(1), ((height * s).round() as u32).max(1))
}

/// Does, ahead of the figures, the work every figure would otherwise wait
/// for: loads the embedded fonts into plotters and into resvg (some 8 ms
/// that the first figure's threads would spend one waiting on the other)
/// and, for PNG figures at `dpi`, makes `canvases` image buffers of
/// `4 x width x height` bytes each (at most 4 are kept, of at most 32 MB
/// each, for the life of the process) and touches their pages. Meant for
/// a thread that runs while the integration does: `ezy run` starts one
/// when it will draw figures. Needs no call: every figure does what is
/// left itself. Returns nothing and cannot fail: what it could not do,
/// the figures do.
pub fn warm_up(format: FigureFormat, dpi: f64, canvases: usize) {
    let _ = ensure_font();
    let _ = svg_options();
    if format != FigureFormat::Png || check_dpi(dpi).is_err() {
        return;
    }
    let (w, h) = image_size(WIDTH as f32, HEIGHT as f32, dpi);
    let bytes = 4 * w as usize * h as usize;
    stock(&CANVASES, canvases, bytes);
}

/// `tree` rasterized at `dpi` on white (the nominal size is at 96 dpi),
/// in a kept image buffer if there is one.
fn raster(tree: &resvg::usvg::Tree, dpi: f64) -> Result<resvg::tiny_skia::Pixmap, PlotError> {
    check_dpi(dpi)?;
    let s = (dpi / 96.0) as f32;
    let (w, h) = image_size(tree.size().width(), tree.size().height(), dpi);
    let no_image = || PlotError::Draw { title: String::new(), message: format!("no {w} x {h} image") };
    let size = resvg::tiny_skia::IntSize::from_wh(w, h).ok_or_else(no_image)?;
    let data = white_canvas(4 * w as usize * h as usize);
    let mut pixmap = resvg::tiny_skia::Pixmap::from_vec(data, size).ok_or_else(no_image)?;
    resvg::render(tree, resvg::tiny_skia::Transform::from_scale(s, s), &mut pixmap.as_mut());
    Ok(pixmap)
}

/// An SVG drawn by this module rasterized at `dpi`, as RGBA bytes with its
/// width and height: frames of an animation.
///
/// # Errors
/// As [`encode`].
pub fn rgba(svg: &str, dpi: f64) -> Result<(u32, u32, Vec<u8>), PlotError> {
    let tree = resvg::usvg::Tree::from_str(&for_raster(svg, dpi), svg_options())
        .map_err(|e| PlotError::Draw { title: String::new(), message: format!("reading the SVG: {e}") })?;
    let p = raster(&tree, dpi)?;
    Ok((p.width(), p.height(), p.take()))
}

/// resvg's options: the embedded DejaVu Sans (regular and bold) as the
/// only font, and as every generic family.
fn svg_options() -> &'static resvg::usvg::Options<'static> {
    static OPTIONS: OnceLock<resvg::usvg::Options<'static>> = OnceLock::new();
    OPTIONS.get_or_init(|| {
        let mut o = resvg::usvg::Options { font_family: FONT_NAME.into(), ..Default::default() };
        let db = o.fontdb_mut();
        db.load_font_data(dejavu::sans::regular().to_vec());
        db.load_font_data(dejavu::sans::bold().to_vec());
        db.set_sans_serif_family(FONT_NAME);
        db.set_serif_family(FONT_NAME);
        db.set_monospace_family(FONT_NAME);
        o
    })
}

/// The SVG plotters wrote for a `SCALE x` canvas, with `width` and
/// `height` set to the nominal size (the `viewBox` keeps the canvas) and
/// its opaque rectangles snapped to the pixel grid ([`snap`]). Its thin
/// lines are left to the viewer's anti-aliasing: a line of one drawing
/// unit is half a pixel wide on a screen at 100 %, and drawn without
/// anti-aliasing it covers no pixel's centre where it is centred on a
/// pixel's edge. A raster snaps them itself ([`for_raster`]).
pub(crate) fn nominal_size(svg: String) -> String {
    let (w, h) = (WIDTH * SCALE, HEIGHT * SCALE);
    let svg =
        svg.replacen(&format!("width=\"{w}\" height=\"{h}\""), &format!("width=\"{WIDTH}\" height=\"{HEIGHT}\""), 1);
    snap(&svg, Snap::Rectangles)
}

/// The attribute [`snap`] marks an element with: drawn on whole pixels,
/// without anti-aliasing.
const CRISP: &str = " shape-rendering=\"crispEdges\"";

/// What [`snap`] marks `shape-rendering="crispEdges"`.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Snap {
    /// Opaque rectangles without a border (the background, a heat map's
    /// cells): in every SVG, so that no viewer shows seams between cells.
    Rectangles,
    /// Solid lines at most one unit wide along an axis (the grid, the
    /// axes, the ticks): for a raster only, made one pixel wide there
    /// ([`one_pixel_crisp_lines`]).
    Lines,
}

/// `svg` with `shape-rendering="crispEdges"` on every opaque rectangle
/// without a border (the background, a heat map's cells) or
/// ([`Snap::Lines`]) on every solid line at most one drawing unit wide
/// whose segments all run along an axis (the grid, the axes and their
/// ticks); an element that already says how it is rendered is left as
/// it is. A renderer draws
/// these on whole pixels without anti-aliasing, as matplotlib snaps its
/// grid, axes and rectangles (`Artist.set_snap`). At the default 144 dpi
/// a unit is 0.75 px, so an anti-aliased grid line was smeared over two
/// pixel columns, and rasterizing a figure's 60-250 of them one pixel at
/// a time, with the background's anti-aliased fill, was a third of a
/// simple figure's PNG time (see the guide's performance chapter). Data
/// lines are thicker than a unit and keep their anti-aliasing. Opaque
/// snapped `<line>`s in a row of one style become one `<path>`
/// ([`CrispRun`]); a raster makes each snapped line one pixel wide
/// ([`one_pixel_crisp_lines`]). Reads the one-element-per-line SVG
/// plotters writes.
fn snap(svg: &str, what: Snap) -> String {
    let mut out = String::with_capacity(svg.len() + 32 * svg.matches("<line ").count());
    // consecutive opaque snapped lines of one style, drawn as one path
    let mut run = CrispRun::default();
    let lines = what == Snap::Lines;
    for line in svg.split_inclusive('\n') {
        let tag = ["<line", "<polyline", "<rect"]
            .into_iter()
            .find(|t| line.starts_with(t) && line[t.len()..].starts_with(' ') && !line.contains(" shape-rendering="));
        match tag {
            Some("<line") if lines && thin_axis_line(line) && run.add(line, &mut out) => {}
            Some(tag)
                if (tag == "<rect" && !lines && opaque_fill_only(line))
                    || (tag != "<rect" && lines && thin_axis_line(line)) =>
            {
                run.flush(&mut out);
                out.push_str(tag);
                out.push_str(CRISP);
                out.push_str(&line[tag.len()..]);
            }
            _ => {
                run.flush(&mut out);
                out.push_str(line);
            }
        }
    }
    run.flush(&mut out);
    out
}

/// Snapped `<line>` elements in a row that share their style, gathered
/// by [`snap`] into one `<path>` of a subpath each: a
/// figure's 60-250 grid lines were as many elements for resvg to read
/// (four fifths of the grid's parsing time) and to paint one by one.
/// Only opaque lines drawn without anti-aliasing are gathered: each
/// pixel is then painted in the one colour whether by one line or by the
/// path, so the image is the same (checked pixel for pixel on a drive
/// run's seven figures).
#[derive(Default)]
struct CrispRun<'a> {
    /// The style the lines share: their element up to their coordinates.
    style: &'a str,
    /// Their segments as path data (`M x1 y1 L x2 y2` each).
    data: String,
    /// The first line, as plotters wrote it.
    first: &'a str,
    /// How many lines.
    count: usize,
}

impl<'a> CrispRun<'a> {
    /// Takes the snapped line `element` (plotters' `<line STYLE x1=..
    /// y1=.. x2=.. y2=../>`) into the run if it can be gathered, writing
    /// a run of another style to `out` first; returns whether it did.
    fn add(&mut self, element: &'a str, out: &mut String) -> bool {
        let Some(at) = element.find(" x1=\"") else { return false };
        let (style, place) = element.split_at(at);
        let opaque = attribute(style, "opacity").is_none_or(|o| o == "1")
            && attribute(style, "stroke-opacity").is_none()
            && attribute(style, "stroke").is_some_and(|c| c.len() == 7 && c.starts_with('#'));
        let [Some(x1), Some(y1), Some(x2), Some(y2)] = ["x1", "y1", "x2", "y2"].map(|name| attribute(place, name))
        else {
            return false;
        };
        if !opaque || place.trim_end() != format!(" x1=\"{x1}\" y1=\"{y1}\" x2=\"{x2}\" y2=\"{y2}\"/>") {
            return false;
        }
        if self.count > 0 && style != self.style {
            self.flush(out);
        }
        if self.count == 0 {
            self.style = style;
            self.first = element;
        }
        self.count += 1;
        use std::fmt::Write;
        let _ = write!(self.data, "M{x1} {y1}L{x2} {y2}");
        true
    }

    /// Writes the run to `out` (one line as it was, more as a path) and
    /// empties it.
    fn flush(&mut self, out: &mut String) {
        match self.count {
            0 => {}
            1 => {
                out.push_str("<line");
                out.push_str(CRISP);
                out.push_str(&self.first["<line".len()..]);
            }
            _ => {
                out.push_str("<path");
                out.push_str(CRISP);
                out.push_str(&self.style["<line".len()..]);
                out.push_str(" fill=\"none\" d=\"");
                out.push_str(&self.data);
                out.push_str("\"/>\n");
            }
        }
        self.count = 0;
        self.data.clear();
    }
}

/// The value of attribute `name` of the SVG element `element`.
fn attribute<'a>(element: &'a str, name: &str) -> Option<&'a str> {
    let mut from = 0;
    while let Some(at) = element[from..].find(name) {
        let start = from + at;
        let rest = &element[start + name.len()..];
        if element[..start].ends_with(' ')
            && let Some(value) = rest.strip_prefix("=\"")
        {
            return value.find('"').map(|end| &value[..end]);
        }
        from = start + name.len();
    }
    None
}

/// Whether the `<rect>` element `element` is filled opaque and not
/// stroked (the background, a heat map's cells): a legend's translucent
/// box and its thin border keep their anti-aliasing.
fn opaque_fill_only(element: &str) -> bool {
    attribute(element, "stroke") == Some("none")
        && attribute(element, "opacity").is_none_or(|o| o == "1")
        && attribute(element, "fill").is_some_and(|f| f != "none")
}

/// Whether the `<line>` or `<polyline>` element `element` is solid, at
/// most one unit wide, and made of horizontal and vertical segments only.
fn thin_axis_line(element: &str) -> bool {
    let thin = attribute(element, "stroke-width").and_then(|w| w.parse::<f64>().ok()).is_some_and(|w| w <= 1.0);
    if !thin || attribute(element, "stroke-dasharray").is_some() {
        return false;
    }
    let same = |a: &str, b: &str| attribute(element, a).is_some_and(|a| Some(a) == attribute(element, b));
    if element.starts_with("<line") {
        return same("x1", "x2") || same("y1", "y2");
    }
    let Some(points) = attribute(element, "points") else { return false };
    let points: Vec<(&str, &str)> = points.split_whitespace().filter_map(|p| p.split_once(',')).collect();
    points.len() >= 2 && points.windows(2).all(|s| s[0].0 == s[1].0 || s[0].1 == s[1].1)
}

/// `chart` as SVG text (see the module documentation for the layout and
/// the readability rules).
///
/// The data ranges are checked before anything is drawn, and the drawing
/// runs on a worker thread given at most [`DRAW_TIMEOUT`].
///
/// # Errors
/// [`PlotError::Empty`] if a panel has no finite point,
/// [`PlotError::InvalidLogFloor`] for a log axis with a bad floor,
/// [`PlotError::Range`] for a range that cannot be drawn (a coordinate
/// beyond [`MAX_MAGNITUDE`]), [`PlotError::Font`] if the embedded font
/// cannot be loaded, [`PlotError::Draw`] if plotters fails and
/// [`PlotError::Timeout`] if drawing takes longer than [`DRAW_TIMEOUT`].
pub fn chart_svg(chart: &Chart) -> Result<String, PlotError> {
    svg_within(chart, DRAW_TIMEOUT)
}

/// A drawing to run on a drawer thread.
type DrawJob = Box<dyn FnOnce() + Send>;

thread_local! {
    /// The thread that draws this thread's charts ([`on_drawer`]), kept
    /// between charts: a new thread for every chart was a fresh stack and
    /// allocator arena to fault in each time. Ends when this thread does
    /// (its queue closes); replaced after a drawing that timed out.
    static DRAWER: std::cell::RefCell<Option<std::sync::mpsc::Sender<DrawJob>>> =
        const { std::cell::RefCell::new(None) };
}

/// Runs `job` on this thread's drawer (an `ezy-plot` thread), started
/// on first use or after the last one was given up.
fn on_drawer(job: DrawJob) -> std::io::Result<()> {
    DRAWER.with_borrow_mut(|drawer| {
        let job = match drawer.as_ref() {
            Some(d) => match d.send(job) {
                Ok(()) => return Ok(()),
                // the drawer ended (a panic in plotters): a new one
                Err(std::sync::mpsc::SendError(job)) => job,
            },
            None => job,
        };
        let (send, queue) = std::sync::mpsc::channel::<DrawJob>();
        std::thread::Builder::new().name("ezy-plot".into()).spawn(move || {
            for job in queue {
                job();
            }
        })?;
        // the new thread holds the queue: this cannot fail
        let _ = send.send(job);
        *drawer = Some(send);
        Ok(())
    })
}

/// [`chart_svg`] with a given time limit.
fn svg_within(chart: &Chart, limit: std::time::Duration) -> Result<String, PlotError> {
    if chart.log_y && !(chart.log_floor.is_finite() && chart.log_floor > 0.0) {
        return Err(PlotError::InvalidLogFloor { title: chart.title.clone(), floor: chart.log_floor });
    }
    ensure_font()?;
    let draw_error = |message| PlotError::Draw { title: chart.title.clone(), message };
    // The worker owns a copy of the chart: if it never returns, the caller
    // still does (and the process ends it on exit).
    let owned = chart.clone();
    let (tx, rx) = std::sync::mpsc::channel();
    on_drawer(Box::new(move || {
        let _ = tx.send(checked_and_drawn(&owned));
    }))
    .map_err(|e| draw_error(format!("cannot start the drawing thread: {e}")))?;
    match rx.recv_timeout(limit) {
        Ok(r) => r,
        Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {
            // the drawer is busy for good: the next chart gets a new one
            DRAWER.with_borrow_mut(|d| *d = None);
            Err(PlotError::Timeout { title: chart.title.clone(), seconds: limit.as_secs_f64() })
        }
        Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
            Err(draw_error("plotters panicked while drawing".into()))
        }
    }
}

/// `chart`'s lines and ranges, checked, then drawn (on the drawer: the
/// lines are made once, 0.1-1 ms of a figure's drawing, where they were
/// made again after the caller's checks). Values plotters cannot draw are
/// refused before anything is drawn; `draw` checks the padded ranges
/// again.
///
/// # Errors
/// [`PlotError::Empty`] for a panel without a drawable point,
/// [`PlotError::Range`] for a range that cannot be drawn, and `draw`'s.
fn checked_and_drawn(chart: &Chart) -> Result<String, PlotError> {
    let lines = chart_lines(chart);
    let (x, ys) = bounds(chart, &lines)?;
    check_range(&chart.title, x_axis_name(chart), &x, undrawable)?;
    for y in &ys {
        check_range(&chart.title, y_axis_name(chart), y, undrawable)?;
    }
    draw(chart, &lines, x, ys)
}

/// The x range over all lines and the y range of each panel.
///
/// # Errors
/// [`PlotError::Empty`] if a panel has no drawable point.
fn bounds(chart: &Chart, lines: &[Line<'_>]) -> Result<(Range<f64>, Vec<Range<f64>>), PlotError> {
    let empty = || PlotError::Empty { title: chart.title.clone() };
    let (x, _) = data_bounds(lines.iter()).ok_or_else(empty)?;
    let ys = (0..panels(chart))
        .map(|p| data_bounds(lines.iter().filter(|l| l.panel == p)).map(|(_, y)| y).ok_or_else(empty))
        .collect::<Result<_, _>>()?;
    Ok((x, ys))
}

/// Number of panels: 2 with a lower panel, else 1.
fn panels(chart: &Chart) -> usize {
    if chart.lower.is_some() { 2 } else { 1 }
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

/// `"x"`, or `"log10 x"` for a logarithmic x axis.
fn x_axis_name(chart: &Chart) -> &'static str {
    if chart.log_x { "log10 x" } else { "x" }
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

/// One series prepared for drawing: its drawable pieces in plot coordinates
/// (`log10` of the value on a log axis) and its resolved style.
struct Line<'a> {
    /// Legend text (empty: no legend entry).
    label: &'a str,
    /// Maximal runs of consecutive drawable points.
    pieces: Vec<Vec<(f64, f64)>>,
    /// Panel index.
    panel: usize,
    /// Colour.
    color: RGBColor,
    /// `None`: solid; `Some(k)`: dash style `k` of [`DASHES`], with markers.
    dash: Option<usize>,
    /// Markers only, no line ([`Stroke::Points`]).
    points_only: bool,
}

/// Split every series into runs of drawable points in plot coordinates
/// and resolve [`Stroke::Auto`].
fn chart_lines(chart: &Chart) -> Vec<Line<'_>> {
    let floor_log = chart.log_floor.log10();
    let mut lines: Vec<Line<'_>> = chart
        .series
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let mut pieces: Vec<Vec<(f64, f64)>> = Vec::new();
            let mut current = Vec::new();
            for &(x, y) in &s.points {
                // a log x axis cannot show values <= 0 (NaN breaks the line)
                let x = if chart.log_x { if x > 0.0 { x.log10() } else { f64::NAN } } else { x };
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
            let dash = match s.stroke {
                Stroke::Dash(k) => Some(k % DASHES.len()),
                Stroke::Auto | Stroke::Solid | Stroke::Points => None,
            };
            Line {
                label: &s.label,
                pieces,
                panel: s.panel.min(panels(chart) - 1),
                color: PALETTE[s.color.unwrap_or(i) % PALETTE.len()],
                dash,
                points_only: s.stroke == Stroke::Points,
            }
        })
        .collect();
    // a series on top of earlier ones of its panel takes the next dash style
    let spans: Vec<(f64, f64)> = (0..panels(chart))
        .map(|p| {
            data_bounds(lines.iter().filter(|l| l.panel == p))
                .map_or((0.0, 0.0), |(x, y)| (x.end - x.start, y.end - y.start))
        })
        .collect();
    for j in 0..lines.len() {
        if chart.series[j].stroke != Stroke::Auto {
            continue;
        }
        let test = if chart.equal_axes { path_overlaps } else { overlaps };
        let under: Vec<Option<usize>> = (0..j)
            .filter(|&i| lines[i].panel == lines[j].panel && test(&lines[i], &lines[j], spans[lines[j].panel]))
            .map(|i| lines[i].dash)
            .collect();
        if !under.is_empty() {
            // the first dash style none of the series underneath has
            let free = (0..DASHES.len()).find(|k| !under.contains(&Some(*k)));
            lines[j].dash = Some(free.unwrap_or(under.len() % DASHES.len()));
        }
    }
    lines
}

/// Whether `b` runs on top of `a`: more than a fifth of `b`'s points lie
/// within 1 % of the panel's extent `(x span, y span)` of `a`'s point of
/// the same index (the lines of a figure share their x values).
fn overlaps(a: &Line<'_>, b: &Line<'_>, (sx, sy): (f64, f64)) -> bool {
    let pa: Vec<&(f64, f64)> = a.pieces.iter().flatten().collect();
    let pb: Vec<&(f64, f64)> = b.pieces.iter().flatten().collect();
    overlap_count(&pa, &pb, (sx, sy), false)
}

/// Whether `b` runs along `a` as a path: more than a fifth of (at most 400
/// of) `b`'s points lie within 1 % of the extent of some point of `a`.
fn path_overlaps(a: &Line<'_>, b: &Line<'_>, span: (f64, f64)) -> bool {
    let sample = |l: &Line<'_>| -> Vec<(f64, f64)> {
        let all: Vec<(f64, f64)> = l.pieces.iter().flatten().copied().collect();
        let every = all.len().div_ceil(400).max(1);
        all.into_iter().step_by(every).collect()
    };
    let (pa, pb) = (sample(a), sample(b));
    let pa: Vec<&(f64, f64)> = pa.iter().collect();
    let pb: Vec<&(f64, f64)> = pb.iter().collect();
    overlap_count(&pa, &pb, span, true)
}

/// The test of [`overlaps`] (`nearest = false`: point by index) and
/// [`path_overlaps`] (`nearest = true`: any point of `a`).
fn overlap_count(pa: &[&(f64, f64)], pb: &[&(f64, f64)], (sx, sy): (f64, f64), nearest: bool) -> bool {
    let s = sx.max(sy);
    if nearest {
        let close = pb.iter().filter(|q| pa.iter().any(|p| (p.0 - q.0).hypot(p.1 - q.1) <= 0.01 * s)).count();
        return !pb.is_empty() && 5 * close > pb.len();
    }
    if pa.len() != pb.len() || pb.is_empty() {
        return false;
    }
    let (tx, ty) = (0.01 * sx, 0.01 * sy);
    let close = pa.iter().zip(pb).filter(|(p, q)| (p.0 - q.0).abs() <= tx && (p.1 - q.1).abs() <= ty).count();
    5 * close > pb.len()
}

/// Smallest and largest x and y over all drawable points of `lines`, or
/// `None` if there are none.
fn data_bounds<'a, 'b: 'a>(mut lines: impl Iterator<Item = &'a Line<'b>>) -> Option<(Range<f64>, Range<f64>)> {
    let mut acc: Option<(Range<f64>, Range<f64>)> = None;
    for l in lines.by_ref() {
        for &(px, py) in l.pieces.iter().flatten() {
            acc = Some(match acc {
                None => (px..px, py..py),
                Some((x, y)) => (x.start.min(px)..x.end.max(px), y.start.min(py)..y.end.max(py)),
            });
        }
    }
    acc
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

/// An axis in plot coordinates, linear or logarithmic (plot coordinate
/// `log10` of the value, ticks on whole decades, and on 2 and 5 times them
/// when the axis spans few decades, labelled `10⁻⁶`, `2·10⁻⁶`).
///
/// plotters' own `log_scale()` is not used because it drops every tick below
/// `f64::EPSILON` (its zero test is absolute), which hides the 1e-16 region
/// that solver residuals live in.
pub(crate) struct Axis {
    /// Linear map of the plot coordinate onto pixels.
    linear: RangedCoordf64,
    /// For a log axis: positions (`log10` of the value) of the labelled
    /// ticks and of the light grid lines.
    log: Option<(Vec<f64>, Vec<f64>)>,
}

impl Axis {
    /// A linear axis over `range`.
    pub(crate) fn linear(range: Range<f64>) -> Self {
        Self { linear: range.into(), log: None }
    }

    /// A log axis over `log10` values `range`, widened outward to whole
    /// decades so that at least two decades are labelled; at most ~12
    /// labels, the decades in between (or the 2..9 multiples when there
    /// are few decades) get light grid lines.
    fn log(range: Range<f64>) -> Self {
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
        Self { linear: range.into(), log: Some((bold, light)) }
    }
}

impl Ranged for Axis {
    type FormatOption = NoDefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        self.linear.map(value, limit)
    }

    fn key_points<Hint: KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        match &self.log {
            Some((bold, light)) => {
                if hint.weight().allow_light_points() {
                    light.clone()
                } else {
                    bold.clone()
                }
            }
            None => self.linear.key_points(hint),
        }
    }

    fn range(&self) -> Range<f64> {
        self.linear.range()
    }
}

impl ValueFormatter<f64> for Axis {
    fn format_ext(&self, value: &f64) -> String {
        match self.log {
            Some(_) => decade_label(*value),
            None => {
                let r = self.linear.range();
                // a tick at zero computed as -1e-17 reads 0, not -0
                if value.abs() <= 1e-9 * (r.end - r.start).abs() {
                    return "0".into();
                }
                // as many decimals as the tick spacing needs
                let ticks = self.linear.key_points(12usize);
                let step = ticks.windows(2).map(|w| w[1] - w[0]).fold(f64::INFINITY, f64::min);
                let decimals =
                    if step.is_finite() && step > 0.0 { (-step.log10().floor()).clamp(0.0, 15.0) } else { 3.0 };
                format!("{:.*}", decimals as usize, value).replace('-', "\u{2212}")
            }
        }
    }
}

/// The label of a log-axis tick at plot coordinate `v` (`log10` of the
/// value): `0.01` to `1000` written out, else `10⁻⁶` or `2·10⁻⁶`.
fn decade_label(v: f64) -> String {
    let k = (v + 1e-9).floor();
    let m = 10f64.powf(v - k).round();
    if (-2.0..=3.0).contains(&k) {
        let value = m * 10f64.powf(k);
        return format!("{}", (value * 100.0).round() / 100.0);
    }
    const SUP: [char; 10] = ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹'];
    let mut exp = String::new();
    if k < 0.0 {
        exp.push('⁻');
    }
    for d in format!("{}", k.abs() as i64).bytes() {
        exp.push(SUP[usize::from(d - b'0')]);
    }
    if m == 1.0 { format!("10{exp}") } else { format!("{m}·10{exp}") }
}

/// Draw the figure as SVG.
///
/// # Errors
/// [`PlotError::Range`] if the axes' final ranges cannot be drawn (checked
/// before any data is drawn), [`PlotError::Draw`] with plotters' message.
fn draw(chart: &Chart, lines: &[Line<'_>], x_data: Range<f64>, y_data: Vec<Range<f64>>) -> Result<String, PlotError> {
    let mut svg = String::new();
    draw_into(&mut svg, chart, lines, x_data, y_data).map_err(|e| match e {
        Failed::Range(e) => e,
        Failed::Draw(message) => PlotError::Draw { title: chart.title.clone(), message },
    })?;
    Ok(nominal_size(svg))
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

/// A drawing area of the SVG backend.
type Area<'a> = DrawingArea<SVGBackend<'a>, plotters::coord::Shift>;
/// A chart context on both [`Axis`].
type Ctx<'a> = ChartContext<'a, SVGBackend<'a>, Cartesian2d<Axis, Axis>>;

/// The title font.
fn title_font() -> TextStyle<'static> {
    // `FontDesc::style` keeps the already loaded glyph data, so the bold
    // face must be chosen when the font is created.
    (FONT, TITLE_SIZE, FontStyle::Bold).into_font().color(&BLACK)
}

fn draw_into(
    svg: &mut String,
    chart: &Chart,
    lines: &[Line<'_>],
    x_data: Range<f64>,
    y_data: Vec<Range<f64>>,
) -> Result<(), Failed> {
    let root = SVGBackend::with_string(svg, (WIDTH * SCALE, HEIGHT * SCALE)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let body = root.margin(8 * SCALE, 0, 0, 0).titled(&chart.title, title_font()).map_err(|e| e.to_string())?;
    let n = panels(chart);
    let areas: Vec<Area<'_>> = if n == 2 {
        let h = body.dim_in_pixel().1;
        let (top, bottom) = body.split_vertically(h * 47 / 100);
        vec![top, bottom]
    } else {
        vec![body]
    };
    // an outside legend: as wide as its longest entry
    let right = if chart.legend_outside {
        let font = TextStyle::from((FONT, LABEL_SIZE).into_font());
        let w = lines.iter().filter_map(|l| root.estimate_text_size(l.label, &font).ok()).map(|(w, _)| w).max();
        w.unwrap_or(0) + LEGEND_SAMPLE + 2 * LEGEND_MARGIN + 20 * SCALE
    } else {
        30 * SCALE
    };
    for (p, area) in areas.iter().enumerate() {
        let last = p + 1 == n;
        let builder = || {
            let mut b = ChartBuilder::on(area);
            b.margin_left(10 * SCALE).margin_right(right).margin_top(6 * SCALE).margin_bottom(6 * SCALE);
            b.x_label_area_size(if last { 62 * SCALE } else { 30 * SCALE }).y_label_area_size(100 * SCALE);
            b
        };
        // Work out the data ranges. For equal axes this needs the plotting
        // area's size, which a throw-away layout (nothing is drawn without a
        // caption) gives exactly.
        let (x_range, y_range) = if chart.equal_axes {
            let probe = builder().build_cartesian_2d(0.0..1.0, 0.0..1.0).map_err(|e| e.to_string())?;
            let dim = probe.plotting_area().dim_in_pixel();
            equalize(pad(x_data.clone(), PAD_FRACTION), pad(y_data[p].clone(), PAD_FRACTION), dim)
        } else if chart.log_x {
            (x_data.clone(), pad(y_data[p].clone(), PAD_FRACTION))
        } else {
            // Time-like x axes end exactly at the data; only a zero range is
            // widened. A chart with points alone (eigenvalues) is padded as
            // its y axis is, so that no marker sits on the frame.
            let x = if lines.iter().any(|l| l.points_only) {
                pad(x_data.clone(), PAD_FRACTION)
            } else if x_data.end > x_data.start {
                x_data.clone()
            } else {
                pad(x_data.clone(), 0.0)
            };
            (x, pad(y_data[p].clone(), PAD_FRACTION))
        };
        check_range(&chart.title, x_axis_name(chart), &x_range, undrawable_axis).map_err(Failed::Range)?;
        check_range(&chart.title, y_axis_name(chart), &y_range, undrawable_axis).map_err(Failed::Range)?;
        let axes = |y_range: Range<f64>| {
            let x_axis = if chart.log_x { Axis::log(x_range.clone()) } else { Axis::linear(x_range.clone()) };
            let y_axis = if chart.log_y { Axis::log(y_range) } else { Axis::linear(y_range) };
            (x_axis, y_axis)
        };
        let mine: Vec<&Line<'_>> = lines.iter().filter(|l| l.panel == p).collect();
        let mut ctx = builder()
            .build_cartesian_2d(axes(y_range.clone()).0, axes(y_range.clone()).1)
            .map_err(|e| e.to_string())?;
        if !chart.equal_axes && !chart.legend_outside && mine.iter().any(|l| !l.label.is_empty()) {
            // where every corner's legend would cover data, the y axis is
            // raised until the legend fits above the data
            let (_, hits, h) = legend_corner(&ctx, &mine, 0);
            if hits > 0 {
                let span = ctx.plotting_area().get_pixel_range().1;
                let f = f64::from(h + 8 * SCALE as i32) / f64::from((span.end - span.start).max(1));
                if f < 0.6 {
                    let top = ctx.y_range();
                    let raised = top.start..top.start + (top.end - top.start) / (1.0 - f);
                    let (xa, ya) = axes(raised);
                    ctx = builder().build_cartesian_2d(xa, ya).map_err(|e| e.to_string())?;
                }
            }
        }
        let y_label = if p == 0 { chart.y_label.as_str() } else { chart.lower.as_deref().unwrap_or_default() };
        let x_label = if last { chart.x_label.as_str() } else { "" };
        draw_contents(&mut ctx, chart, &mine, x_label, y_label)?;
        if chart.legend_outside {
            let (xr, yr) = ctx.plotting_area().get_pixel_range();
            outside_legend(&root, &mine, xr.end + 14 * SCALE as i32, yr.start + 10 * SCALE as i32, chart.log_y)?;
        }
    }
    root.present().map_err(|e| e.to_string())?;
    Ok(())
}

/// A legend right of the plot, from `(x, y)` down: a sample of every
/// labelled line (its dash and marker, or its marker alone) and its label.
fn outside_legend(root: &Area<'_>, lines: &[&Line<'_>], x: i32, y: i32, thin: bool) -> Result<(), String> {
    let s = SCALE as i32;
    let font = TextStyle::from((FONT, LABEL_SIZE).into_font()).pos(plotters::style::text_anchor::Pos::new(
        plotters::style::text_anchor::HPos::Left,
        plotters::style::text_anchor::VPos::Center,
    ));
    let step = (1.25 * f64::from(LABEL_SIZE)) as i32;
    for (k, l) in lines.iter().filter(|l| !l.label.is_empty()).enumerate() {
        let y = y + k as i32 * step;
        let style = l.color.stroke_width(if thin { SCALE } else { LINE_WIDTH });
        let err = |e: DrawingAreaErrorKind<_>| e.to_string();
        if l.points_only {
            root.draw(&(EmptyElement::at((x + 16 * s, y)) + diamond(l.color))).map_err(err)?;
        } else {
            let (on, off) = l.dash.map_or((32 * s, 0), |k| (DASHES[k].0 as i32, DASHES[k].1 as i32));
            let mut a = x;
            while a < x + 32 * s {
                root.draw(&PathElement::new(vec![(a, y), ((a + on).min(x + 32 * s), y)], style)).map_err(err)?;
                a += on + off;
            }
            if l.dash.is_some() {
                root.draw(&Circle::new((x + 16 * s, y), MARKER, l.color.stroke_width(SCALE))).map_err(err)?;
            }
        }
        root.draw(&Text::new(l.label, (x + 42 * s, y), font.clone())).map_err(err)?;
    }
    Ok(())
}

/// Padding inside the legend box \[canvas units\].
const LEGEND_MARGIN: u32 = 10 * SCALE;
/// Width reserved for a legend entry's sample line \[canvas units\].
const LEGEND_SAMPLE: u32 = 42 * SCALE;
/// Radius of start and end markers, and of the markers along dashed lines
/// \[canvas units\].
const MARKER: i32 = 5 * SCALE as i32;
/// Half diagonal of the diamond of a [`Stroke::Points`] point \[canvas units\].
const DIAMOND: i32 = MARKER + 2 * SCALE as i32;
/// How much larger each ring around a covered diamond is \[canvas units\]
/// (see [`Stroke::Points`]).
const RING_STEP: i32 = 4 * SCALE as i32;

/// The filled diamond of a [`Stroke::Points`] point at `(0, 0)`.
fn diamond(color: RGBColor) -> Polygon<(i32, i32)> {
    let d = DIAMOND;
    Polygon::new(vec![(0, -d), (d, 0), (0, d), (-d, 0)], color.filled())
}

/// The outline of a diamond of half diagonal `d` at `(0, 0)`, started and
/// ended in the middle of an edge so that every corner is a join.
fn ring(d: i32, color: RGBColor) -> PathElement<(i32, i32)> {
    let h = d / 2;
    PathElement::new(vec![(-h, -h), (0, -d), (d, 0), (0, d), (-d, 0), (-h, -h)], color.stroke_width(LINE_WIDTH))
}

/// Whether two diamonds centred at `a` and `b` \[canvas units\] overlap.
fn diamonds_touch(a: (i32, i32), b: (i32, i32)) -> bool {
    (a.0 - b.0).abs() + (a.1 - b.1).abs() < 2 * DIAMOND
}

/// The plot corner whose legend box would cover the fewest line segments
/// (upper right, then upper left, lower right, lower left on ties), the
/// number it covers there and the box's height \[canvas units\]; `extra`
/// legend entries besides the labelled lines.
fn legend_corner(ctx: &Ctx<'_>, lines: &[&Line<'_>], extra: usize) -> (SeriesLabelPosition, usize, i32) {
    let area = ctx.plotting_area();
    let font = TextStyle::from((FONT, LABEL_SIZE).into_font());
    let labels: Vec<&str> = lines.iter().map(|l| l.label).filter(|l| !l.is_empty()).collect();
    let text_w = labels.iter().filter_map(|l| area.estimate_text_size(l, &font).ok()).map(|(w, _)| w).max();
    // Same layout as plotters' legend: 5 px from the corner, `margin` inside,
    // lines about 1.25 x the font size apart.
    let w = (text_w.unwrap_or(0) + LEGEND_SAMPLE + 2 * LEGEND_MARGIN) as i32;
    let h = ((labels.len() + extra) as f64 * 1.25 * f64::from(LABEL_SIZE)) as i32 + 2 * LEGEND_MARGIN as i32;
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
    let hits = |x0: i32, y0: i32| -> usize {
        let rect = (f64::from(x0), f64::from(y0), f64::from(x0 + w), f64::from(y0 + h));
        pixels
            .iter()
            .map(|piece| match piece.as_slice() {
                [p] => usize::from(segment_hits_rect(*p, *p, rect)),
                _ => piece.windows(2).filter(|s| segment_hits_rect(s[0], s[1], rect)).count(),
            })
            .sum()
    };
    corners.into_iter().map(|(pos, x0, y0)| (pos, hits(x0, y0), h)).min_by_key(|c| c.1).unwrap_or((
        SeriesLabelPosition::UpperRight,
        0,
        h,
    ))
}

/// Largest distance \[drawing units, 1/192 inch\] by which a point of a
/// line may lie off the line drawn: the drawing rounds every point to a
/// whole unit (plotters' integer coordinates) anyway.
const LINE_TOLERANCE: f64 = 0.5;

/// A line's points kept for the drawing and their drawing units.
type OnTheDrawing = (Vec<(f64, f64)>, Vec<(i32, i32)>);

/// The points of `piece` that its line needs on the drawing, where `at`
/// maps a point to drawing units: those the Ramer-Douglas-Peucker
/// simplification keeps at [`LINE_TOLERANCE`] (Douglas & Peucker 1973,
/// Cartographica 10(2)), in order, first and last always, with their
/// drawing units (`at` of each, computed once). A trajectory's
/// 6,001 points over 1,700 units wide are mostly less than a unit apart:
/// the rasterizer's and the PNG's work was in segments nobody can see
/// (measured on the `drive` scene's figures: see the guide's performance
/// chapter).
fn on_the_drawing(piece: &[(f64, f64)], at: impl Fn(&(f64, f64)) -> (i32, i32)) -> OnTheDrawing {
    // a point on the same drawing unit as the one before it adds nothing
    // to the drawing: left out before the simplification (the last point
    // stays the piece's end)
    let last = piece.len().saturating_sub(1);
    let mut units: Vec<(i32, i32)> = Vec::with_capacity(piece.len());
    let piece: Vec<(f64, f64)> = piece
        .iter()
        .enumerate()
        .filter(|&(i, p)| {
            let u = at(p);
            let new = units.last() != Some(&u) || i == last;
            if new {
                units.push(u);
            }
            new
        })
        .map(|(_, p)| *p)
        .collect();
    let px: Vec<(f64, f64)> = units.iter().map(|&(x, y)| (f64::from(x), f64::from(y))).collect();
    let mut keep = vec![false; piece.len()];
    let last = piece.len().saturating_sub(1);
    keep[0] = true;
    keep[last] = true;
    // the spans still to look at (an explicit stack: no recursion depth)
    let mut spans = vec![(0, last)];
    while let Some((a, b)) = spans.pop() {
        if b <= a + 1 {
            continue;
        }
        let (pa, pb) = (px[a], px[b]);
        let (dx, dy) = (pb.0 - pa.0, pb.1 - pa.1);
        let len2 = dx * dx + dy * dy;
        // the farthest point from the chord as a segment (a point beyond
        // its ends, where the line turns back, is measured to the end),
        // by its squared distance
        let (mut far, mut dmax) = (a, -1.0);
        for (i, p) in px.iter().enumerate().take(b).skip(a + 1) {
            let s = if len2 > 0.0 { (((p.0 - pa.0) * dx + (p.1 - pa.1) * dy) / len2).clamp(0.0, 1.0) } else { 0.0 };
            let (ex, ey) = (p.0 - pa.0 - s * dx, p.1 - pa.1 - s * dy);
            let d2 = ex * ex + ey * ey;
            if d2 > dmax {
                (far, dmax) = (i, d2);
            }
        }
        if dmax > LINE_TOLERANCE * LINE_TOLERANCE {
            keep[far] = true;
            spans.push((a, far));
            spans.push((far, b));
        }
    }
    let kept = |k: &&bool| **k;
    (
        piece.iter().zip(&keep).filter(|(_, k)| kept(k)).map(|(p, _)| *p).collect(),
        units.iter().zip(&keep).filter(|(_, k)| kept(k)).map(|(u, _)| *u).collect(),
    )
}

/// Fewest points of a run drawn as a band (see [`banded`]).
const BAND_MIN_POINTS: usize = 16;

/// A part of a solid line as [`banded`] draws it.
#[derive(Debug, PartialEq)]
enum Part {
    /// These points (indices into the line), stroked as a polyline.
    Line(Range<usize>),
    /// A filled outline \[drawing units\] that covers a dense run.
    Band(Vec<(i32, i32)>),
}

/// How a solid line of the points `px` \[drawing units, x to the right\]
/// stroked `2 r` units wide is drawn: runs of at least
/// [`BAND_MIN_POINTS`] points, and of two points or more per column on
/// average, whose every step moves 0 or 1 unit to the right become one
/// filled outline each ([`band`]); the rest stays a polyline (sharing
/// each run's first and last point).
///
/// Why: a line whose points are denser than the drawing's units (the
/// round-off noise of a residual, a fast oscillation) sweeps up and down
/// hundreds of times through the same scanlines, and a rasterizer's work
/// grows with the edges each scanline crosses: the `drive` scene's
/// residual figure spent two thirds of its PNG time there. Its band has
/// a few edges per column instead, and covers the same pixels: where the
/// steps are at most a unit and the line is at least two units wide, the
/// union of the columns' spans is covered by the stroke, and the stroke
/// lies within that union widened by `r` (the band is that widening).
/// This is the min/max-per-column reduction of line charts (M4, U.
/// Jugel et al., "M4: a visualization-oriented time series data
/// aggregation", PVLDB 7(10), 2014) with the stroke's width added.
fn banded(px: &[(i32, i32)], r: i32) -> Vec<Part> {
    let n = px.len();
    let mut parts = Vec::new();
    if r < 1 {
        return vec![Part::Line(0..n)];
    }
    // the first point of the line part not drawn yet
    let mut line_start = 0;
    let mut i = 0;
    while i < n {
        let mut j = i;
        while j + 1 < n && matches!(px[j + 1].0 - px[j].0, 0 | 1) {
            j += 1;
        }
        let columns = (px[j].0 - px[i].0 + 1) as usize;
        if j + 1 - i >= BAND_MIN_POINTS.max(2 * columns) {
            if i > line_start {
                parts.push(Part::Line(line_start..i + 1));
            }
            parts.push(Part::Band(band(&px[i..=j], r)));
            line_start = j;
        }
        i = j + 1;
    }
    if n - line_start >= 2 {
        parts.push(Part::Line(line_start..n));
    }
    parts
}

/// The outline \[drawing units\] of the area a run of points covers when
/// stroked `2 r` units wide, where every step of the run moves 0 or 1
/// unit to the right. Each point covers a disc of radius `r` (in whole
/// units) flattened to the point's vertical reach: `r` times the cosine
/// of the flatter of its two segments (the bevelled tip of a spike
/// reaches no further than the spike). The outline joins, column by
/// column, the highest and lowest `y` the discs reach, the top edge left
/// to right, then the bottom edge back. A disc's outermost columns count
/// only on their inner side, so the edge steps down there instead of
/// sloping across the next column; vertices in the middle of a level
/// stretch are left out.
fn band(run: &[(i32, i32)], r: i32) -> Vec<(i32, i32)> {
    let (c0, c1) = (run[0].0 - r, run[run.len() - 1].0 + r);
    let columns = (c1 - c0 + 1) as usize;
    // per column: the reach from the left side and from the right side
    let mut top = vec![(i32::MAX, i32::MAX); columns];
    let mut bottom = vec![(i32::MIN, i32::MIN); columns];
    // the disc: the half-height at each horizontal offset
    let disc: Vec<(i32, i32)> = (-r..=r).map(|k| (k, f64::from(r * r - k * k).sqrt().round() as i32)).collect();
    // |cos| of the segment from point a to point b (0 for none)
    let cos = |a: (i32, i32), b: (i32, i32)| {
        let (dx, dy) = (f64::from(b.0 - a.0), f64::from(b.1 - a.1));
        let len = dx.hypot(dy);
        if len > 0.0 { dx.abs() / len } else { 0.0 }
    };
    for (i, &(x, y)) in run.iter().enumerate() {
        let before = if i > 0 { cos(run[i - 1], run[i]) } else { 0.0 };
        let after = run.get(i + 1).map_or(0.0, |&b| cos(run[i], b));
        let reach = (f64::from(r) * before.max(after)).round() as i32;
        for &(k, d) in &disc {
            let at = (x + k - c0) as usize;
            let d = d.min(reach);
            let (t, b) = (&mut top[at], &mut bottom[at]);
            if k < r {
                t.1 = t.1.min(y - d);
                b.1 = b.1.max(y + d);
            }
            if k > -r {
                t.0 = t.0.min(y - d);
                b.0 = b.0.max(y + d);
            }
        }
    }
    let mut outline: Vec<(i32, i32)> = Vec::with_capacity(4 * columns);
    let mut push = |p: (i32, i32)| {
        if p.1 == i32::MAX || p.1 == i32::MIN || outline.last() == Some(&p) {
            return;
        }
        // a vertex between two on the same level or on the same column
        if let [.., a, b] = outline[..]
            && ((a.1 == b.1 && b.1 == p.1) || (a.0 == b.0 && b.0 == p.0))
        {
            outline.pop();
        }
        outline.push(p);
    };
    for (c, &(left, right)) in (c0..c1 + 1).zip(&top) {
        push((c, left));
        push((c, right));
    }
    for (c, &(left, right)) in (c0..c1 + 1).zip(&bottom).rev() {
        push((c, right));
        push((c, left));
    }
    outline
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

/// Draw grid, axes, the series and the legend into an already laid-out chart.
fn draw_contents<'a>(
    ctx: &mut Ctx<'a>,
    chart: &Chart,
    lines: &[&Line<'_>],
    x_label: &str,
    y_label: &str,
) -> Result<(), String> {
    let grid_light = RGBColor(238, 238, 238);
    let grid_bold = RGBColor(205, 205, 205);
    let mut mesh = ctx.configure_mesh();
    mesh.x_desc(x_label)
        .y_desc(y_label)
        .axis_desc_style((FONT, DESC_SIZE))
        .label_style((FONT, LABEL_SIZE))
        .x_labels(12)
        .y_labels(if chart.lower.is_some() { 6 } else { 10 })
        .light_line_style(grid_light)
        .bold_line_style(grid_bold.stroke_width(SCALE / 2));
    mesh.draw().map_err(|e| e.to_string())?;
    if !chart.shade.is_empty() {
        let y = ctx.y_range();
        let tint = RGBColor(214, 39, 40).mix(0.12).filled();
        ctx.draw_series(chart.shade.iter().map(|&(a, b)| Rectangle::new([(a, y.start), (b, y.end)], tint)))
            .map_err(|e| e.to_string())?;
    }

    let width = if chart.log_y { SCALE } else { LINE_WIDTH };
    let mut any_label = false;
    // the points of the panel's earlier point series [canvas units]
    let mut placed: Vec<(i32, i32)> = Vec::new();
    for line in lines {
        let color = line.color;
        let style = color.stroke_width(width);
        if line.points_only {
            // a point on earlier markers: a ring around them, larger for each
            let mine: Vec<((f64, f64), (i32, i32))> =
                line.pieces.iter().flatten().map(|&p| (p, ctx.backend_coord(&p))).collect();
            let covered = |u: (i32, i32)| placed.iter().filter(|&&q| diamonds_touch(q, u)).count();
            ctx.draw_series(
                mine.iter().filter(|(_, u)| covered(*u) == 0).map(|(p, _)| EmptyElement::at(*p) + diamond(color)),
            )
            .map_err(|e| e.to_string())?;
            ctx.draw_series(mine.iter().filter_map(|&(p, u)| {
                let k = covered(u) as i32;
                (k > 0).then(|| EmptyElement::at(p) + ring(DIAMOND + k * RING_STEP, color))
            }))
            .map_err(|e| e.to_string())?;
            placed.extend(mine.iter().map(|(_, u)| *u));
        }
        for piece in line.pieces.iter().filter(|_| !line.points_only) {
            if let [p] = piece.as_slice() {
                ctx.draw_series(std::iter::once(Circle::new(*p, MARKER, color.filled()))).map_err(|e| e.to_string())?;
                continue;
            }
            let (drawn, units) = on_the_drawing(piece, |p| ctx.backend_coord(p));
            match line.dash {
                None => {
                    for part in banded(&units, width as i32 / 2) {
                        match part {
                            Part::Line(range) => {
                                ctx.draw_series(LineSeries::new(drawn[range].iter().copied(), style))
                                    .map_err(|e| e.to_string())?;
                            }
                            Part::Band(outline) => {
                                // drawn in drawing units, relative to the plotting area
                                let area = ctx.plotting_area().strip_coord_spec();
                                let (x0, y0) = area.get_base_pixel();
                                let outline: Vec<(i32, i32)> =
                                    outline.into_iter().map(|(x, y)| (x - x0, y - y0)).collect();
                                area.draw(&Polygon::new(outline, color.filled())).map_err(|e| e.to_string())?;
                            }
                        }
                    }
                }
                Some(k) => {
                    let (on, off) = DASHES[k];
                    ctx.draw_series(DashedLineSeries::new(drawn, on, off, style)).map_err(|e| e.to_string())?;
                    let every = (piece.len() / MARKERS_PER_SERIES).max(1);
                    let offset = every * (k + 1) / (DASHES.len() + 1);
                    ctx.draw_series(
                        piece
                            .iter()
                            .skip(offset)
                            .step_by(every)
                            .map(|p| Circle::new(*p, MARKER, color.stroke_width(SCALE))),
                    )
                    .map_err(|e| e.to_string())?;
                }
            }
        }
        if chart.equal_axes && chart.path_ends {
            // start (circle) and end (square) of the path
            let all: Vec<&(f64, f64)> = line.pieces.iter().flatten().collect();
            if let (Some(&&first), Some(&&last)) = (all.first(), all.last()) {
                ctx.draw_series(std::iter::once(Circle::new(first, MARKER + SCALE as i32, color.filled())))
                    .map_err(|e| e.to_string())?;
                ctx.draw_series(std::iter::once(
                    EmptyElement::at(last) + Rectangle::new([(-MARKER, -MARKER), (MARKER, MARKER)], color.filled()),
                ))
                .map_err(|e| e.to_string())?;
            }
        }
        if !line.label.is_empty() {
            any_label = true;
            // An empty series carries the legend entry, so a line that is
            // broken into pieces (or has no drawable point) is listed once.
            let (dash, points_only) = (line.dash, line.points_only);
            ctx.draw_series(LineSeries::new(std::iter::empty(), style))
                .map_err(|e| e.to_string())?
                .label(line.label)
                .legend(move |(x, y)| {
                    let w = 32 * SCALE as i32;
                    let none = TRANSPARENT.stroke_width(0);
                    // solid: two touching halves and no marker; points: their diamond alone
                    let ((on, off), marker, stroke) = match (points_only, dash) {
                        (true, _) => ((w as u32 / 2, 0), none, none),
                        (false, None) => ((w as u32 / 2, 0), none, style),
                        (false, Some(k)) => (DASHES[k], color.stroke_width(SCALE), style),
                    };
                    let d = if points_only { DIAMOND } else { 0 };
                    let fill = if points_only { color.filled() } else { TRANSPARENT.filled() };
                    EmptyElement::at((x, y))
                        + PathElement::new(vec![(0, 0), (on as i32, 0)], stroke)
                        + PathElement::new(vec![(on as i32 + off as i32, 0), (w, 0)], stroke)
                        + Circle::new((w / 2, 0), MARKER, marker)
                        + Polygon::new(vec![(w / 2, -d), (w / 2 + d, 0), (w / 2, d), (w / 2 - d, 0)], fill)
                });
        }
    }
    let extra = if chart.equal_axes && chart.path_ends && any_label {
        // legend entries for the markers
        let black = BLACK.filled();
        ctx.draw_series(LineSeries::new(std::iter::empty(), BLACK))
            .map_err(|e| e.to_string())?
            .label("start")
            .legend(move |(x, y)| Circle::new((x + 16 * SCALE as i32, y), MARKER + SCALE as i32, black));
        ctx.draw_series(LineSeries::new(std::iter::empty(), BLACK)).map_err(|e| e.to_string())?.label("end").legend(
            move |(x, y)| {
                let c = (x + 16 * SCALE as i32, y);
                Rectangle::new([(c.0 - MARKER, c.1 - MARKER), (c.0 + MARKER, c.1 + MARKER)], black)
            },
        );
        2
    } else {
        0
    };
    if any_label && !chart.legend_outside {
        let position = legend_corner(ctx, lines, extra).0;
        ctx.configure_series_labels()
            .position(position)
            .margin(LEGEND_MARGIN)
            .legend_area_size(LEGEND_SAMPLE)
            .label_font((FONT, LABEL_SIZE))
            .background_style(WHITE.mix(0.9).filled())
            .border_style(RGBColor(120, 120, 120))
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

/// `map` as SVG text (see [`encode`] for the other formats).
///
/// # Errors
/// [`PlotError::Empty`] if no value is finite or the grid is empty or not
/// ascending, [`PlotError::Range`] for values beyond [`MAX_MAGNITUDE`],
/// [`PlotError::Font`], [`PlotError::Draw`] as for [`chart_svg`].
pub fn heatmap_svg(map: &HeatMap) -> Result<String, PlotError> {
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
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (WIDTH * SCALE, HEIGHT * SCALE)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| draw_error(e.to_string()))?;
        let body =
            root.margin(8 * SCALE, 0, 0, 0).titled(&map.title, title_font()).map_err(|e| draw_error(e.to_string()))?;
        let (main, bar) = body.split_horizontally((WIDTH - 190) * SCALE);
        let (span, flat) = if hi > lo { (hi - lo, false) } else { (1.0, true) };
        let colour = |v: f64| -> RGBColor {
            if !v.is_finite() {
                return RGBColor(190, 190, 190);
            }
            let h = if flat { 0.5 } else { ((v - lo) / span) as f32 };
            ViridisRGB::get_color_normalized(h, 0.0, 1.0)
        };
        let mut ctx = ChartBuilder::on(&main)
            .margin_left(10 * SCALE)
            .margin_right(10 * SCALE)
            .margin_top(10 * SCALE)
            .margin_bottom(10 * SCALE)
            .x_label_area_size(62 * SCALE)
            .y_label_area_size(100 * SCALE)
            .build_cartesian_2d(Axis::linear(xe[0]..xe[xe.len() - 1]), Axis::linear(ye[0]..ye[ye.len() - 1]))
            .map_err(|e| draw_error(e.to_string()))?;
        ctx.configure_mesh()
            .disable_mesh()
            .x_desc(map.x_label.as_str())
            .y_desc(map.y_label.as_str())
            .axis_desc_style((FONT, DESC_SIZE))
            .label_style((FONT, LABEL_SIZE))
            .x_labels(10)
            .y_labels(10)
            .draw()
            .map_err(|e| draw_error(e.to_string()))?;
        let cells = (0..map.xs.len()).flat_map(|i| (0..map.ys.len()).map(move |j| (i, j)));
        ctx.draw_series(cells.map(|(i, j)| {
            // each cell reaches 2 % into the next one, so anti-aliased
            // edges leave no light seams between equal neighbours
            let (nx, ny) = (xe.len() - 2, ye.len() - 2);
            let x1 = if i < nx { xe[i + 1] + 0.02 * (xe[i + 2] - xe[i + 1]) } else { xe[i + 1] };
            let y1 = if j < ny { ye[j + 1] + 0.02 * (ye[j + 2] - ye[j + 1]) } else { ye[j + 1] };
            Rectangle::new([(xe[i], ye[j]), (x1, y1)], colour(map.values[i * map.ys.len() + j]).filled())
        }))
        .map_err(|e| draw_error(e.to_string()))?;
        // the colour bar: 100 bands from lo to hi
        let mut cb = ChartBuilder::on(&bar)
            .margin_left(10 * SCALE)
            .margin_right(40 * SCALE)
            .margin_top(10 * SCALE)
            .margin_bottom(72 * SCALE)
            .y_label_area_size(110 * SCALE)
            .build_cartesian_2d(0.0..1.0, Axis::linear(if flat { lo - 0.5..hi + 0.5 } else { lo..hi }))
            .map_err(|e| draw_error(e.to_string()))?;
        cb.configure_mesh()
            .disable_mesh()
            .disable_x_axis()
            .y_desc(map.value_label.as_str())
            .axis_desc_style((FONT, DESC_SIZE))
            .label_style((FONT, LABEL_SIZE))
            .y_labels(8)
            .draw()
            .map_err(|e| draw_error(e.to_string()))?;
        let (b0, b1) = if flat { (lo - 0.5, hi + 0.5) } else { (lo, hi) };
        cb.draw_series((0..100).map(|k| {
            let (y0, y1) = (b0 + (b1 - b0) * f64::from(k) / 100.0, b0 + (b1 - b0) * f64::from(k + 1) / 100.0);
            let top = if k < 99 { y1 + 0.5 * (y1 - y0) } else { y1 };
            Rectangle::new([(0.0, y0), (1.0, top)], colour(0.5 * (y0 + y1)).filled())
        }))
        .map_err(|e| draw_error(e.to_string()))?;
        root.present().map_err(|e| draw_error(e.to_string()))?;
    }
    Ok(nominal_size(svg))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn chart(series: Vec<Series>) -> Chart {
        Chart { log_floor: 1e-16, ..Chart::new("test", "t [s]", "x [m]") }.with(series)
    }

    impl Chart {
        fn with(mut self, series: Vec<Series>) -> Self {
            self.series = series;
            self
        }
    }

    /// The texts of an SVG, trimmed.
    fn texts(svg: &str) -> Vec<String> {
        let doc = roxmltree::Document::parse(svg).expect("XML");
        doc.descendants()
            .filter(|n| n.has_tag_name("text"))
            .filter_map(|n| n.text())
            .map(|t| t.trim().to_string())
            .collect()
    }

    fn two() -> Vec<Series> {
        vec![
            Series::new("ramp", vec![(0.0, 0.0), (1.0, 2.0), (2.0, 1.0)]),
            Series::new("constant", vec![(0.0, 1.0), (2.0, 1.0)]),
        ]
    }

    /// Thin lines along an axis and rectangles are snapped; data lines
    /// (thicker), slanted, dashed and text are left as they are.
    #[test]
    fn only_thin_axis_lines_and_rectangles_snap() {
        let crisp = |element: &str| {
            [Snap::Rectangles, Snap::Lines]
                .into_iter()
                .any(|w| snap(element, w).contains("shape-rendering=\"crispEdges\""))
        };
        // rectangles in every SVG, lines for a raster only
        let line = r##"<line opacity="1" stroke="#EEEEEE" stroke-width="1" x1="220" y1="1143" x2="220" y2="83"/>"##;
        let rect = r##"<rect x="0" y="0" width="1920" height="1280" opacity="1" fill="#FFFFFF" stroke="none"/>"##;
        assert_eq!(snap(line, Snap::Rectangles), line);
        assert_eq!(snap(rect, Snap::Lines), rect);
        // once snapped, an element is left as it is
        let snapped = snap(rect, Snap::Rectangles);
        assert_eq!(snap(&snapped, Snap::Rectangles), snapped);
        assert_eq!(snapped.matches("shape-rendering").count(), 1);
        assert!(crisp(
            r##"<line opacity="1" stroke="#EEEEEE" stroke-width="1" x1="220" y1="1143" x2="220" y2="83"/>"##
        ));
        assert!(crisp(r##"<line stroke-width="1" x1="20" y1="7" x2="90" y2="7"/>"##));
        assert!(crisp(
            r##"<polyline fill="none" stroke="#000000" stroke-width="1" points="219,83 219,1143 400,1143 "/>"##
        ));
        assert!(crisp(r##"<rect x="0" y="0" width="1920" height="1280" opacity="1" fill="#FFFFFF" stroke="none"/>"##));
        // a legend's translucent box and its border
        assert!(!crisp(
            r##"<rect x="225" y="88" width="192" height="72" opacity="0.9" fill="#FFFFFF" stroke="none"/>"##
        ));
        assert!(!crisp(r##"<rect x="225" y="88" width="192" height="72" opacity="1" fill="none" stroke="#787878"/>"##));
        assert!(!crisp(r##"<line stroke-width="1" x1="20" y1="7" x2="90" y2="8"/>"##));
        assert!(!crisp(r##"<polyline fill="none" stroke="#1F77B4" stroke-width="4" points="10,10 10,20 "/>"##));
        assert!(!crisp(r##"<polyline fill="none" stroke-width="1" points="10,10 11,20 "/>"##));
        assert!(!crisp(r##"<line stroke-width="1" stroke-dasharray="4 2" x1="20" y1="7" x2="90" y2="7"/>"##));
        assert!(!crisp(r##"<text x="1" y="2" stroke-width="1">x</text>"##));
        // the rest of the document is kept byte for byte
        let doc = "<svg>\n<line stroke-width=\"1\" x1=\"1\" y1=\"2\" x2=\"1\" y2=\"9\"/>\n<circle r=\"2\"/>\n</svg>\n";
        assert_eq!(snap(doc, Snap::Lines).replacen(" shape-rendering=\"crispEdges\"", "", 1), doc);
    }

    /// Snapped opaque lines in a row of one style become one path of a
    /// subpath each, and the raster is the same pixel for pixel; a
    /// lone line, a translucent one and the rest stay as they were.
    #[test]
    fn runs_of_snapped_lines_are_one_path_with_the_same_pixels() {
        let line = |style: &str, x1: u32, y1: u32, x2: u32, y2: u32| {
            format!("<line {style} x1=\"{x1}\" y1=\"{y1}\" x2=\"{x2}\" y2=\"{y2}\"/>\n")
        };
        let grid = r##"opacity="1" stroke="#EEEEEE" stroke-width="1""##;
        let axis = r##"opacity="1" stroke="#000000" stroke-width="1""##;
        let faint = r##"opacity="0.5" stroke="#000000" stroke-width="1""##;
        let mut body = String::new();
        for k in 0..6 {
            body += &line(grid, 40 + 30 * k, 20, 40 + 30 * k, 600);
        }
        for k in 0..4 {
            body += &line(grid, 20, 50 + 100 * k, 900, 50 + 100 * k);
        }
        body += &line(axis, 20, 610, 900, 610);
        body += r##"<polyline fill="none" opacity="1" stroke="#1F77B4" stroke-width="4" points="20,600 300,100 900,500 "/>"##;
        body += "\n";
        body += &line(faint, 30, 20, 30, 600);
        body += &line(faint, 35, 20, 35, 600);
        let doc = format!(
            r#"<svg width="960" height="640" viewBox="0 0 1920 1280" xmlns="http://www.w3.org/2000/svg">{}{body}</svg>"#,
            "\n"
        );
        let snapped = snap(&doc, Snap::Lines);
        // ten grid lines in one path; the axis alone; the translucent
        // lines one by one (snapped all the same)
        assert_eq!(snapped.matches("<path ").count(), 1, "{snapped}");
        assert_eq!(snapped.matches('M').count(), 10, "{snapped}");
        assert_eq!(snapped.matches("<line ").count(), 3, "{snapped}");
        assert!(snapped.contains(r##"<path shape-rendering="crispEdges" opacity="1" stroke="#EEEEEE" stroke-width="1" fill="none" d="M40 20L40 600M70 20L70 600"##));
        // what the lines drew one by one, snapped as before
        let one_by_one: String = doc
            .split_inclusive('\n')
            .map(|l| match l.strip_prefix("<line ") {
                Some(rest) => format!("<line shape-rendering=\"crispEdges\" {rest}"),
                _ => l.to_string(),
            })
            .collect();
        assert_eq!(one_by_one.matches("crispEdges").count(), 13);
        let (w, h, gathered) = rgba(&snapped, 144.0).expect("raster");
        let (w0, h0, separate) = rgba(&one_by_one, 144.0).expect("raster");
        assert_eq!((w, h), (w0, h0));
        assert!(gathered == separate, "the pixels differ");
        // and the grid is there: the first vertical grid line (x = 40
        // units, 30 px at 144 dpi) is grey in a pixel column near it
        let at = |x: usize, y: usize| &gathered[4 * (y * w as usize + x)..4 * (y * w as usize + x) + 3];
        assert!((28..=32).any(|x| at(x, 225) == [0xEE, 0xEE, 0xEE]));
    }

    /// Every snapped grid line, wherever it lies, is one pixel column in
    /// the raster, the one its centre is in: a unit-wide line centred on
    /// a pixel's edge covered no pixel centre and was not drawn at all.
    #[test]
    fn every_snapped_line_is_one_pixel_wide() {
        for dpi in [96.0, 144.0, 150.0] {
            // units to pixels: the canvas is SCALE units a nominal pixel
            let s = dpi / (96.0 * f64::from(SCALE));
            // lines 5 units apart (2.5 px and more), at every offset
            // from the pixel grid that 96, 144 and 150 dpi give
            let xs: Vec<u32> = (0..48).map(|k| 100 + 5 * k).collect();
            let mut doc = String::from(
                r#"<svg width="960" height="640" viewBox="0 0 1920 1280" xmlns="http://www.w3.org/2000/svg">"#,
            );
            doc.push('\n');
            for &x in &xs {
                doc += &format!(
                    "<line opacity=\"1\" stroke=\"#000000\" stroke-width=\"1\" x1=\"{x}\" y1=\"100\" x2=\"{x}\" y2=\"900\"/>\n"
                );
            }
            doc += "</svg>\n";
            // the lines as a chart's SVG has them: snapped by the raster
            let (w, _, pixels) = rgba(&doc, dpi).expect("raster");
            let row = (500.0 * s) as usize;
            let dark: Vec<usize> = (0..w as usize).filter(|&x| pixels[4 * (row * w as usize + x)] < 128).collect();
            let expected: Vec<usize> = xs.iter().map(|&x| (f64::from(x) * s).floor() as usize).collect();
            assert_eq!(dark, expected, "{dpi} dpi");
        }
    }

    /// The three kinds of snapped line keep their style and their end,
    /// and move across themselves onto pixel centres, one pixel wide.
    #[test]
    fn snapped_lines_move_onto_pixel_centres() {
        // 144 dpi: 0.75 px a unit, so a pixel is 4/3 units
        let s = 0.75;
        let line = r##"<line shape-rendering="crispEdges" opacity="1" stroke="#EEEEEE" stroke-width="1" x1="220" y1="566" x2="220" y2="83"/>"##;
        let moved = on_pixel_centres(&format!("{line}\n"), s).expect("a line");
        // 220 units are 165 px, a pixel's edge: the centre of pixel 165
        let x = 165.5 / s;
        assert_eq!(
            moved,
            format!(
                r##"<line shape-rendering="crispEdges" opacity="1" stroke="#EEEEEE" stroke-width="{}" x1="{x}" y1="566" x2="{x}" y2="83"/>"##,
                1.0 / s
            ) + "\n"
        );
        let axis = r##"<polyline shape-rendering="crispEdges" fill="none" opacity="1" stroke="#000000" stroke-width="1" points="219,83 219,566 400,566 "/>"##;
        let moved = on_pixel_centres(axis, s).expect("a polyline");
        let (x, y) = (164.5 / s, 424.5 / s);
        assert!(moved.ends_with(&format!(r#" points="{x},83 {x},{y} 400,{y} "/>"#)), "{moved}");
        let path = r##"<path shape-rendering="crispEdges" opacity="1" stroke="#EEEEEE" stroke-width="1" fill="none" d="M40 20L40 600M20 50L900 50"/>"##;
        let moved = on_pixel_centres(path, s).expect("a path");
        let (x, y) = (30.5 / s, 37.5 / s);
        assert!(moved.ends_with(&format!(r#" fill="none" d="M{x} 20L{x} 600M20 {y}L900 {y}"/>"#)), "{moved}");
        // at 300 dpi a unit is more than a pixel: nothing to do
        let svg = format!("<svg>\n{line}\n</svg>\n");
        assert_eq!(one_pixel_crisp_lines(&svg, 300.0), svg);
        assert!(one_pixel_crisp_lines(&svg, 144.0).contains(&format!("x1=\"{}\"", 165.5 / s)));
    }

    /// Whether `p` is inside the polygon `outline` or on its boundary.
    fn inside(outline: &[(i32, i32)], p: (f64, f64)) -> bool {
        let on_edge = |a: (f64, f64), b: (f64, f64)| {
            let (dx, dy) = (b.0 - a.0, b.1 - a.1);
            let len2 = dx * dx + dy * dy;
            let t = if len2 > 0.0 { (((p.0 - a.0) * dx + (p.1 - a.1) * dy) / len2).clamp(0.0, 1.0) } else { 0.0 };
            (p.0 - a.0 - t * dx).hypot(p.1 - a.1 - t * dy) < 1e-9
        };
        let mut odd = false;
        for (i, &a) in outline.iter().enumerate() {
            let b = outline[(i + 1) % outline.len()];
            let (a, b) = ((f64::from(a.0), f64::from(a.1)), (f64::from(b.0), f64::from(b.1)));
            if on_edge(a, b) {
                return true;
            }
            if (a.1 > p.1) != (b.1 > p.1) && p.0 < a.0 + (p.1 - a.1) / (b.1 - a.1) * (b.0 - a.0) {
                odd = !odd;
            }
        }
        odd
    }

    /// Distance from `p` to the polyline `run`.
    fn distance(run: &[(i32, i32)], p: (f64, f64)) -> f64 {
        run.windows(2)
            .map(|s| {
                let (a, b) = ((f64::from(s[0].0), f64::from(s[0].1)), (f64::from(s[1].0), f64::from(s[1].1)));
                let (dx, dy) = (b.0 - a.0, b.1 - a.1);
                let len2 = dx * dx + dy * dy;
                let t = if len2 > 0.0 { (((p.0 - a.0) * dx + (p.1 - a.1) * dy) / len2).clamp(0.0, 1.0) } else { 0.0 };
                (p.0 - a.0 - t * dx).hypot(p.1 - a.1 - t * dy)
            })
            .fold(f64::INFINITY, f64::min)
    }

    /// A dense run becomes a band between two line parts that share its
    /// ends; a sparse line stays a line; a line of width below two units
    /// is never banded.
    #[test]
    fn dense_runs_become_bands() {
        let sparse: Vec<(i32, i32)> = (0..10).map(|i| (5 * i, 100 + i)).collect();
        assert_eq!(banded(&sparse, 1), vec![Part::Line(0..10)]);
        // 5 sparse points, 40 points over 20 columns zigzagging, 5 sparse
        let mut line: Vec<(i32, i32)> = (0..5).map(|i| (5 * i, 100)).collect();
        line.extend((0..40).map(|i| (25 + i / 2, if i % 2 == 0 { 50 } else { 150 })));
        line.extend((1..=5).map(|i| (44 + 5 * i, 100)));
        let parts = banded(&line, 1);
        assert_eq!(parts.len(), 3, "{parts:?}");
        assert_eq!(parts[0], Part::Line(0..6));
        assert!(matches!(parts[1], Part::Band(_)));
        assert_eq!(parts[2], Part::Line(44..50));
        assert_eq!(banded(&line, 0), vec![Part::Line(0..50)]);
        // a smooth line is denser than one point a column nowhere
        let smooth: Vec<(i32, i32)> = (0..40).map(|i| (i, 100 + i / 3)).collect();
        assert_eq!(banded(&smooth, 2), vec![Part::Line(0..40)]);
    }

    /// The band covers every point and every segment of its run, and
    /// reaches no further from the run than the stroke's half width plus
    /// the rounding to whole units (a disc of radius `r` rounded to whole
    /// units at each column: at most half a unit more).
    #[test]
    fn a_band_covers_its_run_and_no_more() {
        let mut seed = 7u64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        };
        for r in [1, 2] {
            // noise between two levels with spikes, 3 points a column
            let run: Vec<(i32, i32)> = (0..300)
                .map(|i| (200 + i / 3, if next() % 3 == 0 { 400 } else { 300 + (next() % 40) as i32 }))
                .collect();
            let outline = band(&run, r);
            assert!(outline.len() < run.len(), "{} vertices for {} points", outline.len(), run.len());
            for s in run.windows(2) {
                for k in 0..=8 {
                    let t = f64::from(k) / 8.0;
                    let p = (
                        f64::from(s[0].0) + t * f64::from(s[1].0 - s[0].0),
                        f64::from(s[0].1) + t * f64::from(s[1].1 - s[0].1),
                    );
                    assert!(inside(&outline, p), "r = {r}: {p:?} of the run outside the band");
                }
            }
            for &v in &outline {
                let d = distance(&run, (f64::from(v.0), f64::from(v.1)));
                assert!(d <= f64::from(r) + 0.5, "r = {r}: vertex {v:?} {d} units from the run");
            }
        }
    }

    /// The white background is left out of a raster only where it is the
    /// canvas-wide first element; the PNG is the same either way.
    #[test]
    fn the_white_background_is_not_rasterized_twice() {
        let svg = chart_svg(&chart(two())).expect("svg");
        let without = without_white_background(&svg);
        assert_eq!(svg.len() - without.len(), svg.lines().nth(1).expect("a background").len() + 1);
        assert!(matches!(without_white_background(&without), std::borrow::Cow::Borrowed(_)));
        let tinted = svg.replacen("fill=\"#FFFFFF\"", "fill=\"#FFFFFE\"", 1);
        assert!(matches!(without_white_background(&tinted), std::borrow::Cow::Borrowed(_)));
        let png = |s: &str| {
            let tree = resvg::usvg::Tree::from_str(s, svg_options()).expect("parses");
            raster(&tree, 96.0).expect("raster").take()
        };
        assert!(png(&svg) == png(&without), "the background changed the image");
    }

    /// Every pixel's colour kept and its alpha dropped, for every length
    /// of a last incomplete group of four pixels.
    #[test]
    fn rgb_in_place_keeps_every_colour() {
        for pixels in (0..11usize).chain([191, 192, 255, 256, 257, 1000]) {
            let rgba: Vec<u8> = (0..4 * pixels).map(|i| (i * 7 % 251) as u8).collect();
            let want: Vec<u8> = rgba.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect();
            assert_eq!(rgb_in_place(rgba), want, "{pixels} pixels");
        }
    }

    /// (text nodes, path nodes) in `group` and below.
    fn count_nodes(group: &resvg::usvg::Group) -> (usize, usize) {
        group.children().iter().fold((0, 0), |(t, p), node| match node {
            resvg::usvg::Node::Group(g) => {
                let (tt, pp) = count_nodes(g);
                (t + tt, p + pp)
            }
            resvg::usvg::Node::Text(_) => (t + 1, p),
            resvg::usvg::Node::Path(_) => (t, p + 1),
            resvg::usvg::Node::Image(_) => (t, p),
        })
    }

    /// The PDF's text is drawn as outlines: none is left as text (svg2pdf
    /// without its `text` feature would skip it), and every label became a
    /// path (usvg writes a text span's glyphs as one path): the chart's
    /// title, axis descriptions, tick labels and legend are 21 texts.
    #[test]
    fn pdf_text_becomes_outlines() {
        let svg = chart_svg(&chart(two())).expect("svg");
        let tree = resvg::usvg::Tree::from_str(&svg, svg_options()).expect("svg parses");
        let (texts, paths) = count_nodes(tree.root());
        assert!(texts >= 10, "{texts} texts");
        let (texts_after, paths_after) = count_nodes(outlined(&tree).expect("outlined").root());
        assert_eq!(texts_after, 0);
        assert!(paths_after >= paths + texts, "{paths} -> {paths_after} paths for {texts} texts");
    }

    #[test]
    fn every_format_is_a_file_of_its_kind() {
        let c = chart(two());
        let svg = chart_svg(&c).expect("svg");
        let doc = roxmltree::Document::parse(&svg).expect("the SVG is XML");
        assert_eq!(doc.root_element().tag_name().name(), "svg");
        assert_eq!(doc.root_element().attribute("width"), Some("960"));
        let png = figure(&c, FigureFormat::Png, 96.0).expect("png");
        assert!(png.starts_with(&[0x89, b'P', b'N', b'G', 0x0D, 0x0A, 0x1A, 0x0A]));
        // IHDR: width and height at bytes 16..24; 192 dpi doubles them
        let big = figure(&c, FigureFormat::Png, 192.0).expect("png");
        let size = |b: &[u8]| {
            (u32::from_be_bytes(b[16..20].try_into().unwrap()), u32::from_be_bytes(b[20..24].try_into().unwrap()))
        };
        assert_eq!(size(&png), (960, 640));
        assert_eq!(size(&big), (1920, 1280));
        if PDF {
            let pdf = figure(&c, FigureFormat::Pdf, 96.0).expect("pdf");
            assert!(pdf.starts_with(b"%PDF-"));
            assert!(pdf.windows(5).any(|w| w == b"%%EOF"));
        } else {
            // refused by name, before any drawing
            let e = figure(&c, FigureFormat::Pdf, 96.0).expect_err("no pdf feature");
            assert!(matches!(e, PlotError::Unavailable { format: "pdf", feature: "pdf" }), "{e}");
        }
        assert!(matches!(figure(&c, FigureFormat::Png, 5000.0), Err(PlotError::Dpi { .. })));
    }

    #[test]
    fn png_is_anti_aliased() {
        // a diagonal line leaves pixels between its colour and white
        let c = chart(vec![Series::new("d", vec![(0.0, 0.0), (1.0, 0.7)])]);
        let (_, _, rgba) = rgba(&chart_svg(&c).unwrap(), 96.0).unwrap();
        let mut shades = std::collections::BTreeSet::new();
        for px in rgba.chunks(4) {
            shades.insert((px[0], px[1], px[2]));
        }
        assert!(shades.len() > 50, "only {} colours: not anti-aliased", shades.len());
    }

    #[test]
    fn an_overlapping_series_is_dashed_and_no_tick_reads_minus_zero() {
        let pts: Vec<(f64, f64)> = (0..100).map(|k| (f64::from(k) * 0.1, (f64::from(k) * 0.1).sin())).collect();
        let c = chart(vec![Series::new("a", pts.clone()), Series::new("b", pts.clone())]);
        let lines = chart_lines(&c);
        assert_eq!(lines[0].dash, None);
        assert_eq!(lines[1].dash, Some(0));
        // c lies on b only: it takes a style b does not have
        let shifted: Vec<(f64, f64)> = pts.iter().map(|p| (p.0, p.1 + 0.015)).collect();
        let c3 = chart(vec![Series::new("a", pts.clone()), Series::new("b", pts.clone()), Series::new("c", shifted)]);
        let l3 = chart_lines(&c3);
        assert_eq!((l3[1].dash, l3[2].dash.is_some()), (Some(0), true));
        assert_ne!(l3[2].dash, Some(0), "c would hide b");
        let apart: Vec<(f64, f64)> = pts.iter().map(|p| (p.0, p.1 + 1.0)).collect();
        let c2 = chart(vec![Series::new("a", pts.clone()), Series::new("b", apart)]);
        assert_eq!(chart_lines(&c2)[1].dash, None);
        // a symmetric range puts a tick at zero, computed as a tiny negative
        let t = texts(&chart_svg(&c).unwrap());
        assert!(!t.iter().any(|s| ["-0", "\u{2212}0", "-0.0", "\u{2212}0.0"].contains(&s.as_str())), "{t:?}");
        assert!(t.iter().any(|s| s == "0"), "the zero tick is labelled 0: {t:?}");
    }

    /// Points alone (eigenvalues): the x axis is padded so no marker sits
    /// on the frame, and a point on an earlier series' marker is drawn as
    /// a ring around it; the legend shows each series' diamond.
    #[test]
    fn points_keep_off_the_frame_and_out_of_each_other_s_way() {
        let points = |label: &str, re: &[f64]| Series {
            stroke: Stroke::Points,
            ..Series::new(label, re.iter().map(|&x| (x, 0.0)).collect())
        };
        let c = chart(vec![points("one", &[5.0, 0.0, -0.78]), points("two", &[0.0, -0.78, -5.0])]);
        let svg = chart_svg(&c).unwrap();
        let doc = roxmltree::Document::parse(&svg).expect("XML");
        let hex = |c: RGBColor| format!("#{:02X}{:02X}{:02X}", c.0, c.1, c.2);
        let count = |tag: &str, attribute: &str, colour: RGBColor| {
            doc.descendants()
                .filter(|n| n.has_tag_name(tag) && n.attribute(attribute) == Some(hex(colour).as_str()))
                .count()
        };
        // three diamonds of the first series and one in the legend; the
        // second's point apart is a diamond, its two on the first's rings
        assert_eq!(count("polygon", "fill", PALETTE[0]), 4);
        assert_eq!(count("polygon", "fill", PALETTE[1]), 2);
        assert_eq!(count("polyline", "stroke", PALETTE[1]), 2);
        // the diamonds' centres [canvas units] lie inside the frame, none on it
        let frame = doc
            .descendants()
            .filter(|n| n.has_tag_name("polyline") && n.attribute("stroke") == Some("#000000"))
            .filter_map(|n| n.attribute("points"))
            .flat_map(|p| p.split_whitespace().filter_map(|xy| xy.split(',').next()?.parse::<f64>().ok()))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| (lo.min(x), hi.max(x)));
        let centres: Vec<f64> = doc
            .descendants()
            .filter(|n| n.has_tag_name("polygon") && n.attribute("fill") != Some("#FFFFFF"))
            .filter_map(|n| n.attribute("points"))
            .map(|p| {
                let xs: Vec<f64> = p.split_whitespace().filter_map(|xy| xy.split(',').next()?.parse().ok()).collect();
                xs.iter().sum::<f64>() / xs.len() as f64
            })
            .collect();
        assert!(!centres.is_empty());
        let margin = f64::from(2 * DIAMOND);
        for x in centres {
            assert!(x > frame.0 + margin && x < frame.1 - margin, "a diamond at x = {x} on the frame {frame:?}");
        }
    }

    #[test]
    fn log_axes_label_decades() {
        assert_eq!(decade_label(-6.0), "10⁻⁶");
        assert_eq!(decade_label(-6.0 + 2f64.log10()), "2·10⁻⁶");
        assert_eq!(decade_label(0.0), "1");
        assert_eq!(decade_label(-2.0), "0.01");
        assert_eq!(decade_label(2.0 + 5f64.log10()), "500");
        let mut c = chart(vec![Series::new("w", vec![(1e-4, 1e-3), (1e-2, 1e-9)])]);
        c.log_x = true;
        c.log_y = true;
        let t = texts(&chart_svg(&c).unwrap());
        assert!(t.iter().any(|s| s == "10⁻⁴") && t.iter().any(|s| s == "10⁻⁹"), "decades on both axes: {t:?}");
    }

    #[test]
    fn paths_get_start_and_end_markers_and_panels_their_own_axis() {
        let mut c = chart(vec![Series::new("still", vec![(1.0, 1.0), (1.0, 1.0)])]);
        c.equal_axes = true;
        let t = texts(&chart_svg(&c).unwrap());
        assert!(t.iter().any(|s| s == "start") && t.iter().any(|s| s == "end"), "{t:?}");
        let mut c = chart(vec![
            Series::new("a [m]", vec![(0.0, 0.0), (1.0, 1.0)]),
            Series { panel: 1, ..Series::new("b [N]", vec![(0.0, 5.0), (1.0, 9.0)]) },
        ]);
        c.lower = Some("force [N]".into());
        let t = texts(&chart_svg(&c).unwrap());
        assert!(t.iter().any(|s| s == "force [N]") && t.iter().any(|s| s == "x [m]"), "{t:?}");
    }

    #[test]
    fn empty_chart_is_an_error() {
        let c = chart(vec![Series::new("a", vec![]), Series::new("b", vec![])]);
        assert!(matches!(chart_svg(&c), Err(PlotError::Empty { .. })));
        assert!(matches!(chart_svg(&chart(vec![])), Err(PlotError::Empty { .. })));
        let mut lower_empty = chart(two());
        lower_empty.lower = Some("y [N]".into());
        assert!(matches!(chart_svg(&lower_empty), Err(PlotError::Empty { .. })));
    }

    #[test]
    fn undrawable_ranges_are_refused_before_drawing() {
        for (x, y) in [(1e101, 0.0), (0.0, -1e300), (0.0, 1.7e308), (0.0, f64::MAX)] {
            let c = chart(vec![Series::new("a", vec![(0.0, 0.0), (x, y)])]);
            let t = std::time::Instant::now();
            assert!(matches!(chart_svg(&c), Err(PlotError::Range { .. })), "{x} {y}");
            assert!(t.elapsed().as_secs_f64() < 1.0);
        }
        // tiny spans at any magnitude are drawn (a conserved energy)
        let c = chart(vec![Series::new("T", vec![(0.0, 23.1875), (1.0, 23.1875 + 4e-15)])]);
        assert!(chart_svg(&c).is_ok());
        let c = chart(vec![Series::new("a", vec![(0.0, 1e100), (1.0, -1e100)])]);
        assert!(chart_svg(&c).is_ok());
    }

    #[test]
    fn a_drawing_that_takes_too_long_is_given_up() {
        // long enough to draw (100,000 points, tens of ms) that the worker
        // cannot answer before a zero limit runs out, even on a loaded
        // machine where a two-point chart sometimes did
        let points = (0..100_000).map(|i| (i as f64, (i as f64 * 0.01).sin())).collect();
        let c = chart(vec![Series::new("a", points)]);
        assert!(matches!(svg_within(&c, std::time::Duration::ZERO), Err(PlotError::Timeout { .. })));
    }

    #[test]
    fn warm_up_stocks_one_buffer_per_thread() {
        // every thread that encodes finds a buffer of its own: two asked
        // for, two kept, distinct and white; asked again, none added
        let pool = Pool::new(Vec::new());
        stock(&pool, 2, 4096);
        {
            let kept = pool.lock().unwrap();
            assert_eq!(kept.len(), 2);
            assert_ne!(kept[0].as_ptr(), kept[1].as_ptr());
            assert!(kept.iter().all(|b| b.len() == 4096 && b.iter().all(|&v| v == 255)));
        }
        stock(&pool, 2, 4096);
        assert_eq!(pool.lock().unwrap().len(), 2);
        // never more than KEEP_CANVASES, however many are asked for
        stock(&pool, 100, 16);
        assert_eq!(pool.lock().unwrap().len(), KEEP_CANVASES);
        // a buffer taken is white whatever was in it
        let mut taken = white_from(&pool, 8);
        assert_eq!(taken, vec![255; 8]);
        taken.fill(0);
        recycle_into(&pool, taken);
        assert_eq!(white_from(&pool, 8), vec![255; 8]);
    }
}
