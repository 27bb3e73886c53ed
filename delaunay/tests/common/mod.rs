//! Independent validity checker for a `Tetrahedralization` (exact predicates
//! from `robust`, written against the documented invariants, not the
//! implementation's internals), plus point generators.
#![allow(dead_code)]

use bubblemesh_delaunay::{Tetrahedralization, HULL};
use robust::{insphere, orient3d, Coord3D};
use std::collections::{HashMap, HashSet};

fn c(p: [f64; 3]) -> Coord3D<f64> {
    Coord3D {
        x: p[0],
        y: p[1],
        z: p[2],
    }
}

/// Exact sign, > 0 iff (a,b,c,d) is right-handed (positive signed volume).
pub fn orient(a: [f64; 3], b: [f64; 3], cc: [f64; 3], d: [f64; 3]) -> f64 {
    -orient3d(c(a), c(b), c(cc), c(d))
}

/// Exact, > 0 iff e strictly inside the circumsphere of the right-handed tet.
pub fn inside(a: [f64; 3], b: [f64; 3], cc: [f64; 3], d: [f64; 3], e: [f64; 3]) -> bool {
    -insphere(c(a), c(b), c(cc), c(d), c(e)) > 0.0
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Signed volume of (a,b,c,d) in floating point.
pub fn volume(a: [f64; 3], b: [f64; 3], cc: [f64; 3], d: [f64; 3]) -> f64 {
    dot(sub(b, a), cross(sub(cc, a), sub(d, a))) / 6.0
}

/// Which empty-sphere check to run.
#[derive(Clone, Copy, PartialEq)]
pub enum Sphere {
    /// Every tet against every point (exact, with a float prefilter).
    Global,
    /// Every interior face: the neighbour's opposite vertex is not strictly
    /// inside (with validity this implies the global property).
    Local,
}

/// Summary of a checked tetrahedralization.
pub struct Checked {
    pub hull_faces: usize,
    pub volume: f64,
}

/// Asserts every documented invariant; `expected_volume` is the convex hull
/// volume when known analytically.
pub fn check(
    pts: &[[f64; 3]],
    t: &Tetrahedralization,
    expected_volume: Option<f64>,
    sphere: Sphere,
) -> Checked {
    let n = pts.len();
    assert_eq!(t.tets.len(), t.neighbours.len());
    assert!(!t.tets.is_empty());
    let p = |i: u32| pts[i as usize];
    // Duplicates: each (dup, kept) has equal coordinates, kept is not itself a duplicate.
    let dup_set: HashSet<u32> = t.duplicates.iter().map(|d| d.0).collect();
    assert_eq!(
        dup_set.len(),
        t.duplicates.len(),
        "duplicate reported twice"
    );
    for &(d, k) in &t.duplicates {
        assert_ne!(d, k);
        assert_eq!(
            p(d),
            p(k),
            "duplicate pair ({d},{k}) has different coordinates"
        );
        assert!(!dup_set.contains(&k));
    }
    // Tets: valid, distinct indices, positive orientation.
    let mut used = vec![false; n];
    let mut vol = 0.0;
    for (ti, v) in t.tets.iter().enumerate() {
        for &x in v {
            assert!((x as usize) < n, "tet {ti} has vertex {x} out of range");
            assert!(!dup_set.contains(&x), "tet {ti} uses duplicate {x}");
            used[x as usize] = true;
        }
        let o = orient(p(v[0]), p(v[1]), p(v[2]), p(v[3]));
        assert!(o > 0.0, "tet {ti} {v:?} is not positively oriented ({o})");
        vol += volume(p(v[0]), p(v[1]), p(v[2]), p(v[3]));
    }
    // Every distinct point is a vertex.
    for (i, &u) in used.iter().enumerate() {
        assert!(u || dup_set.contains(&(i as u32)), "point {i} is in no tet");
    }
    // Faces: each shared by at most two tets, consistent with the neighbours.
    let face = |v: &[u32; 4], i: usize| {
        let mut f = [v[(i + 1) % 4], v[(i + 2) % 4], v[(i + 3) % 4]];
        f.sort_unstable();
        f
    };
    let mut faces: HashMap<[u32; 3], Vec<(u32, usize)>> = HashMap::new();
    for (ti, v) in t.tets.iter().enumerate() {
        for i in 0..4 {
            faces.entry(face(v, i)).or_default().push((ti as u32, i));
        }
    }
    let mut hull = Vec::new();
    for (f, users) in &faces {
        assert!(
            users.len() <= 2,
            "face {f:?} is shared by {} tets",
            users.len()
        );
        if users.len() == 2 {
            let (a, i) = users[0];
            let (b, j) = users[1];
            assert_eq!(
                t.neighbours[a as usize][i], b,
                "neighbour of {a} across {f:?}"
            );
            assert_eq!(
                t.neighbours[b as usize][j], a,
                "neighbour of {b} across {f:?}"
            );
        } else {
            let (a, i) = users[0];
            assert_eq!(
                t.neighbours[a as usize][i], HULL,
                "face {f:?} of tet {a} is on the hull"
            );
            hull.push((a, i));
        }
    }
    // Neighbour symmetry over the arrays themselves.
    for (ti, nb) in t.neighbours.iter().enumerate() {
        for (i, &u) in nb.iter().enumerate() {
            if u != HULL {
                assert!((u as usize) < t.tets.len());
                assert!(t.neighbours[u as usize].contains(&(ti as u32)));
                assert_eq!(face(&t.tets[ti], i).len(), 3);
            }
        }
    }
    // Hull faces are supporting planes: no point strictly outside; and the
    // volume they enclose (divergence theorem) matches the sum of the tets.
    let mut hull_vol = 0.0;
    let o = pts[0];
    let stride = (hull.len() * n / 200_000_000).max(1);
    for &(a, i) in &hull {
        let v = t.tets[a as usize];
        // Replacing v[i] by a point outside must give a negative tet. (For
        // benchmark-sized inputs every `stride`-th point, to bound the cost.)
        for (q, &pq) in pts.iter().enumerate().step_by(stride) {
            let mut w = v.map(p);
            w[i] = pq;
            assert!(
                orient(w[0], w[1], w[2], w[3]) >= 0.0,
                "point {q} is outside hull face {i} of tet {a}: hull is not convex"
            );
        }
        let mut w = v.map(p);
        w[i] = o;
        // Cone from o to the face: positive when o is on the inner side.
        hull_vol += volume(w[0], w[1], w[2], w[3]);
    }
    let scale = vol.abs().max(1e-300);
    assert!(
        (vol - hull_vol).abs() <= 1e-9 * scale,
        "sum of tet volumes {vol} != volume enclosed by hull faces {hull_vol}"
    );
    if let Some(e) = expected_volume {
        assert!(
            (vol - e).abs() <= 1e-9 * e.abs(),
            "volume {vol} != expected {e}"
        );
    }
    // Empty spheres.
    match sphere {
        Sphere::Local => {
            for (ti, v) in t.tets.iter().enumerate() {
                for (i, &u) in t.neighbours[ti].iter().enumerate() {
                    if u == HULL {
                        continue;
                    }
                    let w = t.tets[u as usize];
                    let opp = *w.iter().find(|x| !v.contains(x)).unwrap();
                    let _ = i;
                    assert!(
                        !inside(p(v[0]), p(v[1]), p(v[2]), p(v[3]), p(opp)),
                        "tet {ti} is not locally Delaunay: vertex {opp} of neighbour {u} inside"
                    );
                }
            }
        }
        Sphere::Global => {
            for (ti, v) in t.tets.iter().enumerate() {
                let [a, b, cc, d] = v.map(p);
                let filter = circumsphere(a, b, cc, d);
                for (q, &pq) in pts.iter().enumerate() {
                    if let Some((cen, r2)) = filter {
                        let dd = sub(pq, cen);
                        if dot(dd, dd) > r2 * (1.0 + 1e-6) {
                            continue;
                        }
                    }
                    assert!(
                        !inside(a, b, cc, d, pq),
                        "point {q} is strictly inside the circumsphere of tet {ti} {v:?}"
                    );
                }
            }
        }
    }
    Checked {
        hull_faces: hull.len(),
        volume: vol,
    }
}

/// Float circumcentre and squared radius, or None when ill-conditioned (then
/// the caller tests every point exactly).
fn circumsphere(a: [f64; 3], b: [f64; 3], c: [f64; 3], d: [f64; 3]) -> Option<([f64; 3], f64)> {
    let (u, v, w) = (sub(b, a), sub(c, a), sub(d, a));
    let det = 2.0 * dot(u, cross(v, w));
    let l = dot(u, u).max(dot(v, v)).max(dot(w, w));
    if det.abs() < 1e-6 * l.powf(1.5) {
        return None;
    }
    let num = [
        dot(u, u) * cross(v, w)[0] + dot(v, v) * cross(w, u)[0] + dot(w, w) * cross(u, v)[0],
        dot(u, u) * cross(v, w)[1] + dot(v, v) * cross(w, u)[1] + dot(w, w) * cross(u, v)[1],
        dot(u, u) * cross(v, w)[2] + dot(v, v) * cross(w, u)[2] + dot(w, w) * cross(u, v)[2],
    ];
    let rel = [num[0] / det, num[1] / det, num[2] / det];
    let r2 = dot(rel, rel);
    Some(([a[0] + rel[0], a[1] + rel[1], a[2] + rel[2]], r2))
}

/// Tets as a sorted list of sorted vertex sets (for comparing results).
pub fn canonical(tets: &[[u32; 4]]) -> Vec<[u32; 4]> {
    let mut v: Vec<[u32; 4]> = tets
        .iter()
        .map(|t| {
            let mut s = *t;
            s.sort_unstable();
            s
        })
        .collect();
    v.sort_unstable();
    v
}

/// Deterministic uniform numbers in [0, 1) (SplitMix64).
pub struct Rng(pub u64);
impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    pub fn shuffle<T>(&mut self, v: &mut [T]) {
        for i in (1..v.len()).rev() {
            let j = (self.next_u64() % (i as u64 + 1)) as usize;
            v.swap(i, j);
        }
    }
}

