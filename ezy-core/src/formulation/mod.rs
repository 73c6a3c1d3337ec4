//! The equations a run integrates: the index-1 DAE in all
//! `q, qd` with its KKT solve ([`dae`]: [`dae::Dynamics`], the workspace,
//! effects and drives applied), the skates' friction modes ([`friction`]),
//! coordinate projection back onto the constraints ([`projection`]), the
//! reduced formulation on independent coordinates ([`reduced`]),
//! consistent initial values ([`initial`]) and the Newton system RADAU5
//! solves on the KKT matrix ([`newton`], implementing
//! [`crate::integrator::radau5::NewtonSystem`]).
//!
//! Every module here imports only lower floors (settings, model info,
//! effects, drives, the `Model` trait, KKT solvers, event specs) and its
//! siblings; the step loop ([`crate::simulate`](mod@crate::simulate)) sits above.

pub mod dae;
mod fast_law;
pub mod friction;
pub mod initial;
pub mod newton;
pub mod projection;
pub mod reduced;
