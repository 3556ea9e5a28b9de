//! CSV in and out for the command, streamed: a row is read, used and dropped, so a log of
//! any length runs in constant memory. Errors name the line and stay on one short line;
//! numbers are written as the shortest text that parses back to the same `f64`.

use std::fmt;
use std::fs::File;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

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

/// Longest echo of an input field in an error message, in characters.
const ECHO_CHARS: usize = 40;

/// An input field for an error message: at most 40 characters (then "…"), control
/// characters escaped, so that the message stays one short line.
///
/// ```
/// use reckon_cli::csvio::brief;
/// assert_eq!(brief(b"1,5"), "1,5");
/// assert_eq!(brief(b"0.5\n2,1"), "0.5\\n2,1");
/// assert_eq!(brief(&[b'9'; 100]).chars().count(), 41);
/// ```
pub fn brief(field: &[u8]) -> String {
    let text = String::from_utf8_lossy(field);
    let mut out = String::new();
    for (n, c) in text.chars().enumerate() {
        if n == ECHO_CHARS {
            out.push('…');
            break;
        }
        match c {
            '\n' => out.push_str("\\n"),
            '\r' => out.push_str("\\r"),
            '\t' => out.push_str("\\t"),
            c if c.is_control() => out.push_str(&c.escape_default().to_string()),
            c => out.push(c),
        }
    }
    out
}

/// A number for an error message: the shortest text that round-trips, with an exponent
/// when it is very large or small (`1e+308`, never 309 digits).
///
/// ```
/// use reckon_cli::csvio::num;
/// assert_eq!(num(1e308), "1e+308");
/// assert_eq!(num(1e-7), "1e-7");
/// assert_eq!(num(2.0), "2");
/// assert_eq!(num(-0.25), "-0.25");
/// assert_eq!(num(f64::NEG_INFINITY), "-inf");
/// ```
pub fn num(v: f64) -> String {
    let mut buf = zmij::Buffer::new();
    trim_point_zero(buf.format(v)).to_string()
}

/// zmij (like ryu) writes integral values as `1.0`; `{}` and this command write `1`.
fn trim_point_zero(s: &str) -> &str {
    s.strip_suffix(".0").unwrap_or(s)
}

/// Reads a numeric CSV one row at a time: the header must name every requested column
/// (the first is time, strictly increasing, unless [`untimed`](RowReader::untimed));
/// every row must have as many fields as the header; every requested value must be a
/// finite number.
pub struct RowReader<R: Read> {
    file: String,
    timed: bool,
    rdr: csv::Reader<R>,
    columns: Vec<String>,
    index: Vec<usize>,
    header_len: usize,
    record: csv::ByteRecord,
    values: Vec<f64>,
    line: u64,
    rows: u64,
}

impl RowReader<File> {
    /// Open `path` and check its header.
    pub fn open(path: &Path, columns: &[&str]) -> Result<Self, InputError> {
        let file = path.display().to_string();
        let f = File::open(path).map_err(|e| InputError {
            file: file.clone(),
            line: None,
            message: format!("cannot read: {e}"),
        })?;
        Self::new(file, f, columns)
    }
}

impl<R: Read> RowReader<R> {
    /// Read CSV text from `reader` (called `name` in errors) and check its header.
    pub fn new(name: String, reader: R, columns: &[&str]) -> Result<Self, InputError> {
        let mut rdr = csv::ReaderBuilder::new()
            .trim(csv::Trim::Headers)
            .flexible(true)
            .buffer_capacity(1 << 16)
            .from_reader(reader);
        let fail = |message: String| InputError {
            file: name.clone(),
            line: Some(1),
            message,
        };
        let header = rdr
            .byte_headers()
            .map_err(|e| fail(format!("cannot read the header: {}", csv_reason(&e))))?
            .clone();
        let found: Vec<String> = header.iter().map(brief).collect();
        let mut index = Vec::with_capacity(columns.len());
        for c in columns {
            match header.iter().position(|h| h == c.as_bytes()) {
                Some(i) => index.push(i),
                None => {
                    let mut shown = found.join(",");
                    if shown.chars().count() > 2 * ECHO_CHARS {
                        shown = brief(shown.as_bytes());
                    }
                    return Err(fail(format!(
                        "missing column '{c}' (header must be {}; found {shown})",
                        columns.join(","),
                    )));
                }
            }
        }
        Ok(RowReader {
            file: name,
            timed: true,
            header_len: header.len(),
            rdr,
            columns: columns.iter().map(|c| c.to_string()).collect(),
            index,
            record: csv::ByteRecord::new(),
            values: vec![0.0; columns.len()],
            line: 1,
            rows: 0,
        })
    }

