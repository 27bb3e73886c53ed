//! Exactness of the analytic and NURBS surfaces: partials against central
//! finite differences, closest-point inverses, periods and singular points,
//! and classical NURBS identities (rational cylinder and sphere patches).

use std::f64::consts::{FRAC_1_SQRT_2, FRAC_PI_2, PI, TAU};
use std::sync::Arc;

use bubblemesh_analytic::surfaces::INVERSE_MAX_DISTANCE;
use bubblemesh_analytic::{
    CircleArc, Cone, Cylinder, Extrusion, Frame, Line, Nurbs, NurbsSurface, Revolution, Sphere,
    SurfaceError, Torus,
};
use bubblemesh_core::geom::{Curve, Surface, P3, V3};

fn p(x: f64, y: f64, z: f64) -> P3 {
    P3::new(x, y, z)
}
fn v3(x: f64, y: f64, z: f64) -> V3 {
    V3::new(x, y, z)
}

/// A small deterministic generator (xorshift64*), uniform in [0, 1).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.next()
    }
}

/// The domain with infinite ends replaced by ±3.
fn finite_domain(s: &dyn Surface) -> ([f64; 2], [f64; 2]) {
    let (u, v) = s.domain();
    let f = |r: [f64; 2]| {
        [
            if r[0].is_finite() {
                r[0]
            } else {
                r[1].min(0.0) - 3.0
            },
            if r[1].is_finite() {
                r[1]
            } else {
                r[0].max(0.0) + 3.0
            },
        ]
    };
    (f(u), f(v))
}

/// `n` random parameters inside the domain (2 % margin), away from singular
/// points and from the given knots (where second partials jump).
fn params(s: &dyn Surface, n: usize, seed: u64, knots: [&[f64]; 2]) -> Vec<[f64; 2]> {
    let (du, dv) = finite_domain(s);
    let mut rng = Rng(seed);
    let mut out = Vec::new();
    while out.len() < n {
        let mu = 0.02 * (du[1] - du[0]);
        let mv = 0.02 * (dv[1] - dv[0]);
        let x = [
            rng.range(du[0] + mu, du[1] - mu),
            rng.range(dv[0] + mv, dv[1] - mv),
        ];
        let near_knot = (0..2).any(|i| knots[i].iter().any(|k| (x[i] - k).abs() < 1e-3));
        let d = s.derivs(x[0], x[1]);
        if near_knot || d.su.cross(&d.sv).norm() < 1e-3 * d.su.norm().max(d.sv.norm()).powi(2) {
            continue;
        }
        out.push(x);
    }
    out
}

/// su, sv, suu, suv (both ways) and svv against central differences, with
/// relative tolerance 1e-6 (relative to the larger of the exact value and
/// the first partials at the point).
fn check_derivs(s: &dyn Surface, pts: &[[f64; 2]]) {
    let (du, dv) = finite_domain(s);
    let hu = 1e-5 * (du[1] - du[0]);
    let hv = 1e-5 * (dv[1] - dv[0]);
    for &[u, v] in pts {
        let d = s.derivs(u, v);
        assert!((d.p - s.point(u, v)).norm() <= 1e-14 * (1.0 + d.p.coords.norm()));
        // the first-order answer stage 2 uses equals derivs' to rounding
        // (NURBS: power-form patches and spans)
        let (tp, tu, tv) = s.tangents(u, v);
        assert!(
            (tp - d.p).norm() <= 1e-12 * (1.0 + d.p.coords.norm()),
            "tangents' point at {u},{v}"
        );
        let first = d.su.norm() + d.sv.norm();
        assert!(
            (tu - d.su).norm() <= 1e-10 * first,
            "tangents' S_u at {u},{v}"
        );
        assert!(
            (tv - d.sv).norm() <= 1e-10 * first,
            "tangents' S_v at {u},{v}"
        );
        let (a, b) = (s.derivs(u + hu, v), s.derivs(u - hu, v));
        let (c, e) = (s.derivs(u, v + hv), s.derivs(u, v - hv));
        let first = d.su.norm() / (du[1] - du[0]) + d.sv.norm() / (dv[1] - dv[0]);
        let checks = [
            (
                "su",
                d.su,
                (a.p - b.p) / (2.0 * hu),
                d.su.norm() + d.sv.norm(),
            ),
            (
                "sv",
                d.sv,
                (c.p - e.p) / (2.0 * hv),
                d.su.norm() + d.sv.norm(),
            ),
            ("suu", d.suu, (a.su - b.su) / (2.0 * hu), first),
            ("suv", d.suv, (c.su - e.su) / (2.0 * hv), first),
            ("svu", d.suv, (a.sv - b.sv) / (2.0 * hu), first),
            ("svv", d.svv, (c.sv - e.sv) / (2.0 * hv), first),
        ];
        for (name, exact, fd, floor) in checks {
            let err = (exact - fd).norm();
            let scale = exact.norm().max(0.5 * floor).max(1e-12);
            assert!(
                err <= 1e-6 * scale,
                "{s:?}\n{name} at ({u}, {v}): exact {exact:?}, differences {fd:?}, error {err:e} (scale {scale:e})"
            );
        }
        // The second partials are not all trivially zero-compared: a
        // surface with curvature shows it in at least one of them.
        assert!(d.p.iter().all(|x| x.is_finite()));
    }
}

