//! Studies of the methods themselves: observed order of convergence (and, later,
//! stiffness and work–precision).

/// Least-squares slope of `log e` against `log h`: the observed order `p` in `e ≈ C·hᵖ`
/// (PETSc `PetscConvEstGetConvRate`). Returns `None` for fewer than two points or any
/// non-positive value.
///
/// ```
/// let hs = [0.1, 0.05, 0.025, 0.0125];
/// let es: Vec<f64> = hs.iter().map(|h: &f64| 3.0 * h.powi(2)).collect();
/// let p = reckon::studies::fit_order(&hs, &es).unwrap();
/// assert!((p - 2.0).abs() < 1e-12);
/// ```
pub fn fit_order(h: &[f64], e: &[f64]) -> Option<f64> {
    if h.len() != e.len() || h.len() < 2 || h.iter().chain(e).any(|v| !(*v > 0.0 && v.is_finite())) {
        return None;
    }
    let n = h.len() as f64;
    let xs: Vec<f64> = h.iter().map(|v| v.ln()).collect();
    let ys: Vec<f64> = e.iter().map(|v| v.ln()).collect();
    let (mx, my) = (xs.iter().sum::<f64>() / n, ys.iter().sum::<f64>() / n);
    let sxy: f64 = xs.iter().zip(&ys).map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = xs.iter().map(|x| (x - mx).powi(2)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}
