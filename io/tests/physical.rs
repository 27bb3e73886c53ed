//! MSH physical groups: one per entity with elements, tag = entity tag,
//! named after the entity's model name (else `volume N`, `face N`, ...),
//! checked in the file's text, by our reader, by meshio and by Gmsh.
//!
//! meshio: skipped with a printed reason when python3 or meshio is missing,
//! except with `CI` set, where it must be there (`.ci/requirements.txt`).
//! Gmsh: runs only when its Python module is importable and skips with a
//! printed reason otherwise, in CI too.

mod common;

use std::path::Path;
use std::process::Command;

use bubblemesh_core::mesh::{EntityInfo, Mesh};
use bubblemesh_core::model::EntityRef;
use bubblemesh_io::{msh, read, write};
use common::{python_has, sample_mesh};

const BRACKET: &str = "bracket (2/bracket)";
/// A double quote, a backslash and non-ASCII letters.
const PLATE: &str = "Träger \"Ø12\" \\ Größe";
/// What the file says for PLATE: `"` → `'`, `\` → `/`.
const PLATE_WRITTEN: &str = "Träger 'Ø12' / Größe";

/// The sample cube with its 6 tetrahedra in two named volumes (3 each),
/// faces, edges and points unnamed, and one face without elements.
fn two_volumes() -> Mesh {
    let mut m = sample_mesh();
    for (k, t) in m.tetrahedra.iter_mut().enumerate() {
        t.entity = EntityRef::new(3, (k / 3) as u32);
    }
    for e in &mut m.entities {
        e.name = None;
        if e.entity == EntityRef::new(3, 0) {
            e.name = Some(BRACKET.into());
        }
    }
    m.entities.push(EntityInfo {
        entity: EntityRef::new(3, 1),
        boundary: vec![],
        name: Some(PLATE.into()),
    });
    // Face 2 (tag 2): in the entity table, no elements.
    m.entities.push(EntityInfo {
        entity: EntityRef::new(2, 1),
        boundary: vec![],
        name: Some("empty".into()),
    });
    m
}

fn written(m: &Mesh) -> (tempfile::TempDir, std::path::PathBuf, String) {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("two.msh");
    write(m, &p).unwrap();
    let text = std::fs::read_to_string(&p).unwrap();
    (dir, p, text)
}

/// The lines between `$name` and `$Endname`.
fn section<'a>(text: &'a str, name: &str) -> Vec<&'a str> {
    let start = format!("${name}");
    let end = format!("$End{name}");
    text.lines()
        .skip_while(|l| *l != start)
        .skip(1)
        .take_while(|l| *l != end)
        .collect()
}

#[test]
fn physical_names_and_entity_tags_are_written() {
    let (_d, _p, text) = written(&two_volumes());
    // Placement: after $MeshFormat, before $Entities.
    let names_at = text
        .find("$PhysicalNames\n")
        .expect("a $PhysicalNames section");
    assert!(text.find("$EndMeshFormat").unwrap() < names_at);
    assert!(names_at < text.find("$Entities").unwrap());
    // One group per entity with elements: 4 points, 4 edges, face 1,
    // volumes 1 and 2; face 2 has no elements, so no group.
    let want = format!(
        "11\n0 1 \"point 1\"\n0 2 \"point 2\"\n0 3 \"point 3\"\n0 4 \"point 4\"\n\
         1 1 \"edge 1\"\n1 2 \"edge 2\"\n1 3 \"edge 3\"\n1 4 \"edge 4\"\n\
         2 1 \"face 1\"\n3 1 \"{BRACKET}\"\n3 2 \"{PLATE_WRITTEN}\""
    );
    assert_eq!(section(&text, "PhysicalNames").join("\n"), want);
    // $Entities: every entity carries its own tag as its physical tag
    // (numPhysicalTags 1, tag), the element-less face none.
    let ent = section(&text, "Entities");
    assert_eq!(ent[0], "4 4 2 2");
    for (k, l) in ent[1..5].iter().enumerate() {
        let t: Vec<&str> = l.split(' ').collect();
        assert_eq!(t.len(), 6, "{l}");
        assert_eq!(
            (t[0], t[4], t[5]),
            (&*format!("{}", k + 1), "1", t[0]),
            "{l}"
        );
    }
    for l in &ent[5..] {
        let t: Vec<&str> = l.split(' ').collect();
        if l.starts_with("2 ") && t.len() > 7 && t[7] == "0" {
            continue; // face 2
        }
        assert_eq!((t[7], t[8]), ("1", t[0]), "{l}");
    }
    assert!(
        ent.iter()
            .any(|l| l.starts_with("2 ") && l.split(' ').nth(7) == Some("0")),
        "face 2 has no physical tag: {ent:?}"
    );
}

