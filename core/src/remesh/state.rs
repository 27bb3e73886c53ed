//! The state file of a packing (thesis §4.8): the bubbles of every entity
//! after a run, so that a later run can start from them.
//!
//! Format `bubblemesh-state`, version [`VERSION`] (docs/state-format.md):
//! an ASCII header of two lines, then a little-endian binary body. Version
//! 2 adds each volume's tetrahedra (a local re-meshing keeps those away
//! from its region); version 1 files, without them, are still read.
//!
//! ```text
//! bubblemesh-state 2\n
//! <body length in bytes> <CRC-32 of the body, 8 hex digits>\n
//! <body>
//! ```
//!
//! Reading never panics and never allocates more than the file's length
//! justifies: every count is checked against the bytes left before it is
//! used, and the checksum catches a corrupted body before it is parsed.
//! Positions and diameters are stored as the exact bits of their `f64`, so
//! that a kept bubble is written back bit for bit.

use crate::geom::P3;
use crate::model::EntityRef;

/// The format's name, the first word of the file.
pub const FORMAT: &str = "bubblemesh-state";
/// The version this code writes.
pub const VERSION: u32 = 2;
/// The versions this code reads (1: no tetrahedra).
pub const READS: [u32; 2] = [1, 2];

/// One bubble: its parameters on its entity (`[t, 0]` on an edge, `[u, v]`
/// on a face, unused in a volume), its centre and its diameter (the spacing
/// there), in model units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bubble {
    /// Parameters on the entity.
    pub params: [f64; 2],
    /// Centre, model units.
    pub pos: P3,
    /// Diameter, model units (> 0).
    pub d: f64,
}

/// What identifies an entity's geometry across two versions of a model
/// ([`crate::remesh::fingerprint`]): its geometry's type, its measure (an
/// edge's length; a face's boundary length, or its area when it has no
/// boundary; a volume's summed face measures) and its centroid.
#[derive(Clone, Debug, PartialEq)]
pub struct Fingerprint {
    /// The carrier's type (`Line`, `CircleArc`, `Plane`, `NurbsSurface`, …).
    pub kind: String,
    /// Length or area, model units (≥ 0).
    pub measure: f64,
    /// Centroid of the samples the measure was taken on.
    pub centroid: P3,
}

/// One entity's record: what it is and its bubbles.
#[derive(Clone, Debug, PartialEq)]
pub struct EntityState {
    /// Dimension and id in the model it was saved from.
    pub entity: EntityRef,
    /// Its name in that model.
    pub name: Option<String>,
    /// Its geometry's fingerprint.
    pub fingerprint: Fingerprint,
    /// An edge's parameter range `[t0, t1]` (bubbles are carried over by
    /// their parameter relative to it); `[0, 0]` otherwise.
    pub range: [f64; 2],
    /// The bubbles the run left on the entity (its own nodes; not those of
    /// its boundary).
    pub bubbles: Vec<Bubble>,
    /// A volume's tetrahedra, each as its four corners (positive
    /// orientation, exact coordinates: a kept node has them bit for bit);
    /// empty for edges and faces, and in a version 1 file.
    pub tets: Vec<[P3; 4]>,
}

/// A saved packing.
#[derive(Clone, Debug, PartialEq)]
pub struct State {
    /// The spacing the bubbles were packed with, as the user gave it.
    pub spacing: String,
    /// The input the model was read from, as given.
    pub source: String,
    /// The highest dimension meshed.
    pub dim: u8,
    /// Every edge, face and volume of the model, in (dim, id) order.
    pub entities: Vec<EntityState>,
}

