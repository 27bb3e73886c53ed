//! A Python callable as the node spacing d(x): [`PySpacing`].
//!
//! The callable takes an `(n, 3)` float64 array of points and returns `n`
//! spacings; it is only ever called in batches:
//!
//! - where the engine asks for many points at once
//!   ([`Spacing::spacing_batch`]: stage 2 re-spacing the bubbles, the
//!   quality report's L/d), with exactly those points;
//! - where it asks for one point at a time (stage 1, the edge chains, new
//!   bubbles of population control), from a grid of the callable's values
//!   over the model's box: cells of a quarter of the least spacing found
//!   on a first sample ([`PySpacing::new`]),
//!   evaluated lazily in tiles of `TILE`³ cells (fewer along an axis the
//!   box is thin in; one call per tile, where the engine first asks),
//!   interpolated trilinearly.
//!
//! Every value is checked (finite, > 0) and the result's shape too; the
//! first failure, or an exception of the callable, cancels the run
//! ([`crate::Run::cancel`]) and is raised as a `SpacingError`.

use std::collections::HashMap;
use std::sync::{Arc, RwLock};

use bubblemesh_core::spacing::{Spacing, SpacingQuery};
use bubblemesh_core::{Model, P3};
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;

use crate::{Run, SpacingError};

/// The fewest cells of the grid along the model box's diagonal.
const MIN_CELLS: f64 = 64.0;
/// The most cells along the diagonal (surfaces and curves).
const MAX_CELLS: f64 = 1024.0;
/// The most cells along the diagonal of a model with volumes (the grid
/// fills them).
const MAX_CELLS_3D: f64 = 400.0;
/// Cells along each side of a tile (one call of the callable).
const TILE: usize = 8;

/// A Python callable as a [`Spacing`].
pub(crate) struct PySpacing {
    func: Py<PyAny>,
    run: Arc<Run>,
    /// The grid's corner (the model's box, padded).
    lo: P3,
    /// The grid's cell size.
    h: f64,
    /// Cells along x, y, z.
    cells: [i64; 3],
    /// Cells along each side of a tile: [`TILE`], fewer along a thin axis
    /// (a flat model's z).
    tile_cells: [i64; 3],
    /// Values at the nodes of each tile evaluated so far.
    tiles: RwLock<HashMap<[i64; 3], Arc<Vec<f64>>>>,
}

impl PySpacing {
    /// `func` as the spacing of `model`'s run `run`. The grid's cell is a
    /// quarter of the least spacing the callable gives at the model's
    /// vertices, along its edges and on a 17-point lattice over its box (one
    /// call, which also checks the callable before meshing), within
    /// 1/[`MIN_CELLS`] to 1/[`MAX_CELLS`] of the box's diagonal
    /// (1/[`MAX_CELLS_3D`] with volumes).
    pub(crate) fn new(
        py: Python<'_>,
        func: Py<PyAny>,
        model: &Model,
        run: Arc<Run>,
    ) -> PyResult<PySpacing> {
        let (lo, hi) = model
            .bbox()
            .unwrap_or((P3::new(0.0, 0.0, 0.0), P3::new(1.0, 1.0, 1.0)));
        let diag = (hi - lo).norm();
        let diag = if diag > 0.0 && diag.is_finite() {
            diag
        } else {
            1.0
        };
        let d_min = least_spacing(py, &func, model, lo, hi, diag)?;
        let max_cells = if model.volumes.is_empty() {
            MAX_CELLS
        } else {
            MAX_CELLS_3D
        };
        let h = (0.25 * d_min).clamp(diag / max_cells, diag / MIN_CELLS);
        let pad = 2.0 * h;
        let lo = P3::new(lo.x - pad, lo.y - pad, lo.z - pad);
        let ext = hi - lo;
        let cells = [ext.x, ext.y, ext.z].map(|e| ((e + pad) / h).ceil().max(1.0) as i64);
        let tile_cells = cells.map(|c| c.min(TILE as i64));
        Ok(PySpacing {
            func,
            run,
            lo,
            h,
            cells,
            tile_cells,
            tiles: RwLock::new(HashMap::new()),
        })
    }

