//! A series as it is drawn: its drawable pieces in plot coordinates, its
//! resolved stroke (a series on top of another is dashed), its markers,
//! and the points its line needs on the drawing (simplified, dense runs
//! filled as bands).

use std::ops::Range;

use plotters::prelude::*;

use super::series::{Chart, Stroke, panels};
use super::{DASHES, LINE_WIDTH, PALETTE, SCALE};

/// One series prepared for drawing: its drawable pieces in plot coordinates
/// (`log10` of the value on a log axis) and its resolved style.
pub(super) struct Line<'a> {
    /// Legend text (empty: no legend entry).
    pub(super) label: &'a str,
    /// Maximal runs of consecutive drawable points.
    pub(super) pieces: Vec<Vec<(f64, f64)>>,
    /// Panel index.
    pub(super) panel: usize,
    /// Colour.
    pub(super) color: RGBColor,
    /// `None`: solid; `Some(k)`: dash style `k` of [`DASHES`], with markers.
    pub(super) dash: Option<usize>,
    /// Markers only, no line ([`Stroke::Points`]).
    pub(super) points_only: bool,
    /// Pieces that are no path ([`Stroke::Pieces`]): no path ends.
    pub(super) pieces_only: bool,
}

/// Split every series into runs of drawable points in plot coordinates
/// and resolve [`Stroke::Auto`].
pub(super) fn chart_lines(chart: &Chart) -> Vec<Line<'_>> {
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
                Stroke::Auto | Stroke::Solid | Stroke::Pieces | Stroke::Points => None,
            };
            Line {
                label: &s.label,
                pieces,
                panel: s.panel.min(panels(chart) - 1),
                color: PALETTE[s.color.unwrap_or(i) % PALETTE.len()],
                dash,
                points_only: s.stroke == Stroke::Points,
                pieces_only: s.stroke == Stroke::Pieces,
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
pub(super) fn data_bounds<'a, 'b: 'a>(
    mut lines: impl Iterator<Item = &'a Line<'b>>,
) -> Option<(Range<f64>, Range<f64>)> {
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

/// Radius of start and end markers, and of the markers along dashed lines
/// \[canvas units\].
pub(super) const MARKER: i32 = 5 * SCALE as i32;
/// Half diagonal of the diamond of a [`Stroke::Points`] point \[canvas units\].
pub(super) const DIAMOND: i32 = MARKER + 2 * SCALE as i32;
/// How much larger each ring around a covered diamond is \[canvas units\]
/// (see [`Stroke::Points`]).
pub(super) const RING_STEP: i32 = 4 * SCALE as i32;

/// The filled diamond of a [`Stroke::Points`] point at `(0, 0)`.
pub(super) fn diamond(color: RGBColor) -> Polygon<(i32, i32)> {
    let d = DIAMOND;
    Polygon::new(vec![(0, -d), (d, 0), (0, d), (-d, 0)], color.filled())
}

/// The outline of a diamond of half diagonal `d` at `(0, 0)`, started and
/// ended in the middle of an edge so that every corner is a join.
pub(super) fn ring(d: i32, color: RGBColor) -> PathElement<(i32, i32)> {
    let h = d / 2;
    PathElement::new(vec![(-h, -h), (0, -d), (d, 0), (0, d), (-d, 0), (-h, -h)], color.stroke_width(LINE_WIDTH))
}

/// Whether two diamonds centred at `a` and `b` \[canvas units\] overlap.
pub(super) fn diamonds_touch(a: (i32, i32), b: (i32, i32)) -> bool {
    (a.0 - b.0).abs() + (a.1 - b.1).abs() < 2 * DIAMOND
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
pub(super) fn on_the_drawing(piece: &[(f64, f64)], at: impl Fn(&(f64, f64)) -> (i32, i32)) -> OnTheDrawing {
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
pub(super) enum Part {
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
pub(super) fn banded(px: &[(i32, i32)], r: i32) -> Vec<Part> {
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

#[cfg(test)]
mod tests {
    use super::*;

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
}
