//! A template spacing plugin: copy this crate, rename it, change
//! `RadialSpacing`. Built with `cargo build --release`, it gives
//! `target/release/lib<crate_name>.so`; use it with
//!
//! ```text
//! bubblemesh mesh domain.toml -o out.msh --plugin path/to/libmy_plugin.so \
//!     --plugin-arg center=0.5,0.5,0 --plugin-arg d0=0.01 --plugin-arg growth=0.2
//! ```
//!
//! This one grows the spacing linearly with the distance from a centre:
//! d(x) = d0 + growth · |x − center|.
//!
//! Arguments:
//! - `center` (default `0,0,0`): model units, `x,y,z`;
//! - `d0` (required, > 0): the spacing at the centre (model units);
//! - `growth` (default 0, ≥ 0): spacing added per unit of distance.

use bubblemesh_plugin_api::{export_plugin, Args, BmQuery, InitInfo, SpacingPlugin};

/// The plugin's state: made once by `init`, then only read (`&self`), which
/// is what lets the host call `spacing` from several threads at once.
pub struct RadialSpacing {
    center: [f64; 3],
    d0: f64,
    growth: f64,
}

impl SpacingPlugin for RadialSpacing {
    /// Reads and checks the `key=value` arguments. An `Err(message)` is
    /// shown to the user with the plugin's path.
    fn init(_info: &InitInfo, args: &Args) -> Result<Self, String> {
        args.check_known(&["center", "d0", "growth"])?;
        let center = args.vec3("center")?.unwrap_or([0.0; 3]);
        let d0 = args
            .positive("d0")?
            .ok_or("argument d0 (> 0) is required")?;
        let growth = args.f64("growth")?.unwrap_or(0.0);
        if growth < 0.0 {
            return Err(format!("argument growth={growth}: must be >= 0"));
        }
        Ok(RadialSpacing { center, d0, growth })
    }

    /// Many points per call: write `out[i]` for `queries[i]`. Each query
    /// also carries the entity (`dim`, `id`), its parameters and the local
    /// geometry (`tangent`, `normal`, `k1`, `k2`, ...; see `BmQuery`).
    /// Every value must be finite and > 0 (the host checks). A panic here is
    /// caught and reported; so is an `Err`.
    fn spacing(&self, queries: &[BmQuery], out: &mut [f64]) -> Result<(), String> {
        for (q, o) in queries.iter().zip(out.iter_mut()) {
            let r = (0..3)
                .map(|k| (q.point[k] - self.center[k]).powi(2))
                .sum::<f64>()
                .sqrt();
            *o = self.d0 + self.growth * r;
        }
        Ok(())
    }
}

// Defines the exported symbol `bubblemesh_plugin_entry` and the C functions
// of the table (name, one-line description with the arguments).
export_plugin!(
    RadialSpacing,
    "template-radial",
    "d = d0 + growth*|x - center|; args: center=x,y,z, d0, growth"
);
