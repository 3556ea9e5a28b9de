//! Ensembles: exact sums, mergeable sketches, thread- and shard-independent statistics,
//! and the statistics themselves against propagated covariances.

use nalgebra::{DMatrix, Matrix2, Vector2, vector};
use rand::rngs::StdRng;
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, StandardNormal};
use reckon::ensemble::encoder::EncoderEnsemble;
use reckon::ensemble::stats::chi2_interval;
use reckon::ensemble::{Ensemble, ExactSum, Layout, Moments, Shard, Sketch, Statistics, member_seed};
use reckon::methods::Rk45;
use reckon::reckoning::encoder_sim::{Command, EncoderErrors};
use reckon::reckoning::encoders::DiffDrive;
use reckon::{Error, Options, Problem, Save, model};

#[test]
fn exact_sum_matches_integer_arithmetic_in_any_order() {
    // multiples of 2⁻⁴⁰ below 2⁶⁰ in magnitude: their sum is exact in i128
    let mut rng = StdRng::seed_from_u64(1);
    for _ in 0..50 {
        let k: Vec<i64> = (0..2000)
            .map(|_| {
                let bits = rng.random_range(0..53);
                let m: i64 = rng.random_range(-(1i64 << bits)..=(1i64 << bits));
                m << rng.random_range(0..8)
            })
            .collect();
        let exact: i128 = k.iter().map(|v| *v as i128).sum();
        let mut xs: Vec<f64> = k.iter().map(|v| *v as f64 * 2f64.powi(-40)).collect();
        let mut s = ExactSum::default();
        xs.iter().for_each(|x| s.add(*x));
        let want = exact as f64 * 2f64.powi(-40); // exact's rounding to f64, scaled exactly
        assert_eq!(s.value(), want);
        xs.shuffle(&mut rng);
        let (a, b) = xs.split_at(777);
        let (mut p, mut q) = (ExactSum::default(), ExactSum::default());
        b.iter().for_each(|x| q.add(*x));
        a.iter().for_each(|x| p.add(*x));
        p.merge(&q);
        assert_eq!(p, s);
        assert_eq!(p.to_stored(), s.to_stored());
    }
}

#[test]
fn exact_sum_spans_the_whole_exponent_range() {
    let mut s = ExactSum::default();
    let terms = [f64::MAX, 5e-324, -f64::MAX, 1.0, f64::MIN_POSITIVE, -1.0];
    terms.iter().for_each(|x| s.add(*x));
    assert_eq!(s.value(), f64::MIN_POSITIVE + 5e-324);
    // cancelling to zero from both sides of the sign
    let mut z = ExactSum::default();
    for x in [0.1, -0.7, 1e300, 0.6, -1e300] {
        z.add(x);
    }
    let (h, l) = z.value_dd();
    // 0.1 − 0.7 + 0.6 of the stored doubles is −2⁻⁵⁵·… : a few units of 2⁻⁵⁶, not 0
    assert!(h != 0.0 && h.abs() < 1e-16 && l.abs() <= h.abs() * 2f64.powi(-52));
    // the sign-magnitude round trip
    let back = ExactSum::from_stored(&z.to_stored()).unwrap();
    assert_eq!(back, z);
    assert_eq!(back.value(), h + l);
    // products exactly: (1 + 2⁻³⁰)² = 1 + 2⁻²⁹ + 2⁻⁶⁰, its last bit lost by f64
    let mut p = ExactSum::default();
    let a = 1.0 + 2f64.powi(-30);
    p.add_product(a, a);
    p.add(-1.0);
    p.add(-(2f64.powi(-29)));
    assert_eq!(p.value(), 2f64.powi(-60));
    // many adds with carries (beyond one normalisation window is too slow here: the
    // carry path runs at every merge)
    let mut c = ExactSum::default();
    for _ in 0..100_000 {
        c.add(f64::MAX / 4.0);
    }
    assert_eq!(c.value(), f64::INFINITY);
    let mut d = ExactSum::default();
    d.merge(&c);
    for _ in 0..100_000 {
        d.add(-f64::MAX / 4.0);
    }
    d.add(3.0);
    assert_eq!(d.value(), 3.0);
    // IEEE specials
    let mut n = ExactSum::default();
    n.add(f64::INFINITY);
    n.add(1.0);
    assert_eq!(n.value(), f64::INFINITY);
    n.add(f64::NEG_INFINITY);
    assert!(n.value().is_nan());
}

