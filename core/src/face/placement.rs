//! Stage 1 on faces: initial bubble placement by hierarchical subdivision
//! (thesis §4.1.2), the *oblique quadtree* of 60°/120° rhombi, which gives a
//! hexagonal lattice where the spacing is uniform. (Edges: `edge::placement`,
//! §4.1.1.)
//!
//! All placement is O(n) in the number of bubbles placed.

use crate::geom::{P3, V3};

use crate::bubbles::balls::Balls;
use crate::bubbles::constraint::Carrier;
pub(crate) use crate::bubbles::MAX_BUBBLES_PER_ENTITY;
use crate::error::{check_spacing, MeshError};
use crate::model::EntityRef;
use crate::spacing::{Spacing, SpacingQuery};

/// d at a point of a face and its (u,v), checked finite and positive.
pub type FaceSpacing<'a> = dyn FnMut(&P3, [f64; 2]) -> Result<f64, MeshError> + 'a;

/// A free bubble proposed by stage 1.
pub struct Seed {
    pub pos: P3,
    pub params: [f64; 2],
    pub d: f64,
}

/// The oblique quadtree (§4.1.2) over the parameter box `lo..hi`.
///
/// Cells are rhombi with a 60° corner at the lower left, sides `l·(1,0)` and
/// `l·(1/2, √3/2)` in (u,v) (eq. 4.1.1). A cell is split into four while any
/// of the corner pairs (1,2), (2,3), (3,4), (2,4) is farther apart in model
/// space than `SPLIT`·(d_i + d_j)/2 (eq. 4.1.3–4.1.4, with the factor SPLIT
/// explained below); bubbles go on the corners of the leaves that lie
/// inside the entity. A pair whose first-order length at the cell's centre
/// is over twice that threshold splits the cell too, whatever its chord:
/// around a periodic surface a root cell many periods wide has corners at
/// nearly one point (a hole's face of 6 by 5 spacings once got no interior
/// bubble at all).
///
/// `SPLIT` = √2 instead of the thesis's 1: leaves then have sides in
/// (d/√2, √2·d] instead of (d/2, d], so the stage-1 density is right on
/// average instead of up to four times too high. With a uniform spacing
/// `uniform` = Some(d/scale) sets the root size to d·2^k so the leaves are
/// exactly d: the hexagonal lattice of Fig. 4.1a. Corners outside the
/// entity use `d_outside` = [least, largest] boundary spacing: the least
/// in a cell with a corner inside (so cells straddling the boundary are as
/// fine as the boundary), the largest in a cell wholly outside. A thin
/// diagonal band in (u,v) leaves most of its box outside; refining all of
/// that to the boundary's least spacing (tiny where one of its edges is a
/// small circle) made millions of cells.
pub fn oblique_quadtree<C: Carrier>(
    carrier: &C,
    lo: [f64; 2],
    hi: [f64; 2],
    uniform_leaf: Option<f64>,
    d_outside: [f64; 2],
    d_at: &mut FaceSpacing<'_>,
) -> Result<Vec<Seed>, MeshError> {
    const SPLIT: f64 = std::f64::consts::SQRT_2;
    const MAX_LEVEL: u32 = 30;
    let s3 = 3f64.sqrt();
    let (w, h) = (hi[0] - lo[0], hi[1] - lo[1]);
    let uniform_leaf = uniform_leaf.filter(|l| l.is_finite() && *l > 0.0);
    // Root corner 1 sits h/√3 left of the box's lower-left corner so the
    // rhombus covers the box; with a uniform leaf the shift is a whole number
    // of leaves, so the lattice passes through (lo.u, lo.v).
    let shift = match uniform_leaf {
        Some(l) => ((h / s3) / l).ceil() * l,
        None => h / s3,
    };
    let origin = [lo[0] - shift, lo[1]];
    let need = (w + shift).max(2.0 * h / s3) * 1.0001 + f64::MIN_POSITIVE;
    let l0 = match uniform_leaf {
        Some(l) => {
            let k = (need / l).log2().ceil().max(0.0);
            if k > MAX_LEVEL as f64 {
                return Err(MeshError::TooManyBubbles {
                    limit: MAX_BUBBLES_PER_ENTITY,
                });
            }
            l * 2f64.powi(k as i32)
        }
        None => need,
    };
    // a uniform spacing tells the count up front (eq. 4.7.2 on the box)
    if let Some(l) = uniform_leaf {
        let estimate = (w * h) / (0.5 * s3 * l * l);
        if estimate > MAX_BUBBLES_PER_ENTITY as f64 {
            return Err(MeshError::TooManyBubbles {
                limit: MAX_BUBBLES_PER_ENTITY,
            });
        }
    }
    // lattice point (i, j) at level `lev` -> (u,v)
    let at = |i: i64, j: i64, lev: u32| -> [f64; 2] {
        let l = l0 / f64::from(1u32 << lev.min(31));
        let (fi, fj) = (i as f64 * l, j as f64 * l);
        [origin[0] + fi + 0.5 * fj, origin[1] + 0.5 * s3 * fj]
    };
    let key = |i: i64, j: i64, lev: u32| -> (i64, i64) {
        let s = MAX_LEVEL - lev;
        (i << s, j << s)
    };
    let mut seen = Corners::default();
    // leaf corners as lattice keys at the finest level; deduplicated below
    let mut corners: Vec<(i64, i64)> = Vec::new();
    let mut stack: Vec<(i64, i64, u32)> = vec![(0, 0, 0)];
    while let Some((i, j, lev)) = stack.pop() {
        let cuv = [
            at(i, j, lev),
            at(i + 1, j, lev),
            at(i + 1, j + 1, lev),
            at(i, j + 1, lev),
        ];
        // OUT: the cell's box misses the entity's box
        let (mut clo, mut chi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for c in &cuv {
            for k in 0..2 {
                clo[k] = clo[k].min(c[k]);
                chi[k] = chi[k].max(c[k]);
            }
        }
        if chi[0] < lo[0] || clo[0] > hi[0] || chi[1] < lo[1] || clo[1] > hi[1] {
            continue;
        }
        let split = match uniform_leaf {
            Some(l) => {
                let lev_leaf = (l0 / l).log2().round() as u32;
                lev < lev_leaf
            }
            None => {
                let ids = [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)];
                let mut cs = [Corner::default(); 4];
                for ((c, uv), (ci, cj)) in cs.iter_mut().zip(cuv).zip(ids) {
                    *c = seen.at(carrier, key(ci, cj, lev), uv, d_at)?;
                }
                graded_split(carrier, &cuv, cs, d_outside, SPLIT)
            }
        };
        if split && lev < MAX_LEVEL {
            let (i2, j2, l2) = (2 * i, 2 * j, lev + 1);
            stack.push((i2, j2, l2));
            stack.push((i2 + 1, j2, l2));
            stack.push((i2, j2 + 1, l2));
            stack.push((i2 + 1, j2 + 1, l2));
            continue;
        }
        for (ci, cj) in [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)] {
            corners.push(key(ci, cj, lev));
        }
        if corners.len() > 2 * MAX_BUBBLES_PER_ENTITY {
            return Err(MeshError::TooManyBubbles {
                limit: MAX_BUBBLES_PER_ENTITY,
            });
        }
    }
    // row-major order (v, then u), each corner once
    corners.sort_unstable_by_key(|&(i, j)| (j, i));
    corners.dedup();
    let mut out = Vec::with_capacity(corners.len());
    for (ki, kj) in corners {
        let uv = at(ki, kj, MAX_LEVEL);
        let (p, d) = match seen.0.get(&(ki, kj)) {
            Some(c) if !c.inside => continue,
            Some(c) => (c.p, c.d),
            None => {
                if !carrier.contains(uv) {
                    continue;
                }
                let p = carrier.point(uv);
                (p, d_at(&p, uv)?)
            }
        };
        out.push(Seed {
            pos: p,
            params: uv,
            d,
        });
    }
    Ok(out)
}
/// A lattice corner of [`oblique_quadtree`] as its split test sees it: its
/// point, whether it lies inside the entity and, inside, its spacing.
#[derive(Clone, Copy, Default)]
struct Corner {
    p: P3,
    inside: bool,
    d: f64,
}

