//! The SVG turned into the other formats: an anti-aliased PNG (resvg,
//! with the embedded DejaVu Sans, on reused image buffers) or a PDF
//! (svg2pdf, text as outlines); RGBA frames for the animation.

use std::sync::OnceLock;

use super::snap::{attribute, for_raster, opaque_fill_only};
use ezy_scene::FigureFormat;

use super::{FONT_NAME, HEIGHT, PlotError, SCALE, WIDTH, check_dpi, check_format, ensure_font};

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
pub(super) fn without_white_background(svg: &str) -> std::borrow::Cow<'_, str> {
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

/// The PDF of `tree`. Its text is first turned into outlines: usvg
/// lays it out with the embedded DejaVu Sans and writes each glyph as a
/// path (`WriteOptions::preserve_text` false), and the SVG read back has
/// no text left. svg2pdf is then built without its `text` feature, whose
/// font subsetter (write-fonts, read-fonts, skrifa) was some 60 s of a
/// fresh build's CPU time. The page looks the same; its text cannot be
/// selected or searched.
#[cfg(feature = "pdf")]
pub(super) fn pdf(tree: &resvg::usvg::Tree) -> Result<Vec<u8>, String> {
    let tree = outlined(tree)?;
    let page = svg2pdf::PageOptions { dpi: 96.0 };
    svg2pdf::to_pdf(&tree, svg2pdf::ConversionOptions::default(), page).map_err(|e| format!("converting to PDF: {e}"))
}

/// `tree` with every text node replaced by its glyphs' outlines (paths).
#[cfg_attr(not(feature = "pdf"), allow(dead_code))]
pub(super) fn outlined(tree: &resvg::usvg::Tree) -> Result<resvg::usvg::Tree, String> {
    let svg = tree.to_string(&resvg::usvg::WriteOptions { preserve_text: false, ..Default::default() });
    resvg::usvg::Tree::from_str(&svg, svg_options()).map_err(|e| format!("reading the outlined SVG: {e}"))
}

#[cfg(not(feature = "pdf"))]
pub(super) fn pdf(_: &resvg::usvg::Tree) -> Result<Vec<u8>, String> {
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
pub(crate) fn warm_up(format: FigureFormat, dpi: f64, canvases: usize) {
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
pub(super) fn raster(tree: &resvg::usvg::Tree, dpi: f64) -> Result<resvg::tiny_skia::Pixmap, PlotError> {
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
pub(crate) fn rgba(svg: &str, dpi: f64) -> Result<(u32, u32, Vec<u8>), PlotError> {
    let tree = resvg::usvg::Tree::from_str(&for_raster(svg, dpi), svg_options())
        .map_err(|e| PlotError::Draw { title: String::new(), message: format!("reading the SVG: {e}") })?;
    let p = raster(&tree, dpi)?;
    Ok((p.width(), p.height(), p.take()))
}

/// resvg's options: the embedded DejaVu Sans (regular and bold) as the
/// only font, and as every generic family.
pub(super) fn svg_options() -> &'static resvg::usvg::Options<'static> {
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

#[cfg(test)]
mod tests {
    use super::*;

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
