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

#[cfg(feature = "jit")]
pub(crate) mod jit;
#[cfg(not(feature = "jit"))]
#[path = "no_jit.rs"]
pub(crate) mod jit;

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

    /// `r += coef * x`, rounded as `model!`'s code rounds it, output `k`
    /// at `out[k - from]`.
    #[inline]
    fn add_to(self, r: &mut f64, x: f64, out: &[f64], from: usize) {
        match self {
            Coef::One => *r += x,
            Coef::MinusOne => *r -= x,
            Coef::At(k) => *r += out[k - from] * x,
        }
    }
}

/// A body's heading `cos`, `sin` (outputs of [`Fused::forces`]) and its
/// rows of `B`: per body-frame velocity `3 b + axis`, `(speed i, B_ji)`
/// where not zero.
type BodyRows = ([usize; 2], [Vec<(usize, Coef)>; 3]);

/// The plan of the fused right-hand side.
#[derive(Debug)]
pub(super) struct Fused {
    /// Outputs: `B^T M B`'s lower triangle by rows (nu (nu + 1) / 2),
    /// `-B^T M c` (nu), the hinges' coefficients [`Coef::At`] points to
    /// (`n_maggi` in all), then the eliminated coordinates `q_dep.0`
    /// lists and the global rates `qd_at` lists; its parameter-only
    /// subexpressions read from the values of `table` ([`Tape::hoisted`]).
    tape: Tape,
    /// The same for an integrator's stage ([`crate::Model::minimal_rhs_lean`]):
    /// of the eliminated coordinates and rates only the headings', and the
    /// kept coordinates' rates.
    lean: Tape,
    /// The frames' `cos`, `sin` and the body rows' coefficients, wanted
    /// only where a body has an applied force.
    forces: Tape,
    table: Tape,
    nq: usize,
    nu: usize,
    n_maggi: usize,
    /// Where the eliminated coordinates and rates go in `q` and `qd`: for
    /// `tape`, then for `lean`.
    full_at: (Vec<usize>, Vec<usize>),
    lean_at: (Vec<usize>, Vec<usize>),
    /// Per body, its frame and rows (coefficients in `forces`' outputs).
    bodies: Vec<BodyRows>,
    /// Per hinge, `(speed i, coefficient)` where not zero.
    hinges: Vec<Vec<(usize, Coef)>>,
    /// The lengths of the tapes' working space's parts ([`tapes_work`]).
    work: [usize; 5],
    /// The parameters and table values the tapes read (the largest index
    /// read, plus one).
    reach: (usize, usize),
    /// Values the state kernel keeps for the solve: the Maggi terms, and
    /// the frames and rows where they read velocities.
    #[cfg(feature = "jit")]
    kept: usize,
    /// The whole right-hand side compiled, once the model's tapes are
    /// compiled.
    #[cfg(feature = "jit")]
    kernels: std::sync::OnceLock<jit::Kernels>,
}

