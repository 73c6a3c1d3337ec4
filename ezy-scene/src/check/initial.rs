//! `[initial]`: the given coordinates, velocities and starting values, by
//! name (a coordinate, `stem*` for a family's, or `theta_<hinge>` among
//! the positions), each a number or a model parameter's name.

use ezy_core::InitialName;
use ezy_core::model::info::ModelInfo;

use crate::error::{SceneError, known_or_none};
use crate::schema::{InitValue, Initial};

/// Where an initial value's number comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Source {
    /// The number written \[m, rad, m/s, rad/s\].
    Num(f64),
    /// The value of the model parameter of this index, once the scene's
    /// parameters are set.
    Param(usize),
}

/// An initial value as checked: what it gives and where its number comes
/// from.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Given {
    /// The coordinates (or the hinge angle) it gives.
    pub(crate) target: InitialName,
    /// Its number.
    pub(crate) value: Source,
}

/// The checked `[initial]` lists, each in the file's order (a later entry
/// overrides an earlier one).
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct Targets {
    /// Given positions (or hinge angles).
    pub(crate) q: Vec<Given>,
    /// Given velocities.
    pub(crate) qd: Vec<Given>,
    /// Starting values of coordinates the constraints determine.
    pub(crate) guess: Vec<Given>,
}

/// Checks every name of `initial` against the model (a hinge angle only
/// among the positions) and every value (a finite number, or a model
/// parameter's name).
///
/// # Errors
/// The first [`SceneError`], at `initial.GROUP.NAME`.
pub(super) fn check(initial: &Initial, info: &ModelInfo) -> Result<Targets, SceneError> {
    let mut targets = Targets::default();
    let lists = [
        ("q", &initial.q, &mut targets.q),
        ("qd", &initial.qd, &mut targets.qd),
        ("guess", &initial.guess, &mut targets.guess),
    ];
    for (group, list, out) in lists {
        for (name, v) in list {
            let target = match info.initial_name(name) {
                Some(InitialName::HingeAngle(_)) if group != "q" => None,
                target => target,
            };
            let Some(target) = target else {
                let angles = if group == "q" {
                    format!(
                        ", or a hinge angle `theta_<hinge>` (hinges: {})",
                        known_or_none(&info.hinges.iter().map(|h| h.name.as_str()).collect::<Vec<_>>())
                    )
                } else {
                    String::new()
                };
                return Err(SceneError::at(
                    &["initial", group, name],
                    format!(
                        "unknown coordinate `{name}` in model {} (`stem*` names a family's coordinates){angles}; its coordinates: {}",
                        info.name,
                        ezy_core::name_list(&info.coords)
                    ),
                ));
            };
            let value = match v {
                InitValue::Num(x) if !x.is_finite() => {
                    return Err(SceneError::at(&["initial", group, name], format!("{name} = {x} must be finite")));
                }
                InitValue::Num(x) => {
                    info.check_initial(group, &target, name, *x)
                        .map_err(|message| SceneError::at(&["initial", group, name], message))?;
                    Source::Num(*x)
                }
                InitValue::Param(p) => match info.param_index(p) {
                    Some(k) => Source::Param(k),
                    None => {
                        let params: Vec<&str> = info.params.iter().map(|p| p.name).collect();
                        return Err(SceneError::at(
                            &["initial", group, name],
                            format!(
                                "`{p}` is neither a number nor a parameter of model {}; its parameters: {}",
                                info.name,
                                known_or_none(&params)
                            ),
                        ));
                    }
                },
            };
            out.push(Given { target, value });
        }
    }
    Ok(targets)
}
