//! `ezy animate`: a scene's bodies drawn moving, as an animated GIF.
//!
//! The scene is integrated exactly as `ezy run` integrates it (same
//! setup, settings and overrides), with one output sample per frame: the
//! output interval is `speed / fps` seconds of simulated time. Each frame
//! is drawn from the model's geometry at that sample's `q`:
//!
//! - every body as its outline, a line or polygon through its points (or
//!   the points a scene's `[draw]` table lists), filled lightly in the
//!   body's colour, its centre of mass marked with a crossed circle;
//! - hinges as white circles, skates (knife edges) as short thick blades
//!   (red while a skate with friction slides)
//!   along their blade direction, fixed ground points as hatched anchors,
//!   spring-dampers as zig-zags;
//! - fading trails of the skates' contact points (of the points, for a
//!   model without skates; the first eight either way) over the last
//!   `trail` seconds;
//! - the time in the upper left corner, and how many times faster than
//!   real time the animation plays.
//!
//! Text is at least [`MIN_TEXT_PX`] pixels high at any resolution: below
//! about 80 dpi the frame's text, and the margins that hold it, grow.
//!
//! The view is fixed on the whole motion when it spans at most
//! [`FOLLOW_FACTOR`] vehicle sizes, else it follows the vehicle (a window
//! [`FOLLOW_WIDTH`] vehicle sizes wide centred on the mean of its points).
//! A vehicle's size is the diagonal of the bounding box of its points.
//! Frames are drawn as SVG by plotters and rasterized by resvg
//! ([`crate::render::plot::rgba`]) in parallel, mapped onto one 256-colour palette
//! (NeuQuant, trained on frames from the start, middle and end) and
//! written with the `gif` crate; the file is written atomically.

use std::path::PathBuf;

use ezy_core::{Dynamics, Model, Observer, Sample, fmt_value};

use ezy_scene::Scene;
use plotters::prelude::*;
use rayon::prelude::*;

use crate::render::plot::axis::Axis;
use crate::render::plot::{PALETTE, PlotError, SCALE};

/// The view follows the vehicle when its motion spans more than this many
/// vehicle sizes.
pub(crate) const FOLLOW_FACTOR: f64 = 8.0;
/// Width of the following view in vehicle sizes.
pub(crate) const FOLLOW_WIDTH: f64 = 4.0;
/// Most frames an animation may have (`ezy animate` refuses more before
/// integrating; raise `--speed` or lower `--fps`). With a fixed-step
/// method the frames are a whole number of steps apart, and the count and
/// the frame rate are those of that spacing.
pub(crate) const MAX_FRAMES: usize = 4000;
/// Frames drawn and quantized at once (memory: this many RGBA frames).
const CHUNK: usize = 32;
/// Smallest height of a frame's text in the GIF \[px\] (the font size
/// of its tick labels).
pub(crate) const MIN_TEXT_PX: f64 = 11.0;
/// Font sizes of a frame's tick labels, axis descriptions and time
/// label \[nominal px, plotters' convention: the font's size is 1/1.24 of
/// it\], before [`text_zoom`].
const TICK_SIZE: f64 = 16.0;
const DESC_SIZE: f64 = 18.0;
const TIME_SIZE: f64 = 22.0;

/// How much a frame's text is enlarged at `dpi` so that its smallest
/// text, the tick labels, is [`MIN_TEXT_PX`] high or more: 1 from about
/// 82 dpi up (the report's 48 dpi: 1.7).
pub(crate) fn text_zoom(dpi: f64) -> f64 {
    let tick_px = TICK_SIZE / 1.24 * dpi / 96.0;
    (MIN_TEXT_PX / tick_px).max(1.0)
}
/// The palette index of a pixel unchanged since the previous frame.
const TRANSPARENT: u8 = 255;

