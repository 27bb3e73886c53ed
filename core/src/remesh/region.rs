//! The region of a local re-meshing (thesis §4.8.1, Fig. 4.19): a box, a
//! ball, or a list of faces. Bubbles inside it, or within a band of
//! [`BAND`] spacings around it, are free; the others are kept.

use crate::geom::P3;
use crate::model::EntityRef;

/// Width of the band around a region whose bubbles are free too, in
/// spacings (§4.8.1: the free bubbles must reach past the change so that
/// the new packing joins the kept one smoothly).
pub const BAND: f64 = 2.0;

/// Where a local re-meshing may move bubbles.
#[derive(Clone, Debug, PartialEq)]
pub enum Region {
    /// The axis-aligned box between two corners (model units).
    Box {
        /// Lower corner.
        lo: P3,
        /// Upper corner.
        hi: P3,
    },
    /// The ball of `radius` around `center`.
    Sphere {
        /// Centre.
        center: P3,
        /// Radius (> 0).
        radius: f64,
    },
    /// These faces (ids), and the edges only they use.
    Faces(Vec<u32>),
}

impl Region {
    /// Parses `box:x0,y0,z0,x1,y1,z1`, `sphere:x,y,z,r` or `faces:3,7`.
    pub fn parse(text: &str) -> Result<Region, String> {
        let (kind, rest) = text
            .split_once(':')
            .ok_or_else(|| format!("\"{text}\": expected box:…, sphere:… or faces:…"))?;
        let numbers = || -> Result<Vec<f64>, String> {
            rest.split(',')
                .map(|s| {
                    s.trim()
                        .parse::<f64>()
                        .ok()
                        .filter(|x| x.is_finite())
                        .ok_or_else(|| {
                            format!("\"{text}\": \"{}\" is not a finite number", s.trim())
                        })
                })
                .collect()
        };
        match kind {
            "box" => {
                let v = numbers()?;
                if v.len() != 6 {
                    return Err(format!(
                        "\"{text}\": a box needs 6 numbers x0,y0,z0,x1,y1,z1"
                    ));
                }
                let lo = P3::new(v[0].min(v[3]), v[1].min(v[4]), v[2].min(v[5]));
                let hi = P3::new(v[0].max(v[3]), v[1].max(v[4]), v[2].max(v[5]));
                Ok(Region::Box { lo, hi })
            }
            "sphere" => {
                let v = numbers()?;
                if v.len() != 4 || v[3] <= 0.0 {
                    return Err(format!("\"{text}\": a sphere needs x,y,z,r with r > 0"));
                }
                Ok(Region::Sphere {
                    center: P3::new(v[0], v[1], v[2]),
                    radius: v[3],
                })
            }
            "faces" => {
                let ids: Result<Vec<u32>, String> = rest
                    .split(',')
                    .map(|s| {
                        s.trim()
                            .parse::<u32>()
                            .map_err(|_| format!("\"{text}\": \"{}\" is not a face id", s.trim()))
                    })
                    .collect();
                let ids = ids?;
                if ids.is_empty() {
                    return Err(format!("\"{text}\": no face ids"));
                }
                Ok(Region::Faces(ids))
            }
            _ => Err(format!(
                "\"{text}\": unknown region \"{kind}\" (box:…, sphere:… or faces:…)"
            )),
        }
    }

    /// Distance from `p` to the region (0 inside); `None` for a list of
    /// faces, which is not a place in space.
    pub fn distance(&self, p: &P3) -> Option<f64> {
        match self {
            Region::Box { lo, hi } => {
                let mut s = 0.0;
                for k in 0..3 {
                    let d = (lo[k] - p[k]).max(p[k] - hi[k]).max(0.0);
                    s += d * d;
                }
                Some(s.sqrt())
            }
            Region::Sphere { center, radius } => Some(((p - center).norm() - radius).max(0.0)),
            Region::Faces(_) => None,
        }
    }

    /// Whether a bubble of diameter `d` at `p` on `entity` is free: inside
    /// the region or its band; for a list of faces, on one of them or on
    /// an edge whose every face is listed (`faces_of_edge`).
    pub fn frees(
        &self,
        entity: EntityRef,
        p: &P3,
        d: f64,
        faces_of_edge: &dyn Fn(u32) -> Vec<u32>,
    ) -> bool {
        match self {
            Region::Faces(ids) => match entity.dim {
                2 => ids.contains(&entity.id),
                1 => {
                    let fs = faces_of_edge(entity.id);
                    !fs.is_empty() && fs.iter().all(|f| ids.contains(f))
                }
                _ => false,
            },
            _ => self.distance(p).is_some_and(|r| r <= BAND * d),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_the_three_kinds_and_refuses_the_rest() {
        assert_eq!(
            Region::parse("box:1,0,0,0,1,1").unwrap(),
            Region::Box {
                lo: P3::new(0.0, 0.0, 0.0),
                hi: P3::new(1.0, 1.0, 1.0)
            }
        );
        assert!(matches!(
            Region::parse("sphere:0,0,0,2").unwrap(),
            Region::Sphere { radius, .. } if radius == 2.0
        ));
        assert_eq!(
            Region::parse("faces:3, 7").unwrap(),
            Region::Faces(vec![3, 7])
        );
        for bad in [
            "box:1,2",
            "sphere:0,0,0,-1",
            "faces:",
            "cube:1",
            "box",
            "sphere:0,0,nan,1",
        ] {
            assert!(Region::parse(bad).is_err(), "{bad} accepted");
        }
    }

    #[test]
    fn the_band_is_two_spacings() {
        let r = Region::parse("sphere:0,0,0,1").unwrap();
        let none = |_: u32| Vec::new();
        let e = EntityRef::new(2, 0);
        assert!(r.frees(e, &P3::new(2.9, 0.0, 0.0), 1.0, &none));
        assert!(!r.frees(e, &P3::new(3.1, 0.0, 0.0), 1.0, &none));
        let b = Region::parse("box:0,0,0,1,1,1").unwrap();
        assert_eq!(b.distance(&P3::new(0.5, 0.5, 0.5)), Some(0.0));
        assert!((b.distance(&P3::new(4.0, 5.0, 0.5)).unwrap() - 5.0).abs() < 1e-12);
    }
}
