//! Insertion order: BRIO rounds (Amenta, Choi & Rote, "Incremental constructions
//! con BRIO", SoCG 2003), each round sorted along a 3D Hilbert curve.
//!
//! Why written here: the order is ~40 lines (a Hilbert index and a shuffle) and
//! must be deterministic (fixed seed) so that a run is reproducible; no
//! maintained crate gives a multiscale (BRIO) Hilbert order for `[f64; 3]`.
//!
//! Why BRIO and not a plain Hilbert sort: a plain space-filling-curve order has
//! the best walk locality but no guarantee on the size of the conflict regions
//! (e.g. points on a sphere or lattice planes met in curve order can give
//! long, thin intermediate triangulations); the random rounds give the expected
//! O(n log n) bound of randomized incremental construction while the Hilbert
//! order inside each round keeps the point-location walk to a few steps.

/// Bits per axis of the Hilbert key (3 × 21 = 63 bits fit a `u64`).
const BITS: u32 = 21;
/// A round holds the last `1 - 1/ROUND_RATIO` of the remaining shuffled prefix.
const ROUND_RATIO: usize = 4;
/// Prefixes shorter than this are one round.
const MIN_ROUND: usize = 64;

/// SplitMix64 (Steele et al. 2014): a tiny deterministic generator; written
/// here to keep the crate free of an RNG dependency and its version churn.
pub(crate) fn splitmix(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Hilbert index of integer coordinates `x` (each < 2^BITS), following
/// J. Skilling, "Programming the Hilbert curve", AIP Conf. Proc. 707 (2004):
/// axes → transposed index, then bit interleave.
fn hilbert_key(mut x: [u32; 3]) -> u64 {
    let m = 1u32 << (BITS - 1);
    let mut q = m;
    while q > 1 {
        let p = q - 1;
        for i in 0..3 {
            if x[i] & q != 0 {
                x[0] ^= p;
            } else {
                let t = (x[0] ^ x[i]) & p;
                x[0] ^= t;
                x[i] ^= t;
            }
        }
        q >>= 1;
    }
    x[1] ^= x[0];
    x[2] ^= x[1];
    let mut t = 0;
    let mut q = m;
    while q > 1 {
        if x[2] & q != 0 {
            t ^= q - 1;
        }
        q >>= 1;
    }
    for xi in &mut x {
        *xi ^= t;
    }
    let mut h = 0u64;
    for b in (0..BITS).rev() {
        for xi in &x {
            h = (h << 1) | u64::from((xi >> b) & 1);
        }
    }
    h
}

/// A permutation of `0..points.len()`: shuffled, split into BRIO rounds whose
/// sizes grow geometrically (ratio `ROUND_RATIO`), each round in Hilbert order
/// (alternate rounds reversed so one round starts where the previous ended).
/// Coordinates must be finite.
pub(crate) fn brio_hilbert(points: &[[f64; 3]], seed: u64) -> Vec<u32> {
    let n = points.len();
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in points {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let ext = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
    let scale = if ext > 0.0 {
        ((1u64 << BITS) - 1) as f64 / ext
    } else {
        0.0
    };
    let quant = |v: f64, k: usize| (((v - lo[k]) * scale) as u32).min((1 << BITS) - 1);
    let keys: Vec<u64> = points
        .iter()
        .map(|p| hilbert_key([quant(p[0], 0), quant(p[1], 1), quant(p[2], 2)]))
        .collect();
    let mut order: Vec<u32> = (0..n as u32).collect();
    let mut rng = seed;
    for i in (1..n).rev() {
        let j = (splitmix(&mut rng) % (i as u64 + 1)) as usize;
        order.swap(i, j);
    }
    // Rounds from the last (largest) backwards; record them, then orient.
    let mut rounds = Vec::new();
    let mut end = n;
    while end > 0 {
        let begin = if end <= MIN_ROUND {
            0
        } else {
            end / ROUND_RATIO
        };
        order[begin..end].sort_unstable_by_key(|&i| keys[i as usize]);
        rounds.push((begin, end));
        end = begin;
    }
    for (r, &(b, e)) in rounds.iter().rev().enumerate() {
        if r % 2 == 1 {
            order[b..e].reverse();
        }
    }
    order
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hilbert_keys_of_the_2x2x2_cube_are_a_path_of_unit_steps() {
        // On the 2^3 grid of the first level, consecutive Hilbert cells are
        // face neighbours: that is what makes the order local.
        let mut cells: Vec<([u32; 3], u64)> = Vec::new();
        let s = 1u32 << (BITS - 1);
        for x in 0..2 {
            for y in 0..2 {
                for z in 0..2 {
                    let c = [x * s, y * s, z * s];
                    cells.push(([x, y, z], hilbert_key(c)));
                }
            }
        }
        cells.sort_by_key(|c| c.1);
        for w in cells.windows(2) {
            let d: u32 = (0..3).map(|k| w[0].0[k].abs_diff(w[1].0[k])).sum();
            assert_eq!(d, 1, "{:?}", cells);
        }
    }

    #[test]
    fn brio_order_is_a_permutation() {
        let mut rng = 7;
        let pts: Vec<[f64; 3]> = (0..1000)
            .map(|_| [0, 1, 2].map(|_| (splitmix(&mut rng) >> 11) as f64 / (1u64 << 53) as f64))
            .collect();
        let mut o = brio_hilbert(&pts, 1);
        o.sort_unstable();
        assert!(o.iter().enumerate().all(|(i, &v)| i as u32 == v));
    }
}
