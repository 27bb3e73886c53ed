//! The committed C header must be what cbindgen generates from the sources
//! now: this test fails when it is stale. `BM_UPDATE_HEADER=1 cargo test -p
//! bubblemesh-capi --test header` rewrites it.

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
    let path = dir.join("include/bubblemesh.h");
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
        "{} is stale: the sources changed the C API. Regenerate it with\n  \
         BM_UPDATE_HEADER=1 cargo test -p bubblemesh-capi --test header\nand commit it.",
        path.display()
    );
    // every exported function is declared
    for f in [
        "bm_model_add_curve",
        "bm_mesh_generate",
        "bm_last_error_message",
    ] {
        assert!(fresh.contains(f), "{f} missing from the header");
    }
}
