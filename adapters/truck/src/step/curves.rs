//! STEP curves without a bubblemesh-analytic counterpart: `PARABOLA`,
//! `OFFSET_CURVE_3D` (where it has no exact form), `COMPOSITE_CURVE`, and
//! a curve moved and scaled as a whole (a pcurve's image, evaluated on the
//! surface as the file writes it, then placed).
//!
//! Every curve here gives exact first and second derivatives of its point
//! map (the offset curve's second derivative needs the basis's third, taken
//! by a central difference of the basis's exact second derivative).

use std::sync::Arc;

use bubblemesh_core::geom::{Curve, P3, V3};

use super::geometry::Rigid;

/// ISO 10303-42 parabola: C(t) = o + f (t² x + 2 t y), over `[t0, t1]`;
/// `f` is the focal distance, the focus at o + f x.
#[derive(Debug, Clone)]
pub struct Parabola {
    pub o: P3,
    pub x: V3,
    pub y: V3,
    pub f: f64,
    pub t0: f64,
    pub t1: f64,
}

impl Parabola {
    /// The parameter of the point of the parabola nearest in its y
    /// coordinate to `p` (exact for points on it).
    pub fn parameter_of(&self, p: &P3) -> f64 {
        (p - self.o).dot(&self.y) / (2.0 * self.f)
    }
}

impl Curve for Parabola {
    fn interval(&self) -> (f64, f64) {
        (self.t0, self.t1)
    }
    fn point(&self, t: f64) -> P3 {
        self.o + (self.x * (t * t) + self.y * (2.0 * t)) * self.f
    }
    fn d1(&self, t: f64) -> V3 {
        (self.x * (2.0 * t) + self.y * 2.0) * self.f
    }
    fn d2(&self, _t: f64) -> V3 {
        self.x * (2.0 * self.f)
    }
}

/// ISO 10303-42 `OFFSET_CURVE_3D`: O(t) = C(t) + d N(t),
/// N = (V × C') / |V × C'| for the reference direction V (as OpenCascade
/// reads it: its `Geom_OffsetCurve` along C' × V, by −d). Its
/// parametrization is the basis's.
#[derive(Debug, Clone)]
pub struct OffsetCurve {
    pub basis: Arc<dyn Curve>,
    pub d: f64,
    pub v: V3,
}

impl OffsetCurve {
    /// C''' by a central difference of C'' (the trait gives no third
    /// derivative), one-sided at the ends of the interval.
    fn d3(&self, t: f64) -> V3 {
        let (a, b) = self.basis.interval();
        let h = 1e-4 * (b - a).abs().clamp(1e-6, 1e6);
        let (lo, hi) = ((t - h).max(a), (t + h).min(b));
        if hi - lo <= 0.0 {
            return V3::zeros();
        }
        (self.basis.d2(hi) - self.basis.d2(lo)) / (hi - lo)
    }
    /// N, N', N'' at t.
    fn frame(&self, t: f64) -> (V3, V3, V3) {
        let w = self.v.cross(&self.basis.d1(t));
        let w1 = self.v.cross(&self.basis.d2(t));
        let w2 = self.v.cross(&self.d3(t));
        let l = w.norm();
        if !(l > 0.0) {
            return (V3::zeros(), V3::zeros(), V3::zeros());
        }
        let n = w / l;
        // l' = n·w', n' = (w' − n l') / l, l'' = n'·w' + n·w''
        let l1 = n.dot(&w1);
        let n1 = (w1 - n * l1) / l;
        let l2 = n1.dot(&w1) + n.dot(&w2);
        let n2 = (w2 - n1 * l1 - n * l2 - n1 * l1) / l;
        (n, n1, n2)
    }
}

impl Curve for OffsetCurve {
    fn interval(&self) -> (f64, f64) {
        self.basis.interval()
    }
    fn point(&self, t: f64) -> P3 {
        self.basis.point(t) + self.frame(t).0 * self.d
    }
    fn d1(&self, t: f64) -> V3 {
        self.basis.d1(t) + self.frame(t).1 * self.d
    }
    fn d2(&self, t: f64) -> V3 {
        self.basis.d2(t) + self.frame(t).2 * self.d
    }
}

