//! Unit suffixes on a scene's numbers (`"180 deg"`, `"200 g"`, `"30
//! rpm"`, `"5 cm"`): converted to SI where the file is read, and the
//! unit's dimension checked against the quantity's (a parameter's
//! declared unit, a coordinate's metre or radian, an effect's key as the
//! effects reference gives it, a drive's radian). A number without a
//! suffix is SI, as always.
//!
//! The table is small and exact: each unit is a ratio `mul / div` of
//! whole numbers times a power of pi to its SI unit, applied as `(value *
//! mul) / div` and then the power of pi, so that `"5 cm"` is the double
//! nearest 0.05 and `"180 deg"` and `"30 rpm"` are `pi` (BIPM, *The International
//! System of Units*, 9th ed., 2019, tables 4 and 8 for the units outside
//! SI in use with it).

use std::f64::consts::PI;

use crate::error::SceneError;

/// A dimension: the exponents of kg, m, s and rad (the radian kept apart,
/// so that an angle is not taken for a pure number).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Dim([i8; 4]);

impl Dim {
    const NONE: Dim = Dim([0; 4]);

    fn mul(self, other: Dim, sign: i8) -> Dim {
        let mut d = self.0;
        d.iter_mut().zip(other.0).for_each(|(a, b)| *a += sign * b);
        Dim(d)
    }

    /// The SI unit of this dimension, as the table writes units: `kg
    /// m^2`, `rad/s^2`, `kg m^2/s rad` (every factor after the `/` in
    /// the denominator).
    pub fn si(self) -> String {
        let names = ["kg", "m", "s", "rad"];
        let side = |sign: i8| -> String {
            let parts: Vec<String> = names
                .iter()
                .zip(self.0)
                .filter(|(_, e)| e.signum() == sign)
                .map(|(n, e)| if e.abs() == 1 { n.to_string() } else { format!("{n}^{}", e.abs()) })
                .collect();
            parts.join(" ")
        };
        match (side(1), side(-1)) {
            (num, den) if num.is_empty() && den.is_empty() => "1 (a pure number)".into(),
            (num, den) if den.is_empty() => num,
            (num, den) if num.is_empty() => format!("1/{den}"),
            (num, den) => format!("{num}/{den}"),
        }
    }
}

/// The units a suffix may name: `(name, mul, div, dimension)`, the unit
/// being `mul / div` of the SI unit of its dimension; a `mul` of
/// [`PI_MUL`] or `2 PI_MUL` stands for pi or 2 pi (applied last).
const UNITS: &[(&str, f64, f64, [i8; 4])] = &[
    ("kg", 1.0, 1.0, [1, 0, 0, 0]),
    ("g", 1.0, 1e3, [1, 0, 0, 0]),
    ("mg", 1.0, 1e6, [1, 0, 0, 0]),
    ("m", 1.0, 1.0, [0, 1, 0, 0]),
    ("km", 1e3, 1.0, [0, 1, 0, 0]),
    ("cm", 1.0, 1e2, [0, 1, 0, 0]),
    ("mm", 1.0, 1e3, [0, 1, 0, 0]),
    ("s", 1.0, 1.0, [0, 0, 1, 0]),
    ("ms", 1.0, 1e3, [0, 0, 1, 0]),
    ("min", 60.0, 1.0, [0, 0, 1, 0]),
    ("h", 3600.0, 1.0, [0, 0, 1, 0]),
    ("rad", 1.0, 1.0, [0, 0, 0, 1]),
    ("deg", PI_MUL, 180.0, [0, 0, 0, 1]),
    ("rev", 2.0 * PI_MUL, 1.0, [0, 0, 0, 1]),
    // turns per minute and per second, as angular rates
    ("rpm", 2.0 * PI_MUL, 60.0, [0, 0, -1, 1]),
    ("Hz", 2.0 * PI_MUL, 1.0, [0, 0, -1, 1]),
    ("N", 1.0, 1.0, [1, 1, -2, 0]),
    ("kN", 1e3, 1.0, [1, 1, -2, 0]),
    ("J", 1.0, 1.0, [1, 2, -2, 0]),
];

