//! Each output column's unit and meaning, from its name and the model's
//! coordinates (the naming of the command line's trajectory.csv; the
//! guide's reference page "Output columns").

use ezy_core::ModelInfo;

/// `(unit, meaning)` of the column `name` of a run on the model `info`
/// describes; `("", "")` for a name ezy does not write.
pub(crate) fn unit_and_meaning(name: &str, info: &ModelInfo) -> (String, String) {
    let s = |u: &str, m: String| (u.to_string(), m);
    let coords = info.coords.clone();
    let coord = |c: &str| coords.iter().position(|x| x == c);
    // a generalized coordinate, its rate or its acceleration
    let of = |k: usize| {
        let body = info.bodies.iter().find(|b| b.coords.contains(&k));
        let axis = body.and_then(|b| b.coords.iter().position(|&c| c == k)).unwrap_or(k % 3);
        let what = ["x of the centre of mass", "y of the centre of mass", "heading"][axis];
        let body = body.map_or_else(|| format!("body {}", k / 3 + 1), |b| format!("`{}`", b.name));
        (axis == 2, format!("{what} of {body}"))
    };
    if name == "t" {
        return s("s", "time".into());
    }
    if let Some(k) = coord(name) {
        let (angle, m) = of(k);
        return s(if angle { "rad" } else { "m" }, m);
    }
    if let Some(k) = name.strip_suffix("dd").and_then(coord) {
        let (angle, m) = of(k);
        return s(if angle { "rad/s^2" } else { "m/s^2" }, format!("acceleration: {m}"));
    }
    if let Some(k) = name.strip_suffix('d').and_then(coord) {
        let (angle, m) = of(k);
        return s(if angle { "rad/s" } else { "m/s" }, format!("rate: {m}"));
    }
    match name {
        "T" => return s("J", "kinetic energy".into()),
        "W" => return s("J", "work of all applied effects since the start".into()),
        "res_phi" => return s("m", "largest residual of the position constraints phi".into()),
        "res_vel" => return s("m/s", "largest residual of the velocity constraints G qd".into()),
        _ => {}
    }
    if let Some(e) = name.strip_prefix("W_") {
        return s("J", format!("work of `{e}` since the start"));
    }
    if let Some(e) = name.strip_prefix("tau_") {
        return s("N m", format!("torque of `{e}`"));
    }
    if let Some(rest) = name.strip_prefix("F_") {
        let (item, axis) = rest.split_once('.').map_or((rest, None), |(i, a)| (i, Some(a)));
        return match axis {
            Some(a) => s("N", format!("constraint force of `{item}`, {a} component")),
            None => s("N", format!("force of `{item}`")),
        };
    }
    if let Some((point, axis)) = name.rsplit_once('.')
        && info.points.iter().any(|p| p.name == point)
    {
        return match axis {
            "x" | "y" => s("m", format!("{axis} of point {point}")),
            "vx" | "vy" => s("m/s", format!("velocity {} of point {point}", &axis[1..])),
            _ => s("", String::new()),
        };
    }
    s("", String::new())
}