    /// Rows without a time column: the first requested column need not increase.
    ///
    /// ```
    /// use reckon_cli::csvio::RowReader;
    /// let text = "dt,x\n0.5,1\n0.25,2\n";
    /// let mut r = RowReader::new("d.csv".into(), text.as_bytes(), &["dt", "x"]).unwrap().untimed();
    /// assert_eq!(r.next_row().unwrap(), Some(&[0.5, 1.0][..]));
    /// assert_eq!(r.next_row().unwrap(), Some(&[0.25, 2.0][..]));
    /// ```
    pub fn untimed(mut self) -> Self {
        self.timed = false;
        self
    }

    /// The file's name, as used in errors.
    pub fn file(&self) -> &str {
        &self.file
    }

    /// The line of the row last returned by [`RowReader::next_row`].
    pub fn line(&self) -> u64 {
        self.line
    }

    /// Rows returned so far.
    pub fn rows(&self) -> u64 {
        self.rows
    }

    /// An error at the current line.
    pub fn error(&self, message: String) -> InputError {
        InputError {
            file: self.file.clone(),
            line: Some(self.line),
            message,
        }
    }

    /// The next row's values, in the order of the requested columns; `Ok(None)` at the
    /// end of the file; the first malformed row is an error naming its line.
    pub fn next_row(&mut self) -> Result<Option<&[f64]>, InputError> {
        let prev_t = self.values[0];
        match self.rdr.read_byte_record(&mut self.record) {
            Ok(false) => return Ok(None),
            Ok(true) => {}
            Err(e) => {
                let line = e.position().map(|p| p.line()).or(Some(self.line + 1));
                return Err(InputError {
                    file: self.file.clone(),
                    line,
                    message: format!("malformed row: {}", csv_reason(&e)),
                });
            }
        }
        self.line = self.record.position().map_or(self.line + 1, |p| p.line());
        let n = self.record.len();
        if n != self.header_len {
            let hint = if n > self.header_len { "; a decimal comma?" } else { "" };
            let mut msg = format!("{n} fields, the header has {}{hint}", self.header_len);
            if let Some(f) = self.record.iter().find(|f| f.contains(&b'\n')) {
                msg = format!("{msg}; an unterminated quote? ('{}')", brief(f));
            }
            return Err(self.error(msg));
        }
        for k in 0..self.index.len() {
            let field = self.record[self.index[k]].trim_ascii();
            match parse_f64(field) {
                Some(v) if v.is_finite() => self.values[k] = v,
                Some(_) => {
                    return Err(self.error(format!("column '{}': {} is not finite", self.columns[k], brief(field))));
                }
                None => {
                    let hint = if field.contains(&b'\n') {
                        " (an unterminated quote?)"
                    } else {
                        ""
                    };
                    return Err(self.error(format!(
                        "column '{}': '{}' is not a number{hint}",
                        self.columns[k],
                        brief(field)
                    )));
                }
            }
        }
        if self.timed && self.rows > 0 && self.values[0] <= prev_t {
            let t = self.values[0];
            self.values[0] = prev_t;
            return Err(self.error(format!("time does not increase: {} after {}", num(t), num(prev_t))));
        }
        self.rows += 1;
        Ok(Some(&self.values))
    }
}

fn parse_f64(field: &[u8]) -> Option<f64> {
    std::str::from_utf8(field).ok()?.parse().ok()
}