/// Why a state file cannot be read. The caller names the file.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum StateError {
    /// The file does not start with the format's name.
    #[error("not a {FORMAT} file (it does not start with \"{FORMAT} \")")]
    NotAState,
    /// Another version of the format.
    #[error("{FORMAT} version {found} is not supported (this bubblemesh reads versions 1 and {VERSION})")]
    Version {
        /// The version the file says.
        found: String,
    },
    /// The file ends before the data it announces.
    #[error("truncated: {0}")]
    Truncated(String),
    /// The body does not match its checksum, or holds impossible values.
    #[error("corrupted: {0}")]
    Corrupt(String),
}

/// CRC-32 (IEEE 802.3, reflected, polynomial 0xEDB88320, as zlib) of
/// `bytes`, by `crc32fast` (a state with a solid's tetrahedra is
/// megabytes: no bitwise loop over them).
pub fn crc32(bytes: &[u8]) -> u32 {
    crc32fast::hash(bytes)
}

/// Bytes of one bubble in the body (six `f64`).
const BUBBLE_BYTES: usize = 6 * 8;

impl State {
    /// The file's bytes: the header, then the body.
    pub fn to_bytes(&self) -> Vec<u8> {
        self.encode(VERSION)
    }

    /// The file's bytes in format `version` (1 leaves the tetrahedra out).
    fn encode(&self, version: u32) -> Vec<u8> {
        let mut b = Vec::new();
        put_str(&mut b, &self.spacing);
        put_str(&mut b, &self.source);
        b.push(self.dim);
        put_u32(&mut b, self.entities.len() as u32);
        for e in &self.entities {
            b.push(e.entity.dim);
            put_u32(&mut b, e.entity.id);
            match &e.name {
                Some(n) => {
                    b.push(1);
                    put_str(&mut b, n);
                }
                None => b.push(0),
            }
            put_str(&mut b, &e.fingerprint.kind);
            let c = e.fingerprint.centroid;
            for x in [e.fingerprint.measure, c.x, c.y, c.z, e.range[0], e.range[1]] {
                put_f64(&mut b, x);
            }
            put_u32(&mut b, e.bubbles.len() as u32);
            for q in &e.bubbles {
                for x in [q.params[0], q.params[1], q.pos.x, q.pos.y, q.pos.z, q.d] {
                    put_f64(&mut b, x);
                }
            }
            if version >= 2 {
                put_tets(&mut b, e);
            }
        }
        let mut out = format!("{FORMAT} {version}\n{} {:08x}\n", b.len(), crc32(&b)).into_bytes();
        out.extend_from_slice(&b);
        out
    }

    /// Reads a state file's bytes; any defect is an error, never a panic.
    pub fn from_bytes(bytes: &[u8]) -> Result<State, StateError> {
        let (line1, rest) = split_line(bytes).ok_or(StateError::NotAState)?;
        let line1 = std::str::from_utf8(line1).map_err(|_| StateError::NotAState)?;
        let mut words = line1.split(' ');
        if words.next() != Some(FORMAT) {
            return Err(StateError::NotAState);
        }
        let version = words.next().unwrap_or("").to_string();
        let Some(&v) = READS.iter().find(|v| v.to_string() == version) else {
            return Err(StateError::Version { found: version });
        };
        if words.next().is_some() {
            return Err(StateError::Version { found: version });
        }
        let (line2, body) = split_line(rest)
            .ok_or_else(|| StateError::Truncated("the header's second line is missing".into()))?;
        let line2 = std::str::from_utf8(line2)
            .map_err(|_| StateError::Corrupt("the header's second line is not text".into()))?;
        let (len, crc) = line2
            .split_once(' ')
            .and_then(|(l, c)| {
                Some((
                    l.parse::<usize>().ok()?,
                    u32::from_str_radix(c, 16).ok().filter(|_| c.len() == 8)?,
                ))
            })
            .ok_or_else(|| {
                StateError::Corrupt(format!(
                    "the header's second line \"{}\" is not \"<length> <crc32>\"",
                    line2.escape_default()
                ))
            })?;
        if body.len() < len {
            return Err(StateError::Truncated(format!(
                "the body has {} of its {len} bytes",
                body.len()
            )));
        }
        if body.len() > len {
            return Err(StateError::Corrupt(format!(
                "{} bytes after the {len}-byte body",
                body.len() - len
            )));
        }
        if crc32(body) != crc {
            return Err(StateError::Corrupt(
                "the body does not match its checksum".into(),
            ));
        }
        Reader {
            b: body,
            at: 0,
            version: v,
        }
        .state()
    }
}

