//! Vehicle models written as closures over the state, with exact flows where known.
pub mod unicycle;
