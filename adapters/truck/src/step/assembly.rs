//! The product structure of a STEP file (ISO 10303-44, AP203/AP214/AP242
//! assemblies): which shape items (solids, shells) are placed where, and
//! under which part's name.
//!
//! A product definition's shape is found through `PRODUCT_DEFINITION_SHAPE`
//! → `SHAPE_DEFINITION_REPRESENTATION` → a representation; representations
//! linked by a plain `SHAPE_REPRESENTATION_RELATIONSHIP` (a
//! `SHAPE_REPRESENTATION` and its `ADVANCED_BREP_SHAPE_REPRESENTATION`)
//! are the same shape. A child of an assembly is a
//! `NEXT_ASSEMBLY_USAGE_OCCURRENCE`; its placement is the
//! `CONTEXT_DEPENDENT_SHAPE_REPRESENTATION` of that occurrence, whose
//! `(REPRESENTATION_RELATIONSHIP REPRESENTATION_RELATIONSHIP_WITH_TRANSFORMATION
//! SHAPE_REPRESENTATION_RELATIONSHIP)` carries an `ITEM_DEFINED_TRANSFORMATION`
//! (child coordinates ↦ parent coordinates = placement₂ ∘ placement₁⁻¹) or
//! a `CARTESIAN_TRANSFORMATION_OPERATOR_3D`. A `MAPPED_ITEM` in a shape
//! places a whole representation (`REPRESENTATION_MAP`) by target ∘
//! origin⁻¹. Placements compose down nested assemblies; a part used twice
//! gives two instances.

use std::collections::{HashMap, HashSet};

use bubblemesh_core::geom::P3;
use bubblemesh_core::model::Model;
use truck_stepio::r#in::ruststep::ast::Parameter;

use super::geometry::{Geo, Placement, Rigid};
use super::table::Table;
use super::StepError;

/// Most instances read from one file (guards against hostile product
/// structures that multiply exponentially).
pub const MAX_INSTANCES: usize = 200_000;
/// Deepest assembly nesting followed (also stops cycles).
const MAX_DEPTH: usize = 64;

/// One placed shape item.
#[derive(Clone, Debug)]
pub(crate) struct Instance {
    /// A `MANIFOLD_SOLID_BREP`, `BREP_WITH_VOIDS`, `SHELL_BASED_SURFACE_MODEL`
    /// or shell.
    pub root: u64,
    /// Part coordinates ↦ world coordinates.
    pub xf: Rigid,
    /// The product's name, with the path of instance names below the top
    /// product when there is one: `nut (rod-assembly_1/nut_2)`; a number
    /// `[k]` added where names would repeat.
    pub name: String,
}

/// Whether `id` is a shape item that becomes model entities.
pub(crate) fn is_shape_root(t: &Table, id: u64) -> bool {
    t.get(id).is_ok_and(|e| {
        e.is("MANIFOLD_SOLID_BREP")
            || e.is("BREP_WITH_VOIDS")
            || e.is("FACETED_BREP")
            || e.is("SHELL_BASED_SURFACE_MODEL")
            || e.is("CLOSED_SHELL")
            || e.is("OPEN_SHELL")
    })
}

/// The string parameter `k` of `p`, if it is a non-empty string.
fn string_at(p: &[Parameter], k: usize) -> Option<String> {
    match p.get(k) {
        Some(Parameter::String(s)) if !s.trim().is_empty() => Some(s.trim().to_string()),
        _ => None,
    }
}

/// The items of a representation: the list parameter of its
/// `…REPRESENTATION` record (simple or in a complex instance).
fn rep_items(t: &Table, rep: u64) -> Vec<u64> {
    let Ok(e) = t.get(rep) else {
        return Vec::new();
    };
    for r in &e.records {
        if !r.name.ends_with("REPRESENTATION") {
            continue;
        }
        if let Parameter::List(p) = &r.parameter {
            if let Some(Parameter::List(items)) = p.get(1) {
                return items
                    .iter()
                    .filter_map(|x| t.r(rep, x, "items").ok())
                    .collect();
            }
        }
    }
    Vec::new()
}

