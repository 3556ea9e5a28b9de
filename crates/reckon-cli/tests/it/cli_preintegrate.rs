//! `reckon preintegrate`: windows equal to the library's `Preintegrated` on the same
//! samples, a closed-form window (constant turn rate on a circle), composition of two
//! windows into one, and every bad input refused in one line.

use nalgebra::{Matrix3, Vector3, vector};
use reckon::lie::{So3, hat};
use reckon::reckoning::imu::ImuSample;
use reckon::reckoning::preintegration::{Bias, Matrix9, Preintegrated, PreintegrationParams};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn file(name: &str, text: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("reckon-preint-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    let p = d.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn p(path: &Path) -> &str {
    path.to_str().unwrap()
}

/// The log as CSV, each number the shortest text that parses back to it.
fn csv(samples: &[ImuSample]) -> String {
    let mut s = String::from("t,gx,gy,gz,ax,ay,az\n");
    for x in samples {
        let (g, a) = (x.gyro, x.accel);
        writeln!(
            s,
            "{:?},{:?},{:?},{:?},{:?},{:?},{:?}",
            x.t, g.x, g.y, g.z, a.x, a.y, a.z
        )
        .unwrap();
    }
    s
}

const NOISE: [&str; 6] = [
    "--gyro-noise",
    "1e-3,2e-3,1.5e-3",
    "--accel-noise",
    "0.02",
    "--integration-noise",
    "1e-4",
];

fn params() -> PreintegrationParams {
    let d = |a: f64, b: f64, c: f64| Matrix3::from_diagonal(&vector![a * a, b * b, c * c]);
    PreintegrationParams::up(9.81)
        .unwrap()
        .gyro(d(1e-3, 2e-3, 1.5e-3))
        .unwrap()
        .accel(d(0.02, 0.02, 0.02))
        .unwrap()
        .integration(d(1e-4, 1e-4, 1e-4))
        .unwrap()
}

fn reckon(imu: &Path, extra: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_reckon"))
        .arg("preintegrate")
        .arg("--imu")
        .arg(imu)
        .args(NOISE)
        .args(extra)
        .output()
        .unwrap()
}

/// The JSON output's windows.
fn windows(o: &Output) -> Vec<serde_json::Value> {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    v["windows"].as_array().unwrap().clone()
}

fn vec3(v: &serde_json::Value) -> Vector3<f64> {
    Vector3::from_iterator(v.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()))
}

fn mat3(v: &serde_json::Value) -> Matrix3<f64> {
    Matrix3::from_fn(|i, j| v[i][j].as_f64().unwrap())
}

fn mat9(v: &serde_json::Value) -> Matrix9 {
    Matrix9::from_fn(|i, j| v[i][j].as_f64().unwrap())
}

/// One window read back: (t0, t1, ΔR, Δv, Δp, Σ, [∂ΔR/∂b_g, ∂Δv/∂b_g, ∂Δv/∂b_a, ∂Δp/∂b_g, ∂Δp/∂b_a]).
struct Window {
    t0: f64,
    t1: f64,
    r: So3,
    v: Vector3<f64>,
    p: Vector3<f64>,
    cov: Matrix9,
    jac: [Matrix3<f64>; 5],
}

fn window(w: &serde_json::Value) -> Window {
    Window {
        t0: w["t0"].as_f64().unwrap(),
        t1: w["t1"].as_f64().unwrap(),
        r: So3::exp(&vec3(&w["rotation_vector"])),
        v: vec3(&w["delta_v"]),
        p: vec3(&w["delta_p"]),
        cov: mat9(&w["covariance"]),
        jac: [
            mat3(&w["d_rotation_d_gyro_bias"]),
            mat3(&w["d_velocity_d_gyro_bias"]),
            mat3(&w["d_velocity_d_accel_bias"]),
            mat3(&w["d_position_d_gyro_bias"]),
            mat3(&w["d_position_d_accel_bias"]),
        ],
    }
}

/// `|a − b| ≤ tol·max(1, |b|)` entry by entry.
fn close(what: &str, a: &[f64], b: &[f64], tol: f64) {
    assert_eq!(a.len(), b.len());
    for (k, (x, y)) in a.iter().zip(b).enumerate() {
        assert!((x - y).abs() <= tol * y.abs().max(1.0), "{what}[{k}]: {x} against {y}");
    }
}

