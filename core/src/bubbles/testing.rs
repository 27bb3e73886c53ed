//! Small bubble systems for the unit tests of the bubble physics: carriers
//! on the unit square of the xy plane and on the x axis, and lattices to
//! fill them with; the straight curve for tests that build a model; and
//! the tests' pseudo-random numbers.

use crate::bubbles::constraint::Carrier;
use crate::bubbles::system::System;
use crate::geom::{P3, V3};
use crate::model::EntityRef;
use crate::spacing::Constant;

pub(crate) use crate::geom::Segment;

/// Bubbles on the unit square [0,1]² of the xy plane; (u,v) = (x,y).
pub(crate) struct Square;

impl Carrier for Square {
    fn entity(&self) -> EntityRef {
        EntityRef::new(2, 0)
    }
    fn advance(&self, _pos: &P3, params: [f64; 2], dx: &V3) -> Option<(P3, [f64; 2])> {
        let uv = [params[0] + dx.x, params[1] + dx.y];
        self.contains(uv).then(|| (P3::new(uv[0], uv[1], 0.0), uv))
    }
    fn frame(&self, _params: [f64; 2]) -> (V3, V3) {
        (V3::x(), V3::y())
    }
    fn contains(&self, p: [f64; 2]) -> bool {
        (0.0..=1.0).contains(&p[0]) && (0.0..=1.0).contains(&p[1])
    }
    fn point(&self, p: [f64; 2]) -> P3 {
        P3::new(p[0], p[1], 0.0)
    }
    fn normal(&self, _params: [f64; 2]) -> V3 {
        V3::z()
    }
    fn planar(&self) -> bool {
        true
    }
}

/// Bubbles on the segment [0,1] of the x axis; u = x.
pub(crate) struct Line;

impl Carrier for Line {
    fn entity(&self) -> EntityRef {
        EntityRef::new(1, 0)
    }
    fn advance(&self, _pos: &P3, params: [f64; 2], dx: &V3) -> Option<(P3, [f64; 2])> {
        let uv = [params[0] + dx.x, 0.0];
        self.contains(uv).then(|| (P3::new(uv[0], 0.0, 0.0), uv))
    }
    fn frame(&self, _params: [f64; 2]) -> (V3, V3) {
        (V3::x(), V3::y())
    }
    fn project(&self, _params: [f64; 2], v: &V3) -> V3 {
        V3::new(v.x, 0.0, 0.0)
    }
    fn contains(&self, p: [f64; 2]) -> bool {
        (0.0..=1.0).contains(&p[0])
    }
    fn point(&self, p: [f64; 2]) -> P3 {
        P3::new(p[0], 0.0, 0.0)
    }
    fn normal(&self, _params: [f64; 2]) -> V3 {
        V3::z()
    }
    fn planar(&self) -> bool {
        true
    }
}

/// A system on `carrier` with fixed bubbles at `fixed` (in (u,v), on the
/// xy plane) and a uniform spacing.
pub(crate) fn system<'a, C: Carrier>(
    carrier: C,
    spacing: &'a Constant,
    fixed: Vec<[f64; 2]>,
    dim: u8,
) -> System<'a, C> {
    let nf = fixed.len();
    System {
        carrier,
        spacing,
        dim,
        n_fixed: nf,
        pos: fixed.iter().map(|p| P3::new(p[0], p[1], 0.0)).collect(),
        params: fixed,
        vel: vec![V3::zeros(); nf],
        d: vec![spacing.0; nf],
        fixed_ids: (0..nf as u32).collect(),
        pressure: 1.0,
        uniform: Some(spacing.0),
    }
}

/// The unit square's boundary at the spacing `spacing.0`, as fixed bubbles.
pub(crate) fn square_system(spacing: &Constant) -> System<'_, Square> {
    let d = spacing.0;
    let n = (1.0 / d).round() as usize;
    let mut boundary = Vec::new();
    for k in 0..n {
        boundary.push([k as f64 / n as f64, 0.0]);
    }
    for k in 0..n {
        boundary.push([1.0, k as f64 / n as f64]);
    }
    for k in 0..n {
        boundary.push([1.0 - k as f64 / n as f64, 1.0]);
    }
    for k in 0..n {
        boundary.push([0.0, 1.0 - k as f64 / n as f64]);
    }
    system(Square, spacing, boundary, 2)
}

/// Free bubbles of diameter `d` on a hexagonal lattice of side `side`
/// inside the unit square (half a side clear of its boundary), except
/// where `skip(x, y)`.
pub(crate) fn hex_fill<C: Carrier>(
    sys: &mut System<'_, C>,
    side: f64,
    d: f64,
    skip: impl Fn(f64, f64) -> bool,
) {
    let h = side * 3f64.sqrt() / 2.0;
    let mut j = 1;
    while j as f64 * h < 1.0 - 0.5 * side {
        let y = j as f64 * h;
        let off = if j % 2 == 1 { 0.5 * side } else { 0.0 };
        let mut i = 1;
        while off + i as f64 * side < 1.0 - 0.5 * side {
            let x = off + i as f64 * side;
            if !skip(x, y) {
                sys.push_free(P3::new(x, y, 0.0), [x, y], d);
            }
            i += 1;
        }
        j += 1;
    }
}

/// Uniform numbers in [0, 1) from `seed`, the same on every machine (a
/// 64-bit linear congruential generator, Knuth's MMIX constants, its top
/// 53 bits): the tests' jitter and random point sets.
pub(crate) fn uniform(seed: u64) -> impl FnMut() -> f64 {
    let mut state = seed;
    move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    }
}
