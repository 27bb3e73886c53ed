//! The layout rules of `core/src` (docs/architecture.md), checked on the
//! source text so that a change that breaks one fails here:
//!
//! - no import cycle among core's modules (a file-level module graph built
//!   from `use crate::…`, `use super::…` and inline `crate::…` paths, test
//!   modules excluded);
//! - the low rooms never import the high ones: `bubbles/` knows nothing of
//!   `edge/`, `face/`, `volume/` or `engine/`; only `engine/` imports
//!   `engine/`;
//! - no function in `core/src` is longer than 150 lines unless its doc
//!   comment says why it is long;
//! - the tetrahedron face table is written once in the workspace's Rust
//!   (the viewer's JavaScript in `viz/src/html.rs` keeps its own copy, which
//!   viz's tests compare with `measure`'s).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

const MAX_FN_LINES: usize = 150;

fn src_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<_> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// The module path of a file under `src`: `lib.rs` → [], `a.rs` and
/// `a/mod.rs` → [a], `a/b.rs` → [a, b].
fn module_of(src: &Path, file: &Path) -> Vec<String> {
    let rel = file.strip_prefix(src).unwrap();
    let mut parts: Vec<String> = rel
        .iter()
        .map(|s| s.to_string_lossy().into_owned())
        .collect();
    let last = parts.pop().unwrap();
    match last.as_str() {
        "lib.rs" | "mod.rs" => {}
        f => parts.push(f.trim_end_matches(".rs").to_string()),
    }
    parts
}