/// One segment of a [`Composite`]: `curve` over `[a, b]` of its own
/// parameter, run backwards when `reversed`, over `(b − a) / k` of the
/// composite's parameter (`k`: own parameter per composite parameter; 1
/// but for conics in a file whose angles are degrees, and reparametrised
/// segments).
#[derive(Debug, Clone)]
pub struct Segment {
    pub curve: Arc<dyn Curve>,
    pub a: f64,
    pub b: f64,
    pub reversed: bool,
    pub k: f64,
}

/// Segments joined end to end (ISO 10303-42 `composite_curve`): the
/// composite parameter runs over `[0, Σ l_i]`, l_i = (b_i − a_i) / k_i the
/// segment's parameter length in the file's terms, segment i over
/// `[s_i, s_i + l_i]` with its own parameter a_i + k_i (t − s_i) (or
/// b_i − k_i (t − s_i) for a reversed segment). Continuous where the
/// segments meet; derivatives are those of the segment (one-sided at a
/// joint).
#[derive(Debug, Clone)]
pub struct Composite {
    segs: Vec<Segment>,
    starts: Vec<f64>,
    len: f64,
}

impl Composite {
    /// `None` when there are no segments or one has `b ≤ a`.
    pub fn new(segs: Vec<Segment>) -> Option<Self> {
        if segs.is_empty() || segs.iter().any(|s| !(s.b > s.a) || !(s.k > 0.0)) {
            return None;
        }
        let mut starts = Vec::with_capacity(segs.len());
        let mut s = 0.0;
        for g in &segs {
            starts.push(s);
            s += (g.b - g.a) / g.k;
        }
        Some(Composite {
            segs,
            starts,
            len: s,
        })
    }
    pub fn segments(&self) -> &[Segment] {
        &self.segs
    }
    /// The composite parameter where segment `k` starts.
    #[cfg(test)]
    pub fn start_of(&self, k: usize) -> f64 {
        self.starts[k]
    }
    /// The segment at composite parameter `t`, the segment's own parameter
    /// there, and d(own)/dt.
    fn locate(&self, t: f64) -> (&Segment, f64, f64) {
        let k = match self.starts.partition_point(|&s| s <= t) {
            0 => 0,
            k => k - 1,
        };
        let g = &self.segs[k];
        let local = ((t - self.starts[k]) * g.k).clamp(0.0, g.b - g.a);
        if g.reversed {
            (g, g.b - local, -g.k)
        } else {
            (g, g.a + local, g.k)
        }
    }
}

impl Curve for Composite {
    fn interval(&self) -> (f64, f64) {
        (0.0, self.len)
    }
    fn point(&self, t: f64) -> P3 {
        let (g, u, _) = self.locate(t);
        g.curve.point(u)
    }
    fn d1(&self, t: f64) -> V3 {
        let (g, u, s) = self.locate(t);
        g.curve.d1(u) * s
    }
    fn d2(&self, t: f64) -> V3 {
        let (g, u, s) = self.locate(t);
        g.curve.d2(u) * (s * s)
    }
}

/// A curve scaled about the origin by `scale`, then moved by `xf`.
#[derive(Debug, Clone)]
pub struct Moved {
    pub inner: Arc<dyn Curve>,
    pub scale: f64,
    pub xf: Rigid,
}

impl Curve for Moved {
    fn interval(&self) -> (f64, f64) {
        self.inner.interval()
    }
    fn point(&self, t: f64) -> P3 {
        self.xf
            .point(&P3::from(self.inner.point(t).coords * self.scale))
    }
    fn d1(&self, t: f64) -> V3 {
        self.xf.vector(&(self.inner.d1(t) * self.scale))
    }
    fn d2(&self, t: f64) -> V3 {
        self.xf.vector(&(self.inner.d2(t) * self.scale))
    }
    // the inner curve's own (one NURBS evaluation instead of three)
    fn derivs(&self, t: f64) -> (P3, V3, V3) {
        let (p, d1, d2) = self.inner.derivs(t);
        (
            self.xf.point(&P3::from(p.coords * self.scale)),
            self.xf.vector(&(d1 * self.scale)),
            self.xf.vector(&(d2 * self.scale)),
        )
    }
    fn tangent(&self, t: f64) -> (P3, V3) {
        let (p, d1) = self.inner.tangent(t);
        (
            self.xf.point(&P3::from(p.coords * self.scale)),
            self.xf.vector(&(d1 * self.scale)),
        )
    }
}

