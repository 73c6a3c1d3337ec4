//! The register machine that evaluates a tape where no compiled kernel
//! does (any [`Scalar`], or the JIT off): the tape's operations as steps
//! on registers of its own numbering, output `j` in register `j` (or
//! where its caller placed it, [`Machine::new`]).
//!
//! Its registers, in order: the outputs, the numbers, the parameters
//! `0..n_params` and the indices `0..n_indices` in a row (each copied in
//! one loop), the coordinates and velocities read, then the other
//! computed values. An output that is an input or another output's value
//! is copied to its register by a last step.

use crate::scalar::Scalar;

use super::{Inputs, Tape};

/// One operation of a tape.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Op {
    Add,
    Mul,
    Neg,
    Recip,
    Powi(i32),
    Sin,
    Cos,
    /// `dst = sin a`, `b = cos a`.
    SinCos,
    Sqrt,
}

/// `dst = op(a, b)` on the registers (in the tape's numbering).
#[derive(Clone, Copy, Debug)]
pub(super) struct Ins {
    /// The operation.
    pub(super) op: Op,
    /// The register written.
    pub(super) dst: u32,
    /// The first operand's register.
    pub(super) a: u32,
    /// The second operand's register (a one-operand operation's is
    /// unused, but a register).
    pub(super) b: u32,
}

/// An operation of the register machine ([`Machine::run`]).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(u8)]
enum Code {
    Add,
    Mul,
    Neg,
    Recip,
    /// `b` holds the exponent's bits.
    Powi,
    Sin,
    Cos,
    /// `dst = sin a`, `b = cos a`.
    SinCos,
    Sqrt,
    /// `a b + c`.
    MulAdd,
    /// `c + a b`.
    AddMul,
    /// `a b + c d`.
    MulAddMul,
    /// `(a b) c`.
    MulMul,
    /// `c (a b)`.
    MulByMul,
    /// `(a + b) c`.
    AddMulBy,
    /// `c (a + b)`.
    MulByAdd,
    /// `-(a b)`.
    NegMul,
    /// `a` itself (an output that is an input or another output's value).
    Copy,
}

/// `dst = code(a, b, c, d)` on the registers, as [`Machine::run`] runs it
/// (a one-operand code reads `a`; an unused operand is register 0).
#[derive(Clone, Copy, Debug)]
struct Step {
    code: Code,
    dst: u32,
    a: u32,
    b: u32,
    c: u32,
    d: u32,
}

/// A tape's program for the register machine, in its own numbering of
/// the registers (the module's documentation).
#[derive(Debug, Default)]
pub(super) struct Machine {
    /// Numbers, in registers `consts_at..`.
    consts: Vec<f64>,
    consts_at: usize,
    /// Parameters `0..n_params`, in registers `params_at..`.
    params_at: usize,
    n_params: usize,
    /// Indices `0..n_indices`, in registers `indices_at..`.
    indices_at: usize,
    n_indices: usize,
    /// `q`'s and `qd`'s loads as `(slot, coordinate in it, register)`.
    q_at: Vec<(usize, usize, u32)>,
    qd_at: Vec<(usize, usize, u32)>,
    /// The operations, every register checked below `n_regs` when built.
    steps: Vec<Step>,
    /// Registers an evaluation needs (the outputs' included).
    n_regs: usize,
    /// The outputs' registers, where the caller placed them (empty: output
    /// `j` in register `j`).
    places: Vec<u32>,
    /// Registers below the inputs: the outputs' (and gaps between them).
    front: usize,
}

impl Machine {
    /// The program of the tape `t` (its inputs, operations and outputs in
    /// the tape's numbering), output `j` in register `places[j]` (distinct
    /// places, one per output), or in register `j` for no places.
    ///
    /// # Panics
    /// If a register of `t` is out of bounds (a bug of the tape's build),
    /// or the places are not one per output and distinct.
    pub(super) fn new(t: &Tape, places: &[u32]) -> Self {
        let n_out = t.out.len();
        let place = |j: usize| if places.is_empty() { j as u32 } else { places[j] };
        let front = if places.is_empty() { n_out } else { places.iter().map(|&p| p as usize + 1).max().unwrap_or(0) };
        let mut seen = vec![false; front];
        assert!(
            (places.is_empty() || places.len() == n_out)
                && places.iter().all(|&p| !std::mem::replace(&mut seen[p as usize], true)),
            "a tape's outputs placed twice or not at all"
        );
        let (n_params, n_indices) = (t.reach.params, t.reach.indices);
        let consts_at = front;
        let params_at = consts_at + t.consts.len();
        let indices_at = params_at + n_params;
        let mut next = indices_at + n_indices;
        const NONE: u32 = u32::MAX;
        let mut map = vec![NONE; t.n_regs];
        for (k, m) in map.iter_mut().take(t.consts.len()).enumerate() {
            *m = (consts_at + k) as u32;
        }
        for &(i, r) in &t.params {
            map[r as usize] = (params_at + i) as u32;
        }
        for &(k, r) in &t.indices {
            map[r as usize] = (indices_at + k) as u32;
        }
        let mut fresh = |r: u32, map: &mut [u32]| {
            map[r as usize] = next as u32;
            next += 1;
            next as u32 - 1
        };
        let q_at = t.q.iter().map(|&(k, r)| (k / 3, k % 3, fresh(r, &mut map))).collect();
        let qd_at = t.qd.iter().map(|&(k, r)| (k / 3, k % 3, fresh(r, &mut map))).collect();
        // a computed output's register is its own; another output is
        // copied from where its value is
        let mut copies: Vec<(u32, u32)> = Vec::new();
        for (j, &r) in t.out.iter().enumerate() {
            if map[r as usize] == NONE {
                map[r as usize] = place(j);
            } else {
                copies.push((place(j), r));
            }
        }
        for m in &mut map {
            if *m == NONE {
                *m = next as u32;
                next += 1;
            }
        }
        let r = |k: u32| map[k as usize];
        let ins: Vec<Ins> = t.ins.iter().map(|i| Ins { op: i.op, dst: r(i.dst), a: r(i.a), b: r(i.b) }).collect();
        let sources: Vec<u32> = t.out.iter().map(|&o| r(o)).collect();
        let mut steps = steps(&ins, &sources, next);
        steps.extend(copies.iter().map(|&(j, o)| Step { code: Code::Copy, dst: j, a: r(o), b: 0, c: 0, d: 0 }));
        let m = Machine {
            consts: t.consts.clone(),
            consts_at,
            params_at,
            n_params,
            indices_at,
            n_indices,
            q_at,
            qd_at,
            steps,
            n_regs: next,
            places: places.to_vec(),
            front,
        };
        m.check();
        m
    }

