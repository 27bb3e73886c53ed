//! `bubblemesh.Mesh`: a mesh with its spacing, report and quality.

use std::panic::AssertUnwindSafe;
use std::path::PathBuf;
use std::sync::{Arc, OnceLock};

use bubblemesh_core::quality::{self, QualityReport};
use bubblemesh_core::{Mesh as CoreMesh, Spacing};
use bubblemesh_io::output::OutputSet;
use bubblemesh_run::{Drawing, PictureSettings};
use bubblemesh_viz::ColorBy;
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use crate::{to_py, InputError, MeshError, Run};

/// A mesh made by `bubblemesh.mesh` (or read by `bubblemesh.read`):
/// nodes, elements with the model entity each meshes, the spacing it was
/// made with, and its report.
#[pyclass(module = "bubblemesh", name = "Mesh", frozen)]
pub struct Mesh {
    mesh: CoreMesh,
    spacing: Option<Box<dyn Spacing>>,
    run: Arc<Run>,
    title: String,
    note: String,
    report: serde_json::Value,
    warnings: Vec<String>,
    quality: OnceLock<QualityReport>,
}

impl Mesh {
    /// The mesh of a run.
    pub(crate) fn new(
        mesh: CoreMesh,
        spacing: Box<dyn Spacing>,
        run: Arc<Run>,
        title: String,
        note: String,
        report: serde_json::Value,
        warnings: Vec<String>,
    ) -> Mesh {
        Mesh {
            mesh,
            spacing: Some(spacing),
            run,
            title,
            note,
            report,
            warnings,
            quality: OnceLock::new(),
        }
    }

    /// Runs `f`, which may call the spacing, turning a failure of a Python
    /// spacing (which unwinds) or a panic into a Python exception.
    fn guarded<T>(&self, f: impl FnOnce() -> PyResult<T>) -> PyResult<T> {
        match std::panic::catch_unwind(AssertUnwindSafe(f)) {
            Ok(r) => r,
            Err(_) => Err(self
                .run
                .take_failure_and_reset()
                .unwrap_or_else(|| MeshError::new_err("internal error (a bug, please report it)"))),
        }
    }

    /// The quality report, computed once.
    fn quality_report(&self) -> PyResult<&QualityReport> {
        if let Some(q) = self.quality.get() {
            return Ok(q);
        }
        let q = self.guarded(|| Ok(quality::analyse(&self.mesh, self.spacing.as_deref())))?;
        Ok(self.quality.get_or_init(|| q))
    }
}

/// `values` as an `(n, k)` int64 array.
fn int_array<'py, const N: usize>(
    py: Python<'py>,
    rows: impl ExactSizeIterator<Item = [u32; N]>,
) -> Bound<'py, PyArray2<i64>> {
    let n = rows.len();
    let flat: Vec<i64> = rows.flat_map(|r| r.map(i64::from)).collect();
    Array2::from_shape_vec((n, N), flat)
        .expect("N columns")
        .into_pyarray(py)
}

/// Parses a picture colouring.
fn color_by(color: &str) -> PyResult<ColorBy> {
    match color {
        "quality" => Ok(ColorBy::Quality),
        "entity" => Ok(ColorBy::Entity),
        other => Err(InputError::new_err(format!(
            "color '{other}': expected 'quality' or 'entity'"
        ))),
    }
}

