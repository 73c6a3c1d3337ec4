//! The charts drawn whole: formats, strokes, axes, markers, errors.

use super::axis::decade_label;
use super::chart::svg_within;
use super::lines::{DIAMOND, chart_lines};
use super::raster::{outlined, raster, rgba, svg_options, without_white_background};
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