/// The corners evaluated so far, by lattice key at the finest level.
/// Neighbouring cells share corners, so each is evaluated once; keys are
/// exact, a corner's (u,v) being the same bits at every level (the cell
/// size is l0/2^lev).
#[derive(Default)]
struct Corners(rustc_hash::FxHashMap<(i64, i64), Corner>);

impl Corners {
    /// The corner of key `k` at (u,v) `uv`, evaluated if it is new.
    fn at<C: Carrier>(
        &mut self,
        carrier: &C,
        k: (i64, i64),
        uv: [f64; 2],
        d_at: &mut FaceSpacing<'_>,
    ) -> Result<Corner, MeshError> {
        if let Some(c) = self.0.get(&k) {
            return Ok(*c);
        }
        let inside = carrier.contains(uv);
        let p = carrier.point(uv);
        // the spacing is only asked inside the entity (it may be undefined
        // outside)
        let d = if inside { d_at(&p, uv)? } else { f64::NAN };
        let c = Corner { p, inside, d };
        self.0.insert(k, c);
        Ok(c)
    }
}

/// The split test of [`oblique_quadtree`] under a graded spacing: whether a
/// pair of the cell's corners is farther apart than `split` times their
/// mean spacing, by its chord, or by its tangent length at the cell's
/// centre where that is over twice the threshold (a chord wrapping around
/// a periodic surface is short however far apart the corners are along
/// it). Corners outside take `d_outside` (see there).
fn graded_split<C: Carrier>(
    carrier: &C,
    cuv: &[[f64; 2]; 4],
    mut cs: [Corner; 4],
    d_outside: [f64; 2],
    split: f64,
) -> bool {
    let outside_d = if cs.iter().any(|c| c.inside) {
        d_outside[0]
    } else {
        d_outside[1]
    };
    for c in cs.iter_mut().filter(|c| !c.inside) {
        c.d = outside_d;
    }
    let centre = [0.5 * (cuv[0][0] + cuv[2][0]), 0.5 * (cuv[0][1] + cuv[2][1])];
    [(0, 1), (1, 2), (2, 3), (1, 3)].iter().any(|&(a, b)| {
        let limit = split * 0.5 * (cs[a].d + cs[b].d);
        let duv = [cuv[b][0] - cuv[a][0], cuv[b][1] - cuv[a][1]];
        (cs[a].p - cs[b].p).norm() > limit
            || carrier
                .tangent_length(centre, duv)
                .is_some_and(|t| t > 2.0 * limit)
    })
}

