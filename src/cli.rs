//! The command line's arguments (clap): one definition for the `ezy`
//! binary and every user program built with [`crate::App`].

use std::path::PathBuf;

use clap::{Parser, Subcommand, ValueEnum};
use ezy_core::kkt::KktMethod;
use ezy_core::{Baumgarte, Choice, Formulation, Method, ProjectionKind};

use ezy_scene::FigureFormat;

use crate::commands::run::RunOptions;

/// Planar vehicles with hinges and skates: simulate a scene, write CSV and figures.
#[derive(Parser, Debug)]
#[command(name = "ezy", version, about)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Option<Command>,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Run a scene and write trajectory.csv and its figures (default: drive).
    Run(RunArgs),
    /// List the models and scenes, one line each.
    List,
    /// Measure error against wall time over a ladder of integrators and settings.
    Precision(PrecisionArgs),
    /// Print the equations the model! macro derived (phi, G = [C_q; S], gamma).
    Equations(EquationsArgs),
    /// Check the derived Jacobians and convective terms against finite differences.
    Check(CheckArgs),
    /// Time one right-hand-side evaluation against the size of a model's family.
    Scale(ScaleArgs),
    /// Run a scene over a grid, a list or random draws of parameter values
    /// in parallel: one row per run in sweep.csv, resumable and shardable.
    Sweep(Box<SweepArgs>),
    /// Run a scene and draw its bodies moving, as an animated GIF.
    Animate(AnimateArgs),
    /// Time an accurate trajectory: DOP853 at 1e-11 with and without
    /// output, the scene's own setting, and each whole `run` process.
    Bench(BenchArgs),
    /// Find a scene's steady motions (or, driven periodically, its
    /// periodic orbit) and their stability; follow them as a parameter
    /// varies: equilibria.csv, periodic.csv, branch.csv and figures.
    Analyze(AnalyzeArgs),
    /// Linearize a scene at a time of its run: A.csv, B.csv (with
    /// --input), eigenvalues.csv, state.csv.
    Linearize(LinearizeArgs),
}

/// `ezy analyze`.
#[derive(clap::Args, Debug, Default)]
#[command(allow_negative_numbers = true)]
pub struct AnalyzeArgs {
    /// Scene: a known name (see `list`; default: drive) or a path to a
    /// .toml scene file.
    pub scene: Option<String>,
    /// Output directory [default: out/analyze/SCENE].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// The forcing period [s] [default: from the scene's waveforms].
    #[arg(long, value_name = "T", value_parser = parse_positive)]
    pub period: Option<f64>,
    /// The kinetic energy [J] of the steady motions sought [default: the
    /// guess's own in a scene without effects, where energy is conserved].
    #[arg(long, value_name = "J", value_parser = parse_positive)]
    pub energy: Option<f64>,
    /// Follow the solution as a parameter takes COUNT evenly spaced
    /// values from START to STOP (a NAME as for --set).
    #[arg(long = "continue", value_name = "NAME=START:STOP:COUNT")]
    pub continuation: Option<String>,
    /// Do not draw the figures.
    #[arg(long)]
    pub no_figures: bool,
    #[command(flatten)]
    pub overrides: Overrides,
}

/// `ezy linearize`.
#[derive(clap::Args, Debug, Default)]
#[command(allow_negative_numbers = true)]
pub struct LinearizeArgs {
    /// Scene: a known name (see `list`; default: drive) or a path to a
    /// .toml scene file.
    pub scene: Option<String>,
    /// The time [s] of the scene's run whose state is linearized about.
    #[arg(long, value_name = "T", default_value_t = 0.0)]
    pub at: f64,
    /// An input, a column of B: tau_HINGE (a torque pair at a hinge) or
    /// scale_EFFECT (an effect's force scaled by 1 + u); repeatable.
    #[arg(long = "input", value_name = "NAME")]
    pub inputs: Vec<String>,
    /// Output directory [default: out/linearize/SCENE].
    #[arg(long)]
    pub out: Option<PathBuf>,
    #[command(flatten)]
    pub overrides: Overrides,
}

