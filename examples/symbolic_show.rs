//! Print the traced forms of the crate's vehicle models and test problems.
use reckon::{studies::problems, symbolic, vehicles};

fn main() {
    let show = |name: &str, tr: reckon::Result<symbolic::Traced>| match tr {
        Ok(tr) => println!("== {name} ({} nodes)\n{}", tr.nodes(), tr.text()),
        Err(e) => println!("== {name}: {e}"),
    };
    show(
        "unicycle",
        symbolic::trace(&vehicles::unicycle::model(), 3).map(|t| t.with_names(&["x", "y", "θ"], &["v", "ω"])),
    );
    show(
        "bicycle",
        symbolic::trace(&vehicles::bicycle::model(0.5), 3).map(|t| t.with_names(&["x", "y", "θ"], &["v", "α"])),
    );
    show(
        "carlike",
        symbolic::trace(&vehicles::carlike::model(2.5), 4).map(|t| t.with_names(&["x", "y", "θ", "γ"], &["v", "ω"])),
    );
    show("body3d", symbolic::trace(&vehicles::body3d::model(), 3));
    show("robertson", symbolic::trace(&problems::robertson(), 3));
    show("vdp", symbolic::trace(&problems::van_der_pol(1000.0), 2));
    show("bruss 3", symbolic::trace(&problems::brusselator(3), 6));
    let tr = symbolic::trace(&vehicles::unicycle::model(), 3)
        .unwrap()
        .with_names(&["x", "y", "θ"], &["v", "ω"]);
    println!("{}\n{}\n{}", tr.latex(), tr.mathml(), tr.rust());
    for (name, c) in [
        (
            "unicycle",
            symbolic::trace(&vehicles::unicycle::model(), 3)
                .unwrap()
                .compile_jacobian(),
        ),
        (
            "carlike",
            symbolic::trace(&vehicles::carlike::model(2.5), 4)
                .unwrap()
                .compile_jacobian(),
        ),
        (
            "robertson",
            symbolic::trace(&problems::robertson(), 3).unwrap().compile_jacobian(),
        ),
    ] {
        println!("{name}: {} instructions, {c:?}", c.instructions());
    }
    show("stiff cosine", symbolic::trace(&problems::stiff_cosine(), 1));
    if let Some(path) = std::env::args().nth(1) {
        std::fs::write(path, symbolic::trace(&vehicles::unicycle::model(), 3).unwrap().rust()).unwrap();
    }
}