/// Distance between parameters, periodic directions taken modulo the period.
fn param_dist(s: &dyn Surface, a: [f64; 2], b: [f64; 2]) -> f64 {
    let per = s.periods();
    let mut d2 = 0.0;
    for i in 0..2 {
        let mut d = a[i] - b[i];
        if let Some(t) = per[i] {
            d = d - t * (d / t).round();
        }
        d2 += d * d;
    }
    d2.sqrt()
}

/// inverse(point(u,v)) == (u,v) with and without a hint, the result inside
/// the domain (periodic directions in [a, a + T)); a point off the surface
/// along the normal comes back to the same parameters, with the residual
/// along the normal.
fn check_inverse(s: &dyn Surface, pts: &[[f64; 2]], offset: f64, tol: f64) {
    let (du, dv) = s.domain();
    let per = s.periods();
    for (k, &x) in pts.iter().enumerate() {
        let q = s.point(x[0], x[1]);
        let hint = [x[0] + 0.03, x[1] - 0.02];
        for h in [None, Some(hint)] {
            let y = s
                .inverse(&q, h)
                .unwrap_or_else(|| panic!("{s:?}: no inverse of {x:?} (hint {h:?})"));
            assert!(
                param_dist(s, x, y) <= tol,
                "{s:?}: inverse of S{x:?} is {y:?} (hint {h:?})"
            );
            for (i, r) in [du, dv].iter().enumerate() {
                match per[i] {
                    Some(t) => assert!(y[i] >= r[0] && y[i] < r[0] + t, "{y:?} not wrapped"),
                    None => assert!(y[i] >= r[0] && y[i] <= r[1], "{y:?} outside the domain"),
                }
            }
        }
        // Off the surface along the normal, alternating sides.
        let d = s.derivs(x[0], x[1]);
        let n = d.su.cross(&d.sv).normalize();
        let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
        let off = q + n * (sign * offset);
        for h in [None, Some(hint)] {
            let y = s.inverse(&off, h).expect("inverse of an offset point");
            assert!(
                param_dist(s, x, y) <= tol.max(1e-9),
                "{s:?}: offset point of {x:?} maps to {y:?} (hint {h:?})"
            );
            let e = s.derivs(y[0], y[1]);
            let r = off - e.p;
            assert!(
                (r.norm() - offset).abs() <= 1e-8 * offset.max(1.0),
                "distance {} ≠ {offset}",
                r.norm()
            );
            let m = e.su.cross(&e.sv).normalize();
            assert!(
                r.cross(&m).norm() <= 1e-8 * r.norm(),
                "{s:?}: residual {r:?} not along the normal {m:?} at {y:?}"
            );
        }
    }
}

/// Parameters at and next to the u seam of a u-periodic surface.
fn seam_params(s: &dyn Surface) -> Vec<[f64; 2]> {
    let (du, dv) = finite_domain(s);
    let t = s.periods()[0].unwrap();
    let vm = 0.37 * dv[0] + 0.63 * dv[1];
    let vn = 0.8 * dv[0] + 0.2 * dv[1];
    vec![
        [du[0], vm],
        [du[0] + 1e-9, vn],
        [du[0] + t - 1e-9, vm],
        [du[0] + t - 1e-12, vn],
    ]
}

fn tilted_frame() -> Frame {
    Frame::with_reference(p(0.5, -1.0, 2.0), v3(1.0, 2.0, -0.5), v3(0.0, 0.0, 1.0)).unwrap()
}

// ---------------------------------------------------------------- analytic

