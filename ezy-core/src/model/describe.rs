//! What a model says about itself at its current counts, rendered from
//! its [`Description`]: its [`ModelInfo`], its equations as text and
//! LaTeX, and whether the counts give a well-formed model. The one writer
//! of these names, orders and messages, for a compiled model (`model!`
//! writes its description as a `static` and calls [`info`],
//! [`check_counts`] and [`equations`]) and for a model read from text.

use std::borrow::Cow;

use ezy_lang::description::{Description, Group, Item, Ix, Template, Text};

use super::info::{
    BodyInfo, DerivedParamInfo, DriveInfo, EquationExpr, Equations, HingeInfo, ModelInfo, ParamInfo, PointInfo,
    SkateInfo, SliderInfo, check_model_size, render_equation, unique_names,
};
use super::layout::Layout;

/// A generated model's [`ModelInfo`] at `counts` (its counts' values, in
/// declaration order).
#[doc(hidden)]
pub fn info(desc: &Description, counts: &[i64]) -> ModelInfo {
    info_at(desc, &Layout::new(desc, counts))
}

/// A generated model's `check_counts` at `counts`; `direction(group, v)`
/// is the direction as written `(tx, ty)` of group `group` (an index into
/// [`Description::groups`]) at loop value `v`, asked of the groups whose
/// [`Group::direction`] is set.
///
/// # Errors
/// The first failure, in [`check_counts_at`]'s words.
#[doc(hidden)]
pub fn check_counts(
    desc: &Description,
    counts: &[i64],
    direction: &mut dyn FnMut(usize, i64) -> [f64; 2],
) -> Result<(), String> {
    check_counts_at(desc, &Layout::new(desc, counts), direction)
}

/// A generated model's equations at `counts`, rendered with its
/// coordinates' and parameters' names.
#[doc(hidden)]
pub fn equations(desc: &Description, counts: &[i64]) -> Equations {
    equations_at(desc, &Layout::new(desc, counts))
}

/// Whether `generated`, a compiled model's `__ezy_layout` at `counts`, is
/// the layout of its description there (a test's check: the numeric
/// functions' offsets and the description's are written apart).
///
/// # Errors
/// The first field that differs.
#[doc(hidden)]
pub fn layout_agrees<const NF: usize, const NB: usize, const NP: usize, const NG: usize>(
    desc: &Description,
    counts: &[i64],
    generated: &super::info::Layout<NF, NB, NP, NG>,
) -> Result<(), String> {
    Layout::new(desc, counts).agrees(generated)
}

/// An interned name that lives as long as the program: [`ParamInfo`] and
/// [`ModelInfo`] hold `&'static str` (a compiled model's names are
/// literals, borrowed as they are). Each distinct name is stored once,
/// however many models are read.
pub(crate) fn intern(s: &Text) -> &'static str {
    use std::collections::HashSet;
    use std::sync::{Mutex, OnceLock};
    static NAMES: OnceLock<Mutex<HashSet<&'static str>>> = OnceLock::new();
    let s: &str = match *s {
        Cow::Borrowed(s) => return s,
        Cow::Owned(ref s) => s,
    };
    let mut names = NAMES.get_or_init(Default::default).lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    if let Some(&n) = names.get(s) {
        return n;
    }
    let n: &'static str = Box::leak(s.to_owned().into_boxed_str());
    names.insert(n);
    n
}

/// The parameters' descriptions: the reals, then the counts.
pub(crate) fn param_infos(desc: &Description) -> Vec<ParamInfo> {
    desc.params
        .iter()
        .map(|p| ParamInfo {
            name: intern(&p.name),
            default: p.default,
            unit: intern(&p.unit),
            doc: intern(&p.doc),
            count: p.count,
        })
        .collect()
}

/// The [`DerivedParamInfo`] of each parameter the model defines by an
/// expression.
pub(crate) fn derived_infos(desc: &Description) -> Vec<DerivedParamInfo> {
    desc.derived
        .iter()
        .map(|d| DerivedParamInfo {
            name: intern(&d.name),
            formula: intern(&d.formula),
            unit: intern(&d.unit),
            doc: intern(&d.doc),
        })
        .collect()
}

/// The name of an item's element: the item's name, and a family
/// element's index after it (`link3`).
fn element(name: &str, family: Option<usize>, v: i64) -> String {
    match family {
        Some(_) => format!("{name}{v}"),
        None => name.to_string(),
    }
}

/// The columns of `q` of a group's slots at loop value `v`.
fn columns(desc: &Description, l: &Layout, g: &Group, v: i64) -> Vec<usize> {
    g.slots.iter().map(|s| l.body_column(desc, s, v)).collect()
}

