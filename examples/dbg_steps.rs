//! Step-by-step trace of one stiff run (debugging aid): `dbg_steps PROBLEM METHOD RTOL`.
use reckon::methods::{Auto, Bdf, ImplicitEuler, Rodas5P};
use reckon::problems::*;
use reckon::{Options, Problem};
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let rtol: f64 = a[3].parse().unwrap();
    let m = a[2].as_str();
    macro_rules! go {
        ($p:expr, $atol:expr) => {{
            let p = $p;
            let opts = Options::default().rtol(rtol).atol($atol).max_steps(100_000);
            macro_rules! run {
                ($meth:expr) => {{
                    let mut it = p.integrator($meth, &opts).unwrap();
                    let mut last = it.stats();
                    loop {
                        match it.step() {
                            Ok(Some(t)) => {
                                let x = it.x();
                                let s = it.stats();
                                println!(
                                    "{t:14.7e} {:?} h {:10.3e} rej {} f {}",
                                    x.iter().map(|v| format!("{v:11.4e}")).collect::<Vec<_>>(),
                                    it.proposed_step(),
                                    s.rejected - last.rejected,
                                    s.rhs_evals - last.rhs_evals
                                );
                                last = s;
                            }
                            Ok(None) => break,
                            Err(e) => {
                                println!("error {e}");
                                break;
                            }
                        }
                    }
                }};
            }
            match m {
                "bdf" => run!(Bdf::default()),
                "rodas5p" => run!(Rodas5P::default()),
                "auto" => run!(Auto::default()),
                _ => run!(ImplicitEuler::default()),
            }
        }};
    }
    match a[1].as_str() {
        "rober11" => go!(
            Problem::new(robertson(), nalgebra::vector![1.0, 0.0, 0.0], (0.0, 1e11)),
            1e-4 * rtol
        ),
        "hires" => go!(Problem::new(hires(), hires_y0(), (0.0, HIRES_T)), rtol),
        "orego" => go!(
            Problem::new(orego(), nalgebra::vector![1.0, 2.0, 3.0], (0.0, 360.0)),
            rtol
        ),
        _ => go!(
            Problem::new(van_der_pol(1000.0), nalgebra::vector![2.0, 0.0], (0.0, 2000.0)),
            rtol
        ),
    }
}
