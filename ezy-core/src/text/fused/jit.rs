//! The fused right-hand side compiled whole: per plan, two Cranelift
//! functions around the call of the applied forces, with no Rust between
//! the kernels.
//!
//! They do what [`super::rhs`] does, operation for operation, so that
//! the numbers are the same bit for bit. [`StateKernel`] (one full, one
//! for an integrator's stage, lean) scatters the state into `q`, `qd`,
//! runs the fused tape (the values it stored are used where a later read
//! would load them), writes the eliminated coordinates, the rates and
//! `dz`'s coordinate part, and keeps the Maggi terms for the second.
//! Then the caller's closure adds the applied forces in Rust, where the
//! compiler inlines it as in the compiled model (every law, a user's own
//! included, runs as it runs there). [`SolveKernel`] turns each body's
//! force into its frame and adds each hinge's torque where it is not
//! zero (a `select` where the Rust code branches: the same bits), and
//! solves `B^T M B u' = r` by [`crate::kkt::spd::ldl_solve`]'s own
//! sequence of operations for `nu <= 8` (the explicit 2 x 2 and 4 x 4
//! block inverses, else the unrolled `L D L^T`). A pivot that solve would
//! refuse sends `A` and `r` back to the caller, which refuses it with
//! `ldl_solve`'s own error.

use std::collections::HashMap;
use std::mem::MaybeUninit;

use cranelift_codegen::ir::condcodes::{FloatCC, IntCC};
use cranelift_codegen::ir::{self, AbiParam, InstBuilder, MemFlags, Value, types};
use cranelift_frontend::FunctionBuilder;

use super::{Coef, Fused, FusedCall};
use crate::kkt::spd::PIVOT_RTOL;
use crate::text::tape::jit::{Extra, Input, Refs, emit, offset};

/// `state(params, table, z, q, qd, dz, keep)`: `q`, `qd` and `dz[..np]`
/// from `z`, and into `keep` the Maggi terms (and the frames, where they
/// read the velocities before they are written), then `nq + nh` zeros for
/// the forces.
///
/// # Safety
/// `params` and `table` hold what the plan's tapes read, `z` and `dz`
/// hold `np + nu` values, `q` and `qd` hold `nq`, `keep`
/// [`Fused::kept`] `+ nq + nh`.
pub(crate) type StateKernel =
    unsafe extern "C" fn(*const f64, *const f64, *const f64, *mut f64, *mut f64, *mut f64, *mut f64);

/// `solve(params, table, q, qd, keep, dz)`: `dz[np..]` from what `state`
/// kept and the applied forces after it (`f`, nq, then `tau`, one per
/// hinge); returns [`DONE`], or [`REFUSED`] with `A` and `r` after the
/// forces (the spill).
///
/// # Safety
/// As [`StateKernel`], with `keep` as it left it (the forces added to)
/// and room for `nu (nu + 1)` more values after the forces.
pub(crate) type SolveKernel =
    unsafe extern "C" fn(*const f64, *const f64, *const f64, *const f64, *mut f64, *mut f64) -> i32;

/// `dz` written.
const DONE: i32 = 0;
/// A pivot of the solve was refused: `spill` holds `A` (nu x nu,
/// row-major) and then `r` (nu).
const REFUSED: i32 = 2;

/// The most speeds compiled: [`crate::kkt::spd::ldl_solve`] unrolls up to
/// 8, and larger systems take the Rust code (the loop is no faster
/// compiled).
pub(crate) const MAX_SPEEDS: usize = 8;

/// The working space of one call, on the stack \[values\]: what `state`
/// keeps, the forces and the spill; a plan needing more takes the Rust
/// code.
const ROOM: usize = 256;

/// The compiled kernels of a plan.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Kernels {
    /// Full, then lean.
    pub(crate) state: [StateKernel; 2],
    pub(crate) solve: SolveKernel,
}

