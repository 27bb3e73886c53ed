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
    #[error("cannot parse spacing expression '{expr}': {reason}")]
    Parse { expr: String, reason: String },
    #[error(
        "spacing expression '{expr}' uses unknown variable '{var}' (only x, y, z are defined)"
    )]
    UnknownVariable { expr: String, var: String },
    #[error("spacing expression '{expr}' is {value} at {at}; a spacing must be finite and > 0")]
    NotPositive {
        expr: String,
        value: f64,
        at: String,
    },
}

// exmex's default number literal has no exponent; users write 1e-3.
use exmex::MatchLiteral;
exmex::literal_matcher_from_pattern!(SciNumber, r"^(\.?[0-9]+(\.[0-9]*)?([eE][+-]?[0-9]+)?)");

type Flat = exmex::FlatEx<f64, exmex::FloatOpsFactory<f64>, SciNumber>;

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

impl Expr {
    /// Parses `text`. The result is checked at the origin only for
    /// parse-level errors; positivity is checked where it is evaluated.
    pub fn parse(text: &str) -> Result<Self, ExprError> {
        use exmex::prelude::*;
        let normalised = text.replace("**", "^");
        let flat = Flat::parse(&normalised).map_err(|e| ExprError::Parse {
            expr: text.to_string(),
            reason: e.to_string(),
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
    pub inner: S,
    pub min: f64,
    pub max: f64,
}

impl<S: Spacing> Spacing for Clamped<S> {
    fn spacing(&self, q: &SpacingQuery) -> f64 {
        self.inner.spacing(q).clamp(self.min, self.max)
    }
    fn constant(&self) -> Option<f64> {
        self.inner.constant().map(|c| c.clamp(self.min, self.max))
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
}
