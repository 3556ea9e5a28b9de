//! The report's figures and page: every legend clear of the data, readable text, a page
//! that works on a phone. Built with `reckon demo --fast`.

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;

fn build() -> PathBuf {
    let out = std::env::temp_dir().join(format!("reckon-report-{}", std::process::id()));
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
    let layouts: Vec<Value> =
        serde_json::from_str(&std::fs::read_to_string(out.join("figures.json")).unwrap()).unwrap();
    for file in &files {
        check_svg(&out.join(file));
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