/// Settings of an animation.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct AnimateOptions {
    /// The GIF file to write.
    pub out: PathBuf,
    /// Frames per second of the GIF \[1/s\] (1 to 50; GIF delays are whole
    /// hundredths of a second, so 30 fps plays at 33.3).
    pub fps: f64,
    /// Seconds of simulated time per second of animation.
    pub speed: f64,
    /// Length of the fading trails \[s of simulated time\] (0: none).
    pub trail: f64,
    /// Resolution \[dpi\]: the frame is 10 x 6.67 inches (64 dpi: 640 x 427
    /// pixels); its text is enlarged at low resolutions ([`text_zoom`]).
    pub dpi: f64,
}

/// Why an animation failed.
#[derive(Debug, thiserror::Error)]
pub(crate) enum AnimationError {
    /// A setting out of range.
    #[error("{0}")]
    Setting(String),
    /// Drawing a frame failed.
    #[error("drawing frame {frame}: {source}")]
    Draw {
        /// The frame's index.
        frame: usize,
        /// The cause.
        #[source]
        source: PlotError,
    },
    /// Encoding or writing the GIF failed.
    #[error("writing {path}: {message}")]
    Write {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
}

/// The time of every frame's sample and its coordinates `q`: an
/// [`Observer`] of a run with one sample per frame.
#[derive(Default)]
pub(crate) struct Frames {
    t: Vec<f64>,
    q: Vec<Vec<f64>>,
    /// Per frame: the skates (by index in the model's skates) that slide
    /// ([`ezy_core::friction`]); empty without friction.
    sliding: Vec<Vec<usize>>,
}

impl<M: Model> Observer<M> for Frames {
    type Error = std::convert::Infallible;
    fn observe(&mut self, sys: &Dynamics<M>, s: &Sample<'_>) -> Result<(), Self::Error> {
        self.t.push(s.t);
        self.q.push(s.q.to_vec());
        self.sliding.push(sys.friction.iter().filter(|f| f.mode.is_sliding()).map(|f| f.skate).collect());
        Ok(())
    }
}

impl Frames {
    /// Number of frames.
    pub(crate) fn len(&self) -> usize {
        self.t.len()
    }
}

/// Draws `frames` of a run of `scene` on `sys` and writes the GIF
/// `anim.out` atomically; returns the frame size \[px\].
///
/// # Errors
/// [`AnimationError::Setting`] for a `[draw]` table naming an unknown
/// point or a motion that cannot be drawn, [`AnimationError::Draw`] and
/// [`AnimationError::Write`].
pub(crate) fn write<M: Model>(
    sys: &Dynamics<M>,
    scene: &Scene,
    frames: &Frames,
    anim: &AnimateOptions,
) -> Result<(u32, u32), AnimationError> {
    let geometry = Geometry::new(sys, scene, frames)?;
    write_gif(&geometry, frames, anim)
}

/// The colour of a skate that slides.
const SLIDING: RGBColor = RGBColor(214, 39, 40);

/// Checks `anim` and returns the number of frames for `t_end`.
///
/// # Errors
/// [`AnimationError::Setting`] naming the flag.
pub(crate) fn frame_count(anim: &AnimateOptions, t_end: f64) -> Result<usize, AnimationError> {
    let bad = |m: String| Err(AnimationError::Setting(m));
    if !(anim.fps.is_finite() && (1.0..=50.0).contains(&anim.fps)) {
        return bad(format!("--fps {}: the frame rate is from 1 to 50 frames per second", fmt_value(anim.fps)));
    }
    if !(anim.speed.is_finite() && anim.speed > 0.0) {
        return bad(format!("--speed {}: the speed (simulated seconds per second) must be > 0", fmt_value(anim.speed)));
    }
    if !(anim.trail.is_finite() && anim.trail >= 0.0) {
        return bad(format!("--trail {}: the trail length [s] must be >= 0", fmt_value(anim.trail)));
    }
    if !(ezy_scene::MIN_DPI..=ezy_scene::MAX_DPI).contains(&anim.dpi) {
        return bad(format!(
            "--dpi {}: the resolution is from {} to {} dpi",
            fmt_value(anim.dpi),
            ezy_scene::MIN_DPI,
            ezy_scene::MAX_DPI
        ));
    }
    match anim.out.extension().and_then(|e| e.to_str()) {
        Some(e) if e.eq_ignore_ascii_case("gif") => {}
        _ => {
            return bad(format!(
                "--out {}: animations are written as GIF, the name must end in .gif (MP4 would need a video encoder this program does not carry)",
                anim.out.display()
            ));
        }
    }
    let frames = (t_end * anim.fps / anim.speed).floor() + 2.0;
    if frames > MAX_FRAMES as f64 {
        return bad(format!(
            "{} frames ({} s at {} fps and speed {}) are more than {MAX_FRAMES}: raise --speed to at least {} or lower --fps",
            fmt_value(frames),
            fmt_value(t_end),
            fmt_value(anim.fps),
            fmt_value(anim.speed),
            fmt_value(format!("{:.3e}", t_end * anim.fps / (MAX_FRAMES as f64 - 2.0)).parse().unwrap_or(f64::NAN))
        ));
    }
    Ok(frames as usize)
}

/// A spring's two ends: position \[m\] and whether fixed to the ground.
type SpringEnds = [([f64; 2], bool); 2];

/// One body's outline: indices into the drawn positions (points, then
/// the body's centre of mass as `npoints + body`), and whether it closes.
struct Outline {
    nodes: Vec<usize>,
    closed: bool,
}

/// Everything a frame draws, at every frame: world positions of the named
/// points and the centres of mass, skate blades, hinges, springs.
struct Geometry {
    /// Per frame: positions of the points, then of the bodies' centres of
    /// mass \[m\].
    positions: Vec<Vec<[f64; 2]>>,
    /// Per frame: each skate's contact point index, blade direction and
    /// whether it slides (drawn red).
    blades: Vec<Vec<(usize, [f64; 2], bool)>>,
    /// Per frame: each spring's ends (position, fixed to the ground).
    springs: Vec<Vec<SpringEnds>>,
    /// Hinge point indices, with whether the hinge is to the ground.
    hinges: Vec<(usize, bool)>,
    /// Outline of every body.
    outlines: Vec<Outline>,
    /// Points with trails.
    trails: Vec<usize>,
    /// Vehicle size: largest distance between two drawn positions in one
    /// frame \[m\] (at least 0.1 m).
    size: f64,
    /// The fixed view (x, y ranges), or `None` to follow the vehicle.
    view: Option<([f64; 2], [f64; 2])>,
}

impl Geometry {
    fn new<M: Model>(sys: &Dynamics<M>, scene: &Scene, frames: &Frames) -> Result<Self, AnimationError> {
        let info = &sys.info;
        let (np, nb) = (info.points.len(), info.bodies.len());
        let mut local = vec![0.0; 2 * np];
        let mut blade_local = vec![0.0; 2 * info.skates.len()];
        sys.model.local_geometry(&mut local, &mut blade_local);
        let mut buf = vec![0.0; 2 * np];
        let mut positions = Vec::with_capacity(frames.q.len());
        let mut blades = Vec::with_capacity(frames.q.len());
        let mut springs = Vec::with_capacity(frames.q.len());
        for (frame, q) in frames.q.iter().enumerate() {
            let sliding = frames.sliding.get(frame).map_or(&[][..], Vec::as_slice);
            sys.model.points(q, &mut buf);
            let mut pos: Vec<[f64; 2]> = buf.chunks_exact(2).map(|c| [c[0], c[1]]).collect();
            pos.extend(info.bodies.iter().map(|b| [q[b.coords[0]], q[b.coords[1]]]));
            blades.push(
                info.skates
                    .iter()
                    .enumerate()
                    .map(|(k, s)| {
                        let phi = q[info.bodies[info.points[s.point].body].coords[2]];
                        let (sn, cs) = phi.sin_cos();
                        let (tx, ty) = (blade_local[2 * k], blade_local[2 * k + 1]);
                        (s.point, [cs * tx - sn * ty, sn * tx + cs * ty], sliding.contains(&k))
                    })
                    .collect(),
            );
            springs.push(sys.effects.iter().filter_map(|e| e.spring_ends(q)).collect());
            positions.push(pos);
        }
        let outlines = (0..nb)
            .map(|b| {
                let name = &info.bodies[b].name;
                if let Some((_, listed)) = scene.draw.iter().find(|(n, _)| n == name) {
                    let nodes: Vec<usize> = listed
                        .iter()
                        .map(|p| if p == "cm" { Some(np + b) } else { info.point_index(p) })
                        .collect::<Option<_>>()
                        .ok_or_else(|| AnimationError::Setting(format!("[draw] {name}: unknown point")))?;
                    let closed = nodes.len() >= 3;
                    return Ok(Outline { nodes, closed });
                }
                let mine: Vec<usize> = (0..np).filter(|&k| info.points[k].body == b).collect();
                Ok(match mine.len() {
                    0 => Outline { nodes: vec![np + b], closed: false },
                    1 => Outline { nodes: vec![np + b, mine[0]], closed: false },
                    2 => Outline { nodes: mine, closed: false },
                    _ => {
                        // a polygon: the points by angle about their centroid in the body frame
                        let c = mine.iter().fold([0.0, 0.0], |a, &k| [a[0] + local[2 * k], a[1] + local[2 * k + 1]]);
                        let c = [c[0] / mine.len() as f64, c[1] / mine.len() as f64];
                        let mut nodes = mine;
                        let angle = |k: &usize| (local[2 * k + 1] - c[1]).atan2(local[2 * k] - c[0]);
                        nodes.sort_by(|a, b| angle(a).total_cmp(&angle(b)));
                        Outline { nodes, closed: true }
                    }
                })
            })
            .collect::<Result<Vec<_>, AnimationError>>()?;
        let hinges = info.hinges.iter().map(|h| (h.point, h.body_b.is_none())).collect();
        let trails = if info.skates.is_empty() {
            (0..np).take(8).collect()
        } else {
            info.skates.iter().map(|s| s.point).take(8).collect()
        };
        let mut size: f64 = 0.1;
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        let frame_ends = springs.iter().map(|s: &Vec<SpringEnds>| s.iter().flat_map(|e| [e[0].0, e[1].0]));
        for (pos, ends) in positions.iter().zip(frame_ends) {
            let all: Vec<[f64; 2]> = pos.iter().copied().chain(ends).collect();
            for p in &all {
                for d in 0..2 {
                    lo[d] = lo[d].min(p[d]);
                    hi[d] = hi[d].max(p[d]);
                }
            }
            // the vehicle's size: the diagonal of its bounding box (linear in
            // the number of points, where all pairs would be quadratic)
            let (mut flo, mut fhi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
            for p in &all {
                for d in 0..2 {
                    flo[d] = flo[d].min(p[d]);
                    fhi[d] = fhi[d].max(p[d]);
                }
            }
            size = size.max((fhi[0] - flo[0]).hypot(fhi[1] - flo[1]));
        }
        let drawable = |v: f64| v.is_finite() && v.abs() <= crate::render::plot::MAX_MAGNITUDE;
        if !(lo.iter().chain(&hi).all(|&v| drawable(v)) && size.is_finite()) {
            return Err(AnimationError::Setting(format!(
                "the motion reaches positions that cannot be drawn (not finite, or beyond {:e} m)",
                crate::render::plot::MAX_MAGNITUDE
            )));
        }
        let span = (hi[0] - lo[0]).max(hi[1] - lo[1]);
        let view = (span <= FOLLOW_FACTOR * size).then(|| {
            let pad = 0.15 * size;
            ([lo[0] - pad, hi[0] + pad], [lo[1] - pad, hi[1] + pad])
        });
        Ok(Self { positions, blades, springs, hinges, outlines, trails, size, view })
    }

    /// The x and y ranges of frame `k` for a `w x h` plot (equal scales).
    fn view_at(&self, k: usize, (w, h): (u32, u32)) -> ([f64; 2], [f64; 2]) {
        let (cx, cy, half_w) = match self.view {
            Some((x, y)) => {
                let half = 0.5 * (x[1] - x[0]).max((y[1] - y[0]) * f64::from(w) / f64::from(h));
                (0.5 * (x[0] + x[1]), 0.5 * (y[0] + y[1]), half)
            }
            None => {
                let pos = &self.positions[k];
                let n = pos.len() as f64;
                let c = pos.iter().fold([0.0, 0.0], |a, p| [a[0] + p[0], a[1] + p[1]]);
                (c[0] / n, c[1] / n, 0.5 * FOLLOW_WIDTH * self.size)
            }
        };
        let half_h = half_w * f64::from(h) / f64::from(w);
        ([cx - half_w, cx + half_w], [cy - half_h, cy + half_h])
    }
}

/// Frame `k` as SVG.
fn frame_svg(g: &Geometry, frames: &Frames, k: usize, anim: &AnimateOptions) -> Result<String, String> {
    let mut svg = String::new();
    {
        let (w, h) = (crate::render::plot::WIDTH * SCALE, crate::render::plot::HEIGHT * SCALE);
        let root = SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        // text, and the margins that hold it, enlarged at low resolutions
        let zoom = text_zoom(anim.dpi);
        let z = |size: f64| (size * zoom * f64::from(SCALE)).round() as u32;
        let mut builder = ChartBuilder::on(&root);
        builder.margin(12 * SCALE).x_label_area_size(z(40.0)).y_label_area_size(z(70.0));
        let probe = builder.build_cartesian_2d(0.0..1.0, 0.0..1.0).map_err(|e| e.to_string())?;
        let dim = probe.plotting_area().dim_in_pixel();
        let (xr, yr) = g.view_at(k, dim);
        let mut ctx = builder
            .build_cartesian_2d(Axis::linear(xr[0]..xr[1]), Axis::linear(yr[0]..yr[1]))
            .map_err(|e| e.to_string())?;
        ctx.configure_mesh()
            .light_line_style(TRANSPARENT_COLOUR)
            .bold_line_style(RGBColor(220, 220, 220))
            .label_style(("sans-serif", z(TICK_SIZE)))
            .x_desc("x [m]")
            .y_desc("y [m]")
            .axis_desc_style(("sans-serif", z(DESC_SIZE)))
            .draw()
            .map_err(|e| e.to_string())?;
        let px_per_m = f64::from(dim.0) / (xr[1] - xr[0]);
        let m = |px: f64| px / px_per_m;
        let pos = &g.positions[k];
        let err = |e: DrawingAreaErrorKind<_>| e.to_string();

        // trails: older segments fainter
        if anim.trail > 0.0 {
            let t = frames.t[k];
            let first = frames.t.partition_point(|&s| s < t - anim.trail);
            for (ti, &p) in g.trails.iter().enumerate() {
                let colour = PALETTE[(ti + 3) % PALETTE.len()];
                for j in first..k {
                    let age = (t - frames.t[j]) / anim.trail.max(1e-12);
                    let a = g.positions[j][p];
                    let b = g.positions[j + 1][p];
                    // plotters clamps, not clips, what leaves the plot: such segments are left out
                    let inside = |p: [f64; 2]| (xr[0]..=xr[1]).contains(&p[0]) && (yr[0]..=yr[1]).contains(&p[1]);
                    if !(inside(a) && inside(b)) {
                        continue;
                    }
                    let style = colour.mix(0.85 * (1.0 - age).clamp(0.05, 1.0)).stroke_width(2 * SCALE);
                    ctx.draw_series(std::iter::once(PathElement::new(vec![(a[0], a[1]), (b[0], b[1])], style)))
                        .map_err(err)?;
                }
            }
        }
        // springs: zig-zags, ground ends anchored
        for ends in &g.springs[k] {
            let (a, b) = (ends[0].0, ends[1].0);
            ctx.draw_series(std::iter::once(PathElement::new(
                zigzag(a, b, m(10.0 * f64::from(SCALE))),
                BLACK.stroke_width(SCALE),
            )))
            .map_err(err)?;
            for (p, ground) in ends {
                if *ground {
                    anchor(&mut ctx, *p, m(14.0 * f64::from(SCALE)))?;
                }
            }
        }
        // bodies: outline, light fill, centre of mass
        for (b, o) in g.outlines.iter().enumerate() {
            let colour = PALETTE[b % PALETTE.len()];
            let pts: Vec<(f64, f64)> = o.nodes.iter().map(|&n| (pos[n][0], pos[n][1])).collect();
            if o.closed {
                ctx.draw_series(std::iter::once(Polygon::new(pts.clone(), colour.mix(0.2).filled()))).map_err(err)?;
                let mut ring = pts.clone();
                ring.push(pts[0]);
                ctx.draw_series(std::iter::once(PathElement::new(ring, colour.stroke_width(3 * SCALE))))
                    .map_err(err)?;
            } else if pts.len() >= 2 {
                ctx.draw_series(std::iter::once(PathElement::new(pts, colour.stroke_width(5 * SCALE)))).map_err(err)?;
            }
            let np = pos.len() - g.outlines.len();
            let c = pos[np + b];
            let r = 6 * SCALE as i32;
            ctx.draw_series(std::iter::once(
                EmptyElement::at((c[0], c[1]))
                    + Circle::new((0, 0), r, WHITE.filled())
                    + Circle::new((0, 0), r, colour.stroke_width(SCALE))
                    + PathElement::new(vec![(-r, 0), (r, 0)], colour.stroke_width(SCALE))
                    + PathElement::new(vec![(0, -r), (0, r)], colour.stroke_width(SCALE)),
            ))
            .map_err(err)?;
        }
        // skates: short thick blades along their direction
        let half = 0.5 * m(36.0 * f64::from(SCALE)).min(0.25 * g.size);
        for &(p, d, sliding) in &g.blades[k] {
            let c = pos[p];
            let a = (c[0] - half * d[0], c[1] - half * d[1]);
            let e = (c[0] + half * d[0], c[1] + half * d[1]);
            // a skate that slides sideways (friction at its limit): red
            let colour = if sliding { SLIDING } else { BLACK };
            ctx.draw_series(std::iter::once(PathElement::new(vec![a, e], colour.stroke_width(6 * SCALE))))
                .map_err(err)?;
        }
        // hinges: white circles; to the ground: anchored
        for &(p, ground) in &g.hinges {
            let c = (pos[p][0], pos[p][1]);
            if ground {
                anchor(&mut ctx, pos[p], m(14.0 * f64::from(SCALE)))?;
            }
            let r = 7 * SCALE as i32;
            ctx.draw_series(std::iter::once(
                EmptyElement::at(c)
                    + Circle::new((0, 0), r, WHITE.filled())
                    + Circle::new((0, 0), r, BLACK.stroke_width(2 * SCALE)),
            ))
            .map_err(err)?;
        }
        let label = if anim.speed == 1.0 {
            format!("t = {:.2} s (real time)", frames.t[k])
        } else {
            format!("t = {:.2} s ({}x real time)", frames.t[k], (anim.speed * 1000.0).round() / 1000.0)
        };
        let at = (z(90.0) as i32, z(18.0) as i32);
        root.draw(&Text::new(label, at, ("sans-serif", z(TIME_SIZE)).into_font())).map_err(|e| e.to_string())?;
        root.present().map_err(|e| e.to_string())?;
    }
    Ok(crate::render::plot::snap::nominal_size(svg))
}

/// No line at all (the mesh's light lines).
const TRANSPARENT_COLOUR: RGBAColor = RGBAColor(255, 255, 255, 0.0);

/// A zig-zag from `a` to `b` with teeth `w` \[m\] wide: straight ends,
/// eight teeth between.
fn zigzag(a: [f64; 2], b: [f64; 2], w: f64) -> Vec<(f64, f64)> {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let len = dx.hypot(dy).max(1e-12);
    let (nx, ny) = (-dy / len, dx / len);
    let mut out = vec![(a[0], a[1])];
    let teeth = 8;
    for i in 0..=2 * teeth {
        let s = 0.15 + 0.7 * f64::from(i) / f64::from(2 * teeth);
        let side = match i {
            0 => 0.0,
            _ if i == 2 * teeth => 0.0,
            _ if i % 2 == 1 => 0.5 * w,
            _ => -0.5 * w,
        };
        out.push((a[0] + s * dx + side * nx, a[1] + s * dy + side * ny));
    }
    out.push((b[0], b[1]));
    out
}

/// A ground anchor at `p`: a triangle below it on a hatched base, `s` \[m\] wide.
fn anchor<'a>(
    ctx: &mut ChartContext<'a, SVGBackend<'a>, Cartesian2d<Axis, Axis>>,
    p: [f64; 2],
    s: f64,
) -> Result<(), String> {
    let (x, y) = (p[0], p[1]);
    let base = y - s;
    let grey = RGBColor(90, 90, 90);
    ctx.draw_series(std::iter::once(Polygon::new(
        vec![(x, y), (x - 0.6 * s, base), (x + 0.6 * s, base)],
        RGBColor(210, 210, 210).filled(),
    )))
    .map_err(|e| e.to_string())?;
    ctx.draw_series(std::iter::once(PathElement::new(
        vec![(x - s, base), (x + s, base)],
        grey.stroke_width(2 * SCALE),
    )))
    .map_err(|e| e.to_string())?;
    let hatch = (0..6).map(|i| {
        let x0 = x - s + f64::from(i) * 0.4 * s;
        PathElement::new(vec![(x0 + 0.3 * s, base), (x0, base - 0.3 * s)], grey.stroke_width(SCALE))
    });
    ctx.draw_series(hatch).map_err(|e| e.to_string())?;
    Ok(())
}

/// Draws every frame, quantizes them onto one palette and writes the GIF
/// atomically; returns the frame size.
fn write_gif(g: &Geometry, frames: &Frames, anim: &AnimateOptions) -> Result<(u32, u32), AnimationError> {
    let fail = |message: String| AnimationError::Write { path: anim.out.clone(), message };
    let (bytes, size) = encode_gif(g, frames, anim)?;
    if let Some(dir) = anim.out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| fail(format!("creating {}: {e}", dir.display())))?;
    }
    crate::output::transaction::write_atomically(&anim.out, &bytes).map_err(|e| fail(e.to_string()))?;
    Ok(size)
}