/// The `mul` of a unit that is pi times its whole part (a number no
/// other unit's `mul` is divisible by).
const PI_MUL: f64 = 1024.0 * 1024.0 * 1024.0;

/// A unit parsed: `(mul, div, power of pi, dimension)`.
type Parsed = (f64, f64, i32, Dim);

/// Parses a unit as the table writes them: factors separated by spaces or
/// `*`, each a name with an optional integer power (`m^2`, `s^-1`), and
/// every factor after a `/` in the denominator (`N m s/rad`, `m/s^2`,
/// `km/h`).
///
/// # Errors
/// The unknown name, listing the known ones; a malformed power.
pub fn parse_unit(text: &str) -> Result<Parsed, String> {
    let (mut mul, mut div, mut pi, mut dim) = (1.0, 1.0, 0i32, Dim::NONE);
    let mut seen = false;
    for (part, sign) in text.split('/').enumerate().map(|(k, p)| (p, if k == 0 { 1 } else { -1 })) {
        for factor in part.split(|c: char| c.is_whitespace() || c == '*').filter(|f| !f.is_empty()) {
            let (name, power) = match factor.split_once('^') {
                Some((n, p)) => {
                    let p: i8 = p
                        .parse()
                        .ok()
                        .filter(|p: &i8| (-9..=9).contains(p) && *p != 0)
                        .ok_or_else(|| format!("`{factor}`: a power is a whole number from -9 to 9, not 0"))?;
                    (n, p)
                }
                None => (factor, 1),
            };
            let Some(&(_, m, d, base)) = UNITS.iter().find(|u| u.0 == name) else {
                let known: Vec<&str> = UNITS.iter().map(|u| u.0).collect();
                return Err(format!("unknown unit `{name}`; known units: {}", known.join(", ")));
            };
            let p = sign * power;
            let (m, k) = if m >= PI_MUL { (m / PI_MUL, 1) } else { (m, 0) };
            let (m, d) = if p > 0 { (m, d) } else { (d, m) };
            for _ in 0..p.unsigned_abs() {
                mul *= m;
                div *= d;
            }
            pi += k * i32::from(p);
            dim = dim.mul(Dim(base), p);
            seen = true;
        }
    }
    if !seen {
        return Err("no unit after the number".into());
    }
    Ok((mul, div, pi, dim))
}

/// Whether `text` reads as a number with a unit (it starts as a number
/// does) rather than a name.
pub fn looks_like_quantity(text: &str) -> bool {
    text.trim_start().starts_with(|c: char| c.is_ascii_digit() || matches!(c, '+' | '-' | '.'))
}

/// A number with a unit, `"180 deg"`, in SI: `(value, dimension)`.
///
/// # Errors
/// A number that does not parse or is not finite, or a unit as
/// [`parse_unit`].
pub fn parse_quantity(text: &str) -> Result<(f64, Dim), String> {
    let t = text.trim();
    // the number: the longest prefix that parses as one
    let split = (1..=t.len()).rev().filter(|&k| t.is_char_boundary(k)).find(|&k| t[..k].parse::<f64>().is_ok());
    let Some(k) = split else {
        return Err(format!("`{text}` does not start with a number"));
    };
    let (number, unit) = (&t[..k], t[k..].trim());
    // `3e` is not a number; `3 e`... nor `inf`: only finite decimals
    let value: f64 = number.parse().expect("found so");
    if !value.is_finite() || number.chars().any(|c| c.is_ascii_alphabetic() && c != 'e' && c != 'E') {
        return Err(format!("`{text}`: the number must be finite"));
    }
    if unit.is_empty() {
        return Err(format!("`{text}` is a number in a string; write it without quotes, or give a unit (`{t} deg`)"));
    }
    let (mul, div, pi, dim) = parse_unit(unit).map_err(|e| format!("`{text}`: {e}"))?;
    let si = value * mul / div * PI.powi(pi);
    if !si.is_finite() {
        return Err(format!("`{text}` is {si} in SI units"));
    }
    Ok((si, dim))
}

