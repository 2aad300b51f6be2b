use pam_log::{col, read_str, ErrorKind, Log, LogWriter};
use proptest::prelude::*;
use std::path::Path;

const HEADER: &str = "t_s,alpha1_rad,alpha2_rad,fx_n,fy_n,i1_ma,i2_ma,i3_ma,i4_ma";

fn err(text: &str) -> pam_log::LogError {
    read_str(text, Some(Path::new("trial.csv"))).expect_err("the log is malformed")
}

#[test]
fn reads_a_minimal_log_with_metadata_and_extra_columns() {
    let text = format!(
        "# format = pam-log v1\n# experiment = dynamic\n{HEADER},status,p1_bar\n\
         0,0.1,0.2,1,2,4,5,6,7,ok,2.3\n0.001,0.1,0.2,1.5,2,4,5,6,7,\"a, quoted\",2.4\n"
    );
    let log = read_str(&text, None).unwrap();
    assert_eq!(log.len(), 2);
    assert_eq!(log.meta("experiment"), Some("dynamic"));
    assert_eq!(log.column(col::FX_N), Some(&[1.0, 1.5][..]));
    assert_eq!(log.column(col::P1_BAR), Some(&[2.3, 2.4][..]));
    // unknown text columns are kept as NaN, never an error
    assert!(log.column("status").unwrap().iter().all(|v| v.is_nan()));
    assert_eq!(log.sample_period_s(), Some(0.001));
}

#[test]
fn tolerates_crlf_bom_blank_lines_and_column_order() {
    let text = "\u{feff}i4_ma,i3_ma,i2_ma,i1_ma,fy_n,fx_n,alpha2_rad,alpha1_rad,t_s\r\n\r\n\
                7,6,5,4,2,1,0.2,0.1,0\r\n7,6,5,4,2,1,0.2,0.1,0.05\r\n";
    let log = read_str(text, None).unwrap();
    assert_eq!(log.column(col::T_S), Some(&[0.0, 0.05][..]));
    assert_eq!(log.column(col::I1_MA), Some(&[4.0, 4.0][..]));
}

#[test]
fn missing_column_names_it_and_the_header_line() {
    let e = err("# experiment = step\nt_s,alpha1_rad,alpha2_rad,fx_n,i1_ma,i2_ma,i3_ma,i4_ma\n0,0,0,0,4,4,4,4\n");
    assert_eq!(e.kind, ErrorKind::MissingColumn);
    assert_eq!(e.line, Some(2));
    assert_eq!(e.field.as_deref(), Some("fy_n"));
    let shown = e.to_string();
    assert!(shown.starts_with("trial.csv:2:"), "{shown}");
    assert!(shown.contains("`fy_n`"), "{shown}");
}

#[test]
fn text_in_a_number_gives_line_and_column() {
    let e = err(&format!(
        "{HEADER}\n0,0,0,0,0,4,4,4,4\n0.001,0,0,abc,0,4,4,4,4\n"
    ));
    assert_eq!(e.kind, ErrorKind::NotANumber);
    assert_eq!((e.line, e.column), (Some(3), Some(11)));
    assert_eq!(e.field.as_deref(), Some("fx_n"));
    assert_eq!(
        e.to_string(),
        "trial.csv:3:11: `fx_n` holds `abc`; expected a number"
    );
}

#[test]
fn nan_and_infinity_are_rejected_in_known_columns() {
    let e = err(&format!("{HEADER}\n0,0,0,0,NaN,4,4,4,4\n"));
    assert_eq!(
        (e.kind, e.line, e.column),
        (ErrorKind::NotFinite, Some(2), Some(9))
    );
    let e = err(&format!("{HEADER},p2_bar\n0,0,0,0,0,4,4,4,4,inf\n"));
    assert_eq!(
        (e.kind, e.field.as_deref()),
        (ErrorKind::NotFinite, Some("p2_bar"))
    );
}

