//! Ensemble throughput and its 2-core speed-up.
//!
//! - `encoder`: the encoder-robot ensemble of `reckon ensemble` (per sample: up to four
//!   normal draws, the unicycle's exact flow for the truth and for the odometry),
//!   1000 members × 1000 samples, statistics at 10 saved times.
//! - `exact-flow`: each member integrates the unicycle with `Problem::solve(Exact)`
//!   over 1000 held inputs drawn from its seed, statistics at 10 saved times.
//!
//! Each on 1 and on 2 threads, interleaved in one group; the throughput is samples
//! (exact-flow steps) per second, the speed-up is the 1-thread time over the 2-thread time.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use nalgebra::vector;
use rand::Rng;
use reckon::ensemble::encoder::EncoderEnsemble;
use reckon::ensemble::{Ensemble, Layout};
use reckon::methods::Exact;
use reckon::reckoning::encoder_sim::{Command, EncoderErrors};
use reckon::reckoning::encoders::DiffDrive;
use reckon::vehicles::unicycle;
use reckon::{Controls, Options, Problem, Save};
use std::hint::black_box;
use std::time::Duration;

const MEMBERS: u64 = 1000;
const STEPS: usize = 1000;

fn bench(c: &mut Criterion) {
    let robot = DiffDrive::new(0.1, 0.5, 1000.0).unwrap();
    let errors = EncoderErrors {
        pulse_noise: 1.0,
        slip_sigma: 0.002,
        ..Default::default()
    };
    let commands: Vec<Command> = (0..10)
        .map(|k| Command {
            v: 0.5,
            omega: if k % 2 == 0 { 0.2 } else { -0.2 },
            duration: 1.0,
        })
        .collect();
    let drive = EncoderEnsemble::new(robot, errors, commands, 1.0 / (STEPS as f64 / 10.0)).unwrap();
    let layout = drive.layout();
    assert_eq!(layout.times.len(), 10);

    let times: Vec<f64> = (1..=10).map(|k| k as f64 * STEPS as f64 / 10.0 * 0.01).collect();
    let flow_layout = Layout::new(times.clone(), vec!["x".into(), "y".into(), "theta".into()], 3).unwrap();
    let opts = Options::default().dense(false).save(Save::At(times));
    let sys = unicycle::model();
    let member_flow = |m: &mut reckon::ensemble::Member| {
        let rng = m.rng();
        let t: Vec<f64> = (0..STEPS).map(|k| k as f64 * 0.01).collect();
        let u: Vec<Vec<f64>> = (0..STEPS)
            .map(|_| vec![0.5 + 0.05 * rng.random::<f64>(), 0.2 * (rng.random::<f64>() - 0.5)])
            .collect();
        let controls = Controls::new(t, u)?;
        Problem::new(&sys, vector![0.0, 0.0, 0.0], (0.0, STEPS as f64 * 0.01))
            .controls(controls)
            .solve(Exact::new(unicycle::flow), &opts)
    };

    let mut g = c.benchmark_group("ensemble");
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(4))
        .throughput(Throughput::Elements(MEMBERS * STEPS as u64));
    for threads in [1, 2] {
        g.bench_function(format!("encoder/{threads}-threads"), |b| {
            b.iter(|| {
                let s = Ensemble::new(MEMBERS, 1)
                    .threads(threads)
                    .run(&layout, |m, rows| drive.member(m, rows))
                    .unwrap();
                black_box(s.count())
            })
        });
        g.bench_function(format!("exact-flow/{threads}-threads"), |b| {
            b.iter(|| {
                let s = Ensemble::new(MEMBERS, 1)
                    .threads(threads)
                    .solve(&flow_layout, member_flow)
                    .unwrap();
                black_box(s.count())
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
