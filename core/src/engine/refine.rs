//! Local refinement where the geometry needs more nodes than the requested
//! spacing gives: a face whose bubbles cannot be connected into a valid
//! triangulation (a fillet or small sphere sampled too coarsely, a sliver
//! face narrower than the spacing, boundary chords that cross in (u,v)) is
//! meshed again with a finer spacing inside it and on its boundary edges.
//!
//! Each failed attempt raises the face's *level* by one: its interior
//! spacing is d · 2^-level, and each of its edges gets spacing d · 2^-level
//! with at least level + 1 segments (so an edge far shorter than d is split
//! too). Neighbouring faces share the refined edges and are meshed again
//! with them. Levels stop at [`MAX_LEVEL`]; a face that still fails is an
//! error. Every refinement is listed in the report with its reason, since
//! there the mesh departs from the requested spacing.
//!
//! Boundary triangles missing from a volume's tetrahedralization are cured
//! *locally* instead: each becomes a *place*, a ball around the triangle's
//! circumball, inside which the spacing is at most t · 2^-level, t the
//! smaller of d and the triangle's own size (a triangle on the wall of a
//! hole far smaller than d is refined at the hole's scale), graded back to
//! d outside it (the spacing grows by at most [`PLACE_GRADING`] per unit
//! length, so the packing stays smooth and the extra nodes grow only with
//! the logarithm of d/t). A finer surface mesh there makes
//! the triangles' balls smaller than the gap to the other side of a thin
//! wall; refining whole faces did the same at the cost of every face
//! meshed 4^level times denser (a thin-walled bottle at diag/20 ran for
//! minutes).
//!
//! Refinement by places stops when an attempt's surface mesh has grown
//! past [`PLACE_GROWTH`] times that of the first attempt that asked for
//! places: where faces meet at a needle-sharp angle the missing triangles
//! come back at every level, and deepening them only costs time and
//! memory. The error then says so and names the place.

use crate::geom::P3;
use crate::model::{EntityRef, Model};
use crate::spacing::{Spacing, SpacingQuery};

/// The most refinement rounds of one model: each round meshes the whole
/// model again, so this bounds the time. Faces often fail one after
/// another as their neighbours' edges are refined: `as_0049` needs 9 rounds
/// and `as_0085` 7 at diag/25 (with 6, both were refused).
pub const MAX_ROUNDS: usize = 16;

/// The finest level: spacing d/16 and at least 5 segments per edge.
pub const MAX_LEVEL: u8 = 4;

/// The finest level of a place: spacing d/64.
pub const MAX_PLACE_LEVEL: u8 = 6;

/// How fast the spacing returns to the requested one outside a place:
/// model units of spacing per model unit of distance.
pub const PLACE_GRADING: f64 = 0.25;

/// How many times the surface mesh of the first attempt that asked for
/// places an attempt's may have before refinement by places stops. A place
/// that cannot be cured (faces meeting at a needle-sharp angle, where the
/// missing triangles are as many at every level, a level finer each round)
/// otherwise deepens to [`MAX_PLACE_LEVEL`]: `as_0082` at diag/15 grew from
/// 8,624 boundary triangles to 145,598 in seven rounds and six minutes, and
/// the mesh it then gave had 7,507 flat tetrahedra and most edges a
/// hundredth of the spacing. The places that cure a wall thinner than the
/// spacing grow it far less (`as_0083` at diag/20: 1.6-fold).
pub const PLACE_GROWTH: f64 = 4.0;

/// A ball meshed finer than requested.
#[derive(Clone, Debug)]
struct Place {
    centre: P3,
    /// Radius of the ball at the finest spacing, model units.
    radius: f64,
    /// The requested spacing at the centre.
    d_req: f64,
    /// The scale of level 0: the smaller of `d_req` and √3 times the
    /// missing triangle's circumradius (an equilateral triangle's side).
    scale: f64,
    level: u8,
    reason: String,
}

impl Place {
    /// The finest spacing, inside the ball.
    fn target(&self) -> f64 {
        self.scale * 0.5f64.powi(self.level as i32)
    }

    /// The largest spacing the place allows at `p`: [`Place::target`]
    /// inside the ball, growing by [`PLACE_GRADING`] per unit of distance
    /// outside it.
    fn cap(&self, p: &P3) -> f64 {
        let out = ((p - self.centre).norm() - self.radius).max(0.0);
        self.target() + PLACE_GRADING * out
    }

