//! The checks of the minimal coordinates `model!` derived: the expanded
//! state against every constraint, `B = dV/du` and `c` against both
//! references, the fused right-hand side against the expansion and
//! Maggi's equations apart; and the notes on the pivots.

use ezy_core::{Model, Scalar};
use num_dual::Dual64;

use super::{Acc, FD_STEP, max_abs_of, times};

/// One line per pivot of the minimal coordinates of `model` at its
/// parameters: the skate, the body-frame velocity it fixes and the pivot;
/// for an angular rate, the pivot \[m\] and its ratio to the body's
/// radius of gyration `sqrt(I / m)`, which the
/// reduced formulation needs to be at least
/// [`ezy_core::formulation::reduced::MIN_PIVOT_GYRATION`] (docs/physics.md §6.2); or
/// the reason `model!` derived none.
pub fn minimal_notes<M: Model>(model: &M) -> Vec<String> {
    let info = model.info();
    let layout = match model.minimal_layout() {
        Ok(layout) => layout,
        Err(why) => return vec![format!("no minimal coordinates: {why}")],
    };
    let mut mass = vec![0.0; info.nq()];
    model.mass_diagonal(&mut mass);
    let refused = ezy_core::formulation::reduced::small_pivot(&info, &mass, &layout).map(|p| p.0.to_string());
    let mut notes: Vec<String> = layout
        .pivots
        .iter()
        .map(|(skate, j, p)| {
            if j % 3 != 2 {
                // a translational speed: a dimensionless pivot, no gyration
                let body = info.bodies.iter().find(|b| b.coords[j % 3] == *j).map_or("?", |b| b.name.as_str());
                let axis = ["forward", "lateral"][j % 3];
                return format!("skate `{skate}` fixes the {axis} velocity of `{body}` in its frame with pivot {p:.4}");
            }
            let fixes = format!("skate `{skate}` fixes `{}d` with pivot {p:.4} m", info.coords[*j]);
            let body = info.bodies.iter().find(|b| b.coords[2] == *j);
            let rho = body.map(|b| (b.name.as_str(), (mass[*j] / mass[b.coords[0]]).sqrt()));
            match rho {
                Some((name, rho)) if rho.is_finite() && rho > 0.0 => {
                    format!("{fixes}, {:.3} of the radius of gyration {rho:.4} m of `{name}`", p.abs() / rho)
                }
                _ => fixes,
            }
        })
        .collect();
    notes.insert(
        0,
        match refused {
            Some(skate) => format!(
                "minimal coordinates refused at these parameters: the pivot of skate `{skate}` is below {} of its body's radius of gyration (--formulation reduced takes a numeric partition, auto the DAE)",
                ezy_core::formulation::reduced::MIN_PIVOT_GYRATION
            ),
            None => format!(
                "minimal coordinates: {} coordinates, {} speeds; every pivot at least {} of its body's radius of gyration",
                layout.coords.len(),
                layout.speeds.len(),
                ezy_core::formulation::reduced::MIN_PIVOT_GYRATION
            ),
        },
    );
    notes
}

