//! The `ezy` command line: `ezy run [SCENE | FILE.toml]`, `ezy list`,
//! `ezy precision SCENE`, `ezy equations MODEL`, `ezy check MODEL`,
//! `ezy scale MODEL`.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand, ValueEnum};
use ezy::run::{Report, RunOptions, run_scene};
use ezy_core::{Baumgarte, Method, ProjectionKind};

/// `println!` to stdout that ends the process quietly when the reader has
/// gone (`ezy list | head`), instead of panicking on the broken pipe.
macro_rules! out {
    ($($arg:tt)*) => {{
        use std::io::Write;
        if let Err(e) = writeln!(std::io::stdout().lock(), $($arg)*) {
            if e.kind() == std::io::ErrorKind::BrokenPipe {
                std::process::exit(0);
            }
        }
    }};
}

/// `print!` to stdout with the same handling of a broken pipe as `out!`.
macro_rules! out_raw {
    ($($arg:tt)*) => {{
        use std::io::Write;
        if let Err(e) = write!(std::io::stdout().lock(), $($arg)*) {
            if e.kind() == std::io::ErrorKind::BrokenPipe {
                std::process::exit(0);
            }
        }
    }};
}

/// Planar vehicles with hinges and skates: simulate a scene, write CSV and figures.
#[derive(Parser, Debug)]
#[command(name = "ezy", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand, Debug)]
enum Command {
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
}

#[derive(clap::Args, Debug)]
struct ScaleArgs {
    /// Model with a family count (see `ezy list`), e.g. snake.
    model: String,
    /// Family sizes, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "10,100,1000,10000")]
    n: Vec<usize>,
    /// Output format.
    #[arg(long, value_enum, default_value = "table")]
    format: ScaleFormat,
    /// Batches timed per size (the median is reported).
    #[arg(long, default_value_t = 15)]
    batches: usize,
    /// KKT path: auto (dense below 16 rows, sparse from 16), schur (dense), sparse, lu.
    #[arg(long, value_enum, default_value = "auto")]
    kkt: KktArg,
}

