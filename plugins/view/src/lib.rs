//! View-based spacing as a plugin (thesis §4.6, eq. 4.6.2):
//!
//! d(x) = a · |V0 − x|, clamped to [d_min, d_max],
//!
//! small elements near the viewpoint V0 and large ones far away, so that a
//! perspective picture from V0 shows triangles of nearly equal size. The
//! same as the built-in `--view-spacing X,Y,Z,A`.
//!
//! Arguments:
//! - `viewpoint` (required): V0 as `x,y,z` (model units);
//! - `factor` (required, > 0): a, dimensionless (spacing per unit distance;
//!   the angle an element subtends at V0);
//! - `d_min`, `d_max` (optional, model units): bounds on d (default: none;
//!   d_min must then keep the spacing > 0 at V0 itself).

use bubblemesh_plugin_api::{export_plugin, Args, BmQuery, InitInfo, SpacingPlugin};

pub struct ViewSpacing {
    pub viewpoint: [f64; 3],
    pub factor: f64,
    pub d_min: f64,
    pub d_max: f64,
}

impl SpacingPlugin for ViewSpacing {
    fn init(_info: &InitInfo, args: &Args) -> Result<Self, String> {
        args.check_known(&["viewpoint", "factor", "d_min", "d_max"])?;
        let viewpoint = args
            .vec3("viewpoint")?
            .ok_or("argument viewpoint=x,y,z is required")?;
        let factor = args
            .positive("factor")?
            .ok_or("argument factor (> 0) is required")?;
        let d_min = args.positive("d_min")?.unwrap_or(f64::MIN_POSITIVE);
        let d_max = args.positive("d_max")?.unwrap_or(f64::INFINITY);
        if d_min > d_max {
            return Err(format!("d_min {d_min} is larger than d_max {d_max}"));
        }
        Ok(ViewSpacing {
            viewpoint,
            factor,
            d_min,
            d_max,
        })
    }

    fn spacing(&self, queries: &[BmQuery], out: &mut [f64]) -> Result<(), String> {
        let v = self.viewpoint;
        for (q, o) in queries.iter().zip(out.iter_mut()) {
            let p = q.point;
            let r = ((p[0] - v[0]).powi(2) + (p[1] - v[1]).powi(2) + (p[2] - v[2]).powi(2)).sqrt();
            *o = (self.factor * r).clamp(self.d_min, self.d_max);
        }
        Ok(())
    }
}

export_plugin!(
    ViewSpacing,
    "view",
    "view-based spacing d = factor*|viewpoint - x| (thesis eq. 4.6.2); args: viewpoint=x,y,z, factor, d_min, d_max"
);