/// A 3-D motion log at uneven times: every axis turning and accelerating.
fn wobbly(n: usize) -> Vec<ImuSample> {
    (0..n)
        .map(|k| {
            let kf = k as f64;
            let t = 1.7e3 + 0.013 * kf + 0.004 * kf.sin();
            ImuSample {
                t,
                gyro: vector![
                    0.3 * (0.7 * t).sin(),
                    -0.2 + 0.1 * (1.3 * t).cos(),
                    0.5 * (0.4 * t).cos()
                ],
                accel: vector![
                    0.8 * (0.9 * t).cos(),
                    0.3 * (2.1 * t).sin(),
                    9.81 + 0.2 * (0.5 * t).sin()
                ],
            }
        })
        .collect()
}

/// (a) Each window equals `Preintegrated::from_samples` on its samples to 1e-12, the
/// windows tile the log and end on the first sample at or after each nominal end; the
/// CSV holds the same numbers as the JSON.
#[test]
fn windows_equal_the_library() {
    let s = wobbly(400);
    let imu = file("wobbly.csv", &csv(&s));
    let bias = ["--gyro-bias", "0.01,-0.02,0.005", "--accel-bias", "0.1,0,-0.05"];
    let mut args = vec!["--every", "0.5", "--json"];
    args.extend(bias);
    let ws = windows(&reckon(&imu, &args));
    let b = Bias {
        gyro: vector![0.01, -0.02, 0.005],
        accel: vector![0.1, 0.0, -0.05],
    };
    // the nominal ends t_first + 0.5·k, each snapped to the first sample at or after it
    let mut bounds = vec![0usize];
    let mut k = 1.0;
    for (i, x) in s.iter().enumerate() {
        if x.t >= s[0].t + 0.5 * k {
            bounds.push(i);
            while s[0].t + 0.5 * k <= x.t {
                k += 1.0;
            }
        }
    }
    if *bounds.last().unwrap() != s.len() - 1 {
        bounds.push(s.len() - 1);
    }
    assert_eq!(ws.len(), bounds.len() - 1);
    assert!(ws.len() >= 10, "{} windows", ws.len());
    for (w, b2) in ws.iter().zip(bounds.windows(2)) {
        let w = window(w);
        let (i, j) = (b2[0], b2[1]);
        assert_eq!((w.t0, w.t1), (s[i].t, s[j].t));
        let lib = Preintegrated::from_samples(params(), b, &s[i..=j]).unwrap();
        let tol = 1e-12;
        close(
            "rotation",
            lib.delta_r().matrix().as_slice(),
            w.r.matrix().as_slice(),
            tol,
        );
        close("dv", w.v.as_slice(), lib.delta_v().as_slice(), tol);
        close("dp", w.p.as_slice(), lib.delta_p().as_slice(), tol);
        close("cov", w.cov.as_slice(), lib.covariance().as_slice(), tol);
        let j = lib.bias_jacobians();
        let lj = [
            j.d_rotation_d_gyro,
            j.d_velocity_d_gyro,
            j.d_velocity_d_accel,
            j.d_position_d_gyro,
            j.d_position_d_accel,
        ];
        for (a, b) in w.jac.iter().zip(&lj) {
            close("jacobian", a.as_slice(), b.as_slice(), tol);
        }
    }
    // the CSV: the same numbers (rotation vector, variances, Jacobians row-major)
    let mut args = vec!["--every", "0.5"];
    args.extend(bias);
    let o = reckon(&imu, &args);
    assert!(o.status.success());
    let text = String::from_utf8(o.stdout).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(header.len(), 65);
    assert_eq!(&header[..5], &["t0", "t1", "rx", "ry", "rz"]);
    assert_eq!(header[11], "var_phix");
    assert_eq!(header[20], "dR_dbg_00");
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), ws.len());
    for (row, w) in rows.iter().zip(&ws) {
        assert_eq!(row[0], w["t0"].as_f64().unwrap());
        assert_eq!(row[1], w["t1"].as_f64().unwrap());
        assert_eq!(&row[2..5], vec3(&w["rotation_vector"]).as_slice());
        assert_eq!(&row[5..8], vec3(&w["delta_v"]).as_slice());
        let cov = mat9(&w["covariance"]);
        for (i, v) in row[11..20].iter().enumerate() {
            assert_eq!(*v, cov[(i, i)]);
        }
        assert_eq!(row[20 + 3 + 2], w["d_rotation_d_gyro_bias"][1][2].as_f64().unwrap());
        assert_eq!(row[20 + 36 + 4], w["d_position_d_accel_bias"][1][1].as_f64().unwrap());
    }
}