/// The kernels to compile for one plan: the plan, and where its state
/// lives.
pub(crate) struct Spec<'a> {
    fused: &'a Fused,
    coords: &'a [usize],
    speeds: &'a [usize],
    /// Each body's first column (`3 b`).
    cols: &'a [usize],
}

/// One of a plan's kernels: `Some(lean)` a state kernel, `None` the solve.
pub(crate) struct Part<'s, 'a>(&'s Spec<'a>, Option<bool>);

impl<'a> Spec<'a> {
    /// The kernels of `fused`, if they can be compiled: at most
    /// [`MAX_SPEEDS`] speeds, the working space within [`ROOM`], and every
    /// coordinate read or written inside `q` and `qd`.
    pub(crate) fn new(fused: &'a Fused, coords: &'a [usize], speeds: &'a [usize], cols: &'a [usize]) -> Option<Self> {
        let (nq, nu) = (fused.nq, fused.nu);
        let inside = |js: &[usize]| js.iter().all(|&j| j < nq);
        let read_inside = |t: &crate::text::tape::Tape| {
            t.state_reads().all(|(_, k)| cols.get(k / 3).is_some_and(|&c| c.checked_add(k % 3).is_some_and(|j| j < nq)))
        };
        let ok = nu <= MAX_SPEEDS
            && speeds.len() == nu
            && fused.kept() + nq + fused.hinges.len() + nu * (nu + 1) <= ROOM
            && inside(coords)
            && inside(speeds)
            && [&fused.full_at, &fused.lean_at].iter().all(|(d, r)| inside(d) && inside(r))
            && [&fused.tape, &fused.lean, &fused.forces].into_iter().all(read_inside);
        ok.then_some(Spec { fused, coords, speeds, cols })
    }

    /// Its three functions: the full state, the lean state, the solve.
    pub(crate) fn parts(&self) -> [Part<'_, 'a>; 3] {
        [Part(self, Some(false)), Part(self, Some(true)), Part(self, None)]
    }

    /// Hands the compiled kernels (`entries`, in [`Spec::parts`]' order)
    /// to the plan.
    ///
    /// # Safety
    /// Each entry is the finalized code of its part.
    pub(crate) unsafe fn set_kernels(&self, entries: &[*const u8]) {
        // SAFETY: as the caller promises: each is a function of its part's
        // signature (`Extra::signature`), the host's `extern "C"`.
        let kernels = unsafe {
            Kernels {
                state: [
                    std::mem::transmute::<*const u8, StateKernel>(entries[0]),
                    std::mem::transmute::<*const u8, StateKernel>(entries[1]),
                ],
                solve: std::mem::transmute::<*const u8, SolveKernel>(entries[2]),
            }
        };
        self.fused.set_kernels(kernels);
    }

    /// Operations it compiles (for the JIT's budget).
    pub(crate) fn ops(&self) -> usize {
        let f = self.fused;
        f.tape.ops() + f.lean.ops() + 2 * f.forces.ops()
    }
}

/// The pointers a kernel reads its inputs through, and the values of `q`
/// and `qd` it stored (read again without a load).
struct State {
    params: Value,
    table: Value,
    q: Value,
    qd: Value,
    known: [HashMap<usize, Value>; 2],
}

impl State {
    /// The value of a tape's input `input`.
    fn input(&self, b: &mut FunctionBuilder, cols: &[usize], input: Input) -> Result<Value, String> {
        let mem = MemFlags::trusted();
        // the parameters and the table do not change during a call: their
        // loads may move to where they are used (past the forces' call,
        // with the arithmetic that reads them), not live across it
        let fixed = mem.with_readonly().with_can_move();
        let (is_qd, k) = match input {
            Input::Param(i) => return Ok(b.ins().load(types::F64, fixed, self.params, offset(i)?)),
            Input::Index(k) => return Ok(b.ins().load(types::F64, fixed, self.table, offset(k)?)),
            Input::Q(k) => (false, k),
            Input::Qd(k) => (true, k),
        };
        let j = cols[k / 3] + k % 3;
        Ok(match self.known[usize::from(is_qd)].get(&j) {
            Some(&v) => v,
            None => b.ins().load(types::F64, mem, if is_qd { self.qd } else { self.q }, offset(j)?),
        })
    }