/// The [`ModelInfo`] at the layout's counts.
pub(crate) fn info_at(desc: &Description, l: &Layout) -> ModelInfo {
    let mut info = ModelInfo {
        name: intern(&desc.name),
        doc: intern(&desc.doc),
        coords: Vec::with_capacity(l.nq),
        params: param_infos(desc),
        derived: derived_infos(desc),
        bodies: Vec::with_capacity(l.n_bodies),
        points: Vec::with_capacity(l.n_points),
        hinges: Vec::new(),
        sliders: Vec::new(),
        drives: Vec::new(),
        skates: Vec::new(),
        constraints: Vec::with_capacity(l.nc),
        n_holonomic: l.nh,
        pattern: Vec::with_capacity(l.nnz),
    };
    for (bi, b) in desc.bodies.iter().enumerate() {
        let (mass_param, inertia_param) = (b.mass_param.as_ref().map(intern), b.inertia_param.as_ref().map(intern));
        for (e, v) in l.elements(b.family) {
            let k = l.body_off[bi] + 3 * e;
            info.coords.extend(b.coords.iter().map(|c| element(c, b.family, v)));
            info.bodies.push(BodyInfo {
                name: element(&b.name, b.family, v),
                coords: [k, k + 1, k + 2],
                mass_param,
                inertia_param,
            });
        }
    }
    for p in desc.points.iter() {
        for (_, v) in l.elements(p.family) {
            info.points.push(PointInfo { name: element(&p.name, p.family, v), body: l.body_index(desc, &p.body, v) });
        }
    }
    for (gi, g) in desc.groups.iter().enumerate() {
        for (e, v) in l.elements(g.family) {
            let rb = l.row[gi] + e * g.rows;
            let name = element(&g.name, g.family, v);
            let slot = |s: usize| g.slots.get(s).map(|b| l.body_index(desc, b, v));
            match &g.item {
                Item::Hinge { point, .. } => info.hinges.push(HingeInfo {
                    name: name.clone(),
                    body_a: slot(0).expect("a hinge has a body"),
                    body_b: slot(1),
                    row: rb,
                    point: l.point_index(desc, point, v),
                }),
                Item::Slider { heading, .. } => info.sliders.push(SliderInfo {
                    name: name.clone(),
                    body_a: slot(1),
                    body_b: slot(0).expect("a slider has a body"),
                    row: rb,
                    heading: *heading,
                }),
                Item::Drive { hinge_group } => {
                    info.drives.push(DriveInfo { name: name.clone(), hinge: l.item_index[*hinge_group] + e, row: rb });
                }
                Item::Skate { point } => {
                    info.skates.push(SkateInfo { name: name.clone(), point: l.point_index(desc, point, v), row: rb });
                }
            }
            info.constraints.extend(g.suffixes.iter().map(|s| format!("{name}{s}")));
            let cols = columns(desc, l, g, v);
            info.pattern.extend(g.pattern.iter().map(|&(r, c)| (rb + r, cols[c / 3] + c % 3)));
        }
    }
    info
}

/// Whether the counts give a well-formed model, in this order: every
/// count at least 1, the model's size within [`check_model_size`], every
/// family reference of a point or a constraint item inside the family it
/// names, every direction that names a family index not zero at any
/// element (`direction`, as [`check_counts`] takes it), joints between
/// distinct bodies, unique names ([`unique_names`]).
///
/// # Errors
/// The first failure, naming the item's element and the reference.
pub(crate) fn check_counts_at(
    desc: &Description,
    l: &Layout,
    direction: &mut dyn FnMut(usize, i64) -> [f64; 2],
) -> Result<(), String> {
    let counts: Vec<(&str, usize)> =
        desc.params.iter().filter(|p| p.count).zip(&l.counts).map(|(c, &v)| (&*c.name, v as usize)).collect();
    for (&(name, _), &value) in counts.iter().zip(&l.counts) {
        if value < 1 {
            return Err(format!("count `{name}` is 0; it must be at least 1"));
        }
    }
    if !counts.is_empty() {
        check_model_size(l.nq, &counts)?;
    }
    for p in desc.points.iter() {
        let body = &desc.bodies[p.body.item];
        let (Some(fb), Some(ix)) = (body.family, &p.body.index) else { continue };
        for (_, v) in l.elements(p.family) {
            in_range(desc, l, fb, ix, v, &format!("point `{}`", element(&p.name, p.family, v)), &body.name)?;
        }
    }
    for (gi, g) in desc.groups.iter().enumerate() {
        for (_, v) in l.elements(g.family) {
            check_element(desc, l, gi, v, direction)?;
        }
    }
    unique_names(&info_at(desc, l))
}

/// Whether element `ix` (at loop value `v`) of family `f` exists, else a
/// message naming `owner` and `what` it refers to.
fn in_range(desc: &Description, l: &Layout, f: usize, ix: &Ix, v: i64, owner: &str, what: &str) -> Result<(), String> {
    let value = ix.at(v, &l.counts);
    let (start, len) = (l.f_start[f], l.f_len[f] as i64);
    if value < start || value >= start + len {
        let range = &desc.families[f].range;
        let shown = &ix.shown;
        return Err(format!(
            "{owner} refers to {what}[{shown}] = {what}{value}, which does not exist: {what} has elements {start}..{} ({range})",
            start + len
        ));
    }
    Ok(())
}

