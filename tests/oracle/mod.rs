//! The oracle harness: every number class ezy prints checked against an
//! oracle that shares no code with the computation under test (a scan of
//! whole evaluations, differences of whole runs with a Richardson-checked
//! step, a closed form, a Gauss-Newton solve written here), on built-in
//! scenes and on models of a user's own typed as text.
//!
//! Each submodule is one number class. Its fast cases run in CI with the
//! suite; the whole harness (every scene and setting a class accepts)
//! runs with
//!
//! ```text
//! cargo test --release --test suite -- --include-ignored oracle::
//! ```
//!
//! and its coverage and run time are in docs/dev/oracle.md. A new command
//! or printed quantity joins the harness in the same change
//! (docs/dev/tests.md says where).

mod bifurcations;
mod branches;
mod fit;
mod force_jacobian;
mod gait_means;
mod gait_power;
mod gait_sensitivity;
mod geometry;
mod growth;
mod linearization;
mod optimize;
mod run_sensitivity;
mod single_points;
mod stability_words;
