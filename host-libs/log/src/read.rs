//! The strict reader of log format v1.
//!
//! The format's own rules are line rules and are kept here: an optional byte-order mark,
//! `#` comment lines (`# key = value` metadata before the header), blank lines skipped, CRLF
//! or LF, one record per line. The `csv` crate splits the remaining lines into fields
//! (RFC 4180 quoting). Every value is then checked against the header, and every error
//! names the file, the line and the character column.

use std::path::{Path, PathBuf};

use crate::{col, ErrorKind, Log, LogError, FORMAT_V1};

/// Reads a log file. Every error names the file, the line and the column.
pub fn read_path(path: impl AsRef<Path>) -> Result<Log, LogError> {
    let path = path.as_ref();
    let text = std::fs::read_to_string(path).map_err(|e| LogError {
        file: Some(path.to_path_buf()),
        line: None,
        column: None,
        field: None,
        kind: ErrorKind::Io,
        message: format!("cannot read the log: {e}"),
    })?;
    let mut log = parse(&text, Some(path.to_path_buf()))?;
    log.source = Some(path.to_path_buf());
    Ok(log)
}

/// Reads a log from text; `source` names it in errors.
pub fn read_str(text: &str, source: Option<&Path>) -> Result<Log, LogError> {
    let mut log = parse(text, source.map(Path::to_path_buf))?;
    log.source = source.map(Path::to_path_buf);
    Ok(log)
}

/// A line that holds a record (neither blank nor a comment).
#[derive(Clone, Copy)]
struct DataLine<'a> {
    /// 1-based line number in the file.
    number: usize,
    /// The line without its line break.
    text: &'a str,
}

impl DataLine<'_> {
    /// The column just past the end of the line.
    fn end_column(&self) -> usize {
        self.text.chars().count() + 1
    }
}

/// Builds the errors of one file.
struct Errors {
    file: Option<PathBuf>,
}

impl Errors {
    fn at(
        &self,
        line: usize,
        column: Option<usize>,
        field: Option<&str>,
        kind: ErrorKind,
        message: String,
    ) -> LogError {
        LogError {
            file: self.file.clone(),
            line: Some(line),
            column,
            field: field.map(str::to_string),
            kind,
            message,
        }
    }
}

fn parse(text: &str, file: Option<PathBuf>) -> Result<Log, LogError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let errors = Errors { file };
    let (meta, lines) = split_lines(text, &errors)?;
    let Some(&header_line) = lines.first() else {
        return Err(LogError {
            file: errors.file,
            line: Some(1),
            column: Some(1),
            field: None,
            kind: ErrorKind::Empty,
            message: format!(
                "the log is empty; expected a header row with {}",
                quoted_list(&col::REQUIRED)
            ),
        });
    };

    // The data lines, one record each, for the csv crate. Only `\n` ends a record: a lone
    // `\r` inside a line is part of its field, as the line rules above read it.
    let mut body = String::with_capacity(text.len() + 1);
    for line in &lines {
        body.push_str(line.text);
        body.push('\n');
    }
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .terminator(csv::Terminator::Any(b'\n'))
        .from_reader(body.as_bytes());
    let mut record = csv::StringRecord::new();

    next_record(&mut reader, &mut record, header_line, &errors)?;
    let names = header_names(&record, header_line, &errors)?;
    let strict: Vec<bool> = names.iter().map(|n| col::is_known(n)).collect();
    let time_index = names.iter().position(|n| n == col::T_S).unwrap_or(0);
    let mut log = Log::new(&names);
    log.meta = meta;
    let mut row = vec![0.0; names.len()];
    let mut previous_time: Option<f64> = None;

    for &line in &lines[1..] {
        next_record(&mut reader, &mut record, line, &errors)?;
        if record.len() != names.len() {
            let column = field_columns(line.text)
                .ok()
                .and_then(|c| c.get(names.len()).copied())
                .unwrap_or_else(|| line.end_column());
            return Err(errors.at(
                line.number,
                Some(column),
                None,
                ErrorKind::FieldCount,
                format!(
                    "{} fields; expected {} (one per header column)",
                    record.len(),
                    names.len()
                ),
            ));
        }
        for (i, field) in record.iter().enumerate() {
            let trimmed = field.trim();
            row[i] = match trimmed.parse::<f64>() {
                Ok(v) if v.is_finite() => v,
                Ok(v) if strict[i] => {
                    return Err(errors.at(
                        line.number,
                        Some(field_column(line, i)),
                        Some(&names[i]),
                        ErrorKind::NotFinite,
                        format!("`{}` is {v}; expected a finite number", names[i]),
                    ))
                }
                Err(_) if strict[i] => {
                    return Err(errors.at(
                        line.number,
                        Some(field_column(line, i)),
                        Some(&names[i]),
                        ErrorKind::NotANumber,
                        format!("`{}` holds `{trimmed}`; expected a number", names[i]),
                    ))
                }
                // Columns this reader does not know may hold anything.
                _ => f64::NAN,
            };
        }
        let t = row[time_index];
        if let Some(previous) = previous_time {
            if t <= previous {
                return Err(errors.at(
                    line.number,
                    Some(field_column(line, time_index)),
                    Some(col::T_S),
                    ErrorKind::TimeNotIncreasing,
                    format!("time goes from {previous} to {t}; expected it to increase strictly"),
                ));
            }
        }
        previous_time = Some(t);
        log.push_row(&row);
    }

    if log.is_empty() {
        return Err(LogError {
            file: errors.file,
            line: Some(header_line.number),
            column: None,
            field: None,
            kind: ErrorKind::Empty,
            message: "the log has a header but no samples".to_string(),
        });
    }
    Ok(log)
}

