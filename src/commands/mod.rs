//! The commands of the command line, one module each (as cargo keeps
//! `cargo/ops` apart from its `commands`): what a command does with its
//! options, over the library's [`ezy_core::Problem`]. The other commands
//! (`sweep`, `animate`, `precision`, `bench`, `scale`, `equations`) still
//! live in their own top-level modules.

pub mod analyze;
pub mod run;
