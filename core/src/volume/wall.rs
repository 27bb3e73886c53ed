//! The tetrahedra of a twin wall as its prisms, three tetrahedra each
//! ([`crate::face::twin::Wall`]).
//!
//! Across a wall carried from one side to the other, the quadrilateral
//! between two twin segments is twisted: across a bend its sides are skew,
//! across a plane out of every axis it is planar only to rounding. The
//! Delaunay tetrahedralization then splits the prisms on either side of it
//! along different diagonals and fills the space between the two splits
//! with a tetrahedron of those four corners, a sliver (as_0086's bends, 1
//! thick at d = 8: 2.6°). No flip removes it there: a prism whose three
//! diagonals turn the same way round has no split (Schönhardt's prism),
//! and both neighbours' would. Chosen for the whole wall at once, every
//! prism has a split: the earlier face's nodes are ranked, and each
//! quadrilateral is split along the diagonal from the end of lower rank,
//! so that the lowest corner of each prism carries two of its diagonals
//! (the rule of Dompierre et al. 1999, "How to subdivide pyramids, prisms
//! and hexahedra into tetrahedra", with a rank for the global node order).
//! A quadrilateral on the wall's rim keeps the diagonal the tetrahedra
//! beyond it use, which orders its two ends; the ranks are a topological
//! order of those (none where the rim's diagonals go round a loop of the
//! wall's boundary all one way).

use std::collections::{HashMap, HashSet};

use crate::face::twin::Wall;
use crate::geom::P3;
use crate::measure::{dihedral_extremes, orient3d, sorted3, sorted4, tet_volume6, TET_FACES};

use super::tet::mesh::TetMesh;

/// The twin walls of a volume, their prisms in the node ids of its
/// tetrahedral mesh (where the fixed nodes keep their ids through every
/// re-connection).
#[derive(Default)]
pub(super) struct Prisms<'w> {
    /// The walls.
    walls: Vec<Local<'w>>,
    /// Per wall, whether its last [`Prisms::split`] was made.
    split: Vec<bool>,
}

/// One wall in the tetrahedral mesh's node ids.
struct Local<'w> {
    /// Its prisms (see [`Wall`]).
    prisms: Vec<[u32; 6]>,
    /// Their corners.
    nodes: HashSet<u32>,
    wall: &'w Wall,
}

impl<'w> Prisms<'w> {
    /// The walls of `walls` whose prisms' corners are all nodes (`local`
    /// gives a mesh node's id here, `pos` where that node is) where the
    /// wall has them.
    pub(super) fn new(walls: &'w [Wall], local: &HashMap<u32, u32>, pos: &[P3]) -> Self {
        let walls: Vec<_> = walls
            .iter()
            .filter_map(|w| {
                let prisms = w
                    .ids
                    .iter()
                    .zip(&w.prisms)
                    .map(|(ids, p)| {
                        let size = (p[1] - p[0]).norm().max((p[2] - p[0]).norm());
                        let mut out = [0u32; 6];
                        for i in 0..6 {
                            out[i] = *local.get(&ids[i])?;
                            if !((pos[out[i] as usize] - p[i]).norm() <= 1e-6 * size) {
                                return None;
                            }
                        }
                        Some(out)
                    })
                    .collect::<Option<Vec<_>>>()?;
                let nodes = prisms.iter().flatten().copied().collect();
                Some(Local {
                    prisms,
                    nodes,
                    wall: w,
                })
            })
            .collect();
        Prisms {
            split: vec![false; walls.len()],
            walls,
        }
    }

    /// Re-splits every wall whose tetrahedra in `tm` are exactly its
    /// prisms' space (see the module docs) where that raises their
    /// smallest dihedral angle. A wall is left as it is where the
    /// tetrahedra among its nodes do not fill its prisms (a Steiner point,
    /// a split boundary triangle), a quadrilateral's rim forces a prism
    /// without a split, or the new tetrahedra's smallest dihedral angle
    /// would be no larger than the old ones' (a planar wall square to an
    /// axis has its quadrilaterals planar to the last bit and its prisms
    /// split already). Returns the prisms re-split.
    pub(super) fn split(&mut self, tm: &mut TetMesh) -> usize {
        let mut done = 0;
        for (k, Local { prisms, nodes, .. }) in self.walls.iter().enumerate() {
            let n = split_wall(prisms, nodes, tm);
            self.split[k] = n.is_some();
            done += n.unwrap_or(0);
        }
        done
    }