/// Boundary-layer seeds: for each boundary segment a→b (face on its left) one
/// bubble at the apex of the triangle whose sides to a and b are the stable
/// distance r0 (an equilateral triangle when the spacing is uniform).
///
/// This departs from the thesis, whose stage 1 is the quadtree alone: the
/// quadtree's lattice has one orientation, so along a boundary that is not
/// parallel to it the first layer of bubbles is frustrated and the
/// relaxation leaves dislocations there (measured on the unit square: the
/// worst triangles all touched the vertical sides). Seeding the first layer
/// from the boundary puts that misfit one layer inside, where both sides can
/// move. Seeds outside the face are dropped.
pub fn apex_seeds<C: Carrier>(
    carrier: &C,
    ring: &Ring<'_>,
    d_at: &mut FaceSpacing<'_>,
) -> Result<Vec<Seed>, MeshError> {
    let mut out = Vec::with_capacity(ring.directed.len());
    for &[a, b] in ring.directed {
        let Some(ap) = segment_apex(carrier, ring, a, b, d_at)? else {
            continue;
        };
        if !carrier.contains(ap.apex_uv) {
            continue;
        }
        let p = carrier.point(ap.apex_uv);
        let dd = d_at(&p, ap.apex_uv)?;
        out.push(Seed {
            pos: p,
            params: ap.apex_uv,
            d: dd,
        });
    }
    Ok(out)
}

/// The fixed (boundary) bubbles of a face as stage 1's boundary seeding
/// reads them: the directed boundary segments (face on their left) as
/// index pairs into the bubbles' positions, (u,v) and spacings.
pub struct Ring<'r> {
    pub directed: &'r [[usize; 2]],
    pub pos: &'r [P3],
    pub uv: &'r [[f64; 2]],
    pub d: &'r [f64],
}

/// The near-equilateral triangle over a boundary segment a→b
/// ([`apex_seeds`]): its midpoint, the left normal in (u,v) (`nuv`, of
/// model length `scale` per unit of parameter), the unit inward normal in
/// model space, the stable distance r0 and the apex's (u,v), which may lie
/// outside the face. `None` for a segment of zero length or a degenerate
/// parameterisation.
struct SegmentApex {
    mid: P3,
    mid_uv: [f64; 2],
    nuv: [f64; 2],
    scale: f64,
    inward: V3,
    r0: f64,
    apex_uv: [f64; 2],
}

fn segment_apex<C: Carrier>(
    carrier: &C,
    ring: &Ring<'_>,
    a: usize,
    b: usize,
    d_at: &mut FaceSpacing<'_>,
) -> Result<Option<SegmentApex>, MeshError> {
    let (pos, uv, d) = (ring.pos, ring.uv, ring.d);
    let l = (pos[b] - pos[a]).norm();
    if l <= 0.0 {
        return Ok(None);
    }
    let mid_uv = [0.5 * (uv[a][0] + uv[b][0]), 0.5 * (uv[a][1] + uv[b][1])];
    let du = [uv[b][0] - uv[a][0], uv[b][1] - uv[a][1]];
    // left normal in (u,v), scaled to unit length in model space
    let nuv = [-du[1], du[0]];
    let mid = carrier.point(mid_uv);
    let probe = carrier.point([mid_uv[0] + 1e-6 * nuv[0], mid_uv[1] + 1e-6 * nuv[1]]);
    let scale = (probe - mid).norm() / 1e-6;
    if !(scale > 0.0) {
        return Ok(None);
    }
    let r0 = 0.5 * (0.5 * (d[a] + d[b]) + d_at(&mid, mid_uv)?);
    let height = (r0 * r0 - 0.25 * l * l).max(l * l / 12.0).sqrt();
    let t = height / scale;
    Ok(Some(SegmentApex {
        mid,
        mid_uv,
        nuv,
        scale,
        inward: (probe - mid) / (probe - mid).norm(),
        r0,
        apex_uv: [mid_uv[0] + t * nuv[0], mid_uv[1] + t * nuv[1]],
    }))
}