#[test]
fn moments_match_two_pass_formulas_and_keep_digits_far_from_zero() {
    let mut rng = StdRng::seed_from_u64(2);
    let offset = vector![1e9, -3e7, 0.5];
    let xs: Vec<nalgebra::Vector3<f64>> = (0..5000)
        .map(|_| {
            offset
                + vector![
                    rng.random::<f64>() * 1e-3,
                    StandardNormal.sample(&mut rng),
                    rng.random::<f64>() - 0.5
                ]
        })
        .collect();
    let mut m = Moments::new(3);
    xs.iter().for_each(|x| m.add(x.as_slice()));
    // two-pass reference in f64 on y = x − offset (exact: Sterbenz), where rounding the
    // mean to the ulp of 1e9 (1.2e-7) does not bias the variance by that ulp squared
    let n = xs.len() as f64;
    let ys: Vec<nalgebra::Vector3<f64>> = xs.iter().map(|x| x - offset).collect();
    let ybar = ys.iter().fold(nalgebra::Vector3::zeros(), |a, y| a + y) / n;
    let mean = ybar + offset;
    let cov = ys
        .iter()
        .map(|y| {
            let d = y - ybar;
            d * d.transpose()
        })
        .fold(nalgebra::Matrix3::zeros(), |a, b| a + b)
        / (n - 1.0);
    let (mm, cc) = (m.mean(), m.covariance());
    for i in 0..3 {
        assert!((mm[i] - mean[i]).abs() <= 1e-15 * mean[i].abs().max(1.0), "mean {i}");
        for j in 0..3 {
            let scale = (cov[(i, i)] * cov[(j, j)]).sqrt();
            assert!(
                (cc[(i, j)] - cov[(i, j)]).abs() < 1e-13 * scale,
                "cov {i}{j}: {} vs {}",
                cc[(i, j)],
                cov[(i, j)]
            );
        }
    }
    // variance of U(0, 1e-3) is 1e-6/12: the one-pass f64 formula at 1e9 gives garbage
    assert!((cc[(0, 0)] / (1e-6 / 12.0) - 1.0).abs() < 0.05);
    assert_eq!(m.min()[2], xs.iter().map(|x| x[2]).fold(f64::INFINITY, f64::min));
    assert_eq!(m.max()[1], xs.iter().map(|x| x[1]).fold(f64::NEG_INFINITY, f64::max));
}

#[test]
fn sketch_quantiles_are_within_their_relative_accuracy_and_merge_exactly() {
    let mut rng = StdRng::seed_from_u64(3);
    let mut xs: Vec<f64> = (0..20_000)
        .map(|k| {
            let z: f64 = StandardNormal.sample(&mut rng);
            if k % 10 == 0 {
                0.0
            } else {
                z * 10f64.powf(rng.random_range(-3.0..3.0))
            }
        })
        .collect();
    let mut whole = Sketch::default();
    xs.iter().for_each(|x| whole.add(*x));
    let mut parts = [Sketch::default(), Sketch::default(), Sketch::default()];
    xs.iter().enumerate().for_each(|(i, x)| parts[i % 3].add(*x));
    let mut merged = parts[2].clone();
    merged.merge(&parts[0]);
    merged.merge(&parts[1]);
    assert_eq!(merged, whole);
    xs.sort_by(f64::total_cmp);
    for q in [0.0, 0.001, 0.01, 0.1, 0.25, 0.5, 0.75, 0.9, 0.99, 0.999, 1.0] {
        let rank = (q * (xs.len() - 1) as f64).floor() as usize;
        let (got, want) = (whole.quantile(q).unwrap(), xs[rank]);
        assert!((got - want).abs() <= want.abs() / 256.0, "q = {q}: {got} vs {want}");
    }
    assert_eq!(whole.quantile(1.5), None);
    assert_eq!(Sketch::default().quantile(0.5), None);
}