/// The file's code without its test module and without comments (line
/// comments, doc comments); string literals are kept, which is harmless for
/// what is searched here.
fn code_of(text: &str) -> String {
    let body = match text.find("#[cfg(test)]") {
        Some(i) => &text[..i],
        None => text,
    };
    body.lines()
        .map(|l| match l.find("//") {
            Some(i) => &l[..i],
            None => l,
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// Expands one `use` tree (`a::{b, c::{d, e}}`) into full paths.
fn expand_use(tree: &str) -> Vec<String> {
    let tree: String = tree.chars().filter(|c| !c.is_whitespace()).collect();
    fn go(prefix: &str, t: &str, out: &mut Vec<String>) {
        if let Some(open) = t.find('{') {
            let head = &t[..open];
            let inner = &t[open + 1..t.len() - 1];
            let mut depth = 0;
            let mut start = 0;
            for (i, c) in inner.char_indices() {
                match c {
                    '{' => depth += 1,
                    '}' => depth -= 1,
                    ',' if depth == 0 => {
                        go(&format!("{prefix}{head}"), &inner[start..i], out);
                        start = i + 1;
                    }
                    _ => {}
                }
            }
            if start < inner.len() {
                go(&format!("{prefix}{head}"), &inner[start..], out);
            }
        } else if !t.is_empty() {
            let t = t.split(" as ").next().unwrap();
            out.push(format!("{prefix}{t}"));
        }
    }
    let mut out = Vec::new();
    go("", &tree, &mut out);
    out
}

/// Every path the code names that starts at `crate`, `super` or `self`.
fn paths_in(code: &str) -> Vec<String> {
    let mut out = Vec::new();
    // use statements (may span lines and hold brace trees)
    let mut rest = code;
    while let Some(i) = rest.find("use ") {
        let before = rest[..i].chars().last();
        let stmt_start = i + 4;
        let end = rest[stmt_start..].find(';').map(|e| stmt_start + e);
        let boundary = before.is_none_or(|c| !(c.is_alphanumeric() || c == '_'));
        if let (true, Some(end)) = (boundary, end) {
            let stmt = &rest[stmt_start..end];
            if stmt.starts_with("crate::")
                || stmt.starts_with("super::")
                || stmt.starts_with("self::")
            {
                out.extend(expand_use(stmt));
            }
            rest = &rest[end..];
        } else {
            rest = &rest[stmt_start..];
        }
    }
    // inline paths: crate::a::b, super::a
    for key in ["crate::", "super::"] {
        out.extend(paths_starting(code, key));
    }
    out
}

/// Every whole path in `code` that starts with `key` (`crate::`, `tet::`),
/// without a trailing `::`: `key` must not continue an identifier or path.
fn paths_starting(code: &str, key: &str) -> Vec<String> {
    let bytes = code.as_bytes();
    let in_path = |b: u8| b.is_ascii_alphanumeric() || b == b'_' || b == b':';
    let mut out = Vec::new();
    let mut from = 0;
    while let Some(i) = code[from..].find(key) {
        let s = from + i;
        let mut e = s;
        while e < bytes.len() && in_path(bytes[e]) {
            e += 1;
        }
        if s == 0 || !in_path(bytes[s - 1]) {
            out.push(code[s..e].trim_end_matches(':').to_string());
        }
        from = e.max(s + key.len());
    }
    out
}

/// Paths that start at a child module of `here` (`tet::odt::smooth` in
/// `volume/mod.rs`), written as `self::…`.
fn child_paths(code: &str, here: &[String], modules: &BTreeSet<Vec<String>>) -> Vec<String> {
    modules
        .iter()
        .filter(|m| m.len() == here.len() + 1 && m[..here.len()] == *here)
        .flat_map(|m| paths_starting(code, &format!("{}::", m.last().unwrap())))
        .map(|p| format!("self::{p}"))
        .collect()
}

/// The module a path points into: the longest prefix that is a module.
fn resolve(
    path: &str,
    here: &[String],
    modules: &BTreeSet<Vec<String>>,
    is_mod_file: bool,
) -> Option<Vec<String>> {
    let mut segs: Vec<&str> = path.split("::").collect();
    let mut base: Vec<String> = match segs.first().copied() {
        Some("crate") => {
            segs.remove(0);
            vec![]
        }
        Some("self") => {
            segs.remove(0);
            // `self` in a.rs or a/mod.rs is module a
            here.to_vec()
        }
        Some("super") => {
            let mut b = here.to_vec();
            while segs.first() == Some(&"super") {
                segs.remove(0);
                b.pop();
            }
            let _ = is_mod_file;
            b
        }
        _ => return None,
    };
    let mut best = base.clone();
    for s in segs {
        base.push(s.to_string());
        if modules.contains(&base) {
            best = base.clone();
        } else {
            break;
        }
    }
    Some(best)
}

fn graph() -> BTreeMap<Vec<String>, BTreeSet<Vec<String>>> {
    let src = src_dir();
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let modules: BTreeSet<Vec<String>> = files.iter().map(|f| module_of(&src, f)).collect();
    let mut g: BTreeMap<Vec<String>, BTreeSet<Vec<String>>> = BTreeMap::new();
    for f in &files {
        let here = module_of(&src, f);
        let code = code_of(&std::fs::read_to_string(f).unwrap());
        let is_mod = f
            .file_name()
            .is_some_and(|n| n == "mod.rs" || n == "lib.rs");
        let deps = g.entry(here.clone()).or_default();
        for p in paths_in(&code)
            .into_iter()
            .chain(child_paths(&code, &here, &modules))
        {
            if let Some(m) = resolve(&p, &here, &modules, is_mod) {
                // the crate root only re-exports; a module's own items are no arrow
                if !m.is_empty() && m != here {
                    deps.insert(m);
                }
            }
        }
    }
    g
}

fn name(m: &[String]) -> String {
    if m.is_empty() {
        "crate".into()
    } else {
        m.join("::")
    }
}

/// Strongly connected components with more than one module (Tarjan).
fn cycles(g: &BTreeMap<Vec<String>, BTreeSet<Vec<String>>>) -> Vec<Vec<String>> {
    struct Tarjan<'a> {
        g: &'a BTreeMap<Vec<String>, BTreeSet<Vec<String>>>,
        nodes: Vec<&'a Vec<String>>,
        idx: BTreeMap<&'a Vec<String>, usize>,
        index: Vec<usize>,
        low: Vec<usize>,
        on_stack: Vec<bool>,
        stack: Vec<usize>,
        next: usize,
        out: Vec<Vec<String>>,
    }
    impl Tarjan<'_> {
        fn visit(&mut self, v: usize) {
            self.index[v] = self.next;
            self.low[v] = self.next;
            self.next += 1;
            self.stack.push(v);
            self.on_stack[v] = true;
            let deps: Vec<usize> = self.g[self.nodes[v]]
                .iter()
                .filter_map(|w| self.idx.get(w).copied())
                .collect();
            for w in deps {
                if self.index[w] == usize::MAX {
                    self.visit(w);
                    self.low[v] = self.low[v].min(self.low[w]);
                } else if self.on_stack[w] {
                    self.low[v] = self.low[v].min(self.index[w]);
                }
            }
            if self.low[v] == self.index[v] {
                let mut comp = Vec::new();
                loop {
                    let w = self.stack.pop().unwrap();
                    self.on_stack[w] = false;
                    comp.push(name(self.nodes[w]));
                    if w == v {
                        break;
                    }
                }
                if comp.len() > 1 {
                    comp.sort();
                    self.out.push(comp);
                }
            }
        }
    }
    let nodes: Vec<&Vec<String>> = g.keys().collect();
    let n = nodes.len();
    let idx = nodes.iter().enumerate().map(|(i, m)| (*m, i)).collect();
    let mut t = Tarjan {
        g,
        nodes,
        idx,
        index: vec![usize::MAX; n],
        low: vec![0; n],
        on_stack: vec![false; n],
        stack: Vec::new(),
        next: 0,
        out: Vec::new(),
    };
    for v in 0..n {
        if t.index[v] == usize::MAX {
            t.visit(v);
        }
    }
    t.out
}

#[test]
fn no_import_cycle_among_core_modules() {
    let g = graph();
    assert!(
        g.len() > 20,
        "only {} modules found in {}",
        g.len(),
        src_dir().display()
    );
    let c = cycles(&g);
    assert!(c.is_empty(), "import cycles among core's modules: {c:?}");
}

#[test]
fn low_rooms_do_not_import_high_ones() {
    let g = graph();
    let room = |m: &[String]| m.first().cloned().unwrap_or_default();
    let rank = |r: &str| match r {
        "bubbles" => 1,
        "edge" | "face" => 2,
        "volume" => 3,
        "engine" => 4,
        _ => 0,
    };
    let mut bad = Vec::new();
    for (m, deps) in &g {
        let from = room(m);
        for d in deps {
            let to = room(d);
            let uphill = rank(&to) > rank(&from) && rank(&from) > 0;
            // a foundation module (geom, spacing, …) must not reach into the
            // engine's rooms; the crate root only re-exports
            let foundation_up = !m.is_empty() && rank(&from) == 0 && rank(&to) >= 2;
            if uphill || foundation_up {
                bad.push(format!("{} -> {}", name(m), name(d)));
            }
        }
    }
    assert!(bad.is_empty(), "imports running uphill: {bad:#?}");
}

/// `(name, first line, lines, doc)` of every `fn` with a body in `text`.
fn functions(text: &str) -> Vec<(String, usize, usize, String)> {
    let lines: Vec<&str> = text.lines().collect();
    let mut out = Vec::new();
    for (i, l) in lines.iter().enumerate() {
        let t = l.trim_start();
        let t = t
            .trim_start_matches("pub(crate) ")
            .trim_start_matches("pub(super) ")
            .trim_start_matches("pub ")
            .trim_start_matches("const ")
            .trim_start_matches("unsafe ");
        let Some(rest) = t.strip_prefix("fn ") else {
            continue;
        };
        let name: String = rest
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect();
        // find the opening brace of the body, then its match
        let mut depth = 0i64;
        let mut opened = false;
        let mut parens = 0i64;
        let mut end = None;
        'scan: for (j, lj) in lines.iter().enumerate().skip(i) {
            let code = match lj.find("//") {
                Some(k) => &lj[..k],
                None => lj,
            };
            let mut in_str = false;
            let mut prev = ' ';
            for c in code.chars() {
                if c == '"' && prev != '\\' {
                    in_str = !in_str;
                }
                if !in_str {
                    match c {
                        '(' | '[' => parens += 1,
                        ')' | ']' => parens -= 1,
                        _ => {}
                    }
                    if c == ';' && !opened && depth == 0 && parens == 0 {
                        break 'scan; // a declaration without a body
                    }
                    if c == '{' {
                        depth += 1;
                        opened = true;
                    } else if c == '}' {
                        depth -= 1;
                        if opened && depth == 0 {
                            end = Some(j);
                            break 'scan;
                        }
                    }
                }
                prev = c;
            }
        }
        let Some(end) = end else { continue };
        let mut doc = Vec::new();
        let mut k = i;
        while k > 0 {
            let p = lines[k - 1].trim_start();
            if p.starts_with("///") {
                doc.push(p.trim_start_matches('/').trim());
            } else if !p.starts_with("#[") {
                break;
            }
            k -= 1;
        }
        doc.reverse();
        out.push((name, i + 1, end - i + 1, doc.join(" ")));
    }
    out
}