/// Stage 1's seeds `all` (in order of priority) with the middle row of
/// narrow strips ([`strip_seeds`]) first: the others are kept where they do
/// not crowd a fixed bubble, a strip seed or (with `check_seeds`) an
/// earlier kept seed. The strips come first because a lattice seed sitting
/// in a strip leaves it half empty: bubbles there sit in the hollows
/// between the two sides and do not spread along it.
pub fn after_strips<C: Carrier>(
    carrier: &C,
    ring: &Ring<'_>,
    d_at: &mut FaceSpacing<'_>,
    all: Vec<Seed>,
    check_seeds: bool,
) -> Result<Vec<Seed>, MeshError> {
    let (pos, d) = (ring.pos, ring.d);
    let strip = uncrowded(strip_seeds(carrier, ring, d_at)?, &[], &[], true);
    if strip.is_empty() {
        return Ok(uncrowded(all, pos, d, check_seeds));
    }
    let taken_pos: Vec<P3> = pos
        .iter()
        .cloned()
        .chain(strip.iter().map(|s| s.pos))
        .collect();
    let taken_d: Vec<f64> = d.iter().cloned().chain(strip.iter().map(|s| s.d)).collect();
    let mut kept = strip;
    // seeds of one lattice cannot crowd each other, strip seeds can
    kept.extend(uncrowded(all, &taken_pos, &taken_d, true));
    Ok(kept)
}

/// Seeds along the middle of strips between two stretches of boundary
/// [`STRIP_ROW`] to [`STRIP_WIDEST`] stable distances apart (a fillet, a
/// narrow band of a face), where neither [`apex_seeds`] nor the quadtree
/// can place a bubble: one at the apex crowds the other side's boundary
/// bubbles. Without them such a strip is connected by one row of
/// triangles as tall as the strip is wide (radius ratio ≈ 0.75 at a width
/// of 1.6·d); a middle row halves their height.
///
/// For each boundary segment a→b whose apex (as in [`apex_seeds`]) lies
/// within r0 of a boundary bubble j across the strip (within 45° of the
/// segment's inward normal), the seed lies on that normal (to first order
/// in (u,v)) halfway to j's distance along it, kept when it lies
/// in the face and no boundary bubble is closer to it than
/// [`STRIP_CLEARANCE`]·r0. The caller drops seeds that crowd others
/// ([`uncrowded`]).
pub fn strip_seeds<C: Carrier>(
    carrier: &C,
    ring: &Ring<'_>,
    d_at: &mut FaceSpacing<'_>,
) -> Result<Vec<Seed>, MeshError> {
    let mut out = Vec::new();
    if ring.pos.is_empty() {
        return Ok(out);
    }
    let grid = BoundaryGrid::new(ring);
    for &[a, b] in ring.directed {
        let Some((ap, _, width)) = across_strip(carrier, ring, &grid, a, b, d_at)? else {
            continue;
        };
        if !(STRIP_ROW * ap.r0..=STRIP_WIDEST * ap.r0).contains(&width) {
            continue;
        }
        let Some((m_uv, p)) = halfway(carrier, &ap, width) else {
            continue;
        };
        out.extend(grid.clear_seed(ring, p, m_uv, d_at)?);
    }
    Ok(out)
}