    /// Checks what [`Machine::load`] and [`Machine::run`] rely on to index
    /// the registers unchecked: every register they touch is below
    /// `n_regs`.
    ///
    /// # Panics
    /// If one is not (a bug of [`Machine::new`]).
    fn check(&self) {
        let n = self.n_regs;
        let loads = self.q_at.iter().chain(&self.qd_at).map(|p| p.2);
        let steps =
            self.steps.iter().flat_map(|s| [s.dst, s.a, if s.code == Code::Powi { s.a } else { s.b }, s.c, s.d]);
        assert!(
            self.consts_at + self.consts.len() <= n
                && self.params_at + self.n_params <= n
                && self.indices_at + self.n_indices <= n
                && loads.chain(steps).all(|r| (r as usize) < n),
            "a tape's register out of bounds"
        );
    }

    /// Registers an evaluation needs (the outputs' included).
    pub(super) fn registers(&self) -> usize {
        self.n_regs
    }

    /// The outputs' places (empty: output `j` in register `j`).
    pub(super) fn places(&self) -> &[u32] {
        &self.places
    }

    /// Registers below the inputs: the outputs' (and gaps between them).
    pub(super) fn front(&self) -> usize {
        self.front
    }

    /// Evaluates the program on the inputs `x`: output `j` is then
    /// `regs[j]`, or `regs[places[j]]` for a program with places.
    ///
    /// # Panics
    /// If `regs` is shorter than [`Machine::registers`], or an input is
    /// out of bounds.
    #[inline]
    pub(super) fn eval<S: Scalar>(&self, x: &Inputs<'_, S>, regs: &mut [S]) {
        self.load(x, regs);
        self.run(regs);
    }

    /// Loads the inputs into the registers.
    ///
    /// # Panics
    /// If `regs` is shorter than the program's registers, or an input is
    /// out of bounds.
    #[inline]
    fn load<S: Scalar>(&self, x: &Inputs<'_, S>, regs: &mut [S]) {
        let Inputs { params, indices, cols, q, qd, .. } = *x;
        assert!(regs.len() >= self.n_regs, "a tape's registers too short");
        let fill = |to: &mut [S], from: &[f64]| {
            for (r, &v) in to.iter_mut().zip(from) {
                *r = S::from_f64(v);
            }
        };
        fill(&mut regs[self.consts_at..][..self.consts.len()], &self.consts);
        fill(&mut regs[self.params_at..][..self.n_params], &params[..self.n_params]);
        fill(&mut regs[self.indices_at..][..self.n_indices], &indices[..self.n_indices]);
        let r = regs.as_mut_ptr();
        // SAFETY: `check` saw every load's register below `n_regs`, which
        // `regs` holds.
        unsafe {
            for &(s, k, reg) in &self.q_at {
                *r.add(reg as usize) = q[cols[s] + k];
            }
            for &(s, k, reg) in &self.qd_at {
                *r.add(reg as usize) = qd[cols[s] + k];
            }
        }
    }