    /// Whether the corners of `t` are all nodes of one wall that its last
    /// [`Prisms::split`] split: a tetrahedron of its prisms, thin because
    /// the wall is, which a Steiner point would only make thinner.
    pub(super) fn within(&self, t: &[u32; 4]) -> bool {
        self.walls
            .iter()
            .zip(&self.split)
            .any(|(w, &split)| split && t.iter().all(|k| w.nodes.contains(k)))
    }

    /// Whether `p` is inside a wall that its last [`Prisms::split`]
    /// split: no Steiner point goes there (it would leave the wall's
    /// tetrahedra no longer its prisms', and make them thinner).
    pub(super) fn holds(&self, p: &P3) -> bool {
        self.walls
            .iter()
            .zip(&self.split)
            .any(|(w, &split)| split && w.wall.holds(p))
    }
}

/// [`Prisms::split`] for one wall; `None` where it is left as it is.
fn split_wall(prisms: &[[u32; 6]], nodes: &HashSet<u32>, tm: &mut TetMesh) -> Option<usize> {
    // the quadrilaterals on the wall's rim (over an edge of one prism's
    // triangle only): a tetrahedron of their four corners lies against the
    // wall, not in it (flat to rounding where the rim is a planar
    // quadrilateral that is not exactly so)
    let mut sides: HashMap<[u32; 2], u32> = HashMap::new();
    for p in prisms {
        for (i, j) in [(0, 1), (1, 2), (2, 0)] {
            *sides.entry([p[i].min(p[j]), p[i].max(p[j])]).or_default() += 1;
        }
    }
    let mut rim_quads = HashSet::new();
    for p in prisms {
        for (i, j) in [(0, 1), (1, 2), (2, 0)] {
            if sides[&[p[i].min(p[j]), p[i].max(p[j])]] == 1 {
                rim_quads.insert(sorted4([p[i], p[j], p[i + 3], p[j + 3]]));
            }
        }
    }
    let old: Vec<usize> = (0..tm.tets.len())
        .filter(|&i| {
            let t = &tm.tets[i];
            t.iter().all(|k| nodes.contains(k)) && !rim_quads.contains(&sorted4(*t))
        })
        .collect();

    let rim = outer_faces(old.iter().map(|&i| tm.tets[i]));
    // each quadrilateral's diagonal leaves from the end of lower rank
    // among the earlier face's nodes; a quadrilateral on the rim keeps
    // its diagonal, which orders its two ends
    let mut before: Vec<(u32, u32)> = Vec::new();
    let mut ends: HashMap<u32, u32> = HashMap::new();
    for p in prisms {
        for (i, j) in [(0, 1), (1, 2), (2, 0)] {
            let (ai, aj, bi, bj) = (p[i], p[j], p[i + 3], p[j + 3]);
            ends.insert(ai, bi);
            ends.insert(aj, bj);
            let has = |t: [u32; 3]| rim.contains(&sorted3(t));
            let from_i = has([ai, aj, bj]) || has([ai, bj, bi]);
            let from_j = has([ai, aj, bi]) || has([aj, bj, bi]);
            match (from_i, from_j) {
                (true, true) => return None,
                (true, false) => before.push((ai, aj)),
                (false, true) => before.push((aj, ai)),
                (false, false) => {}
            }
        }
    }
    let rank = rank(ends.keys().copied(), &before)?;
    let diagonal = |ai: u32, aj: u32| {
        if rank[&ai] < rank[&aj] {
            [ai, ends[&aj]]
        } else {
            [aj, ends[&ai]]
        }
    };
    let mut new = Vec::with_capacity(3 * prisms.len());
    for p in prisms {
        let diags: Vec<[u32; 2]> = [(0, 1), (1, 2), (2, 0)]
            .iter()
            .map(|&(i, j)| diagonal(p[i], p[j]))
            .collect();
        for t in split_prism(p, &diags)? {
            new.push(positive(&tm.pos, t)?);
        }
    }
    // the same space: the same outer faces and volume
    if outer_faces(new.iter().copied()) != rim {
        return None;
    }
    let volume = |ts: &mut dyn Iterator<Item = [u32; 4]>| {
        ts.map(|t| {
            let p = t.map(|k| tm.pos[k as usize]);
            tet_volume6(&p[0], &p[1], &p[2], &p[3]).abs()
        })
        .sum::<f64>()
    };
    let (v_old, v_new) = (
        volume(&mut old.iter().map(|&i| tm.tets[i])),
        volume(&mut new.iter().copied()),
    );
    if !((v_old - v_new).abs() <= 1e-9 * v_old) {
        return None;
    }
    let least = |ts: &mut dyn Iterator<Item = [u32; 4]>| {
        ts.map(|t| {
            let p = t.map(|k| tm.pos[k as usize]);
            dihedral_extremes(&p[0], &p[1], &p[2], &p[3]).0
        })
        .fold(f64::INFINITY, f64::min)
    };
    // only where it raises the wall's smallest angle: a wall whose
    // quadrilaterals are planar to the last bit (square to an axis) has
    // its prisms split already, and the sliver pass may have done better
    if !(least(&mut new.iter().copied()) > least(&mut old.iter().map(|&i| tm.tets[i]))) {
        return None;
    }
    let gone: HashSet<usize> = old.into_iter().collect();
    let mut i = 0;
    tm.tets.retain(|_| {
        i += 1;
        !gone.contains(&(i - 1))
    });
    tm.tets.extend(new);
    Some(prisms.len())
}

