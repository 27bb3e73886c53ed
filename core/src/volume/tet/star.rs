//! What the tetrahedral passes share: the objective they raise, the
//! threshold below which a tetrahedron is worked on, the node → tetrahedra
//! table, and a node's star gathered for searches that move that node.
//!
//! The passes ([`super::sliver`], [`super::flip`], [`super::polish`],
//! [`super::steiner`]) import from here and from [`crate::measure`], never
//! from each other's internals.

use crate::geom::P3;
use crate::measure::{orient3d, TET_FACES};

/// Tetrahedra whose [`objective`] is below this are worked on by the
/// sliver pass, and no flip or move of the polish may leave one below it
/// (about radius ratio 0.55, dihedral angles within [27°, 138°]).
pub const TARGET_Q: f64 = 0.55;

/// The quality the improvement maximises: the radius ratio, capped by the
/// extreme dihedral angles (scaled so that 25° and 140° score about 0.51,
/// a regular tetrahedron 1): min(ρ, 1.45·θ_min/70.53°, 1.45·(180° − θ_max)/109.47°).
/// Negative for an inverted tetrahedron.
///
/// This is the hot function of the sliver pass and the polish (60 % of
/// case K's time in a profile), so it shares the face normals between the
/// radius ratio and the dihedral angles, and skips the two `acos` when
/// neither angle term can be the minimum: for θ_min ≥ 49.5° and
/// θ_max ≤ 103.3° both terms exceed 1.016 > ρ (ρ ≤ 1). Equals
/// `tet_radius_ratio(..).min(angle terms from dihedral_extremes(..))` to
/// rounding.
pub fn objective(a: &P3, b: &P3, c: &P3, d: &P3) -> f64 {
    let (u, v, w) = (b - a, c - a, d - a);
    // inward area normals (×2) of the faces opposite b, c, d, a for a
    // positive tetrahedron
    let mb = v.cross(&w);
    let mc = w.cross(&u);
    let md = u.cross(&v);
    let vol6 = u.dot(&mb);
    if vol6 == 0.0 {
        return 0.0;
    }
    let ma = (d - b).cross(&(c - b));
    let l = [ma.norm(), mb.norm(), mc.norm(), md.norm()];
    let n = mb * u.norm_squared() + mc * v.norm_squared() + md * w.norm_squared();
    let area = 0.5 * (l[0] + l[1] + l[2] + l[3]);
    let rr = 3.0 * vol6 * vol6 / (area * n.norm());
    if vol6 < 0.0 {
        return -rr;
    }
    // θ_ij = 180° − angle(m_i, m_j), the same for inward as for outward
    // normals; the extremes come from the extreme cosines
    let m = [ma, mb, mc, md];
    let (mut cmin, mut cmax) = (f64::INFINITY, f64::NEG_INFINITY);
    for i in 0..4 {
        for j in i + 1..4 {
            let c = m[i].dot(&m[j]) / (l[i] * l[j]).max(f64::MIN_POSITIVE);
            cmin = cmin.min(c);
            cmax = cmax.max(c);
        }
    }
    let mut q = rr;
    // An angle term is below rr only when its angle is below rr times its
    // scale (48.64° for θ_min, 75.50° for 180° − θ_max), i.e. when
    // cmin < −cos(x) or cmax > cos(y) with x, y those angles in radians
    // (the factors rounded up, so that the test errs towards the acos);
    // cos z ≥ 1 − z²/2 lets a tetrahedron whose radius ratio is the
    // minimum skip the acos (the margin 1e-12 is far above rounding and far
    // below the bound's slack z⁴/24 where it matters)
    let (x, y) = (rr * 0.848_94, rr * 1.317_68);
    let (cmin, cmax) = (
        if cmin >= -1.0 + 0.5 * x * x + 1e-12 {
            0.0
        } else {
            cmin
        },
        if cmax <= 1.0 - 0.5 * y * y - 1e-12 {
            0.0
        } else {
            cmax
        },
    );
    // θ_min = 180° − acos(cmin) ≥ 49.5° ⇔ cmin ≥ cos(130.5°) ≈ −0.6494
    if cmin < -0.65 {
        let lo = 180.0 - cmin.clamp(-1.0, 1.0).acos().to_degrees();
        q = q.min(1.45 * lo / 70.528_779);
    }
    // θ_max = 180° − acos(cmax) ≤ 103.3° ⇔ cmax ≤ cos(76.7°) ≈ 0.2300
    if cmax > 0.23 {
        let hi = 180.0 - cmax.clamp(-1.0, 1.0).acos().to_degrees();
        q = q.min(1.45 * (180.0 - hi) / 109.471_221);
    }
    q
}

