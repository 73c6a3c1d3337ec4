//! Scenes made in Python: a scene file's text with the model a call names,
//! or a scene file's keys given as keywords, as TOML text (what
//! `ezy_scene::Scene::from_toml` reads, so every key is checked and
//! every message is the scene file's).

use std::path::Path;

use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use toml::{Table, Value};

/// `text` with its `model` set to `key` (if given) and a relative `.ezy`
/// model path made absolute (from the working directory); the text as
/// it is where nothing changes or it is not TOML (its own error follows,
/// located in it).
pub(crate) fn with_model(text: &str, key: Option<&str>) -> PyResult<String> {
    let Ok(mut table) = text.parse::<Table>() else { return Ok(text.to_string()) };
    if !set_model(&mut table, key) {
        return Ok(text.to_string());
    }
    toml::to_string(&table).map_err(|e| PyTypeError::new_err(format!("scene(): {e}")))
}

/// The scene file the keywords `keys` write (`name` "python" and a
/// `description` unless given), its `model` `key` if given.
pub(crate) fn from_keys(keys: &Bound<'_, PyDict>, key: Option<&str>) -> PyResult<String> {
    let Value::Table(mut table) = value_of(keys.as_any(), "")? else { unreachable!("a dict is a table") };
    table.entry("name").or_insert_with(|| Value::String("python".into()));
    table.entry("description").or_insert_with(|| Value::String("a scene made in Python".into()));
    set_model(&mut table, key);
    toml::to_string(&table).map_err(|e| PyTypeError::new_err(format!("scene(): {e}")))
}

/// Sets `model` to `key` and makes a relative `.ezy` path absolute;
/// whether anything changed.
fn set_model(table: &mut Table, key: Option<&str>) -> bool {
    let mut changed = false;
    if let Some(k) = key
        && table.get("model").and_then(Value::as_str) != Some(k)
    {
        table.insert("model".into(), Value::String(k.to_string()));
        changed = true;
    }
    if let Some(m) = table.get("model").and_then(Value::as_str)
        && m.ends_with(".ezy")
        && Path::new(m).is_relative()
        && let Ok(cwd) = std::env::current_dir()
    {
        let abs = cwd.join(m).display().to_string();
        table.insert("model".into(), Value::String(abs));
        changed = true;
    }
    changed
}

/// A Python value as a TOML value: dicts (string keys), lists and tuples,
/// strings, booleans, whole numbers and floats (NumPy's too); `at` names
/// where it sits, for the error.
fn value_of(v: &Bound<'_, PyAny>, at: &str) -> PyResult<Value> {
    let here = |k: &str| if at.is_empty() { k.to_string() } else { format!("{at}.{k}") };
    if v.is_instance_of::<PyBool>() {
        return Ok(Value::Boolean(v.extract()?));
    }
    if v.is_instance_of::<PyInt>() {
        return v.extract::<i64>().map(Value::Integer).or_else(|_| Ok(Value::Float(v.extract::<f64>()?)));
    }
    if v.is_instance_of::<PyFloat>() {
        return Ok(Value::Float(v.extract()?));
    }
    if v.is_instance_of::<PyString>() {
        return Ok(Value::String(v.extract()?));
    }
    if let Ok(d) = v.cast::<PyDict>() {
        let mut t = Table::new();
        for (k, x) in d.iter() {
            let k: String = k.extract().map_err(|_| {
                PyTypeError::new_err(format!(
                    "scene(): a key of `{}` is not a string: {k}",
                    if at.is_empty() { "the scene" } else { at }
                ))
            })?;
            let value = value_of(&x, &here(&k))?;
            t.insert(k, value);
        }
        return Ok(Value::Table(t));
    }
    if v.is_instance_of::<PyList>() || v.is_instance_of::<PyTuple>() {
        let items: Vec<Bound<'_, PyAny>> = v.try_iter()?.collect::<PyResult<_>>()?;
        let values =
            items.iter().enumerate().map(|(i, x)| value_of(x, &format!("{at}[{i}]"))).collect::<PyResult<_>>()?;
        return Ok(Value::Array(values));
    }
    // a NumPy number, or anything else that is a float
    if let Ok(x) = v.extract::<f64>() {
        return Ok(Value::Float(x));
    }
    let ty = v.get_type().name().map_or_else(|_| "?".to_string(), |n| n.to_string());
    Err(PyTypeError::new_err(format!("scene(): `{at}` must be a number, string, boolean, list or dict, not {ty}")))
}