/// (b) A body on a circle of radius v/ω at constant turn rate ω about z, level, z up: the
/// gyro reads (0, 0, ω), the accelerometer f = (0, v·ω, g) (centripetal plus gravity's
/// reaction) in the body frame. With samples held over dt (θ = ω·dt, N samples,
/// c = f_x + i·f_y, S_n = Σ_{k<n} e^{ikθ} = (1 − e^{inθ})/(1 − e^{iθ})), the scheme's
/// increments are in closed form: ΔR = Exp(N·θ·ẑ), Δv_xy = dt·c·S_N,
/// Δp_xy = dt²·c·(N − S_N)/(1 − e^{iθ}) + ½dt²·c·S_N, Δv_z = g·N·dt, Δp_z = ½g·(N·dt)²;
/// with σ_g the same on every axis, the rotation variances are
/// σ_g²·N·dt·(2(1 − cos θ)/θ², 2(1 − cos θ)/θ², 1) (J_r(θẑ)·J_r(θẑ)ᵀ on the plane is
/// 2(1 − cos θ)/θ²·I, and rotations about z leave it unchanged).
#[test]
fn constant_turn_matches_the_closed_form() {
    let (n, dt, w, v, g) = (256usize, 1.0 / 256.0, 0.7, 2.0, 9.81);
    let s: Vec<ImuSample> = (0..=n)
        .map(|k| ImuSample {
            t: k as f64 * dt,
            gyro: vector![0.0, 0.0, w],
            accel: vector![0.0, v * w, g],
        })
        .collect();
    let imu = file("circle.csv", &csv(&s));
    let o = Command::new(env!("CARGO_BIN_EXE_reckon"))
        .args([
            "preintegrate",
            "--imu",
            p(&imu),
            "--gyro-noise",
            "0.01",
            "--accel-noise",
            "0.1",
            "--json",
        ])
        .output()
        .unwrap();
    let ws = windows(&o);
    assert_eq!(ws.len(), 1);
    let win = window(&ws[0]);
    assert_eq!((win.t0, win.t1), (0.0, 1.0));

    let nf = n as f64;
    let th = w * dt;
    type C = num_complex_lite::C;
    let e = C::cis(th);
    let c = C::new(0.0, v * w);
    let s_n = (C::new(1.0, 0.0) - C::cis(nf * th)) / (C::new(1.0, 0.0) - e);
    let dv = c * s_n * dt;
    let dp = c * ((C::new(nf, 0.0) - s_n) / (C::new(1.0, 0.0) - e)) * (dt * dt) + c * s_n * (0.5 * dt * dt);
    let tol = 1e-9;
    close("rotation", win.r.log().as_slice(), &[0.0, 0.0, nf * th], tol);
    close("dv", win.v.as_slice(), &[dv.re, dv.im, g * nf * dt], tol);
    close(
        "dp",
        win.p.as_slice(),
        &[dp.re, dp.im, 0.5 * g * (nf * dt).powi(2)],
        tol,
    );
    // close to the continuous motion too: Δv_xy → v·(e^{iωT} − 1) as dt → 0 (O(dt) apart)
    let cont = C::cis(w) - C::new(1.0, 0.0);
    assert!((dv.re - v * cont.re).abs() < 0.01 && (dv.im - v * cont.im).abs() < 0.01);
    let plane = 2.0 * (1.0 - th.cos()) / (th * th);
    let var = 1e-4 * nf * dt;
    close(
        "rotation variances",
        &[win.cov[(0, 0)], win.cov[(1, 1)], win.cov[(2, 2)]],
        &[var * plane, var * plane, var],
        1e-9 * var,
    );
}

/// A tiny complex type for the closed form (the test crate does not depend on num-complex).
mod num_complex_lite {
    #[derive(Clone, Copy, Debug)]
    pub struct C {
        pub re: f64,
        pub im: f64,
    }
    impl C {
        pub fn new(re: f64, im: f64) -> C {
            C { re, im }
        }
        pub fn cis(t: f64) -> C {
            C::new(t.cos(), t.sin())
        }
    }
    impl std::ops::Sub for C {
        type Output = C;
        fn sub(self, o: C) -> C {
            C::new(self.re - o.re, self.im - o.im)
        }
    }
    impl std::ops::Add for C {
        type Output = C;
        fn add(self, o: C) -> C {
            C::new(self.re + o.re, self.im + o.im)
        }
    }
    impl std::ops::Mul for C {
        type Output = C;
        fn mul(self, o: C) -> C {
            C::new(self.re * o.re - self.im * o.im, self.re * o.im + self.im * o.re)
        }
    }
    impl std::ops::Mul<f64> for C {
        type Output = C;
        fn mul(self, k: f64) -> C {
            C::new(self.re * k, self.im * k)
        }
    }
    impl std::ops::Div for C {
        type Output = C;
        fn div(self, o: C) -> C {
            let d = o.re * o.re + o.im * o.im;
            C::new(
                (self.re * o.re + self.im * o.im) / d,
                (self.im * o.re - self.re * o.im) / d,
            )
        }
    }
}

