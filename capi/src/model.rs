//! `bm_model`: the host's B-rep, built entity by entity. Ids are 0-based
//! per dimension, in the order of creation, and never change.

use std::ffi::{c_char, c_int, c_void};
use std::sync::{Arc, Mutex, MutexGuard, TryLockError};

use bubblemesh_core::geom::{Curve, Plane, P3, V3};
use bubblemesh_core::model::{Edge, EdgeUse, Face, Loop, Model, Vertex, Volume};

use crate::error::{bm_result, guard, guard_void, in_callback_scope, Error, Result};
use crate::geometry::{
    bm_curve_callbacks, bm_surface_callbacks, bm_volume_callbacks, CallbackCurve, CallbackSurface,
    CallbackVolume, Segment, UserPtr,
};
use crate::{free_handle, into_handle, need, object, put, utf8, Object};

/// A model under construction (opaque). Create with `bm_model_new`, free
/// with `bm_model_free`.
#[allow(non_camel_case_types)]
pub struct bm_model {
    _private: [u8; 0],
}

#[repr(C)]
pub(crate) struct ModelObj {
    magic: u64,
    pub model: Mutex<Model>,
}

impl Object for ModelObj {
    const MAGIC: u64 = 0x626d_5f6d_6f64_656c; // "bm_model"
    const KIND: &'static str = "bm_model";
}

impl ModelObj {
    /// The model, or `BM_ERR_BUSY` when another call holds it (another
    /// thread meshing it, or a callback re-entering the library).
    pub fn lock(&self) -> Result<MutexGuard<'_, Model>> {
        match self.model.try_lock() {
            Ok(g) => Ok(g),
            Err(TryLockError::Poisoned(p)) => Ok(p.into_inner()),
            Err(TryLockError::WouldBlock) => Err(Error::new(
                bm_result::BM_ERR_BUSY,
                "the model is in use by another call (another thread, or a callback \
                 re-entering the library during meshing)",
            )),
        }
    }
}

/// One use of an edge in a face's boundary loop.
#[allow(non_camel_case_types)]
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct bm_edge_use {
    /// The edge id.
    pub edge: u32,
    /// Non-zero when the loop runs along the edge from its start vertex to
    /// its end vertex, 0 when it runs backwards.
    pub forward: c_int,
}

/// The parameter domain and the special points of a surface.
#[allow(non_camel_case_types)]
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct bm_surface_info {
    /// Parameter domain [u0, u1] x [v0, v1], finite, u0 < u1, v0 < v1.
    pub u0: f64,
    /// The end of the u domain.
    pub u1: f64,
    /// The start of the v domain.
    pub v0: f64,
    /// The end of the v domain.
    pub v1: f64,
    /// Period in u (a sphere's or cylinder's angle: 2*pi), 0 when u is open.
    /// A periodic parameter is kept in [u0, u0 + period_u).
    pub period_u: f64,
    /// Period in v, 0 when v is open.
    pub period_v: f64,
    /// `singular_count` points (x, y, z triples) where Su × Sv vanishes (a
    /// sphere's poles, a cone's apex); NULL when `singular_count` is 0.
    pub singular_points: *const f64,
    /// How many points `singular_points` holds.
    pub singular_count: usize,
}

const DIM_NAMES: [&str; 4] = ["vertex", "edge", "face", "volume"];

fn count(model: &Model, dim: usize) -> usize {
    match dim {
        0 => model.vertices.len(),
        1 => model.edges.len(),
        2 => model.faces.len(),
        _ => model.volumes.len(),
    }
}

fn check_id(model: &Model, dim: usize, id: u32, arg: &str) -> Result<()> {
    let n = count(model, dim);
    if (id as usize) < n {
        Ok(())
    } else {
        let plural = ["vertices", "edges", "faces", "volumes"];
        Err(Error::range(format!(
            "{arg} = {id} is not {} {} id (the model has {n} {})",
            if dim == 1 { "an" } else { "a" },
            DIM_NAMES[dim],
            if n == 1 { DIM_NAMES[dim] } else { plural[dim] }
        )))
    }
}

fn next_id(n: usize, what: &str) -> Result<u32> {
    u32::try_from(n).map_err(|_| Error::range(format!("too many {what}s")))
}