    /// The callable at `points`, checked; cancels the run and unwinds on a
    /// failure.
    fn eval(&self, points: Vec<f64>) -> Vec<f64> {
        self.run.stop_if_cancelled();
        let n = points.len() / 3;
        match Python::with_gil(|py| call(py, &self.func, points, n)) {
            Ok(v) => v,
            Err(e) => {
                self.run.cancel(e);
                self.run.stop_if_cancelled();
                unreachable!("the run was just cancelled")
            }
        }
    }

    /// The values at the nodes of tile `t`, evaluated on first use.
    fn tile(&self, t: [i64; 3]) -> Arc<Vec<f64>> {
        if let Some(v) = self.tiles.read().unwrap_or_else(|p| p.into_inner()).get(&t) {
            return v.clone();
        }
        let tc = self.tile_cells;
        let mut pts = Vec::with_capacity(((tc[0] + 1) * (tc[1] + 1) * (tc[2] + 1) * 3) as usize);
        for i in 0..=tc[0] {
            for j in 0..=tc[1] {
                for k in 0..=tc[2] {
                    let c = [t[0] * tc[0] + i, t[1] * tc[1] + j, t[2] * tc[2] + k];
                    pts.push(self.lo.x + c[0] as f64 * self.h);
                    pts.push(self.lo.y + c[1] as f64 * self.h);
                    pts.push(self.lo.z + c[2] as f64 * self.h);
                }
            }
        }
        let v = Arc::new(self.eval(pts));
        self.tiles
            .write()
            .unwrap_or_else(|p| p.into_inner())
            .entry(t)
            .or_insert(v)
            .clone()
    }

    /// d at `p` from the grid (trilinear in the cell holding `p`; points
    /// off the grid take its nearest cell's values).
    fn interpolate(&self, p: &P3) -> f64 {
        let rel = [
            (p.x - self.lo.x) / self.h,
            (p.y - self.lo.y) / self.h,
            (p.z - self.lo.z) / self.h,
        ];
        let tc = self.tile_cells;
        let mut tile = [0i64; 3];
        let mut local = [0.0f64; 3];
        let mut cell = [0usize; 3];
        for a in 0..3 {
            let c = if rel[a].is_finite() {
                rel[a].clamp(0.0, self.cells[a] as f64)
            } else {
                0.0
            };
            let t = ((c / tc[a] as f64).floor() as i64).min((self.cells[a] - 1) / tc[a]);
            let l = (c - (t * tc[a]) as f64).clamp(0.0, tc[a] as f64);
            let ci = (l.floor() as usize).min(tc[a] as usize - 1);
            tile[a] = t;
            cell[a] = ci;
            local[a] = l - ci as f64;
        }
        let v = self.tile(tile);
        let (mj, mk) = (tc[1] as usize + 1, tc[2] as usize + 1);
        let at = |i: usize, j: usize, k: usize| v[(i * mj + j) * mk + k];
        let [fx, fy, fz] = local;
        let [i, j, k] = cell;
        let c00 = at(i, j, k) * (1.0 - fx) + at(i + 1, j, k) * fx;
        let c10 = at(i, j + 1, k) * (1.0 - fx) + at(i + 1, j + 1, k) * fx;
        let c01 = at(i, j, k + 1) * (1.0 - fx) + at(i + 1, j, k + 1) * fx;
        let c11 = at(i, j + 1, k + 1) * (1.0 - fx) + at(i + 1, j + 1, k + 1) * fx;
        let c0 = c00 * (1.0 - fy) + c10 * fy;
        let c1 = c01 * (1.0 - fy) + c11 * fy;
        c0 * (1.0 - fz) + c1 * fz
    }
}