    /// Stores `v` at `q[j]` (`qd[j]`), and remembers it.
    fn store(&mut self, b: &mut FunctionBuilder, is_qd: bool, j: usize, v: Value) -> Result<(), String> {
        b.ins().store(MemFlags::trusted(), v, if is_qd { self.qd } else { self.q }, offset(j)?);
        self.known[usize::from(is_qd)].insert(j, v);
        Ok(())
    }
}

/// `r + coef x`, rounded as [`Coef::add_to`] rounds it (`vals`: where
/// [`Coef::At`] points).
fn add(b: &mut FunctionBuilder, coef: Coef, r: Value, x: Value, vals: &[Value]) -> Value {
    match coef {
        Coef::One => b.ins().fadd(r, x),
        Coef::MinusOne => b.ins().fsub(r, x),
        Coef::At(k) => {
            let p = b.ins().fmul(vals[k], x);
            b.ins().fadd(r, p)
        }
    }
}

/// `r_i += coef_i x` for each `(i, coef_i)` of `row` where `when` holds
/// (`when`: a truth value; the sums are formed, then kept or not).
fn add_where(
    b: &mut FunctionBuilder,
    r: &mut [Value],
    terms: &[(&[(usize, Coef)], Value)],
    vals: &[Value],
    when: Value,
) {
    let mut cand = r.to_vec();
    for &(row, x) in terms {
        for &(i, coef) in row {
            cand[i] = add(b, coef, cand[i], x, vals);
        }
    }
    for (ri, ci) in r.iter_mut().zip(cand) {
        if ci != *ri {
            *ri = b.ins().select(when, ci, *ri);
        }
    }
}

/// Whether `x` is infinite or NaN (`!x.is_finite()`).
fn not_finite(b: &mut FunctionBuilder, x: Value) -> Value {
    let abs = b.ins().fabs(x);
    let inf = b.ins().f64const(f64::INFINITY);
    b.ins().fcmp(FloatCC::UnorderedOrGreaterThanOrEqual, abs, inf)
}

/// The solve's pivot tests, gathered: each branch to `refuse` where one
/// fails, so that the caller refuses with `ldl_solve`'s own error.
struct Solve {
    refuse: ir::Block,
    rtol: Value,
}

impl Solve {
    /// Goes on where `bad` is false, to `refuse` where it is true.
    fn check(&self, b: &mut FunctionBuilder, bad: Value) {
        let next = b.create_block();
        b.ins().brif(bad, self.refuse, &[], next, &[]);
        b.switch_to_block(next);
        b.seal_block(next);
    }

    /// `!(d > PIVOT_RTOL * diag)` or `d` not finite (`ldl_solve_fixed`'s
    /// test).
    fn pivot(&self, b: &mut FunctionBuilder, d: Value, diag: Value) {
        let bad = not_finite(b, d);
        let tol = b.ins().fmul(self.rtol, diag);
        let small = b.ins().fcmp(FloatCC::UnorderedOrLessThanOrEqual, d, tol);
        let bad = b.ins().bor(bad, small);
        self.check(b, bad);
    }

    /// `pivot_pair`: the determinant of the block `[a00, a10, a11]`, its
    /// pivots checked against the diagonal `diag`.
    fn pair(&self, b: &mut FunctionBuilder, [a00, a10, a11]: [Value; 3], diag: [Value; 2]) -> Value {
        let bad0 = not_finite(b, a00);
        let tol0 = b.ins().fmul(self.rtol, diag[0]);
        let small0 = b.ins().fcmp(FloatCC::UnorderedOrLessThanOrEqual, a00, tol0);
        let p = b.ins().fmul(a00, a11);
        let s = b.ins().fmul(a10, a10);
        let det = b.ins().fsub(p, s);
        let bad1 = not_finite(b, det);
        let t = b.ins().fmul(self.rtol, diag[1]);
        let tol1 = b.ins().fmul(t, a00);
        let small1 = b.ins().fcmp(FloatCC::UnorderedOrLessThanOrEqual, det, tol1);
        let bad = b.ins().bor(bad0, small0);
        let bad = b.ins().bor(bad, bad1);
        let bad = b.ins().bor(bad, small1);
        self.check(b, bad);
        det
    }
}