    /// The distance beyond which the cap exceeds the requested spacing.
    fn reach(&self) -> f64 {
        self.radius + (self.d_req - self.target()).max(0.0) / PLACE_GRADING
    }
}

/// Refinement levels of faces and edges (0: the requested spacing), and
/// places refined in model space.
#[derive(Clone, Debug, Default)]
pub(crate) struct Refinement {
    face: Vec<u8>,
    edge: Vec<u8>,
    /// Why each face was refined (the last error it gave).
    reason: Vec<Option<String>>,
    places: Vec<Place>,
    /// The places by cell of a grid of cell `cell` (their reach boxes).
    grid: std::collections::HashMap<[i64; 3], Vec<u32>>,
    cell: f64,
}

/// One refined place, for the report.
#[derive(Clone, Debug, serde::Serialize)]
pub struct RefinedPlace {
    /// The ball's centre.
    pub centre: [f64; 3],
    /// The ball's radius (the spacing grades back to the requested one
    /// within a few spacings outside it).
    pub radius: f64,
    /// The spacing inside the ball as a fraction of the requested one.
    pub spacing_factor: f64,
    /// The error the place gave at the coarser level.
    pub reason: String,
}

/// One refined face, for the report.
#[derive(Clone, Debug, serde::Serialize)]
pub struct RefinedFace {
    /// The face's id.
    pub face: u32,
    /// The face's name in the model, if it has one.
    pub name: Option<String>,
    /// Interior and boundary spacing as a fraction of the requested one.
    pub spacing_factor: f64,
    /// The error the face gave at the coarser level.
    pub reason: String,
}

impl Refinement {
    /// No refinement: every face and edge at level 0.
    pub fn new(model: &Model) -> Self {
        Refinement {
            face: vec![0; model.faces.len()],
            edge: vec![0; model.edges.len()],
            reason: vec![None; model.faces.len()],
            ..Default::default()
        }
    }

    /// Whether nothing is refined (the requested spacing everywhere).
    pub fn is_empty(&self) -> bool {
        self.face.iter().all(|&l| l == 0)
            && self.edge.iter().all(|&l| l == 0)
            && self.places.is_empty()
    }

    /// Refines the balls `spots` (centre, radius) one level further: a
    /// spot that overlaps a place already refined raises that place's
    /// level (once per call) and widens it to cover the spot; the others
    /// become places of level 1. Returns `false` when every spot lies in a
    /// place at [`MAX_PLACE_LEVEL`].
    /// `d_at` is the requested spacing at a point.
    pub fn bump_spots(
        &mut self,
        spots: &[(P3, f64)],
        d_at: impl Fn(&P3) -> f64,
        reason: &str,
    ) -> bool {
        let mut raised = vec![false; self.places.len()];
        let mut any = false;
        for &(c, r) in spots {
            if !(r.is_finite() && r > 0.0) {
                continue;
            }
            let hit = (0..self.places.len()).find(|&k| {
                let p = &self.places[k];
                (c - p.centre).norm() <= p.radius + r
            });
            match hit {
                Some(k) => {
                    let p = &mut self.places[k];
                    let widened = ((c - p.centre).norm() + r).min(4.0 * p.scale);
                    p.radius = p.radius.max(widened);
                    if k < raised.len() && !raised[k] && p.level < MAX_PLACE_LEVEL {
                        p.level += 1;
                        p.reason = reason.to_string();
                        raised[k] = true;
                        any = true;
                    }
                }
                None => {
                    let d_req = d_at(&c);
                    if !(d_req.is_finite() && d_req > 0.0) {
                        continue;
                    }
                    self.places.push(Place {
                        centre: c,
                        radius: r,
                        d_req,
                        scale: d_req.min(3f64.sqrt() * r),
                        level: 1,
                        reason: reason.to_string(),
                    });
                    any = true;
                }
            }
        }
        self.index_places();
        any
    }

    /// Rebuilds the grid over the places' reach.
    fn index_places(&mut self) {
        self.grid.clear();
        self.cell = self
            .places
            .iter()
            .map(Place::reach)
            .fold(0.0, f64::max)
            .max(f64::MIN_POSITIVE);
        for (k, p) in self.places.iter().enumerate() {
            let (lo, hi) = (
                cell_of(
                    &(p.centre - nalgebra::Vector3::repeat(p.reach())),
                    self.cell,
                ),
                cell_of(
                    &(p.centre + nalgebra::Vector3::repeat(p.reach())),
                    self.cell,
                ),
            );
            for i in lo[0]..=hi[0] {
                for j in lo[1]..=hi[1] {
                    for l in lo[2]..=hi[2] {
                        self.grid.entry([i, j, l]).or_default().push(k as u32);
                    }
                }
            }
        }
    }