#[test]
fn no_long_function_without_a_reason() {
    let src = src_dir();
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let mut long = Vec::new();
    for f in &files {
        let text = std::fs::read_to_string(f).unwrap();
        for (name, line, n, doc) in functions(&text) {
            if n > MAX_FN_LINES && !doc.to_lowercase().contains("long") {
                long.push(format!(
                    "{}:{line} fn {name}: {n} lines",
                    f.strip_prefix(&src).unwrap().display()
                ));
            }
        }
    }
    assert!(
        long.is_empty(),
        "functions over {MAX_FN_LINES} lines whose doc does not say why they are long: {long:#?}"
    );
}

#[test]
fn function_scanner_measures_a_known_function() {
    let text = "/// Short.\nfn a() {\n    let s = \"}\";\n}\n\n/// Long: because.\npub(crate) fn b(x: u8) -> u8 {\n    x\n}\n";
    let f = functions(text);
    assert_eq!(f.len(), 2);
    assert_eq!((f[0].0.as_str(), f[0].2), ("a", 3));
    assert_eq!(
        (f[1].0.as_str(), f[1].2, f[1].3.as_str()),
        ("b", 3, "Long: because.")
    );
}

#[test]
fn import_scanner_sees_use_trees_and_inline_paths() {
    let code = "use crate::bubbles::{dynamics, grid::Grid};\nuse super::x as y;\nfn f() { crate::volume::tet::sliver::objective(); }";
    let p = paths_in(code);
    for want in [
        "crate::bubbles::dynamics",
        "crate::bubbles::grid::Grid",
        "super::x",
        "crate::volume::tet::sliver::objective",
    ] {
        assert!(p.iter().any(|x| x == want), "{want} not in {p:?}");
    }
    let here = vec!["volume".to_string()];
    let modules: BTreeSet<Vec<String>> = [here.clone(), vec!["volume".into(), "tet".into()]].into();
    let c = child_paths("x = tet::odt::smooth(); y = mytet::z;", &here, &modules);
    assert_eq!(c, vec!["self::tet::odt::smooth".to_string()]);
}

#[test]
fn the_tetrahedron_face_table_is_written_once() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf();
    let mut files = Vec::new();
    for dir in [
        "core/src",
        "io/src",
        "viz/src",
        "delaunay/src",
        "cli/src",
        "capi/src",
    ] {
        let d = root.join(dir);
        if d.is_dir() {
            rust_files(&d, &mut files);
        }
    }
    let hits: Vec<String> = files
        .iter()
        .filter(|f| !f.ends_with("viz/src/html.rs"))
        .filter(|f| {
            let t: String = std::fs::read_to_string(f)
                .unwrap()
                .chars()
                .filter(|c| !c.is_whitespace())
                .collect();
            t.contains("[1,2,3],[0,3,2]")
        })
        .map(|f| f.strip_prefix(&root).unwrap().display().to_string())
        .collect();
    assert_eq!(
        hits.len(),
        1,
        "the face table [[1,2,3],[0,3,2],…] is written in: {hits:?}"
    );
}
