//! The Roller Racer's tests, one module per file beside this one, built as
//! one test binary (one link, one instantiation of ezy's solver for the
//! crate's models). Run one file's tests with its module name as the
//! filter: `cargo test --release --test suite -- friction::`.

mod common;

mod analyze;
mod derivatives;
mod events;
mod figures;
mod friction;
mod minimal;
mod scene;
mod sweep;
