//! Planar polygon predicates used to validate sampled loops: signed area,
//! point location, distance and segment intersection.
//!
//! All inputs are sampled (x, y) polylines in model units; curved edges are
//! represented by their chords, so the checks are exact for straight sides
//! and accurate to the sampling sag for arcs and NURBS.

/// A 2D point (x, y).
pub(crate) type Xy = [f64; 2];

/// Twice the signed area of the closed polygon `poly` (the last point joins
/// the first): > 0 counter-clockwise, < 0 clockwise.
///
/// Coordinates are taken relative to the first point, so a small loop far
/// from the origin (a unit square at (1e8, 1e8)) keeps its area instead of
/// losing it to cancellation between products of size 1e16.
pub(crate) fn signed_area(poly: &[Xy]) -> f64 {
    let n = poly.len();
    let Some(&o) = poly.first() else {
        return 0.0;
    };
    let mut s = 0.0;
    for i in 0..n {
        let (a, b) = (poly[i], poly[(i + 1) % n]);
        let (ax, ay) = (a[0] - o[0], a[1] - o[1]);
        let (bx, by) = (b[0] - o[0], b[1] - o[1]);
        s += ax * by - ay * bx;
    }
    0.5 * s
}

/// Perimeter of the closed polygon `poly`.
pub(crate) fn perimeter(poly: &[Xy]) -> f64 {
    let n = poly.len();
    (0..n).map(|i| dist(poly[i], poly[(i + 1) % n])).sum()
}

/// Euclidean distance.
pub(crate) fn dist(a: Xy, b: Xy) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

/// Whether `p` is inside the closed polygon `poly` (crossing-number rule;
/// points exactly on the boundary may go either way — callers test the
/// distance to the boundary first).
pub(crate) fn inside(p: Xy, poly: &[Xy]) -> bool {
    let n = poly.len();
    let mut c = false;
    for i in 0..n {
        let (a, b) = (poly[i], poly[(i + 1) % n]);
        if (a[1] > p[1]) != (b[1] > p[1]) {
            let x = a[0] + (p[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0]);
            if p[0] < x {
                c = !c;
            }
        }
    }
    c
}

/// Distance from `p` to the segment [a, b].
pub(crate) fn dist_to_segment(p: Xy, a: Xy, b: Xy) -> f64 {
    dist(p, bubblemesh_core::geom::closest_on_segment(p, a, b))
}

/// (b − a) × (c − a): > 0 when c is left of a→b.
pub(crate) fn orient(a: Xy, b: Xy, c: Xy) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

/// Whether the segments [a, b] and [c, d] meet. With `proper_only`, only a
/// crossing of their interiors counts; otherwise touching and collinear
/// overlap count too. Returns a point of contact (for messages).
pub(crate) fn segments_meet(a: Xy, b: Xy, c: Xy, d: Xy, proper_only: bool) -> Option<Xy> {
    let o1 = orient(a, b, c);
    let o2 = orient(a, b, d);
    let o3 = orient(c, d, a);
    let o4 = orient(c, d, b);
    let proper = ((o1 > 0.0 && o2 < 0.0) || (o1 < 0.0 && o2 > 0.0))
        && ((o3 > 0.0 && o4 < 0.0) || (o3 < 0.0 && o4 > 0.0));
    if proper {
        // Intersection of the supporting lines.
        let t = o3 / (o3 - o4);
        return Some([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]);
    }
    if proper_only {
        return None;
    }
    let on = |p: Xy, q: Xy, r: Xy| {
        // r on segment [p, q], given collinear.
        r[0] >= p[0].min(q[0])
            && r[0] <= p[0].max(q[0])
            && r[1] >= p[1].min(q[1])
            && r[1] <= p[1].max(q[1])
    };
    if o1 == 0.0 && on(a, b, c) {
        return Some(c);
    }
    if o2 == 0.0 && on(a, b, d) {
        return Some(d);
    }
    if o3 == 0.0 && on(c, d, a) {
        return Some(a);
    }
    if o4 == 0.0 && on(c, d, b) {
        return Some(b);
    }
    None
}

/// Whether consecutive segments [a, q] and [q, b] fold back onto each
/// other (collinear, opposite directions), which makes a loop overlap
/// itself.
pub(crate) fn folds_back(a: Xy, q: Xy, b: Xy) -> bool {
    let u = [a[0] - q[0], a[1] - q[1]];
    let v = [b[0] - q[0], b[1] - q[1]];
    let cross = u[0] * v[1] - u[1] * v[0];
    let dot = u[0] * v[0] + u[1] * v[1];
    let scale = (u[0].hypot(u[1])) * (v[0].hypot(v[1]));
    dot > 0.0 && cross.abs() <= 1e-12 * scale
}

/// A segment of a sampled loop or constraint.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Seg {
    pub a: Xy,
    pub b: Xy,
    /// Which loop or constraint the segment belongs to.
    pub owner: usize,
    /// Index along its owner.
    pub index: usize,
    /// The model vertices at `a` and `b`, when they are vertices.
    pub va: Option<u32>,
    pub vb: Option<u32>,
}

