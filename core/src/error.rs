//! The meshing error: every failure names the entity and the reason.

use crate::geom::P3;
use crate::model::EntityRef;

/// A meshing failure. Messages name the entity and the reason.
#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    /// The spacing function gave zero, a negative or a non-finite value.
    #[error("the spacing is {value} at ({x}, {y}, {z}) on {entity}; a spacing must be finite and > 0", x = point.x, y = point.y, z = point.z)]
    BadSpacing {
        /// The value it gave.
        value: f64,
        /// Where.
        point: P3,
        /// On which entity.
        entity: EntityRef,
    },
    /// The spacing is so small against an entity that its bubbles would
    /// exhaust memory.
    #[error("the spacing asks for more than {limit} bubbles on one entity; is the size in the model's units?")]
    TooManyBubbles {
        /// The most bubbles one entity may have.
        limit: usize,
    },
    /// The model or the request is invalid (the message says why).
    #[error("{0}")]
    Invalid(String),
    /// The model asks for something the engine does not do.
    #[error("{0}")]
    Unsupported(String),
    /// A face's bubbles could not be connected.
    #[error("cannot triangulate: {0}")]
    Connect(#[from] ConnectError),
    /// A step failed where a finer spacing on `faces` may succeed (a
    /// surface mesh that is not Delaunay enough for boundary recovery).
    #[error("{message}")]
    Refinable {
        /// What failed.
        message: String,
        /// The faces to mesh finer.
        faces: Vec<u32>,
        /// Places to mesh finer instead of whole faces, as balls (centre,
        /// radius): where boundary triangles are missing from a
        /// tetrahedralization ([`crate::engine::refine`]).
        spots: Vec<(crate::geom::P3, f64)>,
    },
    /// A volume's tetrahedralization failed (other than for a boundary
    /// that is not Delaunay enough, which is [`MeshError::Refinable`]).
    #[error("{0}")]
    Volume(#[from] Connect3dError),
    /// A volume's faces do not close it.
    #[error("{0}")]
    Shell(#[from] ShellError),
    /// The finished mesh failed [`crate::verify::verify`]: nothing may be
    /// written.
    #[error("{0}")]
    Check(#[from] crate::verify::CheckError),
    /// Refinement by places ([`crate::engine::refine`]) stopped before it
    /// cured `source`: the surface mesh grew past its bound while the same
    /// boundary triangles kept missing.
    #[error("{source}; refinement stopped: {why}")]
    RefinementStopped {
        /// Why it stopped, with the places that kept failing.
        why: String,
        /// The last attempt's error.
        #[source]
        source: Box<MeshError>,
    },
    /// An error inside an entity: `what` names it.
    #[error("{what}: {source}")]
    In {
        /// The entity, described for people (`face 3 ("top")`).
        what: String,
        /// The error.
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

/// Why a triangulation could not be built.
#[derive(Debug, thiserror::Error)]
pub enum ConnectError {
    /// Two nodes map to one (u,v).
    #[error("two mesh nodes coincide at (u,v) = ({0}, {1})")]
    Duplicate(f64, f64),
    /// Two boundary or embedded segments cross in (u,v).
    #[error(
        "constraint segments cross near (u,v) = ({0}, {1}) (boundary or embedded edges intersect)"
    )]
    Crossing(f64, f64),
    /// A coordinate the triangulation cannot take.
    #[error("a coordinate is not finite or too large for the triangulation: {0}")]
    Insertion(String),
    /// The (u,v) triangulation folds on the surface.
    #[error(
        "the surface is too coarsely sampled to connect its bubbles ({0}); \
         a smaller size (at most about a fifth of the smallest radius of curvature) works"
    )]
    Coarse(String),
}

/// Why a volume could not be connected.
#[derive(Debug, thiserror::Error)]
pub enum Connect3dError {
    /// The Delaunay kernel refused the points.
    #[error("Delaunay tetrahedralization failed: {0}")]
    Delaunay(String),
    /// Boundary triangles missing from the tetrahedralization.
    #[error(
        "{missing} boundary triangle(s) are not faces of the tetrahedralization and no interior \
         node blocks them (first near ({x:.6}, {y:.6}, {z:.6})); the surface mesh is not \
         Delaunay there — try a finer size"
    )]
    NotConforming {
        /// How many are missing.
        missing: usize,
        /// x of a point near the first.
        x: f64,
        /// y of that point.
        y: f64,
        /// z of that point.
        z: f64,
        /// Indices into the boundary triangles of those missing (at most
        /// `MAX_REPORTED`), so that the faces they belong to can be
        /// meshed finer.
        triangles: Vec<u32>,
    },
    /// The tetrahedra inside the boundary reach the convex hull.
    #[error("the boundary mesh does not close the volume: the tetrahedra inside reach the convex hull near ({x:.6}, {y:.6}, {z:.6})")]
    Leak {
        /// x of a point where.
        x: f64,
        /// y of that point.
        y: f64,
        /// z of that point.
        z: f64,
    },
    /// Two boundary nodes at one point.
    #[error("two boundary nodes coincide at ({x:.6}, {y:.6}, {z:.6})")]
    Duplicate {
        /// x of the point.
        x: f64,
        /// y of the point.
        y: f64,
        /// z of the point.
        z: f64,
    },
}

/// Why a set of triangles is not a closed shell.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ShellError {
    /// A mesh edge used by other than two triangles: the shell is open or
    /// non-manifold there.
    #[error(
        "the boundary is not closed: the mesh edge ({:.6}, {:.6}, {:.6})–({:.6}, {:.6}, {:.6}) \
         belongs to {triangles} triangle(s), not 2",
        a.x, a.y, a.z, b.x, b.y, b.z
    )]
    NotClosed {
        /// The edge's ends.
        a: P3,
        /// The edge's other end.
        b: P3,
        /// How many triangles use it.
        triangles: usize,
    },
}
