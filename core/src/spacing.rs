//! Node spacing d(x): the diameter of the bubble centred at x (thesis §3.2.1,
//! §4.6). Two neighbouring bubbles are at rest at the *stable distance*
//! r0 = (d_i + d_j)/2 (eq. 3.2.1–3.2.2), so d is the target edge length of
//! the mesh.
//!
//! A spacing receives the point *and* the entity it lies on, with the
//! entity's parameters, so that curvature-based spacing (eq. 4.6.1) can be
//! built on the same interface. Invariant for every implementation: the
//! returned value is finite and > 0; the engine checks this and reports the
//! point and entity otherwise.

use crate::geom::P3;
use crate::model::EntityRef;

/// Where the engine asks for a spacing.
#[derive(Clone, Copy, Debug)]
pub struct SpacingQuery {
    /// The point in model space.
    pub point: P3,
    /// The entity the point lies on.
    pub entity: EntityRef,
    /// The entity's parameters at the point: `[t, 0]` on an edge, `[u, v]` on
    /// a face, unused on vertices and volumes.
    pub params: [f64; 2],
}

/// A node-spacing function d(x) in model units.
pub trait Spacing: Send + Sync {
    /// d at one point.
    fn spacing(&self, q: &SpacingQuery) -> f64;
    /// d at many points; the default loops over [`Spacing::spacing`].
    /// Implementations with a per-call cost (plugins) override it.
    fn spacing_batch(&self, qs: &[SpacingQuery], out: &mut [f64]) {
        for (q, o) in qs.iter().zip(out.iter_mut()) {
            *o = self.spacing(q);
        }
    }
    /// `Some(d)` when the spacing is the same everywhere (lets the engine skip
    /// evaluations).
    fn constant(&self) -> Option<f64> {
        None
    }
    /// `Some(d)` when the spacing is d everywhere on the entity `e` (the
    /// engine's uniform paths for that entity: lattice starts, no
    /// re-evaluation in stage 2); by default [`Spacing::constant`].
    fn constant_on(&self, _e: EntityRef) -> Option<f64> {
        self.constant()
    }
}

/// A boxed spacing is a spacing (so combinators nest).
impl<S: Spacing + ?Sized> Spacing for Box<S> {
    fn spacing(&self, q: &SpacingQuery) -> f64 {
        (**self).spacing(q)
    }
    fn spacing_batch(&self, qs: &[SpacingQuery], out: &mut [f64]) {
        (**self).spacing_batch(qs, out)
    }
    fn constant(&self) -> Option<f64> {
        (**self).constant()
    }
    fn constant_on(&self, e: EntityRef) -> Option<f64> {
        (**self).constant_on(e)
    }
}

/// d(x) = c.
#[derive(Clone, Copy, Debug)]
pub struct Constant(pub f64);

impl Spacing for Constant {
    fn spacing(&self, _q: &SpacingQuery) -> f64 {
        self.0
    }
    fn constant(&self) -> Option<f64> {
        Some(self.0)
    }
}

/// Errors from parsing a spacing expression.
#[derive(Debug, thiserror::Error)]
pub enum ExprError {
    /// The text is not an expression.
    #[error("cannot parse spacing expression '{expr}': {reason}")]
    Parse {
        /// The expression as given.
        expr: String,
        /// The parser's reason.
        reason: String,
    },
    /// The expression names a variable other than x, y, z.
    #[error(
        "spacing expression '{expr}' uses unknown variable '{var}' (only x, y, z are defined)"
    )]
    UnknownVariable {
        /// The expression as given.
        expr: String,
        /// The unknown name.
        var: String,
    },
    /// The expression evaluates to zero, a negative or a non-finite value.
    #[error("spacing expression '{expr}' is {value} at {at}; a spacing must be finite and > 0")]
    NotPositive {
        /// The expression as given.
        expr: String,
        /// The value it took.
        value: f64,
        /// Where, as text.
        at: String,
    },
}

// exmex's default number literal has no exponent; users write 1e-3.
use exmex::MatchLiteral;
exmex::literal_matcher_from_pattern!(SciNumber, r"^(\.?[0-9]+(\.[0-9]*)?([eE][+-]?[0-9]+)?)");

type Flat = exmex::FlatEx<f64, exmex::FloatOpsFactory<f64>, SciNumber>;

/// The expression as quoted in a message: whole if short, else its start.
fn clip_expr(text: &str) -> String {
    const MAX: usize = 80;
    if text.chars().count() <= MAX {
        text.to_string()
    } else {
        let head: String = text.chars().take(MAX).collect();
        format!("{head}…")
    }
}

