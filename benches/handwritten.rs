//! A minimal hand-written Dormand–Prince 5(4) loop over fixed arrays, with the same
//! controller (Hairer's PI, β = 0.04), initial step (HINIT) and end-point rule as
//! reckon's, used as the speed and work baseline in `benches/rk45.rs` and checked for
//! equal work in `tests/it/handwritten.rs`.
#![allow(dead_code, clippy::excessive_precision, clippy::needless_range_loop)]

pub struct Run<const N: usize> {
    pub t: Vec<f64>,
    pub x: Vec<[f64; N]>,
    pub evals: u64,
    pub accepted: u64,
    pub rejected: u64,
}

const C2: f64 = 1.0 / 5.0;
const C3: f64 = 3.0 / 10.0;
const C4: f64 = 4.0 / 5.0;
const C5: f64 = 8.0 / 9.0;
const A21: f64 = 1.0 / 5.0;
const A31: f64 = 3.0 / 40.0;
const A32: f64 = 9.0 / 40.0;
const A41: f64 = 44.0 / 45.0;
const A42: f64 = -56.0 / 15.0;
const A43: f64 = 32.0 / 9.0;
const A51: f64 = 19372.0 / 6561.0;
const A52: f64 = -25360.0 / 2187.0;
const A53: f64 = 64448.0 / 6561.0;
const A54: f64 = -212.0 / 729.0;
const A61: f64 = 9017.0 / 3168.0;
const A62: f64 = -355.0 / 33.0;
const A63: f64 = 46732.0 / 5247.0;
const A64: f64 = 49.0 / 176.0;
const A65: f64 = -5103.0 / 18656.0;
const A71: f64 = 35.0 / 384.0;
const A73: f64 = 500.0 / 1113.0;
const A74: f64 = 125.0 / 192.0;
const A75: f64 = -2187.0 / 6784.0;
const A76: f64 = 11.0 / 84.0;
const E1: f64 = 71.0 / 57600.0;
const E3: f64 = -71.0 / 16695.0;
const E4: f64 = 71.0 / 1920.0;
const E5: f64 = -17253.0 / 339200.0;
const E6: f64 = 22.0 / 525.0;
const E7: f64 = -1.0 / 40.0;

