//! Golden results, pinned bit for bit before the redesign moves any code: every method
//! on a few problems (end state, `Stats`, saved points), the demo's tables, `simulate`,
//! `odometry` and a `jacobian` print. A move that changes no arithmetic leaves every file
//! in `tests/golden/` as it is; a change that means to move a result re-blesses them
//! with `RECKON_BLESS=1 cargo test --release --test golden` and says why in its commit.
//!
//! Floats are written with `{:?}`, Rust's shortest representation that reads back to
//! the same bits, so equal text is equal bits.

use nalgebra::{SVector, vector};
use reckon::methods::{Auto, Bdf, Dopri5, Exact, ExplicitEuler, ExponentialEuler, ImplicitEuler, Method, Rodas5P};
use reckon::models::unicycle;
use reckon::problems::*;
use reckon::{Controls, DualSystem, Options, Problem};
use std::fmt::Write;
use std::path::PathBuf;
use std::process::Command;

/// Compare `text` with `tests/golden/<name>.txt`, or write it there under `RECKON_BLESS`.
fn golden(name: &str, text: &str) {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/golden")
        .join(format!("{name}.txt"));
    if std::env::var_os("RECKON_BLESS").is_some() {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(&path, text).unwrap();
        return;
    }
    let want = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("{}: {e} (bless with RECKON_BLESS=1)", path.display()));
    if want != text {
        let (i, (w, g)) = want
            .lines()
            .zip(text.lines())
            .enumerate()
            .find(|(_, (w, g))| w != g)
            .unwrap_or((want.lines().count().min(text.lines().count()), ("<end>", "<end>")));
        panic!(
            "{name}: differs from {} at line {}\n  golden: {w}\n  now:    {g}\n({} golden lines, {} now)",
            path.display(),
            i + 1,
            want.lines().count(),
            text.lines().count()
        );
    }
}

