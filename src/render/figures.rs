//! Scene figures: [`FigureSpec`]s resolved against the trajectory table and
//! drawn with [`crate::render::plot`]. Every value is checked before anything is
//! drawn: a value that is not finite or beyond
//! [`crate::render::plot::MAX_MAGNITUDE`] is an error naming the figure file, the
//! column, the value and its time.

use ezy_core::ModelInfo;

use ezy_scene::{Column, FigureFormat, FigureSpec};

use crate::output::csv::Table;
use crate::render::plot::PlotError;
use crate::render::plot::series::{Chart, Series};

/// Errors drawing a scene figure.
#[derive(Debug, thiserror::Error)]
pub enum FigureError {
    /// The figure names a column the table does not have.
    #[error("figure {figure}: no column `{column}` in the trajectory")]
    Column {
        /// Figure file name.
        figure: String,
        /// Missing column.
        column: String,
    },
    /// A value the figure would have to draw cannot be drawn: it is not
    /// finite, or its magnitude is beyond [`crate::render::plot::MAX_MAGNITUDE`].
    #[error("figure {figure}: column `{column}` is {value:e} at t = {} s, which {reason}; the figure is not drawn", ezy_core::fmt_value(*t))]
    Value {
        /// Figure file name.
        figure: String,
        /// The column (or column expression, `norm(x1d, y1d)`).
        column: String,
        /// The value.
        value: f64,
        /// The row's time in seconds.
        t: f64,
        /// Why it cannot be drawn.
        reason: &'static str,
    },
    /// Drawing failed.
    #[error("figure {figure}: {source}")]
    Plot {
        /// Figure file name.
        figure: String,
        /// The cause.
        #[source]
        source: PlotError,
    },
}

/// Greek letter names written as their letters in [`typeset`] (names
/// that are also English words, `eta`, `nu`, `xi`, are left alone).
const GREEK: [(&str, char); 17] = [
    ("alpha", 'α'),
    ("beta", 'β'),
    ("gamma", 'γ'),
    ("delta", 'δ'),
    ("epsilon", 'ε'),
    ("theta", 'θ'),
    ("kappa", 'κ'),
    ("lambda", 'λ'),
    ("mu", 'μ'),
    ("pi", 'π'),
    ("rho", 'ρ'),
    ("sigma", 'σ'),
    ("tau", 'τ'),
    ("phi", 'φ'),
    ("psi", 'ψ'),
    ("omega", 'ω'),
    ("Phi", 'Φ'),
];

/// A figure text with coordinate names typeset as mathematics in Unicode:
/// a Greek letter name becomes the letter, trailing digits a subscript and
/// a trailing `d` (`dd`) after them a dot (two dots) over the letter, so
/// `phi2d - phi1d [rad/s]` reads `φ̇₂ − φ̇₁ [rad/s]`, `x1d` `ẋ₁` and
/// `tau` `τ`; a ` - ` between spaces becomes a minus sign. Words with
/// an underscore (`W_motor`) and other words are left as they are.
pub(crate) fn typeset(text: &str) -> String {
    let mut out = String::with_capacity(text.len() + 8);
    let mut word = String::new();
    let flush = |word: &mut String, out: &mut String| {
        out.push_str(&typeset_word(word));
        word.clear();
    };
    for c in text.chars() {
        if c.is_ascii_alphanumeric() || c == '_' {
            word.push(c);
        } else {
            flush(&mut word, &mut out);
            out.push(c);
        }
    }
    flush(&mut word, &mut out);
    out.replace(" - ", " \u{2212} ")
}

/// One word of [`typeset`].
fn typeset_word(w: &str) -> String {
    for (suffix, dot) in [("dd", "\u{308}"), ("d", "\u{307}"), ("", "")] {
        if let Some(base) = w.strip_suffix(suffix)
            && let Some(t) = typeset_symbol(base, dot)
        {
            return t;
        }
    }
    w.to_string()
}

/// `base` (a Greek letter name or a single letter, then digits) as its
/// letter with `dot` over it and the digits as a subscript; `None` if it
/// is no such symbol. Without digits, only Greek letters and (with a dot)
/// `x`, `y` and `q` count: `a` or `d` alone are words.
fn typeset_symbol(base: &str, dot: &str) -> Option<String> {
    const SUB: [char; 10] = ['₀', '₁', '₂', '₃', '₄', '₅', '₆', '₇', '₈', '₉'];
    let split = base.trim_end_matches(|c: char| c.is_ascii_digit()).len();
    let (stem, digits) = base.split_at(split);
    let greek = GREEK.iter().find(|(n, _)| *n == stem).map(|&(_, c)| c);
    let single = (stem.len() == 1).then(|| stem.chars().next()).flatten().filter(char::is_ascii_alphabetic);
    let letter = match (greek, single) {
        (Some(g), _) => g,
        (None, Some(c)) if !digits.is_empty() || (!dot.is_empty() && "xyq".contains(c)) => c,
        _ => return None,
    };
    let mut s = String::from(letter);
    s.push_str(dot);
    s.extend(digits.bytes().map(|d| SUB[usize::from(d - b'0')]));
    Some(s)
}

