//! `ezy sensitivity [SCENE] --wrt NAME[,NAME..]`: a scene's run with its
//! forward sensitivities ([`ezy_core::sensitivity`]): `sensitivity.csv`
//! (`t`, then `d<column>/d<param>`) and a figure per parameter.

use std::fmt::Write as _;
use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

use clap::{ArgMatches, Args, FromArgMatches};
use ezy_core::sensitivity::{MAX_PARAMETERS, Sensitivities};
use ezy_core::{Model, fmt_value};
use ezy_scene::Scene;

use super::{committed, scene_and_options};
use crate::app::{App, AppError};
use crate::cli::Overrides;
use crate::output::csv::{format_number, record};
use crate::output::transaction::{OutLock, Transaction};
use crate::render::plot::series::{Chart, Series};
use crate::session::{Error, RunOptions, analysis_error, problem, settings};

/// Run a scene with the derivatives of its state with respect to named
/// parameters (forward sensitivities): sensitivity.csv and a figure per
/// parameter.
#[derive(Args, Debug, Default)]
#[command(allow_negative_numbers = true)]
struct SensitivityArgs {
    /// Scene: a known name (see `list`; default: drive) or a path to a
    /// .toml scene file.
    scene: Option<String>,
    /// The parameters, comma-separated or repeated: a scene parameter
    /// (M0), a model parameter (m2), an effect's number (motor.omega,
    /// roll.damping: as for --set), or an initial value (initial.q.phi2,
    /// initial.qd.x1).
    #[arg(long, value_name = "NAME[,NAME..]", value_delimiter = ',', required = true)]
    wrt: Vec<String>,
    /// Output directory [default: out/sensitivity/SCENE].
    #[arg(long)]
    out: Option<PathBuf>,
    /// Do not draw the figures.
    #[arg(long)]
    no_figures: bool,
    #[command(flatten)]
    overrides: Overrides,
}

/// The arguments of `ezy sensitivity`, on the subcommand `cmd`.
pub(crate) fn cli(cmd: clap::Command) -> clap::Command {
    SensitivityArgs::augment_args(cmd)
}

/// Runs the scene named (or the default scene) with its sensitivities and
/// prints what it found and wrote.
pub(crate) fn exec(app: &App, args: &ArgMatches, out: &mut dyn Write) -> Result<(), AppError> {
    let args = SensitivityArgs::from_arg_matches(args)?;
    let (src, opts) =
        scene_and_options(app, args.scene.as_deref(), "sensitivity", (args.out, args.no_figures), &args.overrides)?;
    let scene = &src.scene;
    let model = &app.model_or_error(&scene.model)?;
    let clock = Instant::now();
    let (s, files) = sensitivity_model(model, scene, &opts, &args.wrt).map_err(AppError::from_run)?;
    committed(out, &summary(&scene.name, &s, clock.elapsed().as_secs_f64(), &files), &opts.out)
}

/// Refuses a list of parameters that is empty, too long, or names one
/// twice or by an empty name.
fn check_names(wrt: &[String]) -> Result<(), Error> {
    if wrt.len() > MAX_PARAMETERS {
        return Err(Error::Input(format!(
            "--wrt: {} parameters is more than {MAX_PARAMETERS}, the most one run differentiates with respect to",
            wrt.len()
        )));
    }
    for (k, name) in wrt.iter().enumerate() {
        if name.trim().is_empty() {
            return Err(Error::Input("--wrt: an empty parameter name (two commas, or one at an end)".into()));
        }
        if wrt[..k].contains(name) {
            return Err(Error::Input(format!("--wrt: `{name}` is named twice")));
        }
    }
    Ok(())
}