struct Index<'t, 'g> {
    t: &'t Table,
    geo: &'g Geo<'t>,
    /// `PRODUCT_DEFINITION_SHAPE`s by their definition (a product
    /// definition or an assembly occurrence).
    pds_of: HashMap<u64, Vec<u64>>,
    /// Representations of a `PRODUCT_DEFINITION_SHAPE`.
    reps_of_pds: HashMap<u64, Vec<u64>>,
    /// Placement relationships of an occurrence's `PRODUCT_DEFINITION_SHAPE`.
    cdsr_of_pds: HashMap<u64, Vec<u64>>,
    /// Plain (untransformed) links between representations, both ways.
    same: HashMap<u64, Vec<u64>>,
    /// Occurrences below a product definition.
    children: HashMap<u64, Vec<u64>>,
    /// Product definitions used as a child somewhere.
    used: HashSet<u64>,
    /// The product definition whose shape a representation is.
    pd_of_rep: HashMap<u64, u64>,
}

impl<'t, 'g> Index<'t, 'g> {
    fn new(t: &'t Table, geo: &'g Geo<'t>) -> Result<Self, StepError> {
        let mut ix = Index {
            t,
            geo,
            pds_of: HashMap::new(),
            reps_of_pds: HashMap::new(),
            cdsr_of_pds: HashMap::new(),
            same: HashMap::new(),
            children: HashMap::new(),
            used: HashSet::new(),
            pd_of_rep: HashMap::new(),
        };
        for id in t.ids_of("PRODUCT_DEFINITION_SHAPE") {
            let a = t.args(id, &["PRODUCT_DEFINITION_SHAPE"], 3)?;
            if let Ok(d) = t.r(id, &a[2], "definition") {
                ix.pds_of.entry(d).or_default().push(id);
            }
        }
        for id in t.ids_of("SHAPE_DEFINITION_REPRESENTATION") {
            let a = t.args(id, &["SHAPE_DEFINITION_REPRESENTATION"], 2)?;
            let pds = t.r(id, &a[0], "definition")?;
            let rep = t.r(id, &a[1], "used_representation")?;
            ix.reps_of_pds.entry(pds).or_default().push(rep);
        }
        let mut in_cdsr = HashSet::new();
        for id in t.ids_of("CONTEXT_DEPENDENT_SHAPE_REPRESENTATION") {
            let a = t.args(id, &["CONTEXT_DEPENDENT_SHAPE_REPRESENTATION"], 2)?;
            let rr = t.r(id, &a[0], "representation_relation")?;
            let pds = t.r(id, &a[1], "represented_product_relation")?;
            ix.cdsr_of_pds.entry(pds).or_default().push(rr);
            in_cdsr.insert(rr);
        }
        let mut rels = t.ids_of("SHAPE_REPRESENTATION_RELATIONSHIP");
        rels.extend(t.ids_of("REPRESENTATION_RELATIONSHIP"));
        rels.sort_unstable();
        rels.dedup();
        for id in rels {
            let e = t.get(id)?;
            if in_cdsr.contains(&id) || e.is("REPRESENTATION_RELATIONSHIP_WITH_TRANSFORMATION") {
                continue;
            }
            let a = t.args(
                id,
                &[
                    "REPRESENTATION_RELATIONSHIP",
                    "SHAPE_REPRESENTATION_RELATIONSHIP",
                ],
                4,
            )?;
            let r1 = t.r(id, &a[2], "rep_1")?;
            let r2 = t.r(id, &a[3], "rep_2")?;
            ix.same.entry(r1).or_default().push(r2);
            ix.same.entry(r2).or_default().push(r1);
        }
        for id in t.ids_of("NEXT_ASSEMBLY_USAGE_OCCURRENCE") {
            let a = t.args(id, &["NEXT_ASSEMBLY_USAGE_OCCURRENCE"], 5)?;
            let parent = t.r(id, &a[3], "relating_product_definition")?;
            let child = t.r(id, &a[4], "related_product_definition")?;
            ix.children.entry(parent).or_default().push(id);
            ix.used.insert(child);
        }
        let mut pds = t.ids_of("PRODUCT_DEFINITION");
        pds.extend(t.ids_of("PRODUCT_DEFINITION_WITH_ASSOCIATED_DOCUMENTS"));
        pds.sort_unstable();
        for id in pds {
            for rep in ix.direct_reps(id) {
                ix.pd_of_rep.entry(rep).or_insert(id);
            }
        }
        Ok(ix)
    }

    /// The representations a product definition's shape names directly.
    fn direct_reps(&self, pd: u64) -> Vec<u64> {
        let mut out: Vec<u64> = Vec::new();
        for pds in self.pds_of.get(&pd).into_iter().flatten() {
            out.extend(self.reps_of_pds.get(pds).into_iter().flatten());
        }
        out
    }