/// Floor of logarithmic axes: exact zeros (a residual projected to machine
/// zero) are drawn here.
pub(crate) const LOG_FLOOR: f64 = 1e-18;

/// Values of a column expression, one per row.
///
/// # Errors
/// [`FigureError::Column`] if a named column does not exist.
pub(crate) fn values(table: &Table, col: &Column, figure: &str) -> Result<Vec<f64>, FigureError> {
    let get = |name: &str| named(table, name, figure);
    Ok(match col {
        Column::Named(a) => get(a)?,
        Column::Norm(a, b) => get(a)?.into_iter().zip(get(b)?).map(|(x, y)| x.hypot(y)).collect(),
        Column::Diff(a, b) => get(a)?.into_iter().zip(get(b)?).map(|(x, y)| x - y).collect(),
        Column::BalanceGap(a, b) => {
            let v = get(a)?;
            let v0 = v.first().copied().unwrap_or(0.0);
            v.into_iter().zip(get(b)?).map(|(x, w)| (x - v0 - w).abs()).collect()
        }
        Column::FromStart(a) => {
            let v = get(a)?;
            let v0 = v.first().copied().unwrap_or(0.0);
            v.into_iter().map(|x| x - v0).collect()
        }
    })
}

/// Values of the column called `name`.
fn named(table: &Table, name: &str, figure: &str) -> Result<Vec<f64>, FigureError> {
    let k = table.index(name).ok_or_else(|| FigureError::Column { figure: figure.into(), column: name.into() })?;
    Ok(table.column(k).collect())
}

/// Checks that every value of `column` can be drawn (see
/// [`FigureError::Value`]); `times` are the rows' times \[s\], `log` whether
/// the column is drawn on a logarithmic axis (where any finite value can).
fn check_values(figure: &str, column: String, values: &[f64], times: &[f64], log: bool) -> Result<(), FigureError> {
    for (k, &v) in values.iter().enumerate() {
        let reason = if !v.is_finite() {
            "is not a finite number"
        } else if !log && v.abs() > crate::render::plot::MAX_MAGNITUDE {
            "is too large to plot (magnitude above 1e100)"
        } else {
            continue;
        };
        let t = times.get(k).copied().unwrap_or(f64::NAN);
        return Err(FigureError::Value { figure: figure.into(), column, value: v, t, reason });
    }
    Ok(())
}

/// Draws `fig` from `table` as SVG (see [`chart`] and
/// [`crate::render::plot::chart::chart_svg`]).
///
/// # Errors
/// As [`chart`], and [`FigureError::Plot`] for a drawing failure.
pub(crate) fn svg(info: &ModelInfo, fig: &FigureSpec, table: &Table) -> Result<String, FigureError> {
    crate::render::plot::chart::chart_svg(&chart(info, fig, table)?)
        .map_err(|source| FigureError::Plot { figure: fig.file.clone(), source })
}

/// How many threads [`render_all`] encodes `figures` figures on: one per
/// core (`std::thread::available_parallelism`), at most one per figure,
/// none (the calling thread) inside a rayon pool, whose threads (a
/// sweep's runs) are busy already. Asks rayon nothing that would start
/// its global pool, whose idle workers would spin beside the run.
pub(crate) fn encoding_threads(figures: usize) -> usize {
    if rayon::current_thread_index().is_some() {
        0
    } else {
        std::thread::available_parallelism().map_or(1, std::num::NonZero::get).min(figures)
    }
}

