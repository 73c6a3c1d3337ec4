//! A build without the JIT: no compiled kernels, so [`super::rhs`] takes
//! the tapes' path (the types it names exist, and are never made).

use super::FusedCall;

/// No kernels: never made.
#[derive(Debug)]
pub(crate) enum Kernels {}

/// Nothing: [`state`] and [`solve`] are never called.
pub(crate) struct Room;

impl Room {
    pub(crate) fn new() -> Self {
        Room
    }
}

#[expect(clippy::too_many_arguments, reason = "the JIT's signature")]
pub(crate) fn state<'r>(
    k: &Kernels,
    _: bool,
    _: &FusedCall<'_>,
    _: &[f64],
    _: &mut [f64],
    _: &mut [f64],
    _: &mut [f64],
    _: &'r mut Room,
) -> &'r mut [f64] {
    match *k {}
}

pub(crate) fn solve(
    k: &Kernels,
    _: &FusedCall<'_>,
    _: &[f64],
    _: &[f64],
    _: &mut [f64],
    _: &mut Room,
) -> Result<(), crate::error::KktError> {
    match *k {}
}