/// `inner` over another interval (its point map unchanged): an unbounded
/// line of the file over a finite range.
#[derive(Debug, Clone)]
pub struct Ranged {
    pub inner: Arc<dyn Curve>,
    pub t0: f64,
    pub t1: f64,
}

impl Curve for Ranged {
    fn interval(&self) -> (f64, f64) {
        (self.t0, self.t1)
    }
    fn point(&self, t: f64) -> P3 {
        self.inner.point(t)
    }
    fn d1(&self, t: f64) -> V3 {
        self.inner.d1(t)
    }
    fn d2(&self, t: f64) -> V3 {
        self.inner.d2(t)
    }
    fn derivs(&self, t: f64) -> (P3, V3, V3) {
        self.inner.derivs(t)
    }
    fn tangent(&self, t: f64) -> (P3, V3) {
        self.inner.tangent(t)
    }
}

/// A parameter-space curve with its coordinates mapped affinely: (su x,
/// sv y + ov, z) (a pcurve written in degrees on a surface whose angles are
/// radians; a cone's height from its placement as slant from its apex).
#[derive(Debug, Clone)]
pub struct ParamScaled {
    pub inner: Arc<dyn Curve>,
    pub su: f64,
    pub sv: f64,
    pub ov: f64,
}

impl ParamScaled {
    fn map(&self, v: V3) -> V3 {
        V3::new(v.x * self.su, v.y * self.sv, v.z)
    }
}

