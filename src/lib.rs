#![warn(missing_docs)]
//! ezy: planar vehicles and mechanisms with hinges and skates.
//!
//! A model is declared with [`model!`]; [`App`] runs the command line
//! (`run`, `list`, `precision`, `equations`, `check`, `scale`) over the
//! built-in vehicles and any added with [`App::model`]; [`testing`]
//! checks a model's derived terms in its author's tests. The `ezy` binary
//! is `App::new().main()`.

pub mod animate;
pub mod app;
pub mod bench;
mod cli;
pub mod commands;
pub mod equations;
pub mod figures;
pub mod output;
pub mod plot;
pub mod precision;
pub mod progress;
pub mod report;
pub mod scale;
pub mod sweep;
pub mod testing;
pub mod transaction;

pub use app::App;
pub use commands::run::{Report, RunOptions};
pub use ezy_core;
pub use ezy_core::effects;
pub use ezy_core::{Model, Problem, Solution, model};
pub use ezy_models as models;
pub use ezy_scene;
pub use ezy_scene::Scene;
/// serde, for the `Deserialize` and `Serialize` of an effect kind of the
/// user's own (`#[serde(crate = "ezy::serde")]`).
pub use serde;

/// Paths the code `model!` generates uses in a crate that depends on
/// `ezy` alone; not public API.
#[doc(hidden)]
pub use ezy_core::__private;