/// [`objective`] of tetrahedron `t` (indices into `pos`).
pub fn objective_of(pos: &[P3], t: &[u32; 4]) -> f64 {
    let [a, b, c, d] = t.map(|k| pos[k as usize]);
    objective(&a, &b, &c, &d)
}

/// The tetrahedra around each of `n` nodes, as a compressed table: those
/// of node v are `inc[start[v]..start[v + 1]]`, in increasing order.
pub(crate) fn node_tets(n: usize, tets: &[[u32; 4]]) -> (Vec<u32>, Vec<u32>) {
    crate::incidence::node_elements(n, tets, |v| v as usize)
}

/// Node `v`'s star gathered for a search that moves v alone (the sliver
/// pass's and the polish's): per tetrahedron the three other corners
/// (a, b, c), ordered so that [v, a, b, c] is positive, and twice the area
/// of the face (a, b, c), which does not move with v.
///
/// Why by hand: evaluating the star from the mesh's index arrays (which
/// corner is v, four loads per tetrahedron) took a third of the polish's
/// time on case K.
pub(crate) struct Star {
    faces: Vec<([P3; 3], f64)>,
}

impl Star {
    /// The star of node `v`: the tetrahedra `star` (indices into `tets`),
    /// in that order.
    pub(crate) fn gather(pos: &[P3], tets: &[[u32; 4]], star: &[u32], v: usize) -> Star {
        let faces = star
            .iter()
            .map(|&t| {
                let t = tets[t as usize];
                let k = t.iter().position(|&x| x as usize == v).unwrap_or(0);
                // [t_k, face opposite k] is an even permutation of t
                let f = TET_FACES[k].map(|i| pos[t[i] as usize]);
                let a2 = (f[1] - f[0]).cross(&(f[2] - f[0])).norm();
                (f, a2)
            })
            .collect();
        Star { faces }
    }

    /// Σ radius ratio with v at `x` ([`tet_radius_ratio`](crate::measure::tet_radius_ratio) with the fixed face's area reused), and the smallest.
    pub(crate) fn sum_min(&self, x: &P3) -> (f64, f64) {
        let (mut s, mut m) = (0.0, f64::INFINITY);
        for (f, a2) in &self.faces {
            let (u, v, w) = (f[0] - x, f[1] - x, f[2] - x);
            let (vw, wu, uv) = (v.cross(&w), w.cross(&u), u.cross(&v));
            let vol6 = u.dot(&vw);
            let q = if vol6 == 0.0 {
                0.0
            } else {
                let n = vw * u.norm_squared() + wu * v.norm_squared() + uv * w.norm_squared();
                let area = 0.5 * (uv.norm() + vw.norm() + wu.norm() + a2);
                let q = 3.0 * vol6 * vol6 / (area * n.norm());
                if vol6 > 0.0 {
                    q
                } else {
                    -q
                }
            };
            s += q;
            m = m.min(q);
        }
        (s, m)
    }

    /// Σ radius ratio with v at `x`.
    pub(crate) fn sum(&self, x: &P3) -> f64 {
        self.sum_min(x).0
    }

    /// The smallest [`objective`] with v at `x`.
    pub(crate) fn worst(&self, x: &P3) -> f64 {
        self.worst_above(x, f64::NEG_INFINITY)
            .unwrap_or(f64::NEG_INFINITY)
    }

