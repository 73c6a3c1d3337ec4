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
//!
//! ```text
//! scene.toml -> Scene::from_toml   syntax, types, unknown keys, scene parameters
//!            -> Scene::bind_kinds  kinds of the user's own (EffectKinds)
//!            -> Scene::check_all   every name and number against the model, every error
//!            -> Scene::problem     overrides (--set), family counts and expansion,
//!                                  effects resolved: an ezy_core::Problem
//! ```
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
//! use ezy_scene::Scene;
//! let text = r#"
//!     name = "glide"
//!     description = "The sleigh from 1 m/s and 1 rad/s"
//!     model = "sleigh"
//!     t_end = 2.0
//!     [initial]
//!     q = { x = 0.0, y = 0.0, phi = 0.0 }
//!     qd = { x = 1.0, phi = 1.0 }
//! "#;
//! let scene = Scene::from_toml(text, "glide.toml").unwrap();
//! let (problem, _as_run) = scene.problem::<Sleigh>(&[("a".into(), 0.4)]).unwrap();
//! let solution = problem.solve().unwrap();
//! assert_eq!(solution.t.last(), Some(&2.0));
//!
//! // a mistake is reported at its place in the file
//! let bad = Scene::from_toml(&text.replace("t_end = 2.0", "t_end = \"two\""), "glide.toml");
//! assert!(bad.unwrap_err().to_string().starts_with("glide.toml:5:"), "the line of `t_end`");
//! ```
//!
//! Modules: [`scene`] (the document, its check, `--set`, families),
//! [`kinds`] (effects as scene files write them; kinds of the user's own),
//! [`registry`] (models by the key scenes name them by), [`files`]
//! (bounded reads of the files a user names).

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
