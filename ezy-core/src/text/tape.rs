//! Derived expressions as a tape: straight-line code for a register
//! machine, evaluated over any [`Scalar`] (`f64` in a run, dual numbers
//! where the checks and analyses need derivatives).
//!
//! The lowering follows `model!`'s Rust back end operation for operation
//! (ezy-derive's `emit::lower`): nodes in the arena's order, an n-ary sum
//! or product folded from the left in the order of its operands, `-x y`
//! as `-(x y)`, `x^2` as `x x`, `x^-1` as `1 / x`, a sine and a cosine
//! of one angle as one `sin_cos`. Floating point is not reassociated by
//! either, so a tape gives the numbers the compiled code gives for the
//! same expressions.

use std::collections::HashMap;

#[cfg(feature = "jit")]
pub(crate) mod jit;
mod machine;

use ezy_lang::sym::{Arena, Id, Node, Sym};

use crate::scalar::Scalar;
use machine::{Ins, Machine, Op};

/// Straight-line code computing some outputs from a model's parameters,
/// the family indices of an element and the local coordinates of the
/// bodies it touches (slot `s` owns local coordinates `3 s .. 3 s + 3`).
/// Its registers (as lowered; the register machine numbers them its own
/// way): the inputs it reads (numbers, then what is loaded per
/// evaluation), then one per computed value.
///
/// Not `Clone`: a compiled kernel points into code its plan owns.
#[derive(Debug, Default)]
pub(crate) struct Tape {
    /// Numbers, in registers `0..consts.len()`.
    consts: Vec<f64>,
    /// `(parameter index, register)`.
    params: Vec<(usize, u32)>,
    /// `(index number k of Sym::Index(k), register)`.
    indices: Vec<(usize, u32)>,
    /// `(local coordinate, register)` of `q`, then of `qd`.
    q: Vec<(usize, u32)>,
    qd: Vec<(usize, u32)>,
    /// The operations, in the order of the lowering.
    ins: Vec<Ins>,
    /// What the register machine runs, in its own numbering of the
    /// registers (output `j` in register `j`).
    machine: Machine,
    /// The register of each output.
    out: Vec<u32>,
    /// Registers of this numbering (the compiled kernel's values).
    n_regs: usize,
    /// Outputs from here on go to [`Tape::eval_to`]'s second destination.
    split: usize,
    /// What an evaluation reads, for the compiled kernel's bounds: the
    /// parameters and indices it needs, and per slot read from `q` (and
    /// `qd`) the largest local coordinate (0-2).
    reach: Reach,
    /// The compiled kernel, once the model's tapes are compiled.
    #[cfg(feature = "jit")]
    kernel: std::sync::OnceLock<jit::Kernel>,
}

/// What a tape reads ([`Tape::fits`]).
#[derive(Clone, Debug, Default)]
struct Reach {
    params: usize,
    indices: usize,
    #[cfg_attr(not(feature = "jit"), expect(dead_code, reason = "what the JIT's kernels read"))]
    q: Vec<(usize, usize)>,
    #[cfg_attr(not(feature = "jit"), expect(dead_code, reason = "what the JIT's kernels read"))]
    qd: Vec<(usize, usize)>,
}

impl Reach {
    fn of(t: &Tape) -> Self {
        let slots = |list: &[(usize, u32)]| {
            let mut v: Vec<(usize, usize)> = Vec::new();
            for &(k, _) in list {
                match v.iter_mut().find(|(s, _)| *s == k / 3) {
                    Some(e) => e.1 = e.1.max(k % 3),
                    None => v.push((k / 3, k % 3)),
                }
            }
            v
        };
        Reach {
            params: t.params.iter().map(|p| p.0 + 1).max().unwrap_or(0),
            indices: t.indices.iter().map(|p| p.0 + 1).max().unwrap_or(0),
            q: slots(&t.q),
            qd: slots(&t.qd),
        }
    }
}

impl Tape {
    /// The tape computing `outputs` (ids of `ar`).
    pub(crate) fn new(ar: &Arena, outputs: &[Id]) -> Self {
        Self::build(ar, outputs, &HashMap::new())
    }

