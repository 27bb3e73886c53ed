//! The entity table of a STEP file: each instance `#id = NAME(...)` (or a
//! complex instance `#id = (A(...) B(...))`) with typed access to its
//! parameters. Every accessor failure is a [`StepError`] naming the entity.

use std::collections::HashMap;

use truck_stepio::r#in::ruststep::ast::{EntityInstance, Name, Parameter, Record};

use super::StepError;

/// Largest coordinate magnitude accepted in a `CARTESIAN_POINT`. Coordinates
/// beyond it are nonsense in any length unit, and the geometry computes
/// products of up to six coordinate differences (squared norms of cross
/// products, volumes), which stay finite below it: (2·10⁵⁰)⁶ ≈ 6·10³⁰¹ <
/// f64::MAX. A larger but finite coordinate would otherwise surface later
/// as an unrelated error (an infinite model extent makes every edge look
/// closed).
pub const MAX_COORDINATE: f64 = 1e50;

/// One entity instance.
pub(crate) struct Entity {
    /// The records: one for a simple instance, several for a complex one.
    pub records: Vec<Record>,
}

impl Entity {
    /// The type name: `NAME`, or `(A B C)` for a complex instance.
    pub fn type_name(&self) -> String {
        if self.records.len() == 1 {
            self.records[0].name.clone()
        } else {
            let names: Vec<&str> = self.records.iter().map(|r| r.name.as_str()).collect();
            format!("({})", names.join(" "))
        }
    }
    /// Whether this is a simple `name` or a complex instance with a `name` part.
    pub fn is(&self, name: &str) -> bool {
        self.records.iter().any(|r| r.name == name)
    }
    /// Parameters of the record `name`.
    pub fn part(&self, name: &str) -> Option<&[Parameter]> {
        self.records
            .iter()
            .find(|r| r.name == name)
            .map(|r| params(&r.parameter))
    }
}

fn params(p: &Parameter) -> &[Parameter] {
    match p {
        Parameter::List(v) => v,
        other => std::slice::from_ref(other),
    }
}

pub(crate) struct Table {
    pub source: String,
    pub ents: HashMap<u64, Entity>,
}

impl Table {
    pub fn new(source: &str, instances: Vec<EntityInstance>) -> Result<Self, StepError> {
        let mut ents = HashMap::with_capacity(instances.len());
        for inst in instances {
            let (id, records) = match inst {
                EntityInstance::Simple { id, record } => (id, vec![record]),
                EntityInstance::Complex { id, subsuper } => (id, subsuper.0),
            };
            if ents.insert(id, Entity { records }).is_some() {
                return Err(StepError::file(
                    source,
                    format!("entity #{id} is defined twice"),
                ));
            }
        }
        Ok(Table {
            source: source.to_string(),
            ents,
        })
    }

    /// Ids of the entities with a record `name`, sorted.
    pub fn ids_of(&self, name: &str) -> Vec<u64> {
        let mut v: Vec<u64> = self
            .ents
            .iter()
            .filter(|(_, e)| e.is(name))
            .map(|(&id, _)| id)
            .collect();
        v.sort_unstable();
        v
    }

    pub fn get(&self, id: u64) -> Result<&Entity, StepError> {
        self.ents.get(&id).ok_or_else(|| {
            StepError::file(
                &self.source,
                format!("entity #{id} is referenced but not defined"),
            )
        })
    }

    pub fn type_name(&self, id: u64) -> String {
        self.ents
            .get(&id)
            .map_or_else(|| "undefined".into(), |e| e.type_name())
    }

    /// An error about entity `id`.
    pub fn err(&self, id: u64, reason: impl Into<String>) -> StepError {
        StepError::entity(&self.source, id, self.type_name(id), reason)
    }

    /// The parameters of simple entity `id` of one of the types `names`
    /// (or of its record `names[k]` in a complex instance), at least `min`.
    pub fn args(&self, id: u64, names: &[&str], min: usize) -> Result<&[Parameter], StepError> {
        let e = self.get(id)?;
        for n in names {
            if let Some(p) = e.part(n) {
                if p.len() < min {
                    return Err(self.err(
                        id,
                        format!("has {} parameters, expected at least {min}", p.len()),
                    ));
                }
                return Ok(p);
            }
        }
        Err(self.err(
            id,
            format!("expected an entity of type {}", names.join(" or ")),
        ))
    }

    // ---- parameter accessors (`id` is the entity the parameter belongs to)

    pub fn r(&self, id: u64, p: &Parameter, what: &str) -> Result<u64, StepError> {
        match p {
            Parameter::Ref(Name::Entity(x)) => Ok(*x),
            Parameter::Typed { parameter, .. } => self.r(id, parameter, what),
            _ => Err(self.err(id, format!("{what} is not an entity reference"))),
        }
    }

    pub fn real(&self, id: u64, p: &Parameter, what: &str) -> Result<f64, StepError> {
        let x = match p {
            Parameter::Real(x) => *x,
            Parameter::Integer(i) => *i as f64,
            Parameter::Typed { parameter, .. } => return self.real(id, parameter, what),
            _ => return Err(self.err(id, format!("{what} is not a number"))),
        };
        if !x.is_finite() {
            return Err(self.err(id, format!("{what} is not finite")));
        }
        Ok(x)
    }

    pub fn int(&self, id: u64, p: &Parameter, what: &str) -> Result<i64, StepError> {
        match p {
            Parameter::Integer(i) => Ok(*i),
            Parameter::Typed { parameter, .. } => self.int(id, parameter, what),
            _ => Err(self.err(id, format!("{what} is not an integer"))),
        }
    }

    pub fn list<'a>(
        &self,
        id: u64,
        p: &'a Parameter,
        what: &str,
    ) -> Result<&'a [Parameter], StepError> {
        match p {
            Parameter::List(v) => Ok(v),
            _ => Err(self.err(id, format!("{what} is not a list"))),
        }
    }

    pub fn boolean(&self, id: u64, p: &Parameter, what: &str) -> Result<bool, StepError> {
        match p {
            Parameter::Enumeration(s) if s == "T" || s == "TRUE" => Ok(true),
            Parameter::Enumeration(s) if s == "F" || s == "FALSE" => Ok(false),
            _ => Err(self.err(id, format!("{what} is not .T. or .F."))),
        }
    }

    pub fn reals(&self, id: u64, p: &Parameter, what: &str) -> Result<Vec<f64>, StepError> {
        self.list(id, p, what)?
            .iter()
            .map(|x| self.real(id, x, what))
            .collect()
    }

    /// The coordinates of a point: finite numbers of magnitude at most
    /// [`MAX_COORDINATE`].
    pub fn coords(&self, id: u64, p: &Parameter, what: &str) -> Result<Vec<f64>, StepError> {
        let c = self.reals(id, p, what)?;
        if let Some(x) = c.iter().find(|x| !(x.abs() <= MAX_COORDINATE)) {
            return Err(self.err(
                id,
                format!("coordinate {x:e} is out of range (|x| > {MAX_COORDINATE:e})"),
            ));
        }
        Ok(c)
    }

    pub fn refs(&self, id: u64, p: &Parameter, what: &str) -> Result<Vec<u64>, StepError> {
        self.list(id, p, what)?
            .iter()
            .map(|x| self.r(id, x, what))
            .collect()
    }
}