impl Fused {
    /// The plan from the minimal form `m` and its Maggi terms.
    pub(super) fn new(ar: &Arena, m: &Minimal, maggi: &Maggi) -> Self {
        let (nq, nu) = (m.qd.len(), m.speeds.len());
        let coef = |id: Id, outputs: &mut Vec<Id>| {
            let c = Coef::of(ar, id, outputs.len());
            if let Some(Coef::At(_)) = c {
                outputs.push(id);
            }
            c
        };
        let mut head: Vec<Id> = maggi.a.clone();
        head.extend(&maggi.minus_bmc);
        let hinges = maggi
            .hinge
            .iter()
            .map(|row| row.iter().enumerate().filter_map(|(i, &e)| coef(e, &mut head).map(|c| (i, c))).collect())
            .collect();
        let n_maggi = head.len();
        // what a stage keeps: the headings, and the kept coordinates' rates
        let heading = |j: usize| j % 3 == 2;
        let state = |keep: &dyn Fn(usize) -> bool| {
            let dep: Vec<(usize, Id)> = m.q_dep.iter().copied().filter(|p| keep(p.0)).collect();
            let rates: Vec<usize> = (0..nq).filter(|&j| keep(j) || m.coords.contains(&j)).collect();
            let mut out = head.clone();
            out.extend(dep.iter().map(|p| p.1));
            out.extend(rates.iter().map(|&j| m.qd[j]));
            (out, (dep.iter().map(|p| p.0).collect::<Vec<_>>(), rates))
        };
        let (full_out, full_at) = state(&|_| true);
        let (lean_out, lean_at) = state(&heading);
        let mut forces: Vec<Id> = Vec::new();
        let mut bodies = Vec::with_capacity(nq / 3);
        for b in 0..nq / 3 {
            let frame = [forces.len(), forces.len() + 1];
            forces.extend([m.frames[2 * b], m.frames[2 * b + 1]]);
            let rows = [0, 1, 2].map(|axis| {
                let j = 3 * b + axis;
                (0..nu).filter_map(|i| coef(maggi.b[j * nu + i], &mut forces).map(|c| (i, c))).collect()
            });
            bodies.push((frame, rows));
        }
        let (table, mut tapes) = Tape::hoisted(ar, &[&full_out, &lean_out, &forces]);
        let forces = tapes.pop().expect("three tapes");
        let lean = tapes.pop().expect("three tapes");
        let tape = tapes.pop().expect("three tapes");
        // the register machine leaves `B^T M B`'s lower triangle where the
        // solve reads it (an nu x nu matrix by rows), the rest after it
        let n_lower = nu * (nu + 1) / 2;
        let place = |k: usize| {
            let i = (0..nu).find(|&i| k < (i + 1) * (i + 2) / 2).map_or(nu, |i| i);
            (if k < n_lower { i * nu + k - i * (i + 1) / 2 } else { k - n_lower + nu * nu }) as u32
        };
        let placed = |t: Tape| {
            let places: Vec<u32> = (0..t.outputs()).map(place).collect();
            t.with_places(&places)
        };
        let (tape, lean) = (placed(tape), placed(lean));
        let reach = [&tape, &lean, &forces]
            .iter()
            .map(|t| t.input_reach())
            .fold((0, 0), |(p, k), (tp, tk)| (p.max(tp), k.max(tk)));
        let regs = tape.registers().max(lean.registers());
        let work = [regs, forces.registers(), nq, maggi.hinge.len(), nu * (nu + 1)];
        Self {
            #[cfg(feature = "jit")]
            kept: n_maggi + if forces.reads_velocities() { forces.outputs() } else { 0 },
            tape,
            lean,
            forces,
            table,
            nq,
            nu,
            n_maggi,
            full_at,
            lean_at,
            bodies,
            hinges,
            work,
            reach,
            #[cfg(feature = "jit")]
            kernels: Default::default(),
        }
    }

    /// The fused tape (`lean`: an integrator stage's).
    fn tape(&self, lean: bool) -> &Tape {
        if lean { &self.lean } else { &self.tape }
    }

    /// The tapes the compiled whole right-hand side replaces.
    #[cfg(feature = "jit")]
    pub(super) fn kernel_tapes(&self) -> [&Tape; 3] {
        [&self.tape, &self.lean, &self.forces]
    }

    /// Values the state kernel keeps for the solve: the Maggi terms, and
    /// the frames and rows where they read velocities.
    #[cfg(feature = "jit")]
    #[inline]
    fn kept(&self) -> usize {
        self.kept
    }

    /// Whether the whole right-hand side is compiled.
    #[cfg(feature = "jit")]
    pub(super) fn compiled(&self) -> bool {
        self.kernels.get().is_some()
    }

    /// Sets the compiled whole right-hand side (once; later calls are
    /// ignored).
    #[cfg(feature = "jit")]
    pub(super) fn set_kernels(&self, k: jit::Kernels) {
        let _ = self.kernels.set(k);
    }

