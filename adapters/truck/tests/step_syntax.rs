//! The STEP exchange structure (ISO 10303-21) is read as the standard says,
//! and malformed or hostile files give errors that say where, never a crash.
//! Each test guards one case ruststep's parser (used before) got wrong,
//! except the truncation tests, which guard that the new one keeps saying
//! "truncated".

use std::path::PathBuf;

use bubblemesh_truck::parse_step;

fn cube() -> String {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
    std::fs::read_to_string(root.join("fixtures/step/cube.step")).unwrap()
}

fn err(text: &str) -> String {
    parse_step(text, "t.step").unwrap_err().to_string()
}

fn reads(text: &str) {
    let s = parse_step(text, "t.step").unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.model.faces.len(), 6);
}

/// 20,000 nested parentheses: an error naming the place, not a stack
/// overflow (which aborted the whole process).
#[test]
fn deeply_nested_lists_give_an_error_not_a_crash() {
    let deep = format!(
        "#1000 = DUMMY({}{});\n",
        "(".repeat(20_000),
        ")".repeat(20_000)
    );
    let text = cube().replacen("#1 = ", &format!("{deep}#1 = "), 1);
    let e = err(&text);
    assert!(e.contains("nested deeper"), "{e}");
    assert!(e.contains("line 10, column"), "{e}");
}

/// `()` is a legal (empty) list: a PRODUCT without contexts.
#[test]
fn empty_list_parameter_parses() {
    let text = cube().replacen(
        "#1 = ",
        "#1000 = PRODUCT('a','b','',());\n#1001 = DUMMY(());\n#1 = ",
        1,
    );
    reads(&text);
}

/// A UTF-8 byte-order mark before ISO-10303-21; (some Windows tools write
/// one).
#[test]
fn utf8_byte_order_mark_is_accepted() {
    reads(&format!("\u{feff}{}", cube()));
}

/// The exchange structure ends at END-ISO-10303-21;: what follows (a
/// signature, junk) is not read.
#[test]
fn bytes_after_the_end_are_ignored() {
    reads(&format!("{}\nSIGNATURE;\nx'y/*\n\0\0garbage", cube()));
    reads(&format!("{}/* trailing comment */\n", cube()));
}

/// Syntax errors say on which line and column.
#[test]
fn syntax_error_reports_line_and_column() {
    let text = cube().replacen(
        "#12 = CARTESIAN_POINT('',(0.,0.,0.));",
        "#12 = CARTESIAN_POINT('',(0.,,0.));",
        1,
    );
    let e = err(&text);
    assert!(e.contains("syntax error at line 24, column 30"), "{e}");
    // a missing ';' is found at the next instance
    let text = cube().replacen(
        "#12 = CARTESIAN_POINT('',(0.,0.,0.));",
        "#12 = CARTESIAN_POINT('',(0.,0.,0.))",
        1,
    );
    let e = err(&text);
    assert!(
        e.contains("syntax error at line 25, column 1") && e.contains("';'"),
        "{e}"
    );
}

/// A coordinate of 1e308 is finite but overflows the geometry: reported on
/// the point, not as an unrelated "closed edge on a LINE".
#[test]
fn huge_coordinate_is_reported_as_out_of_range() {
    let text = cube().replacen(
        "#25 = CARTESIAN_POINT('',(0.,0.,1.));",
        "#25 = CARTESIAN_POINT('',(0.,0.,1.E308));",
        1,
    );
    let e = err(&text);
    assert!(
        e.contains("#25 CARTESIAN_POINT") && e.contains("out of range"),
        "{e}"
    );
    // beyond f64: parsed as infinite, reported as not finite
    let text = cube().replacen(
        "#25 = CARTESIAN_POINT('',(0.,0.,1.));",
        "#25 = CARTESIAN_POINT('',(0.,0.,1.E400));",
        1,
    );
    let e = err(&text);
    assert!(
        e.contains("#25 CARTESIAN_POINT") && e.contains("not finite"),
        "{e}"
    );
}

/// A file cut anywhere says it is truncated, and where.
#[test]
fn truncated_file_says_truncated() {
    let good = cube();
    // the last ENDSEC cut to ENDS
    let endsec = good.rfind("ENDSEC;").unwrap() + 4;
    for cut in [
        good.len() / 3,
        good.len() / 2,
        good.len() - 5,
        good.len() - 30,
        endsec,
    ] {
        let e = err(&good[..cut]);
        assert!(
            e.contains("truncated") && e.contains("line"),
            "cut at {cut}: {e}"
        );
    }
}

/// An unterminated string or comment: truncated, at the line and column
/// where it opens.
#[test]
fn unterminated_string_or_comment_reports_line_and_column() {
    let body = "ISO-10303-21;\nHEADER;\nENDSEC;\nDATA;\n#1 = PRODUCT('a','b,'',());\nENDSEC;\nEND-ISO-10303-21;\n";
    let e = err(body);
    assert!(
        e.contains("string") && e.contains("line 5, column 18"),
        "{e}"
    );
    let body = "ISO-10303-21;\nHEADER;\nENDSEC;\nDATA;\n#1 = PRODUCT('a','b','',());\n  /* note\nENDSEC;\nEND-ISO-10303-21;\n";
    let e = err(body);
    assert!(
        e.contains("comment") && e.contains("line 6, column 3"),
        "{e}"
    );
}

/// '' inside a string, \X2\ encodings and comments between any two tokens
/// are legal.
#[test]
fn quotes_encodings_and_comments_parse() {
    let text = cube().replacen(
        "#1 = ",
        "#1000 = PRODUCT('it''s','\\X2\\00E9\\X0\\t\\X\\E9', /* c */ '' , ( ) ) /* c */ ;\n#1 = ",
        1,
    );
    reads(&text);
}