#[test]
fn sphere() {
    for s in [
        Sphere::new(p(1.0, -2.0, 0.5), 2.5).unwrap(),
        Sphere::with_frame(tilted_frame(), 0.3).unwrap(),
    ] {
        let pts = params(&s, 20, 1, [&[], &[]]);
        check_derivs(&s, &pts);
        for &[u, v] in &pts {
            assert!(((s.point(u, v) - s.center()).norm() - s.radius()).abs() < 1e-14 * 4.0);
        }
        check_inverse(&s, &pts, 0.1 * s.radius(), 1e-12);
        check_inverse(&s, &seam_params(&s), 0.1 * s.radius(), 1e-12);
        assert_eq!(s.periods(), [Some(TAU), None]);
        // Poles: v = ±π/2 exactly, u from the hint.
        let z = s.frame().z();
        let north = s.center() + z * s.radius();
        let south = s.center() - z * s.radius();
        assert_eq!(s.inverse(&north, None).unwrap()[1], FRAC_PI_2);
        assert_eq!(s.inverse(&south, None).unwrap()[1], -FRAC_PI_2);
        assert_eq!(
            s.inverse(&north, Some([1.25, 1.5])).unwrap(),
            [1.25, FRAC_PI_2]
        );
        assert_eq!(
            s.inverse(&(s.center() + z * 7.0), Some([-1.0, 0.0]))
                .unwrap(),
            [TAU - 1.0, FRAC_PI_2]
        );
        assert!(s.is_singular(0.3, FRAC_PI_2));
        assert!(s.is_singular(4.0, -FRAC_PI_2));
        assert!(!s.is_singular(0.3, FRAC_PI_2 - 1e-6));
        assert!(!s.is_singular(0.3, 0.0));
        // The centre has every point at distance r: any answer on the sphere.
        assert!(s.inverse(&s.center(), None).is_some());
        assert!(s.inverse(&p(f64::NAN, 0.0, 0.0), None).is_none());
    }
    assert!(matches!(
        Sphere::new(P3::origin(), 0.0).unwrap_err(),
        SurfaceError::Geometry(_)
    ));
    assert!(Sphere::new(p(f64::INFINITY, 0.0, 0.0), 1.0).is_err());
}

#[test]
fn cylinder() {
    let s = Cylinder::new(p(0.2, 0.1, -1.0), v3(0.3, -1.0, 2.0), 0.7).unwrap();
    assert_eq!(s.domain(), ([0.0, TAU], [f64::NEG_INFINITY, f64::INFINITY]));
    let pts = params(&s, 20, 2, [&[], &[]]);
    check_derivs(&s, &pts);
    check_inverse(&s, &pts, 0.2, 1e-12);
    check_inverse(&s, &seam_params(&s), 0.2, 1e-12);
    assert_eq!(s.periods(), [Some(TAU), None]);
    assert!(!s.is_singular(0.0, 0.0) && !s.is_singular(2.0, 10.0));
    // v is the signed height along the axis.
    let f = *s.frame();
    let q = f.origin() + f.z() * 2.5 + f.x() * 3.0;
    assert!(param_dist(&s, s.inverse(&q, None).unwrap(), [0.0, 2.5]) < 1e-14);
    // A point on the axis takes the hint's angle.
    assert_eq!(
        s.inverse(&(f.origin() + f.z()), Some([7.0, 0.0])).unwrap()[0],
        7.0 - TAU
    );

    let b = Cylinder::bounded(P3::origin(), V3::z(), 2.0, -1.0, 3.0).unwrap();
    let pts = params(&b, 20, 3, [&[], &[]]);
    check_derivs(&b, &pts);
    check_inverse(&b, &pts, 0.3, 1e-12);
    // Beyond the top: clamped to the rim.
    let y = b.inverse(&p(0.0, 5.0, 9.0), None).unwrap();
    assert!(param_dist(&b, y, [FRAC_PI_2, 3.0]) < 1e-14);
    assert!(Cylinder::bounded(P3::origin(), V3::z(), 2.0, 3.0, 3.0).is_err());
    assert!(Cylinder::new(P3::origin(), V3::zeros(), 1.0).is_err());
    assert!(Cylinder::new(P3::origin(), V3::z(), -1.0).is_err());
}

#[test]
fn cone() {
    let s = Cone::bounded(p(1.0, 1.0, 1.0), v3(-1.0, 0.5, 0.2), 0.4, 0.0, 5.0).unwrap();
    let pts = params(&s, 20, 4, [&[], &[]]);
    check_derivs(&s, &pts);
    check_inverse(&s, &pts, 0.05, 1e-12);
    check_inverse(&s, &seam_params(&s), 0.05, 1e-12);
    assert_eq!(s.periods(), [Some(TAU), None]);
    assert!(s.is_singular(1.0, 0.0));
    assert!(!s.is_singular(1.0, 1e-6));
    // Points of the generator lie at distance v from the apex, at angle α
    // to the axis.
    for &[u, v] in &pts {
        let d = s.point(u, v) - s.apex();
        assert!((d.norm() - v).abs() < 1e-13);
        assert!((d.normalize().dot(&s.frame().z()) - 0.4f64.cos()).abs() < 1e-13);
    }
    // The apex and points below it map to the apex.
    let below = s.apex() - s.frame().z() * 2.0;
    assert_eq!(s.inverse(&below, Some([0.5, 1.0])).unwrap(), [0.5, 0.0]);
    assert_eq!(s.inverse(&s.apex(), None).unwrap()[1], 0.0);
    // The unbounded cone.
    let u = Cone::new(P3::origin(), V3::z(), 1.2).unwrap();
    let pts = params(&u, 20, 5, [&[], &[]]);
    check_derivs(&u, &pts);
    check_inverse(&u, &pts, 0.05, 1e-12);
    for bad in [0.0, FRAC_PI_2, -0.3, f64::NAN] {
        assert!(matches!(
            Cone::new(P3::origin(), V3::z(), bad).unwrap_err(),
            SurfaceError::BadHalfAngle(_)
        ));
    }
    assert!(Cone::bounded(P3::origin(), V3::z(), 0.5, -1.0, 1.0).is_err());
}

