//! Tapes compiled to machine code with Cranelift: the JIT evaluator of
//! models read from text (`f64` only; dual numbers stay on the tape).
//!
//! Each tape becomes one function
//! `kernel(params, indices, cols, q, qd, a, b)` that loads its inputs as
//! [`super::Inputs`] describes them, computes the tape's operations in
//! the tape's order and stores output `j` at `a[j]` below the tape's
//! split, at `b[j - split]` from it on. The operations are
//! the tape's, one Cranelift instruction each (`fadd`, `fmul`, `fneg`,
//! `fdiv` for `1 / x`, `sqrt`), and Cranelift neither reassociates nor
//! fuses floating point, so a kernel gives the tape's numbers bit for
//! bit. Sine, cosine and integer powers are calls to the functions the
//! `f64` [`crate::Scalar`] uses (`libm`'s `sin`, `cos`, `sincos`, Rust's
//! `powi`), the same library the compiled models call.

use std::fmt;

use cranelift_codegen::ir::{self, AbiParam, InstBuilder, MemFlags, StackSlotData, StackSlotKind, Value, types};
use cranelift_codegen::settings::{self, Configurable};
use cranelift_frontend::{FunctionBuilder, FunctionBuilderContext};
use cranelift_jit::{JITBuilder, JITModule};
use cranelift_module::{FuncId, Linkage, Module, default_libcall_names};

use super::Tape;
use super::machine::Op;

/// A compiled tape: `kernel(params, indices, cols, q, qd, a, b)`.
///
/// # Safety
/// Every input the tape reads must be in bounds (its parameters, indices,
/// the slots of `cols` it reads and `q[cols[s] + 0..3]`, `qd[..]` for
/// each: [`Tape::fits`]), `a` must hold the outputs before the tape's
/// split and `b` those from it on.
pub(crate) type Kernel =
    unsafe extern "C" fn(*const f64, *const f64, *const usize, *const f64, *const f64, *mut f64, *mut f64);

/// The machine code of a model's kernels. It lives as long as the model's
/// plan (every kernel pointer into it is held there) and is unmapped when
/// the plan is dropped.
pub(crate) struct Code(Option<JITModule>);

// SAFETY: after `finalize_definitions` the module is only kept to free its
// memory on drop; nothing reads or writes it from two threads, and the
// finalized code it owns is immutable.
unsafe impl Send for Code {}
// SAFETY: as for `Send`: no method of `Code` takes `&self`.
unsafe impl Sync for Code {}

// Nothing of `Code` is seen or changed after finalization: a panic cannot
// leave it half-changed (so a model holding it may cross `catch_unwind`).
impl std::panic::UnwindSafe for Code {}
impl std::panic::RefUnwindSafe for Code {}

impl Drop for Code {
    fn drop(&mut self) {
        if let Some(module) = self.0.take() {
            // SAFETY: the kernels into this memory are held by the plan that
            // owns this `Code` and are dropped with it, never called after.
            unsafe { module.free_memory() }
        }
    }
}

impl fmt::Debug for Code {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("Code(..)")
    }
}

extern "C" fn ezy_sin(x: f64) -> f64 {
    libm::sin(x)
}

extern "C" fn ezy_cos(x: f64) -> f64 {
    libm::cos(x)
}

/// `out[0] = sin x`, `out[1] = cos x` (`libm::sincos`, as the `f64`
/// scalar's `sin_cos`).
extern "C" fn ezy_sincos(x: f64, out: *mut f64) {
    let (s, c) = libm::sincos(x);
    // SAFETY: the kernel passes a 16-byte stack slot.
    unsafe {
        *out = s;
        *out.add(1) = c;
    }
}

/// `sin x`, `cos x` in registers: a struct of two `f64` is returned in
/// `xmm0`, `xmm1` by the System V ABI, where Cranelift returns two `f64`
/// results ([`Pairs`]).
#[repr(C)]
struct SinCos {
    sin: f64,
    cos: f64,
}

extern "C" fn ezy_sincos_pair(x: f64) -> SinCos {
    let (sin, cos) = libm::sincos(x);
    SinCos { sin, cos }
}

/// How `sincos` returns its pair: in two registers where the host's
/// calling convention returns a two-`f64` struct as Cranelift returns two
/// `f64` (System V on x86-64), through a stack slot elsewhere.
#[derive(Clone, Copy, PartialEq)]
enum Pairs {
    Registers,
    Memory,
}

extern "C" fn ezy_powi(x: f64, n: i32) -> f64 {
    f64::powi(x, n)
}

/// The longest tape compiled \[operations\]: Cranelift's register
/// allocation grows faster than linearly in a function's length (a tape
/// of 3,900 operations took 50-70 ms, one of 9,000 up to 340 ms, against
/// 5 ms for all 40 of the EzyRoller's, 1,154 operations); a longer tape
/// stays on the register machine, which gives the same numbers.
pub(crate) const MAX_OPS: usize = 4096;

