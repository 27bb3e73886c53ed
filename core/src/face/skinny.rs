//! Delaunay refinement of a planar face's skinniest triangles: a node at
//! the circumcentre of each triangle whose smallest angle is below
//! [`SKINNY_ANGLE`], then the face connected and improved again.
//!
//! **Why.** Bubbles take the requested spacing, which knows nothing of a
//! neck narrower than it: two holes 0.645 apart at d = 2.3 (rp_4_013 of
//! the random parts) leave a triangle across the neck whose apex is a
//! spacing away, 16.9°, where Gmsh's front closes the neck with a node
//! about a neck's width from it (25.4°). The circumcentre of a triangle
//! with a short edge δ facing an angle θ is on that edge's bisector, at
//! δ / (2 tan θ) from it: such a node (Ruppert 1995), which the mean lift
//! then moves as it moves the others.
//!
//! A circumcentre outside the face is not used. Ruppert's algorithm would
//! split a boundary segment whose diametral circle holds it instead; here
//! the segments belong to the neighbouring faces' meshes too, so the node
//! goes in anyway and the round is judged by what it gives: it is kept
//! where the face's smallest angle rises by more than [`ANGLE_GAIN`] and its
//! mean radius ratio stays within [`MEAN_SLACK`] of what it was; otherwise
//! the face is as before and the splitting stops.
//!
//! Planar faces only: their (u,v) is affine, so a circumcentre's (u,v) is
//! the barycentric combination of its corners'.

use crate::bubbles::constraint::Carrier;
use crate::bubbles::system::System;
use crate::error::MeshError;
use crate::face::carrier::OnFace;
use crate::geom::P3;
use crate::spacing::SpacingQuery;

/// Triangles whose smallest angle (degrees) is below this are split.
pub(crate) const SKINNY_ANGLE: f64 = 25.0;

/// A round is kept where it raises the face's smallest angle by more than
/// this (degrees) ...
pub(crate) const ANGLE_GAIN: f64 = 0.5;

/// ... and the face's mean radius ratio stays within this of what it was
/// before the first round. A node in a neck grades the triangles around it
/// from the neck's width to the spacing, and those are not all
/// equilateral: rp_5_000's face with a 0.243 edge went from 6.0° to 17.7°
/// and its mean from 0.9427 to 0.9377.
pub(crate) const MEAN_SLACK: f64 = 0.005;

/// At most this many rounds of splitting on a face.
pub(crate) const SKINNY_ROUNDS: usize = 3;

/// The barycentric coordinates of the circumcentre of triangle `abc` (in
/// its plane), or `None` for a degenerate triangle.
fn circumcentre_weights(a: &P3, b: &P3, c: &P3) -> Option<[f64; 3]> {
    // the squared lengths of the sides opposite a, b, c
    let (la, lb, lc) = (
        (c - b).norm_squared(),
        (a - c).norm_squared(),
        (b - a).norm_squared(),
    );
    let w = [
        la * (lb + lc - la),
        lb * (lc + la - lb),
        lc * (la + lb - lc),
    ];
    let s = w[0] + w[1] + w[2];
    (s.abs() > 0.0 && s.is_finite()).then(|| [w[0] / s, w[1] / s, w[2] / s])
}

/// Connects and improves a face's bubbles again (`FaceJob::connect_and_improve`).
pub(crate) type Reconnect<'f, 'a> =
    dyn FnMut(&mut System<'a, OnFace<'a>>) -> Result<Vec<[usize; 3]>, MeshError> + 'f;

/// The smallest angle of `tris` (degrees).
fn least_angle(pos: &[P3], tris: &[[usize; 3]]) -> f64 {
    tris.iter()
        .map(|t| crate::measure::triangle_min_angle(&pos[t[0]], &pos[t[1]], &pos[t[2]]))
        .fold(f64::INFINITY, f64::min)
        .to_degrees()
}

/// Splits the skinny triangles of planar face `sys` (connected as `tris`)
/// at their circumcentres, at most [`SKINNY_ROUNDS`] times; `reconnect`
/// connects and improves the bubbles again. Returns how many nodes were
/// added (0 where no round was kept).
pub(crate) fn split_skinny<'a>(
    sys: &mut System<'a, OnFace<'a>>,
    tris: &mut Vec<[usize; 3]>,
    reconnect: &mut Reconnect<'_, 'a>,
) -> Result<usize, MeshError> {
    let mut added = 0;
    // most faces have no skinny triangle: their mean is not needed
    let mut least = least_angle(&sys.pos, tris);
    if least >= SKINNY_ANGLE {
        return Ok(0);
    }
    let first_mean = crate::measure::mean_and_least_radius_ratio(&sys.pos, tris).0;
    for _ in 0..SKINNY_ROUNDS {
        if least >= SKINNY_ANGLE {
            break;
        }
        let mut points: Vec<(P3, [f64; 2])> = Vec::new();
        for t in tris.iter() {
            let [a, b, c] = t.map(|k| sys.pos[k]);
            if crate::measure::triangle_min_angle(&a, &b, &c).to_degrees() >= SKINNY_ANGLE {
                continue;
            }
            let Some(w) = circumcentre_weights(&a, &b, &c) else {
                continue;
            };
            let p = P3::from(a.coords * w[0] + b.coords * w[1] + c.coords * w[2]);
            let uv = [0, 1].map(|k| {
                w[0] * sys.params[t[0]][k] + w[1] * sys.params[t[1]][k] + w[2] * sys.params[t[2]][k]
            });
            if !sys.carrier.contains(uv) {
                continue;
            }
            // two skinny neighbours share a circumcentre nearly
            let near_other = points
                .iter()
                .any(|(q, _)| (p - q).norm() < 1e-3 * (a - b).norm());
            if !near_other {
                points.push((p, uv));
            }
        }
        if points.is_empty() {
            break;
        }
        let saved = (
            sys.pos.clone(),
            sys.params.clone(),
            sys.vel.clone(),
            sys.d.clone(),
        );
        for &(p, uv) in &points {
            let d = sys.spacing.spacing(&SpacingQuery {
                point: p,
                entity: sys.carrier.entity,
                params: uv,
            });
            sys.push_free(p, uv, d);
        }
        let kept = match reconnect(sys) {
            Ok(new) => {
                let after = least_angle(&sys.pos, &new);
                let mean = crate::measure::mean_and_least_radius_ratio(&sys.pos, &new).0;
                (after > least + ANGLE_GAIN && mean >= first_mean - MEAN_SLACK)
                    .then_some((new, after))
            }
            Err(_) => None,
        };
        match kept {
            Some((new, after)) => {
                *tris = new;
                least = after;
                added += points.len();
            }
            None => {
                (sys.pos, sys.params, sys.vel, sys.d) = saved;
                break;
            }
        }
    }
    Ok(added)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_circumcentre_is_equidistant_from_the_corners() {
        let (a, b, c) = (
            P3::new(0.0, 0.0, 1.0),
            P3::new(0.645, 0.0, 1.0),
            P3::new(0.2, 2.0, 1.0),
        );
        let w = circumcentre_weights(&a, &b, &c).unwrap();
        let p = P3::from(a.coords * w[0] + b.coords * w[1] + c.coords * w[2]);
        let (ra, rb, rc) = ((p - a).norm(), (p - b).norm(), (p - c).norm());
        assert!(
            (ra - rb).abs() < 1e-12 && (ra - rc).abs() < 1e-12,
            "{ra} {rb} {rc}"
        );
        assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-12);
    }
}
