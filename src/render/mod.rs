//! What a command draws: charts and heat maps as SVG, PNG or PDF
//! ([`plot`]), a scene's figures from its trajectory table ([`figures`]),
//! a height function's heat map over two shape coordinates (`height_map`),
//! the bodies moving as an animated GIF (`animation`) and a run's
//! self-contained `report.html` (`report`).
//!
//! This layer sees the trajectory table ([`crate::output`]), the scene
//! and the model, never the command line, the commands or the run
//! session: what it draws is given to it.

pub(crate) mod animation;
pub mod figures;
pub(crate) mod height_map;
pub mod plot;
pub(crate) mod report;