    /// The smallest [`objective`] with v at `x`, or `None` as soon as one
    /// tetrahedron (in the star's order) is no better than `best`.
    pub(crate) fn worst_above(&self, x: &P3, best: f64) -> Option<f64> {
        let mut m = f64::INFINITY;
        for (f, _) in &self.faces {
            let q = objective(x, &f[0], &f[1], &f[2]);
            if q <= best {
                return None;
            }
            m = m.min(q);
        }
        Some(m)
    }

    /// Whether every tetrahedron is positive with v at `x` (exact).
    pub(crate) fn positive(&self, x: &P3) -> bool {
        self.faces
            .iter()
            .all(|(f, _)| orient3d(x, &f[0], &f[1], &f[2]) < 0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::measure::{dihedral_extremes, tet_radius_ratio};

    /// The fused [`objective`] against its definition from
    /// [`tet_radius_ratio`] and [`dihedral_extremes`], on random tetrahedra of
    /// every shape (regular-ish to slivers, caps, needles and inverted).
    #[test]
    fn objective_matches_its_definition() {
        let mut rnd = crate::volume::jitter_source(0x9e37_79b9_7f4a_7c15);
        let (mut skipped, mut rr_binds) = (0, 0);
        for k in 0..20000 {
            let scale = [1.0, 0.3, 0.02][k % 3];
            let p: Vec<P3> = (0..4)
                .map(|i| {
                    let base = [
                        [0., 0., 0.],
                        [1., 0., 0.],
                        [0.5, 0.87, 0.],
                        [0.5, 0.29, 0.82],
                    ][i];
                    P3::new(
                        base[0] + scale * rnd(),
                        base[1] + scale * rnd(),
                        base[2] * [1.0, 0.5, 0.05][k % 3] + scale * rnd(),
                    )
                })
                .collect();
            let rr = tet_radius_ratio(&p[0], &p[1], &p[2], &p[3]);
            let want = if rr <= 0.0 {
                rr
            } else {
                let (lo, hi) = dihedral_extremes(&p[0], &p[1], &p[2], &p[3]);
                let (a, b) = (1.45 * lo / 70.528_779, 1.45 * (180.0 - hi) / 109.471_221);
                if lo >= 49.5 && hi <= 103.3 {
                    skipped += 1;
                } else if rr < a.min(b) {
                    // the second shortcut: the angles are extreme, yet the
                    // radius ratio is the minimum
                    rr_binds += 1;
                }
                rr.min(a).min(b)
            };
            let got = objective(&p[0], &p[1], &p[2], &p[3]);
            assert!((got - want).abs() < 1e-9, "{p:?}: {got} vs {want}");
        }
        // both shortcuts were taken on some
        assert!(skipped > 100 && rr_binds > 100, "{skipped} {rr_binds}");
    }

    /// The star's sums and worst equal the measures of its tetrahedra.
    #[test]
    fn star_agrees_with_the_measures() {
        let pos = vec![
            P3::new(0.0, 0.0, 0.0),
            P3::new(1.0, 0.0, 0.0),
            P3::new(0.0, 1.0, 0.0),
            P3::new(0.0, 0.0, 1.0),
            P3::new(1.0, 1.0, 1.0),
        ];
        let tets = vec![[0, 1, 2, 3], [4, 1, 3, 2]];
        let (start, inc) = node_tets(pos.len(), &tets);
        assert_eq!(&inc[start[1] as usize..start[2] as usize], &[0, 1]);
        let star = Star::gather(&pos, &tets, &[0, 1], 1);
        let x = pos[1];
        let (sum, min) = star.sum_min(&x);
        let rr: Vec<f64> = tets
            .iter()
            .map(|t| crate::measure::tet_radius_ratio_of(&pos, t))
            .collect();
        assert!((sum - rr[0] - rr[1]).abs() < 1e-12);
        assert!((min - rr[0].min(rr[1])).abs() < 1e-12);
        let worst = tets
            .iter()
            .map(|t| objective_of(&pos, t))
            .fold(1.0, f64::min);
        assert!((star.worst(&x) - worst).abs() < 1e-12);
        assert!(star.positive(&x));
        assert!(!star.positive(&P3::new(-1.0, 0.2, 0.2)));
    }
}