/// An entity's tetrahedra (version 2): the corners that are not among its
/// bubbles (its boundary nodes) as a table of positions, then each
/// tetrahedron as four indices into the bubbles followed by that table.
fn put_tets(b: &mut Vec<u8>, e: &EntityState) {
    let mut index: std::collections::HashMap<[u64; 3], u32> = e
        .bubbles
        .iter()
        .enumerate()
        .map(|(k, q)| (bits(&q.pos), k as u32))
        .collect();
    let mut extra: Vec<P3> = Vec::new();
    let corners: Vec<[u32; 4]> = e
        .tets
        .iter()
        .map(|t| {
            t.map(|p| {
                *index.entry(bits(&p)).or_insert_with(|| {
                    extra.push(p);
                    (e.bubbles.len() + extra.len() - 1) as u32
                })
            })
        })
        .collect();
    put_u32(b, extra.len() as u32);
    for p in &extra {
        for x in [p.x, p.y, p.z] {
            put_f64(b, x);
        }
    }
    put_u32(b, corners.len() as u32);
    for t in &corners {
        for &k in t {
            put_u32(b, k);
        }
    }
}

/// The exact bits of a position (a key that tells -0.0 from 0.0, as a kept
/// node must be written back).
pub fn bits(p: &P3) -> [u64; 3] {
    [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()]
}

/// The first line of `b` (without its `\n`) and the rest.
fn split_line(b: &[u8]) -> Option<(&[u8], &[u8])> {
    let i = b.iter().take(256).position(|&c| c == b'\n')?;
    Some((&b[..i], &b[i + 1..]))
}

fn put_u32(b: &mut Vec<u8>, x: u32) {
    b.extend_from_slice(&x.to_le_bytes());
}

fn put_f64(b: &mut Vec<u8>, x: f64) {
    b.extend_from_slice(&x.to_bits().to_le_bytes());
}

fn put_str(b: &mut Vec<u8>, s: &str) {
    put_u32(b, s.len() as u32);
    b.extend_from_slice(s.as_bytes());
}

/// A checked cursor over the body.
struct Reader<'a> {
    b: &'a [u8],
    at: usize,
    /// The file's format version (one of [`READS`]).
    version: u32,
}

