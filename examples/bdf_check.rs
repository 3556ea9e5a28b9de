use nalgebra::vector;
use reckon::methods::{Bdf, ImplicitEuler};
use reckon::studies::problems::*;
use reckon::{Options, Problem};
fn main() {
    for rtol in [1e-6, 1e-10] {
        let p = Problem::new(robertson(), vector![1.0, 0.0, 0.0], (0.0, 1e11));
        let o = Options::default().rtol(rtol).atol(1e-4 * rtol).max_steps(1_000_000);
        let s = p.solve(Bdf::default(), &o).unwrap();
        let y = s.last().1;
        let m = (0..3)
            .map(|i| (y[i] - ROBERTSON_REF_1E11[i]).abs() / (1e-4 + ROBERTSON_REF_1E11[i].abs()))
            .fold(0.0, f64::max);
        println!("rober rtol {rtol}: mescd {:.2} {:?}", -m.log10(), s.stats);
        let p = Problem::new(van_der_pol(1000.0), vector![2.0, 0.0], (0.0, 2000.0));
        let o = Options::default().rtol(rtol).atol(rtol).max_steps(1_000_000);
        let s = p.solve(Bdf::default(), &o).unwrap();
        let y = s.last().1;
        let m = (0..2)
            .map(|i| (y[i] - VDPOLM_REF_2000[i]).abs() / (1.0 + VDPOLM_REF_2000[i].abs()))
            .fold(0.0, f64::max);
        println!("vdpolm rtol {rtol}: mescd {:.2} {:?}", -m.log10(), s.stats);
        let p = Problem::new(orego(), vector![1.0, 2.0, 3.0], (0.0, 360.0));
        let s = p.solve(Bdf::default(), &o).unwrap();
        let y = s.last().1;
        let m = (0..3)
            .map(|i| (y[i] - OREGO_REF_360[i]).abs() / (1.0 + OREGO_REF_360[i].abs()))
            .fold(0.0, f64::max);
        println!("orego rtol {rtol}: mescd {:.2} {:?}", -m.log10(), s.stats);
        let p = Problem::new(hires(), hires_y0(), (0.0, HIRES_T));
        let s = p.solve(Bdf::default(), &o).unwrap();
        let y = s.last().1;
        let m = (0..8)
            .map(|i| (y[i] - HIRES_REF[i]).abs() / (1.0 + HIRES_REF[i].abs()))
            .fold(0.0, f64::max);
        println!("hires rtol {rtol}: mescd {:.2} {:?}", -m.log10(), s.stats);
        let p = Problem::new(robertson(), vector![1.0, 0.0, 0.0], (0.0, 1e5));
        let o = Options::default().rtol(rtol).atol(1e-4 * rtol).max_steps(10_000_000);
        let s = p.solve(ImplicitEuler::default(), &o).unwrap();
        println!("IE rober 1e5 {:?}", s.stats);
    }
}