impl Seg {
    /// The model vertex that both segments have as an end point, if any.
    pub fn shared_vertex(&self, other: &Seg) -> Option<u32> {
        [self.va, self.vb]
            .into_iter()
            .flatten()
            .find(|v| other.va == Some(*v) || other.vb == Some(*v))
    }
}

/// Length of the common part of [a, b] and [c, d] when c and d lie within
/// `tol` of the line through a and b (0 when they are not collinear or do
/// not overlap).
pub(crate) fn collinear_overlap(a: Xy, b: Xy, c: Xy, d: Xy, tol: f64) -> f64 {
    let l = dist(a, b);
    if !(l > 0.0) {
        return 0.0;
    }
    if orient(a, b, c).abs() > tol * l || orient(a, b, d).abs() > tol * l {
        return 0.0;
    }
    let u = [(b[0] - a[0]) / l, (b[1] - a[1]) / l];
    let tc = (c[0] - a[0]) * u[0] + (c[1] - a[1]) * u[1];
    let td = (d[0] - a[0]) * u[0] + (d[1] - a[1]) * u[1];
    (l.min(tc.max(td)) - tc.min(td).max(0.0)).max(0.0)
}

/// Calls `test(i, j)` for every pair of segments whose x-ranges overlap
/// (sort and sweep, O(n log n + pairs)) and returns the first `Some`.
pub(crate) fn sweep_pairs<T>(
    segs: &[Seg],
    mut test: impl FnMut(&Seg, &Seg) -> Option<T>,
) -> Option<T> {
    let lo = |s: &Seg| s.a[0].min(s.b[0]);
    let hi = |s: &Seg| s.a[0].max(s.b[0]);
    let mut order: Vec<usize> = (0..segs.len()).collect();
    order.sort_by(|&i, &j| lo(&segs[i]).total_cmp(&lo(&segs[j])));
    for (k, &i) in order.iter().enumerate() {
        let si = &segs[i];
        let (ylo, yhi) = (si.a[1].min(si.b[1]), si.a[1].max(si.b[1]));
        for &j in &order[k + 1..] {
            let sj = &segs[j];
            if lo(sj) > hi(si) {
                break;
            }
            if sj.a[1].max(sj.b[1]) < ylo || sj.a[1].min(sj.b[1]) > yhi {
                continue;
            }
            if let Some(r) = test(si, sj) {
                return Some(r);
            }
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn area_and_inside() {
        let sq = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        assert_eq!(signed_area(&sq), 1.0);
        assert!(inside([0.5, 0.5], &sq));
        assert!(!inside([1.5, 0.5], &sq));
        assert_eq!(perimeter(&sq), 4.0);
        assert!((dist_to_segment([0.5, 0.2], [0.0, 0.0], [1.0, 0.0]) - 0.2).abs() < 1e-15);
    }

    #[test]
    fn area_of_a_small_loop_far_from_the_origin_survives() {
        let o = 1e8;
        let sq = [[o, o], [o + 1.0, o], [o + 1.0, o + 1.0], [o, o + 1.0]];
        assert_eq!(signed_area(&sq), 1.0);
        let rev: Vec<Xy> = sq.iter().rev().copied().collect();
        assert_eq!(signed_area(&rev), -1.0);
    }

    #[test]
    fn segment_predicates() {
        assert!(segments_meet([0.0, 0.0], [1.0, 1.0], [0.0, 1.0], [1.0, 0.0], true).is_some());
        assert!(segments_meet([0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [2.0, 1.0], true).is_none());
        assert!(segments_meet([0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [2.0, 1.0], false).is_some());
        assert!(segments_meet([0.0, 0.0], [2.0, 0.0], [1.0, 0.0], [3.0, 0.0], false).is_some());
        assert!(segments_meet([0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [3.0, 0.0], false).is_none());
        assert!(folds_back([0.0, 0.0], [1.0, 0.0], [0.5, 0.0]));
        assert!(!folds_back([0.0, 0.0], [1.0, 0.0], [2.0, 0.0]));
        assert_eq!(
            collinear_overlap([0.0, 0.0], [2.0, 0.0], [1.0, 0.0], [3.0, 0.0], 1e-9),
            1.0
        );
        assert_eq!(
            collinear_overlap([0.0, 0.0], [2.0, 0.0], [3.0, 0.0], [1.5, 0.0], 1e-9),
            0.5
        );
        assert_eq!(
            collinear_overlap([0.0, 0.0], [2.0, 0.0], [1.0, 1.0], [3.0, 0.0], 1e-9),
            0.0
        );
        assert_eq!(
            collinear_overlap([0.0, 0.0], [2.0, 0.0], [2.0, 0.0], [3.0, 0.0], 1e-9),
            0.0
        );
    }
}
