//! The keywords `run` and `sweep` take, turned into what the command
//! line's flags would give: [`Overrides`] (a `Scene` object's sets, then
//! `set=`, `integrator=`, `rtol=`, ...) and the `set={name: value}` dicts.

use ezy::RunOptions;
use ezy_core::{Choice, Formulation, Method, ProjectionKind};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::ezy_err;

/// What `run` and `sweep` take on top of a scene, as the command line's
/// flags would give it.
#[derive(Default)]
pub(crate) struct Overrides {
    sets: Vec<(String, f64)>,
    integrator: Option<String>,
    formulation: Option<String>,
    projection: Option<String>,
    rtol: Option<f64>,
    atol: Option<f64>,
    dt: Option<f64>,
    t_end: Option<f64>,
    every: Option<f64>,
    max_steps: Option<u64>,
    max_output_mb: Option<f64>,
}

impl Overrides {
    /// The keywords `run` and `sweep` take for settings.
    const KEYWORDS: [&str; 11] = [
        "set",
        "integrator",
        "formulation",
        "projection",
        "rtol",
        "atol",
        "dt",
        "t_end",
        "every",
        "max_steps",
        "max_output_mb",
    ];

    /// A `Scene` object's `sets`, then the keywords `settings` of a call
    /// to `function` (their `set` after the object's).
    pub(crate) fn new(
        sets: Vec<(String, f64)>,
        settings: Option<&Bound<'_, PyDict>>,
        function: &str,
    ) -> PyResult<Self> {
        let mut o = Self { sets, ..Self::default() };
        let Some(settings) = settings else { return Ok(o) };
        for (k, v) in settings.iter() {
            let key: String = k.extract()?;
            let bad = |what: &str| PyValueError::new_err(format!("{function}(): `{key}` = {v} is not {what}"));
            // the wrong type: a TypeError naming the keyword and the type given
            let wrong = |what: &str| {
                let ty = v.get_type().name().map_or_else(|_| "?".to_string(), |n| n.to_string());
                pyo3::exceptions::PyTypeError::new_err(format!("{function}(): `{key}` must be {what}, not {ty} ({v})"))
            };
            let number = || {
                if v.is_instance_of::<pyo3::types::PyBool>() {
                    return Err(wrong("a number"));
                }
                v.extract::<f64>().map_err(|_| wrong("a number"))
            };
            let text = || v.extract::<String>().map_err(|_| wrong("a string"));
            match key.as_str() {
                "set" => o.sets.extend(sets_of(Some(v.cast::<PyDict>().map_err(|_| wrong("a dict"))?))?),
                "integrator" => o.integrator = Some(text()?),
                "formulation" => o.formulation = Some(text()?),
                "projection" => o.projection = Some(text()?),
                "rtol" => o.rtol = Some(number()?),
                "atol" => o.atol = Some(number()?),
                "dt" => o.dt = Some(number()?),
                "t_end" => o.t_end = Some(number()?),
                "every" => o.every = Some(number()?),
                "max_steps" => o.max_steps = whole_kw(function, "max_steps", Some(&v))?,
                "max_output_mb" => {
                    let mb = number()?;
                    if !(mb.is_finite() && mb > 0.0) {
                        return Err(bad("a positive number of MB"));
                    }
                    o.max_output_mb = Some(mb);
                }
                _ => {
                    return Err(pyo3::exceptions::PyTypeError::new_err(format!(
                        "{function}() got an unexpected keyword `{key}`; its settings: {}",
                        Self::KEYWORDS.join(", ")
                    )));
                }
            }
        }
        Ok(o)
    }

    /// The run's options, each choice parsed (an unknown one named by its
    /// keyword).
    pub(crate) fn options(&self) -> PyResult<RunOptions> {
        fn choice<T: Choice>(what: &str, v: &Option<String>) -> PyResult<Option<T>> {
            v.as_deref().map(|s| T::parse(s).map_err(|e| ezy_err(format!("{what}={s:?}: {e}")))).transpose()
        }
        Ok(RunOptions {
            sets: self.sets.clone(),
            method: choice::<Method>("integrator", &self.integrator)?,
            formulation: choice::<Formulation>("formulation", &self.formulation)?,
            projection: choice::<ProjectionKind>("projection", &self.projection)?,
            rtol: self.rtol,
            atol: self.atol,
            dt: self.dt,
            t_end: self.t_end,
            every: self.every,
            max_steps: self.max_steps,
            max_output_mb: self.max_output_mb,
            ..RunOptions::default()
        })
    }
}

/// `v` as a number for `what` (a parameter's or keyword's name): a
/// TypeError naming `what` for a bool (`True` is an int to Python, not a
/// value of a parameter) or anything that is not a real number.
pub(crate) fn real(what: &str, v: &Bound<'_, PyAny>) -> PyResult<f64> {
    let wrong = || {
        let ty = v.get_type().name().map_or_else(|_| "?".to_string(), |n| n.to_string());
        pyo3::exceptions::PyTypeError::new_err(format!("{what} must be a number, not {ty} ({v})"))
    };
    if v.is_instance_of::<pyo3::types::PyBool>() {
        return Err(wrong());
    }
    v.extract::<f64>().map_err(|_| wrong())
}

