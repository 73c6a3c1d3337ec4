//! The command line's top command and what its commands share (clap):
//! the overrides of a scene's settings that `run`, `sweep`, `animate`,
//! `analyze` and `linearize` take ([`Overrides`]), and the parsers of
//! their values. The commands themselves, each with its own arguments,
//! are [`crate::commands`]; [`crate::App::run_cli`] puts them under the
//! top command.

use std::path::{Path, PathBuf};

use clap::{CommandFactory, Parser};
use ezy_core::design::fit::Data;
use ezy_core::{Baumgarte, Choice, Formulation, Method, ProjectionKind};
use ezy_scene::FigureFormat;

use crate::session::RunOptions;

/// Planar vehicles with hinges and skates: simulate a scene, write CSV and figures.
#[derive(Parser, Debug)]
#[command(name = "ezy", version, about)]
struct Cli {}

/// The top command `ezy`: its name, version and description, without
/// its subcommands.
pub(crate) fn top() -> clap::Command {
    Cli::command()
}

/// The settings `run` and `sweep` take on top of a scene's.
#[derive(clap::Args, Debug, Default, Clone)]
pub(crate) struct Overrides {
    /// Override a scene parameter (--set M0=0.1: every number that names it),
    /// a model parameter (--set m2=2) or a number of an effect, by EFFECT.KEY
    /// with the full key or its last part (--set motor.amplitude=3).
    #[arg(long = "set", value_name = "NAME=VALUE", value_parser = parse_set)]
    pub sets: Vec<(String, f64)>,
    /// Step size [s] (scene default: 1e-4).
    #[arg(long, value_name = "H", allow_hyphen_values = true)]
    pub dt: Option<f64>,
    /// Duration [s].
    #[arg(long, value_name = "T", allow_hyphen_values = true)]
    pub t_end: Option<f64>,
    /// Output interval [s] (default 0.01; the final time is always written).
    #[arg(long, value_name = "DT", allow_hyphen_values = true)]
    pub every: Option<f64>,
    /// Coordinate projection after every step.
    #[arg(long, value_parser = choice::<ProjectionKind>())]
    pub projection: Option<ProjectionKind>,
    /// Baumgarte stabilization `ALPHA,BETA` [1/s] (with or instead of --projection).
    #[arg(long, value_name = "ALPHA,BETA", value_parser = parse_baumgarte)]
    pub baumgarte: Option<Baumgarte>,
    /// Integration method (scene default: rk4).
    #[arg(long, value_parser = choice::<Method>())]
    pub integrator: Option<Method>,
    /// Formulation: the DAE in all coordinates with projection, or only the
    /// independent coordinates and velocities (coordinate partitioning).
    #[arg(long, value_parser = choice::<Formulation>())]
    pub formulation: Option<Formulation>,
    /// Relative tolerance of the adaptive methods (default 1e-9).
    #[arg(long, value_name = "R", allow_hyphen_values = true)]
    pub rtol: Option<f64>,
    /// Absolute tolerance of the adaptive methods (default 1e-9).
    #[arg(long, value_name = "A", allow_hyphen_values = true)]
    pub atol: Option<f64>,
    /// Refuse runs that need more step attempts than this (adaptive runs
    /// stop when they reach it) [default: 100000000].
    #[arg(long, value_name = "N", value_parser = parse_count)]
    pub max_steps: Option<u64>,
    /// File format of the figures: png (anti-aliased), svg or pdf (vector)
    /// [default: the scene's output.figure_format, else png].
    #[arg(long, value_name = "FORMAT", value_parser = parse_figure_format)]
    pub format: Option<FigureFormat>,
    /// Resolution of PNG figures in dots per inch (a figure is 10 x 6.67
    /// inches) [default: the scene's output.dpi, else 144].
    #[arg(long, value_name = "DPI", value_parser = parse_dpi)]
    pub dpi: Option<f64>,
}

