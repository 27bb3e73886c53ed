//! Orthographic projection along a view direction.
//!
//! The view direction `v` points from the mesh towards the viewer. The
//! screen's right axis is `z × v` (normalised; `x` when `v` is along `z`),
//! its up axis `v × right`, so z stays up on the screen unless one looks
//! along z; looking down `(0, 0, 1)` shows x to the right and y up. The HTML
//! viewer's orbit uses the same convention, so its first picture matches the
//! SVG's.

use bubblemesh_core::mesh::Mesh;
use bubblemesh_core::{P3, V3};

/// An orthographic camera.
#[derive(Clone, Copy, Debug)]
pub struct Projection {
    /// Towards the viewer (unit).
    pub dir: V3,
    /// The screen's right axis (unit): `z × dir` normalised, or `x` when
    /// `dir` is along `z`.
    pub right: V3,
    /// The screen's up axis (unit): `dir × right`, so `z` points up on the
    /// screen unless one looks along `z`.
    pub up: V3,
}

impl Projection {
    /// The camera looking along `-dir` (`dir` towards the viewer). `None`
    /// when `dir` is zero or not finite.
    pub fn new(dir: V3) -> Option<Projection> {
        let n = dir.norm();
        if !(n.is_finite() && n > 0.0) {
            return None;
        }
        let dir = dir / n;
        let z = V3::z();
        let r = z.cross(&dir);
        let right = if r.norm() < 1e-9 {
            V3::x()
        } else {
            r.normalize()
        };
        let up = dir.cross(&right);
        Some(Projection { dir, right, up })
    }

    /// Screen coordinates (right, up) and depth (larger: nearer the viewer).
    pub fn project(&self, p: &P3) -> (f64, f64, f64) {
        let v = p.coords;
        (v.dot(&self.right), v.dot(&self.up), v.dot(&self.dir))
    }
}

/// The view a picture uses when none is asked for, and whether the mesh is
/// flat (all its nodes in one plane, so that the picture is exact and
/// unshaded). A flat mesh is seen along its plane's normal (the side its
/// triangles face, +z for a planar domain in x, y); any other mesh from
/// `(1, -1, 1)`, front-right and above.
pub fn auto_view(mesh: &Mesh) -> (V3, bool) {
    let n = mesh.nodes.len();
    let oblique = V3::new(1.0, -1.0, 1.0);
    if n < 3 {
        return (V3::z(), true);
    }
    let c = mesh.nodes.iter().map(|p| p.pos.coords).sum::<V3>() / n as f64;
    let mut cov = nalgebra::Matrix3::<f64>::zeros();
    for p in &mesh.nodes {
        let d = p.pos.coords - c;
        cov += d * d.transpose();
    }
    cov /= n as f64;
    let eig = cov.symmetric_eigen();
    let (mut kmin, mut kmax) = (0, 0);
    for k in 1..3 {
        if eig.eigenvalues[k] < eig.eigenvalues[kmin] {
            kmin = k;
        }
        if eig.eigenvalues[k] > eig.eigenvalues[kmax] {
            kmax = k;
        }
    }
    let (lmin, lmax) = (eig.eigenvalues[kmin], eig.eigenvalues[kmax]);
    if lmax.is_nan() || lmax <= 0.0 || lmin > 1e-12 * lmax {
        return (oblique, false);
    }
    let mut normal: V3 = eig.eigenvectors.column(kmin).into_owned();
    // snap to an axis when it is one (exact pictures of planar domains)
    for k in 0..3 {
        if normal[k].abs() > 1.0 - 1e-9 {
            normal = V3::zeros();
            normal[k] = 1.0;
        }
    }
    // face the side the triangles' counter-clockwise normals point to
    let mut s = 0.0;
    for t in &mesh.triangles {
        let p = t.nodes.map(|i| mesh.nodes[i as usize].pos);
        s += (p[1] - p[0]).cross(&(p[2] - p[0])).dot(&normal);
    }
    if s < 0.0 || (s == 0.0 && normal.iter().sum::<f64>() < 0.0) {
        normal = -normal;
    }
    (normal, true)
}

/// Parses a view direction `X,Y,Z`.
pub fn parse_view(text: &str) -> Result<V3, String> {
    let parts: Vec<&str> = text.split(',').map(|s| s.trim()).collect();
    if parts.len() != 3 {
        return Err(format!(
            "view '{text}': expected three numbers X,Y,Z (the direction towards the viewer)"
        ));
    }
    let mut v = V3::zeros();
    for (k, p) in parts.iter().enumerate() {
        v[k] = p
            .parse::<f64>()
            .map_err(|_| format!("view '{text}': '{p}' is not a number"))?;
    }
    if Projection::new(v).is_none() {
        return Err(format!(
            "view '{text}': the direction must be finite and non-zero"
        ));
    }
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn looking_down_z_shows_x_right_and_y_up() {
        let p = Projection::new(V3::new(0.0, 0.0, 2.0)).unwrap();
        assert_eq!(p.project(&P3::new(1.0, 2.0, 3.0)), (1.0, 2.0, 3.0));
        let p = Projection::new(V3::new(0.0, -1.0, 0.0)).unwrap();
        // from the front: x right, z up, y away
        assert_eq!(p.project(&P3::new(1.0, 2.0, 3.0)), (1.0, 3.0, -2.0));
        assert!(Projection::new(V3::zeros()).is_none());
    }

    #[test]
    fn views_parse() {
        assert_eq!(parse_view("1, 0,0").unwrap(), V3::x());
        assert!(parse_view("1,0").is_err());
        assert!(parse_view("0,0,0").is_err());
        assert!(parse_view("a,0,1").is_err());
    }
}
