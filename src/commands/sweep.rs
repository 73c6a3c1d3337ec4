//! `ezy sweep SCENE --grid ..`: many runs of one scene over parameter
//! values, resumable and shardable; `ezy sweep merge` combines shards
//! (the work: [`crate::sweep`]).

use std::io::Write;
use std::path::{Path, PathBuf};

use clap::{ArgMatches, Args, FromArgMatches, Subcommand};
use ezy_scene::registry::{SceneSource, info_of};

use super::{check_figure_format, committed};
use crate::app::scenes::is_scene_path;
use crate::app::{App, AppError};
use crate::cli::{Overrides, parse_count};
use crate::sweep;
use crate::sweep::table::parse_shard;

/// Run a scene over a grid, a list or random draws of parameter values
/// in parallel: one row per run in sweep.csv, resumable and shardable.
#[derive(Args, Debug, Default)]
#[command(args_conflicts_with_subcommands = true, allow_negative_numbers = true)]
struct SweepArgs {
    #[command(subcommand)]
    command: Option<SweepCommand>,
    /// Scene: a known name (see `list`) or a path to a .toml scene file.
    scene: Option<String>,
    /// An axis of evenly spaced values, START and STOP included
    /// (`--grid a=0.1:0.5:9`); repeatable, the first axis varies slowest.
    #[arg(long = "grid", value_name = "NAME=START:STOP:COUNT")]
    grids: Vec<String>,
    /// An axis of given values (`--list m2=1,2,4`); repeatable, after the
    /// --grid axes.
    #[arg(long = "list", value_name = "NAME=V1,V2,...")]
    lists: Vec<String>,
    /// A parameter drawn uniformly from [LO, HI] (`--random omega=1:6`);
    /// all random parameters are drawn together, --samples times, for
    /// every point of the other axes.
    #[arg(long = "random", value_name = "NAME=LO:HI")]
    randoms: Vec<String>,
    /// Number of random draws (with --random).
    #[arg(long, value_name = "N", value_parser = parse_count)]
    samples: Option<u64>,
    /// Seed of the random draws (ChaCha8: the same seed gives the same
    /// values on every machine).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// A quantity per run, a column of `trajectory.csv` or a figure's
    /// column function, reduced over a time window [s]:
    /// `mean(norm(x1d, y1d), 50, 60)`, `max(...)`, `min(...)`, `final(...)`
    /// (window optional: the whole run); or an event of the scene's:
    /// `event_time(NAME)` [s] (its first), `event_count(NAME)`; repeatable.
    #[arg(long = "metric", value_name = "EXPR")]
    metrics: Vec<String>,
    /// Runs at once [default: every core]; at most the number of cores
    /// this process may use (a larger value is capped, with a note).
    #[arg(long, value_name = "J")]
    jobs: Option<usize>,
    /// Output directory [default: out/sweep/SCENE].
    #[arg(long)]
    out: Option<PathBuf>,
    /// Run only every N-th run from the K-th (K from 0): one of N shards
    /// that `ezy sweep merge` combines.
    #[arg(long, value_name = "K/N", value_parser = parse_shard)]
    shard: Option<(u64, u64)>,
    /// Write a Slurm batch script for this sweep (a job array of shards
    /// and the merge as a dependent job) instead of running it. An
    /// existing FILE is replaced only if it is a script ezy wrote (never
    /// the scene, another file, a link, a FIFO or a device); paths and
    /// arguments are quoted in it, and one holding a control character
    /// (a newline) is refused.
    #[arg(long, value_name = "FILE")]
    emit_slurm: Option<PathBuf>,
    /// Number of array tasks in the Slurm script, at most the number of
    /// runs and 1000000 [default: 4].
    #[arg(long, value_name = "N", value_parser = parse_count, requires = "emit_slurm")]
    tasks: Option<u64>,
    /// Also keep every run's trajectory.csv and figures, in DIR/runs/RUN
    /// (a symbolic link at DIR/runs or DIR/runs/RUN is refused, never
    /// followed).
    #[arg(long)]
    save_runs: bool,
    /// Skip the sweep's figures.
    #[arg(long)]
    no_figures: bool,
    #[command(flatten)]
    overrides: Overrides,
}

#[derive(Subcommand, Debug)]
enum SweepCommand {
    /// Combine the outputs of a sweep's shards into one sweep.csv.
    Merge(MergeArgs),
}

