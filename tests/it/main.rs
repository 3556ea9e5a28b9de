//! The library's integration tests, one binary (one link of the whole crate instead of
//! one per file); `tests/alloc.rs` and `tests/no_leak.rs` stay separate binaries because
//! each installs a counting global allocator. Run one file's tests with
//! `cargo test --release --test it <module>::`.

mod common;

mod adaptive;
mod auto;
mod bdf;
mod calibration;
mod carlike_exact;
mod convergence;
mod dae;
mod drift;
mod driver;
mod ensemble;
mod errors;
mod exponential_euler;
mod fail_safe;
mod fast_path;
mod golden;
mod handwritten;
mod hybrid;
mod imu;
mod jacobian;
mod kalman;
mod layers;
mod lie;
mod lie_integrators;
mod literals;
mod lsq;
mod lti;
mod manifold;
mod model_cache;
mod odometry;
mod reliability;
mod rodas;
mod save;
mod sensitivity;
mod sparse;
mod spectral;
mod stiff;
mod studies;
mod symbolic;
mod tableau;
mod vehicles;