pub fn dopri5<const N: usize>(
    f: impl Fn(f64, &[f64; N]) -> [f64; N],
    t0: f64,
    t_end: f64,
    x0: [f64; N],
    tol: f64,
) -> Run<N> {
    let (rtol, atol) = (tol, tol);
    let mut evals = 0u64;
    let mut eval = |t: f64, x: &[f64; N]| {
        evals += 1;
        f(t, x)
    };
    let mut t = t0;
    let mut x = x0;
    let mut k1 = eval(t, &x);
    // HINIT
    let (mut dnf, mut dny) = (0.0, 0.0);
    for i in 0..N {
        let sk = atol + rtol * x[i].abs();
        dnf += (k1[i] / sk).powi(2);
        dny += (x[i] / sk).powi(2);
    }
    let mut h = if dnf <= 1e-10 || dny <= 1e-10 {
        1e-6
    } else {
        0.01 * (dny / dnf).sqrt()
    };
    let mut y = [0.0; N];
    for i in 0..N {
        y[i] = x[i] + h * k1[i];
    }
    let f1 = eval(t + h, &y);
    let mut der2 = 0.0;
    for i in 0..N {
        der2 += ((f1[i] - k1[i]) / (atol + rtol * x[i].abs())).powi(2);
    }
    let der12 = (der2.sqrt() / h).max(dnf.sqrt());
    let h1 = if der12 <= 1e-15 {
        (h * 1e-3).max(1e-6)
    } else {
        (0.01 / der12).powf(0.2)
    };
    h = (100.0 * h).min(h1);

    let mut err_old: f64 = 1e-4;
    let mut rejected_last = false;
    let mut run = Run {
        t: vec![t],
        x: vec![x],
        evals: 0,
        accepted: 0,
        rejected: 0,
    };
    while t < t_end {
        let last = t + 1.01 * h >= t_end;
        if last {
            h = t_end - t;
        }
        let mut y = [0.0; N];
        for i in 0..N {
            y[i] = x[i] + h * A21 * k1[i];
        }
        let k2 = eval(t + C2 * h, &y);
        for i in 0..N {
            y[i] = x[i] + h * (A31 * k1[i] + A32 * k2[i]);
        }
        let k3 = eval(t + C3 * h, &y);
        for i in 0..N {
            y[i] = x[i] + h * (A41 * k1[i] + A42 * k2[i] + A43 * k3[i]);
        }
        let k4 = eval(t + C4 * h, &y);
        for i in 0..N {
            y[i] = x[i] + h * (A51 * k1[i] + A52 * k2[i] + A53 * k3[i] + A54 * k4[i]);
        }
        let k5 = eval(t + C5 * h, &y);
        for i in 0..N {
            y[i] = x[i] + h * (A61 * k1[i] + A62 * k2[i] + A63 * k3[i] + A64 * k4[i] + A65 * k5[i]);
        }
        let k6 = eval(t + h, &y);
        let mut xn = [0.0; N];
        for i in 0..N {
            xn[i] = x[i] + h * (A71 * k1[i] + A73 * k3[i] + A74 * k4[i] + A75 * k5[i] + A76 * k6[i]);
        }
        let k7 = eval(t + h, &xn);
        let mut s = 0.0;
        for i in 0..N {
            let e = h * (E1 * k1[i] + E3 * k3[i] + E4 * k4[i] + E5 * k5[i] + E6 * k6[i] + E7 * k7[i]);
            let sk = atol + rtol * x[i].abs().max(xn[i].abs());
            s += (e / sk).powi(2);
        }
        let err = (s / N as f64).sqrt();
        let fac11 = err.powf(0.17);
        if err <= 1.0 {
            let fac = (fac11 / err_old.powf(0.04) / 0.9).clamp(0.1, 5.0);
            let mut hnew = h / fac;
            err_old = err.max(1e-4);
            if rejected_last {
                hnew = hnew.min(h);
            }
            t = if last { t_end } else { t + h };
            x = xn;
            k1 = k7;
            h = hnew;
            rejected_last = false;
            run.accepted += 1;
            run.t.push(t);
            run.x.push(x);
        } else {
            h /= (fac11 / 0.9).min(5.0);
            rejected_last = true;
            run.rejected += 1;
        }
    }
    run.evals = evals;
    run
}

pub fn lorenz(_t: f64, y: &[f64; 3]) -> [f64; 3] {
    [
        10.0 * (y[1] - y[0]),
        y[0] * (28.0 - y[2]) - y[1],
        y[0] * y[1] - 8.0 / 3.0 * y[2],
    ]
}

pub fn van_der_pol(_t: f64, y: &[f64; 2]) -> [f64; 2] {
    [y[1], (1.0 - y[0] * y[0]) * y[1] - y[0]]
}

/// [`van_der_pol`]'s body as a reckon `model!`, operation for operation, so that reckon
/// and the hand loop run the same model code (`problems::van_der_pol(μ)` also multiplies
/// by its captured μ, which the μ = 1 body here does not).
pub fn van_der_pol_model() -> impl reckon::DualSystem<nalgebra::Const<2>> + Clone {
    reckon::model!(|_, y: [S; 2]| nalgebra::vector![y[1], (1.0 - y[0] * y[0]) * y[1] - y[0]])
}

pub fn arenstorf(_t: f64, y: &[f64; 4]) -> [f64; 4] {
    let mu = 0.012277471;
    let mu1 = 1.0 - mu;
    let r1 = (y[0] + mu).powi(2) + y[1].powi(2);
    let r2 = (y[0] - mu1).powi(2) + y[1].powi(2);
    let d1 = r1 * r1.sqrt();
    let d2 = r2 * r2.sqrt();
    [
        y[2],
        y[3],
        y[0] + 2.0 * y[3] - mu1 * (y[0] + mu) / d1 - mu * (y[0] - mu1) / d2,
        y[1] - 2.0 * y[2] - mu1 * y[1] / d1 - mu * y[1] / d2,
    ]
}