#[test]
fn torus() {
    for s in [
        Torus::new(p(0.0, 1.0, -2.0), v3(0.0, 1.0, 1.0), 3.0, 1.0).unwrap(),
        Torus::with_frame(tilted_frame(), 1.0, 0.9).unwrap(),
    ] {
        let pts = params(&s, 20, 6, [&[], &[]]);
        check_derivs(&s, &pts);
        // Less than the distance from the inner equator to the axis.
        let off = 0.2 * s.minor_radius().min(s.major_radius() - s.minor_radius());
        check_inverse(&s, &pts, off, 1e-12);
        check_inverse(&s, &seam_params(&s), off, 1e-12);
        // Near the v seam too.
        let vs: Vec<[f64; 2]> = [1e-10, TAU - 1e-10, 0.0]
            .iter()
            .map(|&v| [1.0, v])
            .collect();
        check_inverse(&s, &vs, off, 1e-12);
        assert_eq!(s.periods(), [Some(TAU), Some(TAU)]);
        assert!(!s.is_singular(0.0, 0.0) && !s.is_singular(1.0, PI));
    }
    assert!(matches!(
        Torus::new(P3::origin(), V3::z(), 1.0, 1.0).unwrap_err(),
        SurfaceError::BadTorus { .. }
    ));
    assert!(Torus::new(P3::origin(), V3::z(), 1.0, 0.0).is_err());
}

// ------------------------------------------------------ swept surfaces

/// A cubic profile in the plane y = 0 (x > 0), axis z through the origin.
fn profile() -> Arc<dyn Curve> {
    Arc::new(
        Nurbs::new(
            3,
            vec![
                p(1.0, 0.0, 0.0),
                p(2.0, 0.0, 0.5),
                p(1.5, 0.0, 1.5),
                p(0.8, 0.0, 2.0),
                p(1.2, 0.0, 3.0),
            ],
            Some(vec![1.0, 0.8, 1.3, 1.0, 1.0]),
            vec![0.0, 0.0, 0.0, 0.0, 0.4, 1.0, 1.0, 1.0, 1.0],
        )
        .unwrap(),
    )
}

#[test]
fn revolution() {
    let s = Revolution::new(profile(), P3::origin(), V3::z()).unwrap();
    assert_eq!(s.domain(), ([0.0, TAU], [0.0, 1.0]));
    let pts = params(&s, 20, 7, [&[], &[0.4]]);
    check_derivs(&s, &pts);
    check_inverse(&s, &pts, 0.02, 1e-9);
    check_inverse(&s, &seam_params(&s), 0.02, 1e-9);
    assert_eq!(s.periods(), [Some(TAU), None]);
    // u = 0 is the profile; a quarter turn maps x to y.
    for &[_, v] in &pts {
        let c = profile().point(v);
        assert!((s.point(0.0, v) - c).norm() < 1e-15);
        assert!((s.point(FRAC_PI_2, v) - p(0.0, c.x, c.z)).norm() < 1e-14);
    }
    assert!(!s.is_singular(0.0, 0.0));

    // A circle turned about a tilted axis: the torus, periodic in both.
    let f = tilted_frame();
    let circle: Arc<dyn Curve> = Arc::new(
        CircleArc::with_basis(f.origin() + f.x() * 2.0, f.x(), f.z(), 0.5, 0.0, TAU).unwrap(),
    );
    let t = Revolution::new(circle, f.origin(), f.z()).unwrap();
    let torus = Torus::with_frame(f, 2.0, 0.5).unwrap();
    assert_eq!(t.periods(), [Some(TAU), Some(TAU)]);
    for &[u, v] in &params(&t, 20, 8, [&[], &[]]) {
        assert!((t.point(u, v) - torus.point(u, v)).norm() < 1e-14);
        let (a, b) = (t.derivs(u, v), torus.derivs(u, v));
        for (x, y) in [(a.su, b.su), (a.sv, b.sv), (a.suu, b.suu), (a.suv, b.suv)] {
            assert!((x - y).norm() < 1e-13);
        }
        assert!((a.svv - b.svv).norm() < 1e-13);
    }
    let pts = params(&t, 20, 9, [&[], &[]]);
    check_derivs(&t, &pts);
    check_inverse(&t, &pts, 0.1, 1e-9);
    // Across the v seam: evaluation is periodic.
    assert!((t.point(0.3, TAU + 0.2) - t.point(0.3, 0.2)).norm() < 1e-14);

    // A half circle turned about its diameter: a sphere with singular ends.
    let half: Arc<dyn Curve> = Arc::new(
        CircleArc::with_basis(P3::origin(), V3::x(), V3::z(), 1.5, -FRAC_PI_2, FRAC_PI_2).unwrap(),
    );
    let sph = Revolution::new(half, P3::origin(), V3::z()).unwrap();
    assert_eq!(sph.periods(), [Some(TAU), None]);
    assert!(sph.is_singular(0.4, -FRAC_PI_2) && sph.is_singular(2.0, FRAC_PI_2));
    assert!(!sph.is_singular(0.4, 0.0) && !sph.is_singular(0.4, FRAC_PI_2 - 1e-3));
    let pts = params(&sph, 20, 10, [&[], &[]]);
    check_derivs(&sph, &pts);
    check_inverse(&sph, &pts, 0.1, 1e-9);
    let pole = sph.inverse(&p(0.0, 0.0, 1.5), Some([0.3, 1.5])).unwrap();
    assert!((pole[1] - FRAC_PI_2).abs() < 1e-7, "{pole:?}");

    // Far from the surface there is no answer.
    let far = p(0.0, 0.0, 3.0 + 10.0 * s.size());
    assert!(s.inverse(&far, None).is_none());

    let on_axis: Arc<dyn Curve> = Arc::new(Line::new(p(0.0, 0.0, 0.0), p(0.0, 0.0, 1.0)).unwrap());
    assert!(matches!(
        Revolution::new(on_axis, P3::origin(), V3::z()).unwrap_err(),
        SurfaceError::DegenerateProfile(_)
    ));
    assert!(Revolution::new(profile(), P3::origin(), V3::zeros()).is_err());
}