/// Draws every figure of `figs` from `table` (its SVG, [`svg`], then the
/// file's bytes in `format`, PNG at `dpi`, encoded from it) and hands
/// each to `done(index, svg, bytes)` on the calling thread as soon as it
/// is encoded, in the order they finish (not that of `figs`): the caller
/// writes one figure while the others are drawn, and holds none longer.
/// `check` is asked before a figure is drawn and again before it is
/// encoded (a signal); its error, a drawing's or `done`'s stops the
/// drawing at the next figure and is returned.
///
/// One thread per core ([`encoding_threads`]) draws the SVGs, each
/// taking the next figure as it finishes one, and then rasterizes and
/// encodes them largest first, each taking the largest drawn figure no
/// thread has taken: list scheduling in decreasing size (Graham's
/// longest-processing-time rule, within 4/3 of the best schedule; R. L.
/// Graham, "Bounds on multiprocessing timing anomalies", SIAM J. Appl.
/// Math. 17 (1969)), without waiting for the other thread's last drawing.
/// An SVG's length stands for its cost, the rasterizer's work growing
/// with the points it strokes. Taken in file order, two at a time, a
/// drive run waited for the slower figure of each pair. Called from a
/// rayon worker (a sweep's saved runs, already one per core) or where no
/// thread can be started, the calling thread draws them all and then
/// encodes them one by one.
///
/// # Errors
/// The first error received: `check`'s, a drawing's, an encoding's
/// ([`FigureError::Plot`]) or `done`'s; on the calling thread, an SVG that cannot be
/// drawn (the first in the order of `figs`) before any figure is
/// encoded.
pub(crate) fn render_all<E>(
    info: &ModelInfo,
    figs: &[FigureSpec],
    table: &Table,
    format: FigureFormat,
    dpi: f64,
    check: impl Fn(&FigureSpec) -> Result<(), E> + Sync,
    mut done: impl FnMut(usize, &str, Vec<u8>) -> Result<(), E>,
) -> Result<(), E>
where
    E: From<FigureError> + Send,
{
    use std::sync::atomic::{AtomicBool, Ordering};
    let n = figs.len();
    let draw = |i: usize| -> Result<String, E> {
        check(&figs[i])?;
        Ok(svg(info, &figs[i], table)?)
    };
    let encode = |i: usize, svg: &str| -> Result<Vec<u8>, E> {
        let fig = &figs[i];
        check(fig)?;
        crate::render::plot::raster::encode(svg, format, dpi, &fig.title)
            .map_err(|source| FigureError::Plot { figure: fig.file.clone(), source }.into())
    };
    let threads = encoding_threads(n);
    // the shared schedule: the next figure to draw, and each figure's
    // SVG from its drawing until a thread takes it to encode
    struct Board<E> {
        next: usize,
        drawn: Vec<Option<Result<String, E>>>,
    }
    let board = std::sync::Mutex::new(Board { next: 0, drawn: (0..n).map(|_| None).collect() });
    let stop = AtomicBool::new(false);
    // what a worker does next: draw the next figure while any is left,
    // then encode the largest drawn one no thread has taken (its SVG's
    // length standing for its cost); `None` when nothing is left for it
    // (a figure still being drawn is encoded by its drawer)
    enum Job<E> {
        Draw(usize),
        Encode(usize, String),
        Failed(usize, E),
    }
    let take = |board: &mut Board<E>| -> Option<Job<E>> {
        if board.next < n {
            board.next += 1;
            return Some(Job::Draw(board.next - 1));
        }
        let i = (0..n).filter(|&i| board.drawn[i].is_some()).max_by_key(|&i| {
            (
                matches!(board.drawn[i], Some(Err(_))),
                board.drawn[i].as_ref().map_or(0, |d| d.as_ref().map_or(0, String::len)),
            )
        })?;
        match board.drawn[i].take().expect("drawn") {
            Ok(svg) => Some(Job::Encode(i, svg)),
            Err(e) => Some(Job::Failed(i, e)),
        }
    };
    type Message<E> = (usize, Result<(String, Vec<u8>), E>);
    std::thread::scope(|scope| {
        let (send, receive) = std::sync::mpsc::channel::<Message<E>>();
        let mut started = 0;
        for _ in 0..threads {
            let send = send.clone();
            let (board, stop, take, draw, encode) = (&board, &stop, &take, &draw, &encode);
            let worker = move || {
                while !stop.load(Ordering::Relaxed) {
                    let job = take(&mut board.lock().unwrap_or_else(std::sync::PoisonError::into_inner));
                    let message = match job {
                        None => break,
                        Some(Job::Draw(i)) => {
                            let svg = draw(i);
                            board.lock().unwrap_or_else(std::sync::PoisonError::into_inner).drawn[i] = Some(svg);
                            continue;
                        }
                        Some(Job::Encode(i, svg)) => (i, encode(i, &svg).map(|bytes| (svg, bytes))),
                        Some(Job::Failed(i, e)) => (i, Err(e)),
                    };
                    if send.send(message).is_err() {
                        break;
                    }
                }
            };
            if std::thread::Builder::new().name("ezy-figures".into()).spawn_scoped(scope, worker).is_ok() {
                started += 1;
            }
        }
        drop(send);
        if started == 0 {
            // on the calling thread: every drawing first, so that one that
            // cannot be drawn is found before any figure is written
            let svgs = (0..n).map(draw).collect::<Result<Vec<String>, E>>()?;
            let mut order: Vec<usize> = (0..n).collect();
            order.sort_by_key(|&i| std::cmp::Reverse(svgs[i].len()));
            for i in order {
                done(i, &svgs[i], encode(i, &svgs[i])?)?;
            }
            return Ok(());
        }
        let mut outcome = Ok(());
        // every figure arrives once, unless the drawing stopped
        for (i, result) in receive.iter().take(n) {
            if let Err(e) = result.and_then(|(svg, bytes)| done(i, &svg, bytes)) {
                stop.store(true, Ordering::Relaxed);
                outcome = Err(e);
                break;
            }
        }
        outcome
    })
}