/// (c) Two windows composed equal one window over both, to 1e-9: increments
/// `ΔR = ΔR₁ΔR₂`, `Δv = Δv₁ + ΔR₁Δv₂`, `Δp = Δp₁ + Δv₁Δt₂ + ΔR₁Δp₂`; covariance
/// `Σ = AΣ₁Aᵀ + BΣ₂Bᵀ` with `A = [[ΔR₂ᵀ, 0, 0], [−ΔR₁[Δv₂]×, I, 0], [−ΔR₁[Δp₂]×, Δt₂I, I]]`,
/// `B = diag(I, ΔR₁, ΔR₁)`; and the bias Jacobians by the chain rule through the same map.
#[test]
fn two_windows_compose_into_one() {
    let s: Vec<ImuSample> = (0..=128)
        .map(|k| {
            let t = k as f64 / 64.0;
            ImuSample {
                t,
                gyro: vector![0.4 * (1.1 * t).sin(), 0.3 * (0.6 * t).cos(), -0.8 + 0.2 * t],
                accel: vector![1.0 - 0.3 * t, 0.5 * (1.7 * t).sin(), 9.6 + 0.4 * (0.8 * t).cos()],
            }
        })
        .collect();
    let imu = file("two.csv", &csv(&s));
    let two = windows(&reckon(&imu, &["--every", "1", "--json"]));
    let one = windows(&reckon(&imu, &["--json"]));
    assert_eq!((two.len(), one.len()), (2, 1));
    let (a, b, w) = (window(&two[0]), window(&two[1]), window(&one[0]));
    assert_eq!((a.t0, a.t1, b.t0, b.t1, w.t0, w.t1), (0.0, 1.0, 1.0, 2.0, 0.0, 2.0));
    let (r1, r2) = (a.r.matrix(), b.r.matrix());
    let dt2 = b.t1 - b.t0;
    let tol = 1e-9;
    close("rotation", (r1 * r2).as_slice(), w.r.matrix().as_slice(), tol);
    close("dv", (a.v + r1 * b.v).as_slice(), w.v.as_slice(), tol);
    close("dp", (a.p + a.v * dt2 + r1 * b.p).as_slice(), w.p.as_slice(), tol);

    let mut am = Matrix9::identity();
    am.fixed_view_mut::<3, 3>(0, 0).copy_from(&r2.transpose());
    am.fixed_view_mut::<3, 3>(3, 0).copy_from(&(-r1 * hat(&b.v)));
    am.fixed_view_mut::<3, 3>(6, 0).copy_from(&(-r1 * hat(&b.p)));
    am.fixed_view_mut::<3, 3>(6, 3).copy_from(&(Matrix3::identity() * dt2));
    let mut bm = Matrix9::identity();
    bm.fixed_view_mut::<3, 3>(3, 3).copy_from(&r1);
    bm.fixed_view_mut::<3, 3>(6, 6).copy_from(&r1);
    let cov = am * a.cov * am.transpose() + bm * b.cov * bm.transpose();
    let scale = w.cov.amax();
    close("cov", (cov / scale).as_slice(), (w.cov / scale).as_slice(), tol);

    let [ra, vga, vaa, pga, paa] = a.jac;
    let [rb, vgb, vab, pgb, pab] = b.jac;
    let composed = [
        r2.transpose() * ra + rb,
        vga - r1 * hat(&b.v) * ra + r1 * vgb,
        vaa + r1 * vab,
        pga + vga * dt2 - r1 * hat(&b.p) * ra + r1 * pgb,
        paa + vaa * dt2 + r1 * pab,
    ];
    for (k, (c, x)) in composed.iter().zip(&w.jac).enumerate() {
        close(&format!("jacobian {k}"), c.as_slice(), x.as_slice(), tol);
    }
}

/// One line on stderr naming the problem, a failure exit (not a panic), nothing written.
fn refused(o: &Output, needle: &str) {
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{needle}: {err}");
    assert!(err.contains(needle), "stderr {err:?} should mention {needle:?}");
    assert_eq!(err.trim().lines().count(), 1, "one message: {err:?}");
    assert!(o.stdout.is_empty(), "{needle}: nothing written before the error");
}

