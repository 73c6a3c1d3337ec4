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
//! - Speeds: body-frame velocities `V` (each body's forward and lateral
//!   velocity in its own frame, its angular rate; Kane's generalized
//!   speeds), `Sym::Qd(j)` standing for `V[j]` in this derivation.
//! - Skates: in row order, the row `a(p) . V = 0` (the hinges' velocities
//!   substituted, earlier solutions too) is solved for the velocity whose
//!   coefficient mentions no coordinate, a translational one first (the
//!   largest at the declared parameters), else an angular rate:
//!   `V_k = -(row - a_k V_k) / a_k`; earlier solutions are updated. The
//!   rest are the independent speeds `u`.
//! - `V = B(p) u` for every body, `B = dV/du`, the global rates `qd`, and
//!   `c`, the body-frame acceleration at `u' = 0` (the rate of `V` along
//!   `pd` plus the frame's turning), so a body's acceleration in its frame
//!   is `B u' + c`; products of sines and cosines are rewritten over angle
//!   differences (`sym::trig`) and common factors pulled out.

use std::collections::{HashMap, HashSet};

use crate::ast::ModelDef;
use crate::check::Resolved;
use crate::sym::{Arena, Id, Sym};

/// The derived minimal form.
pub struct Minimal {
    /// Kept coordinates `p` (indices into `q`, ascending).
    pub coords: Vec<usize>,
    /// Independent speeds `u` (indices into the body-frame velocities
    /// `V`, ascending: `V[3 i + k]` is body `i`'s forward, lateral or
    /// angular velocity in its own frame).
    pub speeds: Vec<usize>,
    /// Every eliminated coordinate: `(index, q_j(p))`.
    pub q_dep: Vec<(usize, Id)>,
    /// Every global velocity `qd_j(p, u)` (nq).
    pub qd: Vec<Id>,
    /// `B = dV/du` (nq x nu, row-major), body frames.
    pub b: Vec<Id>,
    /// `c`, the body-frame acceleration at `u' = 0` (nq): `V' = B u' + c`.
    pub c: Vec<Id>,
    /// `b` and `c` before their sines and cosines of angle differences
    /// are written as products ([`Arena::trig_products`]): what
    /// [`maggi`] multiplies out and collects.
    pub b_lin: Vec<Id>,
    pub c_lin: Vec<Id>,
    /// Each body's `cos phi, sin phi` (2 nb): the forces into its frame.
    pub frames: Vec<Id>,
    /// Per skate row: `(skate name, body-frame velocity index, coefficient)`.
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
    let order = hinge_tree(def, res)?;
    let zero = ar.cst(0.0);
    let qmap = positions(ar, def, phi, &order, zero)?;
    let coords: Vec<usize> = (0..nq).filter(|j| !qmap.contains_key(&Sym::Q(*j))).collect();
    let trig: Vec<(Id, Id)> = (0..nb)
        .map(|i| {
            let a = ar.sym(Sym::Q(3 * i + 2));
            (ar.cos(a), ar.sin(a))
        })
        .collect();
    let (global, vmap) = frame_velocities(ar, &trig, &coords, &qmap, &order);
    let rows = Rows { pattern, values, skates: nh..nc };
    let (sol, pivots) = solve_skates(ar, def, &rows, &coords, &global, &qmap, zero)?;
    let speeds: Vec<usize> = coords.iter().copied().filter(|k| !sol.contains_key(&Sym::Qd(*k))).collect();

