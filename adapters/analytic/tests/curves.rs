//! Exactness of the analytic curves: derivatives against central finite
//! differences, lengths, and classical NURBS identities.

use std::f64::consts::{FRAC_1_SQRT_2, PI, TAU};

use bubblemesh_analytic::{CircleArc, GeometryError, Line, Nurbs};
use bubblemesh_core::geom::{length_between, Curve, P3, V3};

/// Parameters spread over the interval, including points within 1e-3 of
/// each end.
fn params(c: &dyn Curve) -> Vec<f64> {
    let (a, b) = c.interval();
    [
        1e-3,
        0.01,
        0.137,
        0.25,
        0.5,
        0.618,
        0.75,
        0.9,
        0.99,
        1.0 - 1e-3,
    ]
    .iter()
    .map(|f| a + f * (b - a))
    .collect()
}

/// Compares d1 and d2 with central differences of `point` and `d1`.
/// Skips parameters within 2h of `avoid` (knots where d2 jumps).
fn check_derivatives(c: &dyn Curve, avoid: &[f64]) {
    let (a, b) = c.interval();
    let h = 1e-5 * (b - a);
    let scale = (c.approx_length() / (b - a)).max(1e-12);
    for t in params(c) {
        if avoid.iter().any(|k| (t - k).abs() < 2.0 * h) {
            continue;
        }
        let fd1 = (c.point(t + h) - c.point(t - h)) / (2.0 * h);
        let fd2 = (c.d1(t + h) - c.d1(t - h)) / (2.0 * h);
        let fd2b = (c.point(t + h) - c.point(t) * 2.0 + c.point(t - h).coords) / (h * h);
        let e1 = (fd1 - c.d1(t)).norm();
        let e2 = (fd2 - c.d2(t)).norm();
        let e2b = (fd2b - c.d2(t)).norm();
        assert!(e1 <= 1e-7 * scale, "{c:?}: d1 at t = {t}: error {e1}");
        let s2 = c.d2(t).norm().max(scale / (b - a));
        assert!(
            e2 <= 1e-6 * s2,
            "{c:?}: d2 at t = {t}: error {e2} (scale {s2})"
        );
        assert!(
            e2b <= 1e-3 * s2,
            "{c:?}: d2 vs second difference at t = {t}: error {e2b}"
        );
        assert!(c.point(t).iter().all(|x| x.is_finite()));
        // the first-order answer stage 2 uses equals point and d1 to
        // rounding (NURBS: power-form spans)
        let (pt, d1) = c.tangent(t);
        let e = (pt - c.point(t)).norm();
        assert!(
            e <= 1e-12 * (1.0 + c.point(t).coords.norm()),
            "{c:?}: tangent's point at {t}: {e}"
        );
        let e = (d1 - c.d1(t)).norm();
        assert!(
            e <= 1e-10 * c.d1(t).norm().max(scale),
            "{c:?}: tangent's d1 at {t}: {e}"
        );
    }
}

fn p(x: f64, y: f64, z: f64) -> P3 {
    P3::new(x, y, z)
}

#[test]
fn line_derivatives_and_length() {
    let l = Line::new(p(0.0, 1.0, 2.0), p(3.0, -1.0, 0.5)).unwrap();
    check_derivatives(&l, &[]);
    assert_eq!(l.point(0.0), p(0.0, 1.0, 2.0));
    assert_eq!(l.point(1.0), p(3.0, -1.0, 0.5));
    assert!((l.approx_length() - length_between(&l, 0.0, 1.0)).abs() < 1e-12);
    assert!(!l.is_closed());
    assert!(Line::new(p(f64::NAN, 0.0, 0.0), p(0.0, 0.0, 0.0)).is_err());
}

#[test]
fn arc_derivatives() {
    let xy = CircleArc::xy([1.0, -2.0], 0.7, -0.5, 2.0).unwrap();
    check_derivatives(&xy, &[]);
    let tilted = CircleArc::new(p(1.0, 2.0, 3.0), V3::new(1.0, 1.0, 1.0), 2.5, 0.3, 5.0).unwrap();
    check_derivatives(&tilted, &[]);
    // The tilted arc lies in its plane at its radius.
    let n = tilted.normal();
    for t in params(&tilted) {
        let d = tilted.point(t) - tilted.center();
        assert!(d.dot(&n).abs() < 1e-12);
        assert!((d.norm() - 2.5).abs() < 1e-12);
    }
    let through =
        CircleArc::through(p(1.0, 0.0, 0.0), p(0.0, 1.0, 0.0), p(-1.0, 0.0, 0.0)).unwrap();
    check_derivatives(&through, &[]);
    assert!((through.radius() - 1.0).abs() < 1e-15);
    assert!((through.sweep() - PI).abs() < 1e-14);
    assert!((through.point(through.interval().1) - p(-1.0, 0.0, 0.0)).norm() < 1e-15);
}

