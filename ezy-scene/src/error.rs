//! What is wrong with a scene, and where: a [`SceneError`] (a key path
//! and a message) that a stage after the reading finds, and the
//! [`SceneFileError`] that places a mistake in its file; how an error
//! lists the names it knows (`known_or_none`).

/// A semantic error in a scene: the key path (`["effects", "motor",
/// "hinge"]`) and what is wrong.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SceneError {
    /// Path of the offending key from the file's root; array entries by index.
    pub path: Vec<String>,
    /// What is wrong and what was expected.
    pub message: String,
}

impl SceneError {
    /// The error at the key path `path` (array entries by index).
    pub(crate) fn at(path: &[&str], message: impl Into<String>) -> Self {
        Self { path: path.iter().map(|s| s.to_string()).collect(), message: message.into() }
    }
    /// The path written as TOML would (`effects.motor.hinge`, `figures[2].lines[0].y`).
    pub fn key(&self) -> String {
        let mut out = String::new();
        for p in &self.path {
            if p.parse::<usize>().is_ok() {
                out.push_str(&format!("[{p}]"));
            } else {
                if !out.is_empty() {
                    out.push('.');
                }
                out.push_str(p);
            }
        }
        out
    }
}

/// A scene file that cannot be used: where and why.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{}", self.render())]
pub struct SceneFileError {
    /// The file (or `<builtin NAME>`).
    pub file: String,
    /// Line, from 1 (0: the file as a whole, e.g. it cannot be read).
    pub line: usize,
    /// Column, from 1.
    pub column: usize,
    /// The key at fault, when known.
    pub key: Option<String>,
    /// What is wrong and what was expected.
    pub message: String,
    /// Further mistakes the same check found in other parts of the file
    /// ([`Scene::check_all`](crate::schema::Scene::check_all)), each shown on a line of its own.
    pub also: Vec<SceneFileError>,
}

impl SceneFileError {
    /// `FILE:LINE:COLUMN: `KEY`: MESSAGE`, or `FILE: MESSAGE` for the file
    /// as a whole; then each of [`SceneFileError::also`] on its own line.
    fn render(&self) -> String {
        let key = self.key.as_ref().map(|k| format!("`{k}`: ")).unwrap_or_default();
        let mut out = if self.line == 0 {
            format!("{}: {key}{}", self.file, self.message)
        } else {
            format!("{}:{}:{}: {key}{}", self.file, self.line, self.column, self.message)
        };
        for e in &self.also {
            out.push('\n');
            out.push_str(&e.render());
        }
        out
    }

    /// The first of `errors` with the others as [`SceneFileError::also`]
    /// (`None` for none).
    pub fn collect(errors: impl IntoIterator<Item = SceneFileError>) -> Option<SceneFileError> {
        let mut errors = errors.into_iter();
        let mut first = errors.next()?;
        first.also.extend(errors);
        Some(first)
    }
}

/// `names` as an error lists them, or `none`.
pub(crate) fn known_or_none(names: &[&str]) -> String {
    if names.is_empty() { "none".to_string() } else { ezy_core::name_list(names) }
}