/// A rank for each of `nodes` (0, 1, …) with `a` below `b` for every
/// `(a, b)` of `before`, ties by node id (Kahn's topological sort); `None`
/// where `before` goes round in a circle.
fn rank(nodes: impl Iterator<Item = u32>, before: &[(u32, u32)]) -> Option<HashMap<u32, usize>> {
    use std::cmp::Reverse;
    let mut after: HashMap<u32, Vec<u32>> = HashMap::new();
    let mut waits: HashMap<u32, usize> = nodes.map(|v| (v, 0)).collect();
    for &(a, b) in before {
        after.entry(a).or_default().push(b);
        *waits.get_mut(&b)? += 1;
    }
    let mut ready: std::collections::BinaryHeap<Reverse<u32>> = waits
        .iter()
        .filter(|&(_, &w)| w == 0)
        .map(|(&v, _)| Reverse(v))
        .collect();
    let mut rank = HashMap::with_capacity(waits.len());
    while let Some(Reverse(v)) = ready.pop() {
        rank.insert(v, rank.len());
        for &b in after.get(&v).into_iter().flatten() {
            let w = waits.get_mut(&b)?;
            *w -= 1;
            if *w == 0 {
                ready.push(Reverse(b));
            }
        }
    }
    (rank.len() == waits.len()).then_some(rank)
}

/// The faces of `tets` that only one of them has, each sorted.
fn outer_faces(tets: impl Iterator<Item = [u32; 4]>) -> HashSet<[u32; 3]> {
    let mut count: HashMap<[u32; 3], u32> = HashMap::new();
    for t in tets {
        for f in TET_FACES {
            *count.entry(sorted3(f.map(|k| t[k]))).or_default() += 1;
        }
    }
    count
        .into_iter()
        .filter(|&(_, c)| c == 1)
        .map(|(f, _)| f)
        .collect()
}

/// The three tetrahedra of prism `p` (corners 0–2 one end, 3–5 the
/// other, `p[i]` across from `p[i + 3]`) whose side quadrilaterals
/// (0 1 4 3, 1 2 5 4, 2 0 3 5) are split along `diags`; `None` where the
/// diagonals turn the same way round (no split exists).
fn split_prism(p: &[u32; 6], diags: &[[u32; 2]]) -> Option<[[u32; 4]; 3]> {
    let touches = |v: u32| diags.iter().filter(|d| d.contains(&v)).count();
    // a corner where two diagonals meet: the tetrahedron of it and the far
    // end, then the pyramid of it over the quadrilateral it is not on
    let (k, &v) = p.iter().enumerate().find(|&(_, &v)| touches(v) == 2)?;
    let (end, far) = if k < 3 {
        (k, [p[3], p[4], p[5]])
    } else {
        (k - 3, [p[0], p[1], p[2]])
    };
    // the side quadrilateral without v: corners end+1 and end+2 at both ends
    let (i, j) = ((end + 1) % 3, (end + 2) % 3);
    let quad = [p[i], p[j], p[j + 3], p[i + 3]];
    let side = diags.iter().find(|d| !d.contains(&v))?;
    let others: Vec<u32> = quad.iter().copied().filter(|c| !side.contains(c)).collect();
    Some([
        [v, far[0], far[1], far[2]],
        [v, side[0], side[1], others[0]],
        [v, side[0], side[1], others[1]],
    ])
}

