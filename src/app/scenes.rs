//! The scenes an application knows: by name (the text it was given, or
//! a file read when first needed) or by a file's path, each parsed and
//! checked against its model.

use std::borrow::Cow;
use std::path::{Path, PathBuf};

use ezy_scene::Scene;
use ezy_scene::registry::{SceneSource, check_scene};

use super::{App, AppError};

/// The `name` a scene's text declares, read without parsing it: a
/// top-level line `name = "..."` (a basic string without escapes,
/// perhaps followed by a comment) before the first table header. `None`
/// when the text gives it otherwise; the caller then parses the text.
fn declared_name(text: &str) -> Option<&str> {
    for line in text.lines() {
        let line = line.trim_start();
        if line.starts_with('[') {
            return None;
        }
        let Some(rest) = line.strip_prefix("name").map(str::trim_start).and_then(|r| r.strip_prefix('=')) else {
            continue;
        };
        let rest = rest.trim_start().strip_prefix('"')?;
        let end = rest.find('"')?;
        let (value, after) = (&rest[..end], rest[end + 1..].trim());
        let plain = !value.is_empty() && !value.contains('\\') && (after.is_empty() || after.starts_with('#'));
        return plain.then_some(value);
    }
    None
}

/// A scene the application knows by name: its file as errors name it and
/// its text, or a path read when the scene is first needed.
#[derive(Debug, Clone)]
pub(super) enum SceneEntry {
    Text { file: String, text: Cow<'static, str> },
    Path(PathBuf),
}

/// Why a scene could not be found or loaded.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LoadError {
    /// Neither a known scene name nor a `.toml` file.
    #[error("unknown scene `{name}`; known scenes: {known} (or give a path to a .toml scene file)")]
    Unknown {
        /// What was asked for.
        name: String,
        /// The known names.
        known: String,
    },
    /// A bare name that is both a known scene and a file in the working
    /// directory.
    #[error(
        "`{name}` is both a known scene and a file in the working directory; write `./{name}` for the file or rename it"
    )]
    Ambiguous {
        /// What was asked for.
        name: String,
    },
    /// The application's table is inconsistent (a key or scene name given
    /// twice).
    #[error("{0}")]
    Registry(String),
    /// The file is bad.
    #[error(transparent)]
    File(#[from] ezy_scene::SceneFileError),
}

impl App {
    /// Every known scene, read, parsed and checked against its model, in
    /// the order added.
    ///
    /// # Errors
    /// [`LoadError`]: a table mistake, an unreadable or bad scene file
    /// (file, line, column, key), or two scenes with one name.
    pub fn scenes(&self) -> Result<Vec<SceneSource>, LoadError> {
        self.registry_ok()?;
        let mut out: Vec<SceneSource> = Vec::new();
        for entry in &self.scenes {
            let src = match entry {
                SceneEntry::Text { file, text } => {
                    let scene = Scene::from_toml(text, file)?;
                    check_scene(self, scene, text, file)?
                }
                SceneEntry::Path(path) => self.load_file(path)?,
            };
            if let Some(first) = out.iter().find(|s| s.scene.name == src.scene.name) {
                return Err(LoadError::Registry(format!(
                    "scene `{}` is given twice: in {} and in {}",
                    src.scene.name, first.file, src.file
                )));
            }
            out.push(src);
        }
        Ok(out)
    }