/// The dimension of a declared unit (a parameter's `[kg m^2]`, a key's
/// `[N m/rad]`); `None` where it is not one the table reads (no unit, a
/// pure number, a count).
pub fn declared(unit: &str) -> Option<Dim> {
    let unit = unit.trim();
    if unit.is_empty() {
        return None;
    }
    parse_unit(unit).ok().map(|(.., d)| d)
}

/// Checks a quantity's dimension against the one its place holds: `what`
/// names the place, `unit` its unit as declared (`None`: it declares none).
///
/// # Errors
/// A sentence naming the place, the unit written and the one expected.
pub fn check_fits(written: &str, dim: Dim, what: &str, unit: Option<&str>) -> Result<(), String> {
    match unit.map(|u| (u, declared(u))) {
        Some((_, Some(d))) if d == dim => Ok(()),
        Some((u, Some(d))) => Err(format!(
            "`{written}` does not fit {what}, which is in {u}: its unit is {} where {u} is {}",
            dim.si(),
            d.si()
        )),
        _ => Err(format!("{what} declares no unit, so `{written}` cannot be converted; write the number in SI")),
    }
}

/// The unit of a number inside a waveform of quantity unit `q` (`N m`,
/// `rad`), at `leaf` (the key path inside the waveform, after its kind:
/// `["cos", "amplitude"]`, `["table", "t", "3"]`, `["sum", "0", "linear",
/// "rate"]`): the quantity's for values and amplitudes, `q/s` for rates
/// and slopes, `rad/s` for frequencies, `rad` for phases, `s` for times.
pub fn waveform_unit(q: &str, leaf: &[String]) -> Option<String> {
    let leaf: Vec<&str> = leaf.iter().map(String::as_str).filter(|k| !k.chars().all(|c| c.is_ascii_digit())).collect();
    let last = *leaf.last()?;
    Some(match last {
        "constant" | "amplitude" | "value" => q.to_string(),
        // a quantity already per something has no rate the table writes
        "rate" | "slope_start" | "slope_end" if !q.contains('/') => format!("{q}/s"),
        "omega" => "rad/s".into(),
        "phase" | "phase_step" => "rad".into(),
        "t" => "s".into(),
        _ => return None,
    })
}

/// The unit a built-in effect's key is in, as its entry in the effects
/// reference gives it (`` `stiffness` [N m/rad] ``), and whether the key
/// holds a waveform; `None` for a key without a unit.
pub fn key_unit(keys: &str, key: &str) -> Option<(String, bool)> {
    // the keys are listed as `name` ... [unit]; a unit closes the names
    // before it (`fx`, `fy` (waveforms) [N]); parentheses hold remarks
    let (mut pending, mut wave) = (Vec::new(), false);
    let mut rest = keys;
    let mut depth = 0usize;
    while let Some(c) = rest.chars().next() {
        match c {
            '(' => {
                wave |= depth == 0 && rest.starts_with("(waveform");
                depth += 1;
            }
            ')' => depth = depth.saturating_sub(1),
            '`' if depth == 0 => {
                let end = rest[1..].find('`').map_or(rest.len(), |e| e + 1);
                pending.push(rest[1..end].split([' ', '=']).next().unwrap_or(""));
                rest = &rest[(end + 1).min(rest.len())..];
                continue;
            }
            '[' if depth == 0 => {
                let end = rest.find(']').unwrap_or(rest.len());
                if pending.contains(&key) {
                    return Some((rest[1..end].to_string(), wave));
                }
                (pending, wave) = (Vec::new(), false);
                rest = &rest[(end + 1).min(rest.len())..];
                continue;
            }
            _ => {}
        }
        rest = &rest[c.len_utf8()..];
    }
    None
}

/// Where a scene file wrote a number with a unit: its key path, the text
/// and the unit's dimension (the number itself is in the scene, in SI).
#[derive(Debug, Clone, PartialEq)]
pub struct UnitUse {
    /// Key path from the file's root (`["params", "m1"]`).
    pub path: Vec<String>,
    /// As written: `"200 g"`.
    pub written: String,
    /// Its unit's dimension.
    pub dim: Dim,
}