/// `n` uniform points in the unit cube plus its 8 corners (hull volume 1).
pub fn cube_points(n: usize, seed: u64) -> Vec<[f64; 3]> {
    let mut r = Rng(seed);
    let mut pts: Vec<[f64; 3]> = (0..n)
        .map(|_| [r.uniform(), r.uniform(), r.uniform()])
        .collect();
    for k in 0..8 {
        pts.push([(k & 1) as f64, ((k >> 1) & 1) as f64, ((k >> 2) & 1) as f64]);
    }
    pts
}

/// The m×m×m cubic lattice with unit spacing.
pub fn cubic_lattice(m: usize) -> Vec<[f64; 3]> {
    let mut pts = Vec::new();
    for i in 0..m {
        for j in 0..m {
            for k in 0..m {
                pts.push([i as f64, j as f64, k as f64]);
            }
        }
    }
    pts
}

/// Face-centred cubic lattice: integer points of [0, m]^3 with an even
/// coordinate sum (m even, so the 8 cube corners are in it).
pub fn fcc_lattice(m: usize) -> Vec<[f64; 3]> {
    let mut pts = Vec::new();
    for i in 0..=m {
        for j in 0..=m {
            for k in 0..=m {
                if (i + j + k) % 2 == 0 {
                    pts.push([i as f64, j as f64, k as f64]);
                }
            }
        }
    }
    pts
}
