//! `ezy linearize [SCENE]`: a scene linearized at a time of its run
//! ([`ezy_core::analysis::Analysis::linearize`]): `A.csv`, `B.csv` (with
//! `--input`), `eigenvalues.csv`, `state.csv`.

use std::fmt::Write as _;
use std::io::Write;
use std::path::PathBuf;

use clap::{ArgMatches, Args, FromArgMatches};
use ezy_core::analysis::{Input, c64};
use ezy_core::{Model, fmt_value};
use ezy_scene::Scene;

use super::committed;
use crate::app::{App, AppError};
use crate::cli::Overrides;
use crate::output::csv::{number, record};
use crate::output::transaction::{OutLock, Transaction};
use crate::session::{Error, RunOptions, analysis_error, check_run, complex, rounded, run_to, scene_analysis};

/// Linearize a scene at a time of its run: A.csv, B.csv (with
/// --input), eigenvalues.csv, state.csv.
#[derive(Args, Debug, Default)]
#[command(allow_negative_numbers = true)]
struct LinearizeArgs {
    /// Scene: a known name (see `list`; default: drive) or a path to a
    /// .toml scene file.
    scene: Option<String>,
    /// The time [s] of the scene's run whose state is linearized about.
    #[arg(long, value_name = "T", default_value_t = 0.0)]
    at: f64,
    /// An input, a column of B: tau_HINGE (a torque pair at a hinge) or
    /// scale_EFFECT (an effect's force scaled by 1 + u); repeatable.
    #[arg(long = "input", value_name = "NAME")]
    inputs: Vec<String>,
    /// Output directory [default: out/linearize/SCENE].
    #[arg(long)]
    out: Option<PathBuf>,
    #[command(flatten)]
    overrides: Overrides,
}

/// The arguments of `ezy linearize`, on the subcommand `cmd`.
pub(crate) fn cli(cmd: clap::Command) -> clap::Command {
    LinearizeArgs::augment_args(cmd)
}

/// Linearizes the scene named (or the default scene) and prints the
/// eigenvalues and the files written.
pub(crate) fn exec(app: &App, args: &ArgMatches, out: &mut dyn Write) -> Result<(), AppError> {
    let args = LinearizeArgs::from_arg_matches(args)?;
    let (_, src) = app.named_scene(args.scene.as_deref())?;
    let scene = &src.scene;
    let opts = LinearizeOptions {
        run: RunOptions {
            out: args.out.unwrap_or_else(|| PathBuf::from("out").join("linearize").join(&scene.name)),
            ..args.overrides.options()
        },
        at: args.at,
        inputs: args.inputs,
    };
    let model = &app.model_or_error(&scene.model)?;
    let report = linearize_model(model, scene, &opts).map_err(AppError::from_run)?;
    committed(out, &linearize_summary(&scene.name, &report), &opts.run.out)
}

/// What `ezy linearize` is asked.
#[derive(Debug, Clone, Default)]
struct LinearizeOptions {
    /// Output directory, overrides; `t_end` is ignored.
    run: RunOptions,
    /// The time \[s\] whose state (of the scene's run) is linearized about.
    at: f64,
    /// Inputs by column name: `tau_<hinge>`, `scale_<effect>`.
    inputs: Vec<String>,
}

/// What `ezy linearize` found and wrote.
#[derive(Debug, Clone)]
struct LinearizeReport {
    /// The linearization.
    linearization: ezy_core::analysis::Linearization,
    /// Eigenvalues on the constraint manifold.
    eigenvalues: Vec<c64>,
    /// Files written.
    files: Vec<PathBuf>,
}

/// Parses an input's column name (`tau_<hinge>`, `scale_<effect>`).
///
/// # Errors
/// A name of neither form.
fn parse_input(text: &str) -> Result<Input, String> {
    if let Some(h) = text.strip_prefix("tau_").filter(|h| !h.is_empty()) {
        Ok(Input::HingeTorque(h.into()))
    } else if let Some(e) = text.strip_prefix("scale_").filter(|e| !e.is_empty()) {
        Ok(Input::EffectScale(e.into()))
    } else {
        Err(format!("input `{text}`: write tau_HINGE (a torque at a hinge) or scale_EFFECT (an effect's force scaled)"))
    }
}

