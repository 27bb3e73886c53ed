//! A line- and token-oriented reader for the ASCII formats, tracking line
//! numbers for error messages. Blank lines are skipped; with a comment
//! character, everything from it to the end of the line is ignored.

use std::str::FromStr;

use crate::ParseError;

/// Capacity to reserve for a count read from a file: never trust it for more
/// than this many items up front (a corrupt count must not exhaust memory).
pub(crate) fn cap(n: usize) -> usize {
    n.min(1 << 16)
}

pub(crate) struct Text<'a> {
    lines: std::str::Lines<'a>,
    comment: Option<char>,
    /// 1-based number of the last line taken.
    lineno: usize,
    /// Remaining tokens of a partly consumed line.
    cur: Option<std::str::SplitAsciiWhitespace<'a>>,
}

impl<'a> Text<'a> {
    pub fn new(s: &'a str, comment: Option<char>) -> Self {
        Text {
            lines: s.lines(),
            comment,
            lineno: 0,
            cur: None,
        }
    }

    /// The number of the line last read (0 before any).
    pub fn lineno(&self) -> usize {
        self.lineno
    }

    /// The next non-blank line (comments removed, trimmed), or `None` at the
    /// end. Drops what is left of a partly consumed line.
    pub fn next_line(&mut self) -> Option<&'a str> {
        self.cur = None;
        for l in self.lines.by_ref() {
            self.lineno += 1;
            let l = match self.comment {
                Some(c) => l.split(c).next().unwrap_or(""),
                None => l,
            };
            let l = l.trim();
            if !l.is_empty() {
                return Some(l);
            }
        }
        None
    }

    /// The next non-blank line, or an error naming what was expected.
    pub fn line(&mut self, what: &str) -> Result<&'a str, ParseError> {
        self.next_line().ok_or_else(|| self.eof(what))
    }

    /// The tokens of the next non-blank line.
    pub fn line_tokens(&mut self, what: &str) -> Result<Vec<&'a str>, ParseError> {
        Ok(self.line(what)?.split_ascii_whitespace().collect())
    }

    /// The next token, continuing over line ends.
    pub fn token(&mut self, what: &str) -> Result<&'a str, ParseError> {
        loop {
            if let Some(t) = self.cur.as_mut().and_then(|c| c.next()) {
                return Ok(t);
            }
            let l = self.line(what)?;
            self.cur = Some(l.split_ascii_whitespace());
        }
    }

    /// The next token parsed as `T`.
    pub fn num<T: FromStr>(&mut self, what: &str) -> Result<T, ParseError> {
        let t = self.token(what)?;
        parse_at(t, what, self.lineno)
    }

    /// An "unexpected end of file" error.
    pub fn eof(&self, what: &str) -> ParseError {
        ParseError::at(
            self.lineno.max(1),
            format!("unexpected end of file, expected {what}"),
        )
    }

    /// An error at the current line.
    pub fn err(&self, reason: impl Into<String>) -> ParseError {
        ParseError::at(self.lineno.max(1), reason)
    }
}

/// Parses a token, naming it and the line on failure.
pub(crate) fn parse_at<T: FromStr>(tok: &str, what: &str, line: usize) -> Result<T, ParseError> {
    tok.parse().map_err(|_| {
        ParseError::at(
            line.max(1),
            format!("expected {what}, found '{}'", clip(tok)),
        )
    })
}

/// Parses a finite coordinate.
pub(crate) fn coord(tok: &str, line: usize) -> Result<f64, ParseError> {
    let x: f64 = parse_at(tok, "a coordinate", line)?;
    if x.is_finite() {
        Ok(x)
    } else {
        Err(ParseError::at(
            line.max(1),
            format!("non-finite coordinate '{tok}'"),
        ))
    }
}

/// A token shortened for messages.
pub(crate) fn clip(t: &str) -> String {
    if t.chars().count() > 40 {
        format!("{}…", t.chars().take(40).collect::<String>())
    } else {
        t.to_string()
    }
}

/// Bytes as text for the ASCII formats; invalid UTF-8 is replaced (such
/// bytes can only be in places the parsers reject or ignore).
pub(crate) fn as_text(data: &[u8]) -> std::borrow::Cow<'_, str> {
    String::from_utf8_lossy(data)
}
