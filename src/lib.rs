#![warn(missing_docs)]
//! ezy: planar vehicles and mechanisms with hinges and skates.
//!
//! Data flows one way:
//!
//! ```text
//! model! { .. }        the model text, in your crate
//!   -> ezy-derive      phi(q), its Jacobian, the skate rows S(q), gamma, the
//!                      sparsity pattern: generated Rust, at compile time
//!   -> Problem         the model with its parameters, effects, drives, initial
//!                      values and settings (ezy-core; from a scene file: ezy-scene)
//!   -> integrator      RK4, DOPRI5, DOP853 or RADAU5 on the KKT system, with
//!                      coordinate projection (or the reduced formulation)
//!   -> samples         in memory (Solution), or trajectory.csv and figures (App)
//! ```
//!
//! A whole program with a vehicle of its own, a scene and every command
//! of the `ezy` binary (`run`, `sweep`, `analyze`, ...: `--help` lists
//! them):
//!
//! ```no_run
//! ezy::model! {
//!     /// The Chaplygin sleigh: one body, a skate `a` behind its centre of mass.
//!     pub struct Sleigh {
//!         /// Distance from the centre of mass back to the skate [m]
//!         param a = 0.5;
//!         body s(x, y, phi) { mass: 1.0, inertia: 0.1 }
//!         point P on s at (-a, 0);
//!         skate P: P along (1, 0);
//!     }
//! }
//!
//! fn main() -> std::process::ExitCode {
//!     let scene = r#"
//!         name = "glide"
//!         description = "The sleigh from 1 m/s and 1 rad/s: yaw turns into speed"
//!         model = "sleigh"
//!         t_end = 10.0
//!         [initial]
//!         q = { x = 0.0, y = 0.0, phi = 0.0 }
//!         qd = { x = 1.0, phi = 1.0 }
//!     "#;
//!     // `my-sleigh run glide` writes out/glide/trajectory.csv
//!     ezy::App::new().model::<Sleigh>("sleigh").scene("glide.toml", scene).main()
//! }
//! ```
//!
//! The same run in memory, without files: [`Problem`] (its documentation
//! opens with the EzyRoller's drive scene written in Rust). A force law
//! or controller of your own: [`effects::EffectKind`] and
//! [`effects::ForceLaw`], registered with [`App::effect`]; a closure with
//! [`Problem::controller`].
//!
//! Modules, from the command line down:
//!
//! ```text
//! app/        App: the table of models and scenes, main, run_cli (parse,
//!             then the command's line in the table)
//! cli         the top command and the overrides its commands share
//! commands/   one file per command, its arguments and its exec; the
//!             table of commands in mod.rs
//! run         a scene run to trajectory.csv and figures, or in memory
//! precision   the work-precision ladder
//! sweep/      many runs of a scene, resumable and sharded
//! session     what commands share: RunOptions, settings, Report, summary
//! render/     plot/ (charts, heat maps; SVG, PNG, PDF), figures,
//!             animation, report
//! output/     csv, transaction (the locked output directory), progress
//! testing     a model's derived terms checked in its author's tests
//! ```
//!
//! Imports go down this list (a command also sees the [`App`] it runs
//! on): no command imports another, what they share is in [`session`];
//! [`render`] never imports the session or the commands, and [`output`]
//! imports none of the modules above it. The public modules are [`app`],
//! [`session`] ([`RunOptions`], [`Report`]), [`output`] ([`output::csv`]
//! the trajectory table, [`output::transaction`]), [`render`]
//! ([`render::plot`], [`render::figures`]), [`precision`] and [`testing`].
//! The `ezy` binary is `App::new().main()`.

pub mod app;
mod cli;
mod commands;
pub mod output;
pub mod precision;
pub mod render;
mod run;
pub mod session;
mod sweep;
pub mod testing;

pub use app::App;
pub use commands::python_commands;
pub use ezy_core;
pub use ezy_core::{Model, Problem, Solution, model};
pub use ezy_core::{analysis, effects, events, geometry};
pub use ezy_models as models;
pub use ezy_scene;
pub use ezy_scene::Scene;
/// serde, for the `Deserialize` and `Serialize` of an effect kind of the
/// user's own (`#[serde(crate = "ezy::serde")]`).
pub use serde;
pub use session::{Report, RunOptions};

/// Paths the code `model!` generates uses in a crate that depends on
/// `ezy` alone; not public API.
#[doc(hidden)]
pub use ezy_core::__private;

/// The README's and the guide's Rust examples (docs/book), compiled and
/// run as doctests of this crate (`cargo test --release --workspace`), so
/// an example a user copies cannot rot. The guide's other chapters show
/// compiled sources through mdBook's `{{#include}}`.
#[cfg(doctest)]
pub mod book_examples {
    #[doc = include_str!("../README.md")]
    pub struct Readme;
    #[doc = include_str!("../docs/book/src/library.md")]
    pub struct Library;
    #[doc = include_str!("../docs/book/src/models.md")]
    pub struct Models;
    #[doc = include_str!("../docs/book/src/analysis.md")]
    pub struct Analysis;
    #[doc = include_str!("../docs/book/src/events.md")]
    pub struct Events;
    #[doc = include_str!("../docs/book/src/friction.md")]
    pub struct Friction;
    #[doc = include_str!("../docs/book/src/geometry.md")]
    pub struct Geometry;
}
