//! Local re-meshing of a volume keeps its old tetrahedra (thesis §4.8.1,
//! Figs. 4.19–4.20: the mesh away from the region is kept, and only what
//! the free bubbles occupy is connected anew).
//!
//! A local re-meshing keeps the volume's nodes outside the region and its
//! band bit for bit ([`super::warm`]). Here the old tetrahedra among them
//! are kept too:
//!
//! 1. **Kept tetrahedra** ([`kept_tets`]): an old tetrahedron (from the
//!    state, as corner positions) stays when each corner is a kept node of
//!    the new run (a boundary node or a kept bubble, found by its exact
//!    coordinates), it is still positive, a face of it on the boundary is a
//!    boundary triangle seen from inside, and no other node of the new run
//!    lies in it or on it.
//! 2. **The cavity** ([`Cavity::of`]): the rest of the volume. Its
//!    boundary is the boundary triangles no kept tetrahedron has, and the
//!    kept tetrahedra's faces that no other kept tetrahedron shares and
//!    that are not boundary triangles (the interface, oriented away from
//!    the cavity). Its nodes are the nodes on that boundary (fixed), kept
//!    nodes in no kept tetrahedron (fixed), and the free bubbles.
//! 3. The cavity goes through the volume's usual connection (conforming
//!    Delaunay, flood from the boundary), sliver pass with Steiner points
//!    (only inside the cavity) and polish. An interface triangle that the
//!    connection cannot recover hands the kept tetrahedra at its corners
//!    to the cavity, and it is tried again ([`RECOVERY_ROUNDS`]).
//! 4. The kept and the new tetrahedra together must form a tetrahedral
//!    complex whose boundary is exactly the volume's boundary triangles
//!    ([`is_complex`]); if not — or if anything above fails — the caller
//!    connects the whole volume as before (the nodes are kept either way).
//!
//! The steps are this module's; the volume's passes run them in order
//! ([`super`]'s `connect_keeping`).
//!
//! Invariants: kept tetrahedra are written with the old corner coordinates
//! bit for bit; no new node lies in a kept tetrahedron; the result passes
//! [`is_complex`] or is not used.

// Fx hashing (rustc-hash): the keys are node indices and coordinate bits
// of one run, not input an attacker chooses, and SipHash was a tenth of a
// warm re-meshing's time
use rustc_hash::{FxHashMap as HashMap, FxHashSet as HashSet};

use super::tet::mesh::TetMesh;
use crate::geom::P3;
use crate::measure::{sorted3, TET_FACES};
use crate::remesh::state::bits;

/// Rounds of handing kept tetrahedra to the cavity where an interface
/// triangle is not recovered. Each round is a Delaunay tetrahedralization
/// of the cavity's nodes only; on fixtures/step/sliver_faces.step (a local
/// re-meshing at 0.8, 110,000 old tetrahedra) the triangles not recovered
/// went 582, 112, 40, 19, 7 over the first five rounds (4 rounds then
/// connected the whole volume anew, losing 106 far nodes to the boundary
/// recovery).
pub(super) const RECOVERY_ROUNDS: usize = 12;

fn c3(p: &P3) -> robust::Coord3D<f64> {
    robust::Coord3D {
        x: p.x,
        y: p.y,
        z: p.z,
    }
}

/// `robust::orient3d(a, b, c, d) > 0`: `d` on the inner side of the
/// outward-oriented triangle (a, b, c) (the convention of
/// [`super::connect`]'s flood).
fn orient(a: &P3, b: &P3, c: &P3, d: &P3) -> f64 {
    robust::orient3d(c3(a), c3(b), c3(c), c3(d))
}

/// A positive tetrahedron in our convention (det(b−a, c−a, d−a) > 0).
fn positive(pos: &[P3], t: &[u32; 4]) -> bool {
    let [a, b, c, d] = t.map(|k| pos[k as usize]);
    orient(&a, &b, &c, &d) < 0.0
}