fn finite3(p: [f64; 3], what: &str) -> Result<P3> {
    if p.iter().all(|x| x.is_finite()) {
        Ok(P3::new(p[0], p[1], p[2]))
    } else {
        Err(Error::range(format!(
            "{what} ({}, {}, {}) is not finite",
            p[0], p[1], p[2]
        )))
    }
}

unsafe fn read3(p: *const f64, arg: &str) -> Result<[f64; 3]> {
    if p.is_null() {
        return Err(Error::null(arg));
    }
    Ok(unsafe { [*p, *p.add(1), *p.add(2)] })
}

/// Creates an empty model.
#[no_mangle]
pub unsafe extern "C" fn bm_model_new(out: *mut *mut bm_model) -> bm_result {
    guard("bm_model_new", || unsafe {
        need(out, "out")?;
        put(
            out,
            "out",
            into_handle(ModelObj {
                magic: ModelObj::MAGIC,
                model: Mutex::new(Model::default()),
            }),
        )
    })
}

/// Frees a model (NULL: nothing). Meshes made from it stay valid. The
/// callbacks' user pointers are not touched; the host frees them after
/// this call.
#[no_mangle]
pub unsafe extern "C" fn bm_model_free(model: *mut bm_model) {
    guard_void("bm_model_free", || unsafe {
        free_handle::<ModelObj>(model as *mut c_void)
    })
}

/// Adds a vertex at (x, y, z); its id goes to `*out_id`.
#[no_mangle]
pub unsafe extern "C" fn bm_model_add_vertex(
    model: *mut bm_model,
    x: f64,
    y: f64,
    z: f64,
    out_id: *mut u32,
) -> bm_result {
    guard("bm_model_add_vertex", || unsafe {
        let m = object::<ModelObj>(model as *const c_void, "model")?;
        need(out_id, "out_id")?;
        let point = finite3([x, y, z], "the vertex")?;
        let mut g = m.lock()?;
        let id = next_id(g.vertices.len(), "vertex")?;
        g.vertices.push(Vertex { point, name: None });
        put(out_id, "out_id", id)
    })
}

/// The tolerance for "this point is that vertex": relative to the curve's
/// size.
fn vertex_tolerance(curve: &dyn Curve, t0: f64, t1: f64) -> f64 {
    let mut len = 0.0;
    let mut prev = curve.point(t0);
    for k in 1..=16 {
        let p = curve.point(t0 + (t1 - t0) * k as f64 / 16.0);
        len += (p - prev).norm();
        prev = p;
    }
    1e-5 * len.max(prev.coords.norm() * 1e-3).max(f64::MIN_POSITIVE)
}

fn check_ends(g: &Model, curve: &dyn Curve, t0: f64, t1: f64, start: u32, end: u32) -> Result<()> {
    let tol = vertex_tolerance(curve, t0, t1);
    for (t, v, which) in [(t0, start, "start"), (t1, end, "end")] {
        let p = curve.point(t);
        let q = g.vertices[v as usize].point;
        let dist = (p - q).norm();
        if !(dist <= tol) {
            return Err(Error::geometry(format!(
                "the curve at t = {t} is ({}, {}, {}) but its {which} vertex {v} is at ({}, {}, {}) \
                 (distance {dist:.3e}, tolerance {tol:.3e})",
                p.x, p.y, p.z, q.x, q.y, q.z
            )));
        }
    }
    Ok(())
}

