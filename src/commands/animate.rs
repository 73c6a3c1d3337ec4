//! `ezy animate [SCENE]`: run a scene and draw its bodies moving, as an
//! animated GIF. The scene is integrated exactly as `ezy run` integrates
//! it (same setup, settings and overrides), with one output sample per
//! frame; the drawing is [`crate::render`]'s animation.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::{ArgMatches, Args, FromArgMatches};
use ezy_core::{Model, fmt_value};
use ezy_scene::Scene;

use super::committed;
use crate::app::{App, AppError};
use crate::cli::Overrides;
use crate::output::transaction::OutLock;
use crate::render::animation::{AnimateOptions, Frames, MAX_FRAMES, frame_count};
use crate::session::{Error, RunOptions, problem, settings};

/// Run a scene and draw its bodies moving, as an animated GIF.
#[derive(Args, Debug, Default)]
#[command(allow_negative_numbers = true)]
struct AnimateArgs {
    /// Scene: a known name (see `list`; default: drive) or a path to a
    /// .toml scene file.
    scene: Option<String>,
    /// The GIF file to write [default: out/SCENE/animation.gif].
    #[arg(long, value_name = "FILE.gif")]
    out: Option<PathBuf>,
    /// Frames per second (1 to 50).
    #[arg(long, value_name = "F", default_value_t = 20.0)]
    fps: f64,
    /// Seconds of simulated time per second of animation.
    #[arg(long, value_name = "S", default_value_t = 1.0)]
    speed: f64,
    /// Length of the fading trails of the skates' contact points (of the
    /// points, without skates; the first eight), in seconds of simulated
    /// time (0: none).
    #[arg(long, value_name = "T", default_value_t = 3.0)]
    trail: f64,
    #[command(flatten)]
    overrides: Overrides,
}

impl AnimateArgs {
    /// The animation's settings for scene `scene` (`--dpi` gives the frame
    /// size, default 64 dpi: 640 x 427 pixels).
    ///
    /// # Errors
    /// `--format`, which an animation does not take.
    fn options(&self, scene: &str) -> Result<AnimateOptions, String> {
        if let Some(f) = self.overrides.format {
            return Err(format!("--format {f}: an animation is always a GIF; set its size with --dpi"));
        }
        Ok(AnimateOptions {
            out: self.out.clone().unwrap_or_else(|| default_out(scene)),
            fps: self.fps,
            speed: self.speed,
            trail: self.trail,
            dpi: self.overrides.dpi.unwrap_or(64.0),
        })
    }
}

/// The default file of `ezy animate SCENE`: `out/SCENE/animation.gif`.
fn default_out(scene: &str) -> PathBuf {
    Path::new("out").join(scene).join("animation.gif")
}

/// The arguments of `ezy animate`, on the subcommand `cmd`.
pub(crate) fn cli(cmd: clap::Command) -> clap::Command {
    AnimateArgs::augment_args(cmd)
}

/// Runs the scene named (or the default scene), writes its GIF and says
/// what it wrote.
pub(crate) fn exec(app: &App, args: &ArgMatches, out: &mut dyn Write) -> Result<(), AppError> {
    let args = AnimateArgs::from_arg_matches(args)?;
    let (_, src) = app.named_scene(args.scene.as_deref())?;
    let scene = &src.scene;
    let anim = args.options(&scene.name).map_err(AppError::Failed)?;
    let opts = args.overrides.options();
    let model = &app.model_or_error(&scene.model)?;
    let report = animate_model(model, scene, &opts, &anim)?;
    let dir = anim.out.parent().unwrap_or(Path::new("."));
    committed(out, &report.summary(&anim), dir)
}

/// What an animation produced.
#[derive(Debug, Clone)]
struct AnimateReport {
    /// The GIF written.
    path: PathBuf,
    /// Number of frames.
    frames: usize,
    /// Frame size in pixels.
    size: (u32, u32),
    /// Simulated duration \[s\].
    t_end: f64,
    /// Wall time of the integration \[s\].
    integrate_s: f64,
    /// Wall time of drawing and encoding \[s\].
    draw_s: f64,
}

