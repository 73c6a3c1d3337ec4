//! A heat map: a value per cell of a grid of two parameters, with its
//! colour bar.

use plotters::prelude::*;

use super::axis::Axis;
use super::snap::nominal_size;
use super::{
    DESC_SIZE, FONT, HEIGHT, LABEL_SIZE, PlotError, SCALE, WIDTH, check_range, ensure_font, title_font, undrawable,
};

/// A heat map: a value per point of a grid of two parameters, drawn as
/// coloured cells (viridis, dark for low) with a colour bar.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct HeatMap {
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
    /// Polylines drawn over the cells (a gait's curve, a vector field's
    /// arrows), in the axes' units, white with a dark edge.
    pub lines: Vec<Vec<(f64, f64)>>,
    /// The colours' range `(low, high)`: values beyond it take its end's
    /// colour (`None`: the values' own range).
    pub value_range: Option<(f64, f64)>,
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
pub(crate) fn heatmap_svg(map: &HeatMap) -> Result<String, PlotError> {
    let ascending = |v: &[f64]| !v.is_empty() && v.windows(2).all(|w| w[0] < w[1]) && v.iter().all(|x| x.is_finite());
    let finite: Vec<f64> = map.values.iter().copied().filter(|v| v.is_finite()).collect();
    if !ascending(&map.xs)
        || !ascending(&map.ys)
        || map.values.len() != map.xs.len() * map.ys.len()
        || finite.is_empty()
    {
        return Err(PlotError::Empty { title: map.title.clone() });
    }
    let (lo, hi) = match map.value_range {
        Some((lo, hi)) if lo.is_finite() && hi.is_finite() && lo <= hi => (lo, hi),
        _ => (
            finite.iter().copied().fold(f64::INFINITY, f64::min),
            finite.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        ),
    };
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
            let h = if flat { 0.5 } else { ((v - lo) / span).clamp(0.0, 1.0) as f32 };
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
        let (x0, x1, y0, y1) = (xe[0], xe[xe.len() - 1], ye[0], ye[ye.len() - 1]);
        let inside =
            |p: &(f64, f64)| p.0.is_finite() && p.1.is_finite() && (x0..=x1).contains(&p.0) && (y0..=y1).contains(&p.1);
        for (width, colour) in [(4 * SCALE, RGBColor(40, 40, 40)), (2 * SCALE, WHITE)] {
            for line in &map.lines {
                let pts: Vec<(f64, f64)> = line.iter().copied().filter(inside).collect();
                if pts.len() >= 2 {
                    ctx.draw_series(std::iter::once(PathElement::new(pts, colour.stroke_width(width))))
                        .map_err(|e| draw_error(e.to_string()))?;
                }
            }
        }
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