    /// Tapes computing each list of `lists` with their parameter-only
    /// subexpressions hoisted (code motion, as `model!` hoists the fused
    /// right-hand side's into a table computed once per run): `(table,
    /// tapes)`, where `table` computes the hoisted values (of all lists)
    /// from the parameters and each tape reads them where a family's tape reads its
    /// indices (`Sym::Index(k)` is the table's `k`-th value; a tape of a
    /// model without families reads no index).
    pub(crate) fn hoisted(ar: &Arena, lists: &[&[Id]]) -> (Self, Vec<Self>) {
        let outputs: Vec<Id> = lists.concat();
        let outputs = outputs.as_slice();
        let ids = ar.reachable(outputs);
        let mut fixed: HashMap<Id, bool> = HashMap::with_capacity(ids.len());
        let mut read_by_state: std::collections::HashSet<Id> = std::collections::HashSet::new();
        for &id in &ids {
            let kids: &[Id] = match ar.node(id) {
                Node::Const(_) => &[],
                Node::Sym(s) => {
                    fixed.insert(id, matches!(s, Sym::Param(_)));
                    continue;
                }
                Node::Add(xs) | Node::Mul(xs) => xs,
                Node::Pow(a, _) | Node::Sin(a) | Node::Cos(a) | Node::Sqrt(a) => std::slice::from_ref(a),
            };
            let f = kids.iter().all(|k| fixed[k]);
            if !f {
                read_by_state.extend(kids.iter().copied());
            }
            fixed.insert(id, f);
        }
        // a computed parameter-only value that state-dependent code or an
        // output reads
        let is_leaf = |id: Id| matches!(ar.node(id), Node::Const(_) | Node::Sym(_));
        let table: Vec<Id> = ids
            .iter()
            .copied()
            .filter(|&id| fixed[&id] && !is_leaf(id) && (read_by_state.contains(&id) || outputs.contains(&id)))
            .collect();
        let stops: HashMap<Id, usize> = table.iter().enumerate().map(|(k, &id)| (id, k)).collect();
        (Self::new(ar, &table), lists.iter().map(|l| Self::build(ar, l, &stops)).collect())
    }

    /// How many parameters and indices an evaluation reads (the largest
    /// index read, plus one).
    pub(crate) fn input_reach(&self) -> (usize, usize) {
        (self.reach.params, self.reach.indices)
    }