#[test]
fn member_seeds_are_splitmix64() {
    // SplitMix64 seeded with 0: its first three outputs (Vigna's splitmix64.c)
    assert_eq!(member_seed(0, 0), 0xE220A8397B1DCDAF);
    assert_eq!(member_seed(0, 1), 0x6E789E6AA1B965F4);
    assert_eq!(member_seed(0, 2), 0x06C45D188009454F);
}

fn encoder_drive() -> EncoderEnsemble {
    let robot = DiffDrive::new(0.1, 0.5, 500.0).unwrap();
    let errors = EncoderErrors {
        pulse_noise: 1.0,
        slip_sigma: 0.002,
        left_scale: 1.001,
        ..Default::default()
    };
    let commands = vec![
        Command {
            v: 0.5,
            omega: 0.0,
            duration: 4.0,
        },
        Command {
            v: 0.3,
            omega: 0.4,
            duration: 3.0,
        },
        Command {
            v: 0.5,
            omega: -0.2,
            duration: 4.0,
        },
    ];
    EncoderEnsemble::new(robot, errors, commands, 0.02)
        .unwrap()
        .spreads(0.001, 0.002)
        .unwrap()
}

#[test]
fn statistics_are_the_same_bits_for_one_and_two_threads_and_for_merged_shards() {
    let drive = encoder_drive();
    let layout = drive.layout();
    let run = |e: Ensemble| e.job("test").run(&layout, |m, rows| drive.member(m, rows)).unwrap();
    let one = run(Ensemble::new(601, 99).threads(1));
    let two = run(Ensemble::new(601, 99).threads(2));
    assert_eq!(one, two);
    assert_eq!(
        serde_json::to_string(&one).unwrap(),
        serde_json::to_string(&two).unwrap()
    );
    assert_eq!(one.count(), 601);
    // shards 0/4 … 3/4, merged in a scrambled order, on different thread counts
    let shards: Vec<Statistics> = (0..4)
        .map(|k| {
            run(Ensemble::new(601, 99)
                .shard(Shard::new(k, 4).unwrap())
                .threads(1 + k as usize % 2))
        })
        .collect();
    assert_eq!(shards[1].count(), 150); // members 1, 5, …, 597
    let mut merged = shards[2].clone();
    for k in [0, 3, 1] {
        merged.merge(&shards[k]).unwrap();
    }
    assert!(merged.is_complete());
    assert_eq!(merged.snapshots, one.snapshots);
    // a different seed gives different numbers, and is refused by merge
    let other = run(Ensemble::new(601, 98).shard(Shard::new(0, 4).unwrap()));
    assert_ne!(other.snapshots, shards[0].snapshots);
    let mut m = shards[1].clone();
    assert!(matches!(
        m.merge(&other),
        Err(Error::InvalidInput { what: "shards", .. })
    ));
    assert!(matches!(
        m.merge(&shards[1].clone()),
        Err(Error::InvalidInput { what: "shards", .. })
    ));
    // the JSON form merges to the same bits
    let text = serde_json::to_string(&shards[3]).unwrap();
    let back: Statistics = serde_json::from_str(&text).unwrap();
    assert_eq!(back, shards[3]);
}

