//! A reader of the ISO 10303-21 ("STEP Part 21") exchange structure: the
//! clear-text file `ISO-10303-21; HEADER; … ENDSEC; DATA; #1=…; ENDSEC;
//! END-ISO-10303-21;`, into ruststep's AST types (so the entity table and
//! the conversion do not depend on which parser produced them).
//!
//! # Why our own parser
//!
//! The nom parser of ruststep (re-exported by truck-stepio) recursed once per
//! nesting level (20,000 nested parentheses aborted the process on a stack
//! overflow), rejected legal input (empty lists `()`, a UTF-8 byte-order
//! mark, bytes after `END-ISO-10303-21;`, `''` inside strings) and reported
//! syntax errors without a position. This one is a hand-written byte
//! tokenizer under a table-free LL(1) parser:
//!
//! - **no recursion**: nested lists and typed parameters live on an explicit
//!   stack, bounded by [`MAX_NESTING`] (real files nest 3 or 4 levels; the
//!   bound keeps the recursive drop and accessors of the AST shallow) —
//!   deeper input is a syntax error, not a crash;
//! - **positions**: the tokenizer only tracks a byte offset; the line and
//!   column of an error are computed from it when the error is made, so
//!   every [`Part21Error`] says where at no cost to correct files;
//! - **speed**: one pass over the bytes, no backtracking, no allocation per
//!   token except the strings and keywords the AST owns; numbers are parsed
//!   by the standard library from the token's slice.
//!
//! # What is accepted
//!
//! Whitespace (any ASCII control character or space) and comments `/* … */`
//! between any two tokens; a UTF-8 byte-order mark before `ISO-10303-21;`;
//! a HEADER section (parsed and kept), optional ANCHOR / REFERENCE sections
//! (skipped), any number of DATA sections with or without parameters
//! (`DATA;` or `DATA('name',('schema'));`), simple and complex
//! (`#1=(A(…) B(…));`) entity instances, user-defined keywords `!NAME`.
//! Parameters: integers, reals (`1.`, `-2.5E-3`; also `1E5`), strings with
//! `''` and the `\X\`, `\X2\`…`\X0\`, `\X4\`…`\X0\`, `\S\`, `\\` encodings
//! decoded (line breaks inside a string are dropped, as print control),
//! enumerations `.T.`, references `#12` / `@12` / `#NAME`, `$` (not
//! provided, [`Parameter::NotProvided`]), `*` (derived,
//! [`Parameter::Omitted`]), typed parameters `NAME(…)`, lists (empty ones
//! included), binaries `"0F3A"` (kept as [`Parameter::String`] of their hex
//! digits: ruststep's AST has no binary, and no entity we read uses one).
//! Reading stops at `END-ISO-10303-21;`: the standard ends the exchange
//! structure there (anything after it, e.g. a signature section or junk
//! appended by a mail client, is ignored). A file that ends before it is
//! reported as truncated.
//!
//! Invariants of the result: every record's `parameter` is a
//! [`Parameter::List`]; a typed parameter holds exactly one parameter; no
//! parameter is nested deeper than [`MAX_NESTING`] lists / typed parameters.

use truck_stepio::r#in::ruststep::ast::{EntityInstance, Name, Parameter, Record, SubSuperRecord};

/// Deepest nesting of lists and typed parameters accepted. Real files use 4
/// at most (a typed parameter in a list of lists of a B-spline surface).
pub const MAX_NESTING: usize = 128;

/// The exchange structure as read.
#[derive(Debug, Clone, Default)]
pub struct Exchange {
    /// The HEADER section's entities (`FILE_DESCRIPTION`, `FILE_NAME`,
    /// `FILE_SCHEMA`, …).
    pub header: Vec<Record>,
    /// The instances of all DATA sections, in file order.
    pub instances: Vec<EntityInstance>,
    /// How many DATA sections there were.
    pub data_sections: usize,
}

/// Why the text is not a readable exchange structure. Lines and columns are
/// 1-based; columns count characters.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Part21Error {
    /// What kind of failure it is, which also says what the position means.
    pub kind: Part21ErrorKind,
    /// The 1-based line of the error's position.
    pub line: usize,
    /// The 1-based column of the error's position, in characters.
    pub column: usize,
    /// What was wrong at that position (the token expected or found, ...).
    pub message: String,
}

/// The kinds of [`Part21Error`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Part21ErrorKind {
    /// The text does not start with `ISO-10303-21;`.
    NotStep,
    /// The text ends before `END-ISO-10303-21;` (possibly inside a string or
    /// comment, which the message then names with its start).
    Truncated,
    /// Anything else: the position is where the offending token starts.
    Syntax,
}