    // every body-frame velocity in the independent speeds
    let mut v_full = Vec::with_capacity(nq);
    for j in 0..nq {
        let e = match (sol.get(&Sym::Qd(j)), vmap.get(&Sym::Qd(j))) {
            (Some(&s), _) => s,
            (None, Some(&v)) => {
                let r = ar.replace(v, &|s| sol.get(&s).copied(), &mut HashMap::new());
                ar.linearize(r)
            }
            (None, None) => ar.sym(Sym::Qd(j)),
        };
        v_full.push(e);
    }
    let mut b = Vec::with_capacity(nq * speeds.len());
    for &e in &v_full {
        for &k in &speeds {
            b.push(ar.diff(e, Sym::Qd(k)));
        }
    }
    // the global rates of the kept coordinates in the speeds
    let mut qd = Vec::with_capacity(nq);
    for i in 0..nb {
        let (x, y) = rotate(ar, trig[i], v_full[3 * i], v_full[3 * i + 1], false);
        qd.extend([x, y, v_full[3 * i + 2]]);
    }
    let mut c = convective(ar, &b, &v_full, &qd, &coords, &speeds);
    let mut q_dep: Vec<(usize, Id)> = qmap
        .iter()
        .map(|(s, &e)| match s {
            Sym::Q(j) => (*j, e),
            _ => unreachable!("positions only"),
        })
        .collect();
    q_dep.sort_by_key(|(j, _)| *j);
    let (b_lin, c_lin) = (b.clone(), c.clone());
    // cos(a - b), sin(a - b) from the angles' own sines and cosines
    let mut memo = HashMap::new();
    for e in qd.iter_mut().chain(&mut b).chain(&mut c) {
        *e = ar.trig_products(*e, &mut memo);
    }
    let mut memo = HashMap::new();
    for e in qd.iter_mut().chain(&mut b).chain(&mut c) {
        *e = ar.factor(*e, &mut memo);
    }
    let frames = trig.iter().flat_map(|&(c, s)| [c, s]).collect();
    Ok(Minimal { coords, speeds, q_dep, qd, b, c, b_lin, c_lin, frames, pivots })
}

/// The tree of hinges: `(child body, hinge)` in visiting order,
/// breadth-first from the ground (a body hinged to it), then from the
/// lowest-numbered body not reached yet.
///
/// # Errors
/// A hinge between two bodies already reached (a loop).
fn hinge_tree(def: &ModelDef, res: &Resolved) -> Result<Vec<(usize, usize)>, String> {
    let nb = def.bodies.len();
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
    Ok(order)
}

/// Each child's `x, y` in the tree's `order`, solved from its hinge's
/// rows of `phi` (the parent's already eliminated); `zero` is the
/// arena's 0.
///
/// # Errors
/// A hinge not affine in the body's position, or one whose rows do not
/// vanish in the tree's coordinates.
fn positions(
    ar: &mut Arena,
    def: &ModelDef,
    phi: &[Id],
    order: &[(usize, usize)],
    zero: Id,
) -> Result<HashMap<Sym, Id>, String> {
    let mut qmap: HashMap<Sym, Id> = HashMap::new();
    for &(child, h) in order {
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
    Ok(qmap)
}

/// `R(phi) (vx, vy)` (`R(phi)^T` if `inverse`) with `trig = (cos phi, sin phi)`.
fn rotate(ar: &mut Arena, trig: (Id, Id), vx: Id, vy: Id, inverse: bool) -> (Id, Id) {
    let (c, s) = trig;
    let s = if inverse { ar.neg(s) } else { s };
    let (cx, sy, sx, cy) = (ar.mul2(c, vx), ar.mul2(s, vy), ar.mul2(s, vx), ar.mul2(c, vy));
    (ar.sub(cx, sy), ar.add2(sx, cy))
}

/// Velocities in the body frames: `Sym::Qd(j)` stands, in this
/// derivation, for body `j / 3`'s velocity component `j % 3` in its own
/// frame (forward, lateral [m/s], angular rate [rad/s]); the global rates
/// are `(xd, yd) = R(phi) (v_x, v_y)`, with `trig` each body's
/// `(cos phi, sin phi)`. Returns the global rate of every coordinate
/// (kept and eliminated, `qmap`) in these symbols, and each eliminated
/// child's frame velocity.
fn frame_velocities(
    ar: &mut Arena,
    trig: &[(Id, Id)],
    coords: &[usize],
    qmap: &HashMap<Sym, Id>,
    order: &[(usize, usize)],
) -> (HashMap<usize, Id>, HashMap<Sym, Id>) {
    // the global rate of every kept coordinate in the body-frame symbols
    let mut rates: HashMap<usize, Id> = HashMap::new();
    for &k in coords {
        let i = k / 3;
        let e = match k % 3 {
            2 => ar.sym(Sym::Qd(k)),
            axis => {
                let (vx, vy) = (ar.sym(Sym::Qd(3 * i)), ar.sym(Sym::Qd(3 * i + 1)));
                let (x, y) = rotate(ar, trig[i], vx, vy, false);
                ar.linearize(if axis == 0 { x } else { y })
            }
        };
        rates.insert(k, e);
    }
    // each eliminated position's global rate, then its body's frame velocity
    let rate = |ar: &mut Arena, e: Id, rates: &HashMap<usize, Id>| -> Id {
        let terms: Vec<Id> = coords
            .iter()
            .map(|&k| {
                let d = ar.diff(e, Sym::Q(k));
                ar.mul2(d, rates[&k])
            })
            .collect();
        let sum = ar.add(&terms);
        ar.linearize(sum)
    };
    let mut global: HashMap<usize, Id> = rates.clone();
    // in the order of the coordinates, not of the hash map: the arena's
    // ids, and so the generated code, are the same at every compilation
    let mut eliminated: Vec<(usize, Id)> = qmap
        .iter()
        .map(|(&var, &sol)| {
            let Sym::Q(j) = var else { unreachable!("positions only") };
            (j, sol)
        })
        .collect();
    eliminated.sort_unstable_by_key(|&(j, _)| j);
    for (j, sol) in eliminated {
        let v = rate(ar, sol, &rates);
        global.insert(j, v);
    }
    let mut vmap: HashMap<Sym, Id> = HashMap::new();
    for &(child, _) in order {
        if let (Some(&xd), Some(&yd)) = (global.get(&(3 * child)), global.get(&(3 * child + 1)))
            && qmap.contains_key(&Sym::Q(3 * child))
        {
            let (vx, vy) = rotate(ar, trig[child], xd, yd, true);
            vmap.insert(Sym::Qd(3 * child), ar.linearize(vx));
            vmap.insert(Sym::Qd(3 * child + 1), ar.linearize(vy));
        }
    }
    (global, vmap)
}

/// `G`'s `values` at `pattern`, of which the rows `skates` are the
/// skates'.
struct Rows<'a> {
    pattern: &'a [(usize, usize)],
    values: &'a [Id],
    skates: std::ops::Range<usize>,
}