/// The reason of a CSV error without the crate's own position prefix, kept to one line.
fn csv_reason(e: &csv::Error) -> String {
    let text = match e.kind() {
        csv::ErrorKind::Io(io) => io.to_string(),
        csv::ErrorKind::Utf8 { err, .. } => format!("invalid UTF-8 in field {}", err.field() + 1),
        _ => e.to_string(),
    };
    brief(text.as_bytes())
}

/// Rows per block handed between threads.
const BLOCK: usize = 4096;

/// A block of parsed rows: `width` values per row, each row's line, and the error that
/// ended the file, if any.
struct Block {
    values: Vec<f64>,
    lines: Vec<u64>,
    error: Option<InputError>,
    last: bool,
}

/// [`RowReader`] on a background thread: rows are parsed there in blocks of 4096 while
/// the caller uses the previous ones (at most a few blocks in flight, so memory stays
/// constant). Same interface: `next_row`, `line`, `file`, `error`.
pub struct Rows {
    file: String,
    width: usize,
    rx: std::sync::mpsc::Receiver<Block>,
    block: Block,
    pos: usize,
    line: u64,
    finished: bool,
}

impl Rows {
    /// Open `path`, check its header here, then parse its rows on a thread.
    pub fn open(path: &Path, columns: &[&str]) -> Result<Self, InputError> {
        Ok(Self::spawn(RowReader::open(path, columns)?, columns.len()))
    }

    /// Parse the rows of `rdr` (whose rows have `width` values) on a thread.
    pub fn spawn<R: Read + Send + 'static>(mut rdr: RowReader<R>, width: usize) -> Self {
        let file = rdr.file().to_string();
        let (tx, rx) = std::sync::mpsc::sync_channel::<Block>(4);
        std::thread::spawn(move || {
            loop {
                let mut b = Block {
                    values: Vec::with_capacity(BLOCK * width),
                    lines: Vec::with_capacity(BLOCK),
                    error: None,
                    last: false,
                };
                while b.lines.len() < BLOCK {
                    match rdr.next_row() {
                        Ok(Some(v)) => {
                            b.values.extend_from_slice(v);
                            b.lines.push(rdr.line());
                        }
                        Ok(None) => {
                            b.last = true;
                            break;
                        }
                        Err(e) => {
                            b.error = Some(e);
                            b.last = true;
                            break;
                        }
                    }
                }
                let last = b.last;
                // a closed channel means the caller stopped reading
                if tx.send(b).is_err() || last {
                    return;
                }
            }
        });
        Rows {
            file,
            width,
            rx,
            block: Block {
                values: Vec::new(),
                lines: Vec::new(),
                error: None,
                last: false,
            },
            pos: 0,
            line: 1,
            finished: false,
        }
    }

    /// The file's name, as used in errors.
    pub fn file(&self) -> &str {
        &self.file
    }

    /// The line of the row last returned.
    pub fn line(&self) -> u64 {
        self.line
    }

    /// An error at the current line.
    pub fn error(&self, message: String) -> InputError {
        InputError {
            file: self.file.clone(),
            line: Some(self.line),
            message,
        }
    }

    /// As [`RowReader::next_row`].
    pub fn next_row(&mut self) -> Result<Option<&[f64]>, InputError> {
        loop {
            if self.pos < self.block.lines.len() {
                let i = self.pos;
                self.pos += 1;
                self.line = self.block.lines[i];
                return Ok(Some(&self.block.values[i * self.width..(i + 1) * self.width]));
            }
            if let Some(e) = self.block.error.take() {
                self.finished = true;
                return Err(e);
            }
            if self.finished || self.block.last {
                self.finished = true;
                return Ok(None);
            }
            match self.rx.recv() {
                Ok(b) => {
                    self.block = b;
                    self.pos = 0;
                }
                Err(_) => {
                    self.finished = true;
                    return Err(InputError {
                        file: self.file.clone(),
                        line: None,
                        message: "the reading thread stopped".into(),
                    });
                }
            }
        }
    }
}

/// Rows of a numeric CSV read up to the first bad one (for small files: the command
/// streams with [`RowReader`]).
pub struct Table {
    /// `(line, values in the order of the requested columns)`.
    pub rows: Vec<(u64, Vec<f64>)>,
    /// The first problem found, if any; `rows` holds everything before it.
    pub error: Option<InputError>,
}

