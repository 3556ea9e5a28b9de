pub mod csvio;
pub mod demo;
pub mod odometry;
pub mod simulate;