#[test]
fn names_read_back() {
    let m = two_volumes();
    let (_d, p, _) = written(&m);
    let back = read(&p).unwrap();
    let name = |dim, id| {
        back.entities
            .iter()
            .find(|e| e.entity == EntityRef::new(dim, id))
            .unwrap_or_else(|| panic!("entity {dim} {id}"))
            .name
            .clone()
    };
    assert_eq!(name(3, 0).as_deref(), Some(BRACKET));
    assert_eq!(name(3, 1).as_deref(), Some(PLATE_WRITTEN));
    // Defaults read back as no name; no group, no name.
    assert_eq!(name(2, 0), None);
    assert_eq!(name(1, 2), None);
    assert_eq!(name(0, 3), None);
    assert_eq!(name(2, 1), None);
    // Written again: the same file.
    let again = tempfile::tempdir().unwrap();
    let q = again.path().join("again.msh");
    write(&back, &q).unwrap();
    assert_eq!(
        section(&std::fs::read_to_string(&q).unwrap(), "PhysicalNames"),
        section(&std::fs::read_to_string(&p).unwrap(), "PhysicalNames")
    );
}

/// A Gmsh-written 4.1 file: a group spanning several entities names each
/// of them; entities outside any group stay unnamed. (The 2.2 file's
/// elements all have physical tag 0, no group: nothing is named.)
#[test]
fn gmsh_physical_names_are_read() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    let v22 = read(&data.join("gmsh_cube_v22.msh")).unwrap();
    assert!(v22.entities.iter().all(|e| e.name.is_none()));
    {
        let f = "gmsh_cube_v41.msh";
        let m = read(&data.join(f)).unwrap();
        let named = |name: &str| {
            let mut v: Vec<EntityRef> = m
                .entities
                .iter()
                .filter(|e| e.name.as_deref() == Some(name))
                .map(|e| e.entity)
                .collect();
            v.sort();
            v
        };
        assert_eq!(
            named("walls"),
            vec![EntityRef::new(2, 0), EntityRef::new(2, 1)],
            "{f}"
        );
        assert_eq!(named("solid"), vec![EntityRef::new(3, 0)], "{f}");
        assert_eq!(m.entities.iter().filter(|e| e.name.is_some()).count(), 3);
    }
}

/// Handwritten Gmsh-style text: quoted names with spaces, a group over two
/// curves, a point entity with a physical tag, a malformed name line
/// skipped.
#[test]
fn handwritten_physical_names() {
    let text = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n\
        $PhysicalNames\n4\n0 9 \"tip\"\n1 5 \"two edges\"\n2 3 \"Fläche \"A\"\"\nbad line\n\
        $EndPhysicalNames\n\
        $Entities\n1 2 1 0\n\
        1 0 0 0 1 9\n\
        1 0 0 0 1 0 0 1 5 2 1 -1\n\
        2 0 0 0 1 1 0 1 5 0\n\
        1 0 0 0 1 1 0 2 4 3 0\n\
        $EndEntities\n\
        $Nodes\n1 3 1 3\n2 1 0 3\n1\n2\n3\n0 0 0\n1 0 0\n1 1 0\n$EndNodes\n\
        $Elements\n1 1 1 1\n2 1 2 1\n1 1 2 3\n$EndElements\n";
    let m = msh::parse(text.as_bytes()).unwrap();
    let name = |dim, id| {
        m.entities
            .iter()
            .find(|e| e.entity == EntityRef::new(dim, id))
            .and_then(|e| e.name.clone())
    };
    assert_eq!(name(0, 0).as_deref(), Some("tip"));
    assert_eq!(name(1, 0).as_deref(), Some("two edges"));
    assert_eq!(name(1, 1).as_deref(), Some("two edges"));
    assert_eq!(name(2, 0).as_deref(), Some("Fläche \"A\""));

    // MSH 2.2: the first tag of an element is its physical group.
    let text = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n\
        $PhysicalNames\n1\n2 7 \"skin\"\n$EndPhysicalNames\n\
        $Nodes\n3\n1 0 0 0\n2 1 0 0\n3 1 1 0\n$EndNodes\n\
        $Elements\n2\n1 2 2 7 4 1 2 3\n2 1 2 0 1 1 2\n$EndElements\n";
    let m = msh::parse(text.as_bytes()).unwrap();
    let names: Vec<(EntityRef, Option<&str>)> = m
        .entities
        .iter()
        .filter(|e| e.entity.dim > 0)
        .map(|e| (e.entity, e.name.as_deref()))
        .collect();
    assert_eq!(
        names,
        vec![
            (EntityRef::new(1, 0), None),
            (EntityRef::new(2, 3), Some("skin"))
        ]
    );
}