/// The chart of `fig` from `table`: lines over `fig.x` in one or two
/// panels (lines with `panel = 2` in the lower one), or paths of points
/// and bodies' centres of mass with equal axes. Every value is checked
/// before drawing.
///
/// # Errors
/// [`FigureError::Column`] for a missing column, [`FigureError::Value`] for
/// a value that is not finite or too large to draw.
pub fn chart(info: &ModelInfo, fig: &FigureSpec, table: &Table) -> Result<Chart, FigureError> {
    let mut chart =
        Chart { log_floor: LOG_FLOOR, ..Chart::new(typeset(&fig.title), typeset(&fig.x_label), typeset(&fig.y_label)) };
    let times: Vec<f64> = if table.columns.is_empty() { Vec::new() } else { table.column(0).collect() };
    let check = |column: String, values: &[f64], log| check_values(&fig.file, column, values, &times, log);
    if fig.paths.is_empty() {
        chart.log_y = fig.log_y;
        if fig.lines.iter().any(|l| l.panel == 2) {
            chart.lower = fig.y2_label.as_deref().map(typeset);
        }
        let xs = values(table, &fig.x, &fig.file)?;
        check(fig.x.to_string(), &xs, false)?;
        for c in &fig.shade {
            chart.shade.extend(stretches(&times, &named(table, c, &fig.file)?));
        }
        for line in &fig.lines {
            let vs = values(table, &line.y, &fig.file)?;
            check(line.y.to_string(), &vs, fig.log_y)?;
            let panel = usize::from(line.panel.saturating_sub(1));
            chart
                .series
                .push(Series { panel, ..Series::new(typeset(&line.label), xs.iter().copied().zip(vs).collect()) });
        }
    } else {
        chart.equal_axes = true;
        for name in &fig.paths {
            let (x, y, label) = match info.bodies.iter().find(|b| b.name == *name) {
                Some(b) => {
                    let c = &info.coords;
                    (c[b.coords[0]].to_string(), c[b.coords[1]].to_string(), format!("centre of mass of {name}"))
                }
                None => (format!("{name}.x"), format!("{name}.y"), format!("point {name}")),
            };
            let xs = named(table, &x, &fig.file)?;
            let ys = named(table, &y, &fig.file)?;
            check(x, &xs, false)?;
            check(y, &ys, false)?;
            chart.series.push(Series::new(label, xs.into_iter().zip(ys).collect()));
        }
    }
    Ok(chart)
}

/// The stretches `(from, to)` of `times` over which `flags` is nonzero
/// (each from its first sample to the first sample after it).
fn stretches(times: &[f64], flags: &[f64]) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    let mut start = None;
    for (k, (&t, &f)) in times.iter().zip(flags).enumerate() {
        match (start, f != 0.0) {
            (None, true) => start = Some(t),
            (Some(s), false) => {
                out.push((s, t));
                start = None;
            }
            _ => {}
        }
        if k + 1 == times.len()
            && let Some(s) = start
        {
            out.push((s, t));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    #[test]
    fn stretches_of_nonzero_flags() {
        let t = [0.0, 1.0, 2.0, 3.0, 4.0];
        assert_eq!(super::stretches(&t, &[0.0, 1.0, 1.0, 0.0, 1.0]), vec![(1.0, 3.0), (4.0, 4.0)]);
        assert!(super::stretches(&t, &[0.0; 5]).is_empty());
    }

    use super::typeset;

    #[test]
    fn coordinate_names_are_typeset() {
        assert_eq!(typeset("phi2d - phi1d [rad/s]"), "φ̇₂ − φ̇₁ [rad/s]");
        assert_eq!(typeset("|(x1d, y1d)| [m/s]"), "|(x\u{307}₁, y\u{307}₁)| [m/s]");
        assert_eq!(typeset("tau [N m]"), "τ [N m]");
        assert_eq!(typeset("x1dd"), "x\u{308}₁");
        assert_eq!(typeset("phi1"), "φ₁");
        assert_eq!(typeset("|(xd, yd)|"), "|(x\u{307}, y\u{307})|");
        assert_eq!(typeset("phid"), "φ\u{307}");
        // words, names with underscores and a lone d stay
        assert_eq!(typeset("G(q) qd"), "G(q) q\u{307}");
        for same in ["W_motor [J]", "T(0)", "speed [m/s]", "d", "rate", "a = 0.2", "S5x", "dt", "add", "dd"] {
            assert_eq!(typeset(same), same.replace(" - ", " \u{2212} "));
        }
        assert_eq!(typeset("T - T(0)"), "T − T(0)");
    }
}