/// The numbers a file wrote with units: `values`, each key path with its
/// SI value, for the file reader to put in the scene it reads; `uses`, those in `[params]` and
/// `[initial]`, whose units the model gives, for [`check_model_units`].
#[derive(Debug, Default)]
pub(crate) struct Converted {
    pub(crate) values: Vec<(Vec<String>, f64)>,
    pub(crate) uses: Vec<UnitUse>,
}

/// Finds every number written with a unit in `[params]`, `[initial]`,
/// `[effects.NAME]` and `[drives.NAME]`, puts a placeholder in its place
/// and keeps its SI value ([`Converted`]), checking an effect's and a
/// drive's against the unit of its key at once.
///
/// # Errors
/// A [`SceneError`] at the number: a unit unknown, a dimension that does
/// not fit, a key without a unit, a kind of the user's own.
pub(crate) fn convert(root: &mut toml::de::DeTable<'_>) -> Result<Converted, SceneError> {
    use toml::de::DeValue;
    let mut uses = Vec::new();
    let mut values = Vec::new();
    for (section, v) in root.iter_mut() {
        let section = section.get_ref().to_string();
        if !["params", "initial", "effects", "drives"].contains(&section.as_str()) {
            continue;
        }
        let DeValue::Table(items) = v.get_mut() else { continue };
        for (item, v) in items.iter_mut() {
            let item = item.get_ref().to_string();
            // an effect's kind, for its keys' units
            let kind = match v.get_ref() {
                DeValue::Table(t) if section == "effects" => t
                    .iter()
                    .find(|(k, _)| k.get_ref().as_ref() == "kind")
                    .and_then(|(_, v)| v.get_ref().as_str().map(str::to_string)),
                _ => None,
            };
            let mut path = vec![section.clone(), item];
            crate::kinds::number_strings(v, &mut path, section == "effects", &mut |v, path| {
                let Some(written) = v.get_ref().as_str().filter(|t| looks_like_quantity(t)).map(str::to_string) else {
                    return Ok(());
                };
                let at = |message: String| SceneError { path: path.to_vec(), message };
                let (value, dim) = parse_quantity(&written).map_err(at)?;
                *v.get_mut() = toml::de::DeValue::Float(Default::default());
                let written = written.as_str();
                let unit = match path[0].as_str() {
                    "effects" => effect_unit(kind.as_deref(), path)?,
                    "drives" if path.get(2).map(String::as_str) == Some("angle") => waveform_unit("rad", &path[3..]),
                    "drives" => None,
                    _ => {
                        uses.push(UnitUse { path: path.to_vec(), written: written.to_string(), dim });
                        values.push((path.to_vec(), value));
                        return Ok(());
                    }
                };
                let what = format!("`{}`", path[2..].join("."));
                check_fits(written, dim, &what, unit.as_deref()).map_err(at)?;
                values.push((path.to_vec(), value));
                Ok(())
            })?;
        }
    }
    Ok(Converted { values, uses })
}

/// The unit of the number at `path` inside an effect of kind `kind`.
///
/// # Errors
/// A kind of the user's own, whose keys' units ezy does not know.
fn effect_unit(kind: Option<&str>, path: &[String]) -> Result<Option<String>, SceneError> {
    let at = |m: String| SceneError { path: path.to_vec(), message: m };
    let kind = kind.unwrap_or("");
    let Some(r) = ezy_core::effects::REFERENCE.iter().find(|r| r.kind == kind) else {
        return Err(at(format!(
            "effect kind `{kind}` is not built in, so ezy knows no units for its keys; write the number in the unit the kind takes"
        )));
    };
    Ok(match key_unit(r.keys, &path[2]) {
        Some((unit, true)) => waveform_unit(&unit, &path[3..]),
        Some((unit, false)) => Some(unit),
        None => None,
    })
}