/// Adds an edge: the piece [t0, t1] of a curve given by callbacks, from
/// vertex `start_vertex` (C(t0)) to vertex `end_vertex` (C(t1)); a closed
/// edge (a full circle) has `start_vertex == end_vertex`. The callbacks are
/// called here to check the ends against the vertices. Its id goes to
/// `*out_edge`.
#[no_mangle]
pub unsafe extern "C" fn bm_model_add_curve(
    model: *mut bm_model,
    callbacks: *const bm_curve_callbacks,
    user: *mut c_void,
    t0: f64,
    t1: f64,
    start_vertex: u32,
    end_vertex: u32,
    out_edge: *mut u32,
) -> bm_result {
    guard("bm_model_add_curve", || unsafe {
        let m = object::<ModelObj>(model as *const c_void, "model")?;
        if callbacks.is_null() {
            return Err(Error::null("callbacks"));
        }
        let eval = (*callbacks)
            .eval
            .ok_or_else(|| Error::null("callbacks->eval"))?;
        need(out_edge, "out_edge")?;
        if !(t0.is_finite() && t1.is_finite() && t0 < t1) {
            return Err(Error::range(format!(
                "the parameter interval [t0, t1] = [{t0}, {t1}] must be finite with t0 < t1"
            )));
        }
        let mut g = m.lock()?;
        check_id(&g, 0, start_vertex, "start_vertex")?;
        check_id(&g, 0, end_vertex, "end_vertex")?;
        let id = next_id(g.edges.len(), "edge")?;
        let curve = CallbackCurve {
            eval,
            user: UserPtr(user),
            t0,
            t1,
            edge: id,
        };
        in_callback_scope(|| -> Result<()> {
            for k in 0..=4 {
                let t = t0 + (t1 - t0) * k as f64 / 4.0;
                for order in 0..=2 {
                    curve.try_eval(t, order)?;
                }
            }
            check_ends(&g, &curve, t0, t1, start_vertex, end_vertex)
        })?;
        g.edges.push(Edge {
            curve: Arc::new(curve),
            t0,
            t1,
            start: start_vertex,
            end: end_vertex,
            name: None,
        });
        put(out_edge, "out_edge", id)
    })
}

/// Adds a straight edge from vertex `start_vertex` to vertex `end_vertex`
/// (no callbacks). Its id goes to `*out_edge`.
#[no_mangle]
pub unsafe extern "C" fn bm_model_add_line(
    model: *mut bm_model,
    start_vertex: u32,
    end_vertex: u32,
    out_edge: *mut u32,
) -> bm_result {
    guard("bm_model_add_line", || unsafe {
        let m = object::<ModelObj>(model as *const c_void, "model")?;
        need(out_edge, "out_edge")?;
        let mut g = m.lock()?;
        check_id(&g, 0, start_vertex, "start_vertex")?;
        check_id(&g, 0, end_vertex, "end_vertex")?;
        let (a, b) = (
            g.vertices[start_vertex as usize].point,
            g.vertices[end_vertex as usize].point,
        );
        if a == b {
            return Err(Error::geometry(format!(
                "a line needs two distinct points; vertices {start_vertex} and {end_vertex} \
                 are both at ({}, {}, {})",
                a.x, a.y, a.z
            )));
        }
        let id = next_id(g.edges.len(), "edge")?;
        g.edges.push(Edge {
            curve: Arc::new(Segment(a, b)),
            t0: 0.0,
            t1: 1.0,
            start: start_vertex,
            end: end_vertex,
            name: None,
        });
        put(out_edge, "out_edge", id)
    })
}

/// Reads and checks the loops of a face: `loop_count` loops, loop k having
/// `loop_lengths[k]` consecutive entries of `uses`. Each loop must be a
/// closed chain (each use ends where the next starts).
unsafe fn read_loops(
    g: &Model,
    uses: *const bm_edge_use,
    loop_lengths: *const usize,
    loop_count: usize,
) -> Result<Vec<Loop>> {
    if loop_count == 0 {
        return Ok(Vec::new());
    }
    if loop_lengths.is_null() {
        return Err(Error::null("loop_lengths"));
    }
    let lens = unsafe { std::slice::from_raw_parts(loop_lengths, loop_count) };
    let mut total: usize = 0;
    for (k, &n) in lens.iter().enumerate() {
        if n == 0 || n > (1 << 24) {
            return Err(Error::range(format!(
                "loop_lengths[{k}] = {n}: a loop has at least one edge use"
            )));
        }
        total += n;
    }
    if uses.is_null() {
        return Err(Error::null("uses"));
    }
    let all = unsafe { std::slice::from_raw_parts(uses, total) };
    let mut loops = Vec::with_capacity(loop_count);
    let mut at = 0;
    for (li, &n) in lens.iter().enumerate() {
        let mut lp = Loop::default();
        for (k, u) in all[at..at + n].iter().enumerate() {
            check_id(g, 1, u.edge, &format!("loop {li} use {k}: edge"))?;
            lp.edges.push(EdgeUse {
                edge: u.edge,
                forward: u.forward != 0,
            });
        }
        at += n;
        // connectivity by vertex ids
        let ends = |u: &EdgeUse| {
            let e = &g.edges[u.edge as usize];
            if u.forward {
                (e.start, e.end)
            } else {
                (e.end, e.start)
            }
        };
        for k in 0..n {
            let a = ends(&lp.edges[k]);
            let b = ends(&lp.edges[(k + 1) % n]);
            if a.1 != b.0 {
                return Err(Error::geometry(format!(
                    "loop {li} is not closed: use {k} (edge {}) ends at vertex {} but use {} \
                     (edge {}) starts at vertex {}",
                    lp.edges[k].edge,
                    a.1,
                    (k + 1) % n,
                    lp.edges[(k + 1) % n].edge,
                    b.0
                )));
            }
        }
        loops.push(lp);
    }
    Ok(loops)
}