fn run_python(script: &str, path: &Path) -> String {
    let out = Command::new("python3")
        .arg("-c")
        .arg(script)
        .arg(path)
        .output()
        .expect("python3 runs");
    let stdout = String::from_utf8_lossy(&out.stdout).to_string();
    assert!(
        out.status.success(),
        "python failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
        .lines()
        .filter_map(|l| l.strip_prefix('@'))
        .map(|l| format!("{l}\n"))
        .collect()
}

/// Per cell block: type, physical tags, geometrical tags; then the field
/// data (name → tag, dim) sorted by dimension and tag.
const MESHIO: &str = r#"
import sys, logging
logging.disable(logging.WARNING)
import meshio
m = meshio.read(sys.argv[1])
phys, geo = m.cell_data["gmsh:physical"], m.cell_data["gmsh:geometrical"]
for b, p, g in zip(m.cells, phys, geo):
    print("@%s %s %s" % (b.type, sorted(set(int(x) for x in p)), sorted(set(int(x) for x in g))))
for name, (tag, dim) in sorted(m.field_data.items(), key=lambda kv: (int(kv[1][1]), int(kv[1][0]))):
    print("@%d %d %s" % (dim, tag, name))
"#;

#[test]
fn meshio_reads_physical_groups() {
    if !python_has("meshio") {
        if std::env::var_os("CI").is_some() {
            panic!("python3 with meshio is not available, and CI is set (.ci/requirements.txt)");
        }
        eprintln!("skipped: python3 with meshio is not available");
        return;
    }
    let (_d, p, _) = written(&two_volumes());
    let got = run_python(MESHIO, &p);
    let mut want = String::new();
    for t in 1..=4 {
        want += &format!("vertex [{t}] [{t}]\n");
    }
    for t in 1..=4 {
        want += &format!("line [{t}] [{t}]\n");
    }
    want += "triangle [1] [1]\ntetra [1] [1]\ntetra [2] [2]\n";
    for t in 1..=4 {
        want += &format!("0 {t} point {t}\n");
    }
    for t in 1..=4 {
        want += &format!("1 {t} edge {t}\n");
    }
    want += &format!("2 1 face 1\n3 1 {BRACKET}\n3 2 {PLATE_WRITTEN}\n");
    assert_eq!(got, want);
}

/// Physical groups with their names as Gmsh reads them.
const GMSH: &str = r#"
import sys, gmsh
gmsh.initialize(["-v", "0"])
gmsh.option.setNumber("General.Terminal", 0)
gmsh.open(sys.argv[1])
for d, t in gmsh.model.getPhysicalGroups():
    ents = [int(e) for e in gmsh.model.getEntitiesForPhysicalGroup(d, t)]
    print("@%d %d %s %s" % (d, t, ents, gmsh.model.getPhysicalName(d, t)))
gmsh.finalize()
"#;

/// Runs only where Gmsh's Python module is importable; skips otherwise,
/// in CI as well (the test does not require Gmsh to be installed).
#[test]
fn gmsh_lists_physical_groups() {
    if !python_has("gmsh") {
        eprintln!("skipped: python3 with gmsh is not available");
        return;
    }
    let (_d, p, _) = written(&two_volumes());
    let got = run_python(GMSH, &p);
    let mut want = String::new();
    for t in 1..=4 {
        want += &format!("0 {t} [{t}] point {t}\n");
    }
    for t in 1..=4 {
        want += &format!("1 {t} [{t}] edge {t}\n");
    }
    want += &format!("2 1 [1] face 1\n3 1 [1] {BRACKET}\n3 2 [2] {PLATE_WRITTEN}\n");
    assert_eq!(got, want);
}