#[test]
fn a_failing_member_is_reported_by_its_index_whatever_the_threads() {
    let layout = Layout::new(vec![0.0, 1.0], vec!["a".into(), "b".into()], 2).unwrap();
    let member = |m: &mut reckon::ensemble::Member, rows: &mut [f64]| {
        if m.index == 517 || m.index == 90 {
            return Err(Error::invalid("model", "boom"));
        }
        rows.fill(m.index as f64);
        Ok(())
    };
    for threads in [1, 2] {
        let err = Ensemble::new(1000, 5)
            .threads(threads)
            .run(&layout, member)
            .unwrap_err();
        match err {
            Error::EnsembleMember { index, seed, .. } => {
                assert_eq!(index, 90);
                assert_eq!(seed, member_seed(5, 90));
            }
            e => panic!("{e}"),
        }
    }
    let nan = Ensemble::new(10, 5)
        .run(&layout, |m, rows| {
            rows.fill(if m.index == 3 { f64::NAN } else { 1.0 });
            Ok(())
        })
        .unwrap_err();
    assert!(
        nan.to_string().contains("member 3") && nan.to_string().contains("NaN"),
        "{nan}"
    );
    assert!(Ensemble::new(0, 1).run(&layout, member).is_err());
    assert!("3/3".parse::<Shard>().is_err() && "a/b".parse::<Shard>().is_err() && "1/0".parse::<Shard>().is_err());
    assert_eq!("2/5".parse::<Shard>().unwrap(), Shard::new(2, 5).unwrap());
}

/// `x' = A x` from `x₀ ~ N(m, P₀)`: `x(t) ~ N(e^{At} m, e^{At} P₀ e^{Aᵀt})`. The sample
/// covariance `S` of `N` members has `(N − 1)·tr(Σ⁻¹S) ~ χ²` with `2(N − 1)` degrees of
/// freedom, and the mean `N·(x̄ − μ)ᵀΣ⁻¹(x̄ − μ) ~ χ²₂`.
#[test]
fn a_linear_systems_ensemble_has_the_propagated_mean_and_covariance() {
    let a = Matrix2::new(-0.1, 1.0, -2.0, -0.3);
    let f = model!(|_t, x: [S; 2]| vector![x[0] * (-0.1) + x[1], x[0] * (-2.0) + x[1] * (-0.3)]);
    let (m0, p0) = (Vector2::new(1.0, -0.5), Matrix2::new(0.04, 0.01, 0.01, 0.09));
    let l0 = p0.cholesky().unwrap().l();
    let times = vec![0.5, 2.0, 5.0];
    let layout = Layout::new(times.clone(), vec!["x".into(), "v".into()], 2).unwrap();
    let opts = Options::default().rtol(1e-11).atol(1e-13).save(Save::At(times.clone()));
    let n = 4000u64;
    let stats = Ensemble::new(n, 2026)
        .solve(&layout, |m| {
            let rng = m.rng();
            let z = Vector2::new(StandardNormal.sample(rng), StandardNormal.sample(rng));
            Problem::new(&f, m0 + l0 * z, (0.0, 5.0)).solve(Rk45, &opts)
        })
        .unwrap();
    let nf = n as f64;
    let (lo, hi) = chi2_interval(2.0 * (nf - 1.0), 3.29);
    for (k, t) in times.iter().enumerate() {
        let phi = (a * *t).exp();
        let (mu, sigma) = (phi * m0, phi * p0 * phi.transpose());
        let s = stats.covariance(k);
        let s = Matrix2::new(s[(0, 0)], s[(0, 1)], s[(1, 0)], s[(1, 1)]);
        let inv = sigma.try_inverse().unwrap();
        let trace = (nf - 1.0) * (inv * s).trace();
        assert!(lo < trace && trace < hi, "t = {t}: {trace} outside ({lo}, {hi})");
        let mean = stats.mean(k);
        let d = Vector2::new(mean[0], mean[1]) - mu;
        let t2 = nf * (d.transpose() * inv * d)[0];
        assert!(t2 < 13.82, "t = {t}: mean statistic {t2} (χ²₂ 0.999 quantile 13.82)");
        // and not trivially: the covariance has shrunk and rotated from P₀
        assert!((sigma - p0).norm() > 0.01);
    }
    // a wrong propagated covariance (10 % too large) is caught by the same bound
    let phi = (a * 2.0).exp();
    let wrong = phi * p0 * phi.transpose() * 1.1;
    let s = stats.covariance(1);
    let s = Matrix2::new(s[(0, 0)], s[(0, 1)], s[(1, 0)], s[(1, 1)]);
    let trace = (nf - 1.0) * (wrong.try_inverse().unwrap() * s).trace();
    assert!(trace < lo, "{trace} vs {lo}");
}

