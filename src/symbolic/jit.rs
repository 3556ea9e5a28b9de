//! Native code for a [`Program`]: the instruction list translated once into machine code
//! with Cranelift (the code generator of Wasmtime), so that evaluating a small model's
//! Jacobian is straight-line code like num-dual's, with no dispatch per instruction.
//!
//! Every value lives in a register (Cranelift's SSA values); `+ − · /`, `−a`, `|a|` and
//! `√a` are the IEEE instructions, and every other function is a call of the very Rust
//! function the interpreter calls (`f64::sin`, `f64::powi`, …). So the native code gives
//! the interpreter's results bit for bit (tested), only faster. Any failure to generate
//! code (an unsupported host) leaves the interpreter in charge: it is never an error.

use super::compile::{Ins, Op, Program};
use cranelift_codegen::ir::{
    AbiParam, InstBuilder, MemFlagsData, StackSlotData, StackSlotKind, UserFuncName, Value, types,
};
use cranelift_codegen::settings::{self, Configurable};
use cranelift_frontend::{FunctionBuilder, FunctionBuilderContext};
use cranelift_jit::{JITBuilder, JITModule};
use cranelift_module::{FuncId, Linkage, Module, default_libcall_names};
use std::sync::Arc;

/// Programs longer than this stay interpreted: native code pays off most on small
/// models, and code generation grows faster than the program (one basic block; measured
/// on the 1-D Brusselator: 5 ms for 900 instructions, 52 ms for 4 500, 0.76 s for 18 000).
pub const MAX_NATIVE_INSTRUCTIONS: usize = 5_000;

/// `out[offsets[k]] ← output k` at `(x, u, t)`, the constants and parameters read from
/// `consts` (the program's constant slots): `f(x, u, t, out, consts)`.
pub(crate) type NativeFn = unsafe extern "C" fn(*const f64, *const f64, f64, *mut f64, *const f64);

/// Generated functions and the module that owns their memory.
pub(crate) struct Native {
    module: Option<JITModule>,
    fns: Vec<NativeFn>,
}

// SAFETY: after `finalize_definitions` the module is never used again except to free its
// memory when the last `Arc` drops, and the code it holds is immutable and reentrant.
unsafe impl Send for Native {}
unsafe impl Sync for Native {}

impl Drop for Native {
    fn drop(&mut self) {
        if let Some(m) = self.module.take() {
            // SAFETY: the function pointers die with `self`; nothing calls them after this
            unsafe { m.free_memory() };
        }
    }
}

impl std::fmt::Debug for Native {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Native({} functions)", self.fns.len())
    }
}

impl Native {
    pub(crate) fn get(&self, k: usize) -> NativeFn {
        self.fns[k]
    }
}

macro_rules! unary {
    ($($name:ident => $e:expr),* $(,)?) => {
        $(extern "C" fn $name(a: f64) -> f64 { let f: fn(f64) -> f64 = $e; f(a) })*
    };
}
unary! {
    r_sin => f64::sin, r_cos => f64::cos, r_tan => f64::tan, r_exp => f64::exp,
    r_exp_m1 => f64::exp_m1, r_ln => f64::ln, r_ln_1p => f64::ln_1p, r_cbrt => f64::cbrt,
    r_sign => |a| super::graph::Func::Sign.eval(a), r_asin => f64::asin, r_acos => f64::acos,
    r_atan => f64::atan, r_sinh => f64::sinh, r_cosh => f64::cosh, r_tanh => f64::tanh,
    r_asinh => f64::asinh, r_acosh => f64::acosh, r_atanh => f64::atanh, r_trunc => f64::trunc,
}
extern "C" fn r_rem(a: f64, b: f64) -> f64 {
    a % b
}
extern "C" fn r_powi(a: f64, b: f64) -> f64 {
    a.powi(b as i32)
}
extern "C" fn r_powf(a: f64, b: f64) -> f64 {
    a.powf(b)
}
extern "C" fn r_atan2(a: f64, b: f64) -> f64 {
    a.atan2(b)
}
/// `sin a`, with `cos a` written to `*c`.
extern "C" fn r_sin_cos(a: f64, c: *mut f64) -> f64 {
    let (s, co) = a.sin_cos();
    // SAFETY: the generated code passes the address of an 8-byte stack slot
    unsafe { *c = co };
    s
}