impl Curve for ParamScaled {
    fn interval(&self) -> (f64, f64) {
        self.inner.interval()
    }
    fn point(&self, t: f64) -> P3 {
        P3::from(self.map(self.inner.point(t).coords) + V3::new(0.0, self.ov, 0.0))
    }
    fn d1(&self, t: f64) -> V3 {
        self.map(self.inner.d1(t))
    }
    fn d2(&self, t: f64) -> V3 {
        self.map(self.inner.d2(t))
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use bubblemesh_analytic::{CircleArc, EllipseArc, Line, Nurbs};

    /// First and second derivatives of `c` against central differences of
    /// its points and first derivatives, at interior parameters away from
    /// `skip` (joints).
    pub(crate) fn check_derivatives(c: &dyn Curve, skip: &[f64], what: &str) {
        let (a, b) = c.interval();
        let h = 1e-5 * (b - a);
        for k in 1..40 {
            let t = a + (b - a) * k as f64 / 40.0;
            if skip.iter().any(|s| (s - t).abs() < 4.0 * h) {
                continue;
            }
            let scale = c.d1(t).norm().max(1e-3);
            let fd1 = (c.point(t + h) - c.point(t - h)) / (2.0 * h);
            let e1 = (fd1 - c.d1(t)).norm() / scale;
            assert!(e1 < 1e-6, "{what}: d1 at t = {t} off by {e1} (relative)");
            let fd2 = (c.d1(t + h) - c.d1(t - h)) / (2.0 * h);
            let s2 = c.d2(t).norm().max(scale);
            let e2 = (fd2 - c.d2(t)).norm() / s2;
            assert!(e2 < 1e-5, "{what}: d2 at t = {t} off by {e2} (relative)");
        }
    }

    #[test]
    fn parabola_derivatives_and_focus() {
        let p = Parabola {
            o: P3::new(1.0, 2.0, 3.0),
            x: V3::x(),
            y: V3::z(),
            f: 0.5,
            t0: -2.0,
            t1: 3.0,
        };
        check_derivatives(&p, &[], "parabola");
        // every point is as far from the focus as from the directrix
        let focus = p.o + p.x * p.f;
        for k in 0..=10 {
            let q = p.point(-2.0 + 0.5 * k as f64);
            let to_directrix = (q - p.o).dot(&p.x) + p.f;
            assert!(((q - focus).norm() - to_directrix).abs() < 1e-12);
            assert!((p.parameter_of(&q) - (-2.0 + 0.5 * k as f64)).abs() < 1e-12);
        }
    }

    #[test]
    fn offset_curve_derivatives_and_distance() {
        let e: Arc<dyn Curve> =
            Arc::new(EllipseArc::new(P3::origin(), V3::x(), V3::y(), 3.0, 1.0, 0.2, 5.5).unwrap());
        let n: Arc<dyn Curve> = Arc::new(
            Nurbs::new(
                3,
                vec![
                    P3::new(0.0, 0.0, 0.0),
                    P3::new(1.0, 2.0, 0.5),
                    P3::new(3.0, -1.0, 1.0),
                    P3::new(4.0, 1.0, 0.0),
                    P3::new(6.0, 0.0, -1.0),
                ],
                None,
                vec![0.0, 0.0, 0.0, 0.0, 0.5, 1.0, 1.0, 1.0, 1.0],
            )
            .unwrap(),
        );
        // the B-spline's inner knot (its third derivative jumps there)
        for (basis, what, skip) in [
            (e, "offset ellipse", vec![]),
            (n, "offset B-spline", vec![0.5]),
        ] {
            let o = OffsetCurve {
                basis: basis.clone(),
                d: 0.3,
                v: V3::new(0.1, 0.2, 1.0).normalize(),
            };
            check_derivatives(&o, &skip, what);
            for k in 1..20 {
                let t = basis.interval().0
                    + (basis.interval().1 - basis.interval().0) * k as f64 / 20.0;
                let off = o.point(t) - basis.point(t);
                assert!((off.norm() - 0.3).abs() < 1e-12);
                assert!(off.dot(&basis.d1(t)).abs() < 1e-9 * basis.d1(t).norm());
            }
        }
    }

    #[test]
    fn composite_and_moved_derivatives() {
        let l: Arc<dyn Curve> =
            Arc::new(Line::new(P3::new(0.0, 0.0, 0.0), P3::new(2.0, 0.0, 0.0)).unwrap());
        let c: Arc<dyn Curve> = Arc::new(
            CircleArc::with_basis(P3::new(2.0, 1.0, 0.0), V3::x(), V3::y(), 1.0, -1.5, 1.5)
                .unwrap(),
        );
        let comp = Composite::new(vec![
            Segment {
                curve: l.clone(),
                a: 0.0,
                b: 1.0,
                reversed: false,
                k: 1.0,
            },
            Segment {
                curve: c,
                a: -std::f64::consts::FRAC_PI_2,
                b: std::f64::consts::FRAC_PI_2,
                reversed: false,
                // as if in degrees
                k: std::f64::consts::PI / 180.0,
            },
            Segment {
                curve: l,
                a: 0.25,
                b: 1.0,
                reversed: true,
                k: 0.5,
            },
        ])
        .unwrap();
        let joints = [comp.start_of(1), comp.start_of(2)];
        check_derivatives(&comp, &joints, "composite");
        // continuous at the first joint, reversed segment ends at its a
        let (_, hi) = comp.interval();
        assert!((comp.point(joints[0] - 1e-12) - comp.point(joints[0])).norm() < 1e-9);
        assert!((comp.point(hi) - P3::new(0.5, 0.0, 0.0)).norm() < 1e-12);
        let mut xf = Rigid::identity();
        xf.shift = V3::new(1.0, 2.0, 3.0);
        xf.rot = nalgebra::Rotation3::from_axis_angle(&V3::z_axis(), 0.7).into_inner();
        let m = Moved {
            inner: Arc::new(comp),
            scale: 25.4,
            xf,
        };
        check_derivatives(&m, &joints, "moved composite");
    }
}