/// The skates' rows solved: each pivot velocity's solution, and the
/// pivots ([`Minimal::pivots`]).
type SkateSolution = (HashMap<Sym, Id>, Vec<(String, usize, Id)>);

/// Per skate row, in order, the body-frame velocity it is solved for and
/// its solution (earlier solutions updated), and the row's pivot
/// `(skate name, velocity index, coefficient)`: a velocity of `coords`
/// whose coefficient is free of the coordinates, a root body's
/// translational one first (the largest coefficient), else an angular
/// rate. `global` is every coordinate's global rate, `qmap` the
/// eliminated positions, `zero` the arena's 0.
///
/// # Errors
/// A skate row with no such velocity, or one not linear in the
/// velocities.
fn solve_skates(
    ar: &mut Arena,
    def: &ModelDef,
    rows: &Rows,
    coords: &[usize],
    global: &HashMap<usize, Id>,
    qmap: &HashMap<Sym, Id>,
    zero: Id,
) -> Result<SkateSolution, String> {
    let is_state = |s: Sym| matches!(s, Sym::Q(_) | Sym::Qd(_));
    let mut sol: HashMap<Sym, Id> = HashMap::new();
    let mut pivots = Vec::new();
    for (si, i) in rows.skates.clone().enumerate() {
        let terms: Vec<Id> = rows
            .pattern
            .iter()
            .zip(rows.values)
            .filter(|((r, _), _)| *r == i)
            .map(|(&(_, c), &g)| {
                let v = global.get(&c).copied().unwrap_or_else(|| ar.sym(Sym::Qd(c)));
                ar.mul2(g, v)
            })
            .collect();
        let row = ar.add(&terms);
        let row = ar.replace(row, &|s| qmap.get(&s).copied(), &mut HashMap::new());
        let row = ar.replace(row, &|s| sol.get(&s).copied(), &mut HashMap::new());
        let row = ar.linearize(row);
        let name = def.skates[si].name.to_string();
        let mut best: Option<(usize, Id, f64)> = None;
        for &k in coords.iter().filter(|k| !sol.contains_key(&Sym::Qd(**k))) {
            let a = ar.diff(row, Sym::Qd(k));
            if ar.is_zero(a) || ar.mentions(a, &is_state) {
                continue;
            }
            // translational pivots (dimensionless) by size, at the
            // declared parameter values; an angular rate only without one
            let size = if k % 3 == 2 { 0.0 } else { param_size(ar, a, def) };
            if best.is_none_or(|(_, _, s)| size > s) {
                best = Some((k, a, size));
            }
        }
        let Some((k, a, _)) = best else {
            return Err(format!(
                "no velocity enters the row of skate `{name}` with a coefficient free of the coordinates"
            ));
        };
        let var = Sym::Qd(k);
        let rest = ar.replace(row, &|s| (s == var).then_some(zero), &mut HashMap::new());
        let minus = ar.neg(rest);
        let inv = ar.pow(a, -1);
        let solved = ar.mul2(minus, inv);
        let solved = ar.linearize(solved);
        if ar.mentions(solved, &|s| s == var) {
            return Err(format!("the row of skate `{name}` is not linear in the velocities"));
        }
        for e in sol.values_mut() {
            let r = ar.replace(*e, &|s| (s == var).then_some(solved), &mut HashMap::new());
            *e = ar.linearize(r);
        }
        sol.insert(var, solved);
        pivots.push((name, k, a));
    }
    Ok((sol, pivots))
}