/// The GIF of `frames` in memory, and its frame size.
fn encode_gif(g: &Geometry, frames: &Frames, anim: &AnimateOptions) -> Result<(Vec<u8>, (u32, u32)), AnimationError> {
    let n = frames.t.len();
    let draw = |k: usize| -> Result<(u32, u32, Vec<u8>), AnimationError> {
        let svg = frame_svg(g, frames, k, anim).map_err(|message| AnimationError::Draw {
            frame: k,
            source: PlotError::Draw { title: "animation".into(), message },
        })?;
        crate::render::plot::raster::rgba(&svg, anim.dpi).map_err(|source| AnimationError::Draw { frame: k, source })
    };
    // the palette: NeuQuant over the first, middle and last frames
    let mut sample = Vec::new();
    let mut size = (0, 0);
    for k in [0, n / 2, n.saturating_sub(1)] {
        let (w, h, px) = draw(k)?;
        size = (w, h);
        sample.extend_from_slice(&px);
    }
    // 255 colours and a transparent index: a pixel equal to the previous
    // frame's is left transparent, which LZW packs into almost nothing
    let nq = color_quant::NeuQuant::new(10, 255, &sample);
    let mut palette = nq.color_map_rgb();
    palette.extend_from_slice(&[255, 0, 255]);
    let mut previous: Option<Vec<u8>> = None;
    let fail = |message: String| AnimationError::Write { path: anim.out.clone(), message };
    let mut bytes = Vec::new();
    {
        let mut enc =
            gif::Encoder::new(&mut bytes, size.0 as u16, size.1 as u16, &palette).map_err(|e| fail(e.to_string()))?;
        enc.set_repeat(gif::Repeat::Infinite).map_err(|e| fail(e.to_string()))?;
        let delay = (100.0 / anim.fps).round().max(1.0) as u16;
        for start in (0..n).step_by(CHUNK) {
            let chunk: Vec<Result<Vec<u8>, AnimationError>> = (start..(start + CHUNK).min(n))
                .into_par_iter()
                .map(|k| {
                    let (_, _, px) = draw(k)?;
                    let mut cache = std::collections::HashMap::new();
                    Ok(px
                        .chunks_exact(4)
                        .map(|p| {
                            let key = u32::from_le_bytes([p[0], p[1], p[2], 0]);
                            *cache.entry(key).or_insert_with(|| nq.index_of(p) as u8)
                        })
                        .collect())
                })
                .collect();
            for indices in chunk {
                let indices = indices?;
                let buffer = match &previous {
                    Some(p) => indices.iter().zip(p).map(|(&i, &j)| if i == j { TRANSPARENT } else { i }).collect(),
                    None => indices.clone(),
                };
                previous = Some(indices);
                let frame = gif::Frame {
                    width: size.0 as u16,
                    height: size.1 as u16,
                    delay,
                    dispose: gif::DisposalMethod::Keep,
                    transparent: Some(TRANSPARENT),
                    buffer: std::borrow::Cow::Owned(buffer),
                    ..gif::Frame::default()
                };
                enc.write_frame(&frame).map_err(|e| fail(e.to_string()))?;
            }
        }
    }
    Ok((bytes, size))
}