/// `(x * y) - (u * v)`.
fn cross(b: &mut FunctionBuilder, x: Value, y: Value, u: Value, v: Value) -> Value {
    let p = b.ins().fmul(x, y);
    let q = b.ins().fmul(u, v);
    b.ins().fsub(p, q)
}

/// `a - (x0 * y0 + x1 * y1)`.
fn minus_dot2(b: &mut FunctionBuilder, a: Value, [x0, y0, x1, y1]: [Value; 4]) -> Value {
    let p = b.ins().fmul(x0, y0);
    let q = b.ins().fmul(x1, y1);
    let s = b.ins().fadd(p, q);
    b.ins().fsub(a, s)
}

/// `A x = r` as `ldl_solve` solves it (`a(i, k)`: the lower triangle).
fn emit_solve(b: &mut FunctionBuilder, s: &Solve, a: &dyn Fn(usize, usize) -> Value, r: &[Value]) -> Vec<Value> {
    let nu = r.len();
    let one = b.ins().f64const(1.0);
    match nu {
        0 => Vec::new(),
        2 => {
            let (a00, a10, a11) = (a(0, 0), a(1, 0), a(1, 1));
            let det = s.pair(b, [a00, a10, a11], [a00, a11]);
            let idet = b.ins().fdiv(one, det);
            let x0 = cross(b, a11, r[0], a10, r[1]);
            let x1 = cross(b, a00, r[1], a10, r[0]);
            vec![b.ins().fmul(x0, idet), b.ins().fmul(x1, idet)]
        }
        4 => {
            let (a00, a10, a11) = (a(0, 0), a(1, 0), a(1, 1));
            let (a20, a21, a22) = (a(2, 0), a(2, 1), a(2, 2));
            let (a30, a31, a32, a33) = (a(3, 0), a(3, 1), a(3, 2), a(3, 3));
            let det1 = s.pair(b, [a00, a10, a11], [a00, a11]);
            let i1 = b.ins().fdiv(one, det1);
            let times_i1 = |b: &mut FunctionBuilder, x: Value| b.ins().fmul(x, i1);
            let t = cross(b, a11, a20, a10, a21);
            let y00 = times_i1(b, t);
            let t = cross(b, a11, a30, a10, a31);
            let y01 = times_i1(b, t);
            let t = cross(b, a00, a21, a10, a20);
            let y10 = times_i1(b, t);
            let t = cross(b, a00, a31, a10, a30);
            let y11 = times_i1(b, t);
            let s00 = minus_dot2(b, a22, [a20, y00, a21, y10]);
            let s10 = minus_dot2(b, a32, [a30, y00, a31, y10]);
            let s11 = minus_dot2(b, a33, [a30, y01, a31, y11]);
            let det2 = s.pair(b, [s00, s10, s11], [a22, a33]);
            let i2 = b.ins().fdiv(one, det2);
            let t = cross(b, a11, r[0], a10, r[1]);
            let w0 = times_i1(b, t);
            let t = cross(b, a00, r[1], a10, r[0]);
            let w1 = times_i1(b, t);
            let b2 = minus_dot2(b, r[2], [a20, w0, a21, w1]);
            let b3 = minus_dot2(b, r[3], [a30, w0, a31, w1]);
            let t = cross(b, s11, b2, s10, b3);
            let x2 = b.ins().fmul(t, i2);
            let t = cross(b, s00, b3, s10, b2);
            let x3 = b.ins().fmul(t, i2);
            let x0 = minus_dot2(b, w0, [y00, x2, y01, x3]);
            let x1 = minus_dot2(b, w1, [y10, x2, y11, x3]);
            vec![x0, x1, x2, x3]
        }
        _ => ldl_fixed(b, s, a, r, one),
    }
}

