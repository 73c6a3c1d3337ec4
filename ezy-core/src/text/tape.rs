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

use ezy_lang::sym::{Arena, Id, Node, Sym};

use crate::scalar::Scalar;

/// One operation of a tape.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Op {
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

/// `dst = op(a, b)` on the registers.
#[derive(Clone, Copy, Debug)]
struct Ins {
    op: Op,
    dst: u32,
    a: u32,
    b: u32,
}

/// Straight-line code computing some outputs from a model's parameters,
/// the family indices of an element and the local coordinates of the
/// bodies it touches (slot `s` owns local coordinates `3 s .. 3 s + 3`).
/// Its registers: the inputs it reads (numbers, then what is loaded per
/// evaluation), then one per computed value.
#[derive(Clone, Debug, Default)]
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
    ins: Vec<Ins>,
    /// The register of each output.
    out: Vec<u32>,
    n_regs: usize,
}

impl Tape {
    /// The tape computing `outputs` (ids of `ar`).
    pub(crate) fn new(ar: &Arena, outputs: &[Id]) -> Self {
        let ids = ar.reachable(outputs);
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
        t
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
        self.load(x, regs);
        self.run(regs);
        for (j, &o) in self.out.iter().enumerate() {
            sink(j, regs[o as usize]);
        }
    }

    /// Loads the inputs into the registers (so that the caller may then
    /// write over what they were read from).
    #[inline]
    pub(crate) fn load<S: Scalar>(&self, x: &Inputs<'_, S>, regs: &mut [S]) {
        let Inputs { params, indices, cols, q, qd } = *x;
        for (r, &c) in regs.iter_mut().zip(&self.consts) {
            *r = S::from_f64(c);
        }
        for &(i, r) in &self.params {
            regs[r as usize] = S::from_f64(params[i]);
        }
        for &(k, r) in &self.indices {
            regs[r as usize] = S::from_f64(indices[k]);
        }
        for &(k, r) in &self.q {
            regs[r as usize] = q[cols[k / 3] + k % 3];
        }
        for &(k, r) in &self.qd {
            regs[r as usize] = qd[cols[k / 3] + k % 3];
        }
    }

    /// Runs the operations on loaded registers; output `j` is then
    /// `regs[self.output(j)]`.
    #[inline]
    pub(crate) fn run<S: Scalar>(&self, regs: &mut [S]) {
        let regs = &mut regs[..self.n_regs];
        for ins in &self.ins {
            let a = regs[ins.a as usize];
            let v = match ins.op {
                Op::Add => a + regs[ins.b as usize],
                Op::Mul => a * regs[ins.b as usize],
                Op::Neg => -a,
                Op::Recip => a.recip(),
                Op::Powi(n) => a.powi(n),
                Op::Sin => a.sin(),
                Op::Cos => a.cos(),
                Op::Sqrt => a.sqrt(),
                Op::SinCos => {
                    let (s, c) = a.sin_cos();
                    regs[ins.b as usize] = c;
                    s
                }
            };
            regs[ins.dst as usize] = v;
        }
    }

    /// Number of outputs.
    #[inline]
    pub(crate) fn outputs(&self) -> usize {
        self.out.len()
    }

    /// The register of output `j`.
    #[inline]
    pub(crate) fn output(&self, j: usize) -> usize {
        self.out[j] as usize
    }

    /// Registers an evaluation needs.
    pub(crate) fn registers(&self) -> usize {
        self.n_regs
    }
}

/// What a tape reads for one element: parameter `i` is `params[i]`,
/// `Sym::Index(k)` is `indices[k]`, local coordinate `k` is
/// `q[cols[k / 3] + k % 3]` (and of `qd`).
#[derive(Clone, Copy)]
pub(crate) struct Inputs<'a, S> {
    pub(crate) params: &'a [f64],
    pub(crate) indices: &'a [f64],
    pub(crate) cols: &'a [usize],
    pub(crate) q: &'a [S],
    pub(crate) qd: &'a [S],
}

impl<'a> Inputs<'a, f64> {
    /// Parameters and indices alone (a tape that reads no coordinate).
    pub(crate) fn fixed(params: &'a [f64], indices: &'a [f64]) -> Self {
        Self { params, indices, cols: &[], q: &[], qd: &[] }
    }
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