/// Checks the units written in `[params]` and `[initial]` against the
/// model: a parameter's declared unit (`/// ... [kg]`), a coordinate's
/// metre or radian (per second among the velocities), a hinge angle's
/// radian.
///
/// # Errors
/// The first use whose dimension does not fit, or whose place declares
/// no unit.
pub(crate) fn check_model_units(uses: &[UnitUse], info: &ezy_core::ModelInfo) -> Result<(), SceneError> {
    for u in uses {
        let at = |m: String| SceneError { path: u.path.clone(), message: m };
        let name = u.path.last().map_or("", String::as_str);
        let (what, unit) = match u.path[0].as_str() {
            "params" => {
                let unit = info.param_index(name).map(|k| info.params[k].unit).filter(|u| !u.is_empty());
                (format!("parameter `{name}`"), unit.map(str::to_string))
            }
            _ => {
                let velocity = u.path.get(1).map(String::as_str) == Some("qd");
                let angle = match info.initial_name(name) {
                    Some(ezy_core::InitialName::HingeAngle(_)) => true,
                    Some(ezy_core::InitialName::Coords(ks)) => ks.first().is_some_and(|&k| info.is_angle(k)),
                    None => continue,
                };
                let unit = match (angle, velocity) {
                    (true, false) => "rad",
                    (false, false) => "m",
                    (true, true) => "rad/s",
                    (false, true) => "m/s",
                };
                (format!("initial `{}`", u.path[1..].join(".")), Some(unit.to_string()))
            }
        };
        check_fits(&u.written, u.dim, &what, unit.as_deref()).map_err(at)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each suffix converts to the double its SI value is, and composite
    /// units read as the table writes them.
    #[test]
    fn suffixes_convert_exactly() {
        let si = |t: &str| parse_quantity(t).unwrap().0;
        assert_eq!(si("180 deg"), PI);
        assert_eq!(si("200 g"), 0.2);
        assert_eq!(si("5 cm"), 0.05);
        assert_eq!(si("30 rpm"), PI);
        assert_eq!(si("0.5 Hz"), PI);
        assert_eq!(si("-90deg"), -PI / 2.0);
        assert_eq!(si("36 km/h"), 10.0);
        assert_eq!(si("1e3 mm"), 1.0);
        assert_eq!(si("250 g cm^2"), 250.0 / 1e7);
        assert_eq!(parse_quantity("2 N m").unwrap().1, declared("kg m^2 s^-2").unwrap());
        assert_eq!(declared("N m s/rad"), declared("kg m^2/s rad"));
        for bad in ["3 furlongs", "deg", "3", "1e400 m", "nan m", "3 m^0"] {
            assert!(parse_quantity(bad).is_err(), "{bad}");
        }
    }

    /// A key's unit is read from the effects reference's list.
    #[test]
    fn key_units_are_read_from_the_reference() {
        let k = "`at` (body or point), `fx`, `fy` (waveforms) [N], `frame` = `world` or `body`";
        assert_eq!(key_unit(k, "fy"), Some(("N".into(), true)));
        assert_eq!(key_unit(k, "frame"), None);
        let k = "`hinge`, `stiffness` [N m/rad], `damping` [N m s/rad] (0), `angle` (waveform) [rad]";
        assert_eq!(key_unit(k, "damping"), Some(("N m s/rad".into(), false)));
        assert_eq!(key_unit(k, "angle"), Some(("rad".into(), true)));
        let k = "`g = [gx, gy]` [m/s^2] (`[0, -9.80665]`), `bodies` (all)";
        assert_eq!(key_unit(k, "g"), Some(("m/s^2".into(), false)));
        assert_eq!(waveform_unit("N m", &["sum".into(), "1".into(), "linear".into(), "rate".into()]).unwrap(), "N m/s");
        assert_eq!(waveform_unit("rad", &["cos".into(), "omega".into()]).unwrap(), "rad/s");
        assert_eq!(declared("N m s/rad").unwrap().si(), "kg m^2/s rad");
        assert_eq!(declared("rpm").unwrap().si(), "rad/s");
        assert_eq!(declared("Hz/rad").unwrap().si(), "1/s");
    }
}