/// d(x, y, z) given as an expression parsed at run time with `exmex`.
///
/// Syntax: numbers (also `1e-3`), `x y z`, `+ - * / ^` (also `**`), parentheses, and the
/// functions `sqrt abs min max exp log ln sin cos tan` (`log` is the natural
/// logarithm), constants `PI` and `E`.
pub struct Expr {
    text: String,
    flat: Flat,
    /// For each variable of the parsed expression (exmex orders them
    /// alphabetically), which of x, y, z it is.
    slots: Vec<usize>,
    constant: Option<f64>,
}

impl std::fmt::Debug for Expr {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Expr({:?})", self.text)
    }
}

/// The longest expression accepted, in characters (parsing time grows
/// faster than the length; a spacing never needs this many).
pub const MAX_EXPR_CHARS: usize = 10_000;

/// Functions of the expression language (exmex's float operators).
const FUNCTIONS: &[&str] = &[
    "sqrt", "abs", "min", "max", "exp", "ln", "log", "log2", "log10", "sin", "cos", "tan", "asin",
    "acos", "atan", "atan2", "sinh", "cosh", "tanh", "asinh", "acosh", "atanh", "floor", "round",
    "ceil", "trunc", "fract", "signum", "cbrt",
];

/// Named constants of the expression language.
const CONSTANTS: &[&str] = &["PI", "π", "E", "e", "TAU", "τ"];

/// Checks the words and characters of an expression before exmex sees it,
/// so that a mistake gets a message in the user's terms (unknown function,
/// invalid number, unbalanced parenthesis) instead of the parser's
/// internals. Returns the reason, or `UnknownVariable`'s name as `Err(Ok)`.
fn precheck(text: &str) -> Result<(), Result<String, String>> {
    let chars: Vec<char> = text.chars().collect();
    if chars.len() > MAX_EXPR_CHARS {
        return Err(Err(format!(
            "it is {} characters long; at most {MAX_EXPR_CHARS} are accepted",
            chars.len()
        )));
    }
    if chars.iter().all(|c| c.is_whitespace()) {
        return Err(Err("the expression is empty".into()));
    }
    let word_char = |c: char| c.is_alphanumeric() || c == '_';
    let (n, mut i, mut depth) = (chars.len(), 0usize, 0i64);
    while i < n {
        let c = chars[i];
        if c.is_whitespace() {
            i += 1;
        } else if c.is_ascii_digit() || (c == '.' && i + 1 < n && chars[i + 1].is_ascii_digit()) {
            let start = i;
            while i < n && chars[i].is_ascii_digit() {
                i += 1;
            }
            if i < n && chars[i] == '.' {
                i += 1;
                while i < n && chars[i].is_ascii_digit() {
                    i += 1;
                }
            }
            if i < n && (chars[i] == 'e' || chars[i] == 'E') {
                let mut j = i + 1;
                if j < n && (chars[j] == '+' || chars[j] == '-') {
                    j += 1;
                }
                if j < n && chars[j].is_ascii_digit() {
                    i = j;
                    while i < n && chars[i].is_ascii_digit() {
                        i += 1;
                    }
                }
            }
            if i < n && (word_char(chars[i]) || chars[i] == '.') {
                while i < n && (word_char(chars[i]) || chars[i] == '.') {
                    i += 1;
                }
                let word: String = chars[start..i].iter().collect();
                return Err(Err(format!(
                    "invalid number '{word}' (numbers are decimal, like 0.5, 2 or 1e-3)"
                )));
            }
        } else if word_char(c) {
            let start = i;
            while i < n && word_char(chars[i]) {
                i += 1;
            }
            let word: String = chars[start..i].iter().collect();
            let called = chars[i..].iter().find(|c| !c.is_whitespace()) == Some(&'(');
            if FUNCTIONS.contains(&word.as_str()) {
                if !called {
                    return Err(Err(format!(
                        "function '{word}' needs its argument in parentheses, like {word}(x)"
                    )));
                }
            } else if called {
                return Err(Err(format!(
                    "unknown function '{word}' (known: {})",
                    FUNCTIONS.join(" ")
                )));
            } else if !matches!(word.as_str(), "x" | "y" | "z")
                && !CONSTANTS.contains(&word.as_str())
            {
                return Err(Ok(word));
            }
        } else {
            match c {
                '(' => depth += 1,
                ')' => {
                    depth -= 1;
                    if depth < 0 {
                        return Err(Err(format!("')' at character {} has no '('", i + 1)));
                    }
                }
                '+' | '-' | '*' | '/' | '^' | ',' => {}
                other => {
                    return Err(Err(format!(
                        "unexpected character '{other}' at character {}",
                        i + 1
                    )))
                }
            }
            i += 1;
        }
    }
    if depth > 0 {
        return Err(Err(format!("{depth} '(' without ')'")));
    }
    Ok(())
}

