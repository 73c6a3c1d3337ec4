#![warn(missing_docs)]
//! ezy runtime: the [`Model`] trait generated models implement, the
//! [`Problem`] a run integrates (a model, its effects, drives, initial
//! values and settings, solved in memory), the KKT solve, the integrators
//! (RK4, DOPRI5, DOP853, RADAU5), coordinate projection, the effects and
//! the force-law traits a user's own laws implement
//! ([`effects::EffectKind`], [`effects::ForceLaw`]), consistent initial
//! conditions and the step loop.

// `::ezy_core` paths of `model!` expansions resolve inside this crate too.
extern crate self as ezy_core;

pub mod drive;
pub mod dynamics;
pub mod effects;
mod error;
pub mod files;
pub mod guard;
pub mod initial;
pub mod integrator;
pub mod kkt;
pub mod model;
pub mod newton;
pub mod problem;
pub mod projection;
pub mod reduced;
pub mod registry;
pub mod scalar;
pub mod scene;
pub mod simulate;

pub use dynamics::{Baumgarte, Dynamics};
pub use effects::{Effect, EffectSpec};
pub use error::{LISTED, MASS_SPREAD_WARNING, SimError, advice, fmt_value, name_list};
pub use ezy_derive::model;
pub use integrator::Method;
pub use model::{
    BodyInfo, DriveInfo, EquationExpr, Equations, HingeInfo, MinimalLayout, MinimalRhsError, Model, ModelInfo,
    NameIndex, ParamInfo, PointInfo, SkateInfo, SliderInfo,
};
pub use problem::{Problem, Solution};
pub use projection::ProjectionKind;
pub use reduced::Formulation;
pub use scalar::Scalar;
pub use scene::{
    Binding, Column, DEFAULT_DPI, DriveSpec, FigureFormat, FigureSpec, InitValue, Initial, InitialName,
    IntegratorSettings, Line, MAX_DPI, MIN_DPI, OutputGroup, OutputSettings, Scene, SceneError, SceneFileError,
    figure_stem,
};
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

/// The examples of the `model!` documentation (ezy-derive/src/model.md,
/// shown at [`model!`]), run as doctests of this crate, where
/// `ezy_core::model!` resolves: ezy-derive cannot depend on ezy-core.
#[cfg(doctest)]
#[doc = include_str!("../../ezy-derive/src/model.md")]
pub struct ModelDocExamples;

/// Paths the generated code uses; not public API.
#[doc(hidden)]
pub mod __private {
    pub use crate::kkt::spd::ldl_solve;
    pub use crate::model::{
        BodyInfo, DriveInfo, EquationExpr, Equations, HingeInfo, Layout, MinimalLayout, MinimalRhsError, Model,
        ModelInfo, ParamInfo, PointInfo, SkateInfo, SliderInfo, render_equation, unique_names,
    };
    pub use crate::scalar::Scalar;
}

#[cfg(test)]
mod tests {
    use super::Choice;

    /// Scene files (serde) and the command line ([`Choice::name`]) spell
    /// every value alike, and each name parses back to its value.
    fn same_names<T: Choice + serde::Serialize + std::fmt::Debug>() {
        for &v in T::ALL {
            let serde_name = toml::Value::try_from(v).expect("a unit variant serializes");
            assert_eq!(serde_name.as_str(), Some(v.name()), "{v:?}");
            assert_eq!(T::parse(v.name()), Ok(v));
            assert!(!v.help().is_empty());
        }
        assert!(T::parse("no-such").unwrap_err().contains(T::ALL[0].name()));
    }

    #[test]
    fn choices_have_one_name_each() {
        same_names::<crate::Method>();
        same_names::<crate::ProjectionKind>();
        same_names::<crate::Formulation>();
    }
}