/// [`check_counts_at`] for one element of constraint item `gi`: its
/// references inside their families, its direction not zero, two
/// distinct bodies.
fn check_element(
    desc: &Description,
    l: &Layout,
    gi: usize,
    v: i64,
    direction: &mut dyn FnMut(usize, i64) -> [f64; 2],
) -> Result<(), String> {
    let g = &desc.groups[gi];
    let owner = format!("{} `{}`", g.item.word(), element(&g.name, g.family, v));
    let refs = match &g.item {
        Item::Hinge { point, other } | Item::Slider { point, other, .. } => {
            std::iter::once(point).chain(other).collect()
        }
        Item::Skate { point } => vec![point],
        Item::Drive { .. } => Vec::new(),
    };
    for r in refs {
        let p = &desc.points[r.item];
        if let (Some(fp), Some(ix)) = (p.family, &r.index) {
            in_range(desc, l, fp, ix, v, &owner, &p.name)?;
        }
    }
    for b in g.slots.iter() {
        let body = &desc.bodies[b.item];
        if let (Some(fb), Some(ix)) = (body.family, &b.index) {
            in_range(desc, l, fb, ix, v, &owner, &body.name)?;
        }
    }
    if let Some(written) = &g.direction {
        let [tx, ty] = direction(gi, v);
        let n2 = tx * tx + ty * ty;
        if !(n2 > 0.0 && n2.is_finite()) {
            return Err(format!(
                "{owner} has its {written} = ({tx}, {ty}) at this element and these parameters: not a direction; give one that is not zero at any element"
            ));
        }
    }
    if g.slots.len() == 2
        && !matches!(g.item, Item::Drive { .. })
        && l.body_index(desc, &g.slots[0], v) == l.body_index(desc, &g.slots[1], v)
    {
        return Err(format!("{owner} joins two points of the same body"));
    }
    Ok(())
}

/// A template rendered at an element: where it names one family index
/// and that index is 0, 1 or -1 there, its form simplified at that value;
/// else the element's index values put in (a negative one in
/// parentheses).
fn render(t: &Template, indices: &[Ix], v: i64, counts: &[i64], names: &[&str], params: &[&str]) -> EquationExpr {
    if let ([k], [at0, at1, atm1]) = (&t.named[..], &t.at[..]) {
        let (text, latex) = match indices[*k].at(v, counts) {
            0 => at0,
            1 => at1,
            -1 => atm1,
            _ => return substituted(t, indices, v, counts, names, params),
        };
        return render_equation(text, latex, names, params);
    }
    substituted(t, indices, v, counts, names, params)
}

/// [`render`] with the index values put in.
fn substituted(t: &Template, indices: &[Ix], v: i64, counts: &[i64], names: &[&str], params: &[&str]) -> EquationExpr {
    if t.named.is_empty() {
        return render_equation(&t.text, &t.latex, names, params);
    }
    let (mut text, mut latex) = (t.text.to_string(), t.latex.to_string());
    for &k in t.named.iter() {
        let n = indices[k].at(v, counts);
        let n = if n < 0 { format!("({n})") } else { n.to_string() };
        let m = ezy_lang::index_marker(k);
        (text, latex) = (text.replace(&m, &n), latex.replace(&m, &n));
    }
    render_equation(&text, &latex, names, params)
}

/// The derived equations at the layout's counts, rendered with the
/// coordinates' and parameters' names.
pub(crate) fn equations_at(desc: &Description, l: &Layout) -> Equations {
    let info = info_at(desc, l);
    let params: Vec<&str> = desc.params.iter().filter(|p| !p.count).map(|p| &*p.name).collect();
    let params = &params[..];
    let counts = &l.counts;
    let mut eq = Equations {
        coords: info
            .coords
            .iter()
            .map(|c| render_equation("\u{1}q0\u{2}", "\u{1}q0\u{2}", &[c.as_str()], &[]))
            .collect(),
        ..Equations::default()
    };
    let own = std::slice::from_ref(&desc.own);
    for b in desc.bodies.iter() {
        for (_, v) in l.elements(b.family) {
            eq.mass.extend(b.mass.iter().map(|m| render(m, own, v, counts, &[], params)));
        }
    }
    let coords = &info.coords;
    let names_at = |cols: &[usize]| -> Vec<&str> {
        cols.iter().flat_map(|&c| (0..3).map(move |o| coords[c + o].as_str())).collect()
    };
    for g in desc.groups.iter() {
        if g.slots.is_empty() {
            continue;
        }
        for (_, v) in l.elements(g.family) {
            let names = names_at(&columns(desc, l, g, v));
            let ix = &g.indices[..];
            let each = |ts: &[Template]| -> Vec<EquationExpr> {
                ts.iter().map(|t| render(t, ix, v, counts, &names, params)).collect()
            };
            eq.phi.extend(each(&g.phi[..]));
            eq.velocity.extend(each(&g.velocity[..]));
            eq.jacobian.extend(each(&g.jacobian[..]));
            eq.gamma.extend(each(&g.gamma[..]));
        }
    }
    for p in desc.points.iter() {
        for (_, v) in l.elements(p.family) {
            let names = names_at(&[l.body_column(desc, &p.body, v)]);
            eq.point_velocities.extend(p.velocity.iter().map(|t| render(t, own, v, counts, &names, params)));
        }
    }
    eq
}