#[derive(ValueEnum, Clone, Copy, Debug)]
enum KktArg {
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
enum ScaleFormat {
    /// Aligned columns and the fitted exponent.
    Table,
    /// n,nq,nc,seconds_per_rhs,path
    Csv,
}

#[derive(clap::Args, Debug)]
struct EquationsArgs {
    /// Model name (see `ezy list`).
    model: String,
    /// Set a parameter or a family count first (`--set N=3`); repeatable.
    #[arg(long = "set", value_parser = parse_set)]
    sets: Vec<(String, f64)>,
    /// Output format.
    #[arg(long, value_enum, default_value = "text")]
    format: EqFormat,
}

#[derive(ValueEnum, Clone, Copy, Debug)]
enum EqFormat {
    /// Plain text in SPEC §1's notation.
    Text,
    /// A LaTeX document (amsmath).
    Latex,
}

#[derive(clap::Args, Debug)]
struct CheckArgs {
    /// Model name (see `ezy list`).
    model: String,
    /// Set a family count (or a parameter's centre) first (`--set N=3`); repeatable.
    #[arg(long = "set", value_parser = parse_set)]
    sets: Vec<(String, f64)>,
    /// Number of random states (and random parameter sets).
    #[arg(long, default_value_t = 100)]
    states: usize,
    /// Seed of the random states.
    #[arg(long, default_value_t = 1)]
    seed: u64,
}

/// Runs `ezy equations`, `ezy check` or `ezy scale` for the model type.
enum ModelCommand {
    Equations { format: ezy::equations::Format, sets: Vec<(String, f64)> },
    Check { states: usize, seed: u64, sets: Vec<(String, f64)> },
    Scale { n: Vec<usize>, csv: bool, batches: usize, kkt: ezy_core::kkt::KktMethod },
}

impl ezy_core::ModelVisitor for ModelCommand {
    /// What to print, and the error if the command failed.
    type Output = (String, Option<String>);
    fn visit<M: ezy_core::Model + Default>(self) -> Self::Output {
        match self {
            Self::Equations { format, sets } => match with_sets::<M>(&sets) {
                Ok(m) => (ezy::equations::render(&m, format), None),
                Err(e) => (String::new(), Some(e)),
            },
            Self::Check { states, seed, sets } => {
                let base = match with_sets::<M>(&sets) {
                    Ok(m) => m,
                    Err(e) => return (String::new(), Some(e)),
                };
                let checks = ezy::check::check_at(&base, states, seed);
                let ok = checks.iter().all(|c| c.passed());
                let name = M::default().info().name;
                let err = (!ok).then(|| {
                    format!(
                        "model `{name}`: a derived term differs from its finite difference by more than {:e}",
                        ezy::check::TOLERANCE
                    )
                });
                (ezy::check::table(name, states, &checks), err)
            }
            Self::Scale { n, csv, batches, kkt } => match ezy::scale::scale::<M>(&n, batches, kkt) {
                Ok(points) => (ezy::scale::render(M::default().info().name, &points, csv), None),
                Err(e) => (String::new(), Some(e.to_string())),
            },
        }
    }
}

/// The default model with `sets` applied (parameters and family counts).
fn with_sets<M: ezy_core::Model + Default>(sets: &[(String, f64)]) -> Result<M, String> {
    let mut m = M::default();
    let info = m.info();
    for (name, value) in sets {
        let i = info.param_index(name).ok_or_else(|| {
            let known: Vec<&str> = info.params.iter().map(|p| p.name).collect();
            format!("unknown parameter `{name}` in model {}; its parameters: {}", info.name, known.join(", "))
        })?;
        if info.params[i].count {
            ezy_core::scene::check_count(name, *value).map_err(|e| e.message)?;
        }
        m.set_param(i, *value);
    }
    m.check_counts()?;
    Ok(m)
}

fn model_command(model: &str, cmd: ModelCommand) -> Result<(), String> {
    let (out, err) = ezy_models::visit(model, cmd).ok_or_else(|| {
        let known: Vec<&str> = ezy_models::MODEL_KEYS.to_vec();
        format!("unknown model `{model}`; known models: {}", known.join(", "))
    })?;
    out_raw!("{out}");
    err.map_or(Ok(()), Err)
}

#[derive(clap::Args, Debug, Default)]
#[command(allow_negative_numbers = true)]
struct RunArgs {
    /// Scene: a built-in name (see `ezy list`) or a path to a .toml scene file.
    #[arg(default_value = "drive")]
    scene: String,
    /// Output directory [default: out/SCENE].
    #[arg(long)]
    out: Option<PathBuf>,
    /// Override a scene parameter (--set M0=0.1: every number that names it),
    /// a model parameter (--set m2=2) or a number of an effect, by EFFECT.KEY
    /// with the full key or its last part (--set motor.amplitude=3).
    #[arg(long = "set", value_name = "NAME=VALUE", value_parser = parse_set)]
    sets: Vec<(String, f64)>,
    /// Step size [s] (scene default: 1e-4).
    #[arg(long, value_name = "H")]
    dt: Option<f64>,
    /// Duration [s].
    #[arg(long, value_name = "T")]
    t_end: Option<f64>,
    /// Output interval [s] (default 0.01; the final time is always written).
    #[arg(long, value_name = "DT")]
    every: Option<f64>,
    /// Coordinate projection after every step.
    #[arg(long, value_enum)]
    projection: Option<Projection>,
    /// Baumgarte stabilization `ALPHA,BETA` [1/s] (with or instead of --projection).
    #[arg(long, value_name = "ALPHA,BETA", value_parser = parse_baumgarte)]
    baumgarte: Option<Baumgarte>,
    /// Integration method (scene default: rk4).
    #[arg(long, value_enum)]
    integrator: Option<Integrator>,
    /// Relative tolerance of the adaptive methods (default 1e-9).
    #[arg(long, value_name = "R")]
    rtol: Option<f64>,
    /// Absolute tolerance of the adaptive methods (default 1e-9).
    #[arg(long, value_name = "A")]
    atol: Option<f64>,
    /// Skip the figures (CSV only).
    #[arg(long)]
    no_figures: bool,
}

#[derive(clap::Args, Debug)]
struct PrecisionArgs {
    /// Scene name (see `ezy list`).
    scene: String,
    /// Output format on stdout.
    #[arg(long, value_enum, default_value = "table")]
    format: Format,
    /// Directory for precision.csv and the figures [default: out/precision/SCENE].
    #[arg(long)]
    out: Option<PathBuf>,
}

#[derive(ValueEnum, Clone, Copy, Debug)]
enum Format {
    /// A table for people.
    Table,
    /// CSV: method,dt,rtol,atol,projection,error,wall_s,rhs_evals,max_residual.
    Csv,
}

#[derive(ValueEnum, Clone, Copy, Debug)]
enum Integrator {
    /// Explicit Euler, order 1, fixed step (--dt).
    Euler,
    /// Classic Runge-Kutta, order 4, fixed step (--dt).
    Rk4,
    /// Dormand-Prince 5(4), adaptive (--rtol, --atol).
    Dopri5,
    /// Dormand-Prince 8(5,3), adaptive (--rtol, --atol).
    Dop853,
}

#[derive(ValueEnum, Clone, Copy, Debug)]
enum Projection {
    /// No projection.
    None,
    /// Euclidean, as in the seed.
    Euclidean,
    /// Mass-weighted (kinetic-energy metric), the default.
    Mass,
}

fn parse_baumgarte(s: &str) -> Result<Baumgarte, String> {
    let (a, b) = s.split_once(',').ok_or_else(|| format!("`{s}`: expected ALPHA,BETA"))?;
    let num = |v: &str| -> Result<f64, String> {
        let x: f64 = v.trim().parse().map_err(|_| format!("`{s}`: `{v}` is not a number"))?;
        if x.is_finite() && x >= 0.0 { Ok(x) } else { Err(format!("`{s}`: `{v}` must be finite and >= 0")) }
    };
    Ok(Baumgarte { alpha: num(a)?, beta: num(b)? })
}

fn parse_set(s: &str) -> Result<(String, f64), String> {
    let (name, value) = s.split_once('=').ok_or_else(|| format!("`{s}`: expected NAME=VALUE"))?;
    let v: f64 = value.trim().parse().map_err(|_| format!("`{s}`: `{value}` is not a number"))?;
    if !v.is_finite() {
        return Err(format!("`{s}`: the value must be finite"));
    }
    Ok((name.trim().to_string(), v))
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command.unwrap_or(Command::Run(RunArgs { scene: "drive".into(), ..RunArgs::default() })) {
        Command::List => {
            list();
            Ok(())
        }
        Command::Run(args) => run(args),
        Command::Precision(args) => precision(args),
        Command::Equations(args) => model_command(
            &args.model,
            ModelCommand::Equations {
                format: match args.format {
                    EqFormat::Text => ezy::equations::Format::Text,
                    EqFormat::Latex => ezy::equations::Format::Latex,
                },
                sets: args.sets,
            },
        ),
        Command::Scale(args) => {
            if args.n.is_empty() || args.batches == 0 {
                Err("--n needs at least one size and --batches at least 1".to_string())
            } else {
                let csv = matches!(args.format, ScaleFormat::Csv);
                use ezy_core::kkt::KktMethod;
                let kkt = match args.kkt {
                    KktArg::Auto => KktMethod::Auto,
                    KktArg::Schur => KktMethod::Schur,
                    KktArg::Sparse => KktMethod::Sparse,
                    KktArg::Lu => KktMethod::Lu,
                };
                model_command(&args.model, ModelCommand::Scale { n: args.n, csv, batches: args.batches, kkt })
            }
        }
        Command::Check(args) => {
            if args.states == 0 {
                Err("--states = 0: check at least one state".to_string())
            } else {
                model_command(
                    &args.model,
                    ModelCommand::Check { states: args.states, seed: args.seed, sets: args.sets },
                )
            }
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(msg) => {
            eprintln!("error: {msg}");
            ExitCode::FAILURE
        }
    }
}

fn list() {
    out!("models:");
    for (key, info) in ezy_models::models() {
        let counts: Vec<String> =
            info.params.iter().filter(|p| p.count).map(|p| format!("{} = {}", p.name, p.default)).collect();
        let counts = if counts.is_empty() { String::new() } else { format!(", {}", counts.join(", ")) };
        out!("  {key:<26} {} (nq = {}, nc = {}{counts})", info.doc, info.nq(), info.nc());
    }
    out!("scenes:");
    for s in ezy_models::scenes::builtin() {
        out!("  {:<26} {}", s.scene.name, s.scene.description);
    }
}

/// A built-in scene by name or a scene file by path, checked.
fn find_scene(name: &str) -> Result<ezy_core::Scene, String> {
    ezy_models::scenes::load(name).map(|s| s.scene).map_err(|e| e.to_string())
}

fn precision(args: PrecisionArgs) -> Result<(), String> {
    let scene = find_scene(&args.scene)?;
    let out = args.out.unwrap_or_else(|| PathBuf::from("out").join("precision").join(&scene.name));
    let report = ezy::precision::precision(&scene, &out).map_err(|e| e.to_string())?;
    match args.format {
        Format::Table => {
            out_raw!("{}", ezy::precision::table(&report));
            for f in &report.files {
                out!("wrote {}", f.display());
            }
        }
        Format::Csv => out_raw!("{}", ezy::precision::csv(&report.rows)),
    }
    Ok(())
}

fn run(args: RunArgs) -> Result<(), String> {
    let scene = find_scene(&args.scene)?;
    let opts = RunOptions {
        out: args.out.unwrap_or_else(|| PathBuf::from("out").join(&scene.name)),
        sets: args.sets,
        dt: args.dt,
        t_end: args.t_end,
        every: args.every,
        projection: args.projection.map(|p| match p {
            Projection::None => ProjectionKind::None,
            Projection::Euclidean => ProjectionKind::Euclidean,
            Projection::Mass => ProjectionKind::MassWeighted,
        }),
        method: args.integrator.map(|m| match m {
            Integrator::Euler => Method::Euler,
            Integrator::Rk4 => Method::Rk4,
            Integrator::Dopri5 => Method::Dopri5,
            Integrator::Dop853 => Method::Dop853,
        }),
        baumgarte: args.baumgarte,
        rtol: args.rtol,
        atol: args.atol,
        figures: !args.no_figures,
        progress: true,
    };
    let report = run_scene(&scene, &opts).map_err(|e| e.to_string())?;
    for w in &report.warnings {
        eprintln!("warning: {w}");
    }
    print_summary(&scene.name, &report);
    Ok(())
}

fn print_summary(scene: &str, r: &Report) {
    let s = &r.summary;
    let t = s.integration_time.as_secs_f64();
    let how = if s.method.is_adaptive() {
        format!(
            "{} steps ({} rejected), rtol = {:e}, atol = {:e}",
            s.steps, s.rejected, r.settings.rtol, r.settings.atol
        )
    } else {
        format!("{} steps of h = {} s", s.steps, r.settings.dt)
    };
    out!(
        "{scene}: {} {how} to t = {} s, projection {} ({}), {} KKT path",
        s.method.name(),
        r.settings.t_end,
        r.settings.projection.name(),
        s.projection_path,
        s.kkt
    );
    out!(
        "  RHS evaluations {}, integration {:.3} s ({:.0} ns per RHS incl. projection), whole run {:.3} s",
        s.counters.rhs_evals,
        t,
        t / s.counters.rhs_evals.max(1) as f64 * 1e9,
        r.wall.as_secs_f64()
    );
    out!(
        "  max residuals |C| = {:.2e} m, |G qd| = {:.2e} m/s (largest drift of one step before projection {:.2e} m)",
        s.max_residual_position,
        s.max_residual_velocity,
        s.max_step_drift
    );
    out!("  max |T - T0 - W| = {:.3e} J", s.max_energy_error);
    let state: Vec<String> = r.state_names.iter().zip(&s.final_state).map(|(n, v)| format!("{n} = {v:.9}")).collect();
    out!("  final state: {}", state.join(", "));
    for f in &r.files {
        out!("  wrote {}", f.display());
    }
}
