//! The C ABI exercised from Rust (the same `extern "C"` functions a C host
//! calls): the threading contract, re-entrance, the panic guard, buffers,
//! and geometry beyond the C programs' torus and plate (a sphere with
//! singular points, a cylinder inverted by the library's own Newton
//! iteration, a tilted plane, embedded points, a trim callback).

use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::ffi::{c_char, c_int, c_void, CStr};
use std::ptr::{null, null_mut};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use bubblemesh_capi::bm_result::{self, *};
use bubblemesh_capi::geometry::*;
use bubblemesh_capi::mesh::*;
use bubblemesh_capi::model::*;
use bubblemesh_capi::spacing::*;
use bubblemesh_capi::state::*;
use bubblemesh_capi::*;

fn last_error() -> String {
    unsafe { CStr::from_ptr(bm_last_error_message()) }
        .to_string_lossy()
        .into_owned()
}

#[track_caller]
fn ok(rc: bm_result) {
    assert_eq!(rc, BM_OK, "{}", last_error());
}

#[track_caller]
fn fails(rc: bm_result, code: bm_result, needle: &str) {
    let msg = last_error();
    assert_eq!(rc, code, "{msg}");
    assert!(msg.contains(needle), "'{needle}' not in: {msg}");
}

fn expr(text: &str) -> *mut bm_spacing {
    let c = std::ffi::CString::new(text).unwrap();
    let mut s = null_mut();
    ok(unsafe { bm_spacing_from_expr(c.as_ptr(), &mut s) });
    s
}

fn new_model() -> *mut bm_model {
    let mut m = null_mut();
    ok(unsafe { bm_model_new(&mut m) });
    m
}

/// A square (or any polygon) of built-in lines in z = 0, as a plane face.
fn polygon_face(m: *mut bm_model, pts: &[[f64; 3]], normal: [f64; 3]) -> u32 {
    let mut v = Vec::new();
    for p in pts {
        let mut id = 0;
        ok(unsafe { bm_model_add_vertex(m, p[0], p[1], p[2], &mut id) });
        v.push(id);
    }
    let mut uses = Vec::new();
    for k in 0..v.len() {
        let mut e = 0;
        ok(unsafe { bm_model_add_line(m, v[k], v[(k + 1) % v.len()], &mut e) });
        uses.push(bm_edge_use {
            edge: e,
            forward: 1,
        });
    }
    let len = [uses.len()];
    let mut f = 0;
    ok(unsafe {
        bm_model_add_plane_face(
            m,
            pts[0].as_ptr(),
            normal.as_ptr(),
            uses.as_ptr(),
            len.as_ptr(),
            1,
            &mut f,
        )
    });
    f
}

fn unit_square() -> *mut bm_model {
    let m = new_model();
    polygon_face(
        m,
        &[
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ],
        [0.0, 0.0, 1.0],
    );
    m
}

struct Arrays {
    xyz: Vec<[f64; 3]>,
    tris: Vec<[u32; 3]>,
    tri_ent: Vec<bm_entity>,
    node_ent: Vec<bm_entity>,
}

fn arrays(mesh: *const bm_mesh) -> Arrays {
    unsafe {
        let (mut nn, mut nt) = (0, 0);
        ok(bm_mesh_node_count(mesh, &mut nn));
        ok(bm_mesh_triangle_count(mesh, &mut nt));
        let mut xyz = vec![0.0; 3 * nn];
        let mut tri = vec![0u32; 3 * nt];
        let mut te = vec![bm_entity { dim: -1, id: 0 }; nt];
        let mut ne = vec![bm_entity { dim: -1, id: 0 }; nn];
        ok(bm_mesh_nodes(mesh, xyz.as_mut_ptr(), xyz.len()));
        ok(bm_mesh_triangles(mesh, tri.as_mut_ptr(), tri.len()));
        ok(bm_mesh_triangle_entities(mesh, te.as_mut_ptr(), te.len()));
        ok(bm_mesh_node_entities(mesh, ne.as_mut_ptr(), ne.len()));
        Arrays {
            xyz: xyz.chunks(3).map(|c| [c[0], c[1], c[2]]).collect(),
            tris: tri.chunks(3).map(|c| [c[0], c[1], c[2]]).collect(),
            tri_ent: te,
            node_ent: ne,
        }
    }
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

impl Arrays {
    /// Area and the triangles' (unnormalised) normals.
    fn area(&self) -> (f64, Vec<[f64; 3]>) {
        let mut a = 0.0;
        let mut ns = Vec::new();
        for t in &self.tris {
            let p = t.map(|i| self.xyz[i as usize]);
            let n = cross(sub(p[1], p[0]), sub(p[2], p[0]));
            a += 0.5 * norm(n);
            ns.push(n);
        }
        (a, ns)
    }
    /// Edges used by exactly one triangle, and by more than two.
    fn open_and_bad_edges(&self) -> (usize, usize) {
        let mut m = std::collections::HashMap::new();
        for t in &self.tris {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                *m.entry((a.min(b), a.max(b))).or_insert(0) += 1;
            }
        }
        (
            m.values().filter(|&&c| c == 1).count(),
            m.values().filter(|&&c| c > 2).count(),
        )
    }
}

