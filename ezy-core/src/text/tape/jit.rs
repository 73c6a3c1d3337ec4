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

use super::{Op, Tape};

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
}

/// Compiles `tapes` into one module: their kernels in order, and the code
/// that holds them.
///
/// # Errors
/// The host has no Cranelift back end, or Cranelift refused a function
/// (a message; the caller keeps the tape evaluator).
pub(crate) fn compile(tapes: &[&Tape]) -> Result<(Code, Vec<Kernel>), String> {
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
    jb.symbol("ezy_powi", ezy_powi as *const u8);
    let mut module = JITModule::new(jb);
    let fail = |e: cranelift_module::ModuleError| format!("JIT compilation failed: {e}");

    let ptr = module.target_config().pointer_type();
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
        sin: module.declare_function("ezy_sin", Linkage::Import, &f64_fn(&module, None, true)).map_err(fail)?,
        cos: module.declare_function("ezy_cos", Linkage::Import, &f64_fn(&module, None, true)).map_err(fail)?,
        sincos: module
            .declare_function("ezy_sincos", Linkage::Import, &f64_fn(&module, Some(ptr), false))
            .map_err(fail)?,
        powi: module
            .declare_function("ezy_powi", Linkage::Import, &f64_fn(&module, Some(types::I32), true))
            .map_err(fail)?,
    };
    let mut sig = module.make_signature();
    sig.params.extend([AbiParam::new(ptr); 7]);

    let mut ctx = module.make_context();
    let mut fbc = FunctionBuilderContext::new();
    let mut ids = Vec::with_capacity(tapes.len());
    for tape in tapes {
        let id = module.declare_anonymous_function(&sig).map_err(fail)?;
        ctx.func.signature = sig.clone();
        build(&mut module, &mut ctx.func, &mut fbc, tape, ptr, &calls)?;
        module.define_function(id, &mut ctx).map_err(fail)?;
        module.clear_context(&mut ctx);
        ids.push(id);
    }
    module.finalize_definitions().map_err(fail)?;
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
    Ok((Code(Some(module)), kernels))
}

/// The offset `8 k` of element `k` of an `f64` or `usize` array, as a
/// Cranelift immediate.
fn offset(k: usize) -> Result<i32, String> {
    k.checked_mul(8)
        .and_then(|o| i32::try_from(o).ok())
        .ok_or_else(|| format!("a tape addresses element {k}, too far for the JIT"))
}

/// Writes `tape`'s kernel into `func`.
fn build(
    module: &mut JITModule,
    func: &mut ir::Function,
    fbc: &mut FunctionBuilderContext,
    tape: &Tape,
    ptr: ir::Type,
    calls: &Calls,
) -> Result<(), String> {
    let sin = module.declare_func_in_func(calls.sin, func);
    let cos = module.declare_func_in_func(calls.cos, func);
    let sincos = module.declare_func_in_func(calls.sincos, func);
    let powi = module.declare_func_in_func(calls.powi, func);
    let mut b = FunctionBuilder::new(func, fbc);
    let block = b.create_block();
    b.append_block_params_for_function_params(block);
    b.switch_to_block(block);
    b.seal_block(block);
    let args = b.block_params(block).to_vec();
    let (params, indices, cols, q, qd) = (args[0], args[1], args[2], args[3], args[4]);
    let mem = MemFlags::trusted();
    // where each register's value comes from: an input is loaded (a number
    // materialized) where it is first used, so that its value lives no
    // longer than it must (a tape reading thousands of parameters would
    // otherwise hold them all from the start)
    #[derive(Clone, Copy)]
    enum Src {
        Unset,
        Const(f64),
        Param(usize),
        Index(usize),
        Q(bool, usize),
        Value(Value),
    }
    let mut regs: Vec<Src> = vec![Src::Unset; tape.n_regs];
    for (r, &c) in tape.consts.iter().enumerate() {
        regs[r] = Src::Const(c);
    }
    for &(i, r) in &tape.params {
        regs[r as usize] = Src::Param(i);
    }
    for &(k, r) in &tape.indices {
        regs[r as usize] = Src::Index(k);
    }
    for (is_qd, list) in [(false, &tape.q), (true, &tape.qd)] {
        for &(k, r) in list {
            regs[r as usize] = Src::Q(is_qd, k);
        }
    }
    // the address of slot `s`'s first coordinate in `q` (or `qd`), computed
    // once per slot, at the top
    let mut bases: std::collections::HashMap<(bool, usize), Value> = std::collections::HashMap::new();
    for (is_qd, list) in [(false, &tape.q), (true, &tape.qd)] {
        for &(k, _) in list {
            if let std::collections::hash_map::Entry::Vacant(e) = bases.entry((is_qd, k / 3)) {
                let col = b.ins().load(ptr, mem, cols, offset(k / 3)?);
                let bytes = b.ins().ishl_imm(col, 3);
                e.insert(b.ins().iadd(if is_qd { qd } else { q }, bytes));
            }
        }
    }
    let slot = b.create_sized_stack_slot(StackSlotData::new(StackSlotKind::ExplicitSlot, 16, 3));
    let get = |b: &mut FunctionBuilder, regs: &mut [Src], r: u32| -> Result<Value, String> {
        let v = match regs[r as usize] {
            Src::Value(v) => return Ok(v),
            Src::Unset => return Err(format!("register {r} read before it is set")),
            Src::Const(c) => b.ins().f64const(c),
            Src::Param(i) => b.ins().load(types::F64, mem, params, offset(i)?),
            Src::Index(k) => b.ins().load(types::F64, mem, indices, offset(k)?),
            Src::Q(is_qd, k) => b.ins().load(types::F64, mem, bases[&(is_qd, k / 3)], offset(k % 3)?),
        };
        regs[r as usize] = Src::Value(v);
        Ok(v)
    };
    for ins in &tape.ins {
        let a = get(&mut b, &mut regs, ins.a)?;
        let v = match ins.op {
            Op::Add => {
                let y = get(&mut b, &mut regs, ins.b)?;
                b.ins().fadd(a, y)
            }
            Op::Mul => {
                let y = get(&mut b, &mut regs, ins.b)?;
                b.ins().fmul(a, y)
            }
            Op::Neg => b.ins().fneg(a),
            Op::Recip => {
                let one = b.ins().f64const(1.0);
                b.ins().fdiv(one, a)
            }
            Op::Sqrt => b.ins().sqrt(a),
            Op::Sin | Op::Cos => {
                let call = b.ins().call(if ins.op == Op::Sin { sin } else { cos }, &[a]);
                b.inst_results(call)[0]
            }
            Op::Powi(n) => {
                let n = b.ins().iconst(types::I32, i64::from(n));
                let call = b.ins().call(powi, &[a, n]);
                b.inst_results(call)[0]
            }
            Op::SinCos => {
                let at = b.ins().stack_addr(ptr, slot, 0);
                b.ins().call(sincos, &[a, at]);
                let s = b.ins().stack_load(types::F64, slot, 0);
                regs[ins.b as usize] = Src::Value(b.ins().stack_load(types::F64, slot, 8));
                s
            }
        };
        regs[ins.dst as usize] = Src::Value(v);
    }
    for (j, &o) in tape.out.iter().enumerate() {
        let v = get(&mut b, &mut regs, o)?;
        let (dst, at) = if j < tape.split { (args[5], j) } else { (args[6], j - tape.split) };
        b.ins().store(MemFlags::trusted(), v, dst, offset(at)?);
    }
    b.ins().return_(&[]);
    b.finalize();
    Ok(())
}