/// The callee of an instruction that is a call: symbol, address, number of `f64` operands.
fn callee(op: Op) -> Option<(&'static str, *const u8, usize)> {
    macro_rules! c {
        ($n:literal, $f:ident, $k:expr) => {
            Some(($n, $f as *const u8, $k))
        };
    }
    match op {
        Op::Sin => c!("r_sin", r_sin, 1),
        Op::Cos => c!("r_cos", r_cos, 1),
        Op::Tan => c!("r_tan", r_tan, 1),
        Op::Exp => c!("r_exp", r_exp, 1),
        Op::ExpM1 => c!("r_exp_m1", r_exp_m1, 1),
        Op::Ln => c!("r_ln", r_ln, 1),
        Op::Ln1p => c!("r_ln_1p", r_ln_1p, 1),
        Op::Cbrt => c!("r_cbrt", r_cbrt, 1),
        Op::Sign => c!("r_sign", r_sign, 1),
        Op::Asin => c!("r_asin", r_asin, 1),
        Op::Acos => c!("r_acos", r_acos, 1),
        Op::Atan => c!("r_atan", r_atan, 1),
        Op::Sinh => c!("r_sinh", r_sinh, 1),
        Op::Cosh => c!("r_cosh", r_cosh, 1),
        Op::Tanh => c!("r_tanh", r_tanh, 1),
        Op::Asinh => c!("r_asinh", r_asinh, 1),
        Op::Acosh => c!("r_acosh", r_acosh, 1),
        Op::Atanh => c!("r_atanh", r_atanh, 1),
        Op::Trunc => c!("r_trunc", r_trunc, 1),
        Op::Rem => c!("r_rem", r_rem, 2),
        Op::Powi => c!("r_powi", r_powi, 2),
        Op::Powf => c!("r_powf", r_powf, 2),
        Op::Atan2 => c!("r_atan2", r_atan2, 2),
        _ => None,
    }
}

/// One generated function: where each output goes, and which slots of the output array
/// are set to `0.0` first (the entries outside a dense matrix's pattern).
pub(crate) struct Layout {
    pub offsets: Vec<usize>,
    pub zeros: Vec<usize>,
}

/// Native code for `program`, one function per layout; `None` if the program is too
/// long or the host is not supported.
pub(crate) fn compile(program: &Program, layouts: &[Layout]) -> Option<Arc<Native>> {
    if program.len() > MAX_NATIVE_INSTRUCTIONS {
        return None;
    }
    let mut flags = settings::builder();
    flags.set("use_colocated_libcalls", "false").ok()?;
    flags.set("is_pic", "false").ok()?;
    flags.set("opt_level", "speed").ok()?;
    let isa = cranelift_native::builder()
        .ok()?
        .finish(settings::Flags::new(flags))
        .ok()?;
    let mut jb = JITBuilder::with_isa(isa, default_libcall_names());
    jb.symbol("r_sin_cos", r_sin_cos as *const u8);
    // the functions this program calls
    for ins in program.parts().1 {
        if let Some((name, addr, _)) = callee(ins.op) {
            jb.symbol(name, addr);
        }
    }
    let mut module = JITModule::new(jb);
    let mut ids = Vec::new();
    for (k, layout) in layouts.iter().enumerate() {
        ids.push(define(&mut module, program, layout, k).ok()?);
    }
    module.finalize_definitions().ok()?;
    let fns = ids
        .iter()
        .map(|&id| {
            let code = module.get_finalized_function(id);
            // SAFETY: the function was defined with exactly this signature
            unsafe { std::mem::transmute::<*const u8, NativeFn>(code) }
        })
        .collect();
    Some(Arc::new(Native {
        module: Some(module),
        fns,
    }))
}