#[test]
fn panics_are_caught_and_reported() {
    fails(
        bm_test_panic(),
        BM_ERR_PANIC,
        "deliberate panic for testing",
    );
}

#[test]
fn success_clears_the_last_error_and_reading_it_does_not() {
    unsafe {
        fails(
            bm_model_add_vertex(null_mut(), 0.0, 0.0, 0.0, null_mut()),
            BM_ERR_NULL,
            "bm_model_add_vertex: argument 'model' is NULL",
        );
        let mut len = 0;
        ok(bm_last_error(null_mut(), 0, &mut len));
        assert_eq!(len, last_error().len());
        assert!(len > 0);
        let m = new_model();
        assert_eq!(last_error(), "");
        bm_model_free(m);
        assert_eq!(
            CStr::from_ptr(bm_result_name(BM_ERR_CALLBACK)).to_str(),
            Ok("BM_ERR_CALLBACK")
        );
        assert_eq!(
            CStr::from_ptr(bm_version()).to_str(),
            Ok(env!("CARGO_PKG_VERSION"))
        );
    }
}

/// What the spacing callback saw: the threads it ran on, the most calls in
/// flight at once, and the result of re-entering the model.
struct Probe {
    threads: Mutex<Vec<std::thread::ThreadId>>,
    in_flight: AtomicUsize,
    max_in_flight: AtomicUsize,
    model: *mut bm_model,
    reentry: Mutex<Option<bm_result>>,
}

unsafe extern "C" fn probing_spacing(
    user: *mut c_void,
    _x: f64,
    _y: f64,
    _z: f64,
    _dim: c_int,
    _id: u32,
    _u: f64,
    _v: f64,
    out: *mut f64,
) -> c_int {
    let p = &*(user as *const Probe);
    let now = p.in_flight.fetch_add(1, Ordering::SeqCst) + 1;
    p.max_in_flight.fetch_max(now, Ordering::SeqCst);
    {
        let mut t = p.threads.lock().unwrap();
        let me = std::thread::current().id();
        if !t.contains(&me) {
            t.push(me);
        }
    }
    let mut r = p.reentry.lock().unwrap();
    if r.is_none() && !p.model.is_null() {
        let mut id = 0;
        *r = Some(bm_model_add_vertex(p.model, 5.0, 5.0, 0.0, &mut id));
    }
    *out = 0.2;
    p.in_flight.fetch_sub(1, Ordering::SeqCst);
    0
}

#[test]
fn callbacks_run_on_the_meshing_thread_one_at_a_time_and_reentry_is_busy() {
    let m = unit_square();
    let probe = Box::new(Probe {
        threads: Mutex::new(Vec::new()),
        in_flight: AtomicUsize::new(0),
        max_in_flight: AtomicUsize::new(0),
        model: m,
        reentry: Mutex::new(None),
    });
    let user = &*probe as *const Probe as usize;
    let (mesh_thread, rc, mesh) = {
        let m = m as usize;
        std::thread::spawn(move || unsafe {
            let mut s = null_mut();
            ok(bm_spacing_from_callback(
                Some(probing_spacing),
                user as *mut c_void,
                &mut s,
            ));
            let mut mesh = null_mut();
            let rc = bm_mesh_generate(m as *const bm_model, s, -1, 0, &mut mesh);
            bm_spacing_free(s);
            (std::thread::current().id(), rc, mesh as usize)
        })
        .join()
        .unwrap()
    };
    ok(rc);
    assert_eq!(*probe.threads.lock().unwrap(), vec![mesh_thread]);
    assert_eq!(probe.max_in_flight.load(Ordering::SeqCst), 1);
    assert_eq!(*probe.reentry.lock().unwrap(), Some(BM_ERR_BUSY));
    unsafe {
        let mut n = 0;
        ok(bm_model_entity_count(m, 0, &mut n));
        assert_eq!(n, 4, "the re-entrant add must not have happened");
        bm_mesh_free(mesh as *mut bm_mesh);
        bm_model_free(m);
    }
}