    /// Runs the steps on loaded registers.
    ///
    /// # Panics
    /// If `regs` is shorter than the program's registers.
    #[inline]
    fn run<S: Scalar>(&self, regs: &mut [S]) {
        assert!(regs.len() >= self.n_regs, "a tape's registers too short");
        let r = regs.as_mut_ptr();
        for s in &self.steps {
            // SAFETY: `check` saw every register a step touches below
            // `n_regs`, which `regs` holds.
            unsafe {
                let at = |k: u32| *r.add(k as usize);
                let a = at(s.a);
                let v = match s.code {
                    Code::Add => a + at(s.b),
                    Code::Mul => a * at(s.b),
                    Code::MulAdd => a * at(s.b) + at(s.c),
                    Code::AddMul => at(s.c) + a * at(s.b),
                    Code::MulAddMul => a * at(s.b) + at(s.c) * at(s.d),
                    Code::MulMul => a * at(s.b) * at(s.c),
                    Code::MulByMul => at(s.c) * (a * at(s.b)),
                    Code::AddMulBy => (a + at(s.b)) * at(s.c),
                    Code::MulByAdd => at(s.c) * (a + at(s.b)),
                    Code::NegMul => -(a * at(s.b)),
                    Code::Neg => -a,
                    Code::Recip => a.recip(),
                    Code::Powi => a.powi(s.b as i32),
                    Code::Sin => a.sin(),
                    Code::Cos => a.cos(),
                    Code::Sqrt => a.sqrt(),
                    Code::SinCos => {
                        let (sin, cos) = a.sin_cos();
                        *r.add(s.b as usize) = cos;
                        sin
                    }
                    Code::Copy => a,
                };
                *r.add(s.dst as usize) = v;
            }
        }
    }
}

/// The register machine's steps for `ins`: each operation, with the
/// operations whose value only it reads (and no output, `out` listing
/// their registers) folded in where a fused code fits (a product, sum or
/// negation feeding a sum or a product, evaluated then, in the same
/// order: registers are written once, so a value computed later is the
/// same value).
fn steps(ins: &[Ins], out: &[u32], n_regs: usize) -> Vec<Step> {
    // reads of each register, outputs counted as more than one
    let mut reads = vec![0u32; n_regs];
    for i in ins {
        reads[i.a as usize] += 1;
        if matches!(i.op, Op::Add | Op::Mul) {
            reads[i.b as usize] += 1;
        }
    }
    for &o in out {
        reads[o as usize] += 2;
    }
    // the instruction defining each register read once, where it may fold
    let mut def: Vec<Option<usize>> = vec![None; n_regs];
    for (k, i) in ins.iter().enumerate() {
        if matches!(i.op, Op::Add | Op::Mul | Op::Neg) && reads[i.dst as usize] == 1 {
            def[i.dst as usize] = Some(k);
        }
    }
    let mut folded = vec![false; ins.len()];
    let mut steps = Vec::with_capacity(ins.len());
    for (k, i) in ins.iter().enumerate().rev() {
        if folded[k] {
            continue;
        }
        let kid = |r: u32, op: Op| def[r as usize].filter(|&j| ins[j].op == op);
        let mut fold = |j: usize| {
            folded[j] = true;
            (ins[j].a, ins[j].b)
        };
        let step = |code, a, b, c, d| Step { code, dst: i.dst, a, b, c, d };
        let s = match i.op {
            Op::Add => match (kid(i.a, Op::Mul), kid(i.b, Op::Mul)) {
                (Some(x), Some(y)) => {
                    let ((a, b), (c, d)) = (fold(x), fold(y));
                    step(Code::MulAddMul, a, b, c, d)
                }
                (Some(x), None) => {
                    let (a, b) = fold(x);
                    step(Code::MulAdd, a, b, i.b, 0)
                }
                (None, Some(y)) => {
                    let (a, b) = fold(y);
                    step(Code::AddMul, a, b, i.a, 0)
                }
                (None, None) => step(Code::Add, i.a, i.b, 0, 0),
            },
            Op::Mul => match (kid(i.a, Op::Mul), kid(i.b, Op::Mul), kid(i.a, Op::Add), kid(i.b, Op::Add)) {
                (Some(x), ..) => {
                    let (a, b) = fold(x);
                    step(Code::MulMul, a, b, i.b, 0)
                }
                (None, Some(y), ..) => {
                    let (a, b) = fold(y);
                    step(Code::MulByMul, a, b, i.a, 0)
                }
                (None, None, Some(x), _) => {
                    let (a, b) = fold(x);
                    step(Code::AddMulBy, a, b, i.b, 0)
                }
                (None, None, None, Some(y)) => {
                    let (a, b) = fold(y);
                    step(Code::MulByAdd, a, b, i.a, 0)
                }
                (None, None, None, None) => step(Code::Mul, i.a, i.b, 0, 0),
            },
            Op::Neg => match kid(i.a, Op::Mul) {
                Some(x) => {
                    let (a, b) = fold(x);
                    step(Code::NegMul, a, b, 0, 0)
                }
                None => step(Code::Neg, i.a, 0, 0, 0),
            },
            Op::Recip => step(Code::Recip, i.a, 0, 0, 0),
            Op::Powi(n) => step(Code::Powi, i.a, n as u32, 0, 0),
            Op::Sin => step(Code::Sin, i.a, 0, 0, 0),
            Op::Cos => step(Code::Cos, i.a, 0, 0, 0),
            Op::SinCos => step(Code::SinCos, i.a, i.b, 0, 0),
            Op::Sqrt => step(Code::Sqrt, i.a, 0, 0, 0),
        };
        steps.push(s);
    }
    steps.reverse();
    steps
}
