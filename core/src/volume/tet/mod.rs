//! Improvement passes on a volume's tetrahedral mesh, each a function of
//! one [`mesh::TetMesh`] and its own parameters: optimal-Delaunay
//! smoothing ([`odt`]), sliver removal ([`sliver`]), flips ([`flip`]), the
//! mean-quality polish ([`polish`]) and Steiner points for slivers no move
//! can fix ([`steiner`], or in place: [`insert`]). What they share — the objective, the node →
//! tetrahedra table, a node's star — is in [`star`]; the element measures
//! in [`crate::measure`]. Imports run one way: passes → star, measure →
//! the Delaunay kernel.

pub(crate) mod flip;
pub(crate) mod insert;
pub(crate) mod mesh;
pub(crate) mod odt;
pub(crate) mod polish;
pub(crate) mod sliver;
pub(crate) mod star;
pub(crate) mod steiner;

pub use sliver::SliverStats;
