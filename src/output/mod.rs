//! What a command writes: the trajectory table as CSV ([`csv`]), every
//! output directory as a transaction ([`transaction`]: all files or none,
//! and the signals that cancel one), and the progress of a long run on
//! stderr (`progress`).
//!
//! This layer imports nothing of the crate outside it: the commands, the
//! run session and the drawings ([`crate::render`]) write through it.

pub mod csv;
pub(crate) mod progress;
pub mod transaction;