#[pymethods]
impl Mesh {
    /// Node coordinates, an (n, 3) float64 array.
    #[getter]
    fn points<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let flat: Vec<f64> = self
            .mesh
            .nodes
            .iter()
            .flat_map(|n| [n.pos.x, n.pos.y, n.pos.z])
            .collect();
        Array2::from_shape_vec((self.mesh.nodes.len(), 3), flat)
            .expect("three coordinates")
            .into_pyarray(py)
    }

    /// Triangles, an (m, 3) int64 array of 0-based node indices.
    #[getter]
    fn triangles<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<i64>> {
        int_array(py, self.mesh.triangles.iter().map(|e| e.nodes))
    }

    /// Tetrahedra, an (m, 4) int64 array of 0-based node indices.
    #[getter]
    fn tetrahedra<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<i64>> {
        int_array(py, self.mesh.tetrahedra.iter().map(|e| e.nodes))
    }

    /// Edge elements (segments of the model's curves), an (m, 2) int64 array.
    #[getter]
    fn lines<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<i64>> {
        int_array(py, self.mesh.lines.iter().map(|e| e.nodes))
    }

    /// The face id each triangle meshes (int64, one per triangle).
    #[getter]
    fn triangle_entities<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        let v: Vec<i64> = self
            .mesh
            .triangles
            .iter()
            .map(|e| e.entity.id as i64)
            .collect();
        v.into_pyarray(py)
    }

    /// The volume id each tetrahedron meshes (int64, one per tetrahedron).
    #[getter]
    fn tetrahedron_entities<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        let v: Vec<i64> = self
            .mesh
            .tetrahedra
            .iter()
            .map(|e| e.entity.id as i64)
            .collect();
        v.into_pyarray(py)
    }

    /// The edge id each line element meshes (int64, one per line).
    #[getter]
    fn line_entities<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        let v: Vec<i64> = self.mesh.lines.iter().map(|e| e.entity.id as i64).collect();
        v.into_pyarray(py)
    }

    /// The name of each meshed entity, by (dim, id): the STEP product or
    /// face name, else e.g. "face 12" (as the .msh physical groups).
    #[getter]
    fn entity_names<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for info in &self.mesh.entities {
            let e = info.entity;
            let kind = ["vertex", "edge", "face", "volume"][e.dim.min(3) as usize];
            let name = info
                .name
                .clone()
                .unwrap_or_else(|| format!("{kind} {}", e.id));
            d.set_item((e.dim, e.id), name)?;
        }
        Ok(d)
    }

    /// Warnings of the run (faces meshed finer than asked, elements the
    /// geometry forces below radius ratio 0.01), as the command line prints
    /// them.
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.warnings.clone()
    }

    /// The spacing the mesh was made with, described.
    #[getter]
    fn spacing_note(&self) -> String {
        self.note.clone()
    }

    /// Writes the mesh to `path`; the format follows the extension as on
    /// the command line: .msh .vtu .stl .obj .mesh, or a picture .svg .png
    /// .html. The file is written whole or not at all.
    #[pyo3(signature = (path, color="quality", view=None, bubbles=false, width=1000))]
    fn write(
        &self,
        py: Python<'_>,
        path: PathBuf,
        color: &str,
        view: Option<(f64, f64, f64)>,
        bubbles: bool,
        width: u32,
    ) -> PyResult<()> {
        let kind = bubblemesh_run::output_kind(&path).map_err(to_py)?;
        let pic = PictureSettings {
            color: color_by(color)?,
            view: view.map(|(x, y, z)| bubblemesh_core::V3::new(x, y, z)),
            bubbles,
            width: width.clamp(64, 20000),
        };
        let q = self.quality_report()?;
        self.guarded(|| {
            py.allow_threads(|| {
                let mut out = OutputSet::new();
                bubblemesh_run::stage_output(
                    &mut out,
                    &self.mesh,
                    &path,
                    kind,
                    &pic,
                    &Drawing {
                        title: &self.title,
                        spacing: self.spacing.as_deref(),
                        quality: q,
                        notes: vec![self.note.clone()],
                    },
                )
                .map_err(to_py)?;
                out.commit()
                    .map_err(|e| to_py(bubblemesh_run::Error::Write(e)))
            })
        })
    }

    /// The quality report as a dict (as `bubblemesh quality --json`):
    /// radius ratios, angles, valence, L/d against the spacing.
    fn quality(&self, py: Python<'_>) -> PyResult<PyObject> {
        let q = self.quality_report()?;
        let text = serde_json::to_string(q).map_err(|e| MeshError::new_err(e.to_string()))?;
        Ok(py.import("json")?.call_method1("loads", (text,))?.unbind())
    }

    /// The quality table the command line prints.
    fn quality_table(&self) -> PyResult<String> {
        Ok(self.quality_report()?.table())
    }

    /// The run's report as a dict (as `bubblemesh mesh --report`, less the
    /// output's entries): counts, timings, energy history, STEP findings,
    /// poor elements, and the quality.
    fn report(&self, py: Python<'_>) -> PyResult<PyObject> {
        let mut r = self.report.clone();
        if let Some(o) = r.as_object_mut() {
            let q = serde_json::to_value(self.quality_report()?)
                .map_err(|e| MeshError::new_err(e.to_string()))?;
            o.insert("quality".to_string(), q);
        }
        let text = serde_json::to_string(&r).map_err(|e| MeshError::new_err(e.to_string()))?;
        Ok(py.import("json")?.call_method1("loads", (text,))?.unbind())
    }

    /// The self-contained HTML viewer page of the mesh (as `-o mesh.html`).
    fn html(&self, py: Python<'_>) -> PyResult<String> {
        let q = self.quality_report()?;
        self.guarded(|| {
            py.allow_threads(|| {
                bubblemesh_run::viewer_page(
                    &self.mesh,
                    &PictureSettings::default(),
                    &Drawing {
                        title: &self.title,
                        spacing: self.spacing.as_deref(),
                        quality: q,
                        notes: vec![self.note.clone()],
                    },
                )
                .map_err(to_py)
            })
        })
    }

    /// The mesh as a `meshio.Mesh` (cells "line", "triangle", "tetra";
    /// cell data "entity": the model entity id of each element). Needs
    /// meshio.
    fn to_meshio(&self, py: Python<'_>) -> PyResult<PyObject> {
        let meshio = py.import("meshio").map_err(|e| {
            pyo3::exceptions::PyImportError::new_err(format!(
                "Mesh.to_meshio needs meshio (pip install meshio): {e}"
            ))
        })?;
        let cells = PyList::empty(py);
        let entities = PyList::empty(py);
        if !self.mesh.lines.is_empty() {
            cells.append(("line", self.lines(py)))?;
            entities.append(self.line_entities(py))?;
        }
        if !self.mesh.triangles.is_empty() {
            cells.append(("triangle", self.triangles(py)))?;
            entities.append(self.triangle_entities(py))?;
        }
        if !self.mesh.tetrahedra.is_empty() {
            cells.append(("tetra", self.tetrahedra(py)))?;
            entities.append(self.tetrahedron_entities(py))?;
        }
        let cell_data = PyDict::new(py);
        cell_data.set_item("entity", entities)?;
        let kwargs = PyDict::new(py);
        kwargs.set_item("cell_data", cell_data)?;
        Ok(meshio
            .call_method("Mesh", (self.points(py), cells), Some(&kwargs))?
            .unbind())
    }

    /// The HTML viewer inline (Jupyter): the viewer page in an iframe.
    fn _repr_html_(&self, py: Python<'_>) -> PyResult<String> {
        let page = self.html(py)?;
        let escaped = page.replace('&', "&amp;").replace('"', "&quot;");
        Ok(format!(
            "<iframe srcdoc=\"{escaped}\" style=\"width:100%;height:640px;border:1px solid #ddd\" \
             sandbox=\"allow-scripts\"></iframe>"
        ))
    }

    fn __repr__(&self) -> String {
        format!(
            "<bubblemesh.Mesh of {}: {} nodes, {} lines, {} triangles, {} tetrahedra>",
            self.title,
            self.mesh.nodes.len(),
            self.mesh.lines.len(),
            self.mesh.triangles.len(),
            self.mesh.tetrahedra.len()
        )
    }
}

/// Reads a mesh file (.msh .vtu .stl .obj .mesh) into a `Mesh`.
#[pyfunction]
pub(crate) fn read(py: Python<'_>, path: PathBuf) -> PyResult<Mesh> {
    let (mesh, notes) = py
        .allow_threads(|| bubblemesh_io::read_with_notes(&path))
        .map_err(|e| to_py(e.into()))?;
    Ok(Mesh {
        mesh,
        spacing: None,
        run: Arc::new(Run::default()),
        title: path.display().to_string(),
        note: String::new(),
        report: serde_json::json!({}),
        warnings: notes
            .into_iter()
            .map(|n| format!("warning: {}: {n}", path.display()))
            .collect(),
        quality: OnceLock::new(),
    })
}