/// The sensitivity run of `scene` on `proto` (a model at its defaults),
/// written into `opts.out`.
///
/// # Errors
/// A bad name or setting, the run's and the output's errors.
fn sensitivity_model<M: Model>(
    proto: &M,
    scene: &Scene,
    opts: &RunOptions,
    wrt: &[String],
) -> Result<(Sensitivities, Vec<PathBuf>), Error> {
    check_names(wrt)?;
    let wrt: Vec<&str> = wrt.iter().map(|w| w.trim()).collect();
    let settings = settings(scene, opts)?;
    let (problem, _) = problem(proto, scene, opts, settings)?;
    let params = wrt.iter().map(|n| scene.parameter(proto, &opts.sets, n)).collect::<Result<Vec<_>, _>>()?;
    // the directory is this command's from here to the commit
    // armed before the lock: a signal between the two would take the
    // default action and leave the directory with its lock file
    crate::output::transaction::arm_signals();
    let held = OutLock::take(&opts.out)?;
    // a signal stops the work (it polls the flag) and leaves the directory as it was
    let s = problem
        .sensitivities_stop_when(&params, || crate::output::transaction::pending().is_some())
        .map_err(analysis_error(&opts.out))?;
    let mut tx = Transaction::begin_locked(held)?;
    let stems: Vec<String> = s.parameters.iter().map(|p| figure_stem(p)).collect();
    tx.retire(&["sensitivity.csv".to_string()]);
    tx.write("sensitivity.csv", csv(&s).as_bytes())?;
    if opts.figures {
        let (format, dpi) = opts.look(scene);
        for (j, stem) in stems.iter().enumerate() {
            tx.check(None, Some(format!("drawing {stem}")))?;
            let bytes = crate::render::plot::figure(&chart(&s, j), format, dpi)
                .map_err(|e| Error::Input(format!("figure {stem}: {e}")))?;
            tx.write(&format.file_name(stem), &bytes)?;
        }
    }
    let files = tx.commit()?;
    Ok((s, files))
}

/// The figure's file stem for parameter `p`: `sensitivity_<p>`, any
/// character but a letter, a digit, `.`, `-` or `_` written `_`.
fn figure_stem(p: &str) -> String {
    let safe: String =
        p.chars().map(|c| if c.is_ascii_alphanumeric() || matches!(c, '.' | '-' | '_') { c } else { '_' }).collect();
    format!("sensitivity_{safe}")
}

/// `sensitivity.csv`: `t`, then `d<column>/d<param>` parameter by parameter.
/// The header quoted where a name needs it ([`record`]); the numbers, which
/// never do, written into one string by one formatter ([`format_number`]):
/// a record per row built its own CSV writer, 60 % of the command's
/// instructions on `drive --wrt M0,m1` (callgrind).
fn csv(s: &Sensitivities) -> String {
    let mut head = vec!["t".to_string()];
    head.extend(s.columns());
    let mut text = record(head);
    let mut buf = zmij::Buffer::new();
    for (t, row) in s.t.iter().zip(&s.s) {
        text.push_str(format_number(&mut buf, *t));
        for v in row {
            text.push(',');
            text.push_str(format_number(&mut buf, *v));
        }
        text.push('\n');
    }
    text
}

/// Parameter `j`'s figure: the coordinates' sensitivities over time
/// (upper panel), the velocities' (lower panel).
fn chart(s: &Sensitivities, j: usize) -> Chart {
    let p = &s.parameters[j];
    let n2 = s.names.len();
    let mut chart = Chart::new(
        format!("Sensitivities of the state to {p} = {}", fmt_value(s.values[j])),
        "t [s]",
        format!("dq/d{p} [q's unit per {p}'s]"),
    );
    chart.lower = Some(format!("dqd/d{p}"));
    for (i, name) in s.names.iter().enumerate() {
        let points = s.t.iter().zip(&s.s).map(|(t, row)| (*t, row[j * n2 + i])).collect();
        chart.series.push(Series { panel: usize::from(i >= n2 / 2), ..Series::new(format!("d{name}/d{p}"), points) });
    }
    chart.legend_outside = true;
    chart
}

/// The text `ezy sensitivity` prints.
fn summary(scene: &str, s: &Sensitivities, seconds: f64, files: &[PathBuf]) -> String {
    let n2 = s.names.len();
    let t_end = s.t.last().copied().unwrap_or(0.0);
    let mut text = format!(
        "scene {scene}: state and sensitivities to t = {} s on {} in {} steps ({} rejected), {} evaluations of [x, S]', {:.2} s; the model's terms and the force laws differentiated exactly along S (a law of the user's own without a Jacobian by central differences of its force)\n",
        fmt_value(t_end),
        match s.formulation {
            ezy_core::Formulation::Reduced => format!(
                "the reduced formulation (its steps on the independent components differentiated; {} re-partitions)",
                s.repartitions
            ),
            _ => "the DAE (S projected with the state)".to_string(),
        },
        s.steps,
        s.rejected,
        s.evaluations,
        seconds
    );
    let last = s.s.last();
    for (j, p) in s.parameters.iter().enumerate() {
        let _ = write!(text, "d/d{p} at {p} = {} ({}):", fmt_value(s.values[j]), s.derivatives[j].describe());
        if let Some(row) = last {
            for (i, name) in s.names.iter().enumerate().take(3.min(n2)) {
                let _ = write!(text, " d{name}/d{p} = {}", fmt_value(row[j * n2 + i]));
            }
        }
        text.push('\n');
    }
    for f in files {
        let _ = writeln!(text, "wrote {}", f.display());
    }
    text
}