    /// The local coordinates read: `(false, k)` for `q`'s `k`, `(true, k)`
    /// for `qd`'s.
    #[cfg(feature = "jit")]
    pub(crate) fn state_reads(&self) -> impl Iterator<Item = (bool, usize)> + '_ {
        self.q.iter().map(|p| (false, p.0)).chain(self.qd.iter().map(|p| (true, p.0)))
    }

    /// Whether it reads velocities.
    pub(crate) fn reads_velocities(&self) -> bool {
        !self.qd.is_empty()
    }

    /// The tape computing `outputs`, reading each of `stops` as an input
    /// (`Sym::Index(k)` for `stops[id] = k`) instead of computing it.
    fn build(ar: &Arena, outputs: &[Id], stops: &HashMap<Id, usize>) -> Self {
        let ids = if stops.is_empty() { ar.reachable(outputs) } else { reachable_until(ar, outputs, stops) };
        let mut t = Tape::default();
        let mut reg: HashMap<Id, u32> = HashMap::with_capacity(ids.len());
        let mut next = 0u32;
        let mut fresh = || {
            next += 1;
            next - 1
        };
        // the inputs first: numbers, parameters, indices, coordinates
        for &id in &ids {
            if let Node::Const(bits) = ar.node(id) {
                t.consts.push(f64::from_bits(*bits));
                reg.insert(id, fresh());
            }
        }
        for &id in &ids {
            if let Some(&k) = stops.get(&id) {
                let r = fresh();
                reg.insert(id, r);
                t.indices.push((k, r));
                continue;
            }
            if let Node::Sym(s) = ar.node(id) {
                let r = fresh();
                reg.insert(id, r);
                match *s {
                    Sym::Param(i) => t.params.push((i, r)),
                    Sym::Index(k) => t.indices.push((k, r)),
                    Sym::Q(k) => t.q.push((k, r)),
                    Sym::Qd(k) => t.qd.push((k, r)),
                }
            }
        }
        // a sine and a cosine of one angle are one `sin_cos`, where the
        // first of the two is
        let mut partner: HashMap<(Id, bool), Id> = HashMap::new();
        for &id in &ids {
            match ar.node(id) {
                Node::Sin(a) => partner.insert((*a, true), id),
                Node::Cos(a) => partner.insert((*a, false), id),
                _ => None,
            };
        }
        for &id in &ids {
            if reg.contains_key(&id) {
                continue;
            }
            let r = |id: &Id| reg[id];
            let node = ar.node(id).clone();
            match node {
                Node::Const(_) | Node::Sym(_) => unreachable!("inputs have registers"),
                Node::Sin(a) | Node::Cos(a) => {
                    let sine = matches!(node, Node::Sin(_));
                    let arg = r(&a);
                    if let Some(&other) = partner.get(&(a, !sine)) {
                        let (s, c) = if sine { (id, other) } else { (other, id) };
                        let (rs, rc) = (fresh(), fresh());
                        t.ins.push(Ins { op: Op::SinCos, dst: rs, a: arg, b: rc });
                        reg.insert(s, rs);
                        reg.insert(c, rc);
                    } else {
                        let dst = fresh();
                        t.ins.push(Ins { op: if sine { Op::Sin } else { Op::Cos }, dst, a: arg, b: arg });
                        reg.insert(id, dst);
                    }
                }
                Node::Sqrt(a) => {
                    let dst = fresh();
                    t.ins.push(Ins { op: Op::Sqrt, dst, a: r(&a), b: 0 });
                    reg.insert(id, dst);
                }
                Node::Add(xs) => {
                    let dst = fold(&mut t.ins, Op::Add, &xs.iter().map(r).collect::<Vec<_>>(), &mut fresh);
                    reg.insert(id, dst);
                }
                Node::Mul(xs) => {
                    let dst = if ar.as_const(xs[0]) == Some(-1.0) {
                        let p = fold(&mut t.ins, Op::Mul, &xs[1..].iter().map(r).collect::<Vec<_>>(), &mut fresh);
                        let dst = fresh();
                        t.ins.push(Ins { op: Op::Neg, dst, a: p, b: p });
                        dst
                    } else {
                        fold(&mut t.ins, Op::Mul, &xs.iter().map(r).collect::<Vec<_>>(), &mut fresh)
                    };
                    reg.insert(id, dst);
                }
                Node::Pow(b, n) => {
                    let b = r(&b);
                    let dst = match n {
                        2 => fold(&mut t.ins, Op::Mul, &[b, b], &mut fresh),
                        3 => fold(&mut t.ins, Op::Mul, &[b, b, b], &mut fresh),
                        -1 | -2 => {
                            let x = if n == -1 { b } else { fold(&mut t.ins, Op::Mul, &[b, b], &mut fresh) };
                            let dst = fresh();
                            t.ins.push(Ins { op: Op::Recip, dst, a: x, b: x });
                            dst
                        }
                        n => {
                            let dst = fresh();
                            t.ins.push(Ins { op: Op::Powi(n), dst, a: b, b });
                            dst
                        }
                    };
                    reg.insert(id, dst);
                }
            }
        }
        t.out = outputs.iter().map(|o| reg[o]).collect();
        t.n_regs = next as usize;
        t.reach = Reach::of(&t);
        t.split = t.out.len();
        t.machine = Machine::new(&t, &[]);
        t
    }

    /// Whether the inputs `x` hold everything the tape reads (the compiled
    /// kernel's bounds).
    #[cfg(feature = "jit")]
    fn fits<S>(&self, x: &Inputs<'_, S>) -> bool {
        let r = &self.reach;
        let inside = |slots: &[(usize, usize)], v: &[S]| {
            slots.iter().all(|&(s, m)| x.cols.get(s).is_some_and(|&c| c.checked_add(m).is_some_and(|e| e < v.len())))
        };
        x.params.len() >= r.params && x.indices.len() >= r.indices && inside(&r.q, x.q) && inside(&r.qd, x.qd)
    }

    /// The compiled kernel, if `x` may take it (`f64`, compiled, every
    /// input in bounds).
    #[inline]
    #[cfg(feature = "jit")]
    fn kernel_for<S: Scalar>(&self, x: &Inputs<'_, S>) -> Option<jit::Kernel> {
        let k = *self.kernel.get()?;
        (x.compiled && std::any::TypeId::of::<S>() == std::any::TypeId::of::<f64>() && self.fits(x)).then_some(k)
    }

    /// The tape with output `j` left in register `places[j]` by
    /// [`Tape::eval_in`] (instead of `j`): where its caller reads it.
    ///
    /// # Panics
    /// If the places are not one per output and distinct.
    pub(crate) fn with_places(mut self, places: &[u32]) -> Self {
        self.machine = Machine::new(&self, places);
        self
    }

    /// The tape with its outputs from `split` on written to a second
    /// destination ([`Tape::eval_to`]).
    pub(crate) fn with_split(mut self, split: usize) -> Self {
        self.split = split.min(self.out.len());
        self
    }

    /// Evaluates the tape for one element: output `j` to `a[j]` for `j` below
    /// the tape's split ([`Tape::with_split`]), to `b[j - split]` from it on.
    /// `regs`: scratch of [`Tape::registers`] values for the register
    /// machine (the compiled kernel needs none: it may be empty then).
    ///
    /// # Panics
    /// If `a` or `b` is too short, or an input is out of bounds.
    #[inline]
    pub(crate) fn eval_to<S: Scalar>(&self, x: &Inputs<'_, S>, regs: &mut [S], a: &mut [S], b: &mut [S]) {
        let (na, nb) = (self.split, self.out.len() - self.split);
        let (a, b) = (&mut a[..na], &mut b[..nb]);
        #[cfg(feature = "jit")]
        if let Some(k) = self.kernel_for(x) {
            let f = |v: &[S]| v.as_ptr().cast::<f64>();
            // SAFETY: `S` is `f64` (the casts are identities), `kernel_for`
            // checked every read, and `a`, `b` hold the outputs.
            unsafe {
                k(
                    x.params.as_ptr(),
                    x.indices.as_ptr(),
                    x.cols.as_ptr(),
                    f(x.q),
                    f(x.qd),
                    a.as_mut_ptr().cast::<f64>(),
                    b.as_mut_ptr().cast::<f64>(),
                )
            };
            return;
        }
        let n = self.machine.registers();
        let mut run = |regs: &mut [S]| {
            self.machine.eval(x, regs);
            if self.machine.places().is_empty() {
                a.copy_from_slice(&regs[..na]);
                b.copy_from_slice(&regs[na..na + nb]);
            } else {
                for (j, v) in a.iter_mut().chain(b.iter_mut()).enumerate() {
                    *v = regs[self.output_at(j)];
                }
            }
        };
        if regs.len() >= n { run(regs) } else { S::with_scratch(n, run) }
    }

    /// Sets the compiled kernel (once; later calls are ignored).
    #[cfg(feature = "jit")]
    pub(crate) fn set_kernel(&self, k: jit::Kernel) {
        let _ = self.kernel.set(k);
    }

    /// Evaluates the tape for one element: output `j` is then `regs[j]`
    /// (`regs[places[j]]` for a tape [`Tape::with_places`]). By the
    /// compiled kernel for `f64` where there is one, by the register
    /// machine otherwise. `regs` is scratch of at least
    /// [`Tape::registers`] values (its contents are overwritten).
    ///
    /// # Panics
    /// If `regs` is too short, or an input is out of bounds.
    #[inline]
    pub(crate) fn eval_in<S: Scalar>(&self, x: &Inputs<'_, S>, regs: &mut [S]) {
        #[cfg(feature = "jit")]
        if let Some(k) = self.kernel_for(x)
            && regs.len() >= self.registers()
        {
            // the kernel writes the outputs in a row: past the places, if any
            let places = self.machine.places();
            let at = if places.is_empty() { 0 } else { self.machine.front() };
            let f = |v: &[S]| v.as_ptr().cast::<f64>();
            let out = regs[at..].as_mut_ptr().cast::<f64>();
            // SAFETY: `S` is `f64` (the casts are identities), `kernel_for`
            // checked every read, and `regs[at..]` holds the outputs (the
            // second destination starts at the split).
            unsafe {
                k(x.params.as_ptr(), x.indices.as_ptr(), x.cols.as_ptr(), f(x.q), f(x.qd), out, out.add(self.split))
            };
            for (j, &p) in places.iter().enumerate() {
                regs[p as usize] = regs[at + j];
            }
            return;
        }
        self.machine.eval(x, regs);
    }

    /// Whether it reads coordinates or velocities (a tape that reads
    /// neither depends on the parameters alone).
    #[cfg_attr(not(feature = "jit"), expect(dead_code, reason = "the JIT compiles only such tapes"))]
    pub(crate) fn reads_state(&self) -> bool {
        !self.q.is_empty() || !self.qd.is_empty()
    }

    /// Number of operations (what an evaluation costs, about).
    pub(crate) fn ops(&self) -> usize {
        self.ins.len()
    }

    /// Evaluates the tape for one element (its [`Inputs`]); output `j`
    /// goes to `sink(j, value)`. `regs` is scratch of at least
    /// [`Tape::registers`] values (its contents are overwritten).
    #[inline]
    pub(crate) fn eval<S: Scalar>(&self, x: &Inputs<'_, S>, regs: &mut [S], mut sink: impl FnMut(usize, S)) {
        self.eval_in(x, regs);
        for j in 0..self.out.len() {
            sink(j, regs[self.output_at(j)]);
        }
    }

    /// The register [`Tape::eval_in`] leaves output `j` in.
    #[inline]
    pub(crate) fn output_at(&self, j: usize) -> usize {
        self.machine.places().get(j).map_or(j, |&p| p as usize)
    }

    /// Number of outputs.
    #[inline]
    pub(crate) fn outputs(&self) -> usize {
        self.out.len()
    }

    /// Registers an evaluation needs (room for the outputs included).
    pub(crate) fn registers(&self) -> usize {
        let kernel = if self.machine.places().is_empty() { 0 } else { self.machine.front() };
        self.machine.registers().max(kernel + self.out.len())
    }
}

