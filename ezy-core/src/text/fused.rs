//! The fused right-hand side on the minimal coordinates of a model read
//! from text ([`crate::Model::minimal_rhs`]): one tape computes, from the
//! kept coordinates and the independent speeds, the eliminated
//! coordinates, the global rates and every term of Maggi's equations
//! (`B^T M B`, `-B^T M c`, `B`, the frames, the hinges' rows, as
//! `ezy_lang::minimal::maggi` derives them for `model!`); the applied
//! forces are added in the body frames as `model!`'s code adds them, and
//! `B^T M B u' = B^T (F - M c)` is solved by the same LDL^T. The
//! parameter-only subexpressions `model!` hoists into a table are
//! recomputed here at each evaluation (the same values up to rounding).

use std::cell::Cell;

use ezy_lang::minimal::{Maggi, Minimal};
use ezy_lang::sym::{Arena, Id};

use super::tape::{Inputs, Tape};
use crate::model::MinimalRhsError;
use crate::scalar::Scalar;

/// A coefficient of `B` or of a hinge's row: known when the model is read
/// (`model!` writes `+ f`, `- f` or skips a zero), or output `k` of
/// [`Fused::tape`].
#[derive(Clone, Copy, Debug)]
enum Coef {
    One,
    MinusOne,
    At(usize),
}

impl Coef {
    /// `None` for a zero.
    fn of(ar: &Arena, id: Id, at: usize) -> Option<Self> {
        match ar.as_const(id) {
            Some(0.0) => None,
            Some(1.0) => Some(Coef::One),
            Some(-1.0) => Some(Coef::MinusOne),
            _ => Some(Coef::At(at)),
        }
    }

    /// `r += coef * x`, rounded as `model!`'s code rounds it.
    #[inline]
    fn add_to(self, r: &mut f64, x: f64, out: &[f64]) {
        match self {
            Coef::One => *r += x,
            Coef::MinusOne => *r -= x,
            Coef::At(k) => *r += out[k] * x,
        }
    }
}

/// A body's heading `cos`, `sin` (outputs) and its rows of `B`: per
/// body-frame velocity `3 b + axis`, `(speed i, B_ji)` where not zero.
type BodyRows = ([usize; 2], [Vec<(usize, Coef)>; 3]);

/// The plan of the fused right-hand side.
#[derive(Debug)]
pub(super) struct Fused {
    /// Outputs: the eliminated coordinates (`q_dep`'s order), the global
    /// rates (nq), `B^T M B`'s lower triangle by rows (nu (nu + 1) / 2),
    /// `-B^T M c` (nu), then the coefficients [`Coef::At`] points to;
    /// its parameter-only subexpressions read from the values of `table`
    /// ([`Tape::hoisted`]).
    tape: Tape,
    table: Tape,
    nq: usize,
    nu: usize,
    /// Where output `j < q_dep.len()` goes in `q`.
    q_dep: Vec<usize>,
    /// Per body: `cos`, `sin` of its heading (outputs), and per
    /// body-frame velocity `3 b + axis`, `(speed i, B_ji)` where not zero.
    bodies: Vec<BodyRows>,
    /// Per hinge, `(speed i, coefficient)` where not zero.
    hinges: Vec<Vec<(usize, Coef)>>,
}

impl Fused {
    /// The plan from the minimal form `m` and its Maggi terms.
    pub(super) fn new(ar: &Arena, m: &Minimal, maggi: &Maggi) -> Self {
        let (nq, nu) = (m.qd.len(), m.speeds.len());
        let mut outputs: Vec<Id> = m.q_dep.iter().map(|p| p.1).collect();
        outputs.extend(&m.qd);
        outputs.extend(&maggi.a);
        outputs.extend(&maggi.minus_bmc);
        let coef = |id: Id, outputs: &mut Vec<Id>| {
            let c = Coef::of(ar, id, outputs.len());
            if let Some(Coef::At(_)) = c {
                outputs.push(id);
            }
            c
        };
        let mut bodies = Vec::with_capacity(nq / 3);
        for b in 0..nq / 3 {
            let frame = [outputs.len(), outputs.len() + 1];
            outputs.extend([m.frames[2 * b], m.frames[2 * b + 1]]);
            let rows = [0, 1, 2].map(|axis| {
                let j = 3 * b + axis;
                (0..nu).filter_map(|i| coef(maggi.b[j * nu + i], &mut outputs).map(|c| (i, c))).collect()
            });
            bodies.push((frame, rows));
        }
        let hinges = maggi
            .hinge
            .iter()
            .map(|row| row.iter().enumerate().filter_map(|(i, &e)| coef(e, &mut outputs).map(|c| (i, c))).collect())
            .collect();
        let (table, tape) = Tape::hoisted(ar, &outputs);
        Self { table, tape, nq, nu, q_dep: m.q_dep.iter().map(|p| p.0).collect(), bodies, hinges }
    }

    /// The tapes (for the model's list of tapes).
    pub(super) fn tapes(&self) -> [&Tape; 2] {
        [&self.tape, &self.table]
    }