impl Expr {
    /// Parses `text`. The result is checked at the origin only for
    /// parse-level errors; positivity is checked where it is evaluated.
    pub fn parse(text: &str) -> Result<Self, ExprError> {
        use exmex::prelude::*;
        let parse_err = |reason: String| ExprError::Parse {
            expr: clip_expr(text),
            reason,
        };
        match precheck(text) {
            Ok(()) => {}
            Err(Ok(var)) => {
                return Err(ExprError::UnknownVariable {
                    expr: clip_expr(text),
                    var,
                })
            }
            Err(Err(reason)) => return Err(parse_err(reason)),
        }
        let normalised = text.replace("**", "^");
        // exmex's own messages describe its internals ("we have 0 ops and 2
        // nodes"); the words are checked above, so what is left is the form
        let flat = Flat::parse(&normalised).map_err(|_| {
            parse_err(
                "it is not a well-formed expression (an operator without an operand, two \
                 values without an operator between them, or empty parentheses)"
                    .into(),
            )
        })?;
        let mut slots = Vec::new();
        for v in flat.var_names() {
            let slot = match v.as_str() {
                "x" => 0,
                "y" => 1,
                "z" => 2,
                other => {
                    return Err(ExprError::UnknownVariable {
                        expr: text.to_string(),
                        var: other.to_string(),
                    })
                }
            };
            slots.push(slot);
        }
        let mut e = Expr {
            text: text.to_string(),
            flat,
            slots,
            constant: None,
        };
        if e.slots.is_empty() {
            e.constant = Some(e.eval(&P3::origin()));
        }
        Ok(e)
    }

    /// The expression text as given.
    pub fn text(&self) -> &str {
        &self.text
    }

    /// Evaluates at a point (NaN when the expression fails there, e.g. a
    /// logarithm of a negative number).
    pub fn eval(&self, p: &P3) -> f64 {
        use exmex::prelude::*;
        let mut vals = [0.0f64; 3];
        for (k, s) in self.slots.iter().enumerate() {
            vals[k] = p[*s];
        }
        self.flat
            .eval(&vals[..self.slots.len()])
            .unwrap_or(f64::NAN)
    }

    /// Checks d > 0 and finite at the given sample points.
    pub fn check_positive(&self, samples: &[P3]) -> Result<(), ExprError> {
        for p in samples {
            let d = self.eval(p);
            if !(d.is_finite() && d > 0.0) {
                return Err(ExprError::NotPositive {
                    expr: self.text.clone(),
                    value: d,
                    at: format!("({}, {}, {})", p.x, p.y, p.z),
                });
            }
        }
        Ok(())
    }
}

impl Spacing for Expr {
    fn spacing(&self, q: &SpacingQuery) -> f64 {
        match self.constant {
            Some(c) => c,
            None => self.eval(&q.point),
        }
    }
    fn constant(&self) -> Option<f64> {
        self.constant
    }
}

/// The minimum of several spacings (thesis §4.8.1).
pub struct MinOf(pub Vec<Box<dyn Spacing>>);

impl Spacing for MinOf {
    fn spacing(&self, q: &SpacingQuery) -> f64 {
        self.0
            .iter()
            .map(|s| s.spacing(q))
            .fold(f64::INFINITY, f64::min)
    }
}

/// The product of several spacings (thesis Fig. 5.10c).
pub struct ProductOf(pub Vec<Box<dyn Spacing>>);

impl Spacing for ProductOf {
    fn spacing(&self, q: &SpacingQuery) -> f64 {
        self.0.iter().map(|s| s.spacing(q)).product()
    }
}

/// A spacing clamped to `[min, max]`.
pub struct Clamped<S: Spacing> {
    /// The spacing clamped.
    pub inner: S,
    /// Lower bound, in model units.
    pub min: f64,
    /// Upper bound, in model units.
    pub max: f64,
}

