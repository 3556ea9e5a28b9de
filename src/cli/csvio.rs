//! CSV in and out for the command: numbered-line errors, round-trip number output.

use std::fmt;
use std::io::Write;
use std::path::Path;

/// A problem with an input file, naming the line where it was found.
#[derive(Debug)]
pub struct InputError {
    pub file: String,
    pub line: Option<u64>,
    pub message: String,
}

impl fmt::Display for InputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some(l) => write!(f, "{}: line {l}: {}", self.file, self.message),
            None => write!(f, "{}: {}", self.file, self.message),
        }
    }
}

impl std::error::Error for InputError {}

/// Rows of a numeric CSV read up to the first bad one.
pub struct Table {
    /// `(line, values in the order of the requested columns)`.
    pub rows: Vec<(u64, Vec<f64>)>,
    /// The first problem found, if any; `rows` holds everything before it.
    pub error: Option<InputError>,
}

/// Read `path`, whose header must name every column in `columns` (first one is time,
/// strictly increasing). Stops at the first malformed row.
pub fn read_table(path: &Path, columns: &[&str]) -> Result<Table, InputError> {
    let file = path.display().to_string();
    let fail = |line: Option<u64>, message: String| InputError {
        file: file.clone(),
        line,
        message,
    };
    let mut rdr = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .flexible(true)
        .from_path(path)
        .map_err(|e| fail(None, format!("cannot read: {}", io_reason(&e))))?;
    let header = rdr
        .headers()
        .map_err(|e| fail(Some(1), format!("cannot read the header: {e}")))?
        .clone();
    let mut index = Vec::with_capacity(columns.len());
    for c in columns {
        match header.iter().position(|h| h == *c) {
            Some(i) => index.push(i),
            None => {
                let found: Vec<&str> = header.iter().collect();
                return Err(fail(
                    Some(1),
                    format!(
                        "missing column '{c}' (header must be {}; found {})",
                        columns.join(","),
                        found.join(",")
                    ),
                ));
            }
        }
    }
    let mut table = Table {
        rows: Vec::new(),
        error: None,
    };
    for rec in rdr.records() {
        let rec = match rec {
            Ok(r) => r,
            Err(e) => {
                let line = e.position().map(|p| p.line());
                table.error = Some(fail(line, format!("malformed row: {e}")));
                break;
            }
        };
        let line = rec.position().map(|p| p.line()).unwrap_or(0);
        match parse_row(&rec, columns, &index) {
            Err(msg) => {
                table.error = Some(fail(Some(line), msg));
                break;
            }
            Ok(vals) => {
                if let Some((_, prev)) = table.rows.last()
                    && vals[0] <= prev[0]
                {
                    table.error = Some(fail(
                        Some(line),
                        format!("time does not increase: {} after {}", vals[0], prev[0]),
                    ));
                    break;
                }
                table.rows.push((line, vals));
            }
        }
    }
    Ok(table)
}

fn parse_row(rec: &csv::StringRecord, columns: &[&str], index: &[usize]) -> Result<Vec<f64>, String> {
    let mut vals = Vec::with_capacity(index.len());
    for (c, &i) in columns.iter().zip(index) {
        let field = rec
            .get(i)
            .ok_or_else(|| format!("malformed row: {} fields, column '{c}' is missing", rec.len()))?;
        let v: f64 = field
            .parse()
            .map_err(|_| format!("column '{c}': '{field}' is not a number"))?;
        if !v.is_finite() {
            return Err(format!("column '{c}': {field} is not finite"));
        }
        vals.push(v);
    }
    Ok(vals)
}

fn io_reason(e: &csv::Error) -> String {
    match e.kind() {
        csv::ErrorKind::Io(io) => io.to_string(),
        _ => e.to_string(),
    }
}

/// Output sink: a file (created up front, so an unwritable path fails before any work) or stdout.
pub fn open_output(path: Option<&Path>) -> Result<Box<dyn Write>, Box<dyn std::error::Error>> {
    Ok(match path {
        Some(p) => Box::new(std::io::BufWriter::new(
            std::fs::File::create(p).map_err(|e| format!("cannot write {}: {e}", p.display()))?,
        )),
        None => Box::new(std::io::BufWriter::new(std::io::stdout())),
    })
}

/// One CSV row; `{}` on f64 prints the shortest text that parses back to the same value.
pub fn write_row(out: &mut dyn Write, t: f64, values: &[f64]) -> std::io::Result<()> {
    write!(out, "{t}")?;
    for v in values {
        write!(out, ",{v}")?;
    }
    writeln!(out)
}
