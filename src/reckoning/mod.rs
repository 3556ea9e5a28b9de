//! Dead reckoning: wheel-encoder and IMU odometry, error models, drift studies.
pub mod drift;
pub mod encoders;
pub mod errors;
pub mod imu;