/// Middle-row bubbles added to strips after stage 2, where two rows of
/// triangles beat one.
///
/// [`strip_seeds`] starts strips of at least [`STRIP_ROW`]·r0 with a
/// middle row, but population control deletes it in the narrower ones (a
/// bubble 0.77·r0 from four fixed ones has an excess ratio of 0.9, over the
/// 0.7 limit), and below that width one row was taken to be better. That
/// holds when the two sides' bubbles are staggered (the one row is then of
/// near-equilateral triangles); where they face each other — a wall
/// between two parallel edges meshed alike, the commonest strip of a
/// machined part — the one row is of near-right triangles (radius ratio
/// 0.82 at a width of 1.2·r0) while two rows of half the height give 0.92
/// (Gmsh's frontal insertion places that row too).
///
/// For each boundary segment a→b with a boundary bubble j across the strip
/// ([`across_strip`]) and no free bubble nearer to the segment's apex than
/// j, the seed m halfway across over the segment's midpoint is proposed
/// when the radius ratio of the triangle (a, b, m) exceeds that of
/// (a, b, j) by [`STRIP_ROW_GAIN`]; it is kept when it lies in the face,
/// no boundary bubble is closer than [`STRIP_CLEARANCE`]·r0, and neither a
/// free bubble (`free`: positions and spacings) nor an earlier kept seed
/// is closer than 0.75·r0 ([`uncrowded`]).
pub fn strip_rows<C: Carrier>(
    carrier: &C,
    ring: &Ring<'_>,
    free: (&[P3], &[f64]),
    d_at: &mut FaceSpacing<'_>,
) -> Result<Vec<Seed>, MeshError> {
    use crate::measure::triangle_radius_ratio;
    let mut out = Vec::new();
    if ring.pos.is_empty() {
        return Ok(out);
    }
    let grid = BoundaryGrid::new(ring);
    let (free_pos, free_d) = free;
    // cells of 1.5 times the least spacing, or a tree where spacings
    // spread far (see bubbles::grid)
    let free_points = crate::bubbles::grid::Grid::for_spacings(free_pos, free_d, 1.5);
    for &[a, b] in ring.directed {
        let Some((ap, j, width)) = across_strip(carrier, ring, &grid, a, b, d_at)? else {
            continue;
        };
        if width > STRIP_WIDEST * ap.r0 {
            continue;
        }
        let apex = carrier.point(ap.apex_uv);
        let to_j = (ring.pos[j] - apex).norm();
        let mut free_nearer = false;
        free_points.query(&apex, to_j, |k| {
            free_nearer |= (free_pos[k as usize] - apex).norm() < to_j;
        });
        if free_nearer {
            continue;
        }
        let Some((m_uv, p)) = halfway(carrier, &ap, width) else {
            continue;
        };
        let (pa, pb) = (&ring.pos[a], &ring.pos[b]);
        let one_row = triangle_radius_ratio(pa, pb, &ring.pos[j]);
        let two_rows = triangle_radius_ratio(pa, pb, &p);
        if two_rows > one_row + STRIP_ROW_GAIN {
            out.extend(grid.clear_seed(ring, p, m_uv, d_at)?);
        }
    }
    Ok(uncrowded(out, free_pos, free_d, true))
}

/// How much better (in radius ratio) the triangle over a boundary segment
/// must get for [`strip_rows`] to add a middle bubble: a margin over the
/// first-order estimate, which ignores that the row's bubbles are then
/// moved by the improvement.
pub const STRIP_ROW_GAIN: f64 = 0.03;

/// The boundary bubbles of a ring as balls of radius d/2 (their spacings
/// may span orders of magnitude, see [`Balls`]), for the searches across
/// a strip.
struct BoundaryGrid {
    balls: Balls,
}

impl BoundaryGrid {
    fn new(ring: &Ring<'_>) -> Self {
        BoundaryGrid {
            balls: Balls::new(ring.pos, |k| 0.5 * ring.d[k]),
        }
    }

    /// The seed at `p` (parameters `uv`) with its spacing, unless a
    /// boundary bubble k is closer to it than [`STRIP_CLEARANCE`]·(d + d_k)/2.
    fn clear_seed(
        &self,
        ring: &Ring<'_>,
        p: P3,
        uv: [f64; 2],
        d_at: &mut FaceSpacing<'_>,
    ) -> Result<Option<Seed>, MeshError> {
        let d = d_at(&p, uv)?;
        // STRIP_CLEARANCE < 1: the balls of radius d/2 reach every blocker
        let clear = !self.balls.any(&p, 0.5 * d, |k| {
            (ring.pos[k] - p).norm() < STRIP_CLEARANCE * 0.5 * (d + ring.d[k])
        });
        Ok(clear.then_some(Seed {
            pos: p,
            params: uv,
            d,
        }))
    }
}

/// The point halfway across a strip of `width` over segment `ap`'s
/// midpoint (along its normal, to first order in (u,v)): its (u,v) and
/// position, `None` outside the face.
fn halfway<C: Carrier>(carrier: &C, ap: &SegmentApex, width: f64) -> Option<([f64; 2], P3)> {
    let t = 0.5 * width / ap.scale;
    let m_uv = [ap.mid_uv[0] + t * ap.nuv[0], ap.mid_uv[1] + t * ap.nuv[1]];
    carrier.contains(m_uv).then(|| (m_uv, carrier.point(m_uv)))
}