/// The most operations compiled per model: beyond, tapes stay on the
/// register machine (a text of [`super::super::MAX_TEXT_BYTES`] may
/// derive into many tapes).
pub(crate) const MAX_MODEL_OPS: usize = 1 << 16;

/// The host functions a kernel calls, declared in the module.
struct Calls {
    sin: FuncId,
    cos: FuncId,
    sincos: FuncId,
    powi: FuncId,
    pairs: Pairs,
}

/// The host functions as one function being built refers to them, and the
/// 16-byte stack slot `sincos` writes its pair to.
pub(crate) struct Refs {
    sin: ir::FuncRef,
    cos: ir::FuncRef,
    sincos: ir::FuncRef,
    powi: ir::FuncRef,
    pairs: Pairs,
    slot: ir::StackSlot,
    /// The host's pointer type.
    pub(crate) ptr: ir::Type,
}

impl Refs {
    fn declare(module: &mut JITModule, calls: &Calls, b: &mut FunctionBuilder) -> Self {
        let ptr = module.target_config().pointer_type();
        Refs {
            ptr,
            sin: module.declare_func_in_func(calls.sin, b.func),
            cos: module.declare_func_in_func(calls.cos, b.func),
            sincos: module.declare_func_in_func(calls.sincos, b.func),
            pairs: calls.pairs,
            powi: module.declare_func_in_func(calls.powi, b.func),
            slot: b.create_sized_stack_slot(StackSlotData::new(StackSlotKind::ExplicitSlot, 16, 3)),
        }
    }
}

/// A function compiled beside the tapes' kernels into the same module
/// (the fused right-hand side of [`crate::text`]'s minimal coordinates).
pub(crate) trait Extra {
    /// Its signature's parameters and results (`ptr`: the pointer type).
    fn signature(&self, sig: &mut ir::Signature, ptr: ir::Type);
    /// Writes its body into `b` (the entry block not yet created).
    ///
    /// # Errors
    /// A message: Cranelift refused, or an address does not fit.
    fn build(&self, b: &mut FunctionBuilder, refs: &Refs) -> Result<(), String>;
}

/// What a tape reads, as [`emit`] asks its caller to load it.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Input {
    Param(usize),
    Index(usize),
    /// Local coordinate `k` of `q` (slot `k / 3`).
    Q(usize),
    /// Local coordinate `k` of `qd`.
    Qd(usize),
}

/// The Cranelift settings of every module: optimized, calls to host
/// functions by absolute address.
fn module() -> Result<JITModule, String> {
    let mut flags = settings::builder();
    let set =
        |f: &mut settings::Builder, k: &str, v: &str| f.set(k, v).map_err(|e| format!("cranelift setting {k}: {e}"));
    set(&mut flags, "opt_level", "speed")?;
    set(&mut flags, "use_colocated_libcalls", "false")?;
    set(&mut flags, "is_pic", "false")?;
    let isa = cranelift_native::builder()
        .map_err(|e| format!("no JIT for this machine: {e}"))?
        .finish(settings::Flags::new(flags))
        .map_err(|e| format!("no JIT for this machine: {e}"))?;
    let mut jb = JITBuilder::with_isa(isa, default_libcall_names());
    jb.symbol("ezy_sin", ezy_sin as *const u8);
    jb.symbol("ezy_cos", ezy_cos as *const u8);
    jb.symbol("ezy_sincos", ezy_sincos as *const u8);
    jb.symbol("ezy_sincos_pair", ezy_sincos_pair as *const u8);
    jb.symbol("ezy_powi", ezy_powi as *const u8);
    Ok(JITModule::new(jb))
}

fn failed(e: cranelift_module::ModuleError) -> String {
    format!("JIT compilation failed: {e}")
}