    /// The largest spacing the places allow at `p` (infinite outside
    /// them all).
    fn place_cap(&self, p: &P3) -> f64 {
        if self.places.is_empty() {
            return f64::INFINITY;
        }
        self.grid
            .get(&cell_of(p, self.cell))
            .map_or(f64::INFINITY, |ks| {
                ks.iter()
                    .map(|&k| self.places[k as usize].cap(p))
                    .fold(f64::INFINITY, f64::min)
            })
    }

    /// The refinement level of face `f` (0: the requested spacing).
    pub fn face_level(&self, f: usize) -> u8 {
        self.face.get(f).copied().unwrap_or(0)
    }

    /// A fingerprint of every place that may change the spacing inside the
    /// box [`lo`, `hi`]: those whose reach, widened by a grid cell (the grid
    /// lists a place in every cell its reach box touches), meets the box,
    /// with everything that sets their cap. Equal fingerprints mean equal
    /// [`Refinement::place_cap`] everywhere in the box.
    pub(crate) fn places_key(&self, lo: &P3, hi: &P3) -> Vec<u64> {
        let mut key = Vec::new();
        for (k, p) in self.places.iter().enumerate() {
            if self.place_reaches(p, lo, hi) {
                key.push(k as u64);
                key.push(p.level as u64);
                key.extend(
                    [
                        p.centre.x, p.centre.y, p.centre.z, p.radius, p.d_req, p.scale,
                    ]
                    .map(f64::to_bits),
                );
            }
        }
        if !key.is_empty() {
            key.push(self.cell.to_bits());
        }
        key
    }

    /// Whether place `p`'s reach, widened by a grid cell (see
    /// [`Refinement::places_key`]), meets the box [`lo`, `hi`].
    fn place_reaches(&self, p: &Place, lo: &P3, hi: &P3) -> bool {
        let r = p.reach() + self.cell;
        (0..3).all(|i| p.centre[i] + r >= lo[i] && p.centre[i] - r <= hi[i])
    }

    /// Whether some place may change the spacing inside [`lo`, `hi`]
    /// ([`Refinement::places_key`] not empty).
    pub(crate) fn any_place_reaches(&self, lo: &P3, hi: &P3) -> bool {
        self.places.iter().any(|p| self.place_reaches(p, lo, hi))
    }

    /// The place nearest `at` (a failing spot's centre), for an error:
    /// "within r of (x, y, z), at f of the spacing".
    pub fn place_near(&self, at: &P3) -> Option<String> {
        self.places
            .iter()
            .min_by(|a, b| {
                let gap = |p: &Place| (p.centre - at).norm() - p.radius;
                gap(a).total_cmp(&gap(b))
            })
            .map(|p| {
                format!(
                    "within {:.6} of ({:.6}, {:.6}, {:.6}), at {:.3e} of the spacing",
                    p.radius,
                    p.centre.x,
                    p.centre.y,
                    p.centre.z,
                    p.target() / p.d_req
                )
            })
    }

    /// The refined places, for the report.
    pub fn places(&self) -> Vec<RefinedPlace> {
        self.places
            .iter()
            .map(|p| RefinedPlace {
                centre: [p.centre.x, p.centre.y, p.centre.z],
                radius: p.radius,
                spacing_factor: p.target() / p.d_req,
                reason: p.reason.clone(),
            })
            .collect()
    }

    /// Refines `faces` and `edges` one level further (the faces' boundary
    /// edges with them). Returns `false` when none of them can be refined
    /// further.
    /// `reasons[k]` is why `faces[k]` failed; faces beyond it take `reason`.
    pub fn bump(
        &mut self,
        model: &Model,
        faces: &[u32],
        reasons: &[String],
        edges: &[u32],
        reason: &str,
    ) -> bool {
        let mut any = false;
        for (k, &f) in faces.iter().enumerate() {
            let reason = reasons.get(k).map_or(reason, |r| r.as_str());
            let Some(l) = self.face.get_mut(f as usize) else {
                continue;
            };
            if *l >= MAX_LEVEL {
                continue;
            }
            *l += 1;
            let level = *l;
            any = true;
            self.reason[f as usize] = Some(reason.to_string());
            for u in model.faces[f as usize]
                .loops
                .iter()
                .flat_map(|l| l.edges.iter())
            {
                let e = &mut self.edge[u.edge as usize];
                *e = (*e).max(level);
            }
            for &e in &model.faces[f as usize].embedded_edges {
                let e = &mut self.edge[e as usize];
                *e = (*e).max(level);
            }
        }
        for &e in edges {
            if let Some(l) = self.edge.get_mut(e as usize) {
                if *l < MAX_LEVEL {
                    *l += 1;
                    any = true;
                }
            }
        }
        any
    }