/// `# key = value` lines, in file order.
type Meta = Vec<(String, String)>;

/// The line rules: the metadata before the header and the lines that hold records.
fn split_lines<'a>(text: &'a str, errors: &Errors) -> Result<(Meta, Vec<DataLine<'a>>), LogError> {
    let mut meta = Vec::new();
    let mut lines: Vec<DataLine> = Vec::new();
    for (index, raw_line) in text.split('\n').enumerate() {
        let number = index + 1;
        let line = raw_line.strip_suffix('\r').unwrap_or(raw_line);
        if line.trim().is_empty() {
            continue;
        }
        let Some(comment) = line.trim_start().strip_prefix('#') else {
            lines.push(DataLine { number, text: line });
            continue;
        };
        if !lines.is_empty() {
            continue;
        }
        if let Some((key, value)) = comment.split_once('=') {
            let (key, value) = (key.trim(), value.trim());
            if key == "format" && value != FORMAT_V1 {
                return Err(errors.at(
                    number,
                    Some(1),
                    None,
                    ErrorKind::UnsupportedVersion,
                    format!("unsupported log format `{value}`; expected `{FORMAT_V1}`"),
                ));
            }
            meta.push((key.to_string(), value.to_string()));
        }
    }
    Ok((meta, lines))
}

/// Reads the record of `line`. A record that runs past its line holds a quoted field that
/// the line does not close.
fn next_record(
    reader: &mut csv::Reader<&[u8]>,
    record: &mut csv::StringRecord,
    line: DataLine,
    errors: &Errors,
) -> Result<(), LogError> {
    let unclosed = |column: usize| {
        errors.at(
            line.number,
            Some(column),
            None,
            ErrorKind::FieldCount,
            "a quoted field is not closed; expected a closing `\"`".to_string(),
        )
    };
    match reader.read_record(record) {
        Ok(true) if !record.as_slice().contains('\n') => Ok(()),
        Ok(_) => Err(unclosed(field_columns(line.text).err().unwrap_or(1))),
        Err(e) => Err(errors.at(
            line.number,
            Some(1),
            None,
            ErrorKind::FieldCount,
            format!("the line cannot be split into fields: {e}"),
        )),
    }
}

/// The header's column names: present, unique and with every required column.
fn header_names(
    record: &csv::StringRecord,
    line: DataLine,
    errors: &Errors,
) -> Result<Vec<String>, LogError> {
    let names: Vec<String> = record.iter().map(|f| f.trim().to_string()).collect();
    for (i, name) in names.iter().enumerate() {
        if name.is_empty() {
            return Err(errors.at(
                line.number,
                Some(field_column(line, i)),
                None,
                ErrorKind::BadHeader,
                format!("header field {} is empty; expected a column name", i + 1),
            ));
        }
        if names[..i].contains(name) {
            return Err(errors.at(
                line.number,
                Some(field_column(line, i)),
                Some(name),
                ErrorKind::BadHeader,
                format!("column `{name}` appears twice in the header"),
            ));
        }
    }
    let missing: Vec<&str> = col::REQUIRED
        .iter()
        .copied()
        .filter(|c| !names.iter().any(|n| n == c))
        .collect();
    if let Some(first) = missing.first() {
        return Err(errors.at(
            line.number,
            Some(line.end_column()),
            Some(first),
            ErrorKind::MissingColumn,
            format!(
                "the header lacks the required column{} {}; a v1 log needs {}",
                if missing.len() > 1 { "s" } else { "" },
                quoted_list(&missing),
                quoted_list(&col::REQUIRED),
            ),
        ));
    }
    Ok(names)
}

fn quoted_list(names: &[&str]) -> String {
    names
        .iter()
        .map(|n| format!("`{n}`"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The column where field `index` of `line` starts (1 if the line cannot be split).
fn field_column(line: DataLine, index: usize) -> usize {
    field_columns(line.text)
        .ok()
        .and_then(|c| c.get(index).copied())
        .unwrap_or(1)
}

/// The 1-based character column where each field of `line` starts, split as the csv crate
/// splits it: a quote opens a quoted part only as the first character of a field, `""`
/// inside it is a quote, and what follows its closing quote up to the comma belongs to the
/// field. An unclosed quote is reported by the column where it opens. Only errors need
/// columns, so this runs on the error path alone.
fn field_columns(line: &str) -> Result<Vec<usize>, usize> {
    let mut starts = vec![1];
    let mut chars = line.chars().peekable();
    let (mut column, mut quote_column) = (0, 0);
    let (mut in_quotes, mut at_start) = (false, true);
    while let Some(c) = chars.next() {
        column += 1;
        if in_quotes {
            if c == '"' {
                if chars.peek() == Some(&'"') {
                    chars.next();
                    column += 1;
                } else {
                    in_quotes = false;
                }
            }
        } else if c == ',' {
            starts.push(column + 1);
            at_start = true;
            continue;
        } else if c == '"' && at_start {
            in_quotes = true;
            quote_column = column;
        }
        at_start = false;
    }
    if in_quotes {
        Err(quote_column)
    } else {
        Ok(starts)
    }
}