    /// The table of parameter-only values at the parameters `params`
    /// ([`crate::Model::minimal_constants`]).
    pub(super) fn table(&self, params: &[f64], registers: usize) -> Vec<f64> {
        let mut k = vec![0.0; self.table.outputs()];
        f64::with_scratch(registers, |regs| {
            self.table.eval(&Inputs::fixed(params, &[]), regs, |j, x| k[j] = x);
        });
        k
    }
}

thread_local! {
    /// The fused right-hand side's working space (outputs, forces, Maggi's
    /// matrix and the LDL^T's scratch), kept per thread.
    static WORK: Cell<Vec<f64>> = const { Cell::new(Vec::new()) };
}

/// What [`rhs`] reads besides the state.
pub(super) struct FusedCall<'a> {
    pub(super) fused: &'a Fused,
    pub(super) params: &'a [f64],
    /// [`Fused::table`]'s values.
    pub(super) table: &'a [f64],
    /// Each body's first column (`3 b`).
    pub(super) cols: &'a [usize],
    pub(super) coords: &'a [usize],
    pub(super) speeds: &'a [usize],
    pub(super) compiled: bool,
}

/// [`crate::Model::minimal_rhs`] on the plan `x.fused`.
pub(super) fn rhs<E, F>(
    x: &FusedCall<'_>,
    z: &[f64],
    q: &mut [f64],
    qd: &mut [f64],
    dz: &mut [f64],
    forces: F,
) -> Result<(), MinimalRhsError<E>>
where
    F: FnOnce(&[f64], &[f64], &mut [f64], &mut [f64]) -> Result<(), E>,
{
    let p = x.fused;
    let (nq, nu, np, nh) = (p.nq, p.nu, x.coords.len(), p.hinges.len());
    let n_out = p.tape.outputs();
    let mut work = WORK.with(Cell::take);
    work.resize(n_out + nq + nh + nu * nu + nu + nu * (nu + 1), 0.0);
    let (out, rest) = work.split_at_mut(n_out);
    let (f, rest) = rest.split_at_mut(nq);
    let (tau, rest) = rest.split_at_mut(nh);
    let (a, rest) = rest.split_at_mut(nu * nu);
    let (r, scratch) = rest.split_at_mut(nu);
    // `forces` adds to zeros; `B^T M B` is read below the diagonal only
    f.fill(0.0);
    tau.fill(0.0);
    // the tape reads the kept coordinates in q and the speeds at their
    // body-frame velocities in qd (both written over below)
    for (i, &j) in x.coords.iter().enumerate() {
        q[j] = z[i];
    }
    for (i, &j) in x.speeds.iter().enumerate() {
        qd[j] = z[np + i];
    }
    let inputs = Inputs { params: x.params, indices: x.table, cols: x.cols, q, qd, compiled: x.compiled };
    p.tape.eval_to(&inputs, &mut [], out, &mut []);
    let nd = p.q_dep.len();
    for (&j, &v) in p.q_dep.iter().zip(&out[..nd]) {
        q[j] = v;
    }
    qd[..nq].copy_from_slice(&out[nd..nd + nq]);
    for (i, &j) in x.coords.iter().enumerate() {
        dz[i] = qd[j];
    }
    let res = forces(q, qd, f, tau).map_err(MinimalRhsError::Forces);
    let res = res.and_then(|()| {
        let (lower, minus_bmc) = out[nd + nq..].split_at(nu * (nu + 1) / 2);
        for i in 0..nu {
            let row = &lower[i * (i + 1) / 2..];
            a[i * nu..=i * nu + i].copy_from_slice(&row[..=i]);
        }
        r.copy_from_slice(&minus_bmc[..nu]);
        for (b, (frame, rows)) in p.bodies.iter().enumerate() {
            let (x_, y_, w) = (3 * b, 3 * b + 1, 3 * b + 2);
            if f[x_] != 0.0 || f[y_] != 0.0 {
                let (c, s) = (out[frame[0]], out[frame[1]]);
                let (fx, fy) = (c * f[x_] + s * f[y_], c * f[y_] - s * f[x_]);
                for (axis, fj) in [(0, fx), (1, fy)] {
                    for &(i, coef) in &rows[axis] {
                        coef.add_to(&mut r[i], fj, out);
                    }
                }
            }
            if f[w] != 0.0 {
                for &(i, coef) in &rows[2] {
                    coef.add_to(&mut r[i], f[w], out);
                }
            }
        }
        for (hinge, row) in p.hinges.iter().enumerate() {
            if tau[hinge] != 0.0 {
                for &(i, coef) in row {
                    coef.add_to(&mut r[i], tau[hinge], out);
                }
            }
        }
        crate::kkt::spd::ldl_solve(a, nu, nu, r, &mut dz[np..np + nu], scratch)
            .map(|_| ())
            .map_err(MinimalRhsError::Maggi)
    });
    WORK.with(|w| w.set(work));
    res
}