/// Compiles `tapes` and `extras` into one module: the tapes' kernels in
/// order, the extras' entry points in order, and the code that holds them.
///
/// # Errors
/// The host has no Cranelift back end, or Cranelift refused a function
/// (a message; the caller keeps the tape evaluator).
pub(crate) fn compile(tapes: &[&Tape], extras: &[&dyn Extra]) -> Result<(Code, Vec<Kernel>, Vec<*const u8>), String> {
    let mut module = module()?;
    let ptr = module.target_config().pointer_type();
    // the JIT compiles for the host
    let pairs = if cfg!(target_arch = "x86_64")
        && module.isa().default_call_conv() == cranelift_codegen::isa::CallConv::SystemV
    {
        Pairs::Registers
    } else {
        Pairs::Memory
    };
    let f64_fn = |module: &JITModule, extra: Option<ir::Type>, ret: bool| {
        let mut s = module.make_signature();
        s.params.push(AbiParam::new(types::F64));
        if let Some(t) = extra {
            s.params.push(AbiParam::new(t));
        }
        if ret {
            s.returns.push(AbiParam::new(types::F64));
        }
        s
    };
    let calls = Calls {
        sin: module.declare_function("ezy_sin", Linkage::Import, &f64_fn(&module, None, true)).map_err(failed)?,
        cos: module.declare_function("ezy_cos", Linkage::Import, &f64_fn(&module, None, true)).map_err(failed)?,
        sincos: if pairs == Pairs::Registers {
            let mut s = f64_fn(&module, None, true);
            s.returns.push(AbiParam::new(types::F64));
            module.declare_function("ezy_sincos_pair", Linkage::Import, &s).map_err(failed)?
        } else {
            module
                .declare_function("ezy_sincos", Linkage::Import, &f64_fn(&module, Some(ptr), false))
                .map_err(failed)?
        },
        pairs,
        powi: module
            .declare_function("ezy_powi", Linkage::Import, &f64_fn(&module, Some(types::I32), true))
            .map_err(failed)?,
    };
    let mut sig = module.make_signature();
    sig.params.extend([AbiParam::new(ptr); 7]);

    let mut ctx = module.make_context();
    let mut fbc = FunctionBuilderContext::new();
    let mut define = |module: &mut JITModule,
                      sig: &ir::Signature,
                      body: &dyn Fn(&mut FunctionBuilder, &Refs) -> Result<(), String>|
     -> Result<FuncId, String> {
        let id = module.declare_anonymous_function(sig).map_err(failed)?;
        ctx.func.signature = sig.clone();
        {
            let mut b = FunctionBuilder::new(&mut ctx.func, &mut fbc);
            let refs = Refs::declare(module, &calls, &mut b);
            body(&mut b, &refs)?;
            b.finalize();
        }
        module.define_function(id, &mut ctx).map_err(failed)?;
        module.clear_context(&mut ctx);
        Ok(id)
    };
    let mut ids = Vec::with_capacity(tapes.len());
    for tape in tapes {
        ids.push(define(&mut module, &sig, &|b, refs| build(b, tape, refs))?);
    }
    let mut extra_ids = Vec::with_capacity(extras.len());
    for extra in extras {
        let mut sig = module.make_signature();
        extra.signature(&mut sig, ptr);
        extra_ids.push(define(&mut module, &sig, &|b, refs| extra.build(b, refs))?);
    }
    module.finalize_definitions().map_err(failed)?;
    let kernels = ids
        .iter()
        .map(|&id| {
            let code = module.get_finalized_function(id);
            // SAFETY: `code` is a finalized function of signature `sig`:
            // seven pointer arguments, no result, the host's calling
            // convention (`make_signature`), which is `extern "C"`.
            unsafe { std::mem::transmute::<*const u8, Kernel>(code) }
        })
        .collect();
    let extras = extra_ids.iter().map(|&id| module.get_finalized_function(id)).collect();
    Ok((Code(Some(module)), kernels, extras))
}

/// The offset `8 k` of element `k` of an `f64` or `usize` array, as a
/// Cranelift immediate.
pub(crate) fn offset(k: usize) -> Result<i32, String> {
    k.checked_mul(8)
        .and_then(|o| i32::try_from(o).ok())
        .ok_or_else(|| format!("a tape addresses element {k}, too far for the JIT"))
}

/// Writes `tape`'s kernel into `b`.
fn build(b: &mut FunctionBuilder, tape: &Tape, refs: &Refs) -> Result<(), String> {
    let ptr = refs.ptr;
    let block = b.create_block();
    b.append_block_params_for_function_params(block);
    b.switch_to_block(block);
    b.seal_block(block);
    let args = b.block_params(block).to_vec();
    let (params, indices, cols, q, qd) = (args[0], args[1], args[2], args[3], args[4]);
    let mem = MemFlags::trusted();
    // the parameters, indices and columns do not change during a call:
    // their loads may move to where they are used
    let fixed = mem.with_readonly().with_can_move();
    // the address of slot `s`'s first coordinate in `q` (or `qd`), computed
    // once per slot, at the top
    let mut bases: std::collections::HashMap<(bool, usize), Value> = std::collections::HashMap::new();
    for (is_qd, list) in [(false, &tape.q), (true, &tape.qd)] {
        for &(k, _) in list {
            if let std::collections::hash_map::Entry::Vacant(e) = bases.entry((is_qd, k / 3)) {
                let col = b.ins().load(ptr, fixed, cols, offset(k / 3)?);
                let bytes = b.ins().ishl_imm(col, 3);
                e.insert(b.ins().iadd(if is_qd { qd } else { q }, bytes));
            }
        }
    }
    let outputs = emit(b, tape, refs, &mut |b, input| {
        Ok(match input {
            Input::Param(i) => b.ins().load(types::F64, fixed, params, offset(i)?),
            Input::Index(k) => b.ins().load(types::F64, fixed, indices, offset(k)?),
            Input::Q(k) => b.ins().load(types::F64, mem, bases[&(false, k / 3)], offset(k % 3)?),
            Input::Qd(k) => b.ins().load(types::F64, mem, bases[&(true, k / 3)], offset(k % 3)?),
        })
    })?;
    for (j, v) in outputs.into_iter().enumerate() {
        let (dst, at) = if j < tape.split { (args[5], j) } else { (args[6], j - tape.split) };
        b.ins().store(MemFlags::trusted(), v, dst, offset(at)?);
    }
    b.ins().return_(&[]);
    Ok(())
}