#[test]
fn separate_models_mesh_on_separate_threads() {
    let handles: Vec<_> = (0..2)
        .map(|k| {
            std::thread::spawn(move || unsafe {
                let m = unit_square();
                let s = expr(if k == 0 { "0.1" } else { "0.05 + 0.1*x" });
                let mut mesh = null_mut();
                let rc = bm_mesh_generate(m, s, -1, 0, &mut mesh);
                let msg = last_error();
                let mut nt = 0;
                if rc == BM_OK {
                    ok(bm_mesh_triangle_count(mesh, &mut nt));
                }
                bm_mesh_free(mesh);
                bm_spacing_free(s);
                bm_model_free(m);
                (rc, msg, nt)
            })
        })
        .collect();
    for h in handles {
        let (rc, msg, nt) = h.join().unwrap();
        assert_eq!(rc, BM_OK, "{msg}");
        assert!(nt > 100);
    }
}

#[test]
fn wrong_handles_and_short_buffers_are_refused() {
    unsafe {
        let m = unit_square();
        let s = expr("0.25");
        fails(
            bm_mesh_generate(m, m as *const bm_spacing, -1, 0, &mut null_mut()),
            BM_ERR_RANGE,
            "not a live bm_spacing handle",
        );
        let mut mesh = null_mut();
        ok(bm_mesh_generate(m, s, -1, 1, &mut mesh));
        let mut nn = 0;
        ok(bm_mesh_node_count(mesh, &mut nn));
        let mut buf = vec![0.0; 3 * nn];
        fails(
            bm_mesh_nodes(mesh, buf.as_mut_ptr(), buf.len() - 1),
            BM_ERR_RANGE,
            "need",
        );
        fails(bm_mesh_nodes(mesh, null_mut(), 0), BM_ERR_NULL, "'out'");
        fails(
            bm_mesh_node_count(mesh, null_mut()),
            BM_ERR_NULL,
            "'out_count'",
        );
        // nothing to copy: NULL is fine
        ok(bm_mesh_tetrahedra(mesh, null_mut(), 0));
        ok(bm_mesh_tetrahedron_entities(mesh, null_mut(), 0));
        let mut uv = vec![0.0; 2 * nn];
        ok(bm_mesh_node_params(mesh, uv.as_mut_ptr(), uv.len()));
        // a report as JSON
        let mut len = 0;
        ok(bm_mesh_report_json(mesh, null_mut(), 0, &mut len));
        let mut text = vec![0u8; len + 1];
        fails(
            bm_mesh_report_json(mesh, text.as_mut_ptr() as *mut c_char, len, &mut len),
            BM_ERR_RANGE,
            "with its NUL",
        );
        ok(bm_mesh_report_json(
            mesh,
            text.as_mut_ptr() as *mut c_char,
            len + 1,
            &mut len,
        ));
        let v: serde_json::Value = serde_json::from_slice(&text[..len]).unwrap();
        assert_eq!(v["fast"], serde_json::Value::Bool(true));
        // files: unknown extension, missing directory
        let dir = tempfile::tempdir().unwrap();
        let bad = std::ffi::CString::new(dir.path().join("m.xyz").to_str().unwrap()).unwrap();
        fails(bm_mesh_write(mesh, bad.as_ptr()), BM_ERR_IO, "m.xyz");
        let missing =
            std::ffi::CString::new(dir.path().join("no/such/m.msh").to_str().unwrap()).unwrap();
        fails(bm_mesh_write(mesh, missing.as_ptr()), BM_ERR_IO, "m.msh");
        let good = std::ffi::CString::new(dir.path().join("m.msh").to_str().unwrap()).unwrap();
        ok(bm_mesh_write(mesh, good.as_ptr()));
        bm_mesh_free(mesh);
        // freeing NULL is fine; freeing a handle of another type is ignored
        bm_mesh_free(null_mut());
        bm_mesh_free(s as *mut bm_mesh);
        bm_spacing_free(s);
        bm_model_free(m);
        // bad strings
        let not_utf8 = [0xffu8, 0xfe, 0];
        fails(
            bm_spacing_from_expr(not_utf8.as_ptr() as *const c_char, &mut null_mut()),
            BM_ERR_UTF8,
            "not valid UTF-8",
        );
    }
}

