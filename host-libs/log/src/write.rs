//! The writer of log format v1. Rows are written whole, one `write_all` each, so a log
//! interrupted between rows (Ctrl-C while recording) is still a valid CSV file.

use std::io::Write;

use crate::FORMAT_V1;

/// Writes a v1 log row by row.
pub struct LogWriter<W: Write> {
    out: W,
    column_count: usize,
    line: String,
    rows: u64,
}

impl LogWriter<std::io::BufWriter<std::fs::File>> {
    /// Creates (or truncates) `path` and writes the metadata and the header.
    pub fn create<S: AsRef<str>>(
        path: impl AsRef<std::path::Path>,
        columns: &[S],
        meta: &[(&str, &str)],
    ) -> std::io::Result<Self> {
        let file = std::fs::File::create(path)?;
        Self::new(std::io::BufWriter::new(file), columns, meta)
    }
}

impl<W: Write> LogWriter<W> {
    /// Writes `# format = pam-log v1`, the metadata lines and the header to `out`.
    pub fn new<S: AsRef<str>>(
        mut out: W,
        columns: &[S],
        meta: &[(&str, &str)],
    ) -> std::io::Result<Self> {
        let mut head = format!("# format = {FORMAT_V1}\n");
        for (key, value) in meta.iter().filter(|(k, _)| *k != "format") {
            let value = value.replace(['\n', '\r'], " ");
            head.push_str(&format!("# {key} = {value}\n"));
        }
        let names: Vec<&str> = columns.iter().map(AsRef::as_ref).collect();
        head.push_str(&names.join(","));
        head.push('\n');
        out.write_all(head.as_bytes())?;
        Ok(Self {
            out,
            column_count: names.len(),
            line: String::new(),
            rows: 0,
        })
    }

    /// Appends one row (values in header order). Values print in Rust's shortest form that
    /// reads back to the same f64.
    pub fn write_row(&mut self, row: &[f64]) -> std::io::Result<()> {
        use std::fmt::Write as _;
        if row.len() != self.column_count {
            return Err(std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                format!("{} values for {} columns", row.len(), self.column_count),
            ));
        }
        self.line.clear();
        for (i, v) in row.iter().enumerate() {
            if i > 0 {
                self.line.push(',');
            }
            let _ = write!(self.line, "{v}");
        }
        self.line.push('\n');
        self.out.write_all(self.line.as_bytes())?;
        self.rows += 1;
        Ok(())
    }

    /// Rows written so far.
    pub fn rows(&self) -> u64 {
        self.rows
    }

    /// Pushes buffered rows to the file.
    pub fn flush(&mut self) -> std::io::Result<()> {
        self.out.flush()
    }

    /// Flushes and returns the inner writer.
    pub fn finish(mut self) -> std::io::Result<W> {
        self.out.flush()?;
        Ok(self.out)
    }
}
