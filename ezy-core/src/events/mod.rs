//! Events: a quantity of the run crossing a level, recorded, stopping the
//! run or switching effects on and off. What an event is lives in
//! [`spec`] (data a scene or a library user writes); locating
//! crossings while the run steps is the step loop's
//! ([`crate::simulate::events`]).
//!
//! The items of [`spec`] are re-exported here for users of the crate
//! (`ezy_core::events::EventSpec`); inside the crate they are named by
//! their defining module.

pub mod spec;

pub use spec::{
    Action, CHATTER_STEPS, Direction, Event, EventFn, EventRecord, EventSpec, KeyError, MAX_EVENT_BYTES, Quantity,
    check_event_name, friction_force_unwatched, max_records,
};