#[test]
fn tilted_plane_with_an_embedded_point() {
    unsafe {
        // a square in the plane x + y + z = 1 around (1/3, 1/3, 1/3)
        let n = [1.0, 1.0, 1.0];
        let c = [1.0 / 3.0; 3];
        let e1 = [1.0 / 2f64.sqrt(), -1.0 / 2f64.sqrt(), 0.0];
        let e2 = cross(
            [n[0] / 3f64.sqrt(), n[1] / 3f64.sqrt(), n[2] / 3f64.sqrt()],
            e1,
        );
        let at = |u: f64, v: f64| [0, 1, 2].map(|k| c[k] + u * e1[k] + v * e2[k]);
        let m = new_model();
        let pts = [at(-0.5, -0.5), at(0.5, -0.5), at(0.5, 0.5), at(-0.5, 0.5)];
        let f = polygon_face(m, &pts, n);
        let inner = at(0.123, 0.234);
        let mut v = 0;
        ok(bm_model_add_vertex(m, inner[0], inner[1], inner[2], &mut v));
        ok(bm_model_face_embed_vertex(m, f, v));
        fails(
            bm_model_face_embed_vertex(m, f, 99),
            BM_ERR_RANGE,
            "vertex = 99",
        );
        fails(bm_model_face_embed_edge(m, 7, 0), BM_ERR_RANGE, "face = 7");
        // an edge off the plane is refused
        let mut w = [0u32; 2];
        ok(bm_model_add_vertex(m, 0.0, 0.0, 5.0, &mut w[0]));
        ok(bm_model_add_vertex(m, 1.0, 0.0, 5.0, &mut w[1]));
        let mut e = [0u32; 2];
        ok(bm_model_add_line(m, w[0], w[1], &mut e[0]));
        ok(bm_model_add_line(m, w[1], w[0], &mut e[1]));
        let uses = [
            bm_edge_use {
                edge: e[0],
                forward: 1,
            },
            bm_edge_use {
                edge: e[1],
                forward: 1,
            },
        ];
        let len = [2usize];
        fails(
            bm_model_add_plane_face(
                m,
                c.as_ptr(),
                n.as_ptr(),
                uses.as_ptr(),
                len.as_ptr(),
                1,
                &mut 0,
            ),
            BM_ERR_GEOMETRY,
            "leaves the plane",
        );
        let s = expr("0.08");
        let mut mesh = null_mut();
        ok(bm_mesh_generate(m, s, 2, 0, &mut mesh));
        let a = arrays(mesh);
        let (area, normals) = a.area();
        assert!((area - 1.0).abs() < 1e-9, "area {area}");
        for nrm in normals {
            assert!(dot(nrm, n) > 0.0, "a triangle faces away from the normal");
        }
        // (the off-plane edges stay in the model and are meshed as lines)
        for t in &a.tris {
            for &i in t {
                let p = a.xyz[i as usize];
                assert!((p[0] + p[1] + p[2] - 1.0).abs() < 1e-12, "{p:?}");
            }
        }
        let k = a
            .node_ent
            .iter()
            .position(|e| e.dim == 0 && e.id == v)
            .expect("no node on the embedded vertex");
        assert!(norm(sub(a.xyz[k], inner)) < 1e-12);
        assert!(a.tris.iter().any(|t| t.contains(&(k as u32))));
        bm_mesh_free(mesh);
        bm_spacing_free(s);
        bm_model_free(m);
    }
}

/// A sphere of radius 1: S = (cos v cos u, cos v sin u, sin v).
unsafe extern "C" fn sphere_eval(
    _: *mut c_void,
    u: f64,
    v: f64,
    order: c_int,
    o: *mut f64,
) -> c_int {
    let o = std::slice::from_raw_parts_mut(o, 18);
    let (cu, su, cv, sv) = (u.cos(), u.sin(), v.cos(), v.sin());
    o[..3].copy_from_slice(&[cv * cu, cv * su, sv]);
    if order >= 1 {
        o[3..9].copy_from_slice(&[-cv * su, cv * cu, 0.0, -sv * cu, -sv * su, cv]);
    }
    if order >= 2 {
        o[9..18].copy_from_slice(&[
            -cv * cu,
            -cv * su,
            0.0,
            sv * su,
            -sv * cu,
            0.0,
            -cv * cu,
            -cv * su,
            -sv,
        ]);
    }
    0
}

#[test]
fn sphere_closed_by_its_singular_points() {
    unsafe {
        let m = new_model();
        let poles = [0.0, 0.0, 1.0, 0.0, 0.0, -1.0];
        let info = bm_surface_info {
            u0: 0.0,
            u1: TAU,
            v0: -FRAC_PI_2,
            v1: FRAC_PI_2,
            period_u: TAU,
            period_v: 0.0,
            singular_points: poles.as_ptr(),
            singular_count: 2,
        };
        let cb = bm_surface_callbacks {
            eval: Some(sphere_eval),
            trim: None,
            inverse: None,
        };
        let mut f = 0;
        ok(bm_model_add_surface_face(
            m,
            &cb,
            null_mut(),
            &info,
            null(),
            null(),
            0,
            &mut f,
        ));
        let s = expr("0.15");
        let mut mesh = null_mut();
        ok(bm_mesh_generate(m, s, -1, 0, &mut mesh));
        let a = arrays(mesh);
        let (open, bad) = a.open_and_bad_edges();
        assert_eq!((open, bad), (0, 0), "the sphere is not closed");
        let (area, _) = a.area();
        let exact = 4.0 * PI;
        assert!(area < exact && (exact - area) / exact < 0.02, "area {area}");
        for p in &a.xyz {
            assert!((norm(*p) - 1.0).abs() < 1e-9);
        }
        bm_mesh_free(mesh);
        bm_spacing_free(s);
        bm_model_free(m);
    }
}

