//! Minimal coordinates of a model without families, derived symbolically:
//! the tree of hinges eliminates every child body's `x, y`, and each skate
//! row is solved for one velocity whose coefficient is free of the
//! coordinates (the runtime's `MinimalLayout`, docs/physics.md §6.2).
//!
//! - Hinges: bodies are visited breadth-first from the ground (a body
//!   hinged to it) or else from the lowest-numbered body of each group;
//!   the hinge that reaches a body is solved for its `x, y` (each row has
//!   coefficient +-1 on them), with the parent's already eliminated. A
//!   hinge between two bodies already reached closes a loop: no minimal
//!   form.
//! - Skates: in row order, the row `a(p) . pd = 0` (the hinges'
//!   velocities substituted, earlier solutions too) is solved for the
//!   first velocity, angular rates first, whose coefficient mentions no
//!   coordinate: `pd_k = -(row - a_k pd_k) / a_k`; earlier solutions are
//!   updated. The rest are the independent speeds `u`.
//! - `qd = B(p) u` for every coordinate, `B = dqd/du`, and the convective
//!   `c = sum_i (dqd/dp_i) pd_i`, so `qdd = B u' + c`.

use std::collections::HashMap;

use crate::ast::ModelDef;
use crate::check::Resolved;
use crate::sym::{Arena, Id, Sym};

/// The derived minimal form.
pub struct Minimal {
    /// Kept coordinates `p` (indices into `q`, ascending).
    pub coords: Vec<usize>,
    /// Independent speeds `u` (indices into `qd`, ascending).
    pub speeds: Vec<usize>,
    /// Every eliminated coordinate: `(index, q_j(p))`.
    pub q_dep: Vec<(usize, Id)>,
    /// Every velocity not in `speeds`: `(index, qd_j(p, u))`.
    pub qd_dep: Vec<(usize, Id)>,
    /// `B = dqd/du` (nq x nu, row-major).
    pub b: Vec<Id>,
    /// `c = (d/dt B) u` (nq).
    pub c: Vec<Id>,
    /// Per skate row: `(skate name, velocity index, coefficient)`.
    pub pivots: Vec<(String, usize, Id)>,
}