#[test]
fn extrusion() {
    let s = Extrusion::new(profile(), v3(0.3, 2.0, 0.1)).unwrap();
    assert_eq!(s.domain(), ([0.0, 1.0], [0.0, 1.0]));
    assert_eq!(s.periods(), [None, None]);
    let pts = params(&s, 20, 11, [&[0.4], &[]]);
    check_derivs(&s, &pts);
    check_inverse(&s, &pts, 0.01, 1e-9);
    for &[u, v] in &pts {
        let c = profile().point(u);
        assert!((s.point(u, v) - (c + v3(0.3, 2.0, 0.1) * v)).norm() < 1e-15);
    }
    assert!(!s.is_singular(0.5, 0.5));

    // A closed profile: periodic in u, an elliptic-free circular cylinder.
    let circle: Arc<dyn Curve> = Arc::new(CircleArc::circle_xy([1.0, 2.0], 0.5).unwrap());
    let c = Extrusion::with_range(circle, v3(0.0, 0.0, 2.0), [-1.0, f64::INFINITY]).unwrap();
    assert_eq!(c.periods(), [Some(TAU), None]);
    let pts = params(&c, 20, 12, [&[], &[]]);
    check_derivs(&c, &pts);
    check_inverse(&c, &pts, 0.1, 1e-9);
    check_inverse(&c, &seam_params(&c), 0.1, 1e-9);
    assert!((c.point(-0.5, 0.0) - c.point(TAU - 0.5, 0.0)).norm() < 1e-14);
    // Below the bottom edge: clamped to v = −1.
    let y = c.inverse(&p(1.5, 2.0, -2.3), None).unwrap();
    assert!(param_dist(&c, y, [0.0, -1.0]) < 1e-9, "{y:?}");

    let line: Arc<dyn Curve> = Arc::new(Line::new(p(0.0, 0.0, 0.0), p(0.0, 0.0, 1.0)).unwrap());
    assert!(matches!(
        Extrusion::new(line, V3::z()).unwrap_err(),
        SurfaceError::DegenerateProfile(_)
    ));
    assert!(Extrusion::new(profile(), V3::zeros()).is_err());
    assert!(Extrusion::with_range(profile(), V3::x(), [1.0, 0.0]).is_err());
}

// ------------------------------------------------------------------ NURBS

/// A bicubic, non-rational 5 × 6 patch with non-uniform knots.
fn bicubic(weights: Option<Vec<Vec<f64>>>) -> NurbsSurface {
    let mut rng = Rng(99);
    let net: Vec<Vec<P3>> = (0..5)
        .map(|i| {
            (0..6)
                .map(|j| {
                    p(
                        i as f64 + 0.2 * rng.next(),
                        j as f64 * 0.8 + 0.2 * rng.next(),
                        2.0 * rng.next() - 1.0,
                    )
                })
                .collect()
        })
        .collect();
    NurbsSurface::new(
        3,
        3,
        net,
        weights,
        vec![0.0, 0.0, 0.0, 0.0, 0.35, 1.0, 1.0, 1.0, 1.0],
        vec![0.0, 0.0, 0.0, 0.0, 0.3, 0.55, 1.0, 1.0, 1.0, 1.0],
    )
    .unwrap()
}

