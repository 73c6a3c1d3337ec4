//! The state of the watch on what switches a run's forces or rows
//! ([`SlipWatch`]: the skates' margins and the switching events' values
//! at the ends of the step, their switches in a row); the watching itself
//! is [`super::slip`]'s.

use crate::formulation::dae::Dynamics;
use crate::model::Model;

/// The watch on what switches the run's forces or rows: the skates with
/// friction ([`crate::formulation::friction`]: each one's margin) and then the events
/// that switch effects ([`crate::events::spec::Action::Switch`]: each one's
/// `g`), at the start and the end of the step, and their switches in a row.
#[derive(Debug, Default)]
pub(super) struct SlipWatch {
    pub(super) left: Vec<f64>,
    pub(super) right: Vec<f64>,
    /// The time of `left` \[s\].
    pub(super) t_left: f64,
    /// The skates' margin rates at `left` and `right` (one per skate).
    pub(super) left_rate: Vec<f64>,
    pub(super) right_rate: Vec<f64>,
    /// The smallest margin that counts as a violation, per skate
    /// ([`Dynamics::slip_tolerances`]).
    pub(super) eps: Vec<f64>,
    /// Per skate: whether its margin needs a look inside the step
    /// ([`crate::formulation::friction::margin_suspect`]).
    pub(super) suspect: Vec<bool>,
    /// The skates' margins and rates (one per skate).
    pub(super) scratch: Vec<f64>,
    pub(super) scratch_rate: Vec<f64>,
    /// The longest next step after a step cut where a margin was no longer
    /// resolved ([`crate::formulation::friction::MarginScan::Unresolved`]) \[s\].
    pub(super) h_max: Option<f64>,
    /// Cuts in a row that moved the run on by rounding only.
    pub(super) stalls: u32,
    /// Per switch event: `(steps in a row with a switch, when they began,
    /// the step count at its last switch)` (the skates':
    /// [`SlipWatch::skate_streaks`]).
    pub(super) streaks: Vec<(u64, f64, u64)>,
    /// Per skate: its switches at ever shorter intervals.
    pub(super) skate_streaks: Vec<crate::formulation::friction::SwitchStreak>,
    /// The switch events: indices into [`Dynamics::events`].
    pub(super) switches: Vec<usize>,
    /// Per skate, then per switch event: where it crossed in the step
    /// being cut (infinite where it did not).
    pub(super) times: Vec<f64>,
    /// Scratch of [`crate::events::spec::Event::value`].
    pub(super) values: Vec<f64>,
    /// Scratch: a full state on the step's continuous extension.
    pub(super) full: Vec<f64>,
}

impl SlipWatch {
    /// Whether watch `k` (a skate, then a switch event) crossed from
    /// `left` to `right`, and which way (`Some(true)`: a skate begins to
    /// slide or turns, an event rises).
    pub(super) fn crossing<M: Model>(&self, sys: &Dynamics<M>, k: usize) -> Option<bool> {
        let (l, r, nf) = (self.left[k], self.right[k], sys.friction.len());
        if k < nf {
            self.suspect[k].then_some(true)
        } else {
            sys.events[self.switches[k - nf]].direction.crossing(l, r)
        }
    }
}
