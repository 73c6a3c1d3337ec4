//! The drawing of a [`Chart`] as SVG: the checks before anything is drawn,
//! the drawer thread with its time limit, the layout of the panels and
//! the series drawn into them.

use std::ops::Range;

use plotters::prelude::*;

use super::axis::{Area, Axis, Ctx, equalize, pad, undrawable_axis, x_axis_name, y_axis_name};
use super::legend::{LEGEND_MARGIN, LEGEND_SAMPLE, legend, legend_corner, legend_entry, outside_legend};
use super::lines::{
    DIAMOND, Line, MARKER, Part, RING_STEP, banded, chart_lines, data_bounds, diamond, diamonds_touch, on_the_drawing,
    ring,
};
use super::series::{Chart, panels};
use super::snap::nominal_size;
use super::{
    DASHES, DESC_SIZE, DRAW_TIMEOUT, FONT, HEIGHT, LABEL_SIZE, LINE_WIDTH, MARKERS_PER_SERIES, PAD_FRACTION, PlotError,
    SCALE, WIDTH, check_range, ensure_font, title_font, undrawable,
};

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
/// beyond [`MAX_MAGNITUDE`](super::MAX_MAGNITUDE)), [`PlotError::Font`] if the embedded font
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
pub(super) fn svg_within(chart: &Chart, limit: std::time::Duration) -> Result<String, PlotError> {
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
pub(super) fn bounds(chart: &Chart, lines: &[Line<'_>]) -> Result<(Range<f64>, Vec<Range<f64>>), PlotError> {
    let empty = || PlotError::Empty { title: chart.title.clone() };
    let (x, _) = data_bounds(lines.iter()).ok_or_else(empty)?;
    let ys = (0..panels(chart))
        .map(|p| data_bounds(lines.iter().filter(|l| l.panel == p)).map(|(_, y)| y).ok_or_else(empty))
        .collect::<Result<_, _>>()?;
    Ok((x, ys))
}

/// Draw the figure as SVG.
///
/// # Errors
/// [`PlotError::Range`] if the axes' final ranges cannot be drawn (checked
/// before any data is drawn), [`PlotError::Draw`] with plotters' message.
pub(super) fn draw(
    chart: &Chart,
    lines: &[Line<'_>],
    x_data: Range<f64>,
    y_data: Vec<Range<f64>>,
) -> Result<String, PlotError> {
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
        let style = line.color.stroke_width(width);
        if line.points_only {
            draw_points(ctx, line, &mut placed)?;
        }
        for piece in line.pieces.iter().filter(|_| !line.points_only) {
            draw_piece(ctx, line, piece, style, width)?;
        }
        if chart.equal_axes && chart.path_ends && !line.pieces_only {
            draw_path_ends(ctx, line)?;
        }
        if !line.label.is_empty() {
            any_label = true;
            legend_entry(ctx, line, style)?;
        }
    }
    legend(ctx, chart, lines, any_label)
}

/// The points of a [`Stroke::Points`] series: a diamond each, or, on
/// markers of the panel's earlier point series (`placed`, canvas units,
/// to which this series' points are added), a ring around them, larger
/// for each.
fn draw_points(ctx: &mut Ctx<'_>, line: &Line<'_>, placed: &mut Vec<(i32, i32)>) -> Result<(), String> {
    let color = line.color;
    let mine: Vec<((f64, f64), (i32, i32))> =
        line.pieces.iter().flatten().map(|&p| (p, ctx.backend_coord(&p))).collect();
    let covered = |u: (i32, i32)| placed.iter().filter(|&&q| diamonds_touch(q, u)).count();
    ctx.draw_series(mine.iter().filter(|(_, u)| covered(*u) == 0).map(|(p, _)| EmptyElement::at(*p) + diamond(color)))
        .map_err(|e| e.to_string())?;
    ctx.draw_series(mine.iter().filter_map(|&(p, u)| {
        let k = covered(u) as i32;
        (k > 0).then(|| EmptyElement::at(p) + ring(DIAMOND + k * RING_STEP, color))
    }))
    .map_err(|e| e.to_string())?;
    placed.extend(mine.iter().map(|(_, u)| *u));
    Ok(())
}

/// One piece of a line (a run of drawable points): a dot for a single
/// point, else the line solid (dense runs as bands) or dashed with
/// markers, `style` `width` units wide.
fn draw_piece(
    ctx: &mut Ctx<'_>,
    line: &Line<'_>,
    piece: &[(f64, f64)],
    style: ShapeStyle,
    width: u32,
) -> Result<(), String> {
    let color = line.color;
    if let [p] = piece {
        ctx.draw_series(std::iter::once(Circle::new(*p, MARKER, color.filled()))).map_err(|e| e.to_string())?;
        return Ok(());
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
                        let outline: Vec<(i32, i32)> = outline.into_iter().map(|(x, y)| (x - x0, y - y0)).collect();
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
                piece.iter().skip(offset).step_by(every).map(|p| Circle::new(*p, MARKER, color.stroke_width(SCALE))),
            )
            .map_err(|e| e.to_string())?;
        }
    }
    Ok(())
}

/// The start (circle) and end (square) of a path.
fn draw_path_ends(ctx: &mut Ctx<'_>, line: &Line<'_>) -> Result<(), String> {
    let color = line.color;
    let all: Vec<&(f64, f64)> = line.pieces.iter().flatten().collect();
    if let (Some(&&first), Some(&&last)) = (all.first(), all.last()) {
        ctx.draw_series(std::iter::once(Circle::new(first, MARKER + SCALE as i32, color.filled())))
            .map_err(|e| e.to_string())?;
        ctx.draw_series(std::iter::once(
            EmptyElement::at(last) + Rectangle::new([(-MARKER, -MARKER), (MARKER, MARKER)], color.filled()),
        ))
        .map_err(|e| e.to_string())?;
    }
    Ok(())
}
