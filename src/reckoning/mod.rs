//! Dead reckoning: wheel-encoder and IMU odometry, error models, drift studies.
pub mod drift;
pub mod encoder_sim;
pub mod encoders;
pub mod imu;
pub mod preintegration;