impl std::fmt::Display for Part21Error {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.kind {
            Part21ErrorKind::NotStep => write!(
                f,
                "not a STEP file (it does not start with ISO-10303-21;): line {}, column {}: {}",
                self.line, self.column, self.message
            ),
            Part21ErrorKind::Truncated => write!(
                f,
                "the file is truncated: {} (line {}, column {})",
                self.message, self.line, self.column
            ),
            Part21ErrorKind::Syntax => write!(
                f,
                "STEP syntax error at line {}, column {}: {}",
                self.line, self.column, self.message
            ),
        }
    }
}

impl std::error::Error for Part21Error {}

/// Parses an exchange structure. See the module documentation for what is
/// accepted.
pub fn parse(text: &str) -> Result<Exchange, Part21Error> {
    let start = if text.starts_with('\u{feff}') { 3 } else { 0 };
    let mut p = Parser {
        lx: Lexer {
            text,
            b: text.as_bytes(),
            i: start,
        },
        stack: Vec::new(),
    };
    p.exchange()
}

// ---------------------------------------------------------------- tokens

#[derive(Debug, Clone, Copy, PartialEq)]
enum Tok<'a> {
    /// A standard (`NAME`) or user-defined (`!NAME`) keyword, or one of the
    /// special ones `ISO-10303-21` / `END-ISO-10303-21`.
    Keyword(&'a str),
    /// `#12`
    EntityName(u64),
    /// `@12`
    ValueName(u64),
    /// `#NAME`
    ConstEntity(&'a str),
    /// `@NAME`
    ConstValue(&'a str),
    Integer(i64),
    Real(f64),
    /// The raw text between the quotes (`''` and `\…\` not yet decoded).
    Str(&'a str),
    /// The hex digits between the double quotes.
    Binary(&'a str),
    /// The name between the dots.
    Enum(&'a str),
    /// `<…>` (ANCHOR / REFERENCE sections).
    Resource,
    Dollar,
    Star,
    LParen,
    RParen,
    Comma,
    Semi,
    Eq,
    Eof,
}

fn describe(t: &Tok) -> String {
    match t {
        Tok::Keyword(k) => format!("the keyword {k}"),
        Tok::EntityName(n) => format!("the instance name #{n}"),
        Tok::ValueName(n) => format!("the value name @{n}"),
        Tok::ConstEntity(n) => format!("the constant #{n}"),
        Tok::ConstValue(n) => format!("the constant @{n}"),
        Tok::Integer(i) => format!("the integer {i}"),
        Tok::Real(x) => format!("the real {x}"),
        Tok::Str(_) => "a string".into(),
        Tok::Binary(_) => "a binary".into(),
        Tok::Enum(e) => format!("the enumeration .{e}."),
        Tok::Resource => "a resource <…>".into(),
        Tok::Dollar => "'$'".into(),
        Tok::Star => "'*'".into(),
        Tok::LParen => "'('".into(),
        Tok::RParen => "')'".into(),
        Tok::Comma => "','".into(),
        Tok::Semi => "';'".into(),
        Tok::Eq => "'='".into(),
        Tok::Eof => "the end of the file".into(),
    }
}

fn is_ident(c: u8) -> bool {
    c.is_ascii_alphanumeric() || c == b'_'
}

/// The tokenizer: a byte offset into the text. Whitespace and comments are
/// skipped before each token.
struct Lexer<'a> {
    text: &'a str,
    b: &'a [u8],
    i: usize,
}

impl<'a> Lexer<'a> {
    /// Line and column (1-based, in characters) of byte offset `pos`.
    fn line_col(&self, pos: usize) -> (usize, usize) {
        let pos = pos.min(self.b.len());
        let before = &self.b[..pos];
        let line = 1 + before.iter().filter(|&&c| c == b'\n').count();
        let line_start = before
            .iter()
            .rposition(|&c| c == b'\n')
            .map_or(0, |k| k + 1);
        // tokens start and end on ASCII bytes, so this slice is on
        // character boundaries; bytes are counted should it ever not be
        let column = 1 + self
            .text
            .get(line_start..pos)
            .map_or(pos - line_start, |s| s.chars().count());
        (line, column)
    }

    fn err(&self, kind: Part21ErrorKind, pos: usize, message: impl Into<String>) -> Part21Error {
        let (line, column) = self.line_col(pos);
        Part21Error {
            kind,
            line,
            column,
            message: message.into(),
        }
    }

    fn syntax(&self, pos: usize, message: impl Into<String>) -> Part21Error {
        self.err(Part21ErrorKind::Syntax, pos, message)
    }

    /// The error for a token starting at `pos` that is malformed at byte
    /// `k`: the file is truncated if it ends there.
    fn malformed(&self, pos: usize, k: usize, message: &str) -> Part21Error {
        if k >= self.b.len() {
            self.err(
                Part21ErrorKind::Truncated,
                pos,
                format!("it ends inside a token ({message})"),
            )
        } else {
            self.syntax(pos, message)
        }
    }

    /// Skips whitespace and comments.
    fn skip(&mut self) -> Result<(), Part21Error> {
        let b = self.b;
        loop {
            while self.i < b.len() && b[self.i] <= b' ' {
                self.i += 1;
            }
            if self.i + 1 < b.len() && b[self.i] == b'/' && b[self.i + 1] == b'*' {
                let start = self.i;
                match find2(&b[start + 2..], b'*', b'/') {
                    Some(k) => self.i = start + 2 + k + 2,
                    None => {
                        return Err(self.err(
                            Part21ErrorKind::Truncated,
                            start,
                            "the comment opened here is never closed (no */)",
                        ))
                    }
                }
            } else {
                return Ok(());
            }
        }
    }

    /// The next token and the byte offset where it starts.
    fn next(&mut self) -> Result<(Tok<'a>, usize), Part21Error> {
        self.skip()?;
        let b = self.b;
        let s = self.i;
        let Some(&c) = b.get(s) else {
            return Ok((Tok::Eof, s));
        };
        let tok = match c {
            b'(' => {
                self.i += 1;
                Tok::LParen
            }
            b')' => {
                self.i += 1;
                Tok::RParen
            }
            b',' => {
                self.i += 1;
                Tok::Comma
            }
            b';' => {
                self.i += 1;
                Tok::Semi
            }
            b'=' => {
                self.i += 1;
                Tok::Eq
            }
            b'$' => {
                self.i += 1;
                Tok::Dollar
            }
            b'*' => {
                self.i += 1;
                Tok::Star
            }
            b'\'' => self.string(s)?,
            b'"' => {
                let body = s + 1;
                let mut k = body;
                while k < b.len() && b[k].is_ascii_hexdigit() {
                    k += 1;
                }
                match b.get(k) {
                    Some(b'"') => {
                        self.i = k + 1;
                        Tok::Binary(&self.text[body..k])
                    }
                    None => {
                        return Err(self.err(
                            Part21ErrorKind::Truncated,
                            s,
                            "the binary opened here is never closed",
                        ))
                    }
                    Some(_) => return Err(self.syntax(k, "a binary may only hold hex digits")),
                }
            }
            b'.' => {
                let body = s + 1;
                let mut k = body;
                while k < b.len() && is_ident(b[k]) {
                    k += 1;
                }
                if k == body || b.get(k) != Some(&b'.') {
                    return Err(self.malformed(s, k, "expected an enumeration .NAME."));
                }
                self.i = k + 1;
                Tok::Enum(&self.text[body..k])
            }
            b'#' | b'@' => {
                let body = s + 1;
                let mut k = body;
                if b.get(k).is_some_and(|c| c.is_ascii_digit()) {
                    let mut n: u64 = 0;
                    while k < b.len() && b[k].is_ascii_digit() {
                        n = n
                            .checked_mul(10)
                            .and_then(|n| n.checked_add(u64::from(b[k] - b'0')))
                            .ok_or_else(|| self.syntax(s, "instance name out of range"))?;
                        k += 1;
                    }
                    self.i = k;
                    if c == b'#' {
                        Tok::EntityName(n)
                    } else {
                        Tok::ValueName(n)
                    }
                } else if b
                    .get(k)
                    .is_some_and(|c| c.is_ascii_alphabetic() || *c == b'_')
                {
                    while k < b.len() && is_ident(b[k]) {
                        k += 1;
                    }
                    self.i = k;
                    let name = &self.text[body..k];
                    if c == b'#' {
                        Tok::ConstEntity(name)
                    } else {
                        Tok::ConstValue(name)
                    }
                } else {
                    return Err(self.malformed(s, k, "expected digits or a name after '#' or '@'"));
                }
            }
            b'<' => match b[s..].iter().position(|&c| c == b'>') {
                Some(k) => {
                    self.i = s + k + 1;
                    Tok::Resource
                }
                None => {
                    return Err(self.err(
                        Part21ErrorKind::Truncated,
                        s,
                        "the resource <… opened here is never closed",
                    ))
                }
            },
            b'+' | b'-' | b'0'..=b'9' => self.number(s)?,
            b'!' | b'A'..=b'Z' | b'a'..=b'z' | b'_' => {
                let rest = &b[s..];
                let special = [&b"END-ISO-10303-21"[..], &b"ISO-10303-21"[..]]
                    .into_iter()
                    .find(|k| {
                        rest.starts_with(k) && !rest.get(k.len()).is_some_and(|&c| is_ident(c))
                    });
                let end = match special {
                    Some(k) => s + k.len(),
                    // a file cut inside END-ISO-10303-21
                    None if rest.len() < 16 && b"END-ISO-10303-21".starts_with(rest) => {
                        return Err(self.err(
                            Part21ErrorKind::Truncated,
                            s,
                            "it ends inside END-ISO-10303-21",
                        ))
                    }
                    None => {
                        let mut k = s + 1;
                        while k < b.len() && is_ident(b[k]) {
                            k += 1;
                        }
                        if c == b'!' && k == s + 1 {
                            return Err(self.malformed(s, k, "expected a keyword after '!'"));
                        }
                        k
                    }
                };
                self.i = end;
                Tok::Keyword(&self.text[s..end])
            }
            _ => {
                let ch = self.text[s..].chars().next().unwrap_or('?');
                return Err(self.syntax(s, format!("unexpected character {ch:?}")));
            }
        };
        Ok((tok, s))
    }

    /// A string token starting at the quote at `s`.
    fn string(&mut self, s: usize) -> Result<Tok<'a>, Part21Error> {
        let b = self.b;
        let mut k = s + 1;
        loop {
            match b[k..].iter().position(|&c| c == b'\'') {
                None => {
                    return Err(self.err(
                        Part21ErrorKind::Truncated,
                        s,
                        "the string opened here is never closed",
                    ))
                }
                Some(q) => {
                    k += q;
                    if b.get(k + 1) == Some(&b'\'') {
                        k += 2; // '' is a quote inside the string
                    } else {
                        self.i = k + 1;
                        return Ok(Tok::Str(&self.text[s + 1..k]));
                    }
                }
            }
        }
    }

    /// An integer or real starting at `s` (a sign or a digit).
    fn number(&mut self, s: usize) -> Result<Tok<'a>, Part21Error> {
        let b = self.b;
        let mut k = s;
        if b[k] == b'+' || b[k] == b'-' {
            k += 1;
        }
        let digits = k;
        while k < b.len() && b[k].is_ascii_digit() {
            k += 1;
        }
        if k == digits {
            return Err(self.malformed(s, k, "expected a digit after the sign"));
        }
        let mut real = false;
        if b.get(k) == Some(&b'.') {
            real = true;
            k += 1;
            while k < b.len() && b[k].is_ascii_digit() {
                k += 1;
            }
        }
        if matches!(b.get(k), Some(b'E' | b'e')) {
            real = true;
            k += 1;
            if matches!(b.get(k), Some(b'+' | b'-')) {
                k += 1;
            }
            let e = k;
            while k < b.len() && b[k].is_ascii_digit() {
                k += 1;
            }
            if k == e {
                return Err(self.malformed(s, k, "expected the exponent's digits after E"));
            }
        }
        let slice = &self.text[s..k];
        self.i = k;
        if real {
            // a decimal number too large for f64 parses to ±inf: kept, the
            // conversion reports it as not finite with the entity's name
            slice
                .parse::<f64>()
                .map(Tok::Real)
                .map_err(|_| self.syntax(s, format!("malformed real {slice}")))
        } else {
            slice
                .parse::<i64>()
                .map(Tok::Integer)
                .map_err(|_| self.syntax(s, format!("integer {slice} out of range")))
        }
    }
}

/// Offset of the first `x y` pair in `h`.
fn find2(h: &[u8], x: u8, y: u8) -> Option<usize> {
    let mut from = 0;
    while let Some(k) = h[from..].iter().position(|&c| c == x) {
        let k = from + k;
        if h.get(k + 1) == Some(&y) {
            return Some(k);
        }
        from = k + 1;
    }
    None
}

/// The value of a string token's raw text: `''` → `'`; line breaks
/// dropped; `\\`, `\S\c`, `\X\hh`, `\X2\…\X0\`, `\X4\…\X0\` decoded;
/// `\P?\`, `\N\`, `\F\` dropped. A malformed directive is kept as written.
fn decode_string(raw: &str) -> String {
    if !raw
        .bytes()
        .any(|c| c == b'\'' || c == b'\\' || c == b'\n' || c == b'\r')
    {
        return raw.to_string();
    }
    let mut out = String::with_capacity(raw.len());
    let mut rest = raw;
    while let Some(c) = rest.chars().next() {
        match c {
            '\'' => {
                // the tokenizer only lets '' through
                out.push('\'');
                rest = rest.get(2..).unwrap_or("");
            }
            '\n' | '\r' => rest = &rest[1..],
            '\\' => {
                let (s, n) = directive(rest);
                out.push_str(&s);
                rest = &rest[n..];
            }
            _ => {
                out.push(c);
                rest = &rest[c.len_utf8()..];
            }
        }
    }
    out
}

/// A `\…` directive at the start of `r`: its text and its length in bytes.
fn directive(r: &str) -> (String, usize) {
    let b = r.as_bytes();
    let hex = |s: &[u8]| -> Option<u32> {
        if s.is_empty() || !s.iter().all(|c| c.is_ascii_hexdigit()) {
            return None;
        }
        u32::from_str_radix(std::str::from_utf8(s).ok()?, 16).ok()
    };
    let literal = ("\\".to_string(), 1);
    if b.starts_with(b"\\\\") {
        return ("\\".into(), 2);
    }
    if b.starts_with(b"\\S\\") && b.len() >= 4 && b[3].is_ascii() {
        let ch = char::from_u32(u32::from(b[3]) + 128).unwrap_or('?');
        return (ch.to_string(), 4);
    }
    if b.starts_with(b"\\X\\") && b.len() >= 5 {
        if let Some(v) = hex(&b[3..5]) {
            return (char::from_u32(v).unwrap_or('?').to_string(), 5);
        }
        return literal;
    }
    for (tag, width) in [(&b"\\X2\\"[..], 4usize), (&b"\\X4\\"[..], 8)] {
        if b.starts_with(tag) {
            let Some(end) = r[4..].find("\\X0\\") else {
                return literal;
            };
            let body = &b[4..4 + end];
            if body.len() % width != 0 {
                return literal;
            }
            let units: Option<Vec<u32>> = body.chunks(width).map(hex).collect();
            let Some(units) = units else {
                return literal;
            };
            let s = if width == 4 {
                let u16s: Vec<u16> = units.iter().map(|&u| u as u16).collect();
                String::from_utf16_lossy(&u16s)
            } else {
                units
                    .iter()
                    .map(|&u| char::from_u32(u).unwrap_or('\u{fffd}'))
                    .collect()
            };
            return (s, 4 + end + 4);
        }
    }
    if b.starts_with(b"\\N\\") || b.starts_with(b"\\F\\") {
        return (String::new(), 3);
    }
    if b.len() >= 4 && b[1] == b'P' && b[3] == b'\\' && b[2].is_ascii_uppercase() {
        return (String::new(), 4);
    }
    literal
}

// ---------------------------------------------------------------- parser

/// An open list or typed parameter while its parameters are read.
enum Frame {
    List(Vec<Parameter>),
    /// The keyword and, once read, its one parameter.
    Typed(String, Option<Parameter>),
}

struct Parser<'a> {
    lx: Lexer<'a>,
    /// Reused between parameter lists.
    stack: Vec<Frame>,
}

impl<'a> Parser<'a> {
    fn expect(&mut self, want: Tok, what: &str) -> Result<(), Part21Error> {
        let (t, pos) = self.lx.next()?;
        if t == want {
            Ok(())
        } else {
            Err(self.unexpected(&t, pos, what))
        }
    }

    /// The error for token `t` at `pos` where `what` was expected.
    fn unexpected(&self, t: &Tok, pos: usize, what: &str) -> Part21Error {
        // a token the file ends with (a keyword cut short) is a truncation too
        let rest = &self.lx.b[self.lx.i.min(self.lx.b.len())..];
        if *t == Tok::Eof || rest.iter().all(|&c| c <= b' ') {
            self.lx.err(
                Part21ErrorKind::Truncated,
                pos,
                format!("it ends where {what} was expected, before END-ISO-10303-21;"),
            )
        } else {
            self.lx
                .syntax(pos, format!("expected {what}, found {}", describe(t)))
        }
    }

    fn exchange(&mut self) -> Result<Exchange, Part21Error> {
        // whatever the first token is wrong with (binary data, another
        // format), the file is not STEP
        let (t, pos) = self.lx.next().map_err(|e| Part21Error {
            kind: Part21ErrorKind::NotStep,
            ..e
        })?;
        if t != Tok::Keyword("ISO-10303-21") {
            return Err(self.lx.err(
                Part21ErrorKind::NotStep,
                pos,
                format!("found {}", describe(&t)),
            ));
        }
        self.expect(Tok::Semi, "';' after ISO-10303-21")?;
        let mut ex = Exchange::default();
        loop {
            let (t, pos) = self.lx.next()?;
            match t {
                Tok::Keyword("HEADER") => {
                    self.expect(Tok::Semi, "';' after HEADER")?;
                    self.header(&mut ex)?;
                }
                Tok::Keyword("DATA") => {
                    let (t, pos) = self.lx.next()?;
                    match t {
                        Tok::Semi => {}
                        Tok::LParen => {
                            // DATA('name', ('schema')): read and dropped
                            self.params()?;
                            self.expect(Tok::Semi, "';' after DATA(…)")?;
                        }
                        _ => return Err(self.unexpected(&t, pos, "';' after DATA")),
                    }
                    ex.data_sections += 1;
                    self.data(&mut ex)?;
                }
                Tok::Keyword("ANCHOR") | Tok::Keyword("REFERENCE") => {
                    self.expect(Tok::Semi, "';' after the section's keyword")?;
                    loop {
                        let (t, pos) = self.lx.next()?;
                        match t {
                            Tok::Keyword("ENDSEC") => break,
                            Tok::Eof => return Err(self.unexpected(&t, pos, "ENDSEC")),
                            _ => {}
                        }
                    }
                    self.expect(Tok::Semi, "';' after ENDSEC")?;
                }
                Tok::Keyword("END-ISO-10303-21") => {
                    // the exchange structure ends here; what follows (a
                    // signature section, trailing junk) is not read
                    let (t, pos) = self.lx.next_semi_or_eof()?;
                    if t != Tok::Semi && t != Tok::Eof {
                        return Err(self.unexpected(&t, pos, "';' after END-ISO-10303-21"));
                    }
                    return Ok(ex);
                }
                _ => return Err(self.unexpected(&t, pos, "HEADER;, DATA; or END-ISO-10303-21;")),
            }
        }
    }

    fn header(&mut self, ex: &mut Exchange) -> Result<(), Part21Error> {
        loop {
            let (t, pos) = self.lx.next()?;
            match t {
                Tok::Keyword("ENDSEC") => return self.expect(Tok::Semi, "';' after ENDSEC"),
                Tok::Keyword(k) => {
                    let record = self.record(k)?;
                    self.expect(Tok::Semi, "';' after the header entity")?;
                    ex.header.push(record);
                }
                _ => return Err(self.unexpected(&t, pos, "a header entity or ENDSEC")),
            }
        }
    }

    fn data(&mut self, ex: &mut Exchange) -> Result<(), Part21Error> {
        loop {
            let (t, pos) = self.lx.next()?;
            let id = match t {
                Tok::EntityName(id) => id,
                Tok::Keyword("ENDSEC") => return self.expect(Tok::Semi, "';' after ENDSEC"),
                _ => return Err(self.unexpected(&t, pos, "an entity instance #id = …; or ENDSEC")),
            };
            self.expect(Tok::Eq, "'=' after the instance name")?;
            let (t, pos) = self.lx.next()?;
            let inst = match t {
                Tok::Keyword(k) => EntityInstance::Simple {
                    id,
                    record: self.record(k)?,
                },
                Tok::LParen => {
                    let mut records = Vec::new();
                    loop {
                        let (t, pos) = self.lx.next()?;
                        match t {
                            Tok::Keyword(k) => records.push(self.record(k)?),
                            Tok::RParen if !records.is_empty() => break,
                            _ => {
                                return Err(self.unexpected(
                                    &t,
                                    pos,
                                    "a record NAME(…) of the complex instance",
                                ))
                            }
                        }
                    }
                    EntityInstance::Complex {
                        id,
                        subsuper: SubSuperRecord(records),
                    }
                }
                _ => {
                    return Err(self.unexpected(
                        &t,
                        pos,
                        "an entity NAME(…) or a complex instance (A(…) B(…))",
                    ))
                }
            };
            self.expect(Tok::Semi, "';' after the entity instance")?;
            ex.instances.push(inst);
        }
    }

    /// `NAME(…)` after its keyword `k`.
    fn record(&mut self, k: &str) -> Result<Record, Part21Error> {
        let (t, pos) = self.lx.next()?;
        if t != Tok::LParen {
            return Err(self.unexpected(&t, pos, &format!("'(' after {k}")));
        }
        Ok(Record {
            name: k.to_string(),
            parameter: self.params()?,
        })
    }

    /// The parameters of a list whose '(' at `open` was just read, up to and
    /// including its ')': a [`Parameter::List`]. Iterative: nested lists and
    /// typed parameters are frames of `self.stack`.
    fn params(&mut self) -> Result<Parameter, Part21Error> {
        let mut stack = std::mem::take(&mut self.stack);
        stack.clear();
        stack.push(Frame::List(Vec::new()));
        // what the next token may be: a value, or (after a value) ',' / ')';
        // `first`: just after '(' where ')' is also fine
        let mut after_value = false;
        let mut first = true;
        let result = loop {
            let (t, pos) = self.lx.next()?;
            if after_value || (first && t == Tok::RParen) {
                let in_list = matches!(stack.last(), Some(Frame::List(_)));
                match t {
                    Tok::Comma if in_list && after_value => {
                        after_value = false;
                        first = false;
                        continue;
                    }
                    Tok::RParen => {
                        let frame = stack.pop().expect("a frame is open");
                        let v = match frame {
                            Frame::List(v) => Parameter::List(v),
                            Frame::Typed(keyword, Some(p)) => Parameter::Typed {
                                keyword,
                                parameter: Box::new(p),
                            },
                            Frame::Typed(keyword, None) => {
                                return Err(self.lx.syntax(
                                    pos,
                                    format!("the typed parameter {keyword}(…) needs a value"),
                                ));
                            }
                        };
                        if stack.is_empty() {
                            break v;
                        }
                        Self::complete(&mut stack, v);
                        after_value = true;
                        first = false;
                        continue;
                    }
                    _ => {
                        let what = if in_list {
                            "',' or ')' in the list"
                        } else {
                            "')' closing the typed parameter"
                        };
                        return Err(self.unexpected(&t, pos, what));
                    }
                }
            }
            first = false;
            let v = match t {
                Tok::Integer(i) => Parameter::Integer(i),
                Tok::Real(x) => Parameter::Real(x),
                Tok::EntityName(n) => Parameter::Ref(Name::Entity(n)),
                Tok::ValueName(n) => Parameter::Ref(Name::Value(n)),
                Tok::ConstEntity(n) => Parameter::Ref(Name::ConstantEntity(n.to_string())),
                Tok::ConstValue(n) => Parameter::Ref(Name::ConstantValue(n.to_string())),
                Tok::Str(raw) => Parameter::String(decode_string(raw)),
                Tok::Binary(h) => Parameter::String(h.to_string()),
                Tok::Enum(e) => Parameter::Enumeration(e.to_string()),
                Tok::Dollar => Parameter::NotProvided,
                Tok::Star => Parameter::Omitted,
                Tok::LParen | Tok::Keyword(_) => {
                    if stack.len() >= MAX_NESTING {
                        return Err(self.lx.syntax(
                            pos,
                            format!(
                                "lists nested deeper than {MAX_NESTING} levels (real files use 4 at most)"
                            ),
                        ));
                    }
                    if let Tok::Keyword(k) = t {
                        self.expect(Tok::LParen, &format!("'(' after the type name {k}"))?;
                        // ')' right away is reported as a missing value
                        stack.push(Frame::Typed(k.to_string(), None));
                    } else {
                        stack.push(Frame::List(Vec::new()));
                    }
                    first = true;
                    after_value = false;
                    continue;
                }
                _ => return Err(self.unexpected(&t, pos, "a parameter")),
            };
            Self::complete(&mut stack, v);
            after_value = true;
        };
        self.stack = stack;
        Ok(result)
    }

    /// Hands a finished value to the innermost open frame.
    fn complete(stack: &mut [Frame], v: Parameter) {
        match stack.last_mut() {
            Some(Frame::List(items)) => items.push(v),
            Some(Frame::Typed(_, slot)) => *slot = Some(v),
            None => unreachable!("complete() is called with a frame open"),
        }
    }
}

impl<'a> Lexer<'a> {
    /// After `END-ISO-10303-21`: its ';' (or the end of the text), without
    /// tokenizing further (what follows need not be valid).
    fn next_semi_or_eof(&mut self) -> Result<(Tok<'a>, usize), Part21Error> {
        // whitespace only: a comment opened after the end must not matter
        while self.i < self.b.len() && self.b[self.i] <= b' ' {
            self.i += 1;
        }
        match self.b.get(self.i) {
            None => Ok((Tok::Eof, self.i)),
            Some(b';') => Ok((Tok::Semi, self.i)),
            Some(_) => self.next(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn data(body: &str) -> Result<Exchange, Part21Error> {
        parse(&format!(
            "ISO-10303-21;\nHEADER;\nFILE_NAME('a');\nENDSEC;\nDATA;\n{body}\nENDSEC;\nEND-ISO-10303-21;\n"
        ))
    }

    fn params_of(body: &str) -> Vec<Parameter> {
        let ex = data(body).unwrap_or_else(|e| panic!("{e}"));
        match &ex.instances[0] {
            EntityInstance::Simple { record, .. } => match &record.parameter {
                Parameter::List(v) => v.clone(),
                p => panic!("{p:?}"),
            },
            i => panic!("{i:?}"),
        }
    }

    #[test]
    fn every_kind_of_parameter() {
        let p = params_of(
            "#1=A(1,-2.5E-3,'it''s',.T.,#2,@3,$,*,(),(1,(2,())),B((1)),\"0F\",+3.,1E2,#C);",
        );
        assert_eq!(
            p,
            vec![
                Parameter::Integer(1),
                Parameter::Real(-2.5e-3),
                Parameter::String("it's".into()),
                Parameter::Enumeration("T".into()),
                Parameter::Ref(Name::Entity(2)),
                Parameter::Ref(Name::Value(3)),
                Parameter::NotProvided,
                Parameter::Omitted,
                Parameter::List(vec![]),
                Parameter::List(vec![
                    Parameter::Integer(1),
                    Parameter::List(vec![Parameter::Integer(2), Parameter::List(vec![])])
                ]),
                Parameter::Typed {
                    keyword: "B".into(),
                    parameter: Box::new(Parameter::List(vec![Parameter::Integer(1)]))
                },
                Parameter::String("0F".into()),
                Parameter::Real(3.0),
                Parameter::Real(100.0),
                Parameter::Ref(Name::ConstantEntity("C".into())),
            ]
        );
    }

    #[test]
    fn empty_record_and_complex_instance() {
        let ex = data("#1=A();\n#2=(B(1)C((#1))D());").unwrap();
        assert_eq!(ex.instances.len(), 2);
        match &ex.instances[1] {
            EntityInstance::Complex { id, subsuper } => {
                assert_eq!(*id, 2);
                let names: Vec<&str> = subsuper.0.iter().map(|r| r.name.as_str()).collect();
                assert_eq!(names, ["B", "C", "D"]);
            }
            i => panic!("{i:?}"),
        }
    }

    #[test]
    fn string_encodings() {
        assert_eq!(decode_string("abc"), "abc");
        assert_eq!(decode_string("a''b"), "a'b");
        assert_eq!(decode_string("\\X\\E9t\\X\\E9"), "été");
        assert_eq!(decode_string("\\X2\\00E9006C\\X0\\ve"), "élve");
        assert_eq!(decode_string("\\X4\\0001F600\\X0\\"), "\u{1f600}");
        assert_eq!(decode_string("a\\\\b"), "a\\b");
        assert_eq!(decode_string("\\S\\i"), "\u{e9}");
        assert_eq!(decode_string("\\PA\\x"), "x");
        assert_eq!(decode_string("line\r\nbreak"), "linebreak");
        // malformed directives are kept
        assert_eq!(decode_string("\\X2\\00E"), "\\X2\\00E");
        assert_eq!(decode_string("C:\\dir"), "C:\\dir");
    }

    #[test]
    fn comments_anywhere_and_several_data_sections() {
        let text = "/*c*/ISO-10303-21/*c*/;HEADER;ENDSEC;DATA;#1/**/=/**/A(/**/1/**/,/**/2/**/)/**/;ENDSEC;\nDATA('x',('y'));#2=B();ENDSEC;END-ISO-10303-21;";
        let ex = parse(text).unwrap();
        assert_eq!(ex.instances.len(), 2);
        assert_eq!(ex.data_sections, 2);
    }

    #[test]
    fn errors_have_positions() {
        let e = data("#1=A(1,,2);").unwrap_err();
        assert_eq!(
            (e.kind, e.line, e.column),
            (Part21ErrorKind::Syntax, 6, 8),
            "{e}"
        );
        let e = data("#1=A(1 2);").unwrap_err();
        assert_eq!((e.line, e.column), (6, 8), "{e}");
        let e = data("#1=A(B());").unwrap_err();
        assert!(e.message.contains("needs a value"), "{e}");
        let e = data("#1=A((1,2);").unwrap_err();
        assert_eq!((e.line, e.column), (6, 11), "{e}");
        let e = parse("ISO-10303-21;\nDATA;\n#1=A('abc);\nENDSEC;\nEND-ISO-10303-21;").unwrap_err();
        assert_eq!(
            (e.kind, e.line, e.column),
            (Part21ErrorKind::Truncated, 3, 6),
            "{e}"
        );
        let e = parse("ISO-10303-21;\nDATA;\n  /* abc\nENDSEC;").unwrap_err();
        assert_eq!(
            (e.kind, e.line, e.column),
            (Part21ErrorKind::Truncated, 3, 3),
            "{e}"
        );
        let e = parse("ISO-10303-21;\nDATA;\n#1=A(1);").unwrap_err();
        assert_eq!(e.kind, Part21ErrorKind::Truncated, "{e}");
        let e = parse("hello").unwrap_err();
        assert_eq!(e.kind, Part21ErrorKind::NotStep, "{e}");
        let e = parse("\u{fffd}PNG\r\n").unwrap_err();
        assert_eq!(e.kind, Part21ErrorKind::NotStep, "{e}");
    }

    #[test]
    fn nesting_is_bounded() {
        let ok = format!(
            "#1=A({}{});",
            "(".repeat(MAX_NESTING - 1),
            ")".repeat(MAX_NESTING - 1)
        );
        assert!(data(&ok).is_ok());
        let deep = format!(
            "#1=A({}{});",
            "(".repeat(MAX_NESTING),
            ")".repeat(MAX_NESTING)
        );
        let e = data(&deep).unwrap_err();
        assert!(e.message.contains("nested deeper"), "{e}");
    }

    #[test]
    fn bom_and_trailing_bytes() {
        let ex = parse("\u{feff}ISO-10303-21;DATA;#1=A();ENDSEC;END-ISO-10303-21;\n\0garbage /* '")
            .unwrap();
        assert_eq!(ex.instances.len(), 1);
    }
}