#[test]
fn circle_length_is_two_pi_r() {
    for r in [0.2, 1.0, 37.5] {
        let c = CircleArc::circle_xy([0.3, 0.4], r).unwrap();
        assert!(c.is_closed());
        assert!((c.approx_length() - TAU * r).abs() < 1e-12 * r);
        // The generic quadrature agrees.
        let (a, b) = c.interval();
        assert!((length_between(&c, a, b) - TAU * r).abs() < 1e-10 * r);
        // Start point at angle 0.
        assert!((c.point(0.0) - p(0.3 + r, 0.4, 0.0)).norm() < 1e-15 * r.max(1.0));
    }
}

#[test]
fn arc_validation() {
    assert_eq!(
        CircleArc::xy([0.0, 0.0], 0.0, 0.0, 1.0).unwrap_err(),
        GeometryError::BadRadius(0.0)
    );
    assert!(CircleArc::xy([0.0, 0.0], -1.0, 0.0, 1.0).is_err());
    assert!(CircleArc::xy([0.0, 0.0], 1.0, 1.0, 1.0).is_err());
    assert!(CircleArc::xy([0.0, 0.0], 1.0, 0.0, 7.0).is_err());
    assert!(CircleArc::xy([f64::INFINITY, 0.0], 1.0, 0.0, 1.0).is_err());
    assert!(CircleArc::new(P3::origin(), V3::zeros(), 1.0, 0.0, 1.0).is_err());
    assert_eq!(
        CircleArc::through(p(0.0, 0.0, 0.0), p(1.0, 1.0, 0.0), p(2.0, 2.0, 0.0)).unwrap_err(),
        GeometryError::Collinear
    );
    assert!(CircleArc::through(p(0.0, 0.0, 0.0), p(0.0, 0.0, 0.0), p(2.0, 2.0, 0.0)).is_err());
}

fn quarter_circle() -> Nurbs {
    Nurbs::new(
        2,
        vec![p(1.0, 0.0, 0.0), p(1.0, 1.0, 0.0), p(0.0, 1.0, 0.0)],
        Some(vec![1.0, FRAC_1_SQRT_2, 1.0]),
        vec![0.0, 0.0, 0.0, 1.0, 1.0, 1.0],
    )
    .unwrap()
}

#[test]
fn nurbs_quarter_circle_lies_on_the_circle() {
    let c = quarter_circle();
    assert!(c.is_rational());
    for k in 0..=100 {
        let t = k as f64 / 100.0;
        let q = c.point(t);
        assert!(
            (q.coords.norm() - 1.0).abs() < 1e-14,
            "t = {t}: |C| = {}",
            q.coords.norm()
        );
        // The tangent is perpendicular to the radius.
        assert!(c.d1(t).dot(&q.coords).abs() < 1e-13);
    }
    check_derivatives(&c, &[]);
    assert!((c.approx_length() - PI / 2.0).abs() < 1e-10);
}

#[test]
fn nurbs_full_circle_nine_points() {
    // The classical 9-point full circle, degree 2, knots at quarter turns.
    let w = FRAC_1_SQRT_2;
    let pts = [
        (1.0, 0.0),
        (1.0, 1.0),
        (0.0, 1.0),
        (-1.0, 1.0),
        (-1.0, 0.0),
        (-1.0, -1.0),
        (0.0, -1.0),
        (1.0, -1.0),
        (1.0, 0.0),
    ]
    .iter()
    .map(|&(x, y)| p(2.0 * x, 2.0 * y, 0.0))
    .collect();
    let knots = vec![
        0.0, 0.0, 0.0, 0.25, 0.25, 0.5, 0.5, 0.75, 0.75, 1.0, 1.0, 1.0,
    ];
    let c = Nurbs::new(
        2,
        pts,
        Some(vec![1.0, w, 1.0, w, 1.0, w, 1.0, w, 1.0]),
        knots,
    )
    .unwrap();
    assert!(c.is_closed());
    for k in 0..=200 {
        let q = c.point(k as f64 / 200.0);
        assert!((q.coords.norm() - 2.0).abs() < 1e-13);
    }
    assert!((c.approx_length() - 4.0 * PI).abs() < 1e-8);
    check_derivatives(&c, &[0.25, 0.5, 0.75]);
}