#[test]
fn nurbs_bicubic_second_derivatives() {
    // The truck-geometry 0.5 bug case: S_uu, S_vv off by (p − 1) for p ≥ 3.
    let s = bicubic(None);
    assert!(!s.is_rational());
    let pts = params(&s, 24, 13, [&[0.35], &[0.3, 0.55]]);
    check_derivs(&s, &pts);
    check_inverse(&s, &pts, 0.01, 1e-9);
    assert_eq!(s.periods(), [None, None]);

    // Rational, with the quotient rule for every second partial.
    let mut rng = Rng(5);
    let w: Vec<Vec<f64>> = (0..5)
        .map(|_| (0..6).map(|_| 0.4 + 1.6 * rng.next()).collect())
        .collect();
    let r = bicubic(Some(w));
    assert!(r.is_rational());
    let pts = params(&r, 24, 14, [&[0.35], &[0.3, 0.55]]);
    check_derivs(&r, &pts);
    check_inverse(&r, &pts, 0.01, 1e-9);

    // An exact polynomial: the Bézier patch of (u, v, u³v³).
    let net: Vec<Vec<P3>> = (0..4)
        .map(|i| {
            (0..4)
                .map(|j| {
                    let z = if i == 3 && j == 3 { 1.0 } else { 0.0 };
                    p(i as f64 / 3.0, j as f64 / 3.0, z)
                })
                .collect()
        })
        .collect();
    let b = NurbsSurface::clamped_uniform(3, 3, net, None).unwrap();
    for &[u, v] in &params(&b, 20, 15, [&[], &[]]) {
        let d = b.derivs(u, v);
        let close = |a: V3, e: V3| (a - e).norm() < 1e-13;
        assert!((d.p - p(u, v, u.powi(3) * v.powi(3))).norm() < 1e-14);
        assert!(close(d.su, v3(1.0, 0.0, 3.0 * u * u * v.powi(3))));
        assert!(close(d.sv, v3(0.0, 1.0, 3.0 * u.powi(3) * v * v)));
        assert!(close(d.suu, v3(0.0, 0.0, 6.0 * u * v.powi(3))), "{d:?}");
        assert!(close(d.suv, v3(0.0, 0.0, 9.0 * u * u * v * v)), "{d:?}");
        assert!(close(d.svv, v3(0.0, 0.0, 6.0 * u.powi(3) * v)), "{d:?}");
    }
}

#[test]
fn nurbs_surface_matches_the_curve() {
    // S(u,v) = C(u) + v·(0, 0, 2) for a rational cubic C with weights
    // constant along v.
    let pts = vec![
        p(0.0, 0.0, 0.0),
        p(1.0, 2.0, 0.5),
        p(3.0, 3.0, -1.0),
        p(4.0, 0.0, 0.0),
        p(6.0, 1.0, 2.0),
    ];
    let w = vec![1.0, 0.5, 2.0, 1.5, 0.8];
    let knots = vec![0.0, 0.0, 0.0, 0.0, 0.4, 1.0, 1.0, 1.0, 1.0];
    let c = Nurbs::new(3, pts.clone(), Some(w.clone()), knots.clone()).unwrap();
    let net = pts
        .iter()
        .map(|&q| vec![q, q + v3(0.0, 0.0, 2.0)])
        .collect();
    let ww = w.iter().map(|&x| vec![x, x]).collect();
    let s = NurbsSurface::new(3, 1, net, Some(ww), knots, vec![0.0, 0.0, 1.0, 1.0]).unwrap();
    for k in 0..=20 {
        let u = k as f64 / 20.0;
        let d = s.derivs(u, 0.3);
        assert!((d.p - (c.point(u) + v3(0.0, 0.0, 0.6))).norm() < 1e-13);
        assert!((d.su - c.d1(u)).norm() < 1e-12 * c.d1(u).norm().max(1.0));
        assert!((d.suu - c.d2(u)).norm() < 1e-11 * c.d2(u).norm().max(1.0));
        assert!((d.sv - v3(0.0, 0.0, 2.0)).norm() < 1e-13);
        assert!(d.suv.norm() < 1e-12 && d.svv.norm() < 1e-12);
    }
}

fn quarter_cylinder() -> NurbsSurface {
    let w = FRAC_1_SQRT_2;
    let ring = [(1.0, 0.0), (1.0, 1.0), (0.0, 1.0)];
    let net = ring
        .iter()
        .map(|&(x, y)| vec![p(2.0 * x, 2.0 * y, -1.0), p(2.0 * x, 2.0 * y, 3.0)])
        .collect();
    let weights = vec![vec![1.0, 1.0], vec![w, w], vec![1.0, 1.0]];
    NurbsSurface::clamped_uniform(2, 1, net, Some(weights)).unwrap()
}