/// Adds a face on a surface given by callbacks, bounded by `loop_count`
/// loops of edge uses (the first the outer loop, the others holes; loop k
/// is the next `loop_lengths[k]` entries of `uses`). A face with no loops
/// (`loop_count` 0, `uses` and `loop_lengths` may be NULL) is the whole
/// surface and must be closed: periodic in u and v (a torus), or periodic
/// in one direction with singular points closing the other (a sphere).
/// The surface is evaluated here to check the callbacks. Its id goes to
/// `*out_face`.
#[no_mangle]
pub unsafe extern "C" fn bm_model_add_surface_face(
    model: *mut bm_model,
    callbacks: *const bm_surface_callbacks,
    user: *mut c_void,
    info: *const bm_surface_info,
    uses: *const bm_edge_use,
    loop_lengths: *const usize,
    loop_count: usize,
    out_face: *mut u32,
) -> bm_result {
    guard("bm_model_add_surface_face", || unsafe {
        let m = object::<ModelObj>(model as *const c_void, "model")?;
        if callbacks.is_null() {
            return Err(Error::null("callbacks"));
        }
        let cb = *callbacks;
        let eval = cb.eval.ok_or_else(|| Error::null("callbacks->eval"))?;
        if info.is_null() {
            return Err(Error::null("info"));
        }
        let info = *info;
        need(out_face, "out_face")?;
        let finite = [info.u0, info.u1, info.v0, info.v1]
            .iter()
            .all(|x| x.is_finite());
        if !(finite && info.u0 < info.u1 && info.v0 < info.v1) {
            return Err(Error::range(format!(
                "the domain [{}, {}] x [{}, {}] must be finite and not empty",
                info.u0, info.u1, info.v0, info.v1
            )));
        }
        let mut periods = [None, None];
        for (c, p) in [info.period_u, info.period_v].into_iter().enumerate() {
            if !(p.is_finite() && p >= 0.0) {
                return Err(Error::range(format!(
                    "period_{} = {p} must be 0 (open) or a finite positive period",
                    ["u", "v"][c]
                )));
            }
            if p > 0.0 {
                periods[c] = Some(p);
            }
        }
        let mut singular = Vec::new();
        if info.singular_count > 0 {
            if info.singular_points.is_null() {
                return Err(Error::null("info->singular_points"));
            }
            if info.singular_count > 1 << 20 {
                return Err(Error::range("info->singular_count is unreasonably large"));
            }
            let s = std::slice::from_raw_parts(info.singular_points, 3 * info.singular_count);
            for (k, c) in s.chunks(3).enumerate() {
                singular.push(finite3([c[0], c[1], c[2]], &format!("singular point {k}"))?);
            }
        }
        let mut g = m.lock()?;
        let loops = read_loops(&g, uses, loop_lengths, loop_count)?;
        if loops.is_empty() && periods.iter().all(|p| p.is_none()) {
            return Err(Error::geometry(
                "a face without boundary loops must be a closed surface, but neither u nor v is \
                 periodic (give period_u/period_v, or the face's loops)",
            ));
        }
        let id = next_id(g.faces.len(), "face")?;
        let mut surface = CallbackSurface {
            eval,
            trim: cb.trim,
            inverse: cb.inverse,
            user: UserPtr(user),
            u: [info.u0, info.u1],
            v: [info.v0, info.v1],
            periods,
            singular,
            scale: 1.0,
            face: id,
        };
        // check the callbacks on a grid and measure the surface
        surface.scale = in_callback_scope(|| -> Result<f64> {
            let mut lo = V3::repeat(f64::INFINITY);
            let mut hi = V3::repeat(f64::NEG_INFINITY);
            for i in 0..=4 {
                for j in 0..=4 {
                    let u = info.u0 + (info.u1 - info.u0) * i as f64 / 4.0;
                    let v = info.v0 + (info.v1 - info.v0) * j as f64 / 4.0;
                    let s = surface.try_eval(u, v, 2)?;
                    let p = V3::new(s[0], s[1], s[2]);
                    lo = lo.inf(&p);
                    hi = hi.sup(&p);
                }
            }
            Ok((hi - lo).norm().max(f64::MIN_POSITIVE))
        })?;
        g.faces.push(Face {
            surface: Arc::new(surface),
            loops,
            embedded_edges: vec![],
            embedded_vertices: vec![],
            name: None,
        });
        put(out_face, "out_face", id)
    })
}