    /// The representations of a product definition's shape, closed under
    /// plain representation relationships (not crossing into another
    /// product's own shape: a child's is placed through its occurrence).
    fn reps_of(&self, pd: u64) -> Vec<u64> {
        self.closure(self.direct_reps(pd), Some(pd))
    }

    /// `start` and the representations linked to it by plain
    /// relationships, except those that are the shape of a product other
    /// than `owner`.
    fn closure(&self, mut stack: Vec<u64>, owner: Option<u64>) -> Vec<u64> {
        let mut seen: HashSet<u64> = stack.iter().copied().collect();
        let mut out = Vec::new();
        while let Some(r) = stack.pop() {
            out.push(r);
            for &n in self.same.get(&r).into_iter().flatten() {
                let foreign = matches!(
                    (self.pd_of_rep.get(&n), owner),
                    (Some(&o), Some(w)) if o != w
                );
                if !foreign && seen.insert(n) {
                    stack.push(n);
                }
            }
        }
        out.sort_unstable();
        out.dedup();
        out
    }

    /// The name of a product definition's product (its `name`, else its id).
    fn product_name(&self, pd: u64) -> String {
        let t = self.t;
        let name = || -> Option<String> {
            let a = t
                .args(
                    pd,
                    &[
                        "PRODUCT_DEFINITION",
                        "PRODUCT_DEFINITION_WITH_ASSOCIATED_DOCUMENTS",
                    ],
                    3,
                )
                .ok()?;
            let f = t.r(pd, &a[2], "formation").ok()?;
            let fe = t.get(f).ok()?;
            let fa = fe.records.first()?;
            let Parameter::List(fp) = &fa.parameter else {
                return None;
            };
            let p = t.r(f, fp.get(2)?, "of_product").ok()?;
            let pa = t.args(p, &["PRODUCT"], 2).ok()?;
            string_at(pa, 1).or_else(|| string_at(pa, 0))
        };
        name().unwrap_or_else(|| format!("#{pd}"))
    }

    fn placement(&self, id: u64) -> Result<Rigid, StepError> {
        let e = self.t.get(id)?;
        if !e.is("AXIS2_PLACEMENT_3D") {
            return Err(self.t.err(
                id,
                "a placement of an assembly instance must be an AXIS2_PLACEMENT_3D",
            ));
        }
        Ok(Rigid::from_placement(&self.geo.placement(id)?))
    }

    /// The motion of a transformation entity: an ITEM_DEFINED_TRANSFORMATION
    /// (item₁'s frame onto item₂'s) or a CARTESIAN_TRANSFORMATION_OPERATOR_3D
    /// without scaling.
    fn transformation(&self, id: u64) -> Result<Rigid, StepError> {
        let t = self.t;
        let e = t.get(id)?;
        if e.is("ITEM_DEFINED_TRANSFORMATION") {
            let a = t.args(id, &["ITEM_DEFINED_TRANSFORMATION"], 4)?;
            let p1 = self.placement(t.r(id, &a[2], "transform_item_1")?)?;
            let p2 = self.placement(t.r(id, &a[3], "transform_item_2")?)?;
            return Ok(p2.then_after(&p1.inverse()));
        }
        if e.is("CARTESIAN_TRANSFORMATION_OPERATOR_3D") {
            let a = t.args(
                id,
                &[
                    "CARTESIAN_TRANSFORMATION_OPERATOR",
                    "CARTESIAN_TRANSFORMATION_OPERATOR_3D",
                ],
                4,
            )?;
            let given = |k: usize| {
                !matches!(
                    a.get(k),
                    None | Some(Parameter::NotProvided) | Some(Parameter::Omitted)
                )
            };
            if given(4) {
                let s = t.real(id, &a[4], "scale")?;
                if (s - 1.0).abs() > 1e-9 {
                    return Err(t.err(id, format!("a scaled placement ({s}) is not supported")));
                }
            }
            let o = self.geo.point(t.r(id, &a[3], "local_origin")?)?;
            let dir = |k: usize, d: nalgebra::Vector3<f64>| -> Result<_, StepError> {
                if given(k) {
                    self.geo.direction(t.r(id, &a[k], "axis")?)
                } else {
                    Ok(d)
                }
            };
            let x1 = dir(1, nalgebra::Vector3::x())?;
            let z = dir(5, nalgebra::Vector3::z())?;
            let x = (x1 - z * z.dot(&x1))
                .try_normalize(1e-9)
                .ok_or_else(|| t.err(id, "axis1 is parallel to axis3"))?;
            return Ok(Rigid::from_placement(&Placement {
                o,
                x,
                y: z.cross(&x),
                z,
            }));
        }
        Err(t.err(
            id,
            "unsupported transformation (supported: ITEM_DEFINED_TRANSFORMATION, \
             CARTESIAN_TRANSFORMATION_OPERATOR_3D)",
        ))
    }

