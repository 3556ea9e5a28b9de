//! The import graph of the library's top-level modules (`src/<module>.rs` or
//! `src/<module>/`), read from the source: an edge `a → b` for every `crate::b` path in
//! `a`'s files (`use crate::{b, …}` groups included; comments skipped). Data should
//! travel one way, so the graph's strongly connected components are what this test
//! watches: there is none, and [`KNOWN_CYCLE`] (empty) is the only place one could be
//! allowed.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// Modules allowed in a cycle: none. (Until 2026-12-07 nine were: `system` called
/// `sensitivity::write_eps` and `integrator::brief`, `params` the former, `sparse`
/// implemented `Eval`'s sparse path on `system`'s types, and `problem` built the
/// `Integrator`. Then the folders were regrouped by role, and the choices that kept the
/// new graph a DAG were: the error norm and step-size controller live in `methods`
/// (methods measure their own error), the Newton iteration matrix in `methods` (it
/// evaluates the model; `linalg` stays pure), `Flow`/`DualFlow` and `Stats` in `model`,
/// and `jacobian::choice` decides dense or sparse without knowing the model.)
const KNOWN_CYCLE: &[&str] = &[];

/// Remove `//` comments (doc comments included) and string literals' contents.
fn code_only(src: &str) -> String {
    let mut out = String::with_capacity(src.len());
    for line in src.lines() {
        let mut in_str = false;
        let mut prev = ' ';
        let mut chars = line.chars().peekable();
        while let Some(c) = chars.next() {
            if !in_str && c == '/' && chars.peek() == Some(&'/') {
                break;
            }
            if c == '"' && prev != '\\' {
                in_str = !in_str;
            } else if !in_str {
                out.push(c);
            }
            prev = c;
        }
        out.push('\n');
    }
    out
}

/// `code` without its `#[cfg(test)]` items (unit tests may use anything).
fn without_tests(code: &str) -> String {
    let mut out = String::with_capacity(code.len());
    let mut rest = code;
    while let Some(i) = rest.find("#[cfg(test)]") {
        out.push_str(&rest[..i]);
        rest = &rest[i..];
        // skip to the end of the item: its first `{ … }` block, or its `;`
        let open = rest.find('{');
        let semi = rest.find(';');
        match (open, semi) {
            (Some(o), s) if s.is_none_or(|s| o < s) => {
                let mut depth = 0usize;
                let mut end = rest.len();
                for (k, c) in rest[o..].char_indices() {
                    match c {
                        '{' => depth += 1,
                        '}' => {
                            depth -= 1;
                            if depth == 0 {
                                end = o + k + 1;
                                break;
                            }
                        }
                        _ => {}
                    }
                }
                rest = &rest[end..];
            }
            (_, Some(s)) => rest = &rest[s + 1..],
            _ => rest = "",
        }
    }
    out.push_str(rest);
    out
}

/// The first identifiers of every path in `crate::…`, including each member of a
/// `crate::{a, b::c, d::{e}}` group.
fn crate_paths(code: &str) -> BTreeSet<String> {
    let mut found = BTreeSet::new();
    let ident = |s: &str| -> String { s.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect() };
    let mut rest = code;
    while let Some(i) = rest.find("crate::") {
        let before = rest[..i].chars().last();
        rest = &rest[i + "crate::".len()..];
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_' || c == '$') {
            continue; // `$crate::` in a macro, or part of a longer name
        }
        if let Some(group) = rest.strip_prefix('{') {
            // members at depth 0 of the group
            let (mut depth, mut start) = (0usize, true);
            for (k, c) in group.char_indices() {
                match c {
                    '{' => depth += 1,
                    '}' if depth == 0 => break,
                    '}' => depth -= 1,
                    ',' if depth == 0 => start = true,
                    c if start && !c.is_whitespace() => {
                        start = false;
                        let id = ident(&group[k..]);
                        if !id.is_empty() {
                            found.insert(id);
                        }
                    }
                    _ => {}
                }
            }
        } else {
            let id = ident(rest);
            if !id.is_empty() {
                found.insert(id);
            }
        }
    }
    found
}