/// `ezy linearize` on `proto`, a model at its defaults: `A.csv`, `B.csv` (with inputs),
/// `eigenvalues.csv` and `state.csv`.
///
/// # Errors
/// A bad time or input, the setup's and the output's errors.
fn linearize_model<M: Model>(proto: &M, scene: &Scene, opts: &LinearizeOptions) -> Result<LinearizeReport, Error> {
    let ro = &opts.run;
    if !(opts.at.is_finite() && opts.at >= 0.0) {
        return Err(Error::Input(format!("--at {}: the time must be zero or a positive number of seconds", opts.at)));
    }
    let inputs = opts.inputs.iter().map(|i| parse_input(i)).collect::<Result<Vec<_>, _>>().map_err(Error::Input)?;
    let (mut an, x0) = scene_analysis(proto, scene, &ro.sets)?;
    an.check_inputs(&inputs).map_err(analysis_error(&ro.out))?;
    if opts.at > 0.0 {
        check_run(proto, scene, ro)?;
    }
    // the directory is this command's from here to the commit
    let held = OutLock::take(&ro.out)?;
    let x = if opts.at > 0.0 {
        let (mut x, stopped) = run_to(proto, scene, ro, opts.at, 1)?;
        // the state of a run that stopped short is not the state at --at
        if let Some((event, t)) = stopped.filter(|(_, t)| *t < opts.at) {
            return Err(Error::Input(format!(
                "--at {}: the run stops at the event `{event}` at t = {} s, before it; linearize at a time the run reaches",
                fmt_value(opts.at),
                fmt_value(t)
            )));
        }
        x.pop().unwrap_or(x0)
    } else {
        x0
    };
    let lin = an.linearize(opts.at, &x, &inputs).map_err(analysis_error(&ro.out))?;
    let eigenvalues = lin.eigenvalues().map_err(analysis_error(&ro.out))?;
    let names = &lin.state_names;
    let matrix = |m: &ezy_core::faer::Mat<f64>, cols: &[String]| {
        let mut head = vec!["row".to_string()];
        head.extend(cols.iter().cloned());
        let mut out = record(head);
        for (i, name) in names.iter().enumerate() {
            let mut cells = vec![name.clone()];
            cells.extend((0..m.ncols()).map(|j| number(m[(i, j)])));
            out.push_str(&record(cells));
        }
        out
    };
    let mut tx = Transaction::begin_locked(held)?;
    tx.retire(&["A.csv", "B.csv", "eigenvalues.csv", "state.csv"].map(String::from));
    tx.write("A.csv", matrix(&lin.a, names).as_bytes())?;
    if !inputs.is_empty() {
        tx.write("B.csv", matrix(&lin.b, &lin.input_names).as_bytes())?;
    }
    let mut ev = record(vec!["k".into(), "re".into(), "im".into()]);
    for (k, z) in eigenvalues.iter().enumerate() {
        ev.push_str(&record(vec![(k + 1).to_string(), number(z.re), number(z.im)]));
    }
    tx.write("eigenvalues.csv", ev.as_bytes())?;
    let mut st = record(vec!["name".into(), "value".into()]);
    for (n, v) in names.iter().zip(&lin.state) {
        st.push_str(&record(vec![n.clone(), number(*v)]));
    }
    tx.write("state.csv", st.as_bytes())?;
    let files = tx.commit()?;
    Ok(LinearizeReport { linearization: lin, eigenvalues, files })
}

/// The text `ezy linearize` prints.
fn linearize_summary(scene: &str, r: &LinearizeReport) -> String {
    let l = &r.linearization;
    let mut s = format!(
        "scene {scene} at t = {} s: A is {} x {}{}; on the constraint manifold ({} dimensions) the eigenvalues [1/s] are {}\n",
        fmt_value(l.t),
        l.a.nrows(),
        l.a.ncols(),
        if l.forces_by_differences {
            " (applied forces differentiated by central differences, the model's terms exactly)"
        } else {
            " (exact)"
        },
        l.tangent.ncols(),
        r.eigenvalues.iter().map(|z| complex(*z)).collect::<Vec<_>>().join(", ")
    );
    // at a moving state the eigenvalues are those of the world frame's
    // coordinates along the passing motion: no verdict on stability
    let nq = l.state.len() / 2;
    let speed = l.state[nq..].iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if speed > 0.0 {
        let _ = writeln!(
            s,
            "note: the state moves (largest velocity {} in q's units per second): A and its eigenvalues are those of the world frame's coordinates q, qd along the motion passing through it at t = {} s; they depend on the frame and say nothing of the stability of a steady motion or gait, which `ezy analyze` gives, modulo the plane's rigid motions",
            rounded(speed),
            fmt_value(l.t)
        );
    }
    for f in &r.files {
        let _ = writeln!(s, "wrote {}", f.display());
    }
    s
}