    /// The refinement level of edge `e` (0: the requested spacing).
    pub fn edge_level(&self, e: usize) -> u8 {
        self.edge.get(e).copied().unwrap_or(0)
    }

    /// The least number of segments of edge `e`.
    pub fn min_segments(&self, e: usize) -> usize {
        self.edge.get(e).map_or(1, |&l| l as usize + 1)
    }

    fn factor(&self, e: EntityRef) -> f64 {
        let level = match e.dim {
            1 => self.edge.get(e.id as usize).copied().unwrap_or(0),
            2 => self.face.get(e.id as usize).copied().unwrap_or(0),
            _ => 0,
        };
        0.5f64.powi(level as i32)
    }

    /// `d`, the spacing asked at `q`, with the refinement applied.
    fn apply(&self, q: &SpacingQuery, d: f64) -> f64 {
        let d = d * self.factor(q.entity);
        if q.entity.dim <= 2 {
            d.min(self.place_cap(&q.point))
        } else {
            d
        }
    }

    /// The refined faces, for the report.
    pub fn faces(&self, model: &Model) -> Vec<RefinedFace> {
        (0..self.face.len())
            .filter(|&f| self.face[f] > 0)
            .map(|f| RefinedFace {
                face: f as u32,
                name: model.faces[f].name.clone(),
                spacing_factor: 0.5f64.powi(self.face[f] as i32),
                reason: self.reason[f].clone().unwrap_or_default(),
            })
            .collect()
    }
}

/// The requested spacing with the refinement applied: d times the factor
/// of the entity the query is on (vertices and volumes keep d).
pub(crate) struct Refined<'a> {
    pub inner: &'a dyn Spacing,
    pub refinement: &'a Refinement,
    /// Per face and per edge, the box its mesh of the last attempt lies in
    /// (grown to cover the geometry between its nodes), where there was
    /// one: an entity at level 0 that no place reaches keeps `inner`'s
    /// constant spacing.
    pub face_boxes: &'a [Option<(P3, P3)>],
    pub edge_boxes: &'a [Option<(P3, P3)>],
}

impl Refined<'_> {
    /// The factor the refinement multiplies `inner`'s spacing by on entity
    /// `e` (an edge or a face), where that is all it does (no place reaches
    /// the box of its last mesh); `None` where a place may cap it or the
    /// entity has no box yet.
    fn scale(&self, e: crate::model::EntityRef) -> Option<f64> {
        let boxes = match e.dim {
            1 => self.edge_boxes,
            2 => self.face_boxes,
            _ => return None,
        };
        boxes
            .get(e.id as usize)
            .copied()
            .flatten()
            .is_some_and(|(lo, hi)| !self.refinement.any_place_reaches(&lo, &hi))
            .then(|| self.refinement.factor(e))
    }
}

impl Spacing for Refined<'_> {
    fn spacing(&self, q: &SpacingQuery) -> f64 {
        self.refinement.apply(q, self.inner.spacing(q))
    }
    fn spacing_batch(&self, qs: &[SpacingQuery], out: &mut [f64]) {
        self.inner.spacing_batch(qs, out);
        for (q, o) in qs.iter().zip(out.iter_mut()) {
            *o = self.refinement.apply(q, *o);
        }
    }
    fn constant(&self) -> Option<f64> {
        if self.refinement.is_empty() {
            self.inner.constant()
        } else {
            None
        }
    }
    fn constant_on(&self, e: crate::model::EntityRef) -> Option<f64> {
        // an edge or face the refinement does not touch stays uniform, so
        // that its mesh is the one it had (and is replayed: engine::memo);
        // one it only refines by a factor is uniform at the finer spacing
        if self.refinement.is_empty() {
            return self.inner.constant_on(e);
        }
        let f = self.scale(e)?;
        self.inner.constant_on(e).map(|d| d * f)
    }
}

