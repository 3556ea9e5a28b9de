//! Odometry calibration: parameters from test drives, with their covariance.
pub mod lsq;