    /// The placement of a child whose shape is `child_reps` by the
    /// relationship `rr` (its rep_1 the child's normally; when rep_2 is,
    /// the motion is inverted).
    fn relation(&self, rr: u64, child_reps: &[u64]) -> Result<Rigid, StepError> {
        let t = self.t;
        let a = t.args(
            rr,
            &[
                "REPRESENTATION_RELATIONSHIP",
                "SHAPE_REPRESENTATION_RELATIONSHIP",
            ],
            4,
        )?;
        let r1 = t.r(rr, &a[2], "rep_1")?;
        let r2 = t.r(rr, &a[3], "rep_2")?;
        let e = t.get(rr)?;
        let Some(w) = e.part("REPRESENTATION_RELATIONSHIP_WITH_TRANSFORMATION") else {
            return Ok(Rigid::identity());
        };
        let w = w
            .first()
            .ok_or_else(|| t.err(rr, "missing transformation_operator"))?;
        let m = self.transformation(t.r(rr, w, "transformation_operator")?)?;
        if !child_reps.contains(&r1) && child_reps.contains(&r2) {
            Ok(m.inverse())
        } else {
            Ok(m)
        }
    }
}

struct Walk<'a, 't, 'g> {
    ix: &'a Index<'t, 'g>,
    out: Vec<Instance>,
}

impl Walk<'_, '_, '_> {
    fn push(&mut self, inst: Instance) -> Result<(), StepError> {
        if self.out.len() >= MAX_INSTANCES {
            return Err(StepError::file(
                &self.ix.t.source,
                format!("the assembly has more than {MAX_INSTANCES} part instances"),
            ));
        }
        self.out.push(inst);
        Ok(())
    }

    fn deep(&self, id: u64, depth: usize) -> Result<(), StepError> {
        if depth > MAX_DEPTH {
            return Err(self.ix.t.err(
                id,
                format!("assembly nesting deeper than {MAX_DEPTH} (or a cycle)"),
            ));
        }
        Ok(())
    }

    /// The shape items of representations `reps`, placed by `xf`; mapped
    /// items are followed.
    fn items(
        &mut self,
        reps: &[u64],
        xf: Rigid,
        name: &str,
        path: &[String],
        depth: usize,
    ) -> Result<(), StepError> {
        let t = self.ix.t;
        let mut roots = Vec::new();
        for &rep in reps {
            for it in rep_items(t, rep) {
                if is_shape_root(t, it) {
                    roots.push(it);
                } else if t.get(it)?.is("MAPPED_ITEM") {
                    self.deep(it, depth)?;
                    let a = t.args(it, &["MAPPED_ITEM"], 3)?;
                    let map = t.r(it, &a[1], "mapping_source")?;
                    let target = self.ix.placement(t.r(it, &a[2], "mapping_target")?)?;
                    let ma = t.args(map, &["REPRESENTATION_MAP"], 2)?;
                    let origin = self.ix.placement(t.r(map, &ma[0], "mapping_origin")?)?;
                    let mapped = t.r(map, &ma[1], "mapped_representation")?;
                    let m = xf.then_after(&target.then_after(&origin.inverse()));
                    let owner = self.ix.pd_of_rep.get(&mapped).copied();
                    let sub = self.ix.closure(vec![mapped], owner);
                    let sub_name =
                        owner.map_or_else(|| name.to_string(), |pd| self.ix.product_name(pd));
                    self.items(&sub, m, &sub_name, path, depth + 1)?;
                }
            }
        }
        roots.sort_unstable();
        roots.dedup();
        let many = roots.len() > 1;
        for (k, root) in roots.into_iter().enumerate() {
            let mut n = name.to_string();
            // the path, unless it only repeats the name (an occurrence named
            // after its product)
            if !path.is_empty() && path != [name] {
                n = format!("{n} ({})", path.join("/"));
            }
            if many {
                n = format!("{n} solid {}", k + 1);
            }
            self.push(Instance { root, xf, name: n })?;
        }
        Ok(())
    }

    fn product(
        &mut self,
        pd: u64,
        xf: Rigid,
        path: &mut Vec<String>,
        depth: usize,
    ) -> Result<(), StepError> {
        self.deep(pd, depth)?;
        let ix = self.ix;
        let t = ix.t;
        let reps = ix.reps_of(pd);
        let name = ix.product_name(pd);
        self.items(&reps, xf, &name, path, depth)?;
        let has_mapped = reps.iter().any(|&r| {
            rep_items(t, r)
                .iter()
                .any(|&i| t.get(i).is_ok_and(|e| e.is("MAPPED_ITEM")))
        });
        for &nauo in ix.children.get(&pd).into_iter().flatten() {
            let a = t.args(nauo, &["NEXT_ASSEMBLY_USAGE_OCCURRENCE"], 5)?;
            let child = t.r(nauo, &a[4], "related_product_definition")?;
            // the occurrence's name, unless it is the generic one some
            // writers give every occurrence (then its description, its id)
            let label = string_at(a, 1)
                .filter(|n| !n.eq_ignore_ascii_case("next assembly relationship"))
                .or_else(|| string_at(a, 2))
                .or_else(|| string_at(a, 0))
                .unwrap_or_else(|| format!("#{nauo}"));
            let rels: Vec<u64> = ix
                .pds_of
                .get(&nauo)
                .into_iter()
                .flatten()
                .flat_map(|pds| ix.cdsr_of_pds.get(pds).into_iter().flatten().copied())
                .collect();
            path.push(label);
            if rels.is_empty() {
                // no placement of its own: in place, unless the parent's
                // shape already places it through mapped items
                if !has_mapped {
                    self.product(child, xf, path, depth + 1)?;
                }
            } else {
                let child_reps = ix.reps_of(child);
                for rr in rels {
                    let m = ix.relation(rr, &child_reps)?;
                    self.product(child, xf.then_after(&m), path, depth + 1)?;
                }
            }
            path.pop();
        }
        Ok(())
    }
}