#[test]
fn nurbs_quarter_cylinder_is_exact() {
    let s = quarter_cylinder();
    let cyl = Cylinder::new(P3::origin(), V3::z(), 2.0).unwrap();
    for i in 0..=40 {
        for j in 0..=4 {
            let (u, v) = (i as f64 / 40.0, j as f64 / 4.0);
            let d = s.derivs(u, v);
            assert!(
                (d.p.x.hypot(d.p.y) - 2.0).abs() < 1e-14,
                "({u}, {v}): {:?}",
                d.p
            );
            assert!((d.p.z - (-1.0 + 4.0 * v)).abs() < 1e-14);
            // Tangent to the cylinder: S_u ⟂ radius, S_uu in the circle's plane.
            assert!(d.su.dot(&d.p.coords.xy().push(0.0)) < 1e-13 * d.su.norm());
            assert!(d.suu.z.abs() < 1e-14 && d.suv.norm() < 1e-13 && d.svv.norm() < 1e-13);
            // The cylinder's inverse agrees on the angle.
            let y = cyl.inverse(&d.p, None).unwrap();
            assert!((y[0] - d.p.y.atan2(d.p.x)).abs() < 1e-14);
        }
    }
    let pts = params(&s, 20, 16, [&[], &[]]);
    check_derivs(&s, &pts);
    check_inverse(&s, &pts, 0.05, 1e-9);
    assert_eq!(s.periods(), [None, None]);
    assert!(!s.is_singular(0.5, 0.5));
    // Off the patch's edge the closest point is on the edge (clamped).
    let y = s.inverse(&p(2.2, -0.3, 1.0), None).unwrap();
    assert!(param_dist(&s, y, [0.0, 0.5]) < 1e-9, "{y:?}");
    // The distance limit: INVERSE_MAX_DISTANCE × the net's diagonal.
    let limit = INVERSE_MAX_DISTANCE * s.size();
    let dir = v3(1.0, 1.0, 0.0).normalize();
    let near = P3::from(dir * (2.0 + 0.9 * limit) + v3(0.0, 0.0, 1.0));
    let y = s.inverse(&near, None).expect("within the limit");
    assert!(param_dist(&s, y, [0.5, 0.5]) < 1e-9, "{y:?}");
    let far = P3::from(dir * (2.0 + 1.1 * limit) + v3(0.0, 0.0, 1.0));
    assert!(s.inverse(&far, None).is_none());
    assert!(s.inverse(&far, Some([0.5, 0.5])).is_none());
}

#[test]
fn nurbs_full_cylinder_is_periodic() {
    let w = FRAC_1_SQRT_2;
    let ring = [
        (1.0, 0.0, 1.0),
        (1.0, 1.0, w),
        (0.0, 1.0, 1.0),
        (-1.0, 1.0, w),
        (-1.0, 0.0, 1.0),
        (-1.0, -1.0, w),
        (0.0, -1.0, 1.0),
        (1.0, -1.0, w),
        (1.0, 0.0, 1.0),
    ];
    let net = ring
        .iter()
        .map(|&(x, y, _)| vec![p(x, y, 0.0), p(x, y, 1.0)])
        .collect();
    let weights = ring.iter().map(|&(_, _, w)| vec![w, w]).collect();
    let ku = vec![
        0.0, 0.0, 0.0, 0.25, 0.25, 0.5, 0.5, 0.75, 0.75, 1.0, 1.0, 1.0,
    ];
    let s = NurbsSurface::new(2, 1, net, Some(weights), ku, vec![0.0, 0.0, 1.0, 1.0]).unwrap();
    assert_eq!(s.periods(), [Some(1.0), None]);
    assert!((s.point(1.1, 0.5) - s.point(0.1, 0.5)).norm() < 1e-14);
    let pts = params(&s, 20, 17, [&[0.25, 0.5, 0.75], &[]]);
    check_derivs(&s, &pts);
    check_inverse(&s, &pts, 0.05, 1e-9);
    check_inverse(&s, &seam_params(&s), 0.05, 1e-9);
}

/// The octant x, y, z ≥ 0 of the unit sphere as a degree-(2,2) rational
/// surface of revolution (The NURBS Book A8.1): a quarter meridian turned
/// by a quarter circle. The edge v = 1 collapses to the pole.
fn sphere_octant() -> NurbsSurface {
    let w = FRAC_1_SQRT_2;
    let ring = [(1.0, 0.0, 1.0), (1.0, 1.0, w), (0.0, 1.0, 1.0)];
    let meridian = [(1.0, 0.0, 1.0), (1.0, 1.0, w), (0.0, 1.0, 1.0)]; // (x, z, w)
    let net = ring
        .iter()
        .map(|&(cx, cy, _)| {
            meridian
                .iter()
                .map(|&(x, z, _)| p(cx * x, cy * x, z))
                .collect()
        })
        .collect();
    let weights = ring
        .iter()
        .map(|&(_, _, wu)| meridian.iter().map(|&(_, _, wv)| wu * wv).collect())
        .collect();
    NurbsSurface::clamped_uniform(2, 2, net, Some(weights)).unwrap()
}