impl Reader<'_> {
    fn take(&mut self, n: usize, what: &str) -> Result<&[u8], StateError> {
        if self.b.len() - self.at < n {
            return Err(StateError::Corrupt(format!(
                "{what} at byte {} runs past the end of the body",
                self.at
            )));
        }
        let s = &self.b[self.at..self.at + n];
        self.at += n;
        Ok(s)
    }

    fn u8(&mut self, what: &str) -> Result<u8, StateError> {
        Ok(self.take(1, what)?[0])
    }

    fn u32(&mut self, what: &str) -> Result<u32, StateError> {
        let s = self.take(4, what)?;
        Ok(u32::from_le_bytes([s[0], s[1], s[2], s[3]]))
    }

    fn f64(&mut self, what: &str) -> Result<f64, StateError> {
        let s = self.take(8, what)?;
        let mut a = [0u8; 8];
        a.copy_from_slice(s);
        Ok(f64::from_bits(u64::from_le_bytes(a)))
    }

    fn str(&mut self, what: &str) -> Result<String, StateError> {
        let n = self.u32(what)? as usize;
        let s = self.take(n, what)?;
        String::from_utf8(s.to_vec())
            .map_err(|_| StateError::Corrupt(format!("{what} is not UTF-8")))
    }

    fn finite(&mut self, what: &str) -> Result<f64, StateError> {
        let x = self.f64(what)?;
        if x.is_finite() {
            Ok(x)
        } else {
            Err(StateError::Corrupt(format!("{what} is {x}")))
        }
    }

    fn state(mut self) -> Result<State, StateError> {
        let spacing = self.str("the spacing")?;
        let source = self.str("the source")?;
        let dim = self.u8("the dimension")?;
        if !(1..=3).contains(&dim) {
            return Err(StateError::Corrupt(format!("dimension {dim}")));
        }
        let n = self.u32("the entity count")? as usize;
        // an entity takes at least 63 bytes: no more can fit
        if n > (self.b.len() - self.at) / 63 {
            return Err(StateError::Corrupt(format!(
                "{n} entities cannot fit in the body"
            )));
        }
        let mut entities = Vec::with_capacity(n);
        for k in 0..n {
            entities.push(self.entity(k)?);
        }
        if self.at != self.b.len() {
            return Err(StateError::Corrupt(format!(
                "{} bytes after the last entity",
                self.b.len() - self.at
            )));
        }
        Ok(State {
            spacing,
            source,
            dim,
            entities,
        })
    }

    fn entity(&mut self, k: usize) -> Result<EntityState, StateError> {
        let what = format!("entity {k}");
        let dim = self.u8(&what)?;
        if !(1..=3).contains(&dim) {
            return Err(StateError::Corrupt(format!("{what} has dimension {dim}")));
        }
        let id = self.u32(&what)?;
        let name = match self.u8(&what)? {
            0 => None,
            1 => Some(self.str(&what)?),
            x => return Err(StateError::Corrupt(format!("{what}: name flag {x}"))),
        };
        let kind = self.str(&what)?;
        let measure = self.finite(&what)?;
        let centroid = P3::new(
            self.finite(&what)?,
            self.finite(&what)?,
            self.finite(&what)?,
        );
        let range = [self.finite(&what)?, self.finite(&what)?];
        let nb = self.u32(&what)? as usize;
        if nb > (self.b.len() - self.at) / BUBBLE_BYTES {
            return Err(StateError::Corrupt(format!(
                "{what}: {nb} bubbles cannot fit in the body"
            )));
        }
        let mut bubbles = Vec::with_capacity(nb);
        for _ in 0..nb {
            let params = [self.finite(&what)?, self.finite(&what)?];
            let pos = P3::new(
                self.finite(&what)?,
                self.finite(&what)?,
                self.finite(&what)?,
            );
            let d = self.finite(&what)?;
            if d <= 0.0 {
                return Err(StateError::Corrupt(format!(
                    "{what} has a bubble of diameter {d}"
                )));
            }
            bubbles.push(Bubble { params, pos, d });
        }
        let tets = if self.version >= 2 {
            self.tets(&what, &bubbles)?
        } else {
            Vec::new()
        };
        Ok(EntityState {
            entity: EntityRef::new(dim, id),
            name,
            fingerprint: Fingerprint {
                kind,
                measure,
                centroid,
            },
            range,
            bubbles,
            tets,
        })
    }

    /// An entity's tetrahedra (see [`put_tets`]).
    fn tets(&mut self, what: &str, bubbles: &[Bubble]) -> Result<Vec<[P3; 4]>, StateError> {
        let nc = self.u32(what)? as usize;
        if nc > (self.b.len() - self.at) / 24 {
            return Err(StateError::Corrupt(format!(
                "{what}: {nc} corner nodes cannot fit in the body"
            )));
        }
        let mut nodes: Vec<P3> = bubbles.iter().map(|q| q.pos).collect();
        for _ in 0..nc {
            nodes.push(P3::new(
                self.finite(what)?,
                self.finite(what)?,
                self.finite(what)?,
            ));
        }
        let nt = self.u32(what)? as usize;
        if nt > (self.b.len() - self.at) / 16 {
            return Err(StateError::Corrupt(format!(
                "{what}: {nt} tetrahedra cannot fit in the body"
            )));
        }
        let mut tets = Vec::with_capacity(nt);
        for _ in 0..nt {
            let mut t = [P3::origin(); 4];
            for c in &mut t {
                let k = self.u32(what)? as usize;
                *c = *nodes.get(k).ok_or_else(|| {
                    StateError::Corrupt(format!(
                        "{what}: a tetrahedron's corner {k} is not one of its {} nodes",
                        nodes.len()
                    ))
                })?;
            }
            tets.push(t);
        }
        Ok(tets)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> State {
        State {
            spacing: "0.1".into(),
            source: "plate.toml".into(),
            dim: 2,
            entities: vec![
                EntityState {
                    entity: EntityRef::new(1, 0),
                    name: None,
                    fingerprint: Fingerprint {
                        kind: "Line".into(),
                        measure: 1.0,
                        centroid: P3::new(0.5, 0.0, 0.0),
                    },
                    range: [0.0, 1.0],
                    bubbles: vec![Bubble {
                        params: [0.5, 0.0],
                        pos: P3::new(0.5, 0.0, 0.0),
                        d: 0.1,
                    }],
                    tets: vec![],
                },
                EntityState {
                    entity: EntityRef::new(2, 0),
                    name: Some("plate".into()),
                    fingerprint: Fingerprint {
                        kind: "Plane".into(),
                        measure: 4.0,
                        centroid: P3::new(0.5, 0.5, 0.0),
                    },
                    range: [0.0, 0.0],
                    bubbles: vec![
                        Bubble {
                            params: [0.3, 0.1 + 0.2],
                            pos: P3::new(0.3, 0.1 + 0.2, 0.0),
                            d: 0.1,
                        };
                        3
                    ],
                    tets: vec![],
                },
                EntityState {
                    entity: EntityRef::new(3, 0),
                    name: None,
                    fingerprint: Fingerprint {
                        kind: "Volume".into(),
                        measure: 6.0,
                        centroid: P3::new(0.5, 0.5, 0.5),
                    },
                    range: [0.0, 0.0],
                    bubbles: vec![Bubble {
                        params: [0.0, 0.0],
                        pos: P3::new(0.25, 0.25, 0.1 + 0.2),
                        d: 0.1,
                    }],
                    // one corner a bubble of the volume, three on its boundary
                    tets: vec![
                        [
                            P3::new(0.0, 0.0, 0.0),
                            P3::new(1.0, 0.0, 0.0),
                            P3::new(0.0, 1.0, 0.0),
                            P3::new(0.25, 0.25, 0.1 + 0.2),
                        ],
                        [
                            P3::new(0.0, 0.0, 0.0),
                            P3::new(0.0, 1.0, 0.0),
                            P3::new(-0.0, 0.0, 1.0),
                            P3::new(0.25, 0.25, 0.1 + 0.2),
                        ],
                    ],
                },
            ],
        }
    }

    /// A state survives the round trip bit for bit (0.1 + 0.2 is not a
    /// short decimal).
    #[test]
    fn round_trip_is_exact() {
        let s = sample();
        let back = State::from_bytes(&s.to_bytes()).unwrap();
        assert_eq!(back, s);
        let q = back.entities[1].bubbles[0].params[1];
        assert_eq!(q.to_bits(), (0.1f64 + 0.2).to_bits());
    }

    /// Every truncation of a state is an error, never a panic or a state.
    #[test]
    fn every_truncation_is_an_error() {
        let b = sample().to_bytes();
        for n in 0..b.len() {
            assert!(State::from_bytes(&b[..n]).is_err(), "{n} bytes accepted");
        }
    }

    /// Every single-byte change of a state is an error (the header's
    /// checks, then the CRC, which catches every error burst of 32 bits or
    /// less).
    #[test]
    fn every_byte_flip_is_an_error() {
        let b = sample().to_bytes();
        let mut seed = 0x2545_F491_4F6C_DD1Du64;
        for i in 0..b.len() {
            for _ in 0..4 {
                seed ^= seed << 13;
                seed ^= seed >> 7;
                seed ^= seed << 17;
                let x = (seed as u8).max(1);
                let mut c = b.clone();
                c[i] ^= x;
                assert!(State::from_bytes(&c).is_err(), "byte {i} ^ {x:#x} accepted");
            }
        }
    }

    /// Random garbage after a valid header is an error, not a panic.
    #[test]
    fn garbage_bodies_are_errors() {
        let mut seed = 88172645463325252u64;
        for len in 0..200usize {
            let mut body = Vec::with_capacity(len);
            for _ in 0..len {
                seed ^= seed << 13;
                seed ^= seed >> 7;
                seed ^= seed << 17;
                body.push(seed as u8);
            }
            let mut f = format!("{FORMAT} {VERSION}\n{len} {:08x}\n", crc32(&body)).into_bytes();
            f.extend_from_slice(&body);
            let _ = State::from_bytes(&f);
        }
    }

    /// Another version, another format: the errors say which.
    #[test]
    fn other_versions_and_formats_are_named() {
        let b = sample().to_bytes();
        let mut v9 = b"bubblemesh-state 9".to_vec();
        v9.extend_from_slice(&b[18..]);
        assert_eq!(
            State::from_bytes(&v9),
            Err(StateError::Version { found: "9".into() })
        );
        assert_eq!(
            State::from_bytes(b"$MeshFormat\n4.1 0 8\n"),
            Err(StateError::NotAState)
        );
        let msg = State::from_bytes(&v9).unwrap_err().to_string();
        assert!(
            msg.contains("version 9") && msg.contains("reads versions 1 and 2"),
            "{msg}"
        );
    }

    /// A version 1 file (written before states held tetrahedra) is read,
    /// with no tetrahedra.
    #[test]
    fn version_1_files_are_read_without_tetrahedra() {
        let s = sample();
        let v1 = s.encode(1);
        assert!(v1.starts_with(b"bubblemesh-state 1\n"));
        let back = State::from_bytes(&v1).unwrap();
        assert!(back.entities.iter().all(|e| e.tets.is_empty()));
        let mut without = s.clone();
        for e in &mut without.entities {
            e.tets.clear();
        }
        assert_eq!(back, without);
    }

    /// A tetrahedron's corner index past the volume's nodes is an error.
    #[test]
    fn a_corner_outside_the_node_table_is_corrupt() {
        let mut s = sample();
        s.entities.truncate(2);
        s.entities.push(EntityState {
            tets: vec![],
            ..sample().entities[2].clone()
        });
        let mut b = s.to_bytes();
        // the body ends with the volume's nc = 0, nt = 0: make it one
        // tetrahedron whose corners are 0, 0, 0, 7 (one bubble only)
        let body_at = b
            .iter()
            .enumerate()
            .filter(|(_, &c)| c == b'\n')
            .nth(1)
            .unwrap()
            .0
            + 1;
        b.truncate(b.len() - 4);
        b.extend_from_slice(&1u32.to_le_bytes());
        for k in [0u32, 0, 0, 7] {
            b.extend_from_slice(&k.to_le_bytes());
        }
        let body = b[body_at..].to_vec();
        let mut f =
            format!("{FORMAT} {VERSION}\n{} {:08x}\n", body.len(), crc32(&body)).into_bytes();
        f.extend_from_slice(&body);
        let err = State::from_bytes(&f).unwrap_err().to_string();
        assert!(err.contains("corner 7 is not one of its 1 nodes"), "{err}");
    }

    #[test]
    fn crc32_matches_the_standard_check_value() {
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
    }
}