/// `c = dV/dt` at fixed `u` (along the kept coordinates' rates `qd`) plus
/// the frame's turning, `(-w v_y, w v_x, 0)`: the body-frame acceleration
/// is `B u' + c`; `(d/dt B) u` as `sum_k u_k sum_m dB_jk/dp_m pd_m`, each
/// `pd_m` once.
fn convective(ar: &mut Arena, b: &[Id], v_full: &[Id], qd: &[Id], coords: &[usize], speeds: &[usize]) -> Vec<Id> {
    let nq = v_full.len();
    let nu = speeds.len();
    let u: Vec<Id> = speeds.iter().map(|&k| ar.sym(Sym::Qd(k))).collect();
    let mut c = Vec::with_capacity(nq);
    for j in 0..nq {
        let mut terms = Vec::new();
        for (k, &uk) in u.iter().enumerate() {
            let bjk = b[j * nu + k];
            let rates: Vec<Id> = coords
                .iter()
                .filter_map(|&m| {
                    let d = ar.diff(bjk, Sym::Q(m));
                    (!ar.is_zero(d)).then(|| ar.mul2(d, qd[m]))
                })
                .collect();
            if !rates.is_empty() {
                let bd = ar.add(&rates);
                terms.push(ar.mul2(bd, uk));
            }
        }
        let (i, axis) = (j / 3, j % 3);
        let w = v_full[3 * i + 2];
        match axis {
            0 => {
                let t = ar.mul2(w, v_full[3 * i + 1]);
                terms.push(ar.neg(t));
            }
            1 => terms.push(ar.mul2(w, v_full[3 * i])),
            _ => {}
        }
        c.push(ar.add(&terms));
    }
    c
}

/// The fused right-hand side's symbolic part (`Model::minimal_rhs`): with
/// the mass diagonal `mass` (nq, parameters only; each body's alike along
/// x and y), the lower triangle of Maggi's `B^T M B` (row by row: entry
/// `(i, k)`, `k <= i`, at `i (i + 1) / 2 + k`) and `-B^T M c` (nu), and
/// `B` (nq x nu), each with its fixed parts grouped for hoisting
/// ([`Arena::group_fixed`]). The applied force's part of `B^T (F - M c)`
/// is left to the generated code, `F` coming in at run time, and so is
/// the hinges' torques' part: `hinge` (nh rows of nu) holds each
/// hinge's row `B_a - B_b` of its bodies' headings (`B_a` alone for a
/// ground hinge), so that a torque `tau` adds `tau (B_a - B_b)` to the
/// right-hand side, the two rows' common terms cancelled symbolically.
pub struct Maggi {
    pub a: Vec<Id>,
    pub minus_bmc: Vec<Id>,
    pub b: Vec<Id>,
    pub hinge: Vec<Vec<Id>>,
}

