//! What a model read from text says about itself at its current counts:
//! its [`ModelInfo`], its equations as text and LaTeX, and whether the
//! counts give a well-formed model. The same names, the same order and
//! the same messages as the code `model!` generates (ezy-derive's
//! `emit::info`, `emit::equations`, `emit::checks`).

use ezy_lang::kinematics::Kind;
use ezy_lang::sym::{Id, Sym};

use super::layout::Layout;
use super::plan::{GroupPlan, ItemKind, Ix, Plan};
use crate::model::info::{
    BodyInfo, DriveInfo, Equations, HingeInfo, ModelInfo, PointInfo, SkateInfo, SliderInfo, check_model_size,
    render_equation, unique_names,
};

/// The name of an item's element: the item's name, and a family
/// element's index after it (`link3`).
fn element(name: &str, family: Option<usize>, v: i64) -> String {
    match family {
        Some(_) => format!("{name}{v}"),
        None => name.to_string(),
    }
}

/// The columns of `q` of a group's slots at loop value `v`.
fn columns(plan: &Plan, l: &Layout, g: &GroupPlan, v: i64) -> Vec<usize> {
    g.slots.iter().map(|s| l.body_column(plan, s, v)).collect()
}

/// The [`ModelInfo`] at the layout's counts.
pub(super) fn info(plan: &Plan, l: &Layout) -> ModelInfo {
    let mut info = ModelInfo {
        name: plan.name,
        doc: plan.doc,
        coords: Vec::with_capacity(l.nq),
        params: plan.params.clone(),
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
    for (bi, b) in plan.bodies.iter().enumerate() {
        for (e, v) in l.elements(b.family) {
            let k = l.body_off[bi] + 3 * e;
            info.coords.extend(b.coords.iter().map(|c| element(c, b.family, v)));
            info.bodies.push(BodyInfo {
                name: element(&b.name, b.family, v),
                coords: [k, k + 1, k + 2],
                mass_param: b.mass_param,
                inertia_param: b.inertia_param,
            });
        }
    }
    for p in &plan.points {
        for (_, v) in l.elements(p.family) {
            info.points.push(PointInfo { name: element(&p.name, p.family, v), body: l.body_index(plan, &p.body, v) });
        }
    }
    for (gi, g) in plan.groups.iter().enumerate() {
        for (e, v) in l.elements(g.family) {
            let rb = l.row[gi] + e * g.rows;
            let name = element(&g.name, g.family, v);
            let slot = |s: usize| g.slots.get(s).map(|b| l.body_index(plan, b, v));
            match &g.item_kind {
                ItemKind::Hinge { point, .. } => info.hinges.push(HingeInfo {
                    name: name.clone(),
                    body_a: slot(0).expect("a hinge has a body"),
                    body_b: slot(1),
                    row: rb,
                    point: l.point_index(plan, point, v),
                }),
                ItemKind::Slider { heading, .. } => info.sliders.push(SliderInfo {
                    name: name.clone(),
                    body_a: slot(1),
                    body_b: slot(0).expect("a slider has a body"),
                    row: rb,
                    heading: *heading,
                }),
                ItemKind::Drive { hinge_group } => {
                    info.drives.push(DriveInfo { name: name.clone(), hinge: l.item_index[*hinge_group] + e, row: rb });
                }
                ItemKind::Skate { point } => {
                    info.skates.push(SkateInfo { name: name.clone(), point: l.point_index(plan, point, v), row: rb });
                }
            }
            info.constraints.extend(g.suffixes.iter().map(|s| format!("{name}{s}")));
            let cols = columns(plan, l, g, v);
            info.pattern.extend(g.pattern.iter().map(|&(r, c)| (rb + r, cols[c / 3] + c % 3)));
        }
    }
    info
}

/// Whether the counts give a well-formed model (what a compiled model's
/// `check_counts` checks, in its order and words).
pub(super) fn check_counts(plan: &Plan, l: &Layout, values: &[f64]) -> Result<(), String> {
    let counts = &plan.params[plan.n_real..];
    for (c, &value) in counts.iter().zip(&values[plan.n_real..]) {
        if value < 1.0 {
            return Err(format!("count `{}` is 0; it must be at least 1", c.name));
        }
    }
    if !counts.is_empty() {
        let given: Vec<(&str, usize)> = counts.iter().zip(&l.counts).map(|(c, &v)| (c.name, v as usize)).collect();
        check_model_size(l.nq, &given)?;
    }
    // does element `ix` (at loop value `v`) of family `f` exist?
    let in_range = |f: usize, ix: &Ix, v: i64, owner: &str, what: &str| -> Result<(), String> {
        let value = ix.at(v, &l.counts);
        let (start, len) = (l.f_start[f], l.f_len[f] as i64);
        if value < start || value >= start + len {
            let range = &plan.families[f].range;
            let shown = &ix.shown;
            return Err(format!(
                "{owner} refers to {what}[{shown}] = {what}{value}, which does not exist: {what} has elements {start}..{} ({range})",
                start + len
            ));
        }
        Ok(())
    };
    for p in &plan.points {
        let body = &plan.bodies[p.body.item];
        let (Some(fb), Some(ix)) = (body.family, &p.body.index) else { continue };
        for (_, v) in l.elements(p.family) {
            in_range(fb, ix, v, &format!("point `{}`", element(&p.name, p.family, v)), &body.name)?;
        }
    }
    f64_scratch(plan, |regs| {
        for g in &plan.groups {
            for (_, v) in l.elements(g.family) {
                check_element(plan, l, g, v, values, regs, &in_range)?;
            }
        }
        Ok::<(), String>(())
    })?;
    unique_names(&info(plan, l))
}

fn f64_scratch<R>(plan: &Plan, f: impl FnOnce(&mut [f64]) -> R) -> R {
    <f64 as crate::scalar::Scalar>::with_scratch(plan.registers, f)
}

/// Whether element `ix` (at loop value `v`) of family `f` exists, else a
/// message naming `owner` and `what` it refers to.
type InRange<'a> = dyn Fn(usize, &Ix, i64, &str, &str) -> Result<(), String> + 'a;

/// [`check_counts`] for one element of a constraint item: its references
/// inside their families, its direction not zero, two distinct bodies.
fn check_element(
    plan: &Plan,
    l: &Layout,
    g: &GroupPlan,
    v: i64,
    values: &[f64],
    regs: &mut [f64],
    in_range: &InRange<'_>,
) -> Result<(), String> {
    let owner = format!("{} `{}`", g.kind_word(), element(&g.name, g.family, v));
    let refs = match &g.item_kind {
        ItemKind::Hinge { point, other } | ItemKind::Slider { point, other, .. } => {
            std::iter::once(point).chain(other).collect()
        }
        ItemKind::Skate { point } => vec![point],
        ItemKind::Drive { .. } => Vec::new(),
    };
    for r in refs {
        let p = &plan.points[r.item];
        if let (Some(fp), Some(ix)) = (p.family, &r.index) {
            in_range(fp, ix, v, &owner, &p.name)?;
        }
    }
    for b in &g.slots {
        let body = &plan.bodies[b.item];
        if let (Some(fb), Some(ix)) = (body.family, &b.index) {
            in_range(fb, ix, v, &owner, &body.name)?;
        }
    }
    if let Some((tape, written)) = &g.direction {
        let ix: Vec<f64> = g.indices.iter().map(|a| a.at(v, &l.counts) as f64).collect();
        let mut t = [0.0; 2];
        tape.eval(&super::tape::Inputs::fixed(values, &ix), regs, |j, x| t[j] = x);
        let [tx, ty] = t;
        let n2 = tx * tx + ty * ty;
        if !(n2 > 0.0 && n2.is_finite()) {
            return Err(format!(
                "{owner} has its {written} = ({tx}, {ty}) at this element and these parameters: not a direction; give one that is not zero at any element"
            ));
        }
    }
    if g.slots.len() == 2
        && g.kind != Kind::Drive
        && l.body_index(plan, &g.slots[0], v) == l.body_index(plan, &g.slots[1], v)
    {
        return Err(format!("{owner} joins two points of the same body"));
    }
    Ok(())
}

/// The derived equations at the layout's counts, rendered with the
/// coordinates' and parameters' names.
pub(super) fn equations(plan: &Plan, l: &Layout) -> Equations {
    let info = info(plan, l);
    let params: Vec<&str> = plan.params[..plan.n_real].iter().map(|p| p.name).collect();
    let mut ar = plan.ar.clone();
    let mut eq = Equations {
        coords: info
            .coords
            .iter()
            .map(|c| render_equation("\u{1}q0\u{2}", "\u{1}q0\u{2}", &[c.as_str()], &[]))
            .collect(),
        ..Equations::default()
    };
    // an expression naming family indices gets the element's values: where
    // it names one and that one is 0, 1 or -1, its form simplified by the
    // arena (`x - 0*L` is `x`), else the integer put in (a negative one in
    // parentheses)
    let mut render = |id: Id, indices: &[Ix], v: i64, names: &[&str]| {
        let (t, x) = ezy_lang::equation_templates(&ar, id);
        let named: Vec<usize> = (0..indices.len())
            .filter(|&k| {
                let m = ezy_lang::index_marker(k);
                t.contains(&m) || x.contains(&m)
            })
            .collect();
        if let [k] = named[..] {
            let n = indices[k].at(v, &l.counts);
            if (-1..=1).contains(&n) {
                let value = ar.cst(n as f64);
                let at = ar.replace(id, &|s| (s == Sym::Index(k)).then_some(value), &mut Default::default());
                let (t, x) = ezy_lang::equation_templates(&ar, at);
                return render_equation(&t, &x, names, &params);
            }
        }
        let (mut t, mut x) = (t, x);
        for &k in &named {
            let n = indices[k].at(v, &l.counts);
            let n = if n < 0 { format!("({n})") } else { n.to_string() };
            let m = ezy_lang::index_marker(k);
            (t, x) = (t.replace(&m, &n), x.replace(&m, &n));
        }
        render_equation(&t, &x, names, &params)
    };
    let own = [plan.own.clone()];
    for b in &plan.bodies {
        for (_, v) in l.elements(b.family) {
            eq.mass.extend(b.mass_ids.iter().map(|&m| render(m, &own, v, &[])));
        }
    }
    let coords = &info.coords;
    let names_at = |cols: &[usize]| -> Vec<&str> {
        cols.iter().flat_map(|&c| (0..3).map(move |o| coords[c + o].as_str())).collect()
    };
    for g in &plan.groups {
        if g.slots.is_empty() {
            continue;
        }
        for (_, v) in l.elements(g.family) {
            let names = names_at(&columns(plan, l, g, v));
            let ix = &g.indices;
            eq.phi.extend(g.eq_phi.iter().map(|&x| render(x, ix, v, &names)));
            eq.velocity.extend(g.eq_velocity.iter().map(|&x| render(x, ix, v, &names)));
            eq.jacobian.extend(g.eq_g.iter().map(|&x| render(x, ix, v, &names)));
            eq.gamma.extend(g.eq_gamma.iter().map(|&x| render(x, ix, v, &names)));
        }
    }
    for p in &plan.points {
        for (_, v) in l.elements(p.family) {
            let names = names_at(&[l.body_column(plan, &p.body, v)]);
            eq.point_velocities.extend(p.vel_ids.iter().map(|&x| render(x, &own, v, &names)));
        }
    }
    eq
}
