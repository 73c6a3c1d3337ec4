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
//! scene.toml -> Scene::from_toml      (file)    syntax, types, unknown keys, scene parameters
//!            -> Scene::bind_kinds     (bind)    kinds of the user's own (EffectKinds)
//!            -> Scene::with_sets      (bind)    overrides (--set): scene and model parameters,
//!                                               EFFECT.KEY numbers
//!            -> set_counts            (registry) the family counts on the model
//!            -> Scene::checked        (family, check/) families expanded; every name and
//!                                               number against the model, every error:
//!                                               a Checked scene (indices, typed effect
//!                                               specs, drives, events)
//!            -> Checked -> Problem    (problem) no re-check: what needs the model's
//!                                               values (masses, the effects' laws)
//! ```
//!
//! [`Scene::problem`] runs the stages from `with_sets` on. The output's
//! columns are named and filled in one place ([`columns`]); the figures
//! are data ([`view`]).
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
//! Modules: [`schema`] (the document's types, the output groups among
//! them), [`error`] (what is wrong and where), [`file`](mod@file) (text
//! in and out, errors located in it), [`bind`] (scene parameters, `--set`,
//! phase steps), [`family`] (family expansion), [`check`] (one module per
//! section, returning [`Checked`]), [`problem`] (`Checked -> Problem`),
//! [`columns`] (each output group's names and values), [`view`] (figure specs),
//! [`kinds`] (effects as scene files write them; kinds of the user's own),
//! [`parameter`] (a scene's numbers as parameters of its problem),
//! [`registry`] (models by the key scenes name them by), [`files`]
//! (bounded reads of the files a user names).

pub mod bind;
pub mod check;
pub mod columns;
pub mod error;
pub mod family;
pub mod file;
/// Bounded reads of the files a user names: ezy-core's, which reads
/// model files with them.
pub use ezy_core::files;
pub mod kinds;
pub mod parameter;
pub mod problem;
pub mod registry;
pub mod schema;
pub mod units;
pub mod view;

pub use check::{Checked, MAX_COUNT, MAX_FIGURE_NAME, check_count};
pub use columns::RowBuilder;
pub use error::{SceneError, SceneFileError};
pub use file::MAX_SCENE_BYTES;
pub use kinds::{EffectKinds, KindHandle, NAME_KEYS, SceneEffect, UserTable};
pub use schema::{Binding, DriveSpec, InitValue, Initial, IntegratorSettings, OutputGroup, OutputSettings, Scene};
pub use view::{
    Column, DEFAULT_DPI, FigureFormat, FigureSpec, Line, MAX_DPI, MIN_DPI, figure_stem, split_outside_parentheses,
    unbalanced_parentheses,
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
