//! Helpers shared by several test modules.

pub mod bruss;
pub mod drives;
pub mod golden;
