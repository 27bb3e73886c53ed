//! Curvature-based spacing as a plugin (thesis §4.6): the same d as the
//! built-in `--curvature EPS` (`bubblemesh_core::curvature::Curvature`),
//! computed from the local geometry the host sends.
//!
//! A chord of length d on a circle of radius ρ deviates from the arc by
//! ε = ρ − √(ρ² − d²/4) (eq. 4.6.1), so d = 2√(2ερ − ε²) (eq. 5.1.1), with
//! ρ = 1/max(|κ1|, |κ2|) on a surface (eq. 5.1.2) and 1/κ on a curve. The
//! spacing asked for is that of triangles, not chords, with the packing's
//! margin ([`bubblemesh_core::curvature::triangle_spacing`]): meshes stay
//! within ε of the geometry.
//!
//! Arguments (model units):
//! - `eps` (required): allowed distance from the mesh to the geometry;
//! - `d_min` (default `eps`): the smallest spacing (where ρ ≤ ε/2);
//! - `d_max` (default 1/10 of the model's bounding-box diagonal): the
//!   spacing on flat parts.
//!
//! On an edge or vertex κ is the largest of the curve's curvature and the
//! principal curvatures of the faces around it (the host sends them). At a
//! face point whose curvature the host could not compute (a singular point
//! whose neighbourhood is singular too) the spacing is `d_min`.

use bubblemesh_core::curvature::triangle_spacing;
use bubblemesh_plugin_api::{
    export_plugin, Args, BmQuery, InitInfo, SpacingPlugin, BM_GEOM_SURFACE,
};

pub struct CurvatureSpacing {
    pub eps: f64,
    pub d_min: f64,
    pub d_max: f64,
}

impl CurvatureSpacing {
    /// d at one query.
    pub fn at(&self, q: &BmQuery) -> f64 {
        let surface = q.geom & BM_GEOM_SURFACE != 0;
        if q.dim == 2 && !surface {
            return self.d_min;
        }
        let k_surface = if surface { q.k1.abs() } else { 0.0 };
        let kappa = q.curve_curvature.max(k_surface);
        triangle_spacing(kappa, self.eps, self.d_min, self.d_max)
    }
}

impl SpacingPlugin for CurvatureSpacing {
    fn init(info: &InitInfo, args: &Args) -> Result<Self, String> {
        args.check_known(&["eps", "d_min", "d_max"])?;
        let eps = args
            .positive("eps")?
            .ok_or("argument eps is required (the allowed distance to the geometry)")?;
        let d_min = args.positive("d_min")?.unwrap_or(eps);
        let d_max = match args.positive("d_max")? {
            Some(d) => d,
            None if info.model_size > 0.0 => (info.model_size / 10.0).max(d_min),
            None => return Err("argument d_max is required (the model has no size)".into()),
        };
        if d_min > d_max {
            return Err(format!("d_min {d_min} is larger than d_max {d_max}"));
        }
        Ok(CurvatureSpacing { eps, d_min, d_max })
    }

    fn spacing(&self, queries: &[BmQuery], out: &mut [f64]) -> Result<(), String> {
        for (q, o) in queries.iter().zip(out.iter_mut()) {
            *o = self.at(q);
        }
        Ok(())
    }
}

export_plugin!(
    CurvatureSpacing,
    "curvature",
    "curvature-based spacing (thesis eq. 4.6.1/5.1.1/5.1.2): triangles within eps of the geometry; args: eps (required), d_min (default eps), d_max (default diagonal/10)"
);
