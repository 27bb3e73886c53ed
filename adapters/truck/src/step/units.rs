//! The file's length unit: the `LENGTH_UNIT` that the representation
//! contexts (`GLOBAL_UNIT_ASSIGNED_CONTEXT`) assign, as a name and its size
//! in metres. Coordinates stay in this unit; it is reported so that a user
//! knows what `--size` is measured in.

use truck_stepio::r#in::ruststep::ast::Parameter;

use super::table::Table;

/// A length unit: its name (`millimetre`, `inch`, …) and metres per unit.
#[derive(Debug, Clone, PartialEq)]
pub struct LengthUnit {
    /// The unit's name: `millimetre`, `metre`, … for an SI unit (prefix and
    /// `metre`), the file's own lower-cased name for a conversion-based one.
    pub name: String,
    /// The unit's length in metres (positive: `0.001` for a millimetre).
    pub metres: f64,
}

impl LengthUnit {
    fn named(name: &str, metres: f64) -> Self {
        LengthUnit {
            name: name.to_string(),
            metres,
        }
    }
    /// The millimetre, 0.001 m.
    pub fn millimetre() -> Self {
        Self::named("millimetre", 1e-3)
    }
    /// The centimetre, 0.01 m.
    pub fn centimetre() -> Self {
        Self::named("centimetre", 1e-2)
    }
    /// The metre.
    pub fn metre() -> Self {
        Self::named("metre", 1.0)
    }
    /// The inch, 0.0254 m.
    pub fn inch() -> Self {
        Self::named("inch", 0.0254)
    }
    /// The foot, 0.3048 m.
    pub fn foot() -> Self {
        Self::named("foot", 0.3048)
    }
    /// The unit called `s`: `mm`, `cm`, `m`, `in`, `ft` or the full names
    /// (`millimetre`/`millimeter`, `inch`, `foot`/`feet`, …), any case.
    pub fn parse(s: &str) -> Option<Self> {
        Some(match s.trim().to_ascii_lowercase().as_str() {
            "mm" | "millimetre" | "millimeter" | "millimetres" | "millimeters" => {
                Self::millimetre()
            }
            "cm" | "centimetre" | "centimeter" | "centimetres" | "centimeters" => {
                Self::centimetre()
            }
            "m" | "metre" | "meter" | "metres" | "meters" => Self::metre(),
            "in" | "inch" | "inches" => Self::inch(),
            "ft" | "foot" | "feet" => Self::foot(),
            _ => return None,
        })
    }
    /// How many of `to` make one of `self` (25.4 from inch to millimetre).
    pub fn factor_to(&self, to: &LengthUnit) -> f64 {
        let f = self.metres / to.metres;
        // 0.0254 / 0.001 is 25.400000000000002 in floating point: a ratio
        // within rounding of a number with few decimals is that number
        let r = (f * 1e6).round() / 1e6;
        if (r - f).abs() <= 1e-12 * f.abs() {
            r
        } else {
            f
        }
    }
}

/// Metres per unit of the SI prefix `.MILLI.` etc. (`None`: no prefix).
fn prefix(p: Option<&str>) -> Option<(f64, &'static str)> {
    Some(match p {
        None => (1.0, ""),
        Some("MILLI") => (1e-3, "milli"),
        Some("CENTI") => (1e-2, "centi"),
        Some("DECI") => (1e-1, "deci"),
        Some("KILO") => (1e3, "kilo"),
        Some("MICRO") => (1e-6, "micro"),
        Some("NANO") => (1e-9, "nano"),
        Some("DECA") => (1e1, "deca"),
        Some("HECTO") => (1e2, "hecto"),
        _ => return None,
    })
}

/// The length unit of entity `id`, following conversion-based units to the
/// SI unit they are defined by (at most a few levels).
fn unit_of(t: &Table, id: u64, depth: usize) -> Option<LengthUnit> {
    let e = t.ents.get(&id)?;
    if !e.is("LENGTH_UNIT") || depth > 4 {
        return None;
    }
    if let Some(p) = e.part("SI_UNIT") {
        let pre = match p.first() {
            Some(Parameter::Enumeration(s)) => Some(s.as_str()),
            _ => None,
        };
        let (f, name) = prefix(pre)?;
        return match p.get(1) {
            Some(Parameter::Enumeration(s)) if s == "METRE" => Some(LengthUnit {
                name: format!("{name}metre"),
                metres: f,
            }),
            _ => None,
        };
    }
    let p = e.part("CONVERSION_BASED_UNIT")?;
    let name = match p.first() {
        Some(Parameter::String(s)) => s.trim().to_ascii_lowercase(),
        _ => return None,
    };
    // the conversion factor: a LENGTH_MEASURE_WITH_UNIT (value, unit)
    let factor = p
        .get(1)
        .and_then(|x| t.r(id, x, "conversion_factor").ok())?;
    let m = t.ents.get(&factor)?;
    let mp = m
        .part("LENGTH_MEASURE_WITH_UNIT")
        .or_else(|| m.part("MEASURE_WITH_UNIT"))?;
    let value = t.real(factor, mp.first()?, "value_component").ok()?;
    let base = unit_of(
        t,
        t.r(factor, mp.get(1)?, "unit_component").ok()?,
        depth + 1,
    )?;
    (value > 0.0).then_some(LengthUnit {
        name,
        metres: value * base.metres,
    })
}

/// The length unit the file's representation contexts assign (the one most
/// contexts use, when they differ), or `None` when the file names none.
pub(crate) fn length_unit(t: &Table) -> Option<LengthUnit> {
    let mut found: Vec<(LengthUnit, usize)> = Vec::new();
    let mut ids: Vec<&u64> = t.ents.keys().collect();
    ids.sort_unstable();
    for id in ids {
        let e = &t.ents[id];
        let Some(p) = e.part("GLOBAL_UNIT_ASSIGNED_CONTEXT") else {
            continue;
        };
        let Some(Parameter::List(units)) = p.first() else {
            continue;
        };
        for u in units {
            if let Some(lu) = t.r(*id, u, "units").ok().and_then(|r| unit_of(t, r, 0)) {
                match found.iter_mut().find(|(f, _)| *f == lu) {
                    Some((_, n)) => *n += 1,
                    None => found.push((lu, 1)),
                }
            }
        }
    }
    found.into_iter().max_by_key(|(_, n)| *n).map(|(u, _)| u)
}
