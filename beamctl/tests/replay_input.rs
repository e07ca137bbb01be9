//! `beamctl replay`'s reader on bad and arbitrary input: every problem is
//! a one-line error with its line number, missing samples are counted, and
//! nothing panics, whatever the bytes.

use beamctl::io::csv_in::{Columns, CsvError, Reader};
use proptest::prelude::*;
use std::io::Cursor;

fn read(text: &[u8], ts: Option<f64>) -> Result<Vec<(f64, f64)>, CsvError> {
    let columns = Columns::default_for(ts.is_some());
    let mut r = Reader::from_reader(Box::new(Cursor::new(text.to_vec())), &columns, ts)?;
    let mut all = Vec::new();
    let mut batch = Vec::new();
    while r.next_batch(&mut batch, 7)? {
        all.extend_from_slice(&batch);
    }
    Ok(all)
}

fn err(text: &str) -> String {
    read(text.as_bytes(), None)
        .expect_err("should fail")
        .to_string()
}

#[test]
fn good_input_reads_every_sample_and_finds_ts() {
    let mut text = String::from("t,u,y\n");
    for k in 0..100 {
        text.push_str(&format!("{},{},{}\n", k as f64 * 1e-3, 0.5, k as f64));
    }
    let columns = Columns::default_for(false);
    let r = Reader::from_reader(
        Box::new(Cursor::new(text.clone().into_bytes())),
        &columns,
        None,
    )
    .unwrap();
    assert_eq!(r.ts_s(), 1e-3);
    let s = read(text.as_bytes(), None).unwrap();
    assert_eq!(s.len(), 100);
    assert_eq!(s[99], (0.5, 99.0));
    // CRLF, a BOM, spaces, quotes, reordered and extra columns, no final
    // newline.
    let text = "\u{feff}\"y\", extra ,T_S,u\r\n1, x ,0,2\r\n3,,0.5,4\r\n5,z,1.0,6";
    let s = read(text.as_bytes(), None).unwrap();
    assert_eq!(s, vec![(2.0, 1.0), (4.0, 3.0), (6.0, 5.0)]);
}

#[test]
fn numbers_as_rust_writes_and_reads_them() {
    let text = "t,u,y\n0,.5,5.\n1,+1,1E5\n2,-0.0,1e-300\n3,NaN,INF\n4,Infinity,1\n";
    let s = read(text.as_bytes(), None).unwrap();
    assert_eq!(&s[..3], &[(0.5, 5.0), (1.0, 1e5), (-0.0, 1e-300)]);
    assert!(s[3].0.is_nan() && s[3].1.is_nan() && s[4].0.is_nan());
}

#[test]
fn missing_samples_are_nan_not_errors() {
    let text = "t,u,y\n0,1,2\n1,nan,2\n2,1,inf\n3,,2\n4,1,-Infinity\n5,1,2\n";
    let s = read(text.as_bytes(), None).unwrap();
    assert_eq!(s.len(), 6);
    let bad = s
        .iter()
        .filter(|(u, y)| !(u.is_finite() && y.is_finite()))
        .count();
    assert_eq!(bad, 4);
}

