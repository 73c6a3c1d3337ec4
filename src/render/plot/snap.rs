//! Lines and rectangles on whole pixels: the `shape-rendering` marks of
//! an SVG drawn by this module, its grid lines gathered into one path,
//! and, for a raster, every thin line one pixel wide on a pixel's centre.

use super::{HEIGHT, SCALE, WIDTH};

/// An SVG drawn by this module, ready to rasterize at `dpi`: its thin
/// lines along an axis snapped ([`snap`] with [`Snap::Lines`]), each a
/// pixel wide on a pixel's centre ([`one_pixel_crisp_lines`]).
pub(super) fn for_raster(svg: &str, dpi: f64) -> String {
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
pub(super) fn attribute<'a>(element: &'a str, name: &str) -> Option<&'a str> {
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
pub(super) fn opaque_fill_only(element: &str) -> bool {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::plot::raster::rgba;

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
}