/// `ldl_solve_fixed::<nu>`, unrolled as it unrolls.
fn ldl_fixed(
    b: &mut FunctionBuilder,
    s: &Solve,
    a: &dyn Fn(usize, usize) -> Value,
    r: &[Value],
    one: Value,
) -> Vec<Value> {
    let m = r.len();
    let mut l: Vec<Vec<Value>> = (0..m).map(|i| (0..=i).map(|j| a(i, j)).collect()).collect();
    let (mut d, mut inv) = (Vec::with_capacity(m), Vec::with_capacity(m));
    for j in 0..m {
        let mut v = Vec::with_capacity(j);
        let mut dj = l[j][j];
        for k in 0..j {
            let vk = b.ins().fmul(l[j][k], d[k]);
            v.push(vk);
            let p = b.ins().fmul(l[j][k], vk);
            dj = b.ins().fsub(dj, p);
        }
        s.pivot(b, dj, l[j][j]);
        d.push(dj);
        inv.push(b.ins().fdiv(one, dj));
        for row in &mut l[j + 1..] {
            let mut acc = row[j];
            for (&lik, &vk) in row[..j].iter().zip(&v) {
                let p = b.ins().fmul(lik, vk);
                acc = b.ins().fsub(acc, p);
            }
            row[j] = b.ins().fmul(acc, inv[j]);
        }
    }
    let mut y: Vec<Value> = Vec::with_capacity(m);
    for i in 0..m {
        let mut acc = r[i];
        for k in 0..i {
            let p = b.ins().fmul(l[i][k], y[k]);
            acc = b.ins().fsub(acc, p);
        }
        y.push(acc);
    }
    for i in (0..m).rev() {
        let mut acc = b.ins().fmul(y[i], inv[i]);
        for k in i + 1..m {
            let p = b.ins().fmul(l[k][i], y[k]);
            acc = b.ins().fsub(acc, p);
        }
        y[i] = acc;
    }
    y
}

impl Extra for Part<'_, '_> {
    fn signature(&self, sig: &mut ir::Signature, ptr: ir::Type) {
        match self.1 {
            Some(_) => sig.params.extend([AbiParam::new(ptr); 7]),
            None => {
                sig.params.extend([AbiParam::new(ptr); 6]);
                sig.returns.push(AbiParam::new(types::I32));
            }
        }
    }

    fn build(&self, b: &mut FunctionBuilder, refs: &Refs) -> Result<(), String> {
        let entry = b.create_block();
        b.append_block_params_for_function_params(entry);
        b.switch_to_block(entry);
        b.seal_block(entry);
        let args = b.block_params(entry).to_vec();
        match self.1 {
            Some(lean) => self.0.build_state(b, refs, lean, &args),
            None => self.0.build_solve(b, refs, &args),
        }
    }
}