#[test]
fn every_problem_names_its_line() {
    assert_eq!(err(""), "the file is empty (no header line)");
    assert_eq!(err("t,u,y\n"), "no data rows after the header");
    assert_eq!(err("t,u,y\n\n\n"), "no data rows after the header");
    assert!(err("t,u,y\n0,1,2\n").contains("only one data row"));
    assert!(err("a,u,y\n0,1,2\n").starts_with("line 1: no column named \"t\""));
    assert_eq!(
        err("t,u,y\n0,1,2\n1,2\n"),
        "line 3: 2 fields, the header has 3"
    );
    assert_eq!(
        err("t,u,y\n0,1,2\n1,2,3,4\n"),
        "line 3: 4 fields, the header has 3"
    );
    assert_eq!(
        err("t,u,y\n0,1,2\n1,abc,3\n"),
        "line 3: field 2 (u) is not a number: \"abc\""
    );
    assert!(err("t,u,y\n0,1,2\n1,1,2\n0.5,1,2\n")
        .starts_with("line 4: the time column does not increase"));
    assert!(err("t,u,y\n0,1,2\n1,1,2\n1,1,2\n")
        .starts_with("line 4: the time column does not increase"));
    // Uniform within 1% passes, beyond fails at the first offending line.
    assert!(read(b"t,u,y\n0,1,2\n1,1,2\n2.009,1,2\n3,1,2\n", None).is_ok());
    assert!(err("t,u,y\n0,1,2\n1,1,2\n2,1,2\n3.5,1,2\n4,1,2\n")
        .starts_with("line 5: non-uniform sampling"));
    // Beyond the Ts prefix (10,000 rows) the same check holds.
    let mut long = String::from("t,u,y\n");
    for k in 0..12_000 {
        let t = if k == 11_000 { 11_000.5 } else { k as f64 };
        long.push_str(&format!("{t},1,2\n"));
    }
    assert!(
        err(&long).starts_with("line 11002: non-uniform sampling"),
        "{}",
        err(&long)
    );
    assert!(err("t,u,y\nnan,1,2\n1,1,2\n").starts_with("line 2: the time column"));
}

#[test]
fn a_given_ts_needs_no_time_column() {
    let s = read(b"u,y\n1,2\n3,4\n", Some(1e-4)).unwrap();
    assert_eq!(s, vec![(1.0, 2.0), (3.0, 4.0)]);
    let e = read(b"u,y\n1,2\n", Some(0.0)).unwrap_err().to_string();
    assert!(e.contains("sample interval"), "{e}");
}

#[test]
fn gzip_input_is_read_transparently() {
    use flate2::write::GzEncoder;
    use std::io::Write;
    let dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR"));
    let path = dir.join("replay-input.csv.gz");
    let mut gz = GzEncoder::new(Vec::new(), flate2::Compression::default());
    gz.write_all(b"t,u,y\n0,1,2\n0.5,3,4\n1,5,6\n").unwrap();
    std::fs::write(&path, gz.finish().unwrap()).unwrap();
    let mut r = Reader::open(&path, &Columns::default_for(false), None).unwrap();
    assert_eq!(r.ts_s(), 0.5);
    let mut b = Vec::new();
    assert!(r.next_batch(&mut b, 10).unwrap());
    assert_eq!(b, vec![(1.0, 2.0), (3.0, 4.0), (5.0, 6.0)]);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    /// Arbitrary bytes: an error or samples, never a panic.
    #[test]
    fn arbitrary_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..600)) {
        let _ = read(&bytes, None);
        let _ = read(&bytes, Some(1e-4));
    }

    /// CSV-like text (a valid header, then rows of random fields from a
    /// small alphabet): an error naming a line, or samples.
    #[test]
    fn csv_like_text_errs_with_a_line_or_reads(
        rows in prop::collection::vec(
            prop::collection::vec(
                prop_oneof![
                    Just("0".to_string()), Just("1e-4".to_string()), Just("nan".to_string()),
                    Just("".to_string()), Just("x".to_string()), Just("-inf".to_string()),
                    (-1e3f64..1e3).prop_map(|v| v.to_string()),
                ],
                0..5,
            ),
            0..30,
        )
    ) {
        let mut text = String::from("t,u,y\n");
        for (k, r) in rows.iter().enumerate() {
            let mut fields = vec![format!("{}", k as f64 * 1e-4)];
            fields.extend(r.iter().cloned());
            text.push_str(&fields.join(","));
            text.push('\n');
        }
        match read(text.as_bytes(), None) {
            Ok(s) => prop_assert!(s.len() <= rows.len()),
            Err(e) => {
                let line_err = e.line.is_some_and(|l| l >= 2 && l as usize <= rows.len() + 1);
                let file_err = e.line.is_none();
                prop_assert!(line_err || file_err, "{e}");
                prop_assert!(!e.to_string().contains('\n'));
            }
        }
    }
}