/// Adds a planar face: the plane through `origin[0..3]` with normal
/// `normal[0..3]` (need not be unit length), bounded by loops as in
/// `bm_model_add_surface_face` (at least the outer loop). Every loop edge
/// must lie in the plane (checked here). Triangles come out
/// counter-clockwise seen from the side the normal points to. Its id goes
/// to `*out_face`.
#[no_mangle]
pub unsafe extern "C" fn bm_model_add_plane_face(
    model: *mut bm_model,
    origin: *const f64,
    normal: *const f64,
    uses: *const bm_edge_use,
    loop_lengths: *const usize,
    loop_count: usize,
    out_face: *mut u32,
) -> bm_result {
    guard("bm_model_add_plane_face", || unsafe {
        let m = object::<ModelObj>(model as *const c_void, "model")?;
        let o = finite3(read3(origin, "origin")?, "origin")?;
        let n = finite3(read3(normal, "normal")?, "normal")?.coords;
        need(out_face, "out_face")?;
        if !(n.norm() > 0.0) {
            return Err(Error::range("the normal is the zero vector"));
        }
        if loop_count == 0 {
            return Err(Error::range(
                "a planar face needs at least its outer loop (loop_count is 0)",
            ));
        }
        let n = n.normalize();
        // e1: the coordinate axis least aligned with n, made orthogonal
        let axis = [V3::x(), V3::y(), V3::z()]
            .into_iter()
            .min_by(|a, b| a.dot(&n).abs().total_cmp(&b.dot(&n).abs()))
            .unwrap_or(V3::x());
        let e1 = (axis - n * axis.dot(&n)).normalize();
        let e2 = n.cross(&e1);
        let plane = Plane { origin: o, e1, e2 };
        let mut g = m.lock()?;
        let loops = read_loops(&g, uses, loop_lengths, loop_count)?;
        // every loop edge in the plane
        in_callback_scope(|| -> Result<()> {
            for (li, lp) in loops.iter().enumerate() {
                for u in &lp.edges {
                    let e = &g.edges[u.edge as usize];
                    let tol = vertex_tolerance(e.curve.as_ref(), e.t0, e.t1)
                        .max(1e-9 * (o.coords.norm() + 1.0));
                    for k in 0..=8 {
                        let t = e.t0 + (e.t1 - e.t0) * k as f64 / 8.0;
                        let p = e.curve.point(t);
                        let off = (p - o).dot(&n);
                        if !(off.abs() <= 10.0 * tol) {
                            return Err(Error::geometry(format!(
                                "loop {li}: edge {} leaves the plane: at t = {t} it is \
                                 ({}, {}, {}), {off:.3e} from the plane",
                                u.edge, p.x, p.y, p.z
                            )));
                        }
                    }
                }
            }
            Ok(())
        })?;
        let id = next_id(g.faces.len(), "face")?;
        g.faces.push(Face {
            surface: Arc::new(plane),
            loops,
            embedded_edges: vec![],
            embedded_vertices: vec![],
            name: None,
        });
        put(out_face, "out_face", id)
    })
}

/// Makes edge `edge` a constraint inside face `face`: the face's mesh will
/// contain its segments (the edge must lie on the face's surface).
#[no_mangle]
pub unsafe extern "C" fn bm_model_face_embed_edge(
    model: *mut bm_model,
    face: u32,
    edge: u32,
) -> bm_result {
    guard("bm_model_face_embed_edge", || unsafe {
        let m = object::<ModelObj>(model as *const c_void, "model")?;
        let mut g = m.lock()?;
        check_id(&g, 2, face, "face")?;
        check_id(&g, 1, edge, "edge")?;
        g.faces[face as usize].embedded_edges.push(edge);
        Ok(())
    })
}