/// One line per run: the method, the setting, the saved points, `Stats` and the end state.
fn line<D, S, M>(out: &mut String, label: &str, p: &Problem<'_, D, S>, m: M, o: &Options)
where
    D: nalgebra::Dim,
    S: reckon::System<D>,
    M: Method<D>,
    nalgebra::DefaultAllocator: nalgebra::allocator::Allocator<D>,
{
    match p.solve(m, o) {
        Ok(s) => {
            let (t, x) = s.last();
            let x: Vec<f64> = x.iter().copied().collect();
            writeln!(out, "{label}: points {} t {t:?} x {x:?}\n  {:?}", s.t.len(), s.stats).unwrap();
        }
        Err(e) => writeln!(out, "{label}: error {e}").unwrap(),
    }
}

/// The four stiff methods at three tolerances on one problem.
fn stiff<const N: usize, F>(out: &mut String, name: &str, f: F, y0: SVector<f64, N>, t1: f64, atol: f64)
where
    F: DualSystem<nalgebra::Const<N>> + Clone,
    nalgebra::Const<N>: reckon::linalg::LuDim,
{
    let p = Problem::new(f, y0, (0.0, t1));
    for rtol in [1e-2, 1e-5, 1e-8] {
        let o = Options::default().rtol(rtol).atol(atol * rtol).max_steps(400_000);
        line(out, &format!("{name} bdf {rtol:e}"), &p, Bdf::default(), &o);
        line(out, &format!("{name} bdf-plain {rtol:e}"), &p, Bdf::bdf(), &o);
        line(out, &format!("{name} rodas5p {rtol:e}"), &p, Rodas5P::default(), &o);
        line(out, &format!("{name} auto {rtol:e}"), &p, Auto::default(), &o);
        line(
            out,
            &format!("{name} exponential-euler {rtol:e}"),
            &p,
            ExponentialEuler::default(),
            &o,
        );
        if rtol > 1e-4 {
            line(
                out,
                &format!("{name} implicit-euler {rtol:e}"),
                &p,
                ImplicitEuler::default(),
                &o,
            );
        }
    }
}

#[test]
fn every_method_on_the_test_problems() {
    let mut out = String::new();
    // explicit methods, fixed and adaptive
    let rd = Problem::new(rotation_decay(), vector![1.0, 0.5], (0.0, 5.0));
    line(
        &mut out,
        "rotation-decay euler h 1e-2",
        &rd,
        ExplicitEuler,
        &Options::default().fixed(1e-2),
    );
    line(
        &mut out,
        "rotation-decay implicit-euler h 1e-2",
        &rd,
        ImplicitEuler::default(),
        &Options::default().fixed(1e-2),
    );
    line(
        &mut out,
        "rotation-decay rk45 h 0.1",
        &rd,
        Dopri5::default(),
        &Options::default().fixed(0.1),
    );
    line(
        &mut out,
        "rotation-decay exponential-euler h 0.5",
        &rd,
        ExponentialEuler::default(),
        &Options::default().fixed(0.5),
    );
    let ar = Problem::new(arenstorf(), arenstorf_y0(), (0.0, ARENSTORF_T));
    for rtol in [1e-3, 1e-6, 1e-10] {
        let o = Options::default().rtol(rtol).atol(rtol);
        line(
            &mut out,
            &format!("arenstorf rk45 {rtol:e}"),
            &ar,
            Dopri5::default(),
            &o,
        );
    }
    let lz = Problem::new(lorenz(), lorenz_y0(), (0.0, 20.0));
    line(
        &mut out,
        "lorenz rk45 1e-8 dense",
        &lz,
        Dopri5::default(),
        &Options::default().rtol(1e-8).dense(true),
    );
    let su = Problem::new(sin_u(), vector![0.5], (0.0, 5.0));
    line(
        &mut out,
        "sin-u implicit-euler 1e-3",
        &su,
        ImplicitEuler::default(),
        &Options::default().rtol(1e-3),
    );
    line(
        &mut out,
        "sin-u implicit-euler per-step 1e-3",
        &su,
        ImplicitEuler::default().proportional(false),
        &Options::default().rtol(1e-3),
    );
    // the exact flow of a vehicle with held inputs, and the integrators on the same log
    let controls = Controls::new(
        vec![0.0, 2.0, 4.5, 6.0, 8.0, 10.0],
        vec![
            vec![1.0, 0.0],
            vec![1.5, 0.6],
            vec![2.0, 0.0],
            vec![1.0, -0.9],
            vec![0.5, 0.3],
            vec![0.0, 0.0],
        ],
    )
    .unwrap();
    let uni = unicycle::model();
    let up = Problem::new(&uni, vector![0.0, 0.0, 0.0], (0.0, 10.0)).controls(controls);
    line(
        &mut out,
        "unicycle exact",
        &up,
        Exact::new(unicycle::flow),
        &Options::default(),
    );
    line(
        &mut out,
        "unicycle rk45 1e-10",
        &up,
        Dopri5::default(),
        &Options::default().rtol(1e-10),
    );
    line(&mut out, "unicycle bdf 1e-6", &up, Bdf::default(), &Options::default());
    // stiff test problems
    stiff(&mut out, "robertson", robertson(), vector![1.0, 0.0, 0.0], 1e11, 1e-4);
    stiff(&mut out, "vdpolm", van_der_pol(1000.0), vector![2.0, 0.0], 2000.0, 1.0);
    stiff(&mut out, "orego", orego(), vector![1.0, 2.0, 3.0], 360.0, 1.0);
    stiff(&mut out, "hires", hires(), hires_y0(), HIRES_T, 1.0);
    stiff(
        &mut out,
        "e5",
        e5(),
        vector![1.76e-3, 0.0, 0.0, 0.0],
        1e5,
        1.7e-24 / 1e-6,
    );
    // the sparse path: 200-state Brusselator, traced Jacobian, sparse LU
    let br = Problem::new(brusselator(100), brusselator_y0(100), (0.0, 10.0));
    let o = Options::default()
        .rtol(1e-6)
        .atol(1e-6)
        .save(reckon::options::Save::End);
    line::<nalgebra::Dyn, _, _>(&mut out, "brusselator-100 bdf sparse 1e-6", &br, Bdf::default(), &o);
    line::<nalgebra::Dyn, _, _>(
        &mut out,
        "brusselator-100 rodas5p sparse 1e-6",
        &br,
        Rodas5P::default(),
        &o,
    );
    golden("methods", &out);
}

fn reckon_in(dir: &std::path::Path, args: &[&str]) -> String {
    let o = Command::new(env!("CARGO_BIN_EXE_reckon"))
        .current_dir(dir)
        .args(args)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "reckon {args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8(o.stdout).unwrap()
}

fn scratch(name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("golden").join(name);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The demo's tables with the time column blanked (the only column a run may change).
#[test]
fn demo_tables() {
    let text = reckon_in(&scratch("demo"), &["demo", "--fast"]);
    let mut out = String::new();
    let mut col = None;
    for l in text.lines() {
        if let Some(i) = l.find("time ms") {
            col = Some(i + "time ms".len());
        } else if l.trim().is_empty() {
            col = None;
        } else if let Some(end) = col {
            let (head, tail) = l.split_at(end.min(l.len()));
            let keep = head.trim_end().rsplit_once(' ').map_or(head, |(h, _)| h).trim_end();
            writeln!(out, "{keep} <time>{tail}").unwrap();
            continue;
        }
        writeln!(out, "{l}").unwrap();
    }
    golden("demo", &out);
}

#[test]
fn simulate_and_odometry_outputs() {
    let d = scratch("cli");
    std::fs::write(
        d.join("uni.csv"),
        "t,v,omega\n0,1,0\n2,1.5,0.6\n4.5,2,0\n6,1,-0.9\n8,0.5,0.3\n10,0,0\n",
    )
    .unwrap();
    std::fs::write(d.join("bike.csv"), "t,v,steer\n0,1,0.1\n1.5,2,-0.2\n3,1,0.3\n5,0,0\n").unwrap();
    std::fs::write(
        d.join("car.csv"),
        "t,v,steer_rate\n0,3,0.05\n2,3,-0.1\n4,2,0.05\n6,0,0\n",
    )
    .unwrap();
    let mut enc = String::from("t,left,right\n");
    for k in 0..50 {
        writeln!(enc, "{},{},{}", k as f64 * 0.1, 100 + k % 7, 104 + (k * 3) % 11).unwrap();
    }
    std::fs::write(d.join("enc.csv"), enc).unwrap();
    let mut out = String::new();
    for (model, csv, method) in [
        ("unicycle", "uni.csv", "exact"),
        ("unicycle", "uni.csv", "rk45"),
        ("bicycle", "bike.csv", "euler"),
        ("bicycle", "bike.csv", "implicit-euler"),
        ("carlike", "car.csv", "bdf"),
        ("carlike", "car.csv", "rodas5p"),
        ("carlike", "car.csv", "auto"),
    ] {
        let args = [
            "simulate",
            "--model",
            model,
            "--controls",
            csv,
            "--method",
            method,
            "--dt",
            "0.25",
        ];
        writeln!(out, "$ reckon {}\n{}", args.join(" "), reckon_in(&d, &args)).unwrap();
    }
    for update in ["midpoint", "euler", "exact"] {
        let args = [
            "odometry",
            "--encoders",
            "enc.csv",
            "--wheel-diameter",
            "0.1",
            "--wheel-separation",
            "0.4",
            "--pulses-per-rev",
            "2048",
            "--update",
            update,
        ];
        writeln!(out, "$ reckon {}\n{}", args.join(" "), reckon_in(&d, &args)).unwrap();
    }
    golden("simulate_odometry", &out);
}

#[test]
fn jacobian_prints() {
    let d = scratch("jacobian");
    let mut out = String::new();
    for args in [
        &["jacobian", "--model", "carlike"][..],
        &["jacobian", "--problem", "robertson"],
        &["jacobian", "--problem", "hires", "--format", "rust"],
        &["jacobian", "--problem", "brusselator:3", "--format", "json"],
    ] {
        writeln!(out, "$ reckon {}\n{}", args.join(" "), reckon_in(&d, args)).unwrap();
    }
    golden("jacobian", &out);
}