/// Every placed shape item reachable from the top products (product
/// definitions that are no assembly's child), in file order of the
/// products. Empty when the file has no product structure.
pub(crate) fn instances(t: &Table, geo: &Geo) -> Result<Vec<Instance>, StepError> {
    let ix = Index::new(t, geo)?;
    let mut w = Walk {
        ix: &ix,
        out: Vec::new(),
    };
    let mut pds = t.ids_of("PRODUCT_DEFINITION");
    pds.extend(t.ids_of("PRODUCT_DEFINITION_WITH_ASSOCIATED_DOCUMENTS"));
    pds.sort_unstable();
    pds.dedup();
    for pd in pds {
        if !ix.used.contains(&pd) {
            w.product(pd, Rigid::identity(), &mut Vec::new(), 0)?;
        }
    }
    // names repeated (occurrences with the same label) get a number each
    let mut count: HashMap<String, usize> = HashMap::new();
    for i in &w.out {
        *count.entry(i.name.clone()).or_default() += 1;
    }
    let mut seen: HashMap<String, usize> = HashMap::new();
    for i in &mut w.out {
        if count[&i.name] > 1 {
            let k = seen.entry(i.name.clone()).or_default();
            *k += 1;
            i.name = format!("{} [{k}]", i.name);
        }
    }
    Ok(w.out)
}

/// Axis-aligned bounding box of model volume `v`: the sub-model of its
/// faces, their edges and vertices (see [`Model::bbox`]). For checking where
/// the parts of an assembly were placed.
pub fn volume_bbox(model: &Model, v: usize) -> Option<(P3, P3)> {
    let vol = model.volumes.get(v)?;
    let mut sub = Model::default();
    let mut edges: Vec<u32> = Vec::new();
    for &f in &vol.faces {
        let face = &model.faces[f as usize];
        edges.extend(
            face.loops
                .iter()
                .flat_map(|l| l.edges.iter().map(|u| u.edge)),
        );
        sub.faces.push(face.clone());
    }
    edges.sort_unstable();
    edges.dedup();
    for e in edges {
        let edge = &model.edges[e as usize];
        for p in [edge.start, edge.end] {
            sub.vertices.push(model.vertices[p as usize].clone());
        }
        sub.edges.push(edge.clone());
    }
    // the copied faces' loops index the full model's edges; bbox reads only
    // the surfaces, edges and vertices as lists
    for f in &mut sub.faces {
        f.loops.clear();
    }
    sub.bbox()
}