/// `png`, `svg` or `pdf`.
///
/// # Errors
/// Any other name; `pdf` in a build without the `pdf` feature
/// ([`crate::render::plot::check_format`]).
pub(crate) fn parse_figure_format(s: &str) -> Result<FigureFormat, String> {
    let format = s.trim().parse()?;
    crate::render::plot::check_format(format).map_err(|e| e.to_string())?;
    Ok(format)
}

/// A PNG resolution from [`ezy_scene::MIN_DPI`] to [`ezy_scene::MAX_DPI`].
///
/// # Errors
/// Not a number, or out of range.
pub(crate) fn parse_dpi(s: &str) -> Result<f64, String> {
    let v: f64 = s.trim().parse().map_err(|_| format!("`{s}` is not a number"))?;
    if (ezy_scene::MIN_DPI..=ezy_scene::MAX_DPI).contains(&v) {
        Ok(v)
    } else {
        Err(format!("`{s}`: the resolution is from {} to {} dpi", ezy_scene::MIN_DPI, ezy_scene::MAX_DPI))
    }
}

impl Overrides {
    /// The overrides as command-line arguments that parse back to them
    /// (what a Slurm script passes on, and how a sweep's manifest records
    /// them).
    pub(crate) fn to_args(&self) -> Vec<String> {
        self.options().to_args()
    }
}

/// The command line's parser of a [`Choice`] (an integrator, a
/// projection, a formulation): its values and their help from the one
/// list the library keeps ([`Choice::ALL`]).
fn choice<T: Choice>() -> impl clap::builder::TypedValueParser<Value = T> {
    use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser as _};
    PossibleValuesParser::new(T::ALL.iter().map(|v| PossibleValue::new(v.name()).help(v.help())))
        .map(|name: String| T::parse(&name).expect("one of the possible values"))
}

pub(crate) fn parse_baumgarte(s: &str) -> Result<Baumgarte, String> {
    let (a, b) = s.split_once(',').ok_or_else(|| format!("`{s}`: expected ALPHA,BETA"))?;
    let num = |v: &str| -> Result<f64, String> {
        let x: f64 = v.trim().parse().map_err(|_| format!("`{s}`: `{v}` is not a number"))?;
        if x.is_finite() && x >= 0.0 { Ok(x) } else { Err(format!("`{s}`: `{v}` must be finite and >= 0")) }
    };
    Ok(Baumgarte { alpha: num(a)?, beta: num(b)? })
}

/// A finite number > 0.
pub(crate) fn parse_positive(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        Ok(_) => Err(format!("`{s}` must be a finite number > 0")),
        Err(_) => Err(format!("`{s}` is not a number")),
    }
}

/// A whole number >= 1, also written as a float (`6e10`, as the budget
/// messages suggest it).
///
/// # Errors
/// A value that is not a whole number from 1 to 2^53.
pub(crate) fn parse_count(s: &str) -> Result<u64, String> {
    let v: f64 = s.trim().parse().map_err(|_| format!("`{s}` is not a number"))?;
    if v.is_finite() && v >= 1.0 && v.fract() == 0.0 && v <= 9_007_199_254_740_992.0 {
        Ok(v as u64)
    } else {
        Err(format!("`{s}` must be a whole number from 1 to 2^53"))
    }
}

/// A whole number from 1 to `max`, also written as a float (`1e3`), for
/// a flag whose every unit costs time: `what` says what it counts.
///
/// # Errors
/// Not a whole number >= 1, or more than `max` (the message gives the
/// value and the limit).
pub(crate) fn parse_capped(s: &str, max: u64, what: &str) -> Result<u64, String> {
    let n = parse_count(s).map_err(|e| {
        if s.trim().parse::<f64>().is_ok_and(|v| v > max as f64) {
            format!("`{s}` is more than {max}, the most {what}")
        } else {
            e
        }
    })?;
    if n > max {
        return Err(format!("`{}` is more than {max}, the most {what}", s.trim()));
    }
    Ok(n)
}