/// An animation of a finished run from its trajectory table (for the run
/// report): every `stride`-th row, so that there are at most `max_frames`
/// frames, at `fps` frames per second and `dpi`; returns the GIF's bytes.
///
/// # Errors
/// [`AnimationError::Setting`] if the table lacks a coordinate column or
/// has no rows, [`AnimationError::Draw`] and [`AnimationError::Write`].
pub(crate) fn gif_of_table<M: Model>(
    sys: &Dynamics<M>,
    scene: &Scene,
    table: &crate::output::csv::Table,
    max_frames: usize,
    fps: f64,
    dpi: f64,
) -> Result<Vec<u8>, AnimationError> {
    let cols: Vec<usize> = sys
        .info
        .coords
        .iter()
        .map(|c| table.index(c).ok_or_else(|| AnimationError::Setting(format!("no column `{c}` in the trajectory"))))
        .collect::<Result<_, _>>()?;
    let t: Vec<f64> = table.column(0).collect();
    if t.is_empty() {
        return Err(AnimationError::Setting("the trajectory has no rows".into()));
    }
    let stride = t.len().div_ceil(max_frames.max(2) - 1).max(1);
    let mut rows: Vec<usize> = (0..t.len()).step_by(stride).collect();
    if rows.last() != Some(&(t.len() - 1)) {
        rows.push(t.len() - 1);
    }
    let columns: Vec<Vec<f64>> = cols.iter().map(|&c| table.column(c).collect()).collect();
    // the skates' modes, where the trajectory has them (`sliding_<skate>`)
    let modes: Vec<(usize, Vec<f64>)> = (sys.info.skates.iter().enumerate())
        .filter_map(|(k, s)| table.index(&format!("sliding_{}", s.name)).map(|c| (k, table.column(c).collect())))
        .collect();
    let frames = Frames {
        t: rows.iter().map(|&r| t[r]).collect(),
        q: rows.iter().map(|&r| columns.iter().map(|c| c[r]).collect()).collect(),
        sliding: rows.iter().map(|&r| modes.iter().filter(|(_, m)| m[r] != 0.0).map(|(k, _)| *k).collect()).collect(),
    };
    let span = frames.t.last().copied().unwrap_or(0.0) - frames.t[0];
    let speed = (span / (frames.t.len().max(2) - 1) as f64 * fps).max(f64::MIN_POSITIVE);
    let anim = AnimateOptions { out: PathBuf::from("report.gif"), fps, speed, trail: 3.0 * speed, dpi };
    let geometry = Geometry::new(sys, scene, &frames)?;
    Ok(encode_gif(&geometry, &frames, &anim)?.0)
}