#[test]
fn the_encoder_ensembles_error_matches_the_ekf_covariance() {
    // pulse noise only: the EKF's covariance prediction is the model's
    let robot = DiffDrive::new(0.1, 0.5, 500.0).unwrap();
    let errors = EncoderErrors {
        pulse_noise: 2.0,
        ..Default::default()
    };
    let commands = vec![
        Command {
            v: 0.5,
            omega: 0.0,
            duration: 5.0,
        },
        Command {
            v: 0.3,
            omega: 0.6,
            duration: 5.0,
        },
        Command {
            v: 0.5,
            omega: -0.3,
            duration: 10.0,
        },
    ];
    let drive = EncoderEnsemble::new(robot, errors, commands, 0.02).unwrap();
    let layout = drive.layout();
    let n = 3000u64;
    let stats = Ensemble::new(n, 7)
        .run(&layout, |m, rows| drive.member(m, rows))
        .unwrap();
    let predicted = drive.predicted_covariance();
    let (lo, hi) = chi2_interval(3.0 * n as f64, 3.29);
    for (k, p) in predicted.iter().enumerate() {
        let p = DMatrix::from_column_slice(3, 3, p.as_slice());
        let nees = stats.snapshots[k].moments.mean_nees(&p).unwrap();
        let scaled = nees * n as f64;
        assert!(
            lo < scaled && scaled < hi,
            "t = {}: NEES {nees} outside",
            layout.times[k]
        );
        // heading error variance in closed form: n samples of 2(σ_p k)²/b²
        let kk = robot.distance_per_pulse();
        let samples = (layout.times[k] / 0.02).round();
        let var_th = samples * 2.0 * (2.0 * kk).powi(2) / 0.25;
        assert!((p[(2, 2)] / var_th - 1.0).abs() < 1e-9);
    }
    // a filter 15 % over- or under-confident is outside the band
    let p = DMatrix::from_column_slice(3, 3, predicted[2].as_slice());
    for (scale, outside) in [(0.85, hi), (1.15, lo)] {
        let nees = stats.snapshots[2].moments.mean_nees(&(&p * scale)).unwrap() * n as f64;
        assert!((nees - outside) * (scale - 1.0) < 0.0, "{scale}: {nees} vs {outside}");
    }
}

/// A member's generator lives as long as the member: two draws written the natural way
/// are the first two numbers of the member's stream (not the same number twice), so two
/// uniform draws are uncorrelated; the statistics stay the same bits for any threads.
#[test]
fn a_members_draws_continue_one_stream_on_any_threads() {
    let layout = Layout::new(vec![1.0], vec!["a".into(), "b".into()], 2).unwrap();
    let member = |m: &mut reckon::ensemble::Member, row: &mut [f64]| {
        let a: f64 = m.rng().random();
        let b: f64 = m.rng().random();
        let mut fresh = StdRng::seed_from_u64(member_seed(11, m.index));
        let (x, y): (f64, f64) = (fresh.random(), fresh.random());
        if (a, b) != (x, y) || a == b {
            return Err(Error::invalid(
                "draws",
                format!("{a}, {b} against the stream's {x}, {y}"),
            ));
        }
        row.copy_from_slice(&[a, b]);
        Ok(())
    };
    let n = 4000u64;
    let one = Ensemble::new(n, 11).threads(1).run(&layout, member).unwrap();
    let three = Ensemble::new(n, 11).threads(3).run(&layout, member).unwrap();
    assert_eq!(one, three);
    let mut shards = Ensemble::new(n, 11)
        .shard(Shard::new(1, 2).unwrap())
        .threads(2)
        .run(&layout, member)
        .unwrap();
    shards
        .merge(
            &Ensemble::new(n, 11)
                .shard(Shard::new(0, 2).unwrap())
                .run(&layout, member)
                .unwrap(),
        )
        .unwrap();
    assert_eq!(shards.snapshots, one.snapshots);
    // U(0, 1) draws: variance 1/12 each; the same number twice would give cov = 1/12
    let c = one.covariance(0);
    assert!((c[(0, 0)] * 12.0 - 1.0).abs() < 0.1 && (c[(1, 1)] * 12.0 - 1.0).abs() < 0.1);
    let se = (1.0 / 12.0) / (n as f64).sqrt();
    assert!(
        c[(0, 1)].abs() < 4.0 * se,
        "cov {} (4 standard errors {})",
        c[(0, 1)],
        4.0 * se
    );
}