/// Whether the triangles `x` and `y` are the same oriented triangle.
fn same_turn(x: [u32; 3], y: [u32; 3]) -> bool {
    x == y || x == [y[1], y[2], y[0]] || x == [y[2], y[0], y[1]]
}

/// Face `k` of `t`, oriented outward.
fn face(t: &[u32; 4], k: usize) -> [u32; 3] {
    TET_FACES[k].map(|i| t[i])
}

/// A bucket grid over tetrahedra, for "which of them contain this point".
pub(super) struct TetGrid<'a> {
    pos: &'a [P3],
    tets: &'a [[u32; 4]],
    cell: f64,
    cells: HashMap<[i64; 3], Vec<u32>>,
}

impl<'a> TetGrid<'a> {
    /// Buckets `tets` (indices into `pos`) by their bounding boxes; the
    /// cell is the largest box side (so a box meets at most 8 cells).
    pub(super) fn new(pos: &'a [P3], tets: &'a [[u32; 4]]) -> TetGrid<'a> {
        let boxes: Vec<(P3, P3)> = tets
            .iter()
            .map(|t| {
                let (mut lo, mut hi) = (pos[t[0] as usize], pos[t[0] as usize]);
                for &k in &t[1..] {
                    let p = pos[k as usize];
                    for i in 0..3 {
                        lo[i] = lo[i].min(p[i]);
                        hi[i] = hi[i].max(p[i]);
                    }
                }
                (lo, hi)
            })
            .collect();
        let cell = boxes
            .iter()
            .map(|(lo, hi)| (hi - lo).max())
            .fold(0.0, f64::max)
            .max(f64::MIN_POSITIVE);
        let mut cells: HashMap<[i64; 3], Vec<u32>> = HashMap::default();
        for (ti, (lo, hi)) in boxes.iter().enumerate() {
            let (a, b) = (key(lo, cell), key(hi, cell));
            for x in a[0]..=b[0] {
                for y in a[1]..=b[1] {
                    for z in a[2]..=b[2] {
                        cells.entry([x, y, z]).or_default().push(ti as u32);
                    }
                }
            }
        }
        TetGrid {
            pos,
            tets,
            cell,
            cells,
        }
    }

    /// The tetrahedra that contain `p` or have it on their boundary
    /// (exact), other than those with `p` as a corner.
    pub(super) fn containing(&self, p: &P3) -> impl Iterator<Item = u32> + '_ {
        let p = *p;
        self.cells
            .get(&key(&p, self.cell))
            .into_iter()
            .flatten()
            .copied()
            .filter(move |&ti| {
                let t = &self.tets[ti as usize];
                !t.iter().any(|&k| self.pos[k as usize] == p)
                    && (0..4).all(|k| {
                        let [a, b, c] = face(t, k).map(|v| self.pos[v as usize]);
                        orient(&a, &b, &c, &p) >= 0.0
                    })
            })
    }
}

fn key(p: &P3, cell: f64) -> [i64; 3] {
    [0, 1, 2].map(|i| (p[i] / cell).floor() as i64)
}