impl Spec<'_> {
    /// [`StateKernel`]'s body (`args`: its parameters).
    fn build_state(&self, b: &mut FunctionBuilder, refs: &Refs, lean: bool, args: &[Value]) -> Result<(), String> {
        let (p, mem, cols) = (self.fused, MemFlags::trusted(), self.cols);
        let (z, dz, keep) = (args[2], args[5], args[6]);
        let mut st = State { params: args[0], table: args[1], q: args[3], qd: args[4], known: Default::default() };
        let (dep_at, rate_at) = if lean { &p.lean_at } else { &p.full_at };
        let np = self.coords.len();
        // the state into q, qd
        for (i, &j) in self.coords.iter().chain(self.speeds).enumerate() {
            let v = b.ins().load(types::F64, mem, z, offset(i)?);
            st.store(b, i >= np, j, v)?;
        }
        let out = emit(b, p.tape(lean), refs, &mut |b, input| st.input(b, cols, input))?;
        // the frames and body rows that read the velocities before they
        // are written over: now
        let early = if p.forces.reads_velocities() {
            emit(b, &p.forces, refs, &mut |b, input| st.input(b, cols, input))?
        } else {
            Vec::new()
        };
        let (maggi, state) = out.split_at(p.n_maggi);
        let (deps, rates) = state.split_at(dep_at.len());
        for (&j, &v) in dep_at.iter().zip(deps) {
            st.store(b, false, j, v)?;
        }
        for (&j, &v) in rate_at.iter().zip(rates) {
            st.store(b, true, j, v)?;
        }
        for (i, &j) in self.coords.iter().enumerate() {
            let v = match st.known[1].get(&j) {
                Some(&v) => v,
                None => b.ins().load(types::F64, mem, st.qd, offset(j)?),
            };
            b.ins().store(mem, v, dz, offset(i)?);
        }
        for (k, &v) in maggi.iter().chain(&early).enumerate() {
            b.ins().store(mem, v, keep, offset(k)?);
        }
        // the forces and torques after what is kept, to be added to (two
        // at a time)
        let n = p.nq + p.hinges.len();
        let zeros = b.ins().f64const(0.0);
        let pairs = b.ins().splat(types::F64X2, zeros);
        for k in (0..n / 2).map(|i| 2 * i) {
            b.ins().store(mem, pairs, keep, offset(p.kept() + k)?);
        }
        if n % 2 == 1 {
            b.ins().store(mem, zeros, keep, offset(p.kept() + n - 1)?);
        }
        b.ins().return_(&[]);
        Ok(())
    }

    /// [`SolveKernel`]'s body (`args`: its parameters).
    fn build_solve(&self, b: &mut FunctionBuilder, refs: &Refs, args: &[Value]) -> Result<(), String> {
        let p = self.fused;
        let (nq, nu, np) = (p.nq, p.nu, self.coords.len());
        let (keep, dz) = (args[4], args[5]);
        let forces = b.ins().iadd_imm(keep, i64::from(offset(p.kept())?));
        let spill = b.ins().iadd_imm(keep, i64::from(offset(p.kept() + nq + p.hinges.len())?));
        let st = State { params: args[0], table: args[1], q: args[2], qd: args[3], known: Default::default() };
        let (mem, fixed) = (MemFlags::trusted(), MemFlags::trusted().with_readonly().with_can_move());
        let kept = (0..p.kept())
            .map(|k| Ok(b.ins().load(types::F64, fixed, keep, offset(k)?)))
            .collect::<Result<Vec<_>, String>>()?;
        let (maggi, early) = kept.split_at(p.n_maggi);
        let lower = nu * (nu + 1) / 2;
        let mut r: Vec<Value> = maggi[lower..lower + nu].to_vec();
        if p.forces.reads_velocities() {
            self.body_forces(b, &mut r, early, forces)?;
        } else if let Some(any) = self.any_force(b, forces)? {
            // the frames and rows only where a body is pushed or turned
            // (`r` is loaded on each way, not before the branch: live
            // across the frames' calls, it would be spilled on both)
            let (pushed, calm, join) = (b.create_block(), b.create_block(), b.create_block());
            for _ in 0..nu {
                b.append_block_param(join, types::F64);
            }
            b.ins().brif(any, pushed, &[], calm, &[]);
            b.switch_to_block(calm);
            b.seal_block(calm);
            let r_args: Vec<ir::BlockArg> = r.iter().map(|&v| v.into()).collect();
            b.ins().jump(join, &r_args);
            b.switch_to_block(pushed);
            b.seal_block(pushed);
            let fo = emit(b, &p.forces, refs, &mut |b, input| st.input(b, self.cols, input))?;
            let mut pushed_r = r.clone();
            self.body_forces(b, &mut pushed_r, &fo, forces)?;
            let r_args: Vec<ir::BlockArg> = pushed_r.iter().map(|&v| v.into()).collect();
            b.ins().jump(join, &r_args);
            b.switch_to_block(join);
            b.seal_block(join);
            r = b.block_params(join).to_vec();
        }
        // each hinge's torque along its row, where it is not zero
        for (hinge, row) in p.hinges.iter().enumerate() {
            if !row.is_empty() {
                let t = b.ins().load(types::F64, fixed, forces, offset(nq + hinge)?);
                let nz = nonzero(b, t);
                add_where(b, &mut r, &[(row, t)], maggi, nz);
            }
        }
        // B^T M B u' = r
        let rtol = b.ins().f64const(PIVOT_RTOL);
        let s = Solve { refuse: b.create_block(), rtol };
        let a = |i: usize, k: usize| maggi[i * (i + 1) / 2 + k];
        let x = emit_solve(b, &s, &a, &r);
        for (i, &xi) in x.iter().enumerate() {
            b.ins().store(mem, xi, dz, offset(np + i)?);
        }
        let done = b.ins().iconst(types::I32, i64::from(DONE));
        b.ins().return_(&[done]);
        // a refused pivot: A and r to the caller
        b.switch_to_block(s.refuse);
        b.seal_block(s.refuse);
        for i in 0..nu {
            for k in 0..nu {
                b.ins().store(mem, a(i.max(k), i.min(k)), spill, offset(i * nu + k)?);
            }
        }
        for (i, &ri) in r.iter().enumerate() {
            b.ins().store(mem, ri, spill, offset(nu * nu + i)?);
        }
        let refused = b.ins().iconst(types::I32, i64::from(REFUSED));
        b.ins().return_(&[refused]);
        Ok(())
    }

    /// Whether any force a body's row reads is not zero (`None`: no body
    /// has a row), from the values' bits: `x != 0.0` exactly where `x`'s
    /// bits without the sign are not zero (NaN included, -0.0 not).
    fn any_force(&self, b: &mut FunctionBuilder, forces: Value) -> Result<Option<Value>, String> {
        let fixed = MemFlags::trusted().with_readonly().with_can_move();
        let mut bits: Option<Value> = None;
        for (body, (_, rows)) in self.fused.bodies.iter().enumerate() {
            let pushed = !rows[0].is_empty() || !rows[1].is_empty();
            for (axis, used) in [pushed, pushed, !rows[2].is_empty()].into_iter().enumerate() {
                if used {
                    let x = b.ins().load(types::I64, fixed, forces, offset(3 * body + axis)?);
                    bits = Some(match bits {
                        Some(acc) => b.ins().bor(acc, x),
                        None => x,
                    });
                }
            }
        }
        Ok(bits.map(|x| {
            let magnitude = b.ins().ishl_imm(x, 1);
            b.ins().icmp_imm(IntCC::NotEqual, magnitude, 0)
        }))
    }

    /// Each body's force turned into its frame and added along its rows
    /// where it is not zero (`fo`: the frames and rows' values).
    fn body_forces(&self, b: &mut FunctionBuilder, r: &mut [Value], fo: &[Value], forces: Value) -> Result<(), String> {
        let fixed = MemFlags::trusted().with_readonly().with_can_move();
        for (body, (frame, rows)) in self.fused.bodies.iter().enumerate() {
            let force = |b: &mut FunctionBuilder, axis: usize| -> Result<Value, String> {
                Ok(b.ins().load(types::F64, fixed, forces, offset(3 * body + axis)?))
            };
            if !rows[0].is_empty() || !rows[1].is_empty() {
                let (gx, gy) = (force(b, 0)?, force(b, 1)?);
                let (nx, ny) = (nonzero(b, gx), nonzero(b, gy));
                let pushed = b.ins().bor(nx, ny);
                let (c, s) = (fo[frame[0]], fo[frame[1]]);
                let fx = {
                    let (cx, sy) = (b.ins().fmul(c, gx), b.ins().fmul(s, gy));
                    b.ins().fadd(cx, sy)
                };
                let fy = cross(b, c, gy, s, gx);
                add_where(b, r, &[(&rows[0], fx), (&rows[1], fy)], fo, pushed);
            }
            if !rows[2].is_empty() {
                let gw = force(b, 2)?;
                let turned = nonzero(b, gw);
                add_where(b, r, &[(&rows[2], gw)], fo, turned);
            }
        }
        Ok(())
    }
}

