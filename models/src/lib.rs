#![warn(missing_docs)]
//! Vehicles written in ezy's model language, one file each, their
//! registration under the keys scene files use, and the built-in scenes.
//!
//! This crate depends on `ezy-core` alone: it is the in-repository
//! example of a model crate of that kind (`model!` finds the runtime as
//! `::ezy_core`); a user's crate usually depends on `ezy` alone instead.

mod chaplygin_sleigh;
mod ezyroller;
mod ezyroller_driven;
mod kinematic_snake;
mod mechanisms;
pub mod scenes;
mod snake;
mod snakeboard;
mod trailer;

pub use chaplygin_sleigh::ChaplyginSleigh;
use ezy_scene::registry::{InfoOnly, Register};
pub use ezyroller::EzyRoller;
pub use ezyroller_driven::EzyRollerDriven;
pub use kinematic_snake::KinematicSnake;
pub use mechanisms::{DoublePendulum, ElasticFourBar, FourBar, NFourBar, Pendulum, SliderCrank};
pub use snake::{Snake, SnakeDriven, SnakeServo};
pub use snakeboard::Snakeboard;
pub use trailer::Trailer;

/// Registers every built-in vehicle under its key, in the order `ezy
/// list` shows them. Adding a vehicle to the repository is one line here.
pub fn register<R: Register>(r: &mut R) {
    r.register::<EzyRoller>("ezyroller");
    r.register::<EzyRollerDriven>("ezyroller_driven");
    r.register::<ChaplyginSleigh>("chaplygin_sleigh");
    r.register::<Trailer>("trailer");
    r.register::<Snake>("snake");
    r.register::<SnakeDriven>("snake_driven");
    r.register::<SnakeServo>("snake_servo");
    r.register::<KinematicSnake>("kinematic_snake");
    r.register::<Snakeboard>("snakeboard");
    r.register::<FourBar>("four_bar");
    r.register::<ElasticFourBar>("elastic_four_bar");
    r.register::<SliderCrank>("slider_crank");
    r.register::<DoublePendulum>("double_pendulum");
    r.register::<Pendulum>("pendulum");
    r.register::<NFourBar>("n_four_bar");
}

/// The built-in vehicles alone, enough to check the built-in scenes (the
/// `ezy` crate's `App` holds them with everything else a command needs).
pub fn builtins() -> InfoOnly {
    let mut r = InfoOnly::default();
    register(&mut r);
    r
}