/// `NAME=VALUE` of `--set`, with a finite value.
///
/// # Errors
/// No `=`, or a value that is not a finite number.
pub(crate) fn parse_set(s: &str) -> Result<(String, f64), String> {
    let (name, value) = s.split_once('=').ok_or_else(|| format!("`{s}`: expected NAME=VALUE"))?;
    let v: f64 = value.trim().parse().map_err(|_| {
        if value.contains(',') {
            format!("`{s}`: one value per --set; for several values run `ezy sweep SCENE --list {}`", s.trim())
        } else {
            format!("`{s}`: `{value}` is not a number")
        }
    })?;
    if !v.is_finite() {
        return Err(format!("`{s}`: the value must be finite"));
    }
    Ok((name.trim().to_string(), v))
}

impl Overrides {
    /// The run options these overrides give (no output directory, no
    /// figures, no progress display).
    pub(crate) fn options(&self) -> RunOptions {
        RunOptions {
            out: PathBuf::new(),
            sets: self.sets.clone(),
            dt: self.dt,
            t_end: self.t_end,
            every: self.every,
            projection: self.projection,
            method: self.integrator,
            formulation: self.formulation,
            baumgarte: self.baumgarte,
            rtol: self.rtol,
            atol: self.atol,
            figures: false,
            figure_format: self.format,
            dpi: self.dpi,
            report: false,
            progress: false,
            max_steps: self.max_steps,
            max_output_mb: None,
            scene_file: None,
        }
    }
}

/// `NAME=LO:HI`: a parameter and its bounds (`--over` of `fit` and
/// `optimize`).
///
/// # Errors
/// Another form, bounds that are not finite numbers.
pub(crate) fn parse_over(s: &str) -> Result<(String, f64, f64), String> {
    let (name, range) = s.split_once('=').ok_or_else(|| format!("`{s}`: expected NAME=LO:HI"))?;
    let (lo, hi) = range.split_once(':').ok_or_else(|| format!("`{s}`: expected NAME=LO:HI"))?;
    let num = |v: &str| match v.trim().parse::<f64>() {
        Ok(x) if x.is_finite() => Ok(x),
        _ => Err(format!("`{s}`: `{}` is not a finite number", v.trim())),
    };
    let name = name.trim();
    if name.is_empty() {
        return Err(format!("`{s}`: no parameter name before `=`"));
    }
    Ok((name.to_string(), num(lo)?, num(hi)?))
}

/// The repeatable flags that name something, by clap id: the flag and
/// whether the name is the value's part before `=` (`--set m1=2`) or the
/// whole value (`--input tau_B`). One name given twice is refused, never
/// applied twice or silently the last one.
const NAMED_REPEATS: &[(&str, &str, bool)] = &[
    ("sets", "--set", true),
    ("over", "--over", true),
    ("bounds", "--bound", true),
    ("to", "--to", true),
    ("inputs", "--input", false),
    ("wrt", "--wrt", false),
    ("columns", "--columns", false),
];

/// Refuses a repeatable flag of a command's arguments `args` that gives
/// one name twice (`--input tau_B --input tau_B`, `--set m1=2 --set
/// m1=3`, `--wrt a,a`).
///
/// # Errors
/// The flag, the name and the two values.
pub(crate) fn check_repeats(args: &clap::ArgMatches) -> Result<(), String> {
    for &(id, flag, before_eq) in NAMED_REPEATS {
        let Ok(Some(raw)) = args.try_get_raw(id) else { continue };
        let values: Vec<String> = raw.map(|v| v.to_string_lossy().trim().to_string()).collect();
        let name = |v: &str| {
            if before_eq { v.split_once('=').map_or(v, |(n, _)| n).trim().to_string() } else { v.to_string() }
        };
        for (k, v) in values.iter().enumerate() {
            if let Some(first) = values[..k].iter().find(|w| name(w) == name(v)) {
                let both = if before_eq { format!(" ({flag} {first} and {flag} {v})") } else { String::new() };
                return Err(format!("{flag}: `{}` is given twice{both}; give each name once", name(v)));
            }
        }
    }
    Ok(())
}

