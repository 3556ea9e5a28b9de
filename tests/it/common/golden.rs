//! The golden-file check shared by the library's and the command's golden tests: the
//! files live in the repository's `tests/golden/`.

use std::path::PathBuf;

/// The repository's `tests/golden/`, from the library's or the command's crate.
fn dir() -> PathBuf {
    let m = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let root = if m.ends_with("crates/reckon-cli") {
        m.join("../..")
    } else {
        m
    };
    root.join("tests/golden")
}

/// Compare `text` with `tests/golden/<name>.txt`, or write it there under `RECKON_BLESS`.
pub fn golden(name: &str, text: &str) {
    let path = dir().join(format!("{name}.txt"));
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