impl Spacing for PySpacing {
    fn spacing(&self, q: &SpacingQuery) -> f64 {
        self.interpolate(&q.point)
    }

    fn spacing_batch(&self, qs: &[SpacingQuery], out: &mut [f64]) {
        if qs.is_empty() {
            return;
        }
        let pts: Vec<f64> = qs
            .iter()
            .flat_map(|q| [q.point.x, q.point.y, q.point.z])
            .collect();
        out.copy_from_slice(&self.eval(pts));
    }
}
/// Calls the function on the `n` points (x, y, z flattened) and checks
/// what it returns.
fn call(py: Python<'_>, func: &Py<PyAny>, points: Vec<f64>, n: usize) -> PyResult<Vec<f64>> {
    let arr = Array2::from_shape_vec((n, 3), points)
        .expect("three coordinates per point")
        .into_pyarray(py);
    let got = func.call1(py, (arr.clone(),)).map_err(|e| {
        let err = SpacingError::new_err(format!("the spacing callable raised {e}"));
        err.set_cause(py, Some(e));
        err
    })?;
    let np = py.import("numpy")?;
    let values = np
        .call_method1("asarray", (got.bind(py), "float64"))
        .map_err(|e| {
            SpacingError::new_err(format!(
                "the spacing callable returned something that is not an array of numbers ({e})"
            ))
        })?;
    let values = values
        .downcast::<numpy::PyArrayDyn<f64>>()
        .map_err(|_| SpacingError::new_err("the spacing callable returned no float array"))?;
    if values.shape() != [n] {
        return Err(SpacingError::new_err(format!(
            "the spacing callable returned an array of shape {:?} for {n} points; expected ({n},)",
            values.shape()
        )));
    }
    let out: Vec<f64> = values.readonly().as_array().iter().copied().collect();
    if let Some(k) = out.iter().position(|d| !(d.is_finite() && *d > 0.0)) {
        let p = arr.readonly();
        let p = p.as_array();
        return Err(SpacingError::new_err(format!(
            "the spacing callable returned {} at ({}, {}, {}): a spacing must be finite and > 0",
            out[k],
            p[[k, 0]],
            p[[k, 1]],
            p[[k, 2]]
        )));
    }
    Ok(out)
}

/// The least value of `func` at `model`'s vertices, along its edges and on
/// a lattice of 17 points a side over the box `lo..hi` (one along an axis
/// the box is flat in), in one call.
fn least_spacing(
    py: Python<'_>,
    func: &Py<PyAny>,
    model: &Model,
    lo: P3,
    hi: P3,
    diag: f64,
) -> PyResult<f64> {
    let mut pts: Vec<P3> = model.vertices.iter().map(|v| v.point).collect();
    for e in &model.edges {
        for k in 0..=8 {
            pts.push(e.curve.point(e.t0 + (e.t1 - e.t0) * k as f64 / 8.0));
        }
    }
    let ext = hi - lo;
    let steps = [ext.x, ext.y, ext.z].map(|e| if e > 1e-9 * diag { 16 } else { 0 });
    for i in 0..=steps[0] {
        for j in 0..=steps[1] {
            for k in 0..=steps[2] {
                let f = |n: usize, s: usize| if s == 0 { 0.0 } else { n as f64 / s as f64 };
                pts.push(P3::new(
                    lo.x + ext.x * f(i, steps[0]),
                    lo.y + ext.y * f(j, steps[1]),
                    lo.z + ext.z * f(k, steps[2]),
                ));
            }
        }
    }
    pts.retain(|p| p.x.is_finite() && p.y.is_finite() && p.z.is_finite());
    let n = pts.len();
    let flat: Vec<f64> = pts.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
    let values = call(py, func, flat, n)?;
    Ok(values.into_iter().fold(f64::INFINITY, f64::min))
}