#[test]
fn time_must_increase_strictly() {
    let e = err(&format!(
        "{HEADER}\n0,0,0,0,0,4,4,4,4\n0.002,0,0,0,0,4,4,4,4\n0.002,0,0,0,0,4,4,4,4\n"
    ));
    assert_eq!(
        (e.kind, e.line, e.column),
        (ErrorKind::TimeNotIncreasing, Some(4), Some(1))
    );
}

#[test]
fn wrong_field_count_and_unclosed_quote() {
    let e = err(&format!("{HEADER}\n0,0,0,0,0,4,4,4\n"));
    assert_eq!((e.kind, e.line), (ErrorKind::FieldCount, Some(2)));
    let e = err(&format!("{HEADER},note\n0,0,0,0,0,4,4,4,4,\"open\n"));
    assert_eq!(
        (e.kind, e.line, e.column),
        (ErrorKind::FieldCount, Some(2), Some(19))
    );
}

#[test]
fn columns_count_the_quotes_of_quoted_fields() {
    // `"a ""b"", c"` is one field of 12 characters; the next field starts at column 14
    let e = err(&format!(
        "note,{HEADER}\n\"a \"\"b\"\", c\",0,0,0,x,0,4,4,4,4\n"
    ));
    assert_eq!(
        (e.kind, e.line, e.column, e.field.as_deref()),
        (ErrorKind::NotANumber, Some(2), Some(20), Some("fx_n"))
    );
    // a quoted field is one value: its comma does not add a field
    let log = read_str(
        &format!("{HEADER},note\n0,0,0,0,0,4,4,4,4,\"x, y\"\n"),
        None,
    )
    .unwrap();
    assert_eq!(log.len(), 1);
    // a quote that opens on one line is not closed by the next
    let e = err(&format!(
        "{HEADER},note\n0,0,0,0,0,4,4,4,4,\"open\n0.1,0,0,0,0,4,4,4,4,close\"\n"
    ));
    assert_eq!(
        (e.kind, e.line, e.column),
        (ErrorKind::FieldCount, Some(2), Some(19))
    );
}

#[test]
fn empty_logs_and_other_versions_are_errors() {
    assert_eq!(err("").kind, ErrorKind::Empty);
    assert_eq!(err(&format!("{HEADER}\n")).kind, ErrorKind::Empty);
    assert_eq!(
        err(&format!("# format = pam-log v2\n{HEADER}\n")).kind,
        ErrorKind::UnsupportedVersion
    );
    assert_eq!(err("t_s,,x\n").kind, ErrorKind::BadHeader);
}

#[test]
fn a_log_cut_between_rows_is_still_valid() {
    let mut out = Vec::new();
    let mut writer = LogWriter::new(&mut out, &col::REQUIRED, &[("experiment", "record")]).unwrap();
    for k in 0..5 {
        writer
            .write_row(&[k as f64 * 0.001, 0.0, 0.0, 0.0, 0.0, 4.0, 4.0, 4.0, 4.0])
            .unwrap();
    }
    assert!(writer.write_row(&[1.0]).is_err(), "a short row is refused");
    writer.finish().unwrap();
    let log = read_str(std::str::from_utf8(&out).unwrap(), None).unwrap();
    assert_eq!(log.len(), 5);
    assert_eq!(log.meta("format"), Some(pam_log::FORMAT_V1));
}

proptest! {
    #[test]
    fn write_then_read_is_exact(
        rows in prop::collection::vec(prop::array::uniform9(-1e6f64..1e6), 1..40),
        dt in 1e-4f64..0.1,
    ) {
        let mut log = Log::new(&col::REQUIRED);
        log.set_meta("point", 3);
        for (k, mut row) in rows.into_iter().enumerate() {
            row[0] = k as f64 * dt;
            log.push_row(&row);
        }
        let back = read_str(&log.to_csv_string(), None).unwrap();
        prop_assert_eq!(back.columns(), log.columns());
        prop_assert_eq!(back.meta("point"), Some("3"));
        for name in col::REQUIRED {
            prop_assert_eq!(back.column(name), log.column(name));
        }
    }

    #[test]
    fn arbitrary_text_never_panics(text in "\\PC{0,200}") {
        let _ = read_str(&text, None);
    }
}