/// `ezy bench`.
#[derive(clap::Args, Debug, Default)]
pub struct BenchArgs {
    /// Scene: a known name (default: drive) or a path to a .toml scene file.
    pub scene: Option<String>,
    /// Runs per setting (the median is reported), at most 100.
    #[arg(long, value_name = "N", default_value_t = 5, value_parser = parse_repeat)]
    pub repeat: u64,
    /// Skip timing the whole `run` processes.
    #[arg(long)]
    pub no_process: bool,
}

/// `ezy animate`: the scene's bodies, skates, hinges and springs drawn moving.
#[derive(clap::Args, Debug, Default)]
#[command(allow_negative_numbers = true)]
pub struct AnimateArgs {
    /// Scene: a known name (see `list`; default: drive) or a path to a
    /// .toml scene file.
    pub scene: Option<String>,
    /// The GIF file to write [default: out/SCENE/animation.gif].
    #[arg(long, value_name = "FILE.gif")]
    pub out: Option<PathBuf>,
    /// Frames per second (1 to 50).
    #[arg(long, value_name = "F", default_value_t = 20.0)]
    pub fps: f64,
    /// Seconds of simulated time per second of animation.
    #[arg(long, value_name = "S", default_value_t = 1.0)]
    pub speed: f64,
    /// Length of the fading trails of the skates' contact points (of the
    /// points, without skates; the first eight), in seconds of simulated
    /// time (0: none).
    #[arg(long, value_name = "T", default_value_t = 3.0)]
    pub trail: f64,
    #[command(flatten)]
    pub overrides: Overrides,
}

impl AnimateArgs {
    /// The animation's settings for scene `scene` (`--dpi` gives the frame
    /// size, default 64 dpi: 640 x 427 pixels).
    ///
    /// # Errors
    /// `--format`, which an animation does not take.
    pub fn options(&self, scene: &str) -> Result<crate::animate::AnimateOptions, String> {
        if let Some(f) = self.overrides.format {
            return Err(format!("--format {f}: an animation is always a GIF; set its size with --dpi"));
        }
        Ok(crate::animate::AnimateOptions {
            out: self.out.clone().unwrap_or_else(|| crate::animate::default_out(scene)),
            fps: self.fps,
            speed: self.speed,
            trail: self.trail,
            dpi: self.overrides.dpi.unwrap_or(64.0),
        })
    }
}

#[derive(clap::Args, Debug)]
pub struct ScaleArgs {
    /// Model with a family count (see `ezy list`), e.g. snake.
    pub model: String,
    /// Family sizes, comma-separated (each from 1 to 1e6).
    #[arg(long, value_delimiter = ',', default_value = "10,100,1000,10000", value_parser = parse_size)]
    pub n: Vec<usize>,
    /// Output format.
    #[arg(long, value_enum, default_value = "table")]
    pub format: ScaleFormat,
    /// Batches timed per size (the median is reported), at most 1000.
    #[arg(long, default_value_t = 15, value_parser = parse_batches)]
    pub batches: usize,
    /// KKT path: auto (dense below 16 rows, sparse from 16), schur (dense), sparse, lu.
    #[arg(long, value_enum, default_value = "auto")]
    pub kkt: KktArg,
}

#[derive(ValueEnum, Clone, Copy, Debug)]
pub enum KktArg {
    /// Dense Schur complement below 16 constraint rows, sparse from 16.
    Auto,
    /// Dense Schur complement (LDL^T of G M^-1 G^T).
    Schur,
    /// Sparse Schur complement (faer, symbolic factor once).
    Sparse,
    /// Dense LU of the whole KKT matrix.
    Lu,
}

#[derive(ValueEnum, Clone, Copy, Debug)]
pub enum ScaleFormat {
    /// Aligned columns and the fitted exponent.
    Table,
    /// n,nq,nc,seconds_per_rhs,path
    Csv,
}

#[derive(clap::Args, Debug)]
pub struct EquationsArgs {
    /// Model name (see `ezy list`).
    pub model: String,
    /// Set a parameter or a family count first (`--set N=3`); repeatable.
    #[arg(long = "set", value_parser = parse_set)]
    pub sets: Vec<(String, f64)>,
    /// Output format.
    #[arg(long, value_enum, default_value = "text")]
    pub format: EqFormat,
}