#[test]
fn clamped_nurbs_interpolates_end_points_and_derivatives_match() {
    let pts = vec![
        p(0.0, 0.0, 0.0),
        p(1.0, 2.0, 0.5),
        p(3.0, 3.0, -1.0),
        p(4.0, 0.0, 0.0),
        p(6.0, 1.0, 2.0),
        p(7.0, -1.0, 0.0),
    ];
    // Polynomial, non-uniform knots.
    let c = Nurbs::new(
        3,
        pts.clone(),
        None,
        vec![0.0, 0.0, 0.0, 0.0, 0.3, 0.4, 1.0, 1.0, 1.0, 1.0],
    )
    .unwrap();
    assert!(!c.is_rational());
    assert!((c.point(0.0) - pts[0]).norm() < 1e-15);
    assert!((c.point(1.0) - pts[5]).norm() < 1e-14);
    // End tangent of a clamped curve: p / (u_{p+1} − u_1) (P1 − P0).
    assert!((c.d1(0.0) - (pts[1] - pts[0]) * (3.0 / 0.3)).norm() < 1e-12);
    check_derivatives(&c, &[0.3, 0.4]);
    // Rational, on a different interval.
    let r = Nurbs::new(
        3,
        pts.clone(),
        Some(vec![1.0, 0.5, 2.0, 1.5, 0.8, 1.0]),
        vec![2.0, 2.0, 2.0, 2.0, 3.0, 4.5, 5.0, 5.0, 5.0, 5.0],
    )
    .unwrap();
    assert_eq!(r.interval(), (2.0, 5.0));
    assert!((r.point(2.0) - pts[0]).norm() < 1e-14);
    assert!((r.point(5.0) - pts[5]).norm() < 1e-14);
    check_derivatives(&r, &[3.0, 4.5]);
    // Clamped uniform knots.
    let u = Nurbs::clamped_uniform(2, pts.clone(), None).unwrap();
    assert_eq!(u.knots(), &[0.0, 0.0, 0.0, 0.25, 0.5, 0.75, 1.0, 1.0, 1.0]);
    assert!((u.point(1.0) - pts[5]).norm() < 1e-14);
    check_derivatives(&u, &[0.25, 0.5, 0.75]);
    // Degree 1 is the control polygon; d2 = 0.
    let l = Nurbs::clamped_uniform(1, pts.clone(), None).unwrap();
    assert!((l.point(0.2) - pts[1]).norm() < 1e-14);
    assert_eq!(l.d2(0.1), V3::zeros());
    check_derivatives(&l, &[0.2, 0.4, 0.6, 0.8]);
    // High degree, rational: a single Bézier piece.
    let b =
        Nurbs::clamped_uniform(5, pts.clone(), Some(vec![1.0, 3.0, 0.2, 1.0, 2.0, 1.0])).unwrap();
    check_derivatives(&b, &[]);
}

#[test]
fn unclamped_nurbs_derivatives() {
    let pts = vec![
        p(0.0, 0.0, 0.0),
        p(1.0, 1.0, 0.0),
        p(2.0, -1.0, 0.0),
        p(3.0, 0.5, 1.0),
        p(4.0, 0.0, 0.0),
    ];
    let knots: Vec<f64> = (0..8).map(|i| i as f64).collect();
    let c = Nurbs::new(2, pts, Some(vec![1.0, 2.0, 1.0, 0.5, 1.0]), knots).unwrap();
    assert_eq!(c.interval(), (2.0, 5.0));
    check_derivatives(&c, &[3.0, 4.0]);
}

#[test]
fn nurbs_validation() {
    let pts = || vec![p(0.0, 0.0, 0.0), p(1.0, 1.0, 0.0), p(2.0, 0.0, 0.0)];
    let err = |r: Result<Nurbs, GeometryError>| r.unwrap_err().to_string();
    assert!(err(Nurbs::new(0, pts(), None, vec![0.0, 1.0, 2.0])).contains("degree"));
    assert!(err(Nurbs::new(3, pts(), None, vec![0.0; 7])).contains("at least 4 control points"));
    assert!(
        err(Nurbs::new(2, pts(), None, vec![0.0, 0.0, 0.0, 1.0, 1.0])).contains("n + p + 1 = 6")
    );
    assert!(err(Nurbs::new(
        2,
        pts(),
        None,
        vec![0.0, 0.0, 1.0, 0.5, 1.0, 1.0]
    ))
    .contains("non-decreasing"));
    assert!(err(Nurbs::new(
        2,
        pts(),
        None,
        vec![0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    ))
    .contains("empty"));
    assert!(err(Nurbs::new(
        2,
        pts(),
        None,
        vec![0.0, 0.0, 0.0, f64::NAN, 1.0, 1.0]
    ))
    .contains("knot 4"));
    assert!(err(Nurbs::new(
        2,
        pts(),
        Some(vec![1.0, 0.0, 1.0]),
        vec![0.0, 0.0, 0.0, 1.0, 1.0, 1.0]
    ))
    .contains("weight 2"));
    assert!(err(Nurbs::new(
        2,
        pts(),
        Some(vec![1.0, -1.0, 1.0]),
        vec![0.0, 0.0, 0.0, 1.0, 1.0, 1.0]
    ))
    .contains("> 0"));
    assert!(err(Nurbs::new(
        2,
        pts(),
        Some(vec![1.0, 1.0]),
        vec![0.0, 0.0, 0.0, 1.0, 1.0, 1.0]
    ))
    .contains("2 weights"));
    // Interior knot of multiplicity > p.
    let five = vec![
        p(0.0, 0.0, 0.0),
        p(1.0, 1.0, 0.0),
        p(2.0, 0.0, 0.0),
        p(3.0, 1.0, 0.0),
        p(4.0, 0.0, 0.0),
    ];
    assert!(err(Nurbs::new(
        1,
        five,
        None,
        vec![0.0, 0.0, 0.5, 0.5, 1.0, 1.0, 1.0]
    ))
    .contains("multiplicity"));
    assert!(err(Nurbs::new(
        1,
        vec![p(f64::INFINITY, 0.0, 0.0), p(0.0, 0.0, 0.0)],
        None,
        vec![0.0, 0.0, 1.0, 1.0]
    ))
    .contains("finite"));
}
