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
//! [`initial`]) and the settings ([`RunSettings`]). Solving it builds the
//! right-hand side ([`Dynamics`]: the KKT system
//! `[M G^T; G 0] [qdd; lambda] = [f; -gamma]`, [`kkt`], or the reduced
//! formulation, [`reduced`]) and integrates it ([`integrator`]: RK4,
//! DOPRI5, DOP853, RADAU5) with coordinate projection ([`projection`]),
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
pub mod drive;
pub mod dynamics;
pub mod effects;
pub mod erased;
mod error;
pub mod events;
pub mod friction;
pub mod guard;
pub mod initial;
pub mod integrator;
pub mod kkt;
pub mod model;
pub mod newton;
pub mod problem;
pub mod projection;
pub mod reduced;
pub mod scalar;
pub mod simulate;

pub use dynamics::{Baumgarte, Dynamics};
pub use effects::{Effect, EffectSpec};
pub use erased::AnyModel;
pub use error::{
    LISTED, MASS_SPREAD_WARNING, Setting, SimError, advice, fmt_value, name_list, spell_settings_as_flags,
};
pub use events::{Event, EventRecord, EventSpec};
/// The dense linear algebra the analyses' matrices are in ([`analysis::Linearization::a`]).
pub use faer;
pub use friction::SkateMode;
pub use integrator::Method;
pub use model::{
    BodyInfo, DriveInfo, EquationExpr, Equations, HingeInfo, InitialName, MAX_ANGLE, MAX_COORDS, MAX_MAGNITUDE,
    MAX_RATE, MinimalLayout, MinimalRhsError, Model, ModelInfo, NameIndex, ParamInfo, PointInfo, SETUP_BYTES_PER_COORD,
    SkateInfo, SliderInfo, check_angle, check_magnitude, check_rate,
};
pub use problem::{Problem, Solution};
pub use projection::ProjectionKind;
pub use reduced::Formulation;
pub use scalar::Scalar;
pub use simulate::{
    Observer, RunError, RunSettings, SINGULAR_PERSIST_STEPS, SLIP_CHATTER_GAP, Sample, Summary, simulate,
};

/// A setting with a few named values (the integrator, the projection,
/// the formulation): one list that scene files, the command line and
/// reports share. Scene files spell each value by [`Choice::name`]
/// (serde), the command line offers [`Choice::ALL`] with
/// [`Choice::help`].
pub trait Choice: Copy + PartialEq + Send + Sync + 'static {
    /// Every value, in the order help lists them.
    const ALL: &'static [Self];
    /// The value as scene files and the command line spell it.
    fn name(self) -> &'static str;
    /// One line on what it is.
    fn help(self) -> &'static str;
    /// The value spelled `name`.
    ///
    /// # Errors
    /// A message listing the names.
    fn parse(name: &str) -> Result<Self, String> {
        Self::ALL
            .iter()
            .copied()
            .find(|v| v.name() == name)
            .ok_or_else(|| format!("`{name}`: expected one of {}", name_list(Self::ALL.iter().map(|v| v.name()))))
    }
}

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
    pub use crate::model::{
        BodyInfo, DriveInfo, EquationExpr, Equations, HingeInfo, Layout, MinimalLayout, MinimalRhsError, Model,
        ModelInfo, ParamInfo, PointInfo, SkateInfo, SliderInfo, check_model_size, render_equation, unique_names,
    };
    pub use crate::scalar::Scalar;
    pub use ezy_derive::model as model_with_root;
}