impl<S: Spacing> Spacing for Clamped<S> {
    fn spacing(&self, q: &SpacingQuery) -> f64 {
        self.inner.spacing(q).clamp(self.min, self.max)
    }
    fn constant(&self) -> Option<f64> {
        self.inner.constant().map(|c| c.clamp(self.min, self.max))
    }
    fn constant_on(&self, e: EntityRef) -> Option<f64> {
        self.inner
            .constant_on(e)
            .map(|c| c.clamp(self.min, self.max))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn q(x: f64, y: f64) -> SpacingQuery {
        SpacingQuery {
            point: P3::new(x, y, 0.0),
            entity: EntityRef::new(2, 0),
            params: [x, y],
        }
    }

    #[test]
    fn expression_matches_meshkit_case_c() {
        let e = Expr::parse(
            "0.02 + 0.1*max(min(sqrt((x-0.5)^2+(y-0.5)^2), sqrt((x-1.5)^2+(y-0.5)^2)) - 0.2, 0)",
        )
        .unwrap();
        let d = e.spacing(&q(0.3, 0.7));
        let r = (0.2f64 * 0.2 + 0.2 * 0.2).sqrt();
        assert!((d - (0.02 + 0.1 * (r - 0.2))).abs() < 1e-12);
        assert_eq!(e.spacing(&q(0.5, 0.5)), 0.02);
    }

    #[test]
    fn python_power_is_accepted() {
        let e = Expr::parse("0.01 + 0.2*((x-0.5)**2 + (y-0.5)**2)").unwrap();
        assert!((e.spacing(&q(1.0, 1.0)) - 0.11).abs() < 1e-12);
    }

    #[test]
    fn scientific_notation_is_accepted() {
        assert_eq!(Expr::parse("1e-3").unwrap().constant(), Some(1e-3));
        assert_eq!(Expr::parse("2.5E+2*1").unwrap().constant(), Some(250.0));
        let e = Expr::parse("1e-2 + 0.5e1*x").unwrap();
        assert!((e.spacing(&q(0.1, 0.0)) - 0.51).abs() < 1e-12);
    }

    #[test]
    fn constant_expression_is_detected() {
        let e = Expr::parse("0.5*0.2").unwrap();
        assert_eq!(e.constant(), Some(0.1));
    }

    #[test]
    fn unknown_variable_is_named() {
        let err = Expr::parse("0.1 + w").unwrap_err().to_string();
        assert!(err.contains("'w'"), "{err}");
    }

    #[test]
    fn garbage_is_rejected_with_the_text() {
        let err = Expr::parse("0.1 + (x").unwrap_err().to_string();
        assert!(err.contains("0.1 + (x"), "{err}");
    }

    #[test]
    fn non_positive_is_reported_with_the_point() {
        let e = Expr::parse("x - 0.5").unwrap();
        let err = e
            .check_positive(&[P3::new(1.0, 0.0, 0.0), P3::new(0.25, 0.0, 0.0)])
            .unwrap_err()
            .to_string();
        assert!(err.contains("0.25"), "{err}");
    }

    /// Mistakes are named in the user's terms, never in the parser's
    /// internals ("wlog", "we have 0 ops and 2 nodes").
    #[test]
    fn parse_errors_name_the_mistake_not_parser_internals() {
        let msg = |t: &str| Expr::parse(t).unwrap_err().to_string();
        let e = msg("foo(x)");
        assert!(e.contains("unknown function 'foo'"), "{e}");
        let e = msg("0x10");
        assert!(e.contains("invalid number '0x10'"), "{e}");
        let e = msg("0.1 + 2.5.3");
        assert!(e.contains("invalid number '2.5.3'"), "{e}");
        let e = msg("0.1 + )x(");
        assert!(e.contains("has no '('"), "{e}");
        let e = msg("0.1 $ x");
        assert!(e.contains("unexpected character '$'"), "{e}");
        for t in ["foo(x)", "0x10", "0.1 +", "* 2", "()", "0.1 0.2", "sin", ""] {
            let e = msg(t);
            assert!(!e.contains("wlog") && !e.contains(" ops "), "{t}: {e}");
        }
        // what the parser does take still parses
        for t in [
            "log10(x + 1) + 0.1",
            "atan2(y, x) + 4",
            "PI*0.01",
            "e^-2",
            ".5*x+1",
        ] {
            Expr::parse(t).unwrap_or_else(|e| panic!("{t}: {e}"));
        }
    }

    /// A 29,000-term expression used to take minutes (parsing grows faster
    /// than its length); it is refused at once with the limit.
    #[test]
    fn an_overlong_expression_is_refused_quickly() {
        let text = format!("0.05{}", "+0*x".repeat(29_000));
        let t = std::time::Instant::now();
        let e = Expr::parse(&text).unwrap_err().to_string();
        assert!(t.elapsed().as_secs_f64() < 1.0);
        assert!(e.contains("at most 10000"), "{e}");
        assert!(
            e.len() < 400,
            "the message quotes the whole expression: {} bytes",
            e.len()
        );
        // below the limit it parses in reasonable time
        let text = format!("0.05{}", "+0*x".repeat(2_000));
        let t = std::time::Instant::now();
        Expr::parse(&text).unwrap();
        assert!(t.elapsed().as_secs_f64() < 5.0, "{:?}", t.elapsed());
    }
}