/// Makes vertex `vertex` a constraint point inside face `face`: the face's
/// mesh will have a node there.
#[no_mangle]
pub unsafe extern "C" fn bm_model_face_embed_vertex(
    model: *mut bm_model,
    face: u32,
    vertex: u32,
) -> bm_result {
    guard("bm_model_face_embed_vertex", || unsafe {
        let m = object::<ModelObj>(model as *const c_void, "model")?;
        let mut g = m.lock()?;
        check_id(&g, 2, face, "face")?;
        check_id(&g, 0, vertex, "vertex")?;
        g.faces[face as usize].embedded_vertices.push(vertex);
        Ok(())
    })
}

/// Adds a volume bounded by `face_count` faces, which together must form
/// closed shells (the outer boundary and any voids; each face's triangles
/// are oriented by the library, whichever way its surface's normal
/// points). `callbacks` may be NULL (or have a NULL `contains`): in/out
/// then comes from the boundary mesh alone; a `contains` callback is asked
/// in addition, and a point is inside only when both agree.
/// `bm_mesh_generate` with dim 3 fills the volume with tetrahedra. Its id
/// goes to `*out_volume`.
#[no_mangle]
pub unsafe extern "C" fn bm_model_add_volume(
    model: *mut bm_model,
    faces: *const u32,
    face_count: usize,
    callbacks: *const bm_volume_callbacks,
    user: *mut c_void,
    out_volume: *mut u32,
) -> bm_result {
    guard("bm_model_add_volume", || unsafe {
        let m = object::<ModelObj>(model as *const c_void, "model")?;
        need(out_volume, "out_volume")?;
        if face_count == 0 {
            return Err(Error::range("a volume needs at least one bounding face"));
        }
        if faces.is_null() {
            return Err(Error::null("faces"));
        }
        let fs = std::slice::from_raw_parts(faces, face_count).to_vec();
        let mut g = m.lock()?;
        for (k, &f) in fs.iter().enumerate() {
            check_id(&g, 2, f, &format!("faces[{k}]"))?;
        }
        let id = next_id(g.volumes.len(), "volume")?;
        let geometry = if callbacks.is_null() {
            None
        } else {
            (*callbacks).contains.map(|contains| {
                Arc::new(CallbackVolume {
                    contains,
                    user: UserPtr(user),
                    volume: id,
                }) as Arc<dyn bubblemesh_core::geom::VolumeGeometry>
            })
        };
        g.volumes.push(Volume {
            faces: fs,
            geometry,
            name: None,
        });
        put(out_volume, "out_volume", id)
    })
}

/// Names an entity (`dim` 0 vertex, 1 edge, 2 face, 3 volume); names appear
/// in error messages and in the files written (MSH physical names). The
/// string is copied.
#[no_mangle]
pub unsafe extern "C" fn bm_model_set_name(
    model: *mut bm_model,
    dim: c_int,
    id: u32,
    name: *const c_char,
) -> bm_result {
    guard("bm_model_set_name", || unsafe {
        let m = object::<ModelObj>(model as *const c_void, "model")?;
        let name = utf8(name, "name")?.to_string();
        if !(0..=3).contains(&dim) {
            return Err(Error::range(format!("dim = {dim} must be 0, 1, 2 or 3")));
        }
        let mut g = m.lock()?;
        check_id(&g, dim as usize, id, "id")?;
        let slot = match dim {
            0 => &mut g.vertices[id as usize].name,
            1 => &mut g.edges[id as usize].name,
            2 => &mut g.faces[id as usize].name,
            _ => &mut g.volumes[id as usize].name,
        };
        *slot = Some(name);
        Ok(())
    })
}

/// The number of entities of dimension `dim` (0..3) in the model.
#[no_mangle]
pub unsafe extern "C" fn bm_model_entity_count(
    model: *const bm_model,
    dim: c_int,
    out_count: *mut usize,
) -> bm_result {
    guard("bm_model_entity_count", || unsafe {
        let m = object::<ModelObj>(model as *const c_void, "model")?;
        need(out_count, "out_count")?;
        if !(0..=3).contains(&dim) {
            return Err(Error::range(format!("dim = {dim} must be 0, 1, 2 or 3")));
        }
        let g = m.lock()?;
        put(out_count, "out_count", count(&g, dim as usize))
    })
}
