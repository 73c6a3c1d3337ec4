//! The legend: inside the plot in the corner where it covers the fewest
//! line segments, or right of it for long legends.

use plotters::prelude::*;

use super::axis::{Area, Ctx};
use super::lines::{DIAMOND, Line, MARKER, diamond};
use super::series::Chart;
use super::{DASHES, FONT, LABEL_SIZE, LINE_WIDTH, SCALE};

/// A legend right of the plot, from `(x, y)` down: a sample of every
/// labelled line (its dash and marker, or its marker alone) and its label.
pub(super) fn outside_legend(root: &Area<'_>, lines: &[&Line<'_>], x: i32, y: i32, thin: bool) -> Result<(), String> {
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
pub(super) const LEGEND_MARGIN: u32 = 10 * SCALE;
/// Width reserved for a legend entry's sample line \[canvas units\].
pub(super) const LEGEND_SAMPLE: u32 = 42 * SCALE;

/// The plot corner whose legend box would cover the fewest line segments
/// (upper right, then upper left, lower right, lower left on ties), the
/// number it covers there and the box's height \[canvas units\]; `extra`
/// legend entries besides the labelled lines.
pub(super) fn legend_corner(ctx: &Ctx<'_>, lines: &[&Line<'_>], extra: usize) -> (SeriesLabelPosition, usize, i32) {
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

/// The legend entry of the labelled `line`, stroked with `style`: a
/// sample of its dash and marker, or its diamond alone. An empty series
/// carries the entry, so a line that is broken into pieces (or has no
/// drawable point) is listed once.
pub(super) fn legend_entry(ctx: &mut Ctx<'_>, line: &Line<'_>, style: ShapeStyle) -> Result<(), String> {
    let (color, dash, points_only) = (line.color, line.dash, line.points_only);
    ctx.draw_series(LineSeries::new(std::iter::empty(), style)).map_err(|e| e.to_string())?.label(line.label).legend(
        move |(x, y)| {
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
        },
    );
    Ok(())
}

/// The legend inside the plot, in the corner where it covers the fewest
/// of `lines`' segments (with `any_label`, some line labelled), with
/// entries for a path's start and end markers; none for a legend
/// outside the plot ([`outside_legend`]).
pub(super) fn legend(ctx: &mut Ctx<'_>, chart: &Chart, lines: &[&Line<'_>], any_label: bool) -> Result<(), String> {
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