/// The minimal coordinates' expansion at `(q, v)`, `v` holding the
/// body-frame speeds: the expansion keeps the kept coordinates and the
/// speeds and satisfies the constraints (`phi = 0`, `G qd = 0` against
/// zero), the state alone ([`Model::minimal_state`]) equals it exactly,
/// `B = dV/du` by seeding each speed (central differences and
/// dual numbers), `c` (the body-frame acceleration at `u' = 0`) by moving
/// the kept coordinates along `pd` at fixed `u` and adding the frame's
/// turning, and the frames' `cos phi, sin phi` exactly.
pub(super) fn check_minimal<M: Model>(
    m: &M,
    layout: &ezy_core::MinimalLayout,
    q: &[f64],
    v: &[f64],
    s: usize,
    (kept, b_acc, c_acc, fused): &mut (Acc, [Acc; 2], [Acc; 2], Acc),
) {
    let info = m.info();
    let (nq, nu) = (q.len(), layout.speeds.len());
    let nc = nq + 2 * (nq / 3);
    let expand = |q: &[f64], v: &[f64]| {
        let (mut q, mut qd, mut b, mut c) = (q.to_vec(), v.to_vec(), vec![0.0; nq * nu], vec![0.0; nc]);
        m.minimal_expand(&mut q, &mut qd, &mut b, &mut c);
        (q, qd, b, c)
    };
    // the body-frame velocities of the expansion of (q, v)
    let expand_dual = |q: Vec<Dual64>, v: Vec<Dual64>| {
        let (mut q, mut qd) = (q, v);
        let (mut b, mut c) = (vec![Dual64::from(0.0); nq * nu], vec![Dual64::from(0.0); nc]);
        m.minimal_expand(&mut q, &mut qd, &mut b, &mut c);
        body_frame(&q, &qd)
    };
    let (q0, qd0, b, c) = expand(q, v);
    let v0 = body_frame(&q0, &qd0);
    let mut phi = vec![0.0; info.n_holonomic];
    m.phi(&q0, &mut phi);
    let mut vals = vec![0.0; info.pattern.len()];
    m.constraint_matrix(&q0, &mut vals);
    let gqd = times(&info, &vals, &qd0);
    // each residual against the size of the terms that cancel in it: the
    // coordinates for phi, sum_k |G_ik qd_k| for G qd (a small pivot makes
    // the expanded rates large and their rounding with them)
    let abs = |v: &[f64]| v.iter().map(|x| x.abs()).collect::<Vec<f64>>();
    let q_size = vec![max_abs_of(&q0).max(1.0); phi.len()];
    let gqd_size = times(&info, &abs(&vals), &abs(&qd0));
    for (what, rows, size) in [("phi", &phi, &q_size), ("G qd", &gqd, &gqd_size)] {
        for (i, (r, w)) in rows.iter().zip(size.iter()).enumerate() {
            kept.add(r / w.max(1.0), 0.0, || {
                format!("state {s}, {what}[{}] at the expanded state (scaled)", info.constraints[i])
            });
        }
    }
    let coord = |j: usize| info.coords[j].as_str();
    // the state alone (a dense-output sample's, `minimal_state`) is the
    // expansion's to the bit: the same expressions without B and c
    let (mut qs, mut qds) = (q.to_vec(), v.to_vec());
    if m.minimal_state(&mut qs, &mut qds) {
        for j in 0..nq {
            kept.add(qs[j] - q0[j], 0.0, || format!("state {s}, minimal_state q {}", coord(j)));
            kept.add(qds[j] - qd0[j], 0.0, || format!("state {s}, minimal_state qd {}", coord(j)));
        }
    }
    // the kept coordinates and the speeds come back as they went in
    for &j in &layout.coords {
        kept.add(q0[j] - q[j], 0.0, || format!("state {s}, kept coordinate {}", coord(j)));
    }
    for &u in &layout.speeds {
        kept.add((v0[u] - v[u]) / v[u].abs().max(1.0), 0.0, || format!("state {s}, speed {} (body frame)", coord(u)));
    }
    // each body's cos, sin behind c's nq entries, as the forces use them
    for i in 0..nq / 3 {
        let (sn, cs) = q0[3 * i + 2].sin_cos();
        kept.add(c[nq + 2 * i] - cs, 0.0, || format!("state {s}, c's cos {}", coord(3 * i + 2)));
        kept.add(c[nq + 2 * i + 1] - sn, 0.0, || format!("state {s}, c's sin {}", coord(3 * i + 2)));
    }
    let h = FD_STEP;
    for (k, &u) in layout.speeds.iter().enumerate() {
        let seeded = |d: f64| {
            let mut w = v0.clone();
            w[u] += d;
            let (qq, qd, ..) = expand(&q0, &w);
            body_frame(&qq, &qd)
        };
        let (p, mn) = (seeded(h), seeded(-h));
        let mut vk: Vec<Dual64> = v0.iter().map(|&x| Dual64::from(x)).collect();
        vk[u].eps = 1.0;
        let dual = expand_dual(q0.iter().map(|&x| Dual64::from(x)).collect(), vk);
        for j in 0..nq {
            let at = || format!("state {s}, B[V {}, {}]", coord(j), coord(u));
            b_acc[0].add(b[j * nu + k], (p[j] - mn[j]) / (2.0 * h), at);
            b_acc[1].add(b[j * nu + k], dual[j].eps, at);
        }
    }
    // along pd at fixed u: the kept coordinates move, the rest follow; the
    // difference steps along pd / scale, a direction of unit size, so its
    // truncation error stays that of the module docs for fast states
    let scale = layout.coords.iter().fold(1.0f64, |a, &j| a.max(qd0[j].abs()));
    let moved = |d: f64| {
        let mut w = q0.clone();
        for &j in &layout.coords {
            w[j] += d * qd0[j] / scale;
        }
        let (qq, qd, ..) = expand(&w, &v0);
        body_frame(&qq, &qd)
    };
    let (p, mn) = (moved(h), moved(-h));
    let mut qe: Vec<Dual64> = q0.iter().map(|&x| Dual64::from(x)).collect();
    for &j in &layout.coords {
        qe[j].eps = qd0[j];
    }
    let dual = expand_dual(qe, v0.iter().map(|&x| Dual64::from(x)).collect());
    for j in 0..nq {
        // the frame's turning: (-w v_y, w v_x, 0)
        let w = v0[3 * (j / 3) + 2];
        let turning = match j % 3 {
            0 => -w * v0[j + 1],
            1 => w * v0[j - 1],
            _ => 0.0,
        };
        let at = || format!("state {s}, c[V {}]", coord(j));
        c_acc[0].add(c[j], scale * (p[j] - mn[j]) / (2.0 * h) + turning, at);
        c_acc[1].add(c[j], dual[j].eps + turning, at);
    }
    check_fused(m, layout, (&q0, &qd0, v), (&b, &c), s, fused);
}

