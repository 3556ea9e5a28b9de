//! What a `Solution` keeps (`Options::save`): every step, every k-th, the end, or output
//! times from the dense polynomial; the same steps in every mode, bit for bit, and
//! exactly the data asked for (`Solution::kept_bytes`).

use nalgebra::{SVector, vector};
use reckon::methods::{Bdf, Euler, Rk45, Rodas5P};
use reckon::studies::problems::{brusselator, brusselator_y0, lorenz, van_der_pol};
use reckon::{Error, Event, Options, Problem, Save, StepSize, model};

#[test]
fn end_and_every_k_keep_a_subset_of_the_same_steps() {
    let p = Problem::new(lorenz(), vector![1.0, 1.0, 1.0], (0.0, 20.0));
    let o = Options::default().rtol(1e-8).atol(1e-8).dense(false);
    let all = p.solve(Rk45, &o).unwrap();
    let n = all.t.len();
    assert!(n > 1000, "{n} steps");

    let end = p.solve(Rk45, &o.clone().save(Save::End)).unwrap();
    assert_eq!(end.t, [0.0, 20.0]);
    assert_eq!(end.x[1], *all.last().1); // bit for bit
    assert_eq!(end.stats, all.stats);
    assert_eq!(end.kept_bytes(), 2 * 8 + 2 * 3 * 8);
    assert_eq!(all.kept_bytes(), n * 8 + n * 3 * 8);

    let k = 7;
    let every = p.solve(Rk45, &o.clone().save(Save::Every(k))).unwrap();
    let mut want: Vec<usize> = (0..n).step_by(k).collect();
    if *want.last().unwrap() != n - 1 {
        want.push(n - 1);
    }
    assert_eq!(every.t.len(), want.len());
    for (j, &i) in want.iter().enumerate() {
        assert_eq!(every.t[j], all.t[i], "entry {j}");
        assert_eq!(every.x[j], all.x[i], "entry {j}");
    }

    // the general (non-lean) path: a breakpoint forces it, and the subset rule holds there
    let ob = o.clone().breakpoints(vec![7.5]);
    let allb = p.solve(Rk45, &ob).unwrap();
    let endb = p.solve(Rk45, &ob.save(Save::End)).unwrap();
    assert_eq!(endb.t, [0.0, 20.0]);
    assert_eq!(endb.x[1], *allb.last().1);
}

#[test]
fn output_times_from_the_dense_polynomial() {
    // x' = −x·(1 + cos t): x = exp(−t − sin t)
    let f = model!(|t, x: [S; 1]| vector![-x[0] * (t.cos() + 1.0)]);
    let exact = |t: f64| (-t - t.sin()).exp();
    let times: Vec<f64> = (0..=40).map(|i| 0.1 * i as f64).collect();
    let p = Problem::new(&f, vector![1.0], (0.0, 4.0));
    // dense output off (the default): the output times need no kept polynomials
    let o = Options::default().rtol(1e-10).atol(1e-12).save(Save::At(times.clone()));
    // (method, largest error at the output times)
    for (name, s, tol) in [
        ("rk45", p.solve(Rk45, &o).unwrap(), 1e-9),
        ("rodas5p", p.solve(Rodas5P, &o).unwrap(), 1e-8),
        ("bdf", p.solve(Bdf::default(), &o).unwrap(), 1e-8),
    ] {
        assert_eq!(s.t, times, "{name}: output times land exactly");
        assert!(s.dense_segments().is_empty(), "{name}: no polynomials kept");
        let err =
            s.t.iter()
                .zip(&s.x)
                .map(|(t, x)| (x[0] - exact(*t)).abs())
                .fold(0.0, f64::max);
        assert!(err < tol, "{name}: {err:e}");
        // a bounded step count for 41 output times (Bdf, tolerance-proportional at
        // 1e-10, takes 492 steps for an error of 2.3e-11)
        assert!(s.stats.accepted < times.len() as u64 * 15, "{name}: {:?}", s.stats);
        assert_eq!(s.kept_bytes(), times.len() * 16);
    }
    // the same as interpolating a run that kept its dense output, bit for bit
    let d = p
        .solve(Rk45, &Options::default().rtol(1e-10).atol(1e-12).dense(true))
        .unwrap();
    let s = p.solve(Rk45, &o).unwrap();
    for (t, x) in s.t.iter().zip(&s.x) {
        assert_eq!(*x, d.at(*t).unwrap(), "t = {t}");
    }
    // fixed-step explicit Euler: linear interpolation between grid points, exact on them
    let e = p
        .solve(
            Euler,
            &Options::default()
                .step(StepSize::Fixed(0.05))
                .dense(false)
                .save(Save::At(vec![0.1, 0.125])),
        )
        .unwrap();
    let g = p.solve(Euler, &Options::default().step(StepSize::Fixed(0.05))).unwrap();
    assert_eq!(e.x[0], g.x[2]);
    assert!((e.x[1][0] - 0.5 * (g.x[2][0] + g.x[3][0])).abs() < 1e-15);
}