    fn load_file(&self, path: &Path) -> Result<SceneSource, LoadError> {
        let (mut scene, text) = Scene::read(path)?;
        // a model file is named relative to the scene's own file
        if super::is_model_path(&scene.model)
            && Path::new(&scene.model).is_relative()
            && let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty())
        {
            scene.model = dir.join(&scene.model).display().to_string();
        }
        Ok(check_scene(self, scene, &text, &path.display().to_string())?)
    }

    /// A known scene by name, or a scene file by path: a name containing
    /// `/` (or the platform's separator) or ending in `.toml` is a path,
    /// any other name is a known scene. A bare name that is both a known
    /// scene and a file in the working directory is refused as ambiguous.
    ///
    /// # Errors
    /// [`LoadError`]: unknown or ambiguous name, unreadable file, or a bad
    /// scene file with its line, column and key.
    pub fn load_scene(&self, name_or_path: &str) -> Result<SceneSource, LoadError> {
        self.registry_ok()?;
        if is_scene_path(name_or_path) {
            return self.load_file(Path::new(name_or_path));
        }
        if let Some(src) = self.quick_scene(name_or_path)? {
            return Ok(src);
        }
        let all = self.scenes()?;
        let known = all.iter().map(|s| s.scene.name.clone()).collect::<Vec<_>>().join(", ");
        match all.into_iter().find(|s| s.scene.name == name_or_path) {
            Some(_) if Path::new(name_or_path).is_file() => {
                Err(LoadError::Ambiguous { name: name_or_path.to_string() })
            }
            Some(s) => Ok(s),
            None => Err(LoadError::Unknown { name: name_or_path.to_string(), known }),
        }
    }

    /// The known scene `name` with only its own text parsed and checked,
    /// when every scene declares its name plainly ([`declared_name`]) and
    /// the names are distinct; `None` leaves the lookup to
    /// [`App::scenes`], which parses them all (and reports what is wrong
    /// with any). Parsing and checking every built-in scene took most
    /// of a short run's setup.
    fn quick_scene(&self, name: &str) -> Result<Option<SceneSource>, LoadError> {
        let mut found = None;
        let mut names = std::collections::HashSet::new();
        for entry in &self.scenes {
            let SceneEntry::Text { file, text } = entry else { return Ok(None) };
            let Some(declared) = declared_name(text) else { return Ok(None) };
            if !names.insert(declared) {
                return Ok(None);
            }
            if declared == name {
                found = Some((file, text));
            }
        }
        let Some((file, text)) = found else { return Ok(None) };
        if Path::new(name).is_file() {
            return Err(LoadError::Ambiguous { name: name.to_string() });
        }
        let scene = Scene::from_toml(text, file)?;
        if scene.name != name {
            return Ok(None);
        }
        Ok(Some(check_scene(self, scene, text, file)?))
    }

    /// The scene a command names (`given`), or the default scene, loaded;
    /// with the name as given.
    pub(crate) fn named_scene(&self, given: Option<&str>) -> Result<(String, SceneSource), AppError> {
        let name = given.map_or_else(|| self.default_scene.clone(), str::to_string);
        if name.is_empty() {
            return Err(AppError::Failed("no scene given and this program has no default scene".into()));
        }
        let src = self.load_scene(&name).map_err(AppError::failed)?;
        Ok((name, src))
    }
}

/// Whether a scene given on the command line is a file's path rather than
/// a known scene's name: it contains `/` (or the platform's separator) or
/// ends in `.toml` ([`App::load_scene`]).
pub(crate) fn is_scene_path(name: &str) -> bool {
    name.ends_with(".toml") || name.contains('/') || name.contains(std::path::MAIN_SEPARATOR)
}

#[cfg(test)]
mod tests {
    use super::declared_name;

    #[test]
    fn declared_names_are_read_only_when_plain() {
        assert_eq!(declared_name("# c\nname = \"drive\"\nmodel = \"m\"\n"), Some("drive"));
        assert_eq!(declared_name("name=\"a-b\"   # the scene\n[initial]\n"), Some("a-b"));
        assert_eq!(declared_name("model = \"m\"\nnames = 1\nname = \"x\"\n"), Some("x"));
        // anything else is left to the TOML parser
        for text in [
            "[output]\nname = \"x\"\n",
            "name = 'x'\n",
            "name = \"a\\u0041\"\n",
            "name = \"\"\"x\"\"\"\n",
            "name = \"x\" extra\n",
            "name = \"\"\n",
            "model = \"m\"\n",
        ] {
            assert_eq!(declared_name(text), None, "{text}");
        }
    }
}
