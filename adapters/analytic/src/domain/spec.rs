//! The serde schema of the domain format, version 1 (`docs/domain-format.md`).
//!
//! These structs mirror the TOML one to one; every table denies unknown keys
//! so that a misspelt key is an error with its line and column rather than
//! silently ignored. Geometry is checked later, in `build`.

use serde::Deserialize;

/// A point as written: `[x, y]` or `[x, y, z]` (checked in `build`).
pub(crate) type Pt = Vec<f64>;

/// The whole file.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct DomainSpec {
    /// Checked before deserialisation; kept so the key is not "unknown".
    #[allow(dead_code)]
    pub format: String,
    /// Absolute merge/gap tolerance in model units; default 1e-9 × size.
    pub tolerance: Option<f64>,
    #[serde(default)]
    pub face: Vec<FaceSpec>,
    #[serde(default)]
    pub curve: Vec<PathSpec>,
    #[serde(default)]
    pub surface: Vec<super::surface::SurfaceSpec>,
    #[serde(default)]
    pub solid: Vec<super::solid::SolidSpec>,
}

/// One `[[face]]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct FaceSpec {
    pub name: Option<String>,
    pub outer: PathSpec,
    #[serde(default)]
    pub holes: Vec<PathSpec>,
    #[serde(default)]
    pub constraints: Vec<PathSpec>,
    #[serde(default)]
    pub points: Vec<Pt>,
}

/// A path: a loop, a constraint or a `[[curve]]`. Exactly one geometry key
/// must be present (checked in `build`, which names the keys it found).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct PathSpec {
    pub name: Option<String>,
    pub line: Option<Vec<Pt>>,
    pub polyline: Option<Vec<Pt>>,
    pub polygon: Option<Vec<Pt>>,
    pub circle: Option<CircleSpec>,
    pub arc: Option<ArcSpec>,
    pub arc3: Option<Vec<Pt>>,
    pub nurbs: Option<NurbsSpec>,
    pub chain: Option<Vec<PieceSpec>>,
}

/// One piece of a `chain`: an open curve with a direction.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct PieceSpec {
    pub name: Option<String>,
    pub line: Option<Vec<Pt>>,
    pub polyline: Option<Vec<Pt>>,
    pub arc: Option<ArcSpec>,
    pub arc3: Option<Vec<Pt>>,
    pub nurbs: Option<NurbsSpec>,
}

/// `circle = { center, radius, normal? }`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct CircleSpec {
    pub center: Pt,
    pub radius: f64,
    pub normal: Option<Pt>,
}

/// `arc = { center, radius, start, end, normal? }`, angles in degrees.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct ArcSpec {
    pub center: Pt,
    pub radius: f64,
    pub start: f64,
    pub end: f64,
    pub normal: Option<Pt>,
}

/// `nurbs = { degree, points, weights?, knots? }`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct NurbsSpec {
    pub degree: usize,
    pub points: Vec<Pt>,
    pub weights: Option<Vec<f64>>,
    pub knots: Option<Vec<f64>>,
}

/// A view of the geometry keys of a path or piece, for uniform handling.
pub(crate) enum Geometry<'a> {
    Line(&'a [Pt]),
    Polyline(&'a [Pt]),
    Polygon(&'a [Pt]),
    Circle(&'a CircleSpec),
    Arc(&'a ArcSpec),
    Arc3(&'a [Pt]),
    Nurbs(&'a NurbsSpec),
    Chain(&'a [PieceSpec]),
}

/// The one geometry among the present keys, or "found none" / "found `a`
/// and `b`".
fn present<'a>(cands: Vec<Option<(&'static str, Geometry<'a>)>>) -> Result<Geometry<'a>, String> {
    let mut found: Vec<(&'static str, Geometry<'a>)> = cands.into_iter().flatten().collect();
    match found.len() {
        0 => Err("found none".to_string()),
        1 => match found.pop() {
            Some((_, g)) => Ok(g),
            None => Err("found none".to_string()),
        },
        _ => {
            let names: Vec<String> = found.iter().map(|(k, _)| format!("`{k}`")).collect();
            Err(format!("found {}", names.join(" and ")))
        }
    }
}

impl PathSpec {
    /// The single geometry of this path, or a message naming the problem.
    pub fn geometry(&self) -> Result<Geometry<'_>, String> {
        present(vec![
            self.line.as_deref().map(|v| ("line", Geometry::Line(v))),
            self.polyline.as_deref().map(|v| ("polyline", Geometry::Polyline(v))),
            self.polygon.as_deref().map(|v| ("polygon", Geometry::Polygon(v))),
            self.circle.as_ref().map(|v| ("circle", Geometry::Circle(v))),
            self.arc.as_ref().map(|v| ("arc", Geometry::Arc(v))),
            self.arc3.as_deref().map(|v| ("arc3", Geometry::Arc3(v))),
            self.nurbs.as_ref().map(|v| ("nurbs", Geometry::Nurbs(v))),
            self.chain.as_deref().map(|v| ("chain", Geometry::Chain(v))),
        ])
        .map_err(|m| {
            format!(
                "expected exactly one of the keys `polygon`, `circle`, `chain`, `line`, `polyline`, `arc`, `arc3`, `nurbs` ({m})"
            )
        })
    }
}

impl PieceSpec {
    /// The single geometry of this chain piece, or a message naming the
    /// problem.
    pub fn geometry(&self) -> Result<Geometry<'_>, String> {
        present(vec![
            self.line.as_deref().map(|v| ("line", Geometry::Line(v))),
            self.polyline.as_deref().map(|v| ("polyline", Geometry::Polyline(v))),
            self.arc.as_ref().map(|v| ("arc", Geometry::Arc(v))),
            self.arc3.as_deref().map(|v| ("arc3", Geometry::Arc3(v))),
            self.nurbs.as_ref().map(|v| ("nurbs", Geometry::Nurbs(v))),
        ])
        .map_err(|m| {
            format!("a chain piece needs exactly one of the keys `line`, `polyline`, `arc`, `arc3`, `nurbs` ({m})")
        })
    }
}

impl Geometry<'_> {
    /// The key name, for messages.
    pub fn kind(&self) -> &'static str {
        match self {
            Geometry::Line(_) => "line",
            Geometry::Polyline(_) => "polyline",
            Geometry::Polygon(_) => "polygon",
            Geometry::Circle(_) => "circle",
            Geometry::Arc(_) => "arc",
            Geometry::Arc3(_) => "arc3",
            Geometry::Nurbs(_) => "nurbs",
            Geometry::Chain(_) => "chain",
        }
    }
}