#[test]
fn nurbs_sphere_octant_lies_on_the_sphere() {
    let s = sphere_octant();
    for i in 0..=30 {
        for j in 0..=30 {
            let (u, v) = (i as f64 / 30.0, j as f64 / 30.0);
            let q = s.point(u, v);
            assert!(
                (q.coords.norm() - 1.0).abs() < 1e-14,
                "({u}, {v}): |S| = {}",
                q.coords.norm()
            );
            assert!(q.iter().all(|&x| x >= -1e-15));
            // The partials are tangent to the sphere.
            let d = s.derivs(u, v);
            assert!(d.su.dot(&q.coords).abs() < 1e-13 && d.sv.dot(&q.coords).abs() < 1e-13);
        }
    }
    let pts = params(&s, 20, 18, [&[], &[]]);
    check_derivs(&s, &pts);
    check_inverse(&s, &pts, 0.05, 1e-9);
    // The collapsed edge is singular, the rest is not.
    for u in [0.0, 0.3, 1.0] {
        assert!(s.is_singular(u, 1.0), "({u}, 1) should be singular");
        assert!(!s.is_singular(u, 0.999));
        assert!(!s.is_singular(u, 0.0));
    }
    assert_eq!(s.periods(), [None, None]);
    // The pole inverts to v = 1.
    let y = s.inverse(&p(0.0, 0.0, 1.0), Some([0.4, 0.9])).unwrap();
    assert!((y[1] - 1.0).abs() < 1e-6, "{y:?}");
}

#[test]
fn nurbs_surface_validation() {
    let row = |z: f64| vec![p(0.0, 0.0, z), p(1.0, 0.0, z), p(2.0, 0.0, z)];
    let net = || vec![row(0.0), row(1.0), row(2.0)];
    let k = || vec![0.0, 0.0, 0.0, 1.0, 1.0, 1.0];
    assert!(NurbsSurface::new(2, 2, net(), None, k(), k()).is_ok());
    let ragged = vec![row(0.0), row(1.0)[..2].to_vec(), row(2.0)];
    assert!(matches!(
        NurbsSurface::new(2, 2, ragged, None, k(), k()).unwrap_err(),
        SurfaceError::BadNet(_)
    ));
    let e =
        NurbsSurface::new(2, 2, net(), None, k(), vec![0.0, 0.0, 1.0, 0.5, 1.0, 1.0]).unwrap_err();
    assert!(e.to_string().contains("v direction") && e.to_string().contains("non-decreasing"));
    let e = NurbsSurface::new(3, 2, net(), None, k(), k()).unwrap_err();
    assert!(e.to_string().contains("u direction"), "{e}");
    let e = NurbsSurface::new(2, 2, net(), Some(vec![vec![1.0; 3]; 2]), k(), k()).unwrap_err();
    assert!(matches!(e, SurfaceError::BadNet(_)));
    let mut w = vec![vec![1.0; 3]; 3];
    w[1][2] = 0.0;
    let e = NurbsSurface::new(2, 2, net(), Some(w), k(), k()).unwrap_err();
    assert!(e.to_string().contains("weight (2, 3)"), "{e}");
    let mut bad = net();
    bad[0][0].x = f64::NAN;
    assert!(NurbsSurface::new(2, 2, bad, None, k(), k()).is_err());
}

#[test]
fn frames() {
    let f = Frame::new(p(1.0, 2.0, 3.0), v3(0.0, 0.0, 5.0)).unwrap();
    assert_eq!((f.x(), f.y(), f.z()), (V3::x(), V3::y(), V3::z()));
    let g = tilted_frame();
    for (a, b) in [(g.x(), g.y()), (g.y(), g.z()), (g.z(), g.x())] {
        assert!(a.dot(&b).abs() < 1e-15);
        assert!((a.cross(&b).norm() - 1.0).abs() < 1e-15);
    }
    assert!((g.x().cross(&g.y()) - g.z()).norm() < 1e-15);
    assert!(Frame::new(P3::origin(), V3::zeros()).is_err());
    assert!(Frame::with_reference(P3::origin(), V3::z(), v3(0.0, 0.0, 2.0)).is_err());
    let q = p(0.3, -2.0, 7.0);
    let l = g.to_local(&q);
    assert!((g.point(l.x, l.y, l.z) - q).norm() < 1e-14);
}
