//! Colours: the quality map and the entity palette. The HTML viewer receives
//! the same tables, so pictures and viewer agree.

/// An sRGB colour.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rgb(pub u8, pub u8, pub u8);

impl Rgb {
    /// `#rrggbb`.
    pub fn hex(self) -> String {
        format!("#{:02x}{:02x}{:02x}", self.0, self.1, self.2)
    }

    /// The colour scaled towards black by `f` in [0, 1] (1: unchanged).
    pub fn shade(self, f: f64) -> Rgb {
        let s = |c: u8| (c as f64 * f.clamp(0.0, 1.0)).round() as u8;
        Rgb(s(self.0), s(self.1), s(self.2))
    }

    /// `self` moved towards `other` by `t` in [0, 1].
    pub fn mix(self, other: Rgb, t: f64) -> Rgb {
        let t = t.clamp(0.0, 1.0);
        let m = |a: u8, b: u8| (a as f64 + (b as f64 - a as f64) * t).round() as u8;
        Rgb(m(self.0, other.0), m(self.1, other.1), m(self.2, other.2))
    }

    fn from_hex(h: u32) -> Rgb {
        Rgb((h >> 16) as u8, (h >> 8) as u8, h as u8)
    }
}

/// Stops of the quality map: radius ratio q → colour, linear in between.
/// Red for poor elements through yellow to green for near-equilateral ones,
/// with most of the range spent where bubble meshes live (q > 0.7).
pub const QUALITY_STOPS: [(f64, u32); 7] = [
    (0.0, 0xa50026),
    (0.4, 0xf46d43),
    (0.6, 0xfdae61),
    (0.75, 0xfee08b),
    (0.85, 0xd9ef8b),
    (0.93, 0xa6d96a),
    (1.0, 0x7cc46a),
];

/// The colour of radius ratio `q` (clamped to [0, 1]; NaN counts as 0).
pub fn quality(q: f64) -> Rgb {
    let q = if q.is_nan() { 0.0 } else { q.clamp(0.0, 1.0) };
    for w in QUALITY_STOPS.windows(2) {
        let ((q0, c0), (q1, c1)) = (w[0], w[1]);
        if q <= q1 {
            let t = if q1 > q0 { (q - q0) / (q1 - q0) } else { 0.0 };
            let (a, b) = (Rgb::from_hex(c0), Rgb::from_hex(c1));
            let mix = |x: u8, y: u8| (x as f64 + (y as f64 - x as f64) * t).round() as u8;
            return Rgb(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2));
        }
    }
    Rgb::from_hex(QUALITY_STOPS[QUALITY_STOPS.len() - 1].1)
}

/// A qualitative palette for entities (Tableau 10).
pub const PALETTE: [u32; 10] = [
    0x4e79a7, 0xf28e2b, 0xe15759, 0x76b7b2, 0x59a14f, 0xedc948, 0xb07aa1, 0xff9da7, 0x9c755f,
    0xbab0ac,
];

/// The colour of the `k`-th entity.
pub fn entity(k: usize) -> Rgb {
    Rgb::from_hex(PALETTE[k % PALETTE.len()])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_map_hits_its_stops_and_clamps() {
        assert_eq!(quality(1.0), Rgb::from_hex(0x7cc46a));
        assert_eq!(quality(2.0), quality(1.0));
        assert_eq!(quality(0.0), Rgb::from_hex(0xa50026));
        assert_eq!(quality(f64::NAN), quality(0.0));
        assert_eq!(quality(0.75).hex(), "#fee08b");
        assert_ne!(quality(0.5), quality(0.95));
        assert_eq!(entity(0), entity(10));
    }
}