#[test]
fn output_times_backward_and_with_a_terminal_event() {
    let f = model!(|_t, x: [S; 2]| vector![x[1], -x[0]]);
    // backward from t = 0 to −3 on the harmonic oscillator: x = (cos t, −sin t)
    let p = Problem::new(&f, vector![1.0, 0.0], (0.0, -3.0));
    let ts = vec![-0.5, -1.0, -2.5, -3.0];
    let s = p
        .solve(
            Rk45,
            &Options::default().rtol(1e-11).atol(1e-12).save(Save::At(ts.clone())),
        )
        .unwrap();
    assert_eq!(s.t, ts);
    for (t, x) in s.t.iter().zip(&s.x) {
        assert!(
            (x[0] - t.cos()).abs() < 1e-9 && (x[1] + t.sin()).abs() < 1e-9,
            "t = {t}"
        );
    }
    // a terminal event at x₀ = 0 (t = π/2) ends the run: the times before it, then the stop
    let p =
        Problem::new(&f, vector![1.0, 0.0], (0.0, 3.0)).event(Event::new(|_t, x: &SVector<f64, 2>| x[0]).terminal());
    let s = p
        .solve(
            Rk45,
            &Options::default()
                .rtol(1e-11)
                .atol(1e-12)
                .save(Save::At(vec![0.5, 1.0, 2.0, 2.5])),
        )
        .unwrap();
    assert_eq!(&s.t[..2], [0.5, 1.0]);
    assert_eq!(s.events.len(), 1, "the event is located without kept dense output");
    assert!(s.dense_segments().is_empty());
    assert_eq!(s.t.len(), 3);
    assert!((s.t[2] - std::f64::consts::FRAC_PI_2).abs() < 1e-9, "{}", s.t[2]);
    assert!(s.x[2][0].abs() < 1e-9);
}

#[test]
fn invalid_save_options_are_typed_errors() {
    let p = Problem::new(van_der_pol(1.0), vector![2.0, 0.0], (0.0, 1.0));
    for (save, needle) in [
        (Save::Every(0), "k ≥ 1"),
        (Save::At(vec![]), "at least one"),
        (Save::At(vec![0.5, f64::NAN]), "finite"),
        (Save::At(vec![0.5, 0.25]), "direction"),
        (Save::At(vec![0.5, 0.5]), "direction"),
        (Save::At(vec![0.5, 1.5]), "outside"),
        (Save::At(vec![-0.1]), "outside"),
    ] {
        match p.solve(Rk45, &Options::default().save(save.clone())) {
            Err(Error::InvalidInput { what, reason }) => {
                assert_eq!(what, "save");
                assert!(reason.contains(needle), "{save:?}: {reason}");
            }
            other => panic!("{save:?}: {other:?}"),
        }
    }
}

/// Dense output is kept only when asked (`Options::dense`, default false): a default
/// solve keeps the step ends and nothing else, `at` between them is the typed
/// `Error::NoDenseOutput` naming the fix, and events still work (they use each step's
/// polynomial during the run).
#[test]
fn default_solve_keeps_no_dense_output() {
    assert!(!Options::default().dense);
    let p = Problem::new(lorenz(), vector![1.0, 1.0, 1.0], (0.0, 5.0));
    let o = Options::default().rtol(1e-8).atol(1e-8);
    let s = p.solve(Rk45, &o).unwrap();
    let n = s.t.len();
    assert!(s.dense_segments().is_empty());
    assert_eq!(s.kept_bytes(), n * 8 + n * 3 * 8, "times and states only");
    let tm = 0.5 * (s.t[1] + s.t[2]);
    let e = s.at(tm).unwrap_err();
    assert_eq!(e, Error::NoDenseOutput { t: tm });
    assert!(e.to_string().contains("set Options::dense(true)"), "{e}");
    // asked for: one polynomial of 5 coefficients (DOPRI5's dense output) per step
    let d = p.solve(Rk45, &o.clone().dense(true)).unwrap();
    assert_eq!(d.t, s.t, "the same steps");
    assert_eq!(d.x, s.x);
    assert_eq!(d.dense_segments().len(), n - 1);
    assert_eq!(d.kept_bytes(), s.kept_bytes() + (n - 1) * (24 + 5 * 3 * 8));
    assert!(d.at(tm).is_ok());
    // every method and a run with events: nothing kept by default
    let q = Problem::new(van_der_pol(5.0), vector![2.0, 0.0], (0.0, 20.0))
        .event(Event::new(|_t, x: &SVector<f64, 2>| x[0]));
    for (name, s) in [
        ("rk45", q.solve(Rk45, &o).unwrap()),
        ("bdf", q.solve(Bdf::default(), &o).unwrap()),
        ("rodas5p", q.solve(Rodas5P, &o).unwrap()),
        ("euler", q.solve(Euler, &Options::default().fixed(1e-3)).unwrap()),
    ] {
        assert!(s.dense_segments().is_empty(), "{name}");
        assert!(s.events.len() >= 2, "{name}: x₀ crosses zero: {:?}", s.events.len());
        assert!(matches!(s.at(5.0), Err(Error::NoDenseOutput { .. })), "{name}");
    }
    // the memory it saves on BRUSS 1-D (1 000 states): DOPRI5 keeps 5 coefficient
    // vectors per step besides the step end, six times the data
    let b = Problem::new(brusselator(500), brusselator_y0(500), (0.0, 0.1));
    let o = Options::default().rtol(1e-4).atol(1e-4);
    let lean = b.solve(Rk45, &o).unwrap();
    let full = b.solve(Rk45, &o.dense(true)).unwrap();
    let steps = lean.t.len() - 1;
    assert_eq!(lean.kept_bytes(), (steps + 1) * (8 + 8000));
    assert_eq!(full.kept_bytes(), lean.kept_bytes() + steps * (24 + 5 * 8000));
}

