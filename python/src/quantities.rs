//! What each column of an analysis' tables means, read from the one
//! table of quantities (`ezy_core::quantities`, the guide's Quantities
//! page): `describe()` and `units` of `ezy.Analysis` and `ezy.Geometry`,
//! and `.attrs["units"]`, `.attrs["description"]` of the DataFrames
//! `ezy.sensitivity` and `ezy.optimize` return.

use ezy_core::quantities::{Column, Names, lookup, table};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// The columns of a DataFrame `frame`: its index's name where it has one
/// (`evaluation`), then its columns.
pub(crate) fn columns(frame: &Bound<'_, PyAny>) -> PyResult<Vec<String>> {
    let mut out: Vec<String> =
        frame.getattr("index")?.getattr("name")?.extract::<Option<String>>()?.into_iter().collect();
    out.extend(frame.getattr("columns")?.call_method0("tolist")?.extract::<Vec<String>>()?);
    Ok(out)
}

/// The entry of each column of the table written to `file` (`None` for a
/// column the table lacks). A branch's first column is the parameter it
/// follows.
fn entries(file: &str, columns: &[String]) -> Vec<Option<&'static Column>> {
    let parameters: Vec<String> =
        if file == "branch.csv" { columns.iter().take(1).cloned().collect() } else { Vec::new() };
    let names = Names { parameters: &parameters, ..Names::default() };
    columns.iter().map(|c| lookup(file, c, &names)).collect()
}

/// `{column: unit}` of the table written to `file` with these columns
/// (the unit as the quantities table gives it; "" for a pure number or a
/// column it lacks).
pub(crate) fn units<'py>(py: Python<'py>, file: &str, columns: &[String]) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for (c, e) in columns.iter().zip(entries(file, columns)) {
        d.set_item(c, e.map_or("", |e| e.unit))?;
    }
    Ok(d)
}

/// The text of the table written to `file` with these columns: its file
/// and what a row is, then each column with its unit, meaning, and frame
/// and time, the columns of one entry (a state's, the multipliers' real
/// parts) on one line where the first of them stands.
pub(crate) fn describe(file: &str, columns: &[String]) -> String {
    let mut s = match table(file) {
        Some(t) => format!("{} ({}): {}.\n", t.file, t.command, t.about),
        None => format!("{file}\n"),
    };
    let found = entries(file, columns);
    for (k, entry) in found.iter().enumerate() {
        match entry {
            // listed with the first column of its entry
            Some(_) if found[..k].contains(entry) => {}
            Some(e) => {
                let names: Vec<&str> =
                    columns.iter().zip(&found).filter(|(_, f)| *f == entry).map(|(c, _)| c.as_str()).collect();
                let unit = if e.unit.is_empty() { String::new() } else { format!(" [{}]", e.unit) };
                let frame = if e.frame.is_empty() { String::new() } else { format!(" ({})", e.frame) };
                s.push_str(&format!("  {}{unit}: {}{frame}\n", names.join(", "), e.meaning));
            }
            None => s.push_str(&format!("  {}\n", columns[k])),
        }
    }
    s
}

/// `units` and `describe` of every table in `tables` (`{key: DataFrame}`),
/// the file of key `k` being `file(k)`: `({key: {column: unit}}, text)`.
pub(crate) fn of_tables<'py>(
    py: Python<'py>,
    tables: &Bound<'py, PyDict>,
    file: impl Fn(&str) -> String,
) -> PyResult<(Bound<'py, PyDict>, String)> {
    let all = PyDict::new(py);
    let mut text = Vec::new();
    for (key, frame) in tables.iter() {
        let key: String = key.extract()?;
        let cols = columns(&frame)?;
        let f = file(&key);
        all.set_item(&key, units(py, &f, &cols)?)?;
        text.push(describe(&f, &cols));
    }
    Ok((all, text.join("\n") + "\nEvery column is defined in the guide's Quantities page."))
}

/// Sets `.attrs["units"]` and `.attrs["description"]` of a DataFrame
/// `frame` read from the table written to `file`.
pub(crate) fn annotate(py: Python<'_>, frame: &Bound<'_, PyAny>, file: &str) -> PyResult<()> {
    let cols = columns(frame)?;
    let attrs = frame.getattr("attrs")?;
    attrs.set_item("units", units(py, file, &cols)?)?;
    attrs.set_item("description", describe(file, &cols))?;
    Ok(())
}
