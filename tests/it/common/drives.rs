//! Test drives shared by the calibration tests and the sensitivity bench.
#![allow(dead_code)]

use nalgebra::Vector3;
use reckon::Controls;
use reckon::reckoning::drift::square;
use reckon::reckoning::encoder_sim::{EncoderErrors, EncoderRun, simulate};
use reckon::reckoning::encoders::DiffDrive;

/// Wheel speeds (rad/s) changing every 2 s over 60 s: straight runs and turns both ways.
pub fn wheel_speed_log() -> Controls {
    let pattern = [
        (10.0, 10.0),
        (6.0, 12.0),
        (12.0, 12.0),
        (12.0, 5.0),
        (-4.0, 4.0),
        (8.0, 9.0),
    ];
    let t: Vec<f64> = (0..30).map(|k| 2.0 * k as f64).collect();
    let u = (0..30).map(|k| vec![pattern[k % 6].0, pattern[k % 6].1]).collect();
    Controls::new(t, u).unwrap()
}

/// The nominal robot of [`square_log`]: D = 0.1 m, B = 0.5 m, 2048 pulses per revolution.
pub fn square_robot() -> DiffDrive {
    DiffDrive::new(0.1, 0.5, 2048.0).unwrap()
}

/// A 3 m square driven clockwise then counter-clockwise by [`square_robot`] whose true left
/// wheel is 0.4 % large, right wheel 0.3 % small and wheelbase 2 % long, sampled every 50 ms
/// (no noise): the encoder counts and the true poses.
pub fn square_log() -> EncoderRun {
    let e = EncoderErrors {
        left_scale: 1.004,
        right_scale: 0.997,
        wheelbase_scale: 1.02,
        ..Default::default()
    };
    let mut cmds = square(3.0, true, 0.5, 0.8);
    cmds.extend(square(3.0, false, 0.5, 0.8));
    simulate(&square_robot(), &e, &cmds, 0.05, Vector3::zeros())
}
