//! Vehicles written in ezy's model language, one file each, the model
//! registry the CLI reads, and the built-in scenes.

mod chaplygin_sleigh;
mod ezyroller;
mod ezyroller_driven;
pub mod scenes;
mod snake;
mod snakeboard;
mod trailer;

pub use chaplygin_sleigh::ChaplyginSleigh;
use ezy_core::{Model, ModelInfo, ModelVisitor};
pub use ezyroller::EzyRoller;
pub use ezyroller_driven::EzyRollerDriven;
pub use snake::Snake;
pub use snakeboard::Snakeboard;
pub use trailer::Trailer;

/// The keys of the model registry, one per vehicle, in the order `ezy
/// list` shows them.
pub const MODEL_KEYS: &[&str] =
    &["ezyroller", "ezyroller_driven", "chaplygin_sleigh", "trailer", "snake", "snakeboard"];

/// The registry with each model's description at its default counts.
pub fn models() -> Vec<(&'static str, ModelInfo)> {
    MODEL_KEYS.iter().map(|&k| (k, visit(k, DefaultInfo).expect("registered"))).collect()
}

struct DefaultInfo;
impl ModelVisitor for DefaultInfo {
    type Output = ModelInfo;
    fn visit<M: Model + Default>(self) -> ModelInfo {
        M::default().info()
    }
}

/// Runs `visitor` with the model registered as `key`; `None` if unknown.
pub fn visit<V: ModelVisitor>(key: &str, visitor: V) -> Option<V::Output> {
    match key {
        "ezyroller" => Some(visitor.visit::<EzyRoller>()),
        "ezyroller_driven" => Some(visitor.visit::<EzyRollerDriven>()),
        "chaplygin_sleigh" => Some(visitor.visit::<ChaplyginSleigh>()),
        "trailer" => Some(visitor.visit::<Trailer>()),
        "snake" => Some(visitor.visit::<Snake>()),
        "snakeboard" => Some(visitor.visit::<Snakeboard>()),
        _ => None,
    }
}
