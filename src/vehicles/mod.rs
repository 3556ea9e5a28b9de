//! Vehicle models written as closures over the state, with exact flows where known.
//!
//! Conventions (REP-103): x forward, y left, z up, θ counter-clockwise from +x, SI
//! units; θ is integrated unwrapped and wrapped only for display.
pub mod bicycle;
pub mod body3d;
pub mod body_se3;
pub mod carlike;
pub mod rigid_body;
pub mod unicycle;

/// Wrap an angle to `(−π, π]` for display (integration keeps θ unwrapped).
///
/// ```
/// use reckon::vehicles::wrap_angle;
/// assert!((wrap_angle(3.0 * std::f64::consts::PI) - std::f64::consts::PI).abs() < 1e-15);
/// assert!((wrap_angle(-0.5) + 0.5).abs() < 1e-15);
/// ```
pub fn wrap_angle(a: f64) -> f64 {
    let two_pi = std::f64::consts::TAU;
    let w = a - two_pi * ((a + std::f64::consts::PI) / two_pi).floor();
    if w <= -std::f64::consts::PI { w + two_pi } else { w }
}