#[derive(Args, Debug)]
struct MergeArgs {
    /// The shards' output directories.
    #[arg(required = true)]
    dirs: Vec<PathBuf>,
    /// Directory of the merged sweep.csv and figures.
    #[arg(long)]
    out: PathBuf,
    /// Skip the figures.
    #[arg(long)]
    no_figures: bool,
}

/// The sweep `args` define on the scene `src` (named `name` on the
/// command line): axes, metrics, overrides, output directory, jobs.
fn sweep_job(src: &SceneSource, name: &str, args: &SweepArgs) -> Result<sweep::SweepJob, AppError> {
    let scene = &src.scene;
    let mut axes = Vec::new();
    for g in &args.grids {
        axes.push(sweep::plan::grid(g).map_err(|e| AppError::Failed(format!("--grid {e}")))?);
    }
    for l in &args.lists {
        axes.push(sweep::plan::list(l).map_err(|e| AppError::Failed(format!("--list {e}")))?);
    }
    for r in &args.randoms {
        axes.push(sweep::plan::random(r).map_err(|e| AppError::Failed(format!("--random {e}")))?);
    }
    if let Some(a) = axes.iter().find(|a| args.overrides.sets.iter().any(|(n, _)| *n == a.name)) {
        return Err(AppError::Failed(format!("`{}` is both swept and fixed by --set", a.name)));
    }
    let plan = sweep::plan::Plan::new(axes, args.samples, args.seed).map_err(AppError::Failed)?;
    let metrics = args
        .metrics
        .iter()
        .map(|m| m.parse::<sweep::metric::Metric>())
        .collect::<Result<Vec<_>, _>>()
        .map_err(AppError::Failed)?;
    // at most the cores this process may use: more threads only
    // contend (and a huge --jobs would start them all)
    let cores = std::thread::available_parallelism().map_or(1, std::num::NonZero::get);
    let jobs = match args.jobs {
        Some(0) => return Err(AppError::Failed("--jobs 0: give at least 1".into())),
        Some(j) => j.min(cores),
        None => cores,
    };
    let mut definition = Vec::new();
    for (flag, list) in [("--grid", &args.grids), ("--list", &args.lists), ("--random", &args.randoms)] {
        for v in list {
            definition.extend([flag.to_string(), v.trim().to_string()]);
        }
    }
    if let Some(n) = args.samples {
        definition.extend(["--samples".into(), n.to_string(), "--seed".into(), args.seed.to_string()]);
    }
    for m in &metrics {
        definition.extend(["--metric".into(), m.text.clone()]);
    }
    definition.extend(args.overrides.to_args());
    let scene_ref = if is_scene_path(name) {
        std::fs::canonicalize(name).map_or_else(|_| name.to_string(), |p| p.display().to_string())
    } else {
        scene.name.clone()
    };
    let manifest = sweep::table::Manifest {
        scene: scene_ref,
        scene_fingerprint: sweep::fingerprint(&src.text),
        runs: plan.runs(),
        args: definition,
        shard: args.shard.map(|(k, n)| format!("{k}/{n}")),
    };
    let out = args.out.clone().unwrap_or_else(|| PathBuf::from("out").join("sweep").join(&scene.name));
    Ok(sweep::SweepJob {
        scene: scene.clone(),
        manifest,
        plan,
        metrics,
        opts: args.overrides.options(),
        out,
        jobs,
        shard: args.shard,
        save_runs: args.save_runs,
        figures: !args.no_figures,
        progress: true,
        check_only: false,
    })
}

/// The arguments of `ezy sweep` (and `ezy sweep merge`), on the
/// subcommand `cmd`.
pub(crate) fn cli(cmd: clap::Command) -> clap::Command {
    SweepArgs::augment_args(cmd)
}

