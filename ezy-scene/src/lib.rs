#![warn(missing_docs)]
//! ezy scene files: the TOML document of a run (which model, its
//! parameters, the effects, drives and initial values, the integrator and
//! its settings, the outputs and figures), read with errors that name the
//! file, line, column and key, checked against the model while collecting
//! every error, and turned into the [`ezy_core::Problem`] it describes
//! ([`Scene::problem`]).
//!
//! The runtime (`ezy-core`) knows nothing of files or TOML; this crate is
//! its reader, as a format crate is apart from serde.

pub mod files;
pub mod kinds;
mod problem;
pub mod registry;
pub mod scene;

pub use kinds::{EffectKinds, KindHandle, NAME_KEYS, SceneEffect, UserTable};
pub use scene::{
    Binding, Column, DEFAULT_DPI, DriveSpec, FigureFormat, FigureSpec, InitValue, Initial, IntegratorSettings, Line,
    MAX_DPI, MIN_DPI, OutputGroup, OutputSettings, Scene, SceneError, SceneFileError, figure_stem,
};

#[cfg(test)]
mod tests {
    use ezy_core::Choice;

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
        same_names::<ezy_core::Method>();
        same_names::<ezy_core::ProjectionKind>();
        same_names::<ezy_core::Formulation>();
    }
}
