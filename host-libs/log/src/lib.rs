//! Log format v1: the one file format that the firmware's telemetry (through `pamctl record`),
//! the emulator, the digital twin and the model tools share.
//!
//! A log is CSV with a header row and one row per loop sample, SI units in the column names
//! (see `docs/log-format.md`). Optional `# key = value` metadata lines may precede the header.
//! The required columns are [`col::REQUIRED`]; readers ignore columns they do not know, but
//! every column this crate knows ([`col::KNOWN`]) is parsed strictly: a value that is not a
//! finite number is an error with file, line and column.

mod read;
mod write;

use std::fmt;
use std::path::PathBuf;

pub use read::{read_path, read_str};
pub use write::LogWriter;

/// The value of the `format` metadata key written by [`LogWriter`].
pub const FORMAT_V1: &str = "pam-log v1";

/// Column names (the unit is part of the name).
pub mod col {
    /// Time since the start of the log, strictly increasing.
    pub const T_S: &str = "t_s";
    /// Joint angles α1, α2 (thesis §2.2: zero at the neutral pose).
    pub const ALPHA1_RAD: &str = "alpha1_rad";
    pub const ALPHA2_RAD: &str = "alpha2_rad";
    /// Force the robot exerts on whatever holds the handle, user frame.
    pub const FX_N: &str = "fx_n";
    pub const FY_N: &str = "fy_n";
    /// Commanded current of I/P channels 1–4.
    pub const I1_MA: &str = "i1_ma";
    pub const I2_MA: &str = "i2_ma";
    pub const I3_MA: &str = "i3_ma";
    pub const I4_MA: &str = "i4_ma";
    /// Force target in the user frame, when a force target is active.
    pub const FX_REF_N: &str = "fx_ref_n";
    pub const FY_REF_N: &str = "fy_ref_n";
    /// Measured (or simulated) muscle pressure of channels 1–4.
    pub const P1_BAR: &str = "p1_bar";
    pub const P2_BAR: &str = "p2_bar";
    pub const P3_BAR: &str = "p3_bar";
    pub const P4_BAR: &str = "p4_bar";
    /// Commanded pressure of channels 1–4 (after every limit).
    pub const P1_CMD_BAR: &str = "p1_cmd_bar";
    pub const P2_CMD_BAR: &str = "p2_cmd_bar";
    pub const P3_CMD_BAR: &str = "p3_cmd_bar";
    pub const P4_CMD_BAR: &str = "p4_cmd_bar";
    /// Telemetry sequence number (gaps are dropped frames).
    pub const SEQ: &str = "seq";
    /// Controller state: 0 disarmed, 1 armed, 2 faulted.
    pub const STATE: &str = "state";
    /// Latched fault bits (pam-control `Faults`).
    pub const FAULTS: &str = "faults";
    /// What the controller had to limit (telemetry's `limited` byte: the model's `Limited`
    /// bits of both joints, 0x20 a closed-loop force target scaled to the capability, 0x80
    /// the slew limit or a converter's range). Not in [`KNOWN`]: an extra column.
    pub const LIMITED: &str = "limited";

    /// Every log has these, in any order.
    pub const REQUIRED: [&str; 9] = [
        T_S, ALPHA1_RAD, ALPHA2_RAD, FX_N, FY_N, I1_MA, I2_MA, I3_MA, I4_MA,
    ];
    /// The four commanded currents, channel order.
    pub const CURRENTS_MA: [&str; 4] = [I1_MA, I2_MA, I3_MA, I4_MA];
    /// The four measured pressures, channel order.
    pub const PRESSURES_BAR: [&str; 4] = [P1_BAR, P2_BAR, P3_BAR, P4_BAR];
    /// The four commanded pressures, channel order.
    pub const PRESSURES_CMD_BAR: [&str; 4] = [P1_CMD_BAR, P2_CMD_BAR, P3_CMD_BAR, P4_CMD_BAR];
    /// Columns whose values must be finite numbers (all others are ignored when not numbers).
    pub const KNOWN: [&str; 22] = [
        T_S, ALPHA1_RAD, ALPHA2_RAD, FX_N, FY_N, I1_MA, I2_MA, I3_MA, I4_MA, FX_REF_N, FY_REF_N,
        P1_BAR, P2_BAR, P3_BAR, P4_BAR, P1_CMD_BAR, P2_CMD_BAR, P3_CMD_BAR, P4_CMD_BAR, SEQ, STATE,
        FAULTS,
    ];

    /// Whether the reader checks this column strictly.
    pub fn is_known(name: &str) -> bool {
        KNOWN.contains(&name)
    }
}

/// A log in memory: named columns of equal length (column-major), plus metadata.
#[derive(Debug, Clone, PartialEq)]
pub struct Log {
    columns: Vec<String>,
    values: Vec<Vec<f64>>,
    /// `# key = value` lines, in file order.
    pub meta: Vec<(String, String)>,
    /// Where the log was read from, if it was read from a file.
    pub source: Option<PathBuf>,
}