/// Derives the minimal form from the model's global holonomic rows `phi`
/// (hinges, two rows each, in item order) and `G`'s `values` at
/// `pattern` (`nc` rows, the skates' after the hinges').
///
/// # Errors
/// A sentence for the user saying which item rules the form out.
pub fn derive(
    ar: &mut Arena,
    def: &ModelDef,
    res: &Resolved,
    phi: &[Id],
    pattern: &[(usize, usize)],
    values: &[Id],
    nc: usize,
) -> Result<Minimal, String> {
    if let Some(s) = def.sliders.first() {
        return Err(format!("it has a slider or slot (`{}`): only hinges and skates are eliminated", s.name));
    }
    if let Some(d) = def.drives.first() {
        return Err(format!("it has a drive (`{}`): prescribed angles are kept as constraints", d.name));
    }
    let nb = def.bodies.len();
    let nq = 3 * nb;
    let nh = phi.len();
    if nh != 2 * def.hinges.len() {
        return Err("its holonomic rows are not all hinges".into());
    }
    // the tree: (child body, hinge) in visiting order
    let ends: Vec<(usize, Option<usize>)> = res
        .hinge_points
        .iter()
        .map(|(a, b)| (res.body_of(def, a).0, b.as_ref().map(|b| res.body_of(def, b).0)))
        .collect();
    let mut reached = vec![false; nb];
    let mut used = vec![false; ends.len()];
    let mut order: Vec<(usize, usize)> = Vec::new();
    let closes = |h: usize| format!("hinge `{}` closes a loop: loops are kept as constraints", def.hinges[h].name);
    let visit = |start: usize, reached: &mut Vec<bool>, used: &mut Vec<bool>, order: &mut Vec<(usize, usize)>| {
        let mut queue = std::collections::VecDeque::from([start]);
        while let Some(x) = queue.pop_front() {
            for (h, &(a, b)) in ends.iter().enumerate() {
                if used[h] {
                    continue;
                }
                let other = match b {
                    Some(b) if a == x => b,
                    Some(b) if b == x => a,
                    _ => continue,
                };
                used[h] = true;
                if reached[other] {
                    return Err(closes(h));
                }
                reached[other] = true;
                order.push((other, h));
                queue.push_back(other);
            }
        }
        Ok(())
    };
    for (h, &(a, b)) in ends.iter().enumerate() {
        if b.is_none() {
            if reached[a] {
                return Err(closes(h));
            }
            used[h] = true;
            reached[a] = true;
            order.push((a, h));
            visit(a, &mut reached, &mut used, &mut order)?;
        }
    }
    for b in 0..nb {
        if !reached[b] {
            reached[b] = true;
            visit(b, &mut reached, &mut used, &mut order)?;
        }
    }

    // positions: each child's x, y from its hinge's rows
    let zero = ar.cst(0.0);
    let mut qmap: HashMap<Sym, Id> = HashMap::new();
    for &(child, h) in &order {
        for k in 0..2 {
            let row = ar.replace(phi[2 * h + k], &|s| qmap.get(&s).copied(), &mut HashMap::new());
            let var = Sym::Q(3 * child + k);
            let coef = ar.diff(row, var);
            let Some(a) = ar.as_const(coef).filter(|a| *a != 0.0) else {
                return Err(format!("hinge `{}` is not affine in the body's position", def.hinges[h].name));
            };
            let rest = ar.replace(row, &|s| (s == var).then_some(zero), &mut HashMap::new());
            let sol = scaled(ar, rest, -1.0 / a);
            qmap.insert(var, sol);
        }
    }
    for (r, &row) in phi.iter().enumerate() {
        let left = ar.replace(row, &|s| qmap.get(&s).copied(), &mut HashMap::new());
        if !ar.is_zero(left) {
            return Err(format!("hinge `{}` does not vanish in the tree's coordinates", def.hinges[r / 2].name));
        }
    }
    let coords: Vec<usize> = (0..nq).filter(|j| !qmap.contains_key(&Sym::Q(*j))).collect();
    let rate = |ar: &mut Arena, e: Id, coords: &[usize]| -> Id {
        let terms: Vec<Id> = coords
            .iter()
            .map(|&k| {
                let d = ar.diff(e, Sym::Q(k));
                let v = ar.sym(Sym::Qd(k));
                ar.mul2(d, v)
            })
            .collect();
        ar.add(&terms)
    };
    let mut qdmap: HashMap<Sym, Id> = HashMap::new();
    for (&var, &sol) in &qmap {
        let Sym::Q(j) = var else { unreachable!("positions only") };
        let v = rate(ar, sol, &coords);
        qdmap.insert(Sym::Qd(j), v);
    }

    // skates: each row solved for one velocity with a constant coefficient
    let is_state = |s: Sym| matches!(s, Sym::Q(_) | Sym::Qd(_));
    let mut candidates: Vec<usize> = coords.iter().copied().filter(|k| k % 3 == 2).collect();
    candidates.extend(coords.iter().copied().filter(|k| k % 3 != 2));
    let mut sol: HashMap<Sym, Id> = HashMap::new();
    let mut pivots = Vec::new();
    for (si, i) in (nh..nc).enumerate() {
        let terms: Vec<Id> = pattern
            .iter()
            .zip(values)
            .filter(|((r, _), _)| *r == i)
            .map(|(&(_, c), &g)| {
                let v = ar.sym(Sym::Qd(c));
                ar.mul2(g, v)
            })
            .collect();
        let row = ar.add(&terms);
        let row = ar.replace(row, &|s| qmap.get(&s).or_else(|| qdmap.get(&s)).copied(), &mut HashMap::new());
        let row = ar.replace(row, &|s| sol.get(&s).copied(), &mut HashMap::new());
        let chosen = candidates.iter().copied().filter(|k| !sol.contains_key(&Sym::Qd(*k))).find_map(|k| {
            let a = ar.diff(row, Sym::Qd(k));
            (!ar.is_zero(a) && !ar.mentions(a, &is_state)).then_some((k, a))
        });
        let name = def.skates[si].name.to_string();
        let Some((k, a)) = chosen else {
            return Err(format!(
                "no velocity enters the row of skate `{name}` with a coefficient free of the coordinates"
            ));
        };
        let var = Sym::Qd(k);
        let rest = ar.replace(row, &|s| (s == var).then_some(zero), &mut HashMap::new());
        let minus = ar.neg(rest);
        let solved = ar.div(minus, a);
        if ar.mentions(solved, &|s| s == var) {
            return Err(format!("the row of skate `{name}` is not linear in the velocities"));
        }
        for e in sol.values_mut() {
            *e = ar.replace(*e, &|s| (s == var).then_some(solved), &mut HashMap::new());
        }
        sol.insert(var, solved);
        pivots.push((name, k, a));
    }
    let speeds: Vec<usize> = coords.iter().copied().filter(|k| !sol.contains_key(&Sym::Qd(*k))).collect();

    // velocities of every coordinate in the independent speeds
    let mut qd_full = Vec::with_capacity(nq);
    for j in 0..nq {
        let e = match (sol.get(&Sym::Qd(j)), qdmap.get(&Sym::Qd(j))) {
            (Some(&s), _) => s,
            (None, Some(&v)) => ar.replace(v, &|s| sol.get(&s).copied(), &mut HashMap::new()),
            (None, None) => ar.sym(Sym::Qd(j)),
        };
        qd_full.push(e);
    }
    let mut b = Vec::with_capacity(nq * speeds.len());
    for &e in &qd_full {
        for &k in &speeds {
            b.push(ar.diff(e, Sym::Qd(k)));
        }
    }
    let pd: Vec<Id> = coords.iter().map(|&k| qd_full[k]).collect();
    let mut c = Vec::with_capacity(nq);
    for &e in &qd_full {
        let terms: Vec<Id> = coords
            .iter()
            .zip(&pd)
            .map(|(&k, &v)| {
                let d = ar.diff(e, Sym::Q(k));
                ar.mul2(d, v)
            })
            .collect();
        c.push(ar.add(&terms));
    }
    let mut q_dep: Vec<(usize, Id)> = qmap
        .iter()
        .map(|(s, &e)| match s {
            Sym::Q(j) => (*j, e),
            _ => unreachable!("positions only"),
        })
        .collect();
    q_dep.sort_by_key(|(j, _)| *j);
    let qd_dep = (0..nq).filter(|j| !speeds.contains(j)).map(|j| (j, qd_full[j])).collect();
    Ok(Minimal { coords, speeds, q_dep, qd_dep, b, c, pivots })
}

/// `k e` with the constant distributed over a sum, so that like terms
/// meet and cancel when the result is added to others.
fn scaled(ar: &mut Arena, e: Id, k: f64) -> Id {
    let k = ar.cst(k);
    match ar.node(e).clone() {
        crate::sym::Node::Add(ts) => {
            let ts: Vec<Id> = ts.iter().map(|&t| ar.mul2(t, k)).collect();
            ar.add(&ts)
        }
        _ => ar.mul2(e, k),
    }
}