/// The old tetrahedra `old` (corner positions) that stay, as indices into
/// `pos` (see the module docs, step 1). `pos`: the volume's nodes, the
/// first `n_fixed` on its boundary, the first `n_keep` fixed (boundary
/// nodes, then kept bubbles); `boundary`: its outward triangles.
pub(super) fn kept_tets(
    pos: &[P3],
    n_fixed: usize,
    n_keep: usize,
    boundary: &[[u32; 3]],
    old: &[[P3; 4]],
) -> Vec<[u32; 4]> {
    let index: HashMap<[u64; 3], u32> = pos[..n_keep]
        .iter()
        .enumerate()
        .map(|(k, p)| (bits(p), k as u32))
        .collect();
    let bset: HashMap<[u32; 3], [u32; 3]> = boundary.iter().map(|t| (sorted3(*t), *t)).collect();
    let mut tets: Vec<[u32; 4]> = old
        .iter()
        .filter_map(|t| {
            let mut out = [0u32; 4];
            for (o, p) in out.iter_mut().zip(t) {
                *o = *index.get(&bits(p))?;
            }
            Some(out)
        })
        .filter(|t| positive(pos, t))
        .filter(|t| {
            // a face among boundary nodes that is a boundary triangle must
            // be seen from inside (the tetrahedron on the inner side)
            (0..4).all(|k| {
                let f = face(t, k);
                if f.iter().any(|&v| v as usize >= n_fixed) {
                    return true;
                }
                bset.get(&sorted3(f)).is_none_or(|&b| same_turn(f, b))
            })
        })
        .collect();
    // no other node in or on a kept tetrahedron
    let mut corner = vec![false; pos.len()];
    for t in &tets {
        for &k in t {
            corner[k as usize] = true;
        }
    }
    let mut drop: HashSet<u32> = HashSet::default();
    {
        let grid = TetGrid::new(pos, &tets);
        for (k, p) in pos.iter().enumerate() {
            if !corner[k] {
                drop.extend(grid.containing(p));
            }
        }
    }
    if !drop.is_empty() {
        let mut k = 0;
        tets.retain(|_| {
            k += 1;
            !drop.contains(&(k - 1))
        });
    }
    // an old mesh is a complex: a face in three kept tetrahedra is not
    let mut count: HashMap<[u32; 3], u8> = HashMap::default();
    for t in &tets {
        for k in 0..4 {
            let c = count.entry(sorted3(face(t, k))).or_insert(0);
            *c += 1;
            if *c > 2 {
                return Vec::new();
            }
        }
    }
    tets
}

/// The part of the volume the kept tetrahedra leave (module docs, step 2),
/// in its own node numbering.
pub(super) struct Cavity {
    /// The cavity's node `k` is the volume's node `nodes[k]`: first those
    /// on its boundary (`n_fixed`), then the other fixed ones (`n_keep` in
    /// all), then the free ones.
    pub nodes: Vec<u32>,
    pub n_fixed: usize,
    pub n_keep: usize,
    /// Its boundary, outward, in its own numbering.
    pub boundary: Vec<[u32; 3]>,
    /// Which of those are the volume's boundary triangles (the others are
    /// the interface with the kept tetrahedra).
    #[cfg_attr(not(test), allow(dead_code))]
    pub on_surface: Vec<bool>,
}

impl Cavity {
    /// The cavity the kept tetrahedra `kept` leave in a volume with nodes
    /// `0..n_nodes` (the first `n_keep` fixed) and outward boundary
    /// triangles `boundary`. `None` when the kept tetrahedra cover the
    /// volume.
    pub(super) fn of(
        n_nodes: usize,
        n_keep: usize,
        boundary: &[[u32; 3]],
        kept: &[[u32; 4]],
    ) -> Option<Cavity> {
        let mut faces: HashMap<[u32; 3], ([u32; 3], u8)> = HashMap::default();
        for t in kept {
            for k in 0..4 {
                let f = face(t, k);
                faces.entry(sorted3(f)).or_insert((f, 0)).1 += 1;
            }
        }
        let bset: HashSet<[u32; 3]> = boundary.iter().map(|t| sorted3(*t)).collect();
        let mut sides: Vec<([u32; 3], bool)> = boundary
            .iter()
            .filter(|t| !faces.contains_key(&sorted3(**t)))
            .map(|t| (*t, true))
            .collect();
        let mut interface: Vec<[u32; 3]> = faces
            .iter()
            .filter(|(s, (_, n))| *n == 1 && !bset.contains(*s))
            // outward from the cavity: into the kept tetrahedron
            .map(|(_, (f, _))| [f[0], f[2], f[1]])
            .collect();
        interface.sort_unstable();
        sides.extend(interface.into_iter().map(|t| (t, false)));
        if sides.is_empty() {
            return None;
        }
        let mut corner = vec![false; n_nodes];
        for t in kept {
            for &k in t {
                corner[k as usize] = true;
            }
        }
        let mut on_side = vec![false; n_nodes];
        for (t, _) in &sides {
            for &k in t {
                on_side[k as usize] = true;
            }
        }
        let mut nodes: Vec<u32> = (0..n_nodes as u32)
            .filter(|&k| on_side[k as usize])
            .collect();
        let n_fixed = nodes.len();
        let inner = |k: &u32| !on_side[*k as usize] && !corner[*k as usize];
        nodes.extend((0..n_keep as u32).filter(inner));
        let n_keep_c = nodes.len();
        nodes.extend((n_keep as u32..n_nodes as u32).filter(inner));
        let mut local = vec![u32::MAX; n_nodes];
        for (i, &k) in nodes.iter().enumerate() {
            local[k as usize] = i as u32;
        }
        Some(Cavity {
            nodes,
            n_fixed,
            n_keep: n_keep_c,
            boundary: sides
                .iter()
                .map(|(t, _)| t.map(|k| local[k as usize]))
                .collect(),
            on_surface: sides.iter().map(|(_, s)| *s).collect(),
        })
    }
}