/// The keyword `key` of `function` as a whole number >= 0 (a count, a
/// seed): a TypeError naming it for a bool or anything else.
pub(crate) fn whole_kw(function: &str, key: &str, v: Option<&Bound<'_, PyAny>>) -> PyResult<Option<u64>> {
    let Some(v) = v.filter(|v| !v.is_none()) else { return Ok(None) };
    let wrong = || {
        let ty = v.get_type().name().map_or_else(|_| "?".to_string(), |n| n.to_string());
        pyo3::exceptions::PyTypeError::new_err(format!(
            "{function}(): `{key}` must be a whole number >= 0, not {ty} ({v})"
        ))
    };
    if v.is_instance_of::<pyo3::types::PyBool>() {
        return Err(wrong());
    }
    v.extract::<u64>().map(Some).map_err(|_| wrong())
}

/// `{name: value}` as `(name, value)` pairs, in the dict's order.
///
/// # Errors
/// ValueError for a key that is not a string; TypeError naming the key
/// for a value that is not a number (a bool included).
pub(crate) fn sets_of(set: Option<&Bound<'_, PyDict>>) -> PyResult<Vec<(String, f64)>> {
    let mut out = Vec::new();
    if let Some(d) = set {
        for (k, v) in d.iter() {
            let name: String =
                k.extract().map_err(|_| PyValueError::new_err(format!("set: key {k} is not a string")))?;
            let value = real(&format!("set: `{name}`"), &v)?;
            out.push((name, value));
        }
    }
    Ok(out)
}

/// The keyword `key` of `function` as a number: a TypeError naming the
/// keyword and the type given otherwise (as `run`'s settings).
pub(crate) fn number_kw(function: &str, key: &str, v: Option<&Bound<'_, PyAny>>) -> PyResult<Option<f64>> {
    let Some(v) = v.filter(|v| !v.is_none()) else { return Ok(None) };
    let wrong = || {
        let ty = v.get_type().name().map_or_else(|_| "?".to_string(), |n| n.to_string());
        pyo3::exceptions::PyTypeError::new_err(format!("{function}(): `{key}` must be a number, not {ty} ({v})"))
    };
    if v.is_instance_of::<pyo3::types::PyBool>() {
        return Err(wrong());
    }
    v.extract::<f64>().map(Some).map_err(|_| wrong())
}

/// The keyword `key` of `function` as a string, likewise.
pub(crate) fn text_kw(function: &str, key: &str, v: Option<&Bound<'_, PyAny>>) -> PyResult<Option<String>> {
    let Some(v) = v.filter(|v| !v.is_none()) else { return Ok(None) };
    v.extract::<String>().map(Some).map_err(|_| {
        let ty = v.get_type().name().map_or_else(|_| "?".to_string(), |n| n.to_string());
        pyo3::exceptions::PyTypeError::new_err(format!("{function}(): `{key}` must be a string, not {ty} ({v})"))
    })
}

/// A keyword that names parameters: one name, names separated by commas,
/// or a list of names; `None` when absent; the names joined by commas.
///
/// # Errors
/// `TypeError` naming `function` and `key` for anything else.
pub(crate) fn names_kw(function: &str, key: &str, v: Option<&Bound<'_, PyAny>>) -> PyResult<Option<String>> {
    let Some(v) = v.filter(|v| !v.is_none()) else { return Ok(None) };
    if let Ok(s) = v.extract::<String>() {
        return Ok(Some(s));
    }
    v.extract::<Vec<String>>().map(|names| Some(names.join(","))).map_err(|_| {
        let ty = v.get_type().name().map_or_else(|_| "?".to_string(), |n| n.to_string());
        pyo3::exceptions::PyTypeError::new_err(format!(
            "{function}(): `{key}` must be a parameter's name or a list of names, not {ty} ({v})"
        ))
    })
}

/// `over={name: (lower, upper)}` of `function` (its keyword `key`) as
/// the command line's `--over NAME=LO:HI` arguments.
///
/// # Errors
/// TypeError for a key that is not a name or a value that is not a pair
/// of numbers.
pub(crate) fn over_args(function: &str, key: &str, over: &Bound<'_, PyDict>) -> PyResult<Vec<String>> {
    let type_error = |m: String| pyo3::exceptions::PyTypeError::new_err(m);
    let mut args = Vec::new();
    for (name, bounds) in over.iter() {
        let name: String = name.extract().map_err(|_| type_error(format!("{function}(): `{key}`'s keys are names")))?;
        let pair = || type_error(format!("{function}(): `{key}[{name:?}]` must be a pair (lower, upper)"));
        let (lo, hi): (Bound<'_, PyAny>, Bound<'_, PyAny>) = bounds.extract().map_err(|_| pair())?;
        let what = format!("{function}(): `{key}[{name:?}]`'s bound");
        let (lo, hi) = (real(&what, &lo)?, real(&what, &hi)?);
        args.extend(["--over".to_string(), format!("{name}={lo:?}:{hi:?}")]);
    }
    Ok(args)
}
