#![warn(missing_docs)]
//! ezy runtime: no files, no TOML, no command line.
//!
//! A model (a type the [`model!`] macro generates, implementing [`Model`])
//! gives at any state its mass diagonal, the constraint residual `phi(q)`,
//! the constraint Jacobian `G = [C_q; S]` (nc x nq), the convective term
//! `gamma` and its sparsity pattern. A [`Problem`] holds the model with its
//! parameters, the effects acting on it ([`effects`]: the built-in kinds of
//! [`EffectSpec`], or laws of the user's own through
//! [`effects::EffectKind`] and [`effects::ForceLaw`]), its drives, the
//! initial values given by name (the rest solved for consistency,
//! [`formulation::initial`]) and the settings ([`RunSettings`]). Solving it builds the
//! right-hand side ([`Dynamics`]: the KKT system
//! `[M G^T; G 0] [qdd; lambda] = [f; -gamma]`, [`kkt`], or the reduced
//! formulation, [`formulation::reduced`]) and integrates it ([`integrator`]: RK4,
//! DOPRI5, DOP853, RADAU5) with coordinate projection ([`formulation::projection`]),
//! showing every sample to an [`Observer`] or keeping them in a
//! [`Solution`].
//!
//! ```
//! # ezy_core::model! {
//! #     /// The Chaplygin sleigh.
//! #     pub struct Sleigh {
//! #         param a = 0.5;
//! #         body s(x, y, phi) { mass: 1.0, inertia: 0.1 }
//! #         point P on s at (-a, 0);
//! #         skate P: P along (1, 0);
//! #     }
//! # }
//! # fn main() -> Result<(), ezy_core::SimError> {
//! use ezy_core::{Method, Problem};
//! // the sleigh from 1 m/s and 1 rad/s: the skate turns yaw into forward speed
//! let solution = Problem::new(Sleigh::default())
//!     .q("x", 0.0)?.q("y", 0.0)?.q("phi", 0.0)?
//!     .qd("x", 1.0)?.qd("phi", 1.0)?
//!     .t_end(10.0)
//!     .method(Method::Dop853)
//!     .tolerances(1e-10, 1e-10)
//!     .solve()?;
//! let omega = solution.column("phid").unwrap();
//! assert!(omega.last().unwrap().abs() < 0.1); // the yaw rate decays
//! # Ok(())
//! # }
//! ```
//!
//! Scene files (TOML) are read by the `ezy-scene` crate into a
//! [`Problem`]; the `ezy` crate adds the command line, CSV and figures.
//! The formulation and its sources: `docs/physics.md`.

pub mod analysis;
pub mod design;
pub mod drive;
pub mod effects;
pub mod erased;
pub mod error;
pub mod events;
pub mod files;
pub mod formulation;
pub mod geometry;
pub mod integrator;
pub mod kkt;
pub mod model;
pub mod names;
pub mod plan;
pub mod problem;
pub mod quantities;
pub mod scalar;
pub mod sensitivity;
pub mod settings;
pub mod simulate;
pub mod text;

pub use effects::{Effect, EffectSpec};
pub use erased::AnyModel;
pub use error::{KktError, MASS_SPREAD_WARNING, SetupError, SimError, advice};
pub use events::spec::{Event, EventRecord, EventSpec};
/// The dense linear algebra the analyses' matrices are in ([`analysis::Linearization::a`]).
pub use faer;
pub use formulation::dae::{Baumgarte, Dynamics};
pub use formulation::friction::SkateMode;
pub use model::info::{
    BodyInfo, DerivedParamInfo, DriveInfo, EquationExpr, Equations, HingeInfo, InitialName, MAX_COORDS, MinimalLayout,
    ModelInfo, NameIndex, ParamInfo, PointInfo, SETUP_BYTES_PER_COORD, SkateInfo, SliderInfo,
};
pub use model::{MinimalCall, MinimalRhsError, Model};
pub use names::{LISTED, fmt_located, fmt_value, name_list};
pub use problem::{Problem, Solution};
pub use scalar::Scalar;
pub use settings::{
    Choice, Formulation, MAX_ANGLE, MAX_MAGNITUDE, MAX_RATE, Message, Method, Part, ProjectionKind, RunSettings,
    Setting, Spelling, check_angle, check_magnitude, check_rate,
};
pub use simulate::observer::{Observer, RunError, Sample, Summary};
pub use simulate::run::SINGULAR_PERSIST_STEPS;
pub use simulate::simulate;
pub use simulate::slip::SLIP_CHATTER_GAP;

#[doc = include_str!("../../ezy-derive/src/model.md")]
// A `macro_rules!` wrapper around the procedural macro, passing its
// `$crate` as the path of this crate: the generated code names the runtime
// however the user's crate depends on it (directly, through `ezy`'s
// re-export, renamed). Its examples (ezy-derive/src/model.md) run as
// doctests of this crate, where `ezy_core::model!` resolves.
#[macro_export]
macro_rules! model {
    ($($model:tt)*) => {
        $crate::__private::model_with_root! { @root($crate) $($model)* }
    };
}

/// Paths the generated code uses; not public API.
#[doc(hidden)]
pub mod __private {
    pub use crate::kkt::spd::ldl_solve;
    pub use crate::model::info::{
        BodyInfo, DerivedParamInfo, DriveInfo, EquationExpr, Equations, HingeInfo, Layout, MinimalLayout, ModelInfo,
        ParamInfo, PointInfo, SkateInfo, SliderInfo, check_model_size, render_equation, unique_names,
    };
    pub use crate::model::{MinimalRhsError, Model};
    pub use crate::scalar::Scalar;
    pub use ezy_derive::model as model_with_root;
    /// A model's description (`ezy_lang::description`, written by
    /// `model!` as a `static`) and its rendering at the counts.
    pub mod describe {
        pub use crate::model::describe::{check_counts, equations, info, layout_agrees};
        pub use ezy_lang::description::*;
    }
}
