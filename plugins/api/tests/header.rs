//! The committed C header plugins/c-example/bubblemesh_plugin.h must be what
//! cbindgen generates from src/lib.rs now: this test fails when it is stale.
//! `BM_UPDATE_HEADER=1 cargo test -p bubblemesh-plugin-api --test header`
//! rewrites it. (That the C compiler sees the same layout as Rust is checked
//! by plugins/host/tests/c_plugin.rs, which compiles C against it.)

use std::path::Path;

#[test]
fn committed_header_is_up_to_date() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let config = cbindgen::Config::from_file(dir.join("cbindgen.toml")).expect("cbindgen.toml");
    let bindings = cbindgen::Builder::new()
        .with_crate(dir)
        .with_config(config)
        .generate()
        .expect("cbindgen could not generate the header");
    let mut fresh = Vec::new();
    bindings.write(&mut fresh);
    let fresh = String::from_utf8(fresh).unwrap();
    let path = dir.join("../c-example/bubblemesh_plugin.h");
    let committed = std::fs::read_to_string(&path).unwrap_or_default();
    if std::env::var_os("BM_UPDATE_HEADER").is_some() {
        if committed != fresh {
            std::fs::write(&path, &fresh).unwrap();
            eprintln!("rewrote {}", path.display());
        }
        return;
    }
    assert!(
        committed == fresh,
        "{} is stale: plugins/api/src/lib.rs changed the ABI. Regenerate it with\n  \
         BM_UPDATE_HEADER=1 cargo test -p bubblemesh-plugin-api --test header\nand commit it.",
        path.display()
    );
    for item in [
        "BmPlugin",
        "BmQuery",
        "BmInitInfo",
        "BM_PLUGIN_ABI_VERSION",
        "BmPluginEntryFn",
    ] {
        assert!(fresh.contains(item), "{item} missing from the header");
    }
}