/// Hands kept tetrahedra over to the cavity `cav` where its boundary
/// triangles `triangles` (indices into `cav.boundary`) were not recovered:
/// those at their corners, and those with a corner in their diametral balls
/// (a kept node there blocks the triangle, and only the cavity's free
/// nodes may be removed). `pos`: the volume's nodes. False when none was.
pub(super) fn hand_over(
    pos: &[P3],
    cav: &Cavity,
    triangles: &[u32],
    kept: &mut Vec<[u32; 4]>,
) -> bool {
    let mut at: HashSet<u32> = HashSet::default();
    let (mut centres, mut radii) = (Vec::new(), Vec::new());
    for &k in triangles {
        let t = cav.boundary[k as usize].map(|v| cav.nodes[v as usize]);
        at.extend(t);
        let [a, b, c] = t.map(|v| pos[v as usize]);
        let (centre, r) = crate::measure::triangle_circumball(&a, &b, &c);
        // a needle's ball is huge and its blockers are near it: then the
        // ball about its centroid through its farthest corner's distance
        // doubled (so the grid below stays fine)
        let longest = (b - a).norm().max((c - b).norm()).max((a - c).norm());
        if r <= 2.0 * longest {
            centres.push(centre);
            radii.push(r);
        } else {
            centres.push(P3::from((a.coords + b.coords + c.coords) / 3.0));
            radii.push(longest);
        }
    }
    // the balls bucketed by their largest radius (hundreds of balls
    // against a hundred thousand kept tetrahedra)
    let rmax = radii.iter().cloned().fold(f64::MIN_POSITIVE, f64::max);
    let grid = crate::bubbles::grid::Grid::new(&centres, rmax);
    let in_ball = |v: u32| {
        let p = pos[v as usize];
        let mut hit = false;
        grid.query(&p, rmax, |j| {
            hit |= (p - centres[j as usize]).norm() <= radii[j as usize];
        });
        hit
    };
    let before = kept.len();
    kept.retain(|t| !t.iter().any(|&v| at.contains(&v) || in_ball(v)));
    kept.len() < before
}

/// The volume's mesh from the kept tetrahedra `kept` (indices into `tm`'s
/// nodes) and the cavity's mesh `c` (in the numbering of `cav`): `tm`'s
/// first `n_keep` nodes (the fixed ones, which the kept tetrahedra and the
/// cavity's boundary use), then the cavity's other nodes (free bubbles at
/// their new positions, Steiner points).
pub(super) fn merged(
    tm: &TetMesh,
    n_keep: usize,
    kept: Vec<[u32; 4]>,
    c: &TetMesh,
    cav: &Cavity,
) -> TetMesh {
    let mut out = TetMesh {
        pos: tm.pos[..n_keep].to_vec(),
        d: tm.d[..n_keep].to_vec(),
        movable: vec![false; n_keep],
        tets: kept,
    };
    let map: Vec<u32> = (0..c.pos.len())
        .map(|i| {
            if i < cav.n_keep {
                cav.nodes[i]
            } else {
                out.pos.push(c.pos[i]);
                out.d.push(c.d[i]);
                out.movable.push(true);
                (out.pos.len() - 1) as u32
            }
        })
        .collect();
    out.tets
        .extend(c.tets.iter().map(|t| t.map(|k| map[k as usize])));
    out
}