fn define(
    module: &mut JITModule,
    program: &Program,
    layout: &Layout,
    k: usize,
) -> Result<FuncId, Box<cranelift_module::ModuleError>> {
    let ptr = module.target_config().pointer_type();
    let mut sig = module.make_signature();
    for t in [ptr, ptr, types::F64, ptr, ptr] {
        sig.params.push(AbiParam::new(t));
    }
    let id = module
        .declare_function(&format!("jac{k}"), Linkage::Local, &sig)
        .map_err(Box::new)?;
    // the functions this program calls, each declared once
    let mut callees = std::collections::HashMap::new();
    for ins in program.parts().1 {
        let Some((name, _, n)) = callee(ins.op) else {
            continue;
        };
        if callees.contains_key(&ins.op) {
            continue;
        }
        let mut s = module.make_signature();
        for _ in 0..n {
            s.params.push(AbiParam::new(types::F64));
        }
        s.returns.push(AbiParam::new(types::F64));
        let id = module.declare_function(name, Linkage::Import, &s).map_err(Box::new)?;
        callees.insert(ins.op, id);
    }
    let mut s = module.make_signature();
    s.params.push(AbiParam::new(types::F64));
    s.params.push(AbiParam::new(ptr));
    s.returns.push(AbiParam::new(types::F64));
    let sin_cos = module
        .declare_function("r_sin_cos", Linkage::Import, &s)
        .map_err(Box::new)?;

    let cfg = module.target_config();
    let mut ctx = module.make_context();
    ctx.func.signature = sig;
    ctx.func.name = UserFuncName::user(0, id.as_u32());
    let mut fbc = FunctionBuilderContext::new();
    {
        let mut b = FunctionBuilder::new(&mut ctx.func, &mut fbc);
        let block = b.create_block();
        b.append_block_params_for_function_params(block);
        b.switch_to_block(block);
        let p = b.block_params(block).to_vec();
        let (xp, up, t, out, cp) = (p[0], p[1], p[2], p[3], p[4]);
        let flags = MemFlagsData::trusted();
        let slot = b.create_sized_stack_slot(StackSlotData::new(StackSlotKind::ExplicitSlot, 8, 3));
        let (template, ins, outputs) = program.parts();
        let mut val: Vec<Option<Value>> = vec![None; template.len()];
        let mut refs = std::collections::HashMap::new();
        // a constant slot is never written by an instruction: loaded from `consts` at its
        // first use (data, not code: the same code serves other constants and parameters)
        let get = |b: &mut FunctionBuilder, val: &mut Vec<Option<Value>>, s: u32| -> Value {
            *val[s as usize].get_or_insert_with(|| b.ins().load(types::F64, flags, cp, 8 * s as i32))
        };
        for &Ins { op, d, a, b: bb } in ins {
            let r = match op {
                Op::LoadX => b.ins().load(types::F64, flags, xp, 8 * a as i32),
                Op::LoadU => b.ins().load(types::F64, flags, up, 8 * a as i32),
                Op::LoadT => t,
                Op::Neg => {
                    let x = get(&mut b, &mut val, a);
                    b.ins().fneg(x)
                }
                Op::Abs => {
                    let x = get(&mut b, &mut val, a);
                    b.ins().fabs(x)
                }
                Op::Sqrt => {
                    let x = get(&mut b, &mut val, a);
                    b.ins().sqrt(x)
                }
                Op::Add | Op::Sub | Op::Mul | Op::NegMul | Op::Div => {
                    let x = get(&mut b, &mut val, a);
                    let y = get(&mut b, &mut val, bb);
                    match op {
                        Op::Add => b.ins().fadd(x, y),
                        Op::Sub => b.ins().fsub(x, y),
                        Op::Mul => b.ins().fmul(x, y),
                        Op::Div => b.ins().fdiv(x, y),
                        _ => {
                            let m = b.ins().fmul(x, y);
                            b.ins().fneg(m)
                        }
                    }
                }
                Op::SinCos => {
                    let x = get(&mut b, &mut val, a);
                    let f = *refs
                        .entry(None)
                        .or_insert_with(|| module.declare_func_in_func(sin_cos, b.func));
                    let addr = b.ins().stack_addr(ptr, slot, 0);
                    let call = b.ins().call(f, &[x, addr]);
                    let s = b.inst_results(call)[0];
                    let c = b.ins().stack_load(ptr, types::F64, slot, 0);
                    val[bb as usize] = Some(c);
                    s
                }
                _ => {
                    let (_, _, n) = callee(op).expect("every other instruction is a call");
                    let x = get(&mut b, &mut val, a);
                    let args = if n == 2 {
                        vec![x, get(&mut b, &mut val, bb)]
                    } else {
                        vec![x]
                    };
                    let f = *refs
                        .entry(Some(op))
                        .or_insert_with(|| module.declare_func_in_func(callees[&op], b.func));
                    let call = b.ins().call(f, &args);
                    b.inst_results(call)[0]
                }
            };
            val[d as usize] = Some(r);
        }
        let zero = b.ins().f64const(0.0);
        for &z in &layout.zeros {
            b.ins().store(flags, zero, out, (8 * z) as i32);
        }
        for (&o, &off) in outputs.iter().zip(&layout.offsets) {
            let v = get(&mut b, &mut val, o);
            b.ins().store(flags, v, out, (8 * off) as i32);
        }
        b.ins().return_(&[]);
        b.seal_all_blocks();
        b.finalize(cfg);
    }
    module.define_function(id, &mut ctx).map_err(Box::new)?;
    module.clear_context(&mut ctx);
    Ok(id)
}
