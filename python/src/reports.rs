//! What `equations` and `check` return: `ezy.Equations` (the text, and the
//! LaTeX Jupyter renders) and `ezy.Check` (passed or not, and the table).

use pyo3::prelude::*;

/// A model's derived equations: `str()` is the text, Jupyter shows the
/// LaTeX (`_repr_latex_`).
#[pyclass(module = "ezy", frozen)]
pub struct Equations {
    /// The plain text `ezy equations` prints.
    #[pyo3(get)]
    pub(crate) text: String,
    /// The whole LaTeX document (`ezy equations --format latex`).
    #[pyo3(get)]
    pub(crate) latex: String,
}

#[pymethods]
impl Equations {
    /// The document's body, for Jupyter (MathJax renders the displayed
    /// equations; the section heading becomes bold text).
    fn _repr_latex_(&self) -> String {
        let body = self
            .latex
            .split_once("\\begin{document}")
            .map_or(self.latex.as_str(), |(_, b)| b)
            .split("\\end{document}")
            .next()
            .unwrap_or_default();
        body.replace("\\section*{", "\\textbf{").trim().to_string()
    }

    fn __str__(&self) -> String {
        self.text.clone()
    }

    fn __repr__(&self) -> String {
        self.text.clone()
    }
}

/// The outcome of `check`: whether every derived term matched its
/// reference, and the table.
#[pyclass(module = "ezy", frozen)]
pub struct Check {
    /// Whether every derived term matched its reference within its tolerance.
    #[pyo3(get)]
    pub(crate) passed: bool,
    /// The table `ezy check` prints.
    #[pyo3(get)]
    pub(crate) table: String,
    /// Why the check failed (empty when it passed).
    #[pyo3(get)]
    pub(crate) message: String,
}

#[pymethods]
impl Check {
    fn __bool__(&self) -> bool {
        self.passed
    }

    fn __repr__(&self) -> String {
        if self.passed { self.table.clone() } else { format!("{}\n{}", self.table, self.message) }
    }
}