/// The sliver pass's target for a cavity's last pass ([`raise_worst`]).
pub(super) const CAVITY_TARGET: f64 = 0.6;

/// One more sliver pass over the cavity's tetrahedra below
/// [`CAVITY_TARGET`] (the whole volume's stops at
/// [`TARGET_Q`](super::tet::star::TARGET_Q)); what it did, if anything was
/// below.
///
/// Why: a warm start is judged against meshing from scratch, and a
/// cavity's worst tetrahedra are where the change is, next to fixed
/// nodes (the kept ones and the re-meshed faces'), with less room than
/// from scratch. The cavity is small, so its worst can be asked for more
/// at little cost; the pass only accepts moves and flips that raise the
/// worst of what they touch.
pub(super) fn raise_worst(c: &mut TetMesh) -> Option<super::tet::SliverStats> {
    let params = super::tet::sliver::SliverParams {
        target: CAVITY_TARGET,
        ..Default::default()
    };
    super::tet::sliver::remove_slivers_near_bad(c, &params).map(|(s, _)| s)
}

/// Whether `tets` (indices into `pos`) form a tetrahedral complex whose
/// boundary is exactly `boundary` (outward triangles): every tetrahedron
/// positive (exact), every face in one or two tetrahedra (two: on opposite
/// sides), the faces in one exactly the boundary triangles, seen from
/// inside, and the tetrahedra's volumes summing to the volume the boundary
/// encloses (no part covered twice).
pub(super) fn is_complex(pos: &[P3], tets: &[[u32; 4]], boundary: &[[u32; 3]]) -> bool {
    if !tets.iter().all(|t| positive(pos, t)) {
        return false;
    }
    let mut faces: HashMap<[u32; 3], ([u32; 3], u8)> =
        HashMap::with_capacity_and_hasher(2 * tets.len(), Default::default());
    for t in tets {
        for k in 0..4 {
            let f = face(t, k);
            let e = faces.entry(sorted3(f)).or_insert((f, 0));
            e.1 += 1;
            if e.1 == 2 && !same_turn([f[0], f[2], f[1]], e.0) || e.1 > 2 {
                return false;
            }
        }
    }
    let mut open = faces.values().filter(|(_, n)| *n == 1).count();
    for b in boundary {
        match faces.get(&sorted3(*b)) {
            Some((f, 1)) if same_turn(*f, *b) => open -= 1,
            _ => return false,
        }
    }
    if open != 0 {
        return false;
    }
    // 6 V two ways: the tetrahedra, and the divergence theorem over the
    // boundary (Σ a·(b×c)), both about the centroid of the boundary nodes
    let o = boundary
        .iter()
        .flatten()
        .fold(crate::geom::V3::zeros(), |s, &k| s + pos[k as usize].coords)
        / (3 * boundary.len()).max(1) as f64;
    let rel = |k: u32| pos[k as usize].coords - o;
    let (mut v_tets, mut scale) = (0.0, 0.0);
    for t in tets {
        let [a, b, c, d] = t.map(rel);
        let v = (b - a).cross(&(c - a)).dot(&(d - a));
        v_tets += v;
        scale += v.abs();
    }
    let v_shell: f64 = boundary
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(rel);
            a.dot(&b.cross(&c))
        })
        .sum();
    (v_tets - v_shell).abs() <= 1e-9 * scale.max(f64::MIN_POSITIVE)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit cube split into six positive tetrahedra around its diagonal
    /// 0–6, with its twelve outward boundary triangles.
    fn cube() -> (Vec<P3>, Vec<[u32; 4]>, Vec<[u32; 3]>) {
        let pos: Vec<P3> = (0..8)
            .map(|i| P3::new((i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64))
            .collect();
        // corners 0 = (0,0,0), 7 = (1,1,1); six tetrahedra 0–7–a–b
        let ring = [1u32, 3, 2, 6, 4, 5];
        let mut tets = Vec::new();
        for k in 0..6 {
            let mut t = [0, 7, ring[k], ring[(k + 1) % 6]];
            if !positive(&pos, &t) {
                t.swap(2, 3);
            }
            tets.push(t);
        }
        let mut boundary = Vec::new();
        for t in &tets {
            for k in 0..4 {
                let f = face(t, k);
                if !(f.contains(&0) && f.contains(&7)) {
                    boundary.push(f);
                }
            }
        }
        (pos, tets, boundary)
    }

    #[test]
    fn a_cube_of_six_tetrahedra_is_a_complex_and_a_missing_or_doubled_one_is_not() {
        let (pos, tets, boundary) = cube();
        assert_eq!(boundary.len(), 12);
        assert!(is_complex(&pos, &tets, &boundary));
        assert!(!is_complex(&pos, &tets[1..], &boundary));
        let mut twice = tets.clone();
        twice.push(tets[0]);
        assert!(!is_complex(&pos, &twice, &boundary));
        let mut inverted = tets.clone();
        inverted[2].swap(0, 1);
        assert!(!is_complex(&pos, &inverted, &boundary));
    }

    /// Kept tetrahedra are found by exact coordinates; a node of the new
    /// run inside one drops it; the cavity is bounded by the remaining
    /// boundary triangles and the kept ones' open faces, and kept plus a
    /// filling of the cavity is a complex.
    #[test]
    fn kept_tetrahedra_and_their_cavity() {
        let (pos, tets, boundary) = cube();
        let old: Vec<[P3; 4]> = tets.iter().map(|t| t.map(|k| pos[k as usize])).collect();
        // every node kept (all on the boundary): all six stay
        let kept = kept_tets(&pos, 8, 8, &boundary, &old);
        assert_eq!(kept.len(), 6);
        assert!(Cavity::of(8, 8, &boundary, &kept).is_none());
        // one coordinate changed by one ulp: the three tetrahedra at that
        // corner (the ring's node 2 is in two, not in the others) go
        let mut moved = pos.clone();
        moved[2].x = f64::from_bits(moved[2].x.to_bits() + 1);
        let kept = kept_tets(&moved, 8, 8, &boundary, &old);
        let with2 = tets.iter().filter(|t| t.contains(&2)).count();
        assert_eq!(kept.len(), 6 - with2);
        // a free node at the centre lies on the diagonal 0–7: on every
        // tetrahedron, so none stays
        let mut with_centre = pos.clone();
        with_centre.push(P3::new(0.5, 0.5, 0.5));
        assert!(kept_tets(&with_centre, 8, 8, &boundary, &old).is_empty());
        // keep four of six; the cavity is the other two, bounded by their
        // four boundary triangles and the two interface faces
        let kept = &tets[..4];
        let cav = Cavity::of(8, 8, &boundary, kept).unwrap();
        assert_eq!(cav.boundary.len(), 6);
        assert_eq!(cav.on_surface.iter().filter(|&&s| s).count(), 4);
        let fill: Vec<[u32; 4]> = tets[4..].to_vec();
        let mut all = kept.to_vec();
        all.extend(fill.iter().copied());
        assert!(is_complex(&pos, &all, &boundary));
        // and the cavity's own boundary is that of its filling
        let back: Vec<[u32; 3]> = cav
            .boundary
            .iter()
            .map(|t| t.map(|k| cav.nodes[k as usize]))
            .collect();
        assert!(is_complex(&pos, &fill, &back));
    }
}