/// (d) Hostile inputs: each refused with a message naming the problem.
#[test]
fn bad_inputs_are_refused_in_one_line() {
    let h = "t,gx,gy,gz,ax,ay,az\n";
    let good = format!("{h}0,0,0,0,0,0,9.81\n0.5,0,0,0,0,0,9.81\n1,0,0,0,0,0,9.81\n");
    let cases: [(&str, String, &str); 9] = [
        (
            "backwards",
            format!("{h}0,0,0,0,0,0,9.81\n1,0,0,0,0,0,9.81\n0.5,0,0,0,0,0,9.81\n"),
            "line 4: time does not increase: 0.5 after 1",
        ),
        (
            "repeated",
            format!("{h}0,0,0,0,0,0,9.81\n1,0,0,0,0,0,9.81\n1,0,0,0,0,0,9.81\n"),
            "line 4: time does not increase: 1 after 1",
        ),
        (
            "nan",
            format!("{h}0,0,0,0,0,0,9.81\n1,NaN,0,0,0,0,9.81\n"),
            "line 3: column 'gx': NaN is not finite",
        ),
        (
            "inf",
            format!("{h}0,0,0,0,0,0,9.81\n1,0,0,0,0,-inf,9.81\n"),
            "line 3: column 'ay': -inf is not finite",
        ),
        (
            "missing",
            "t,gx,gy,gz,ax,ay\n0,0,0,0,0,0\n".to_string(),
            "missing column 'az'",
        ),
        ("empty", String::new(), "missing column 't'"),
        ("header-only", h.to_string(), "0 IMU samples: at least two are needed"),
        (
            "one-row",
            format!("{h}0,0,0,0,0,0,9.81\n"),
            "1 IMU sample: at least two are needed",
        ),
        (
            "text",
            format!("{h}0,0,0,0,0,0,9.81\n1,0,0,x,0,0,9.81\n"),
            "line 3: column 'gz': 'x' is not a number",
        ),
    ];
    for (name, text, needle) in &cases {
        let f = file(&format!("bad-{name}.csv"), text);
        refused(&reckon(&f, &[]), needle);
    }
    let f = file("good.csv", &good);
    let run = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_reckon"))
            .arg("preintegrate")
            .arg("--imu")
            .arg(&f)
            .args(args)
            .output()
            .unwrap()
    };
    let noise = ["--gyro-noise", "1e-3", "--accel-noise", "1e-2"];
    let with = |extra: &[&str]| {
        let mut a: Vec<&str> = noise.to_vec();
        a.extend(extra);
        run(&a)
    };
    refused(
        &run(&["--gyro-noise", "-1e-3", "--accel-noise", "1e-2"]),
        "--gyro-noise must be finite and non-negative, got -0.001",
    );
    refused(
        &run(&["--gyro-noise", "1e-3", "--accel-noise", "1e-2,1e-2"]),
        "--accel-noise takes one value or three (x,y,z), got 2",
    );
    refused(
        &with(&["--integration-noise", "nan"]),
        "--integration-noise must be finite, got NaN",
    );
    refused(
        &with(&["--gyro-bias", "0.1"]),
        "--gyro-bias takes three values (x,y,z), got 1",
    );
    refused(&with(&["--g", "-9.81"]), "--g must be finite and non-negative");
    for (every, shown) in [
        ("0", "0"),
        ("-0.5", "-0.5"),
        ("nan", "NaN"),
        ("inf", "inf"),
        ("-inf", "-inf"),
    ] {
        refused(
            &with(&["--every", every]),
            &format!("--every must be finite and positive, got {shown}"),
        );
    }
    let o = with(&["--every", "1e-7"]);
    refused(&o, "windows, more than the limit of 10⁶");
    assert!(String::from_utf8_lossy(&o.stderr).contains("--every 1e-7 cuts the log's 1 s into"));
    refused(&with(&["--out", p(&f)]), "is the input file");
    let gone = f.with_file_name("does-not-exist.csv");
    let o = Command::new(env!("CARGO_BIN_EXE_reckon"))
        .args(["preintegrate", "--imu", p(&gone)])
        .args(noise)
        .output()
        .unwrap();
    refused(&o, "cannot read");
    // samples so large that the covariance overflows: an error naming the line
    let huge = file(
        "huge.csv",
        &format!("{h}0,0,0,0,1e300,0,0\n1,0,0,0,1e300,0,0\n2,0,0,0,0,0,0\n"),
    );
    let o = Command::new(env!("CARGO_BIN_EXE_reckon"))
        .args(["preintegrate", "--imu", p(&huge)])
        .args(noise)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("line 4: the window's increments or covariance overflow"),
        "{err}"
    );
    // the good log runs: 2 windows of 0.5 s
    let o = with(&["--every", "0.5"]);
    assert!(o.status.success());
    assert_eq!(String::from_utf8(o.stdout).unwrap().lines().count(), 3);
}