/// Runs the sweep (or writes its Slurm script, or merges shards) and
/// prints its summary.
pub(crate) fn exec(app: &App, args: &ArgMatches, out: &mut dyn Write) -> Result<(), AppError> {
    let args = SweepArgs::from_arg_matches(args)?;
    if let Some(SweepCommand::Merge(m)) = args.command {
        return merge(app, m, out);
    }
    let Some(name) = args.scene.clone() else {
        return Err(AppError::Failed(
            "sweep needs a scene and at least one axis: `ezy sweep SCENE --grid NAME=START:STOP:COUNT` (see `ezy sweep --help`)".into(),
        ));
    };
    let src = app.load_scene(&name).map_err(AppError::failed)?;
    let mut job = sweep_job(&src, &name, &args)?;
    // the sweep's own figures, and each saved run's
    check_figure_format(&src, job.opts.figure_format, job.figures || job.save_runs)?;
    let model = &app.model_or_error(&src.scene.model)?;
    if let Some(file) = &args.emit_slurm {
        if args.shard.is_some() {
            return Err(AppError::Failed("--emit-slurm writes the shards itself: leave out --shard".into()));
        }
        job.check_only = true;
        sweep::sweep_model(model, &job).map_err(AppError::failed)?;
        let runs = job.plan.runs();
        let tasks = args.tasks.unwrap_or(4).min(runs);
        let dir = std::path::absolute(&job.out).map_err(|e| AppError::Failed(format!("{}: {e}", job.out.display())))?;
        let exe = std::env::current_exe().map_err(|e| AppError::Failed(format!("the path of this program: {e}")))?;
        let text =
            sweep::slurm::script(&exe, &job.manifest.scene, &job.manifest.args, &dir, tasks, runs, &src.scene.name)
                .map_err(AppError::Failed)?;
        // the scene's file (a known scene is none), never replaced
        let scene_file = Path::new(&job.manifest.scene);
        let scene_file = scene_file.is_absolute().then_some(scene_file);
        sweep::slurm::write_script(file, &text, scene_file).map_err(AppError::Failed)?;
        let msg = format!(
            "wrote {} ({runs} runs in {tasks} array tasks, merged into {}); submit it with `bash {}`\n",
            file.display(),
            dir.display(),
            file.display()
        );
        return Ok(out.write_all(msg.as_bytes())?);
    }
    if let Some(asked) = args.jobs.filter(|&j| j > job.jobs) {
        eprintln!("note: --jobs {asked} capped to {}, the number of cores this process may use", job.jobs);
    }
    let report = sweep::sweep_model(model, &job).map_err(|e| match e {
        sweep::SweepError::Interrupted(i) => AppError::Interrupted(i),
        e => AppError::failed(e),
    })?;
    committed(out, &report.summary(&src.scene.name), &job.out)
}

/// `ezy sweep merge`: the shards' tables in one, and the sweep's figures
/// drawn from it.
fn merge(app: &App, args: MergeArgs, out: &mut dyn Write) -> Result<(), AppError> {
    let (manifest, mut files) = sweep::table::merge(&args.dirs, &args.out).map_err(AppError::Failed)?;
    let mut notes = Vec::new();
    if !args.no_figures {
        // the plan and the metrics, from the definition the shards share
        let mut argv = vec!["ezy".to_string(), "sweep".into(), manifest.scene.clone()];
        argv.extend(manifest.args.iter().cloned());
        let matches = crate::cli::top().subcommand(cli(clap::Command::new("sweep"))).try_get_matches_from(&argv);
        let parsed = match matches.and_then(|m| m.subcommand().map(|(_, m)| SweepArgs::from_arg_matches(m)).transpose())
        {
            Ok(Some(a)) => a,
            Ok(None) => {
                return Err(AppError::Failed(format!("the shards' sweep.toml does not parse: {}", argv.join(" "))));
            }
            Err(e) => {
                let why = e.to_string();
                let why = why.lines().next().unwrap_or_default().trim_start_matches("error: ");
                return Err(AppError::Failed(format!(
                    "the shards' sweep.toml does not parse: {}: {why}",
                    argv.join(" ")
                )));
            }
        };
        let src = app.load_scene(&manifest.scene).map_err(AppError::failed)?;
        let job = sweep_job(&src, &manifest.scene, &parsed)?;
        check_figure_format(&src, job.opts.figure_format, true)?;
        let info = info_of(&app.model_or_error(&src.scene.model)?, &[]).map_err(|e| AppError::Failed(e.message))?;
        let look = job.opts.look(&job.scene);
        let (f, n) = sweep::figure::draw(&args.out, &job.plan, &job.metrics, &info, look).map_err(|e| match e {
            sweep::SweepError::Interrupted(i) => AppError::Interrupted(i),
            e => AppError::failed(e),
        })?;
        files.extend(f);
        notes = n;
    }
    let mut text = format!("merged {} shards: {} runs into {}\n", args.dirs.len(), manifest.runs, args.out.display());
    for n in notes {
        text.push_str(&format!("  note: {n}\n"));
    }
    for f in files {
        text.push_str(&format!("  wrote {}\n", f.display()));
    }
    committed(out, &text, &args.out)
}