/// Issue 38.1 through the library: statistics edited in memory or in JSON fail
/// `validate`/`from_json` with the typed error naming the field, and `merge` refuses them
/// (never a panic, never a partial answer presented as whole).
#[test]
fn statistics_that_break_an_invariant_are_typed_errors() {
    let layout = Layout::new(vec![1.0, 2.0], vec!["a".into(), "b".into()], 1).unwrap();
    let run = |k| {
        Ensemble::new(10, 3)
            .shard(Shard::new(k, 3).unwrap())
            .run(&layout, |m, row| {
                row.fill(m.index as f64);
                Ok(())
            })
            .unwrap()
    };
    let (a, b) = (run(0), run(1));
    let field = |e: Error| match e {
        Error::InvalidInput {
            what: "statistics",
            reason,
        } => reason,
        e => panic!("{e}"),
    };
    let mut whole = a.clone();
    whole.shards = vec![0, 1, 2];
    assert_eq!(
        field(whole.validate().unwrap_err()),
        "snapshots[0].moments.n: 4 members counted, but shards [0, 1, 2] of 3 hold 10"
    );
    let mut m = b.clone();
    assert!(matches!(
        m.merge(&whole),
        Err(Error::InvalidInput { what: "statistics", .. })
    ));
    assert_eq!(m, b, "a refused merge changes nothing");
    let mut short = a.clone();
    short.snapshots.pop();
    assert_eq!(field(short.validate().unwrap_err()), "snapshots: 1 for 2 saved times");
    let mut beyond = a.clone();
    beyond.shards = vec![7];
    assert_eq!(
        field(beyond.validate().unwrap_err()),
        "shards: 7 is not a shard of 3 (0 to 2)"
    );
    let mut none = a.clone();
    none.shard_count = 0;
    assert_eq!(field(none.validate().unwrap_err()), "shard_count: 0 (at least 1)");
    // JSON: a moment of the wrong dimension, a limb window no f64 sum reaches
    let text = serde_json::to_string(&a).unwrap();
    let dim = text.replacen(r#""dim":1"#, r#""dim":2"#, 1);
    let e = field(Statistics::from_json(&dim).unwrap_err());
    assert!(
        e.starts_with("snapshots[0].moments.s1: 1 sums for dimension 2 (need 2)"),
        "{e}"
    );
    let far = text.replacen(r#""lo":"#, r#""lo":2147483647,"was":"#, 1);
    let e = field(Statistics::from_json(&far).unwrap_err());
    assert!(
        e.starts_with("snapshots[0].moments.s1[0]: invalid exact sum: lo = 2147483647 with 1 limbs"),
        "{e}"
    );
    assert!(serde_json::from_str::<Statistics>(&far).is_err());
    // the valid ones still merge, and an empty shard round-trips (±∞ extremes as text)
    let mut ab = a.clone();
    ab.merge(&b).unwrap();
    assert_eq!(ab.count(), 7);
    let empty = Ensemble::new(2, 3)
        .shard(Shard::new(2, 3).unwrap())
        .run(&layout, |_, row| {
            row.fill(1.0);
            Ok(())
        })
        .unwrap();
    let text = serde_json::to_string(&empty).unwrap();
    assert!(text.contains(r#""min":["inf"],"max":["-inf"]"#), "{text}");
    assert_eq!(Statistics::from_json(&text).unwrap(), empty);
    // moments of different dimensions do not merge
    let mut m1 = Moments::new(1);
    assert!(matches!(
        m1.merge(&Moments::new(2)),
        Err(Error::InvalidInput { what: "moments", .. })
    ));
}