/// The fused right-hand side ([`Model::minimal_rhs`]), where the model has
/// one and the run would take it (every pivot fit at these parameters,
/// [`ezy_core::formulation::reduced::small_pivot`]), against the expansion and Maggi's
/// equations apart ([`Model::minimal_expand`], [`Model::minimal_maggi`])
/// at the state `(q0, qd0)` expanded from the speeds `v` (body-frame
/// velocities, read at the independent speeds) with its `b`, `c`, under
/// an applied force that loads every coordinate and a torque at every
/// hinge (given apart, [`Model::minimal_rhs`]'s `tau`, one per entry of
/// `ModelInfo::hinges`): the full state exactly,
/// the kept coordinates' rates exactly, and `u'` by the residual of the
/// separate Maggi equations, `|B^T M B u' - B^T (F - M c)|` divided by the
/// size of the terms that cancel in it, `sum_k |A_ik u'_k|` and
/// `sum_j |B_ji| (|F_j| + |m_j c_j|)`: a backward error, independent of the
/// conditioning of `B^T M B` (a skate 1 mm from its hinge makes it 1e6).
fn check_fused<M: Model>(
    m: &M,
    layout: &ezy_core::MinimalLayout,
    (q0, qd0, v): (&[f64], &[f64], &[f64]),
    (b, c): (&[f64], &[f64]),
    s: usize,
    acc: &mut Acc,
) {
    let Some(k) = m.minimal_constants() else { return };
    let info = m.info();
    let (nq, np, nu) = (q0.len(), layout.coords.len(), layout.speeds.len());
    let mut mass = vec![0.0; nq];
    m.mass_diagonal(&mut mass);
    if ezy_core::formulation::reduced::small_pivot(&info, &mass, layout).is_some() {
        return;
    }
    let coord = |j: usize| info.coords[j].as_str();
    let force: Vec<f64> = (0..nq).map(|j| 10.0 * (1.3 * j as f64 + s as f64).sin()).collect();
    let mut z: Vec<f64> = layout.coords.iter().map(|&j| q0[j]).collect();
    z.extend(layout.speeds.iter().map(|&j| v[j]));
    let (mut q, mut qd, mut dz) = (vec![f64::NAN; nq], vec![f64::NAN; nq], vec![f64::NAN; np + nu]);
    // a torque at every hinge as well, given apart (the model maps it at
    // compile time) and added into the separate equations' force
    let torque: Vec<f64> = (0..info.hinges.len()).map(|h| 5.0 * (0.7 * h as f64 + s as f64).cos()).collect();
    let mut hinge_slots = 0;
    let res = m.minimal_rhs(&k, &z, &mut q, &mut qd, &mut dz, |_, _, f: &mut [f64], tau: &mut [f64]| {
        f.copy_from_slice(&force);
        hinge_slots = tau.len();
        for (slot, &v) in tau.iter_mut().zip(&torque) {
            *slot = v;
        }
        Ok::<(), ()>(())
    });
    if hinge_slots != torque.len() {
        acc.add(f64::INFINITY, 0.0, || {
            format!(
                "state {s}, the fused right-hand side takes {hinge_slots} hinge torques, the model has {}",
                torque.len()
            )
        });
        return;
    }
    // the force with the torques added, and the size of its terms
    let (mut force, mut force_size) = (force.clone(), force.iter().map(|f| f.abs()).collect::<Vec<f64>>());
    for (hi, &tau) in info.hinges.iter().zip(&torque) {
        for (body, sign) in std::iter::once((hi.body_a, 1.0)).chain(hi.body_b.map(|b| (b, -1.0))) {
            let phi = info.bodies[body].coords[2];
            force[phi] += sign * tau;
            force_size[phi] += tau.abs();
        }
    }
    if let Err(e) = res {
        acc.add(f64::INFINITY, 0.0, || format!("state {s}, the fused right-hand side failed: {e:?}"));
        return;
    }
    for j in 0..nq {
        acc.add(q[j], q0[j], || format!("state {s}, fused q {}", coord(j)));
        acc.add(qd[j], qd0[j], || format!("state {s}, fused qd {}", coord(j)));
    }
    for (i, &j) in layout.coords.iter().enumerate() {
        acc.add(dz[i], qd0[j], || format!("state {s}, fused rate of {}", coord(j)));
    }
    let (mut a, mut r) = (vec![0.0; nu * nu], vec![0.0; nu]);
    m.minimal_maggi(&mass, b, c, &force, &mut a, &mut r);
    let ud = &dz[np..];
    for i in 0..nu {
        // the lower triangle holds the symmetric matrix
        let at = |i: usize, k: usize| if k <= i { a[i * nu + k] } else { a[k * nu + i] };
        // the size of r's terms B_ji (F_j - m_j c_j), F_j turned into the
        // body's frame (at most |f_x| + |f_y| along either axis)
        let mut size: f64 = (0..nq)
            .map(|j| {
                let (x, y) = (3 * (j / 3), 3 * (j / 3) + 1);
                let fj = if j % 3 == 2 { force_size[j] } else { force_size[x] + force_size[y] };
                b[j * nu + i].abs() * (fj + (mass[j] * c[j]).abs())
            })
            .sum();
        let mut lhs = 0.0;
        for (k, &x) in ud.iter().enumerate() {
            lhs += at(i, k) * x;
            size += (at(i, k) * x).abs();
        }
        acc.add((lhs - r[i]) / size.max(1.0), 0.0, || format!("state {s}, fused u' {}", coord(layout.speeds[i])));
    }
    check_lean(m, &k, &z, q0, qd0, &torque, s, acc);
}