/// Largest data file `ezy fit` and `ezy plan --guess` read (64 MB: about
/// a million rows of a few columns).
pub(crate) const MAX_DATA_BYTES: u64 = 64 << 20;

/// The CSV file `path`'s column `t` and `columns` (`what` it is, for
/// messages: "the data file"), every cell a finite number, the times
/// sorted (`ezy fit`'s data, `ezy plan --guess`'s inputs).
///
/// # Errors
/// The file's name with what is wrong: unreadable, too large, no header,
/// a column missing or named twice in the header, a cell that is not a
/// number (with its line).
pub(crate) fn read_columns(path: &Path, columns: &[String], what: &str) -> Result<Data, String> {
    let at = path.display();
    let text = ezy_scene::files::read_capped_text(path, MAX_DATA_BYTES, what).map_err(|e| format!("{at}: {e}"))?;
    let mut reader = csv::ReaderBuilder::new().trim(csv::Trim::All).comment(Some(b'#')).from_reader(text.as_bytes());
    let head: Vec<String> = reader.headers().map_err(|e| format!("{at}: {e}"))?.iter().map(String::from).collect();
    let find = |c: &str| {
        let k = head
            .iter()
            .position(|h| h == c)
            .ok_or_else(|| format!("{at}: no column `{c}` (it has {})", head.join(", ")))?;
        // a second column of the name would be silently left out
        match head.iter().skip(k + 1).position(|h| h == c) {
            Some(j) => Err(format!(
                "{at}: the header names column `{c}` twice (columns {} and {}): rename one, so that the data fitted are the ones meant",
                k + 1,
                k + j + 2
            )),
            None => Ok(k),
        }
    };
    let tcol = find("t")?;
    let cols = columns.iter().map(|c| find(c.trim())).collect::<Result<Vec<_>, _>>()?;
    let mut data = Data {
        t: Vec::new(),
        columns: columns.iter().map(|c| c.trim().to_string()).collect(),
        values: vec![Vec::new(); cols.len()],
    };
    for row in reader.records() {
        let row = row.map_err(|e| format!("{at}: {e}"))?;
        let line = row.position().map_or(0, |p| p.line());
        let cell = |k: usize| -> Result<f64, String> {
            let v = row.get(k).unwrap_or("");
            v.parse::<f64>().map_err(|_| format!("{at}, line {line}, column `{}`: `{v}` is not a number", head[k]))
        };
        data.t.push(cell(tcol)?);
        for (list, &k) in data.values.iter_mut().zip(&cols) {
            list.push(cell(k)?);
        }
    }
    data.check().map_err(|e| format!("{at}: {e}"))?;
    Ok(data)
}

/// `--gait TEXT` (one period, `t` in `[0, 2 pi]`, a trigonometric
/// polynomial per coordinate of `names`) as the Fourier series of order
/// `--harmonics` (default: its highest harmonic) over `period` \[s\]
/// (default the text's): the start of `gait-optimize` and of `optimize
/// --gait` ([`ezy_core::design::gait::FourierGait::from_gait`]).
///
/// # Errors
/// The text's or the series' sentence, after the flags at fault.
pub(crate) fn fourier_start(
    text: &str,
    harmonics: Option<usize>,
    period: Option<f64>,
    names: &[String],
) -> Result<ezy_core::design::gait::FourierGait, String> {
    let gait = ezy_core::geometry::Gait::parse(names, text).map_err(|e| e.to_string())?;
    ezy_core::design::gait::FourierGait::from_gait(&gait, harmonics, period, names).map_err(|e| match harmonics {
        Some(n) => format!("--gait (--harmonics {n}): {e}"),
        None => format!("--gait: {e}"),
    })
}