/// `x != 0.0` (true for NaN, as Rust's `!=`).
fn nonzero(b: &mut FunctionBuilder, x: Value) -> Value {
    let zero = b.ins().f64const(0.0);
    b.ins().fcmp(FloatCC::NotEqual, x, zero)
}

/// The working space of one call of the kernels, on the caller's stack.
pub(crate) struct Room(MaybeUninit<[f64; ROOM]>);

impl Room {
    pub(crate) fn new() -> Self {
        Room(MaybeUninit::uninit())
    }

    fn at(&mut self, k: usize) -> *mut f64 {
        debug_assert!(k <= ROOM);
        // SAFETY: `k <= ROOM` (`Spec::new` checked what a plan uses).
        unsafe { self.0.as_mut_ptr().cast::<f64>().add(k) }
    }
}

/// [`super::rhs`] by the state kernel of `k` (the caller checked the
/// lengths: [`Fused::kernels_for`]): returns the zeroed forces `f`, `tau`
/// (one after the other, in `room`).
#[expect(clippy::too_many_arguments, reason = "`rhs`'s arguments, the kernels and their room")]
#[inline]
pub(crate) fn state<'r>(
    k: &Kernels,
    lean: bool,
    x: &FusedCall<'_>,
    z: &[f64],
    q: &mut [f64],
    qd: &mut [f64],
    dz: &mut [f64],
    room: &'r mut Room,
) -> &'r mut [f64] {
    let p = x.fused;
    let (keep, applied) = (room.at(0), room.at(p.kept()));
    // SAFETY: the caller checked the lengths the kernel reads and writes;
    // what it keeps and the forces after it fit in `room`.
    unsafe {
        (k.state[usize::from(lean)])(
            x.params.as_ptr(),
            x.table.as_ptr(),
            z.as_ptr(),
            q.as_mut_ptr(),
            qd.as_mut_ptr(),
            dz.as_mut_ptr(),
            keep,
        );
        // zeroed by the kernel
        std::slice::from_raw_parts_mut(applied, p.nq + p.hinges.len())
    }
}

