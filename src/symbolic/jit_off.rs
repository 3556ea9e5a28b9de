//! Without the `jit` feature compiled symbolic Jacobians are interpreted: this module
//! keeps the interface of the native-code one and never generates code.

use super::compile::Program;
use std::sync::Arc;

/// With the `jit` feature, programs up to this length get native code; without it none do.
pub const MAX_NATIVE_INSTRUCTIONS: usize = 0;

pub(crate) type NativeFn = unsafe extern "C" fn(*const f64, *const f64, f64, *mut f64, *const f64);

/// No native code exists without the `jit` feature.
#[derive(Debug)]
pub(crate) enum Native {}

impl Native {
    pub(crate) fn get(&self, _k: usize) -> NativeFn {
        match *self {}
    }
}

#[allow(dead_code)]
pub(crate) struct Layout {
    pub offsets: Vec<usize>,
    pub zeros: Vec<usize>,
}

pub(crate) fn compile(_program: &Program, _layouts: &[Layout]) -> Option<Arc<Native>> {
    None
}