/// A circle of radius 0.5 at height `*user`.
unsafe extern "C" fn ring_eval(user: *mut c_void, t: f64, order: c_int, out: *mut f64) -> c_int {
    let z = *(user as *const f64);
    let o = std::slice::from_raw_parts_mut(out, 3);
    let (c, s) = (t.cos(), t.sin());
    o.copy_from_slice(&match order {
        0 => [0.5 * c, 0.5 * s, z],
        1 => [-0.5 * s, 0.5 * c, 0.0],
        _ => [-0.5 * c, -0.5 * s, 0.0],
    });
    0
}

/// A cylinder of radius 0.5 about z, v = height.
unsafe extern "C" fn cylinder_eval(
    _: *mut c_void,
    u: f64,
    v: f64,
    order: c_int,
    o: *mut f64,
) -> c_int {
    let o = std::slice::from_raw_parts_mut(o, 18);
    let (c, s) = (u.cos(), u.sin());
    o[..3].copy_from_slice(&[0.5 * c, 0.5 * s, v]);
    if order >= 1 {
        o[3..9].copy_from_slice(&[-0.5 * s, 0.5 * c, 0.0, 0.0, 0.0, 1.0]);
    }
    if order >= 2 {
        o[9..18].copy_from_slice(&[-0.5 * c, -0.5 * s, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
    }
    0
}

static TRIM_CALLS: AtomicUsize = AtomicUsize::new(0);

unsafe extern "C" fn trim_all_in(_: *mut c_void, _u: f64, _v: f64, inside: *mut c_int) -> c_int {
    TRIM_CALLS.fetch_add(1, Ordering::SeqCst);
    *inside = 1;
    0
}

unsafe extern "C" fn trim_fails(_: *mut c_void, _u: f64, _v: f64, _inside: *mut c_int) -> c_int {
    5
}

/// The side of a cylinder between two circles, with no inverse callback:
/// the library maps the boundary to (u,v) by its own Newton iteration.
fn cylinder_model(trim: bm_surface_trim_fn, heights: &'static [f64; 2]) -> *mut bm_model {
    unsafe {
        let m = new_model();
        let mut uses = Vec::new();
        for (k, z) in heights.iter().enumerate() {
            let mut v = 0;
            ok(bm_model_add_vertex(m, 0.5, 0.0, *z, &mut v));
            let cb = bm_curve_callbacks {
                eval: Some(ring_eval),
            };
            let mut e = 0;
            ok(bm_model_add_curve(
                m,
                &cb,
                z as *const f64 as *mut c_void,
                0.0,
                TAU,
                v,
                v,
                &mut e,
            ));
            uses.push(bm_edge_use {
                edge: e,
                forward: (k == 0) as c_int,
            });
        }
        let info = bm_surface_info {
            u0: 0.0,
            u1: TAU,
            v0: heights[0],
            v1: heights[1],
            period_u: TAU,
            period_v: 0.0,
            singular_points: null(),
            singular_count: 0,
        };
        let cb = bm_surface_callbacks {
            eval: Some(cylinder_eval),
            trim,
            inverse: None,
        };
        let lens = [1usize, 1];
        let mut f = 0;
        ok(bm_model_add_surface_face(
            m,
            &cb,
            null_mut(),
            &info,
            uses.as_ptr(),
            lens.as_ptr(),
            2,
            &mut f,
        ));
        m
    }
}

static HEIGHTS: [f64; 2] = [0.0, 1.0];

#[test]
fn cylinder_side_inverted_by_newton() {
    unsafe {
        let m = cylinder_model(Some(trim_all_in), &HEIGHTS);
        let s = expr("0.1");
        let mut mesh = null_mut();
        ok(bm_mesh_generate(m, s, -1, 0, &mut mesh));
        assert!(TRIM_CALLS.load(Ordering::SeqCst) > 0, "trim never asked");
        let a = arrays(mesh);
        let (area, _) = a.area();
        let exact = TAU * 0.5 * 1.0;
        assert!(
            area < exact && (exact - area) / exact < 0.02,
            "area {area} vs {exact}"
        );
        let (open, bad) = a.open_and_bad_edges();
        assert_eq!(bad, 0);
        assert!(open > 0);
        for p in &a.xyz {
            assert!((p[0].hypot(p[1]) - 0.5).abs() < 1e-9);
            assert!(p[2] > -1e-12 && p[2] < 1.0 + 1e-12);
        }
        assert!(a.tri_ent.iter().all(|e| e.dim == 2 && e.id == 0));
        bm_mesh_free(mesh);

        let m2 = cylinder_model(Some(trim_fails), &HEIGHTS);
        fails(
            bm_mesh_generate(m2, s, -1, 0, &mut mesh),
            BM_ERR_CALLBACK,
            "surface callback 'trim' of face 0",
        );
        bm_model_free(m2);
        bm_spacing_free(s);
        bm_model_free(m);
    }
}

#[test]
fn null_and_range_checks_on_the_model_builders() {
    unsafe {
        let m = new_model();
        let mut id = 0;
        fails(bm_model_new(null_mut()), BM_ERR_NULL, "'out'");
        fails(
            bm_model_add_vertex(m, 0.0, 0.0, f64::INFINITY, &mut id),
            BM_ERR_RANGE,
            "not finite",
        );
        fails(
            bm_model_add_vertex(m, 0.0, 0.0, 0.0, null_mut()),
            BM_ERR_NULL,
            "out_id",
        );
        ok(bm_model_add_vertex(m, 0.0, 0.0, 0.0, &mut id));
        fails(
            bm_model_add_line(m, 0, 0, &mut id),
            BM_ERR_GEOMETRY,
            "two distinct points",
        );
        fails(
            bm_model_add_line(m, 0, 1, &mut id),
            BM_ERR_RANGE,
            "end_vertex = 1",
        );
        let cb = bm_curve_callbacks { eval: None };
        fails(
            bm_model_add_curve(m, &cb, null_mut(), 0.0, 1.0, 0, 0, &mut id),
            BM_ERR_NULL,
            "callbacks->eval",
        );
        fails(
            bm_model_add_curve(m, null(), null_mut(), 0.0, 1.0, 0, 0, &mut id),
            BM_ERR_NULL,
            "'callbacks'",
        );
        let scb = bm_surface_callbacks {
            eval: Some(cylinder_eval),
            trim: None,
            inverse: None,
        };
        let mut info = bm_surface_info {
            u0: 0.0,
            u1: 1.0,
            v0: 0.0,
            v1: 1.0,
            period_u: 0.0,
            period_v: 0.0,
            singular_points: null(),
            singular_count: 0,
        };
        fails(
            bm_model_add_surface_face(m, &scb, null_mut(), &info, null(), null(), 0, &mut id),
            BM_ERR_GEOMETRY,
            "without boundary loops must be a closed surface",
        );
        info.period_u = -1.0;
        fails(
            bm_model_add_surface_face(m, &scb, null_mut(), &info, null(), null(), 0, &mut id),
            BM_ERR_RANGE,
            "period_u = -1",
        );
        info.period_u = 0.0;
        info.singular_count = 1;
        fails(
            bm_model_add_surface_face(m, &scb, null_mut(), &info, null(), null(), 0, &mut id),
            BM_ERR_NULL,
            "singular_points",
        );
        info.singular_count = 0;
        info.u1 = f64::NAN;
        fails(
            bm_model_add_surface_face(m, &scb, null_mut(), &info, null(), null(), 0, &mut id),
            BM_ERR_RANGE,
            "domain",
        );
        let lens = [0usize];
        fails(
            bm_model_add_plane_face(
                m,
                [0.0; 3].as_ptr(),
                [0.0, 0.0, 1.0].as_ptr(),
                null(),
                lens.as_ptr(),
                1,
                &mut id,
            ),
            BM_ERR_RANGE,
            "loop_lengths[0] = 0",
        );
        fails(
            bm_model_add_plane_face(
                m,
                [0.0; 3].as_ptr(),
                [0.0; 3].as_ptr(),
                null(),
                lens.as_ptr(),
                1,
                &mut id,
            ),
            BM_ERR_RANGE,
            "zero vector",
        );
        let name = c"corner";
        ok(bm_model_set_name(m, 0, 0, name.as_ptr()));
        fails(
            bm_model_set_name(m, 4, 0, name.as_ptr()),
            BM_ERR_RANGE,
            "dim = 4",
        );
        fails(
            bm_model_set_name(m, 1, 0, name.as_ptr()),
            BM_ERR_RANGE,
            "not an edge id",
        );
        fails(
            bm_model_add_volume(m, [0u32].as_ptr(), 1, null(), null_mut(), &mut id),
            BM_ERR_RANGE,
            "faces[0] = 0",
        );
        let mut n = 9;
        fails(
            bm_model_entity_count(m, -1, &mut n),
            BM_ERR_RANGE,
            "dim = -1",
        );
        ok(bm_model_entity_count(m, 1, &mut n));
        assert_eq!(n, 0);
        let s = expr("0.1");
        fails(
            bm_mesh_generate(m, s, 2, 0, &mut null_mut()),
            BM_ERR_RANGE,
            "dim = 2 but the model's highest dimension is 0",
        );
        bm_spacing_free(s);
        let mut o = std::mem::zeroed::<bm_options>();
        ok(bm_options_init(&mut o));
        assert_eq!((o.dim, o.fast, o.max_steps), (-1, 0, 0));
        fails(
            bm_mesh_generate_ex(m, null(), null(), &mut null_mut()),
            BM_ERR_NULL,
            "'options'",
        );
        bm_model_free(m);
    }
}

/// `bm_mesh_step_file` with a NULL spacing uses the command line's default
/// (1/40 of the bounding-box diagonal) and meshes a solid's faces by
/// default; a STEP mesh's ids are the file's faces and solids.
#[test]
fn step_file_defaults_follow_the_command_line() {
    let path = std::ffi::CString::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../fixtures/step/ball.step"
    ))
    .unwrap();
    let mut mesh = null_mut();
    ok(unsafe { bm_mesh_step_file(path.as_ptr(), null(), -1, 0, &mut mesh) });
    let a = arrays(mesh);
    let mut ntet = usize::MAX;
    ok(unsafe { bm_mesh_tetrahedron_count(mesh, &mut ntet) });
    assert_eq!(ntet, 0, "dim -1 on a solid meshes its faces only");
    assert!(a.tri_ent.iter().all(|e| e.dim == 2 && e.id == 0));
    // mean edge length against d = diag / 40 (the ball's box is 2 x 2 x 2)
    let d = (12.0f64).sqrt() / 40.0;
    let mut sum = 0.0;
    for t in &a.tris {
        for k in 0..3 {
            sum += norm(sub(a.xyz[t[k] as usize], a.xyz[t[(k + 1) % 3] as usize]));
        }
    }
    let mean = sum / (3 * a.tris.len()) as f64;
    assert!(
        (0.8 * d..1.25 * d).contains(&mean),
        "mean edge {mean}, default d {d}"
    );
    unsafe { bm_mesh_free(mesh) };
    // a plugin spacing with the STEP shortcut, and BUSY while it is used
    // is covered in C; here: an options struct with a progress callback
    // that cancels works for STEP too
    unsafe extern "C" fn stop(
        _u: *mut c_void,
        _p: *const c_char,
        _d: c_int,
        _i: u32,
        step: usize,
        _m: usize,
    ) -> c_int {
        (step >= 3) as c_int
    }
    let mut o = std::mem::MaybeUninit::<bm_options>::uninit();
    ok(unsafe { bm_options_init(o.as_mut_ptr()) });
    let mut o = unsafe { o.assume_init() };
    o.progress = Some(stop);
    let mut mesh = null_mut();
    fails(
        unsafe { bm_mesh_step_file_ex(path.as_ptr(), null(), &o, &mut mesh) },
        BM_ERR_CANCELLED,
        "cancelled by the progress callback",
    );
    assert!(mesh.is_null());
}