/// `t` ordered to be positive (exact sign); `None` where it is flat.
fn positive(pos: &[P3], mut t: [u32; 4]) -> Option<[u32; 4]> {
    let p = t.map(|k| pos[k as usize]);
    let o = orient3d(&p[0], &p[1], &p[2], &p[3]);
    if o == 0.0 {
        return None;
    }
    // orient3d is negative for a positive tetrahedron
    if o > 0.0 {
        t.swap(2, 3);
    }
    Some(t)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A prism over the triangle (0,0,0) (2,0,0) (0,2,0), 1 high, its
    /// corners twisted a little (the top's corners turned about z), and
    /// its volume: nodes 0–2 below, 3–5 above.
    fn twisted_prism() -> Vec<P3> {
        let turn = |p: P3| {
            let (s, c) = 0.05f64.sin_cos();
            P3::new(c * p.x - s * p.y, s * p.x + c * p.y, p.z)
        };
        vec![
            P3::new(0.0, 0.0, 0.0),
            P3::new(2.0, 0.0, 0.0),
            P3::new(0.0, 2.0, 0.0),
            turn(P3::new(0.0, 0.0, 1.0)),
            turn(P3::new(2.0, 0.0, 1.0)),
            turn(P3::new(0.0, 2.0, 1.0)),
        ]
    }

    /// Per side quadrilateral (0 1 4 3, 1 2 5 4, 2 0 3 5), its two
    /// diagonals.
    const CHOICES: [[[u32; 2]; 2]; 3] = [[[0, 4], [1, 3]], [[1, 5], [2, 4]], [[2, 3], [0, 5]]];

    #[test]
    fn a_prism_whose_diagonals_turn_one_way_round_has_no_split() {
        let p = [0, 1, 2, 3, 4, 5];
        // each quadrilateral's diagonal from its first bottom corner, or
        // each from its second: Schönhardt's prism either way
        for k in 0..2 {
            let diags: Vec<[u32; 2]> = CHOICES.iter().map(|c| c[k]).collect();
            assert!(split_prism(&p, &diags).is_none(), "{diags:?}");
        }
    }

    #[test]
    fn every_other_choice_of_diagonals_splits_the_prism_into_three_tetrahedra_that_fill_it() {
        let pos = twisted_prism();
        let p = [0, 1, 2, 3, 4, 5];
        let mut split = 0;
        for mask in 0..8 {
            let diags: Vec<[u32; 2]> = (0..3).map(|q| CHOICES[q][(mask >> q) & 1]).collect();
            let Some(tets) = split_prism(&p, &diags) else {
                continue;
            };
            split += 1;
            let tets: Vec<[u32; 4]> = tets.iter().map(|&t| positive(&pos, t).unwrap()).collect();
            // outside: the two ends and each side quadrilateral as the two
            // triangles of its chosen diagonal
            let mut want: HashSet<[u32; 3]> = [sorted3([0, 1, 2]), sorted3([3, 4, 5])].into();
            for (q, d) in diags.iter().enumerate() {
                let quad = [[0, 1, 4, 3], [1, 2, 5, 4], [2, 0, 3, 5]][q];
                for c in quad.iter().filter(|c| !d.contains(c)) {
                    want.insert(sorted3([d[0], d[1], *c]));
                }
            }
            assert_eq!(outer_faces(tets.iter().copied()), want, "{diags:?}");
            for t in &tets {
                let q = t.map(|k| pos[k as usize]);
                assert!(tet_volume6(&q[0], &q[1], &q[2], &q[3]) > 0.0, "{t:?}");
            }
        }
        assert_eq!(split, 6);
    }

    #[test]
    fn ranks_follow_the_order_asked_and_a_circle_has_none() {
        let r = rank([5, 1, 3, 7].into_iter(), &[(7, 1), (3, 5)]).unwrap();
        assert!(r[&7] < r[&1] && r[&3] < r[&5]);
        // ties by node id: 3 and 7 wait for nothing, 3 first
        assert_eq!(r[&3], 0);
        assert!(rank([1, 2, 3].into_iter(), &[(1, 2), (2, 3), (3, 1)]).is_none());
    }
}
