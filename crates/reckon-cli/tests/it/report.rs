//! The report's figures and page: every legend clear of the data, readable text, a page
//! that works on a phone. Built with `reckon demo --fast`.

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;

fn build() -> PathBuf {
    build_named("main")
}

/// The report of `reckon demo --fast` in a folder of its own (`name` keeps two tests of
/// one process apart).
fn build_named(name: &str) -> PathBuf {
    let out = std::env::temp_dir().join(format!("reckon-report-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let o = Command::new(env!("CARGO_BIN_EXE_reckon"))
        .args(["demo", "--fast", "--out", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    out
}

/// The `src` of every `<img>` in the page.
fn images(html: &str) -> Vec<String> {
    html.split("<img src=\"")
        .skip(1)
        .map(|s| s[..s.find('"').unwrap()].to_string())
        .collect()
}

type Rect = [i64; 4];

fn rect(v: &Value) -> Rect {
    let a = v.as_array().unwrap();
    [0, 1, 2, 3].map(|k| a[k].as_i64().unwrap())
}

fn pts(v: &Value) -> Vec<(i64, i64)> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|p| (p[0].as_i64().unwrap(), p[1].as_i64().unwrap()))
        .collect()
}

fn inside(p: (i64, i64), r: &Rect, grow: i64) -> bool {
    p.0 >= r[0] - grow && p.0 <= r[2] + grow && p.1 >= r[1] - grow && p.1 <= r[3] + grow
}

/// Orientation of c against a→b (sign of the cross product).
fn orient(a: (i64, i64), b: (i64, i64), c: (i64, i64)) -> i64 {
    ((b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0)).signum()
}

fn on_segment(a: (i64, i64), b: (i64, i64), c: (i64, i64)) -> bool {
    c.0 >= a.0.min(b.0) && c.0 <= a.0.max(b.0) && c.1 >= a.1.min(b.1) && c.1 <= a.1.max(b.1)
}

fn segments_cross(a: (i64, i64), b: (i64, i64), c: (i64, i64), d: (i64, i64)) -> bool {
    let (o1, o2, o3, o4) = (orient(a, b, c), orient(a, b, d), orient(c, d, a), orient(c, d, b));
    (o1 != o2 && o3 != o4)
        || (o1 == 0 && on_segment(a, b, c))
        || (o2 == 0 && on_segment(a, b, d))
        || (o3 == 0 && on_segment(c, d, a))
        || (o4 == 0 && on_segment(c, d, b))
}

/// Whether the segment a–b touches the rectangle: an end inside, or crossing an edge.
fn segment_meets(a: (i64, i64), b: (i64, i64), r: &Rect) -> bool {
    let c = [(r[0], r[1]), (r[2], r[1]), (r[2], r[3]), (r[0], r[3])];
    inside(a, r, 0) || inside(b, r, 0) || (0..4).any(|k| segments_cross(a, b, c[k], c[(k + 1) % 4]))
}

#[test]
fn segment_test_is_sound() {
    let r = [10, 10, 20, 20];
    assert!(segment_meets((0, 15), (30, 15), &r));
    assert!(segment_meets((0, 0), (30, 30), &r));
    assert!(!segment_meets((0, 0), (30, 5), &r));
    assert!(!segment_meets((0, 30), (9, 0), &r));
}

#[test]
fn report_figures_legends_text_and_page() {
    let out = build();
    let html = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(
        html.contains(r#"<meta name="viewport" content="width=device-width, initial-scale=1">"#),
        "no viewport meta tag"
    );
    assert!(html.contains("max-width:100%"), "images are not responsive");
    assert!(
        html.contains("overflow-x:auto"),
        "tables do not scroll on narrow screens"
    );
    assert_eq!(
        html.matches("<table>").count(),
        html.matches("<div class=\"scroll\"><table>").count(),
        "every table sits in a scrolling container"
    );
    let files = images(&html);
    assert!(files.len() >= 22, "only {} figures", files.len());
    // MathML fences stretch only with a math font: the page names one
    assert!(
        html.contains("math{font-family:\"STIX Two Math\",\"Latin Modern Math\",\"Cambria Math\""),
        "no math font stack"
    );
    // the unicycle's text names the five segments its figure shows
    assert!(html.contains("right arc, slow left arc"));
    let phone = PhoneWidth::of(&html);
    let layouts: Vec<Value> =
        serde_json::from_str(&std::fs::read_to_string(out.join("figures.json")).unwrap()).unwrap();
    for file in &files {
        check_svg(&out.join(file));
        check_phone_text(&out.join(file), &phone);
        let lay = layouts
            .iter()
            .find(|l| l["file"] == file.as_str())
            .unwrap_or_else(|| panic!("{file}: no layout in figures.json"));
        check_legend(file, lay, &std::fs::read_to_string(out.join(file)).unwrap());
    }
    // the DP5 islands and every other stability boundary close inside the window
    let stab = layouts.iter().find(|l| l["file"] == "stability_regions.svg").unwrap();
    for s in stab["series"].as_array().unwrap() {
        let p = pts(&s["points"]);
        assert!(p.len() > 100);
        for (k, a) in p.iter().enumerate() {
            let partner = p
                .iter()
                .enumerate()
                .any(|(j, b)| j / 2 != k / 2 && (a.0 - b.0).abs() <= 1 && (a.1 - b.1).abs() <= 1);
            assert!(partner, "{}: open end at {a:?}", s["label"]);
        }
    }
}

/// How wide the page shows a figure on a phone 420 CSS px wide: the viewport less the
/// body's side padding in the narrow-screen rule and the image's border, read from the
/// page's CSS (so that a change there is measured, not assumed).
struct PhoneWidth {
    content: f64,
}

impl PhoneWidth {
    const VIEWPORT: f64 = 420.0;
    const EM: f64 = 16.0;
    fn of(html: &str) -> PhoneWidth {
        let css = &html[html.find("<style>").unwrap()..html.find("</style>").unwrap()];
        // images shrink to the column, never grow past their own width
        assert!(css.contains("img{display:block;max-width:100%;height:auto;"), "{css}");
        let border = css[css.find("img{").unwrap()..]
            .split("border:")
            .nth(1)
            .and_then(|b| b.split("px").next())
            .map(|b| b.parse::<f64>().unwrap())
            .unwrap_or(0.0);
        // @media (max-width:600px){body{padding:TOP SIDE}…}: 420 px is inside the rule
        let media = &css[css.find("@media (max-width:600px){").expect("a narrow-screen rule")..];
        let pad = media.split("body{padding:").nth(1).unwrap();
        let pad = &pad[..pad.find(['}', ';']).unwrap()];
        let side = pad.split_whitespace().nth(1).unwrap_or(pad);
        let side = match side.strip_suffix("em") {
            Some(em) => em.parse::<f64>().unwrap() * Self::EM,
            None => side.trim_end_matches("px").parse::<f64>().unwrap(),
        };
        PhoneWidth {
            content: Self::VIEWPORT - 2.0 * side - 2.0 * border,
        }
    }
}

/// Every text of the figure is at least 10 CSS px when the page is 420 px wide: its
/// font size times the scale at which the figure is shown (the column's width over the
/// SVG's viewBox width, or 1 when the figure is narrower than the column).
fn check_phone_text(path: &Path, phone: &PhoneWidth) {
    let text = std::fs::read_to_string(path).unwrap();
    let doc = roxmltree::Document::parse(&text).unwrap();
    let root = doc.root_element();
    let vb: Vec<f64> = root
        .attribute("viewBox")
        .unwrap()
        .split_whitespace()
        .map(|v| v.parse().unwrap())
        .collect();
    let width: f64 = root.attribute("width").unwrap().parse().unwrap();
    let shown = width.min(phone.content);
    let scale = shown / vb[2];
    for t in doc.descendants().filter(|n| n.has_tag_name("text")) {
        let size: f64 = t
            .attribute("font-size")
            .unwrap()
            .trim_end_matches("px")
            .parse()
            .unwrap();
        assert!(
            size * scale >= 10.0,
            "{}: {:?} is {:.1} CSS px at 420 px ({size} px × {scale:.3})",
            path.display(),
            t.text().map(str::trim),
            size * scale
        );
    }
}

/// The colour (`stroke` or `fill`) of every element the SVG draws with, and how many
/// elements use it.
fn colours(svg: &str) -> std::collections::HashMap<String, usize> {
    let doc = roxmltree::Document::parse(svg).unwrap();
    let mut out = std::collections::HashMap::new();
    for n in doc.descendants().filter(|n| n.is_element() && !n.has_tag_name("text")) {
        for a in ["stroke", "fill"] {
            if let Some(c) = n.attribute(a).filter(|c| c.starts_with('#')) {
                *out.entry(c.to_string()).or_insert(0) += 1;
            }
        }
    }
    out
}

/// Series that belong together share one colour, and different groups differ: `groups`
/// lists each group's labels. Checked in the layout and in the SVG (each colour drawn).
fn check_pairs(out: &Path, layouts: &[Value], file: &str, groups: &[&[&str]]) {
    let lay = layouts.iter().find(|l| l["file"] == file).unwrap();
    let series = lay["series"].as_array().unwrap();
    let colour = |label: &str| -> String {
        series
            .iter()
            .find(|s| s["label"] == label)
            .unwrap_or_else(|| panic!("{file}: no series {label:?}"))["color"]
            .as_str()
            .unwrap()
            .to_string()
    };
    let used = colours(&std::fs::read_to_string(out.join(file)).unwrap());
    let mut seen: Vec<String> = Vec::new();
    for g in groups {
        let c = colour(g[0]);
        for label in &g[1..] {
            assert_eq!(colour(label), c, "{file}: {label:?} is not in the colour of {:?}", g[0]);
        }
        assert!(
            !seen.contains(&c),
            "{file}: {:?} shares its colour {c} with another group",
            g[0]
        );
        // drawn: the lines or dots of every member of the group, and its legend entries
        assert!(
            used.get(&c).copied().unwrap_or(0) > g.len(),
            "{file}: colour {c} of {:?} is hardly drawn ({:?})",
            g[0],
            used.get(&c)
        );
        seen.push(c);
    }
}

#[test]
fn paired_figures_share_one_colour_per_pair() {
    let out = build_named("pairs");
    let layouts: Vec<Value> =
        serde_json::from_str(&std::fs::read_to_string(out.join("figures.json")).unwrap()).unwrap();
    let times: Vec<[String; 2]> = [10, 20, 30, 40]
        .map(|t| [format!("t = {t} s: ensemble"), format!("t = {t} s: EKF")])
        .to_vec();
    let groups: Vec<Vec<&str>> = times.iter().map(|p| p.iter().map(String::as_str).collect()).collect();
    let groups: Vec<&[&str]> = groups.iter().map(Vec::as_slice).collect();
    check_pairs(&out, &layouts, "ensemble_encoder_ellipses.svg", &groups);
    // the EKF's ellipse is a thin dashed line over the ensemble's wide pale one
    let svg = std::fs::read_to_string(out.join("ensemble_encoder_ellipses.svg")).unwrap();
    let doc = roxmltree::Document::parse(&svg).unwrap();
    let lines: Vec<_> = doc.descendants().filter(|n| n.has_tag_name("polyline")).collect();
    for (label, _) in groups.iter().map(|g| (g[0], ())) {
        let lay = layouts
            .iter()
            .find(|l| l["file"] == "ensemble_encoder_ellipses.svg")
            .unwrap();
        let c = lay["series"]
            .as_array()
            .unwrap()
            .iter()
            .find(|s| s["label"] == label)
            .unwrap()["color"]
            .as_str()
            .unwrap()
            .to_string();
        let of = |w: &str| {
            lines
                .iter()
                .filter(|l| l.attribute("stroke") == Some(&c) && l.attribute("stroke-width") == Some(w))
                .count()
        };
        assert!(of("6") >= 1, "{label}: no wide line");
        assert!(
            of("2") >= 20,
            "{label}: the EKF line is not dashed ({} pieces)",
            of("2")
        );
    }
    check_pairs(
        &out,
        &layouts,
        "umbmark.svg",
        &[
            &["ccw: truth", "ccw: odometry", "ccw: true end"],
            &["cw: truth", "cw: odometry", "cw: true end"],
            &["start"],
        ],
    );
    check_pairs(
        &out,
        &layouts,
        "ensemble_auv_sigma.svg",
        &[
            &["σx ensemble", "σy ensemble", "σx = σy Kalman"],
            &["σz ensemble", "σz Kalman"],
        ],
    );
    // UMBmark: the start is drawn last (on top), and the x axis spans the square and its
    // margin, not −5…9 m: every x tick within [−1, 5]
    let umb = layouts.iter().find(|l| l["file"] == "umbmark.svg").unwrap();
    assert_eq!(umb["series"].as_array().unwrap().last().unwrap()["label"], "start");
    let svg = std::fs::read_to_string(out.join("umbmark.svg")).unwrap();
    let ticks = numeric_texts(&svg, Some("middle"));
    assert!(ticks.iter().all(|v| (-1.0..=5.0).contains(v)), "{ticks:?}");
    // the spy plot's rows are numbered 1…2N downwards, never negative
    let spy = numeric_texts(&std::fs::read_to_string(out.join("brusselator_spy.svg")).unwrap(), None);
    assert!(spy.len() > 6 && spy.iter().all(|v| *v >= 0.0), "{spy:?}");
    // implicit Euler is dotted in the stability figure's curve as in its legend: its
    // boundary is drawn in many short pieces
    let stab = std::fs::read_to_string(out.join("stability_regions.svg")).unwrap();
    let ie = stab.matches("stroke=\"#2CA02C\"").count();
    assert!(ie > 40, "implicit Euler drawn in {ie} pieces");
    // the stiff work–precision figures plot correct digits
    for p in ["robertson", "van-der-pol", "orego"] {
        let svg = std::fs::read_to_string(out.join(format!("stiff_wp_{p}_evals.svg"))).unwrap();
        assert!(svg.contains("correct digits at t_end (mescd)"), "{p}");
    }
}

/// The numbers among the SVG's texts (the tick labels), only those anchored at `anchor`
/// when given (the x axis' are centred, the y axis' end at the axis).
fn numeric_texts(svg: &str, anchor: Option<&str>) -> Vec<f64> {
    let doc = roxmltree::Document::parse(svg).unwrap();
    doc.descendants()
        .filter(|n| n.has_tag_name("text"))
        .filter(|n| anchor.is_none() || n.attribute("text-anchor") == anchor)
        .filter_map(|n| n.text().and_then(|t| t.trim().parse::<f64>().ok()))
        .collect()
}

/// The SVG parses, every text is at least 13 px, and no linear-axis tick is rounding noise.
fn check_svg(path: &Path) {
    let text = std::fs::read_to_string(path).unwrap();
    let doc = roxmltree::Document::parse(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut n = 0;
    for t in doc.descendants().filter(|n| n.has_tag_name("text")) {
        let size: f64 = t
            .attribute("font-size")
            .unwrap_or_else(|| panic!("{}: text without font-size", path.display()))
            .trim_end_matches("px")
            .parse()
            .unwrap();
        assert!(size >= 13.0, "{}: text {:?} at {size} px", path.display(), t.text());
        n += 1;
    }
    assert!(n >= 5, "{}: only {n} texts", path.display());
}

fn check_legend(file: &str, lay: &Value, svg: &str) {
    let pa = rect(&lay["plot_area"]);
    let series = lay["series"].as_array().unwrap();
    let total: usize = series.iter().map(|s| s["points"].as_array().unwrap().len()).sum();
    assert!(total > 0, "{file}: nothing plotted");
    // the recorded pixels are where the data are: inside the plot area
    for s in series {
        for p in pts(&s["points"]).into_iter().chain(pts(&s["markers"])) {
            assert!(inside(p, &pa, 1), "{file}: point {p:?} outside the plot area {pa:?}");
        }
    }
    let labelled = series.iter().any(|s| s["label"] != "");
    if !labelled {
        assert!(lay["legend"].is_null());
        return;
    }
    let lg = rect(&lay["legend"]);
    let (w, h) = (lay["width"].as_i64().unwrap(), lay["height"].as_i64().unwrap());
    assert!(
        lg[0] >= 0 && lg[1] >= 0 && lg[2] <= w && lg[3] <= h,
        "{file}: legend {lg:?} off the {w}×{h} canvas"
    );
    // the recorded legend box is the one drawn
    let drawn = format!(
        r#"<rect x="{}" y="{}" width="{}" height="{}""#,
        lg[0],
        lg[1],
        lg[2] - lg[0],
        lg[3] - lg[1]
    );
    assert!(svg.contains(&drawn), "{file}: legend box {lg:?} not in the SVG");
    for s in series {
        let label = &s["label"];
        let r = s["marker_radius"].as_i64().unwrap();
        let p = pts(&s["points"]);
        for q in p.iter().chain(&pts(&s["markers"])) {
            assert!(!inside(*q, &lg, r), "{file}: legend {lg:?} covers {q:?} of {label}");
        }
        let segs: Vec<((i64, i64), (i64, i64))> = if s["joined"] == true {
            p.windows(2).map(|w| (w[0], w[1])).collect()
        } else if s["pairs"] == true {
            p.chunks_exact(2).map(|w| (w[0], w[1])).collect()
        } else {
            Vec::new()
        };
        for (a, b) in segs {
            assert!(
                !segment_meets(a, b, &lg),
                "{file}: legend {lg:?} covers the line {a:?}–{b:?} of {label}"
            );
        }
    }
    // a linear axis never shows rounding noise such as -6e-17 as a tick
    if lay["log_x"] == false && lay["log_y"] == false {
        for t in svg.split("<text").skip(1) {
            let body = &t[t.find('>').unwrap() + 1..t.find("</text>").unwrap()];
            if let Ok(v) = body.trim().parse::<f64>() {
                assert!(v == 0.0 || v.abs() > 1e-12, "{file}: tick label {body}");
            }
        }
    }
}
