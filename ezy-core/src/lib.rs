#![warn(missing_docs)]
//! ezy runtime: the [`Model`] trait generated models implement, the
//! [`Problem`] a run integrates (a model, its effects, drives, initial
//! values and settings, solved in memory), the KKT solve, the integrators
//! (RK4, DOPRI5, DOP853, RADAU5), coordinate projection, the effects and
//! the force-law traits a user's own laws implement
//! ([`effects::EffectKind`], [`effects::ForceLaw`]), consistent initial
//! conditions and the step loop.

pub mod drive;
pub mod dynamics;
pub mod effects;
mod error;
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
pub use error::{LISTED, MASS_SPREAD_WARNING, SimError, advice, fmt_value, name_list};
pub use integrator::Method;
pub use model::{
    BodyInfo, DriveInfo, EquationExpr, Equations, HingeInfo, InitialName, MinimalLayout, MinimalRhsError, Model,
    ModelInfo, NameIndex, ParamInfo, PointInfo, SkateInfo, SliderInfo,
};
pub use problem::{Problem, Solution};
pub use projection::ProjectionKind;
pub use reduced::Formulation;
pub use scalar::Scalar;
pub use simulate::{Observer, RunError, RunSettings, SINGULAR_PERSIST_STEPS, Sample, Summary, simulate};

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
        ModelInfo, ParamInfo, PointInfo, SkateInfo, SliderInfo, render_equation, unique_names,
    };
    pub use crate::scalar::Scalar;
    pub use ezy_derive::model as model_with_root;
}
