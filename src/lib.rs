//! ezy: planar vehicles and mechanisms with hinges and skates.
//!
//! Models are declared with [`ezy_core::model!`] (see `models/`), scenes
//! are run with [`run::run_scene`], which writes `trajectory.csv` and the
//! scene's figures. The `ezy` binary is the command-line front end.

pub mod check;
pub mod equations;
pub mod figures;
pub mod output;
pub mod plot;
pub mod precision;
pub mod progress;
pub mod run;
pub mod scale;

pub use ezy_core;
pub use ezy_models as models;
