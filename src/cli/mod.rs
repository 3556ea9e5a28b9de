pub mod csvio;
pub mod demo;
pub mod odometry;
pub mod plot;
pub mod registry;
pub mod report;
pub mod simulate;
pub mod studies;