    /// The compiled whole right-hand side, if `x` may take it: compiled,
    /// and the state and the inputs as long as the kernels read them.
    #[inline]
    fn kernels_for(&self, x: &FusedCall<'_>, z: &[f64], q: &[f64], qd: &[f64], dz: &[f64]) -> Option<&jit::Kernels> {
        #[cfg(feature = "jit")]
        let k = self.kernels.get()?;
        #[cfg(not(feature = "jit"))]
        let k: &jit::Kernels = None?;
        let n = x.coords.len() + self.nu;
        let fits = x.compiled
            && z.len() >= n
            && dz.len() >= n
            && q.len() == self.nq
            && qd.len() == self.nq
            && x.params.len() >= self.reach.0
            && x.table.len() >= self.reach.1;
        fits.then_some(k)
    }

    /// The tapes (for the model's list of tapes).
    pub(super) fn tapes(&self) -> [&Tape; 4] {
        [&self.tape, &self.lean, &self.forces, &self.table]
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

impl FusedCall<'_> {
    /// What the tapes read: the state `q`, `qd` as they are now.
    fn inputs<'a>(&'a self, q: &'a [f64], qd: &'a [f64]) -> Inputs<'a, f64> {
        Inputs { params: self.params, indices: self.table, cols: self.cols, q, qd, compiled: self.compiled }
    }
}

/// [`crate::Model::minimal_rhs`] on the plan `x.fused` (`lean`: what
/// [`crate::Model::minimal_rhs_lean`] writes): by the compiled kernels
/// where there are ([`Fused::kernels_for`]), else by the tapes. Both
/// meet `forces` at one call, so that the compiler inlines it.
pub(super) fn rhs<E, F>(
    x: &FusedCall<'_>,
    lean: bool,
    z: &[f64],
    q: &mut [f64],
    qd: &mut [f64],
    dz: &mut [f64],
    forces: F,
) -> Result<(), MinimalRhsError<E>>
where
    F: FnOnce(&[f64], &[f64], &mut [f64], &mut [f64]) -> Result<(), E>,
{
    let compiled = x.fused.kernels_for(x, z, q, qd, dz);
    let mut room = jit::Room::new();
    let mut work = std::mem::ManuallyDrop::new(Vec::new());
    let applied = match compiled {
        Some(k) => jit::state(k, lean, x, z, q, qd, dz, &mut room),
        None => {
            *work = WORK.with(Cell::take);
            tapes_state(x, lean, z, q, qd, dz, &mut work)
        }
    };
    let (f, tau) = applied.split_at_mut(x.fused.nq);
    let res = forces(q, qd, f, tau).map_err(MinimalRhsError::Forces);
    match compiled {
        Some(k) => res.and_then(|()| jit::solve(k, x, q, qd, dz, &mut room).map_err(MinimalRhsError::Maggi)),
        None => {
            let res = res.and_then(|()| tapes_solve(x, q, qd, dz, &mut work).map_err(MinimalRhsError::Maggi));
            // the working space back (it is empty on the compiled path:
            // nothing to drop there)
            WORK.with(|w| w.set(std::mem::ManuallyDrop::into_inner(work)));
            res
        }
    }
}

/// The tapes' working space in `work`, one layout for the full and the
/// lean evaluation: the fused tape's registers (`A`, `r`, the hinges'
/// coefficients, the eliminated coordinates and rates, then the rest:
/// [`Fused::new`] placed them), the frames and rows' registers (their
/// outputs first), `f`, `tau` and the solve's scratch.
#[inline(always)]
fn tapes_work<'w>(p: &Fused, work: &'w mut [f64]) -> [&'w mut [f64]; 5] {
    let [regs, fo, nq, nh, _] = p.work;
    let (regs, rest) = work.split_at_mut(regs);
    let (fo, rest) = rest.split_at_mut(fo);
    let (f, rest) = rest.split_at_mut(nq);
    let (tau, scratch) = rest.split_at_mut(nh);
    [regs, fo, f, tau, scratch]
}