#[derive(ValueEnum, Clone, Copy, Debug)]
pub enum EqFormat {
    /// Plain text in the notation of docs/physics.md (`phi1d` is the rate of `phi1`).
    Text,
    /// A LaTeX document (amsmath).
    Latex,
}

#[derive(clap::Args, Debug)]
pub struct CheckArgs {
    /// Model name (see `ezy list`).
    pub model: String,
    /// Set a family count (or a parameter's centre) first (`--set N=3`); repeatable.
    #[arg(long = "set", value_parser = parse_set)]
    pub sets: Vec<(String, f64)>,
    /// Number of random states (and random parameter sets) [default: 100;
    /// fewer above 3000 coordinates, where one state already checks every
    /// element of a family: states x coordinates about 3e5, at least 3].
    #[arg(long)]
    pub states: Option<usize>,
    /// Seed of the random states.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

#[derive(clap::Args, Debug, Default)]
#[command(allow_negative_numbers = true)]
pub struct RunArgs {
    /// Scene: a known name (see `list`; default: drive) or a path to a
    /// .toml scene file (a name with `/` or ending in `.toml`).
    pub scene: Option<String>,
    /// Output directory [default: out/SCENE].
    #[arg(long)]
    pub out: Option<PathBuf>,
    #[command(flatten)]
    pub overrides: Overrides,
    /// Refuse runs whose trajectory.csv would be larger than this many MB
    /// (estimated before the run) [default: 1000].
    #[arg(long, value_name = "MB", value_parser = parse_positive)]
    pub max_output_mb: Option<f64>,
    /// Skip the figures (CSV only).
    #[arg(long)]
    pub no_figures: bool,
    /// Also write report.html: the summary, the energy ledger, an
    /// animation, every figure and the settings to reproduce the run, in
    /// one self-contained file.
    #[arg(long)]
    pub report: bool,
}

/// The settings `run` and `sweep` take on top of a scene's.
#[derive(clap::Args, Debug, Default, Clone)]
pub struct Overrides {
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
/// ([`crate::plot::check_format`]).
pub fn parse_figure_format(s: &str) -> Result<FigureFormat, String> {
    let format = s.trim().parse()?;
    crate::plot::check_format(format).map_err(|e| e.to_string())?;
    Ok(format)
}

/// A PNG resolution from [`ezy_scene::MIN_DPI`] to [`ezy_scene::MAX_DPI`].
///
/// # Errors
/// Not a number, or out of range.
pub fn parse_dpi(s: &str) -> Result<f64, String> {
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
    pub fn to_args(&self) -> Vec<String> {
        self.options().to_args()
    }
}

/// `ezy sweep`: many runs of one scene over parameter values.
#[derive(clap::Args, Debug, Default)]
#[command(args_conflicts_with_subcommands = true, allow_negative_numbers = true)]
pub struct SweepArgs {
    #[command(subcommand)]
    pub command: Option<SweepCommand>,
    /// Scene: a known name (see `list`) or a path to a .toml scene file.
    pub scene: Option<String>,
    /// An axis of evenly spaced values, START and STOP included
    /// (`--grid a=0.1:0.5:9`); repeatable, the first axis varies slowest.
    #[arg(long = "grid", value_name = "NAME=START:STOP:COUNT")]
    pub grids: Vec<String>,
    /// An axis of given values (`--list m2=1,2,4`); repeatable, after the
    /// --grid axes.
    #[arg(long = "list", value_name = "NAME=V1,V2,...")]
    pub lists: Vec<String>,
    /// A parameter drawn uniformly from [LO, HI] (`--random omega=1:6`);
    /// all random parameters are drawn together, --samples times, for
    /// every point of the other axes.
    #[arg(long = "random", value_name = "NAME=LO:HI")]
    pub randoms: Vec<String>,
    /// Number of random draws (with --random).
    #[arg(long, value_name = "N", value_parser = parse_count)]
    pub samples: Option<u64>,
    /// Seed of the random draws (ChaCha8: the same seed gives the same
    /// values on every machine).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// A quantity per run, a column of `trajectory.csv` or a figure's
    /// column function, reduced over a time window [s]:
    /// `mean(norm(x1d, y1d), 50, 60)`, `max(...)`, `min(...)`, `final(...)`
    /// (window optional: the whole run); or an event of the scene's:
    /// `event_time(NAME)` [s] (its first), `event_count(NAME)`; repeatable.
    #[arg(long = "metric", value_name = "EXPR")]
    pub metrics: Vec<String>,
    /// Runs at once [default: every core]; at most the number of cores
    /// this process may use (a larger value is capped, with a note).
    #[arg(long, value_name = "J")]
    pub jobs: Option<usize>,
    /// Output directory [default: out/sweep/SCENE].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Run only every N-th run from the K-th (K from 0): one of N shards
    /// that `ezy sweep merge` combines.
    #[arg(long, value_name = "K/N", value_parser = parse_shard)]
    pub shard: Option<(u64, u64)>,
    /// Write a Slurm batch script for this sweep (a job array of shards
    /// and the merge as a dependent job) instead of running it. An
    /// existing FILE is replaced only if it is a script ezy wrote (never
    /// the scene, another file, a link, a FIFO or a device); paths and
    /// arguments are quoted in it, and one holding a control character
    /// (a newline) is refused.
    #[arg(long, value_name = "FILE")]
    pub emit_slurm: Option<PathBuf>,
    /// Number of array tasks in the Slurm script, at most the number of
    /// runs and 1000000 [default: 4].
    #[arg(long, value_name = "N", value_parser = parse_count, requires = "emit_slurm")]
    pub tasks: Option<u64>,
    /// Also keep every run's trajectory.csv and figures, in DIR/runs/RUN
    /// (a symbolic link at DIR/runs or DIR/runs/RUN is refused, never
    /// followed).
    #[arg(long)]
    pub save_runs: bool,
    /// Skip the sweep's figures.
    #[arg(long)]
    pub no_figures: bool,
    #[command(flatten)]
    pub overrides: Overrides,
}

#[derive(Subcommand, Debug)]
pub enum SweepCommand {
    /// Combine the outputs of a sweep's shards into one sweep.csv.
    Merge(MergeArgs),
}

#[derive(clap::Args, Debug)]
pub struct MergeArgs {
    /// The shards' output directories.
    #[arg(required = true)]
    pub dirs: Vec<PathBuf>,
    /// Directory of the merged sweep.csv and figures.
    #[arg(long)]
    pub out: PathBuf,
    /// Skip the figures.
    #[arg(long)]
    pub no_figures: bool,
}

/// `K/N` of `--shard`: 0 <= K < N.
///
/// # Errors
/// Not two whole numbers, N = 0 or K >= N.
pub fn parse_shard(s: &str) -> Result<(u64, u64), String> {
    let (k, n) = s.split_once('/').ok_or_else(|| format!("`{s}`: expected K/N (shard K of N, K from 0)"))?;
    let k: u64 = k.trim().parse().map_err(|_| format!("`{s}`: `{k}` is not a whole number"))?;
    let n: u64 = n.trim().parse().map_err(|_| format!("`{s}`: `{n}` is not a whole number"))?;
    if n == 0 || k >= n {
        return Err(format!("`{s}`: need 0 <= K < N"));
    }
    Ok((k, n))
}

#[derive(clap::Args, Debug)]
pub struct PrecisionArgs {
    /// Scene name (see `ezy list`).
    pub scene: String,
    /// Output format on stdout.
    #[arg(long, value_enum, default_value = "table")]
    pub format: Format,
    /// Directory for precision.csv and the figures [default: out/precision/SCENE].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Draw other tools' points over the work-precision diagram: a CSV
    /// file with the header label,wall_s,error (wall time [s], max state
    /// error at the final time), one point per row.
    #[arg(long, value_name = "FILE")]
    pub overlay: Option<PathBuf>,
    /// Run no ladder: redraw the figures from the precision.csv already in
    /// the output directory (with --overlay; the drift figure's two short
    /// runs are still run).
    #[arg(long)]
    pub replot: bool,
}

#[derive(ValueEnum, Clone, Copy, Debug)]
pub enum Format {
    /// A table for people.
    Table,
    /// CSV: method,dt,rtol,atol,projection,error,wall_s,rhs_evals,max_residual.
    Csv,
}

/// The command line's parser of a [`Choice`] (an integrator, a
/// projection, a formulation): its values and their help from the one
/// list the library keeps ([`Choice::ALL`]).
fn choice<T: Choice>() -> impl clap::builder::TypedValueParser<Value = T> {
    use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser as _};
    PossibleValuesParser::new(T::ALL.iter().map(|v| PossibleValue::new(v.name()).help(v.help())))
        .map(|name: String| T::parse(&name).expect("one of the possible values"))
}

pub fn parse_baumgarte(s: &str) -> Result<Baumgarte, String> {
    let (a, b) = s.split_once(',').ok_or_else(|| format!("`{s}`: expected ALPHA,BETA"))?;
    let num = |v: &str| -> Result<f64, String> {
        let x: f64 = v.trim().parse().map_err(|_| format!("`{s}`: `{v}` is not a number"))?;
        if x.is_finite() && x >= 0.0 { Ok(x) } else { Err(format!("`{s}`: `{v}` must be finite and >= 0")) }
    };
    Ok(Baumgarte { alpha: num(a)?, beta: num(b)? })
}

/// A finite number > 0.
pub fn parse_positive(s: &str) -> Result<f64, String> {
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
pub fn parse_count(s: &str) -> Result<u64, String> {
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
fn parse_capped(s: &str, max: u64, what: &str) -> Result<u64, String> {
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

/// `--repeat` of `ezy bench`: from 1 to [`crate::bench::MAX_REPEAT`].
///
/// # Errors
/// Not a whole number from 1 to the limit.
pub fn parse_repeat(s: &str) -> Result<u64, String> {
    parse_capped(
        s,
        crate::bench::MAX_REPEAT,
        "runs per setting (each repeat runs the seven settings again, and as many whole processes)",
    )
}

/// `--batches` of `ezy scale`: from 1 to [`crate::scale::MAX_BATCHES`].
///
/// # Errors
/// Not a whole number from 1 to the limit.
pub fn parse_batches(s: &str) -> Result<usize, String> {
    parse_capped(
        s,
        crate::scale::MAX_BATCHES as u64,
        "batches per size (each takes at least 2 ms, more for large sizes)",
    )
    .map(|n| n as usize)
}

/// A family size of `ezy scale --n`: a whole number (also `1e4`) from 1
/// to [`ezy_scene::MAX_COUNT`].
///
/// # Errors
/// Not a whole number from 1 to the limit.
pub fn parse_size(s: &str) -> Result<usize, String> {
    parse_capped(s, ezy_scene::MAX_COUNT as u64, "elements of a family (1e6)").map(|n| n as usize)
}

/// `NAME=VALUE` of `--set`, with a finite value.
///
/// # Errors
/// No `=`, or a value that is not a finite number.
pub fn parse_set(s: &str) -> Result<(String, f64), String> {
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

impl From<KktArg> for KktMethod {
    fn from(k: KktArg) -> Self {
        match k {
            KktArg::Auto => KktMethod::Auto,
            KktArg::Schur => KktMethod::Schur,
            KktArg::Sparse => KktMethod::Sparse,
            KktArg::Lu => KktMethod::Lu,
        }
    }
}

impl From<EqFormat> for crate::equations::Format {
    fn from(f: EqFormat) -> Self {
        match f {
            EqFormat::Text => Self::Text,
            EqFormat::Latex => Self::Latex,
        }
    }
}

impl RunArgs {
    /// The run's overrides; the output directory defaults to `out/SCENE`.
    pub fn options(self, scene: &str) -> RunOptions {
        RunOptions {
            out: self.out.unwrap_or_else(|| PathBuf::from("out").join(scene)),
            figures: !self.no_figures,
            report: self.report,
            progress: true,
            max_output_mb: self.max_output_mb,
            ..self.overrides.options()
        }
    }
}

impl Overrides {
    /// The run options these overrides give (no output directory, no
    /// figures, no progress display).
    pub fn options(&self) -> RunOptions {
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