/// Read all of `path` with [`RowReader`]; a bad header is an `Err`, a bad row ends the
/// table with `error` set.
pub fn read_table(path: &Path, columns: &[&str]) -> Result<Table, InputError> {
    let mut rdr = RowReader::open(path, columns)?;
    let mut table = Table {
        rows: Vec::new(),
        error: None,
    };
    loop {
        match rdr.next_row() {
            Ok(Some(v)) => {
                let v = v.to_vec();
                table.rows.push((rdr.line(), v));
            }
            Ok(None) => break,
            Err(e) => {
                table.error = Some(e);
                break;
            }
        }
    }
    Ok(table)
}

/// Refuse an output path that names the input file (it would be truncated before it is read).
pub fn check_not_input(out: Option<&Path>, input: &Path) -> Result<(), String> {
    let Some(out) = out else { return Ok(()) };
    let same = match (std::fs::canonicalize(out), std::fs::canonicalize(input)) {
        (Ok(a), Ok(b)) => a == b || same_inode(&a, &b),
        _ => false,
    };
    if same {
        return Err(format!(
            "--out {} is the input file {}: refusing to overwrite it",
            out.display(),
            input.display()
        ));
    }
    Ok(())
}

/// Refuse two outputs that name one file (`--stats` and `--out`): the second would
/// overwrite the first. Paths are compared after resolving their folders (the files need
/// not exist yet) and, when both exist, by inode; `/dev/null` may be named twice.
///
/// ```
/// use reckon_cli::csvio::check_distinct_outputs;
/// use std::path::Path;
/// let d = std::env::temp_dir();
/// assert!(check_distinct_outputs(("--stats", &d.join("a.json")), ("--out", &d.join("a.csv"))).is_ok());
/// let e = check_distinct_outputs(("--stats", &d.join("x.csv")), ("--out", &d.join(".").join("x.csv"))).unwrap_err();
/// assert!(e.contains("--stats and --out"), "{e}");
/// ```
pub fn check_distinct_outputs(a: (&str, &Path), b: (&str, &Path)) -> Result<(), String> {
    let resolve = |p: &Path| -> PathBuf {
        if let Ok(c) = std::fs::canonicalize(p) {
            return c;
        }
        let parent = match p.parent() {
            Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
            _ => PathBuf::from("."),
        };
        match (std::fs::canonicalize(&parent), p.file_name()) {
            (Ok(d), Some(name)) => d.join(name),
            _ => p.to_path_buf(),
        }
    };
    let (ra, rb) = (resolve(a.1), resolve(b.1));
    if ra == Path::new("/dev/null") && rb == ra {
        return Ok(());
    }
    if ra == rb || same_inode(&ra, &rb) {
        return Err(format!(
            "{} and {} both name {}: each output needs its own file",
            a.0,
            b.0,
            a.1.display()
        ));
    }
    Ok(())
}

