//! The `ezy` command line: `ezy run [SCENE]`, `ezy list`.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand, ValueEnum};
use ezy::run::{Report, RunOptions, run_scene};
use ezy_core::ProjectionKind;

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
}

#[derive(clap::Args, Debug, Default)]
#[command(allow_negative_numbers = true)]
struct RunArgs {
    /// Scene name (see `ezy list`).
    #[arg(default_value = "drive")]
    scene: String,
    /// Output directory [default: out/SCENE].
    #[arg(long)]
    out: Option<PathBuf>,
    /// Override a model parameter or an effect parameter (M0, omega), e.g. --set m2=2.
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
    /// Skip the figures (CSV only).
    #[arg(long)]
    no_figures: bool,
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
    println!("models:");
    for (key, info) in ezy_models::MODELS {
        println!("  {key:<18} {} (nq = {}, nc = {})", info.doc, info.nq(), info.nc());
    }
    println!("scenes:");
    for s in ezy_models::scenes::builtin() {
        println!("  {:<18} {}", s.name, s.description);
    }
}

fn run(args: RunArgs) -> Result<(), String> {
    let scene = ezy_models::scenes::find(&args.scene).ok_or_else(|| {
        let known: Vec<&str> = ezy_models::scenes::builtin().iter().map(|s| s.name).collect();
        format!("unknown scene `{}`; known scenes: {}", args.scene, known.join(", "))
    })?;
    let opts = RunOptions {
        out: args.out.unwrap_or_else(|| PathBuf::from("out").join(scene.name)),
        sets: args.sets,
        dt: args.dt,
        t_end: args.t_end,
        every: args.every,
        projection: args.projection.map(|p| match p {
            Projection::None => ProjectionKind::None,
            Projection::Euclidean => ProjectionKind::Euclidean,
            Projection::Mass => ProjectionKind::MassWeighted,
        }),
        figures: !args.no_figures,
        progress: true,
    };
    let report = run_scene(&scene, &opts).map_err(|e| e.to_string())?;
    print_summary(scene.name, &report);
    Ok(())
}

fn print_summary(scene: &str, r: &Report) {
    let s = &r.summary;
    let t = s.integration_time.as_secs_f64();
    println!(
        "{scene}: {} RK4 steps of h = {} s to t = {} s, projection {} ({} KKT path)",
        s.steps,
        r.settings.dt,
        r.settings.t_end,
        r.settings.projection.name(),
        s.kkt
    );
    println!(
        "  RHS evaluations {}, integration {:.3} s ({:.0} ns per RHS incl. projection), whole run {:.3} s",
        s.counters.rhs_evals,
        t,
        t / s.counters.rhs_evals.max(1) as f64 * 1e9,
        r.wall.as_secs_f64()
    );
    println!(
        "  max residuals |C| = {:.2e} m, |G qd| = {:.2e} m/s (largest drift of one step before projection {:.2e} m)",
        s.max_residual_position, s.max_residual_velocity, s.max_step_drift
    );
    println!("  max |T - T0 - W| = {:.3e} J", s.max_energy_error);
    let state: Vec<String> = r.state_names.iter().zip(&s.final_state).map(|(n, v)| format!("{n} = {v:.9}")).collect();
    println!("  final state: {}", state.join(", "));
    for f in &r.files {
        println!("  wrote {}", f.display());
    }
}
