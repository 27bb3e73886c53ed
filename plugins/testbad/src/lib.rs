//! Test only: a plugin that misbehaves as its argument `mode` says, so the
//! host's tests can check that each misbehaviour gives a clear error and no
//! crash.
//!
//! `mode`: `ok`, `panic` (panics in spacing), `panic_init`, `nan`, `zero`,
//! `negative`, `inf`, `fail` (returns an error). `d` (default 0.1): the
//! good value; `after` (default 0): the first `after` points answered (over
//! all calls) get the good value, so a failure can come mid-meshing.

use std::sync::atomic::{AtomicUsize, Ordering};

use bubblemesh_plugin_api::{export_plugin, Args, BmQuery, InitInfo, SpacingPlugin};

pub struct Bad {
    mode: String,
    d: f64,
    after: usize,
    calls: AtomicUsize,
}

impl SpacingPlugin for Bad {
    fn init(_info: &InitInfo, args: &Args) -> Result<Self, String> {
        args.check_known(&["mode", "d", "after"])?;
        let mode = args.str("mode").unwrap_or("ok").to_string();
        if mode == "panic_init" {
            panic!("testbad: deliberate panic in init");
        }
        let known = ["ok", "panic", "nan", "zero", "negative", "inf", "fail"];
        if !known.contains(&mode.as_str()) {
            return Err(format!(
                "unknown mode '{mode}' (known: {})",
                known.join(", ")
            ));
        }
        Ok(Bad {
            mode,
            d: args.positive("d")?.unwrap_or(0.1),
            after: args.f64("after")?.unwrap_or(0.0) as usize,
            calls: AtomicUsize::new(0),
        })
    }

    fn spacing(&self, queries: &[BmQuery], out: &mut [f64]) -> Result<(), String> {
        let seen = self.calls.fetch_add(queries.len(), Ordering::Relaxed);
        for (i, o) in out.iter_mut().enumerate() {
            *o = self.d;
            if seen + i < self.after {
                continue;
            }
            *o = match self.mode.as_str() {
                "panic" => panic!("testbad: deliberate panic in spacing"),
                "nan" => f64::NAN,
                "zero" => 0.0,
                "negative" => -self.d,
                "inf" => f64::INFINITY,
                "fail" => return Err("testbad: deliberate failure".into()),
                _ => self.d,
            };
        }
        Ok(())
    }
}

export_plugin!(Bad, "testbad", "test only: misbehaves as mode= says");