#[cfg(unix)]
fn same_inode(a: &Path, b: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    match (std::fs::metadata(a), std::fs::metadata(b)) {
        (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
        _ => false,
    }
}

#[cfg(not(unix))]
fn same_inode(_: &Path, _: &Path) -> bool {
    false
}

/// Buffered CSV output of numeric rows, to a file or standard output. Rows are collected
/// in blocks of numbers that a background thread formats and writes, so formatting
/// overlaps the caller's work; memory stays constant (a few blocks in flight).
pub struct RowWriter {
    tx: Option<std::sync::mpsc::SyncSender<Chunk>>,
    worker: Option<std::thread::JoinHandle<std::io::Result<()>>>,
    chunk: Chunk,
}

/// Numbers of consecutive rows of one width, or a text line.
enum Chunk {
    Rows { width: usize, values: Vec<f64> },
    Text(String),
}

const ROWS_PER_CHUNK: usize = 4096;

impl RowWriter {
    /// Write to `sink`.
    pub fn new(sink: Box<dyn Write + Send>) -> Self {
        let (tx, rx) = std::sync::mpsc::sync_channel::<Chunk>(4);
        let worker = std::thread::spawn(move || -> std::io::Result<()> {
            let mut sink = sink;
            let mut buf: Vec<u8> = Vec::with_capacity(FLUSH_AT + 1024);
            let mut num = zmij::Buffer::new();
            for chunk in rx {
                match chunk {
                    Chunk::Text(t) => {
                        buf.extend_from_slice(t.as_bytes());
                        buf.push(b'\n');
                    }
                    Chunk::Rows { width, values } => {
                        for row in values.chunks_exact(width) {
                            for (i, &v) in row.iter().enumerate() {
                                if i > 0 {
                                    buf.push(b',');
                                }
                                buf.extend_from_slice(trim_point_zero(num.format(v)).as_bytes());
                            }
                            buf.push(b'\n');
                            if buf.len() >= FLUSH_AT {
                                sink.write_all(&buf)?;
                                buf.clear();
                            }
                        }
                    }
                }
            }
            sink.write_all(&buf)?;
            sink.flush()
        });
        RowWriter {
            tx: Some(tx),
            worker: Some(worker),
            chunk: Chunk::Rows {
                width: 0,
                values: Vec::new(),
            },
        }
    }

    /// A file (created now, so that an unwritable path fails before any work) or stdout.
    pub fn open(path: Option<&Path>) -> Result<Self, String> {
        Ok(match path {
            Some(p) => Self::new(Box::new(
                File::create(p).map_err(|e| format!("cannot write {}: {e}", p.display()))?,
            )),
            None => Self::new(Box::new(std::io::stdout())),
        })
    }

    /// A text line (the header).
    pub fn line(&mut self, text: &str) -> std::io::Result<()> {
        self.send()?;
        self.put(Chunk::Text(text.to_string()))
    }

    /// One row `t,values…`; each number is the shortest text that parses back to the same
    /// `f64` (the digits `{}` prints, with an exponent for very small or large magnitudes:
    /// `1e-7`, `1.5e+20`), by zmij (measured 30 ns a number against ryu's 73).
    pub fn row(&mut self, t: f64, values: &[f64]) -> std::io::Result<()> {
        let width = values.len() + 1;
        match &mut self.chunk {
            Chunk::Rows { width: w, values: v } if *w == width || v.is_empty() => {
                if v.is_empty() {
                    *w = width;
                    v.reserve(width * ROWS_PER_CHUNK);
                }
                v.push(t);
                v.extend_from_slice(values);
                if v.len() >= width * ROWS_PER_CHUNK {
                    self.send()?;
                }
                Ok(())
            }
            _ => {
                self.send()?;
                self.row(t, values)
            }
        }
    }

    /// Hand the rows collected so far to the writing thread.
    fn send(&mut self) -> std::io::Result<()> {
        let chunk = std::mem::replace(
            &mut self.chunk,
            Chunk::Rows {
                width: 0,
                values: Vec::new(),
            },
        );
        match &chunk {
            Chunk::Rows { values, .. } if values.is_empty() => Ok(()),
            _ => self.put(chunk),
        }
    }

    fn put(&mut self, chunk: Chunk) -> std::io::Result<()> {
        let sent = match &self.tx {
            Some(tx) => tx.send(chunk).is_ok(),
            None => false,
        };
        if sent { Ok(()) } else { self.finish() }
    }

    /// Write out everything and wait for the writing thread; its write error, if any.
    fn finish(&mut self) -> std::io::Result<()> {
        self.tx = None;
        match self.worker.take() {
            Some(w) => match w.join() {
                Ok(r) => r,
                Err(_) => Err(std::io::Error::other("the writing thread panicked")),
            },
            // closed after an error that was returned then
            None => Ok(()),
        }
    }

    /// Write out everything written so far and close the output.
    pub fn flush(&mut self) -> std::io::Result<()> {
        self.send()?;
        self.finish()
    }
}

impl Drop for RowWriter {
    fn drop(&mut self) {
        if self.worker.is_some() {
            let _ = self.flush();
        }
    }
}

const FLUSH_AT: usize = 1 << 16;