fn cstring(p: &std::path::Path) -> std::ffi::CString {
    std::ffi::CString::new(p.to_str().unwrap()).unwrap()
}

/// A state written as the command line writes it (`mesh --save-state`:
/// `remesh::state_of` of the model it read, its mesh and spacing) loads
/// through the C ABI and re-meshes the same STEP file from
/// `bm_remesh_step_file`; the report's `remesh` section has the CLI's
/// fields, and every old node outside the box and its band is kept.
#[test]
fn a_command_line_state_remeshes_a_step_file() {
    use bubblemesh_core::remesh;
    use bubblemesh_core::spacing::Constant;
    let step = concat!(env!("CARGO_MANIFEST_DIR"), "/../fixtures/step/cube.step");
    let model = bubblemesh_truck::read_step(std::path::Path::new(step))
        .unwrap()
        .model;
    let d = 0.1;
    let s = Constant(d);
    let opts = bubblemesh_core::Options {
        dim: Some(2),
        ..Default::default()
    };
    let (m0, _) = bubblemesh_core::mesh_model(&model, &s, &opts).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("cli.state");
    std::fs::write(
        &file,
        remesh::state_of(&model, &m0, &s, "0.1", step).to_bytes(),
    )
    .unwrap();
    unsafe {
        let mut state = null_mut();
        ok(bm_state_load(cstring(&file).as_ptr(), &mut state));
        let sp = expr("0.1");
        let path = std::ffi::CString::new(step).unwrap();
        let region = c"box:0.6,0.6,0.6,1.2,1.2,1.2";
        let mut mesh = null_mut();
        ok(bm_remesh_step_file(
            path.as_ptr(),
            sp,
            state,
            -1,
            region.as_ptr(),
            &mut mesh,
        ));
        let a = arrays(mesh);
        let now: std::collections::HashSet<[u64; 3]> = a
            .xyz
            .iter()
            .map(|p| [p[0].to_bits(), p[1].to_bits(), p[2].to_bits()])
            .collect();
        let dist = |p: &bubblemesh_core::P3| {
            let q = [p.x, p.y, p.z].map(|c| (0.6 - c).max(0.0));
            (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt()
        };
        let far: Vec<_> = m0.nodes.iter().filter(|n| dist(&n.pos) > 2.0 * d).collect();
        assert!(far.len() > m0.nodes.len() / 2);
        assert!(far.iter().all(|n| now.contains(&[
            n.pos.x.to_bits(),
            n.pos.y.to_bits(),
            n.pos.z.to_bits()
        ])));
        let mut len = 0;
        ok(bm_mesh_report_json(mesh, null_mut(), 0, &mut len));
        let mut text = vec![0u8; len + 1];
        ok(bm_mesh_report_json(
            mesh,
            text.as_mut_ptr() as *mut c_char,
            len + 1,
            &mut len,
        ));
        let v: serde_json::Value = serde_json::from_slice(&text[..len]).unwrap();
        let r = &v["remesh"];
        let summary = &r["summary"];
        assert_eq!(summary["matching"]["matched"].as_array().unwrap().len(), 19);
        assert_eq!(summary["far_from_region"], summary["far_kept"]);
        assert!(summary["kept"].as_u64().unwrap() as usize >= far.len());
        for key in ["moved", "added", "removed"] {
            assert!(summary[key].is_u64(), "{key} missing: {summary}");
        }
        assert!(r["stage2_steps_max"].as_u64().unwrap() > 0);
        assert_eq!(
            r["stage2_steps_per_face"].as_array().unwrap().len(),
            6,
            "{r}"
        );
        // the engine's report is still there, as for a run from scratch
        assert_eq!(v["triangles"].as_u64(), Some(a.tris.len() as u64));
        bm_mesh_free(mesh);
        bm_spacing_free(sp);
        bm_state_free(state);
    }
}

/// `bm_state_save` replaces an existing file whole, leaves nothing behind
/// when it cannot write, and a state records the spacing it was made with
/// (a callback spacing as "callback"); BM_ERR_STATE has its name.
#[test]
fn states_save_whole_and_record_their_spacing() {
    unsafe extern "C" fn d(
        _u: *mut c_void,
        _x: f64,
        _y: f64,
        _z: f64,
        _dim: c_int,
        _id: u32,
        _a: f64,
        _b: f64,
        out: *mut f64,
    ) -> c_int {
        *out = 0.2;
        0
    }
    unsafe {
        assert_eq!(
            CStr::from_ptr(bm_result_name(BM_ERR_STATE)).to_str(),
            Ok("BM_ERR_STATE")
        );
        let m = unit_square();
        let mut s = null_mut();
        ok(bm_spacing_from_callback(Some(d), null_mut(), &mut s));
        let mut mesh = null_mut();
        ok(bm_mesh_generate(m, s, -1, 0, &mut mesh));
        let mut state = null_mut();
        ok(bm_mesh_state(mesh, &mut state));
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("s.state");
        std::fs::write(&file, b"old contents").unwrap();
        ok(bm_state_save(state, cstring(&file).as_ptr()));
        let st =
            bubblemesh_core::remesh::State::from_bytes(&std::fs::read(&file).unwrap()).unwrap();
        assert_eq!(st.spacing, "callback");
        assert_eq!(st.dim, 2);
        // the unit square's 4 edges and face, each with bubbles
        assert_eq!(st.entities.len(), 5);
        assert!(st.entities.iter().all(|e| !e.bubbles.is_empty()));
        // a directory in the way: refused, the directory left alone, no
        // temporary file left in the parent
        let sub = dir.path().join("sub.state");
        std::fs::create_dir(&sub).unwrap();
        fails(
            bm_state_save(state, cstring(&sub).as_ptr()),
            BM_ERR_IO,
            "sub.state",
        );
        assert!(sub.is_dir());
        let mut names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .collect();
        names.sort();
        assert_eq!(names, ["s.state", "sub.state"]);
        // a directory is not a state file either
        let mut none = null_mut();
        fails(
            bm_state_load(cstring(&sub).as_ptr(), &mut none),
            BM_ERR_IO,
            "sub.state",
        );
        assert!(none.is_null());
        // freeing a handle of another type through bm_state_free is ignored
        bm_state_free(mesh as *mut bm_state);
        bm_state_free(state);
        let mut n = 0;
        ok(bm_mesh_node_count(mesh, &mut n));
        bm_mesh_free(mesh);
        bm_spacing_free(s);
        bm_model_free(m);
    }
}