/// The boundary bubble j across a strip from segment a→b, if any: the one
/// nearest to the segment's apex ([`segment_apex`], inside the face),
/// within one stable distance of it, and seen from the segment's midpoint
/// within 45° of the inward normal (not a neighbour along the boundary);
/// with the apex and the strip's width there (the distance from the
/// midpoint to j along the inward normal).
fn across_strip<C: Carrier>(
    carrier: &C,
    ring: &Ring<'_>,
    grid: &BoundaryGrid,
    a: usize,
    b: usize,
    d_at: &mut FaceSpacing<'_>,
) -> Result<Option<(SegmentApex, usize, f64)>, MeshError> {
    let (pos, d) = (ring.pos, ring.d);
    let Some(ap) = segment_apex(carrier, ring, a, b, d_at)? else {
        return Ok(None);
    };
    if !carrier.contains(ap.apex_uv) {
        return Ok(None);
    }
    let apex = carrier.point(ap.apex_uv);
    let mut across: Option<(usize, f64)> = None;
    grid.balls.each(&apex, 0.5 * ap.r0, |j| {
        let dist = (pos[j] - apex).norm();
        let to_j = pos[j] - ap.mid;
        // the nearest, the lowest index among equally near ones (the
        // search's order does not decide)
        if j != a
            && j != b
            && dist < 0.5 * (ap.r0 + d[j])
            && to_j.dot(&ap.inward) >= std::f64::consts::FRAC_1_SQRT_2 * to_j.norm()
            && across.is_none_or(|(k, best)| dist < best || (dist == best && j < k))
        {
            across = Some((j, dist));
        }
    });
    Ok(across.map(|(j, _)| {
        let width = (pos[j] - ap.mid).dot(&ap.inward);
        (ap, j, width)
    }))
}

/// The narrowest strip, in stable distances r0, that gets a middle row of
/// bubbles ([`strip_seeds`]): below it one row of triangles of height w is
/// better than two of height w/2 (w = √2·0.87·r0 is where they are equal).
pub const STRIP_ROW: f64 = 1.3;

/// The widest strip [`strip_seeds`] considers; wider ones get apex seeds.
pub const STRIP_WIDEST: f64 = 2.5;

/// How close, in stable distances, a strip seed may be to a boundary
/// bubble (half a strip of [`STRIP_ROW`] is 0.65).
pub const STRIP_CLEARANCE: f64 = 0.6;

/// The seeds, in order, that do not crowd a fixed bubble or (with
/// `check_seeds`) an earlier kept seed: closer than 0.75·r0.
pub(crate) fn uncrowded(
    all: Vec<Seed>,
    fixed_pos: &[P3],
    fixed_d: &[f64],
    check_seeds: bool,
) -> Vec<Seed> {
    // each bubble as a ball of radius CROWD·d/2: two crowd each other when
    // their balls overlap (the spacings may span orders of magnitude, see
    // bubbles::balls)
    const CROWD: f64 = 0.75;
    let fixed = Balls::new(fixed_pos, |j| CROWD * 0.5 * fixed_d[j]);
    let mut keep: Vec<bool> = all
        .iter()
        .map(|s| {
            !fixed.any(&s.pos, CROWD * 0.5 * s.d, |j| {
                (fixed_pos[j] - s.pos).norm() < CROWD * 0.5 * (s.d + fixed_d[j])
            })
        })
        .collect();
    if check_seeds {
        let spos: Vec<P3> = all.iter().map(|s| s.pos).collect();
        let seeds = Balls::new(&spos, |j| CROWD * 0.5 * all[j].d);
        for i in 0..all.len() {
            if keep[i] {
                let (p, d) = (spos[i], all[i].d);
                if seeds.any(&p, CROWD * 0.5 * d, |j| {
                    j < i && keep[j] && (spos[j] - p).norm() < CROWD * 0.5 * (d + all[j].d)
                }) {
                    keep[i] = false;
                }
            }
        }
    }
    all.into_iter()
        .zip(keep)
        .filter(|(_, k)| *k)
        .map(|(s, _)| s)
        .collect()
}