/// `dense(true)` interpolates exactly as the old default (dense output on) did: the
/// bits below are `Solution::at` on Van der Pol μ = 5 at rtol 1e-8, atol 1e-10 from the
/// commit before the default changed (1b3d856, `Options::default()` with no `dense`
/// call), for each method's own dense output.
#[test]
fn dense_true_interpolates_as_the_old_default() {
    let p = Problem::new(van_der_pol(5.0), vector![2.0, 0.0], (0.0, 10.0));
    let o = Options::default().rtol(1e-8).atol(1e-10).dense(true);
    let ts = [0.37, 1.5, 4.2, 9.9];
    let old: [(&str, usize, [u64; 8]); 3] = [
        (
            "rk45",
            363,
            [
                0x3fff5865b1129904,
                0xbfc175023cc5ab45,
                0x3ffcae64836d835c,
                0xbfc46fb056d05a4a,
                0x3ff27f39b24cdd6c,
                0xbfdbb756c5cf081e,
                0xbff3325ba6d32a90,
                0x3fd923ae612ed7fe,
            ],
        ),
        (
            // re-taken when Bdf became tolerance-proportional below rtol 1e-6 (its steps
            // moved, 821 → 939; the dense output code did not)
            "bdf",
            939,
            [
                0x3fff5865b10fd38a,
                0xbfc175023b79d5da,
                0x3ffcae6483679b8b,
                0xbfc46fb0571c95c0,
                0x3ff27f39af8c329e,
                0xbfdbb756d4a384fd,
                0xbff3325ba323d24c,
                0x3fd923ae6fb16fb8,
            ],
        ),
        (
            "rodas5p",
            397,
            [
                0x3fff5865b1139c39,
                0xbfc175023d1a82a2,
                0x3ffcae64836fdf93,
                0xbfc46fb05704c684,
                0x3ff27f39b27ae216,
                0xbfdbb756c4becff2,
                0xbff3325ba9ce8338,
                0x3fd923ae5583e6da,
            ],
        ),
    ];
    for (name, segments, bits) in old {
        let s = match name {
            "rk45" => p.solve(Rk45, &o),
            "bdf" => p.solve(Bdf::default(), &o),
            _ => p.solve(Rodas5P, &o),
        }
        .unwrap();
        assert_eq!(s.dense_segments().len(), segments, "{name}");
        for (k, &t) in ts.iter().enumerate() {
            let x = s.at(t).unwrap();
            assert_eq!(
                [x[0].to_bits(), x[1].to_bits()],
                [bits[2 * k], bits[2 * k + 1]],
                "{name} at t = {t}"
            );
        }
        // Save::At with the default (no kept polynomials) gives the same values
        let a = match name {
            "rk45" => p.solve(Rk45, &o.clone().dense(false).save(Save::At(ts.to_vec()))),
            "bdf" => p.solve(Bdf::default(), &o.clone().dense(false).save(Save::At(ts.to_vec()))),
            _ => p.solve(Rodas5P, &o.clone().dense(false).save(Save::At(ts.to_vec()))),
        }
        .unwrap();
        assert!(a.dense_segments().is_empty());
        for (k, x) in a.x.iter().enumerate() {
            assert_eq!(
                [x[0].to_bits(), x[1].to_bits()],
                [bits[2 * k], bits[2 * k + 1]],
                "{name} Save::At"
            );
        }
    }
}