/// [`super::rhs`] by the solve kernel of `k`, after [`state`] and the
/// forces: `dz[np..]`.
///
/// # Errors
/// The solve's ([`crate::kkt::spd::ldl_solve`]'s own, where the kernel
/// refused a pivot).
#[inline(always)]
pub(crate) fn solve(
    k: &Kernels,
    x: &FusedCall<'_>,
    q: &[f64],
    qd: &[f64],
    dz: &mut [f64],
    room: &mut Room,
) -> Result<(), crate::error::KktError> {
    let p = x.fused;
    let (nq, nu, nh, kept) = (p.nq, p.nu, p.hinges.len(), p.kept());
    // SAFETY: as for the state kernel; `room` as `state` and the forces
    // left it.
    let status =
        unsafe { (k.solve)(x.params.as_ptr(), x.table.as_ptr(), q.as_ptr(), qd.as_ptr(), room.at(0), dz.as_mut_ptr()) };
    let spill = room.at(kept + nq + nh);
    if status == DONE {
        return Ok(());
    }
    // SAFETY: a refusing kernel wrote the first nu (nu + 1) values of `spill`.
    refused(unsafe { std::slice::from_raw_parts(spill, nu * (nu + 1)) }, nu, &mut dz[x.coords.len()..])
}

/// The solve's error for the system `spill` (`A`, nu x nu, then `r`) that
/// the kernel refused, by [`crate::kkt::spd::ldl_solve`] itself (were it
/// to solve it after all, its solution).
#[cold]
#[inline(never)]
fn refused(spill: &[f64], nu: usize, x: &mut [f64]) -> Result<(), crate::error::KktError> {
    let (a, r) = spill.split_at(nu * nu);
    crate::kkt::spd::ldl_solve(a, nu, nu, r, &mut x[..nu], &mut []).map(|_| ())
}
