//! The strict reader of log format v1.

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

/// One CSV field: its text and its 1-based character column.
struct Field<'a> {
    text: std::borrow::Cow<'a, str>,
    column: usize,
}

fn parse(text: &str, file: Option<PathBuf>) -> Result<Log, LogError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let error =
        |line: usize, column: Option<usize>, field: Option<&str>, kind, message: String| LogError {
            file: file.clone(),
            line: Some(line),
            column,
            field: field.map(str::to_string),
            kind,
            message,
        };

    let mut meta = Vec::new();
    let mut header: Option<(usize, Vec<String>)> = None;
    let mut log: Option<Log> = None;
    let mut strict: Vec<bool> = Vec::new();
    let mut time_index = 0;
    let mut previous_time: Option<f64> = None;
    let mut row = Vec::new();

    for (index, raw_line) in text.split('\n').enumerate() {
        let line_number = index + 1;
        let line = raw_line.strip_suffix('\r').unwrap_or(raw_line);
        if line.trim().is_empty() {
            continue;
        }
        if let Some(comment) = line.trim_start().strip_prefix('#') {
            if header.is_none() {
                if let Some((key, value)) = comment.split_once('=') {
                    let (key, value) = (key.trim(), value.trim());
                    if key == "format" && value != FORMAT_V1 {
                        return Err(error(
                            line_number,
                            Some(1),
                            None,
                            ErrorKind::UnsupportedVersion,
                            format!("unsupported log format `{value}`; expected `{FORMAT_V1}`"),
                        ));
                    }
                    meta.push((key.to_string(), value.to_string()));
                }
            }
            continue;
        }
        let fields = split_fields(line).map_err(|column| {
            error(
                line_number,
                Some(column),
                None,
                ErrorKind::FieldCount,
                "a quoted field is not closed; expected a closing `\"`".to_string(),
            )
        })?;

        let Some(current) = log.as_mut() else {
            // The first non-comment line is the header.
            let names: Vec<String> = fields.iter().map(|f| f.text.trim().to_string()).collect();
            for (i, (name, field)) in names.iter().zip(&fields).enumerate() {
                if name.is_empty() {
                    return Err(error(
                        line_number,
                        Some(field.column),
                        None,
                        ErrorKind::BadHeader,
                        format!("header field {} is empty; expected a column name", i + 1),
                    ));
                }
                if names[..i].contains(name) {
                    return Err(error(
                        line_number,
                        Some(field.column),
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
            if !missing.is_empty() {
                let end = line.chars().count() + 1;
                return Err(error(
                    line_number,
                    Some(end),
                    Some(missing[0]),
                    ErrorKind::MissingColumn,
                    format!(
                        "the header lacks the required column{} {}; a v1 log needs {}",
                        if missing.len() > 1 { "s" } else { "" },
                        quoted_list(&missing),
                        quoted_list(&col::REQUIRED),
                    ),
                ));
            }
            strict = names.iter().map(|n| col::is_known(n)).collect();
            time_index = names.iter().position(|n| n == col::T_S).unwrap_or(0);
            let mut new_log = Log::new(&names);
            new_log.meta = std::mem::take(&mut meta);
            log = Some(new_log);
            header = Some((line_number, names));
            row = vec![0.0; strict.len()];
            continue;
        };

        let names = &header.as_ref().map(|(_, n)| n).expect("set with the log");
        if fields.len() != names.len() {
            let column = fields
                .get(names.len())
                .map_or(line.chars().count() + 1, |f| f.column);
            return Err(error(
                line_number,
                Some(column),
                None,
                ErrorKind::FieldCount,
                format!(
                    "{} fields; expected {} (one per header column)",
                    fields.len(),
                    names.len()
                ),
            ));
        }
        for (i, field) in fields.iter().enumerate() {
            let trimmed = field.text.trim();
            let value = match trimmed.parse::<f64>() {
                Ok(v) if v.is_finite() => v,
                Ok(v) if strict[i] => {
                    return Err(error(
                        line_number,
                        Some(field.column),
                        Some(&names[i]),
                        ErrorKind::NotFinite,
                        format!("`{}` is {v}; expected a finite number", names[i]),
                    ))
                }
                Err(_) if strict[i] => {
                    return Err(error(
                        line_number,
                        Some(field.column),
                        Some(&names[i]),
                        ErrorKind::NotANumber,
                        format!("`{}` holds `{trimmed}`; expected a number", names[i]),
                    ))
                }
                // Columns this reader does not know may hold anything.
                _ => f64::NAN,
            };
            row[i] = value;
        }
        let t = row[time_index];
        if let Some(previous) = previous_time {
            if t <= previous {
                return Err(error(
                    line_number,
                    Some(fields[time_index].column),
                    Some(col::T_S),
                    ErrorKind::TimeNotIncreasing,
                    format!("time goes from {previous} to {t}; expected it to increase strictly"),
                ));
            }
        }
        previous_time = Some(t);
        current.push_row(&row);
    }

    match log {
        Some(log) if !log.is_empty() => Ok(log),
        Some(_) => Err(LogError {
            file,
            line: header.map(|(l, _)| l),
            column: None,
            field: None,
            kind: ErrorKind::Empty,
            message: "the log has a header but no samples".to_string(),
        }),
        None => Err(LogError {
            file,
            line: Some(1),
            column: Some(1),
            field: None,
            kind: ErrorKind::Empty,
            message: format!(
                "the log is empty; expected a header row with {}",
                quoted_list(&col::REQUIRED)
            ),
        }),
    }
}

fn quoted_list(names: &[&str]) -> String {
    names
        .iter()
        .map(|n| format!("`{n}`"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Splits one CSV line (RFC 4180 quoting) into fields with their character columns.
/// An unclosed quote is reported by the column where it opens.
fn split_fields(line: &str) -> Result<Vec<Field<'_>>, usize> {
    let mut fields = Vec::new();
    let mut chars = line.char_indices().peekable();
    let mut column = 1;
    loop {
        let start_column = column;
        let start_byte = chars.peek().map_or(line.len(), |&(b, _)| b);
        if chars.peek().is_some_and(|&(_, c)| c == '"') {
            chars.next();
            column += 1;
            let mut text = String::new();
            let mut closed = false;
            while let Some((_, c)) = chars.next() {
                column += 1;
                if c == '"' {
                    if chars.peek().is_some_and(|&(_, c)| c == '"') {
                        chars.next();
                        column += 1;
                        text.push('"');
                    } else {
                        closed = true;
                        break;
                    }
                } else {
                    text.push(c);
                }
            }
            if !closed {
                return Err(start_column);
            }
            // Anything between the closing quote and the comma is kept out of the value.
            let mut ended_line = true;
            for (_, c) in chars.by_ref() {
                column += 1;
                if c == ',' {
                    ended_line = false;
                    break;
                }
            }
            fields.push(Field {
                text: text.into(),
                column: start_column,
            });
            if ended_line {
                return Ok(fields);
            }
        } else {
            let mut end_byte = line.len();
            let mut ended_line = true;
            for (b, c) in chars.by_ref() {
                if c == ',' {
                    end_byte = b;
                    ended_line = false;
                    column += 1;
                    break;
                }
                column += 1;
            }
            fields.push(Field {
                text: line[start_byte..end_byte].into(),
                column: start_column,
            });
            if ended_line {
                return Ok(fields);
            }
        }
    }
}