/// d(x) on face `fe` at a point and its (u,v), checked finite and positive:
/// the spacing stage 1 asks of a face.
pub(crate) fn spacing_on<'s>(
    spacing: &'s dyn Spacing,
    fe: EntityRef,
) -> impl FnMut(&P3, [f64; 2]) -> Result<f64, MeshError> + 's {
    move |p, uv| {
        let d = spacing.spacing(&SpacingQuery {
            point: *p,
            entity: fe,
            params: uv,
        });
        check_spacing(d, *p, fe)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bubbles::testing::Square;

    fn graded(x: f64) -> f64 {
        0.05 + 0.1 * x
    }

    /// A strip of the unit square 1.5 stable distances wide (d = 0.1,
    /// between y = 0 and 0.15): every boundary segment's apex crowds the
    /// other side, and the seeds go down the middle, one over each segment.
    /// Three times wider the strip has room for apex seeds and gets none.
    #[test]
    fn strip_seeds_run_down_the_middle_of_a_narrow_strip() {
        let (n, d) = (10, 0.1);
        for (width, expect) in [(0.15, true), (0.45, false)] {
            let mut pos = Vec::new();
            let mut uv = Vec::new();
            for y in [0.0, width] {
                for k in 0..=n {
                    let x = k as f64 / n as f64;
                    pos.push(P3::new(x, y, 0.0));
                    uv.push([x, y]);
                }
            }
            // bottom left to right, top right to left: the strip on the left
            let mut boundary: Vec<[usize; 2]> = (0..n).map(|k| [k, k + 1]).collect();
            boundary.extend((0..n).map(|k| [n + 2 + k, n + 1 + k]));
            let ds = vec![d; pos.len()];
            let mut d_at = |_: &P3, _: [f64; 2]| Ok(d);
            let ring = Ring {
                directed: &boundary,
                pos: &pos,
                uv: &uv,
                d: &ds,
            };
            let seeds = strip_seeds(&Square, &ring, &mut d_at).unwrap();
            if !expect {
                assert!(seeds.is_empty(), "{} seeds {width} wide", seeds.len());
                continue;
            }
            assert_eq!(seeds.len(), 2 * n, "one per segment of either side");
            for s in &seeds {
                assert!(
                    (s.pos.y - 0.5 * width).abs() < 1e-6,
                    "a seed off the middle: {:?}",
                    s.pos
                );
                let k = (s.pos.x * n as f64 - 0.5).round();
                assert!(
                    (s.pos.x - (k + 0.5) / n as f64).abs() < 1e-9,
                    "not over a segment: {:?}",
                    s.pos
                );
            }
            // the two sides propose the same row: one of each pair is kept
            assert_eq!(uncrowded(seeds, &[], &[], true).len(), n);
        }
    }

    /// [`strip_rows`] proposes a middle row where the two sides' bubbles
    /// face each other (one row of right triangles), none where they are
    /// staggered (one row of near-equilateral triangles is better), and
    /// none over a segment whose apex a free bubble already serves.
    #[test]
    fn strip_rows_only_where_the_sides_face_each_other() {
        let (n, d, width) = (10usize, 0.1, 0.12);
        // bottom at x = k/n, top at x = (k + shift)/n
        let strip = |shift: f64| {
            let mut pos = Vec::new();
            let mut uv = Vec::new();
            for (y, s) in [(0.0, 0.0), (width, shift)] {
                for k in 0..=n {
                    let x = (k as f64 + s) / n as f64;
                    pos.push(P3::new(x, y, 0.0));
                    uv.push([x, y]);
                }
            }
            let mut boundary: Vec<[usize; 2]> = (0..n).map(|k| [k, k + 1]).collect();
            boundary.extend((0..n).map(|k| [n + 2 + k, n + 1 + k]));
            (pos, uv, boundary)
        };
        let mut d_at = |_: &P3, _: [f64; 2]| Ok(d);
        let rows = |pos: &[P3],
                    uv: &[[f64; 2]],
                    b: &[[usize; 2]],
                    free: &[P3],
                    d_at: &mut FaceSpacing<'_>| {
            let ds = vec![d; pos.len()];
            let ring = Ring {
                directed: b,
                pos,
                uv,
                d: &ds,
            };
            let fd = vec![d; free.len()];
            strip_rows(&Square, &ring, (free, &fd), d_at).unwrap()
        };
        let (pos, uv, b) = strip(0.0);
        let seeds = rows(&pos, &uv, &b, &[], &mut d_at);
        assert_eq!(seeds.len(), n, "one middle bubble per segment");
        for s in &seeds {
            assert!(
                (s.pos.y - 0.5 * width).abs() < 1e-9,
                "off the middle: {:?}",
                s.pos
            );
        }
        let (pos, uv, b) = strip(0.5);
        let staggered = rows(&pos, &uv, &b, &[], &mut d_at);
        assert!(
            staggered.is_empty(),
            "{} seeds between staggered sides",
            staggered.len()
        );
        let (pos, uv, b) = strip(0.0);
        let free: Vec<P3> = (0..n)
            .map(|k| P3::new((k as f64 + 0.5) / n as f64, 0.08, 0.0))
            .collect();
        let served = rows(&pos, &uv, &b, &free, &mut d_at);
        assert!(
            served.is_empty(),
            "{} seeds beside free bubbles",
            served.len()
        );
    }

    /// Seeds of the oblique quadtree (§4.1.2) on the unit square, counted
    /// against the hexagonal lattice's density 2/(√3 d²): exact leaves for a
    /// uniform spacing give the lattice itself; for a graded one the
    /// leaves' sides lie in (d/√2, √2 d], and the count in the middle of
    /// the square (away from the cells that straddle its boundary, where
    /// the corners outside take `d_outside`) is right on average.
    #[test]
    fn quadtree_seed_density_matches_the_spacing() {
        // the lattice's bubbles over [a, b]² for a spacing varying with x
        let expected = |d: &dyn Fn(f64) -> f64, a: f64, b: f64| -> f64 {
            let m = 1000;
            let w = (b - a) / m as f64;
            (0..m)
                .map(|k| {
                    let x = a + (k as f64 + 0.5) * w;
                    2.0 / (3f64.sqrt() * d(x) * d(x)) * w * (b - a)
                })
                .sum()
        };
        let inside =
            |s: &Seed, a: f64, b: f64| (a..b).contains(&s.pos.x) && (a..b).contains(&s.pos.y);
        // uniform: the lattice
        let d = 0.05;
        let mut d_at = |_: &P3, _: [f64; 2]| Ok(d);
        let seeds =
            oblique_quadtree(&Square, [0.0, 0.0], [1.0, 1.0], Some(d), [d, d], &mut d_at).unwrap();
        let e = expected(&|_| d, 0.0, 1.0);
        let n = seeds.len() as f64;
        assert!((n - e).abs() < 0.05 * e, "{n} seeds, {e:.0} expected");
        for s in &seeds {
            let nearest = seeds
                .iter()
                .filter(|t| !std::ptr::eq(*t, s))
                .map(|t| (t.pos - s.pos).norm())
                .fold(f64::INFINITY, f64::min);
            assert!((nearest - d).abs() < 1e-9, "nearest {nearest}");
        }
        // graded
        let mut d_at = |p: &P3, _: [f64; 2]| Ok(graded(p.x));
        let seeds = oblique_quadtree(
            &Square,
            [0.0, 0.0],
            [1.0, 1.0],
            None,
            [0.05, 0.05],
            &mut d_at,
        )
        .unwrap();
        let e = expected(&graded, 0.2, 0.8);
        let n = seeds.iter().filter(|s| inside(s, 0.2, 0.8)).count() as f64;
        assert!((n - e).abs() < 0.25 * e, "{n} seeds, {e:.0} expected");
    }

    /// Half a cylinder of radius 16 around z, u ∈ [0, π] (radians), v ∈
    /// [−21.84, 23.16]: a hole's face of `as_0042` (realstep).
    struct HalfCylinder;

    impl Carrier for HalfCylinder {
        fn entity(&self) -> crate::model::EntityRef {
            crate::model::EntityRef::new(2, 0)
        }
        fn advance(&self, _: &P3, _: [f64; 2], _: &crate::geom::V3) -> Option<(P3, [f64; 2])> {
            None
        }
        fn frame(&self, p: [f64; 2]) -> (crate::geom::V3, crate::geom::V3) {
            (
                crate::geom::V3::new(-p[0].sin(), p[0].cos(), 0.0),
                crate::geom::V3::z(),
            )
        }
        fn contains(&self, p: [f64; 2]) -> bool {
            (0.0..=std::f64::consts::PI).contains(&p[0]) && (-21.84..=23.16).contains(&p[1])
        }
        fn point(&self, p: [f64; 2]) -> P3 {
            P3::new(16.0 * p[0].cos(), 16.0 * p[0].sin(), p[1])
        }
        fn normal(&self, p: [f64; 2]) -> crate::geom::V3 {
            crate::geom::V3::new(p[0].cos(), p[0].sin(), 0.0)
        }
        fn planar(&self) -> bool {
            false
        }
        fn tangent_length(&self, p: [f64; 2], duv: [f64; 2]) -> Option<f64> {
            let (su, sv) = (self.frame(p).0 * 16.0, crate::geom::V3::z());
            Some((su * duv[0] + sv * duv[1]).norm())
        }
    }

    /// The quadtree's root cell around a cylinder is many periods wide in
    /// u (radians against millimetres in v), so its corners' chords are
    /// short and it was never split: a face of 6 by 5 spacings got two
    /// seeds, both on its boundary, and was connected from its boundary
    /// alone (`as_0042`, q 0.5). Splitting on the tangent length gives the
    /// face its lattice.
    #[test]
    fn quadtree_fills_a_cylinder_whose_root_cell_wraps_around() {
        let d = 8.452;
        let mut d_at = |_: &P3, _: [f64; 2]| Ok(d);
        let (lo, hi) = ([0.0, -21.84], [std::f64::consts::PI, 23.16]);
        let seeds = oblique_quadtree(&HalfCylinder, lo, hi, None, [d, d], &mut d_at).unwrap();
        // every point of the face is within a spacing of a seed (the
        // surplus of an anisotropic (u,v) is stage 1's crowding check's)
        for i in 0..=20 {
            for j in 0..=20 {
                let uv = [
                    lo[0] + (hi[0] - lo[0]) * i as f64 / 20.0,
                    lo[1] + (hi[1] - lo[1]) * j as f64 / 20.0,
                ];
                let p = HalfCylinder.point(uv);
                let near = seeds
                    .iter()
                    .map(|s| (s.pos - p).norm())
                    .fold(f64::INFINITY, f64::min);
                assert!(
                    near < d,
                    "(u,v) = {uv:?} is {near} from the nearest of {} seeds",
                    seeds.len()
                );
            }
        }
    }
}