/// What a tape reads for one element: parameter `i` is `params[i]`,
/// `Sym::Index(k)` is `indices[k]`, local coordinate `k` is
/// `q[cols[k / 3] + k % 3]` (and of `qd`); `compiled`: whether a tape's
/// compiled kernel may evaluate it (for `f64`).
#[derive(Clone, Copy)]
pub(crate) struct Inputs<'a, S> {
    pub(crate) params: &'a [f64],
    pub(crate) indices: &'a [f64],
    pub(crate) cols: &'a [usize],
    pub(crate) q: &'a [S],
    pub(crate) qd: &'a [S],
    #[cfg_attr(not(feature = "jit"), expect(dead_code, reason = "no kernel without the JIT"))]
    pub(crate) compiled: bool,
}

impl<'a> Inputs<'a, f64> {
    /// Parameters and indices alone (a tape that reads no coordinate; the
    /// register machine: these tapes run once per setup).
    pub(crate) fn fixed(params: &'a [f64], indices: &'a [f64]) -> Self {
        Self { params, indices, cols: &[], q: &[], qd: &[], compiled: false }
    }
}

/// The nodes `roots` reach, in the arena's order, not looking into
/// `stops` (which are included).
fn reachable_until(ar: &Arena, roots: &[Id], stops: &HashMap<Id, usize>) -> Vec<Id> {
    let mut seen = std::collections::HashSet::new();
    let mut stack: Vec<Id> = roots.to_vec();
    while let Some(id) = stack.pop() {
        if !seen.insert(id) || stops.contains_key(&id) {
            continue;
        }
        match ar.node(id) {
            Node::Const(_) | Node::Sym(_) => {}
            Node::Add(xs) | Node::Mul(xs) => stack.extend_from_slice(xs),
            Node::Pow(a, _) | Node::Sin(a) | Node::Cos(a) | Node::Sqrt(a) => stack.push(*a),
        }
    }
    let mut ids: Vec<Id> = seen.into_iter().collect();
    ids.sort_by_key(|id| id.index());
    ids
}

/// `x0 op x1 op x2 ...` folded from the left into fresh registers; the
/// register of the result (`x0`'s own for a single operand).
fn fold(ins: &mut Vec<Ins>, op: Op, xs: &[u32], fresh: &mut impl FnMut() -> u32) -> u32 {
    let mut acc = xs[0];
    for &x in &xs[1..] {
        let dst = fresh();
        ins.push(Ins { op, dst, a: acc, b: x });
        acc = dst;
    }
    acc
}