/// [`Model::minimal_rhs_lean`] (an integrator stage's evaluation, whose
/// forces are hinge torques) against [`Model::minimal_rhs`] with the
/// same torques: the same `dz` bit for bit, and the headings (each body's
/// angle and angular rate, what a hinge torque reads) those of the state
/// `(q0, qd0)`, both when the torques are asked for and after.
#[expect(
    clippy::too_many_arguments,
    reason = "the state, the torques and the accumulator of one check, as the fused right-hand side takes them"
)]
fn check_lean<M: Model>(m: &M, k: &[f64], z: &[f64], q0: &[f64], qd0: &[f64], torque: &[f64], s: usize, acc: &mut Acc) {
    let info = m.info();
    let nq = q0.len();
    let headings: Vec<usize> = info.bodies.iter().map(|b| b.coords[2]).collect();
    let run = |lean: bool| {
        let (mut q, mut qd, mut dz) = (vec![f64::NAN; nq], vec![f64::NAN; nq], vec![f64::NAN; z.len()]);
        let mut seen = Vec::new();
        let torques = |q: &[f64], qd: &[f64], _: &mut [f64], tau: &mut [f64]| {
            seen = headings.iter().map(|&j| (q[j], qd[j])).collect();
            tau.copy_from_slice(torque);
            Ok::<(), ()>(())
        };
        let res = if lean {
            m.minimal_rhs_lean(k, z, &mut q, &mut qd, &mut dz, torques)
        } else {
            m.minimal_rhs(k, z, &mut q, &mut qd, &mut dz, torques)
        };
        (res, dz, seen, headings.iter().map(|&j| (q[j], qd[j])).collect::<Vec<_>>())
    };
    let (full, lean) = (run(false), run(true));
    if full.0.is_err() || lean.0.is_err() {
        acc.add(f64::INFINITY, 0.0, || format!("state {s}, the lean right-hand side failed: {:?}", lean.0));
        return;
    }
    for (i, (a, b)) in lean.1.iter().zip(&full.1).enumerate() {
        let exact = if a.to_bits() == b.to_bits() { 0.0 } else { f64::INFINITY };
        acc.add(exact, 0.0, || format!("state {s}, lean dz[{i}] {a:e} against {b:e}"));
    }
    for (at, pairs) in [("when the torques are asked", &lean.2), ("after", &lean.3)] {
        for (&j, &(qj, qdj)) in headings.iter().zip(pairs.iter()) {
            let name = info.coords[j].as_str();
            acc.add(qj, q0[j], || format!("state {s}, lean q {name} {at}"));
            acc.add(qdj, qd0[j], || format!("state {s}, lean qd {name} {at}"));
        }
    }
}

/// The body-frame velocities `V` (nq) of the global rates `qd` (nq) at
/// `q`, each by [`ezy_core::formulation::reduced::body_velocity`].
fn body_frame<S: Scalar>(q: &[S], qd: &[S]) -> Vec<S> {
    (0..qd.len()).map(|j| ezy_core::formulation::reduced::body_velocity(q, qd, j)).collect()
}