/// The grid cell of `p` for cells of size `h`.
fn cell_of(p: &P3, h: f64) -> [i64; 3] {
    [0, 1, 2].map(|i| (p[i] / h).floor() as i64)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn query(p: P3, dim: u8) -> SpacingQuery {
        SpacingQuery {
            point: p,
            entity: EntityRef::new(dim, 0),
            params: [0.0, 0.0],
        }
    }

    /// A missing triangle far smaller than the spacing (the wall of a tiny
    /// hole) is refined at its own scale, and the spacing grades back to
    /// the requested one with slope at most `PLACE_GRADING`; volumes keep
    /// the requested spacing.
    #[test]
    fn a_place_refines_at_the_triangles_scale_and_grades_back() {
        let mut r = Refinement::default();
        let c = P3::new(10.0, -3.0, 2.0);
        assert!(r.bump_spots(&[(c, 0.01)], |_| 1.0, "missing"));
        let d = |p: P3, dim: u8| r.apply(&query(p, dim), 1.0);
        let inside = d(c, 2);
        assert!(
            (inside - 3f64.sqrt() * 0.01 * 0.5).abs() < 1e-12,
            "{inside}"
        );
        assert_eq!(d(c, 3), 1.0);
        let mut prev = inside;
        for k in 1..=2000 {
            let p = c + nalgebra::Vector3::new(k as f64 * 0.005, 0.0, 0.0);
            let now = d(p, 1);
            assert!(now >= prev && now - prev <= PLACE_GRADING * 0.005 + 1e-12);
            prev = now;
        }
        assert_eq!(prev, 1.0, "back to the requested spacing 10 units away");
        let report = r.places();
        assert_eq!(report.len(), 1);
        assert!(report[0].spacing_factor < 0.01);
    }

    /// A face the refinement only halves (no place reaches its box) has a
    /// uniform spacing where the requested one is uniform: `constant_on`
    /// says so, with the value `spacing` gives on it (stage 2 then packs
    /// it as a uniform face, without the graded faces' pressure); where a
    /// place may reach it, or it has no box yet, it does not.
    #[test]
    fn a_face_refined_by_levels_alone_keeps_a_uniform_spacing() {
        use crate::spacing::{Constant, Spacing};
        let mut r = Refinement {
            face: vec![2, 0, 1, 1],
            edge: vec![0],
            ..Default::default()
        };
        let far = P3::new(100.0, 0.0, 0.0);
        assert!(r.bump_spots(&[(far, 0.1)], |_| 1.0, "missing"));
        let unit = |x: f64| Some((P3::new(x, 0.0, 0.0), P3::new(x + 1.0, 1.0, 1.0)));
        let boxes = [unit(0.0), unit(2.0), Some((far, far)), None];
        let inner = Constant(1.0);
        let refined = Refined {
            inner: &inner,
            refinement: &r,
            face_boxes: &boxes,
            edge_boxes: &[],
        };
        let face = |f: u32| EntityRef::new(2, f);
        assert_eq!(refined.constant_on(face(0)), Some(0.25));
        let on_face = SpacingQuery {
            point: P3::new(0.5, 0.5, 0.5),
            entity: face(0),
            params: [0.0, 0.0],
        };
        assert_eq!(refined.spacing(&on_face), 0.25);
        assert_eq!(refined.constant_on(face(1)), Some(1.0));
        assert_eq!(refined.constant_on(face(2)), None, "a place reaches it");
        assert_eq!(refined.constant_on(face(3)), None, "no box yet");
        assert_eq!(refined.constant_on(EntityRef::new(1, 0)), None, "no box");
    }

    /// A spot that keeps failing raises its place one level per round up to
    /// `MAX_PLACE_LEVEL`, then refinement says it cannot go further; spots
    /// of one round overlapping each other make one place.
    #[test]
    fn a_place_stops_at_its_finest_level() {
        let mut r = Refinement::default();
        let c = P3::new(0.0, 0.0, 0.0);
        let spots = [(c, 0.5), (P3::new(0.3, 0.0, 0.0), 0.5)];
        let mut rounds = 0;
        while r.bump_spots(&spots, |_| 2.0, "missing") {
            rounds += 1;
            assert!(rounds <= 10);
        }
        assert_eq!(rounds, MAX_PLACE_LEVEL as usize);
        assert_eq!(r.places.len(), 1);
        let finest = r.apply(&query(c, 2), 2.0);
        assert!((finest - 2f64.min(3f64.sqrt() * 0.5) / 64.0).abs() < 1e-12);
    }
}