impl Log {
    /// An empty log with these columns.
    ///
    /// # Panics
    /// If a name is repeated (a programming error, not bad input).
    pub fn new<S: AsRef<str>>(columns: &[S]) -> Self {
        let columns: Vec<String> = columns.iter().map(|c| c.as_ref().to_string()).collect();
        for (i, c) in columns.iter().enumerate() {
            assert!(!columns[..i].contains(c), "column {c:?} given twice");
        }
        let values = vec![Vec::new(); columns.len()];
        Self {
            columns,
            values,
            meta: Vec::new(),
            source: None,
        }
    }

    /// Appends one sample; `row` is in the order of [`Log::columns`].
    ///
    /// # Panics
    /// If `row` does not have one value per column (a programming error).
    pub fn push_row(&mut self, row: &[f64]) {
        assert_eq!(
            row.len(),
            self.columns.len(),
            "row length must equal the column count"
        );
        for (column, &v) in self.values.iter_mut().zip(row) {
            column.push(v);
        }
    }

    /// Column names, in file order.
    pub fn columns(&self) -> &[String] {
        &self.columns
    }

    /// The values of a column, if the log has it.
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        self.column_index(name).map(|i| self.values[i].as_slice())
    }

    /// The values of a column, or an error naming the column and the file.
    pub fn require(&self, name: &str) -> Result<&[f64], LogError> {
        self.column(name).ok_or_else(|| LogError {
            file: self.source.clone(),
            line: None,
            column: None,
            field: Some(name.to_string()),
            kind: ErrorKind::MissingColumn,
            message: format!("the log has no column `{name}`"),
        })
    }

    pub fn column_index(&self, name: &str) -> Option<usize> {
        self.columns.iter().position(|c| c == name)
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.values.first().map_or(0, Vec::len)
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// One sample, in column order.
    pub fn row(&self, index: usize) -> Vec<f64> {
        self.values.iter().map(|c| c[index]).collect()
    }

    /// The value of a metadata key (the last one, if repeated).
    pub fn meta(&self, key: &str) -> Option<&str> {
        self.meta
            .iter()
            .rev()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }

    /// Sets (or replaces) a metadata key.
    pub fn set_meta(&mut self, key: &str, value: impl fmt::Display) {
        let value = value.to_string();
        match self.meta.iter_mut().find(|(k, _)| k == key) {
            Some(entry) => entry.1 = value,
            None => self.meta.push((key.to_string(), value)),
        }
    }

    /// Median sampling period of `t_s`, if the log has at least two samples.
    pub fn sample_period_s(&self) -> Option<f64> {
        let t = self.column(col::T_S)?;
        if t.len() < 2 {
            return None;
        }
        let mut dt: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
        dt.sort_by(f64::total_cmp);
        Some(dt[dt.len() / 2])
    }

    /// The samples `range` as a new log (same columns and metadata).
    pub fn slice(&self, range: std::ops::Range<usize>) -> Log {
        Log {
            columns: self.columns.clone(),
            values: self
                .values
                .iter()
                .map(|c| c[range.clone()].to_vec())
                .collect(),
            meta: self.meta.clone(),
            source: self.source.clone(),
        }
    }

    /// Writes the log as CSV (metadata, header, rows).
    pub fn write_to<W: std::io::Write>(&self, out: W) -> std::io::Result<()> {
        let meta: Vec<(&str, &str)> = self
            .meta
            .iter()
            .map(|(k, v)| (k.as_str(), v.as_str()))
            .collect();
        let mut writer = LogWriter::new(out, &self.columns, &meta)?;
        let mut row = vec![0.0; self.columns.len()];
        for i in 0..self.len() {
            for (slot, column) in row.iter_mut().zip(&self.values) {
                *slot = column[i];
            }
            writer.write_row(&row)?;
        }
        writer.finish().map(drop)
    }

    /// Writes the log to a file.
    pub fn write_path(&self, path: impl AsRef<std::path::Path>) -> std::io::Result<()> {
        let file = std::fs::File::create(path)?;
        self.write_to(std::io::BufWriter::new(file))
    }

    /// The log as CSV text.
    pub fn to_csv_string(&self) -> String {
        let mut out = Vec::new();
        self.write_to(&mut out)
            .expect("writing to memory cannot fail");
        String::from_utf8(out).expect("the writer emits UTF-8")
    }
}

/// What is wrong with a log.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ErrorKind {
    Io,
    Empty,
    BadHeader,
    MissingColumn,
    FieldCount,
    NotANumber,
    NotFinite,
    TimeNotIncreasing,
    UnsupportedVersion,
}

/// An error reading a log: where (file, 1-based line and character column, the column's
/// name) and what was expected.
#[derive(Debug, Clone, PartialEq)]
pub struct LogError {
    pub file: Option<PathBuf>,
    pub line: Option<usize>,
    pub column: Option<usize>,
    /// The CSV column concerned, by name.
    pub field: Option<String>,
    pub kind: ErrorKind,
    pub message: String,
}

impl fmt::Display for LogError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.file {
            Some(file) => write!(f, "{}", file.display())?,
            None => write!(f, "<log>")?,
        }
        if let Some(line) = self.line {
            write!(f, ":{line}")?;
            if let Some(column) = self.column {
                write!(f, ":{column}")?;
            }
        }
        write!(f, ": {}", self.message)
    }
}

impl std::error::Error for LogError {}