/// [`rhs`] by the tapes' evaluators (the register machine, or a kernel
/// per tape) up to the forces: the state in `q`, `qd`, `dz[..np]`, and
/// in `work` (sized here) the Maggi terms; returns the zeroed `f` and
/// `tau` (in `work`, one after the other) for the forces to add to.
#[inline(never)]
fn tapes_state<'w>(
    x: &FusedCall<'_>,
    lean: bool,
    z: &[f64],
    q: &mut [f64],
    qd: &mut [f64],
    dz: &mut [f64],
    work: &'w mut Vec<f64>,
) -> &'w mut [f64] {
    let p = x.fused;
    let (dep_at, rate_at) = if lean { &p.lean_at } else { &p.full_at };
    let np = x.coords.len();
    let len = p.work.iter().sum();
    if work.len() < len {
        work.resize(len, 0.0);
    }
    let [regs, fo, f, tau, ..] = tapes_work(p, work);
    // the tapes read the kept coordinates in q and the speeds at their
    // body-frame velocities in qd (qd written over below)
    for (i, &j) in x.coords.iter().enumerate() {
        q[j] = z[i];
    }
    for (i, &j) in x.speeds.iter().enumerate() {
        qd[j] = z[np + i];
    }
    p.tape(lean).eval_in(&x.inputs(q, qd), regs);
    // the frames and body rows: where a body has a force (below), or now
    // should they read velocities, which `forces` writes over
    if p.forces.reads_velocities() {
        p.forces.eval_in(&x.inputs(q, qd), fo);
    }
    let n_lower = p.nu * (p.nu + 1) / 2;
    let (deps, rates) = regs[p.nu * p.nu + p.n_maggi - n_lower..].split_at(dep_at.len());
    for (&j, &v) in dep_at.iter().zip(deps) {
        q[j] = v;
    }
    for (&j, &v) in rate_at.iter().zip(rates) {
        qd[j] = v;
    }
    for (i, &j) in x.coords.iter().enumerate() {
        dz[i] = qd[j];
    }
    // `forces` adds to zeros
    f.fill(0.0);
    tau.fill(0.0);
    let at = p.work[0] + p.work[1];
    &mut work[at..at + p.nq + p.hinges.len()]
}

/// [`rhs`] by the tapes after the forces: `dz[np..]` from `work` as
/// [`tapes_state`] and the forces left it.
///
/// # Errors
/// The solve's ([`crate::kkt::spd::ldl_solve`]).
#[inline(never)]
fn tapes_solve(
    x: &FusedCall<'_>,
    q: &[f64],
    qd: &[f64],
    dz: &mut [f64],
    work: &mut [f64],
) -> Result<(), crate::error::KktError> {
    let p = x.fused;
    let (nu, np) = (p.nu, x.coords.len());
    let [regs, fo, f, tau, scratch] = tapes_work(p, work);
    // where the tape left them: `B^T M B` below the diagonal of `a` (read
    // there only), `-B^T M c` in `r` (added to here), then the hinges'
    // coefficients (from Maggi term `nu (nu + 1) / 2 + nu` on)
    let (a, rest) = regs.split_at_mut(nu * nu);
    let (r, coefs) = rest.split_at_mut(nu);
    let from = nu * (nu + 1) / 2 + nu;
    let mut framed = p.forces.reads_velocities();
    for (b, (frame, rows)) in p.bodies.iter().enumerate() {
        let (x_, y_, w) = (3 * b, 3 * b + 1, 3 * b + 2);
        let pushed = f[x_] != 0.0 || f[y_] != 0.0;
        if (pushed || f[w] != 0.0) && !framed {
            p.forces.eval_in(&x.inputs(q, qd), fo);
            framed = true;
        }
        if pushed {
            let (c, s) = (fo[frame[0]], fo[frame[1]]);
            let (fx, fy) = (c * f[x_] + s * f[y_], c * f[y_] - s * f[x_]);
            for (axis, fj) in [(0, fx), (1, fy)] {
                for &(i, coef) in &rows[axis] {
                    coef.add_to(&mut r[i], fj, fo, 0);
                }
            }
        }
        if f[w] != 0.0 {
            for &(i, coef) in &rows[2] {
                coef.add_to(&mut r[i], f[w], fo, 0);
            }
        }
    }
    for (hinge, row) in p.hinges.iter().enumerate() {
        if tau[hinge] != 0.0 {
            for &(i, coef) in row {
                coef.add_to(&mut r[i], tau[hinge], coefs, from);
            }
        }
    }
    crate::kkt::spd::ldl_solve(a, nu, nu, r, &mut dz[np..np + nu], scratch).map(|_| ())
}