/// Emits `tape`'s operations at the builder's position and returns its
/// outputs' values (in the tape's order). An input is asked of `load`
/// where it is first used, so that its value lives no longer than it
/// must (a tape reading thousands of parameters would otherwise hold them
/// all from the start); a number is materialized there too.
///
/// # Errors
/// A register read before it is set (a malformed tape), or `load`'s.
pub(crate) fn emit(
    b: &mut FunctionBuilder,
    tape: &Tape,
    refs: &Refs,
    load: &mut dyn FnMut(&mut FunctionBuilder, Input) -> Result<Value, String>,
) -> Result<Vec<Value>, String> {
    #[derive(Clone, Copy)]
    enum Src {
        Unset,
        Const(f64),
        In(Input),
        Value(Value),
    }
    let mut regs: Vec<Src> = vec![Src::Unset; tape.n_regs];
    for (r, &c) in tape.consts.iter().enumerate() {
        regs[r] = Src::Const(c);
    }
    let inputs = [
        (&tape.params, Input::Param as fn(usize) -> Input),
        (&tape.indices, Input::Index),
        (&tape.q, Input::Q),
        (&tape.qd, Input::Qd),
    ];
    for (list, input) in inputs {
        for &(k, r) in list {
            regs[r as usize] = Src::In(input(k));
        }
    }
    let mut get = |b: &mut FunctionBuilder, regs: &mut [Src], r: u32| -> Result<Value, String> {
        let v = match regs[r as usize] {
            Src::Value(v) => return Ok(v),
            Src::Unset => return Err(format!("register {r} read before it is set")),
            Src::Const(c) => b.ins().f64const(c),
            Src::In(input) => load(b, input)?,
        };
        regs[r as usize] = Src::Value(v);
        Ok(v)
    };
    // `x + (-y)` is `x - y` exactly (IEEE 754 defines the difference so):
    // the negation's operand, by the negation's value
    let mut negated: std::collections::HashMap<Value, Value> = std::collections::HashMap::new();
    for ins in &tape.ins {
        let a = get(b, &mut regs, ins.a)?;
        let v = match ins.op {
            Op::Add => {
                let y = get(b, &mut regs, ins.b)?;
                match (negated.get(&y), negated.get(&a)) {
                    (Some(&ny), _) => b.ins().fsub(a, ny),
                    (None, Some(&na)) => b.ins().fsub(y, na),
                    (None, None) => b.ins().fadd(a, y),
                }
            }
            Op::Mul => {
                let y = get(b, &mut regs, ins.b)?;
                b.ins().fmul(a, y)
            }
            Op::Neg => {
                let v = b.ins().fneg(a);
                negated.insert(v, a);
                v
            }
            Op::Recip => {
                let one = b.ins().f64const(1.0);
                b.ins().fdiv(one, a)
            }
            Op::Sqrt => b.ins().sqrt(a),
            Op::Sin | Op::Cos => {
                let call = b.ins().call(if ins.op == Op::Sin { refs.sin } else { refs.cos }, &[a]);
                b.inst_results(call)[0]
            }
            Op::Powi(n) => {
                let n = b.ins().iconst(types::I32, i64::from(n));
                let call = b.ins().call(refs.powi, &[a, n]);
                b.inst_results(call)[0]
            }
            Op::SinCos if refs.pairs == Pairs::Registers => {
                let call = b.ins().call(refs.sincos, &[a]);
                let (s, c) = (b.inst_results(call)[0], b.inst_results(call)[1]);
                regs[ins.b as usize] = Src::Value(c);
                s
            }
            Op::SinCos => {
                let at = b.ins().stack_addr(refs.ptr, refs.slot, 0);
                b.ins().call(refs.sincos, &[a, at]);
                let s = b.ins().stack_load(types::F64, refs.slot, 0);
                regs[ins.b as usize] = Src::Value(b.ins().stack_load(types::F64, refs.slot, 8));
                s
            }
        };
        regs[ins.dst as usize] = Src::Value(v);
    }
    tape.out.iter().map(|&o| get(b, &mut regs, o)).collect()
}
