//! The meshing error: every failure names the entity and the reason.

use crate::face::connect::ConnectError;
use crate::geom::P3;
use crate::model::EntityRef;

/// A meshing failure. Messages name the entity and the reason.
#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    #[error("the spacing is {value} at ({x}, {y}, {z}) on {entity}; a spacing must be finite and > 0", x = point.x, y = point.y, z = point.z)]
    BadSpacing {
        value: f64,
        point: P3,
        entity: EntityRef,
    },
    #[error("the spacing asks for more than {limit} bubbles on one entity; is the size in the model's units?")]
    TooManyBubbles { limit: usize },
    #[error("{0}")]
    Invalid(String),
    #[error("{0}")]
    Unsupported(String),
    #[error("cannot triangulate: {0}")]
    Connect(#[from] ConnectError),
    /// A step failed where a finer spacing on `faces` may succeed (a
    /// surface mesh that is not Delaunay enough for boundary recovery).
    #[error("{message}")]
    Refinable { message: String, faces: Vec<u32> },
    /// A volume's tetrahedralization failed (other than for a boundary
    /// that is not Delaunay enough, which is [`MeshError::Refinable`]).
    #[error("{0}")]
    Volume(#[from] crate::volume::Connect3dError),
    /// A volume's faces do not close it.
    #[error("{0}")]
    Shell(#[from] crate::volume::ShellError),
    /// The finished mesh failed [`crate::verify::verify`]: nothing may be
    /// written.
    #[error("{0}")]
    Check(#[from] crate::verify::CheckError),
    #[error("{what}: {source}")]
    In {
        what: String,
        #[source]
        source: Box<MeshError>,
    },
}

impl MeshError {
    pub(crate) fn within(self, what: String) -> MeshError {
        match self {
            e @ MeshError::In { .. } => e,
            e => MeshError::In {
                what,
                source: Box::new(e),
            },
        }
    }
}

pub(crate) fn check_spacing(d: f64, point: P3, entity: EntityRef) -> Result<f64, MeshError> {
    if d.is_finite() && d > 0.0 {
        Ok(d)
    } else {
        Err(MeshError::BadSpacing {
            value: d,
            point,
            entity,
        })
    }
}
