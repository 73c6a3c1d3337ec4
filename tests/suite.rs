//! The integration tests, one module per file beside this one, built as
//! one test binary: each file used to be its own binary, and each linked
//! and instantiated ezy's generic solver for its models again (43 release
//! binaries took most of CI's build). `tests/no_alloc.rs` (it installs a
//! counting global allocator) and `tests/docs.rs` stay binaries of their own.
//!
//! Run one file's tests with its module name as the filter:
//! `cargo test --release --test suite -- friction::`.

#[path = "support/bare_rhs.rs"]
mod bare_rhs;
mod common;
mod continuation;
#[path = "support/text_models.rs"]
mod text_support;

mod adversarial_input;
mod adversarial_output;
mod analysis;
mod any_model;
mod app;
mod bench;
mod bifurcation;
mod build_sharing;
mod cli;
mod closed_branch;
mod culprits;
mod cycle_branch;
mod derived_terms;
mod design;
mod drives;
mod effects;
mod events;
mod figures;
mod formulations;
mod friction;
mod gait_optimize;
mod gait_report;
mod geometry;
mod growth;
mod guards;
mod hard_cases;
mod hinge_friction;
mod hostile_sizing;
mod hostile_sweep;
mod kkt_paths;
mod mechanisms;
mod models;
mod optimize;
mod oracle;
mod output_window;
mod plan;
mod properties;
mod quantities;
mod refusals;
mod scene_files;
mod scenes;
mod sensitivity;
mod singular;
mod sliders;
mod slurm;
mod snakeboard;
mod stiff;
mod sweep;
mod switching;
mod testing;
mod text_models;