impl AnimateReport {
    /// One line for people.
    fn summary(&self, opts: &AnimateOptions) -> String {
        format!(
            "wrote {}: {} frames of {} x {} px, {:.1} s of animation for {} s simulated ({}x real time); integration {:.3} s, drawing {:.2} s\n",
            self.path.display(),
            self.frames,
            self.size.0,
            self.size.1,
            self.frames as f64 / opts.fps,
            self.t_end,
            opts.speed,
            self.integrate_s,
            self.draw_s
        )
    }
}

/// Integrates `scene` with `opts` (as `ezy run` does, one sample per
/// frame) and writes the animation `anim.out` of `proto` (a model at its
/// defaults).
///
/// # Errors
/// A setting out of range (checked before anything runs), the run's
/// errors (a bad scene, override or integration), and the drawing's.
fn animate_model<M: Model>(
    proto: &M,
    scene: &Scene,
    opts: &RunOptions,
    anim: &AnimateOptions,
) -> Result<AnimateReport, AppError> {
    let t_end = opts.t_end.unwrap_or(scene.t_end);
    frame_count(anim, t_end).map_err(AppError::failed)?;
    if let Some(every) = opts.every {
        return Err(AppError::Failed(format!(
            "--every {}: an animation samples every speed / fps seconds; set --speed and --fps instead",
            fmt_value(every)
        )));
    }
    let opts = RunOptions { every: Some(anim.speed / anim.fps), ..opts.clone() };
    let run_error = |e: ezy_core::SimError| AppError::from_run(Error::from(e));
    let settings = settings(scene, &opts).map_err(run_error)?;
    // a fixed-step method samples every whole number of steps: the frames
    // are that far apart, and the GIF's frame rate follows
    let mut anim = anim.clone();
    if !settings.method.is_adaptive() {
        let spacing = settings.output_stride() as f64 * settings.dt;
        anim.fps = anim.speed / spacing;
        let frames = settings.n_steps() / settings.output_stride() + 2;
        if frames > MAX_FRAMES as u64 || !(1.0..=50.0).contains(&anim.fps) {
            return Err(AppError::Failed(format!(
                "with steps of {} s, frames are {} s apart: {frames} frames at {} fps (at most {MAX_FRAMES} frames from 1 to 50 fps); choose --speed as a multiple of {} s times --fps",
                fmt_value(settings.dt),
                fmt_value(spacing),
                fmt_value(format!("{:.1}", anim.fps).parse().unwrap_or(anim.fps)),
                fmt_value(settings.dt)
            )));
        }
    }
    let anim = &anim;
    let (problem, run_scene) = problem(proto, scene, &opts, settings).map_err(run_error)?;
    let (mut sys, y0, _) = problem.into_system().map_err(run_error)?;
    // the GIF's directory is this command's from here to the write: a
    // second command into it meanwhile is refused at its start
    let dir = anim.out.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let _held = OutLock::take(dir).map_err(|e| AppError::from_run(Error::from(e)))?;
    let wall = Instant::now();
    let mut frames = Frames::default();
    ezy_core::simulate(&mut sys, &y0, &settings, &mut frames).map_err(|e| match e {
        ezy_core::RunError::Sim(e) => run_error(sys.explain(e, &settings)),
        ezy_core::RunError::Output(never) => match never {},
    })?;
    let integrate_s = wall.elapsed().as_secs_f64();
    let wall = Instant::now();
    let size = crate::render::animation::write(&sys, &run_scene, &frames, anim).map_err(AppError::failed)?;
    Ok(AnimateReport {
        path: anim.out.clone(),
        frames: frames.len(),
        size,
        t_end: settings.t_end,
        integrate_s,
        draw_s: wall.elapsed().as_secs_f64(),
    })
}