/// [`Maggi`] of the minimal form `m`, with the hinges' bodies `hinges`
/// (first, second or `None` for the ground), in the order of the model's
/// `ModelInfo::hinges`.
pub fn maggi(ar: &mut Arena, m: &Minimal, mass: &[Id], hinges: &[(usize, Option<usize>)]) -> Maggi {
    let (nq, nu) = (m.qd.len(), m.speeds.len());
    let mut memo = crate::sym::hoist::Grouping::default();
    let b: Vec<Id> = m.b.iter().map(|&e| ar.group_fixed(e, &mut memo)).collect();
    // each entry twice: as the sum of the factored products, and
    // multiplied out and collected in the state (`Arena::collect_state`)
    // over the sines and cosines of angle differences, then written in
    // the angles' own and factored as the rest; the cheaper is kept
    let (mut trig, mut fac, mut fixed) = (HashMap::new(), HashMap::new(), Vec::new());
    let mut both = |ar: &mut Arena, memo: &mut crate::sym::hoist::Grouping, factored: Id, linear: Id| {
        let old = ar.group_fixed(factored, memo);
        let new = ar.collect_state(linear, &mut fixed).map(|e| {
            let e = ar.trig_products(e, &mut trig);
            let e = ar.factor_state(e, &mut fac);
            ar.group_fixed(e, memo)
        });
        (old, new)
    };
    let mut a = Vec::with_capacity(nu * (nu + 1) / 2);
    for i in 0..nu {
        for k in 0..=i {
            let sum = |ar: &mut Arena, b: &[Id]| {
                let terms: Vec<Id> = (0..nq).map(|j| ar.mul(&[mass[j], b[j * nu + i], b[j * nu + k]])).collect();
                ar.add(&terms)
            };
            let (f, l) = (sum(ar, &m.b), sum(ar, &m.b_lin));
            a.push(both(ar, &mut memo, f, l));
        }
    }
    let minus = ar.cst(-1.0);
    let minus_bmc: Vec<(Id, Option<Id>)> = (0..nu)
        .map(|i| {
            let sum = |ar: &mut Arena, b: &[Id], c: &[Id]| {
                let terms: Vec<Id> = (0..nq).map(|j| ar.mul(&[minus, mass[j], b[j * nu + i], c[j]])).collect();
                ar.add(&terms)
            };
            let (f, l) = (sum(ar, &m.b, &m.c), sum(ar, &m.b_lin, &m.c_lin));
            both(ar, &mut memo, f, l)
        })
        .collect();
    // the choice, counted beyond what the stages compute anyway (the
    // lean function's: the kept coordinates' and the headings' rates;
    // `Model::minimal_rhs_lean`)
    let fixed = ar.fixed_nodes();
    let mut done = HashSet::new();
    let pre: Vec<Id> = (0..nq)
        .filter(|&j| j % 3 == 2 || m.coords.contains(&j))
        .map(|j| m.qd[j])
        .chain(m.frames.iter().copied())
        .collect();
    ar.op_count(&pre, &fixed, &mut done);
    let a: Vec<Id> = a.into_iter().map(|(old, new)| ar.cheaper(old, new, &fixed, &mut done)).collect();
    let minus_bmc: Vec<Id> = minus_bmc.into_iter().map(|(old, new)| ar.cheaper(old, new, &fixed, &mut done)).collect();
    let hinge = hinges
        .iter()
        .map(|&(body_a, body_b)| {
            (0..nu)
                .map(|i| {
                    let ba = m.b[(3 * body_a + 2) * nu + i];
                    let row = match body_b {
                        Some(body_b) => {
                            let bb = scaled(ar, m.b[(3 * body_b + 2) * nu + i], -1.0);
                            ar.add(&[ba, bb])
                        }
                        None => ba,
                    };
                    ar.group_fixed(row, &mut memo)
                })
                .collect()
        })
        .collect();
    Maggi { a, minus_bmc, b, hinge }
}

/// `|e|` at the parameters' declared values (`NaN` if it mentions anything else).
fn param_size(ar: &Arena, e: Id, def: &ModelDef) -> f64 {
    ar.eval(e, &|s| match s {
        Sym::Param(i) => def.params[i].value,
        _ => f64::NAN,
    })
    .abs()
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