fn rust_files(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// `module → modules it names`, over `src/`.
fn graph() -> BTreeMap<String, BTreeSet<String>> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let top = |p: &Path| -> String {
        let rel = p.strip_prefix(&src).unwrap();
        let first = rel.components().next().unwrap().as_os_str().to_str().unwrap();
        first.trim_end_matches(".rs").to_string()
    };
    let modules: BTreeSet<String> = files.iter().map(|p| top(p)).collect();
    let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for p in &files {
        let m = top(p);
        if m == "lib" || m == "prelude" {
            continue; // the crate root and the prelude re-export everything
        }
        let code = without_tests(&code_only(&std::fs::read_to_string(p).unwrap()));
        let e = g.entry(m.clone()).or_default();
        for t in crate_paths(&code) {
            if t != m && modules.contains(&t) {
                e.insert(t);
            }
        }
    }
    g
}

/// Strongly connected components with more than one module (Tarjan).
fn cycles(g: &BTreeMap<String, BTreeSet<String>>) -> Vec<BTreeSet<String>> {
    struct T<'a> {
        g: &'a BTreeMap<String, BTreeSet<String>>,
        index: BTreeMap<&'a str, usize>,
        low: BTreeMap<&'a str, usize>,
        stack: Vec<&'a str>,
        next: usize,
        out: Vec<BTreeSet<String>>,
    }
    fn visit<'a>(t: &mut T<'a>, v: &'a str) {
        t.index.insert(v, t.next);
        t.low.insert(v, t.next);
        t.next += 1;
        t.stack.push(v);
        let g = t.g;
        for w in g.get(v).into_iter().flatten() {
            let w = w.as_str();
            if !t.index.contains_key(w) {
                visit(t, w);
                let lw = t.low[w];
                let lv = t.low.get_mut(v).unwrap();
                *lv = (*lv).min(lw);
            } else if t.stack.contains(&w) {
                let iw = t.index[w];
                let lv = t.low.get_mut(v).unwrap();
                *lv = (*lv).min(iw);
            }
        }
        if t.low[v] == t.index[v] {
            let mut c = BTreeSet::new();
            while let Some(w) = t.stack.pop() {
                c.insert(w.to_string());
                if w == v {
                    break;
                }
            }
            if c.len() > 1 {
                t.out.push(c);
            }
        }
    }
    let mut t = T {
        g,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        next: 0,
        out: Vec::new(),
    };
    for v in g.keys() {
        if !t.index.contains_key(v.as_str()) {
            visit(&mut t, v);
        }
    }
    t.out
}

#[test]
fn the_scanner_reads_paths_and_groups() {
    let code = code_only(
        "use crate::a::B;\nuse crate::{c, d::{E, f::G}, h};\n// crate::zz\nlet s = \"crate::yy\";\n$crate::m::x();\nfoo_crate::n;",
    );
    let got: Vec<String> = crate_paths(&code).into_iter().collect();
    assert_eq!(got, ["a", "c", "d", "h"]);
}

#[test]
fn unit_tests_are_left_out() {
    let code = "use crate::a;\n#[cfg(test)]\nmod tests {\n    use crate::b;\n    fn f() { crate::c::g(); }\n}\n#[cfg(test)]\nuse crate::d;\nuse crate::e;";
    let got: Vec<String> = crate_paths(&without_tests(code)).into_iter().collect();
    assert_eq!(got, ["a", "e"]);
}

#[test]
fn the_cycle_finder_finds_cycles() {
    let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (a, b) in [("a", "b"), ("b", "c"), ("c", "a"), ("c", "d"), ("d", "e"), ("e", "d")] {
        g.entry(a.into()).or_default().insert(b.into());
        g.entry(b.into()).or_default();
    }
    let mut c = cycles(&g);
    c.sort();
    let names: Vec<Vec<&str>> = c.iter().map(|s| s.iter().map(String::as_str).collect()).collect();
    assert_eq!(names, [vec!["a", "b", "c"], vec!["d", "e"]]);
}

#[test]
fn no_import_cycle_but_the_known_one() {
    let g = graph();
    assert!(g.len() >= 15, "read {} modules", g.len());
    let known: BTreeSet<String> = KNOWN_CYCLE.iter().map(|s| s.to_string()).collect();
    for c in cycles(&g) {
        assert!(
            c.is_subset(&known),
            "an import cycle outside the known one: {c:?} (graph: {:?})",
            c.iter().map(|m| (m, &g[m])).collect::<Vec<_>>()
        );
    }
}
