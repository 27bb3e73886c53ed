//! Node → element tables, shared by the planar improvement
//! ([`crate::face::improve`]) and the volume passes (through
//! [`crate::volume::tet::star::node_tets`]).

/// The elements around each of `n` nodes, as a compressed table: those of
/// node v are `inc[start[v]..start[v + 1]]`, in increasing order. `index`
/// reads a node index from an element's corner.
///
/// Why a compressed table and not a `Vec` per node: it is built on
/// meshes of millions of elements (case K: 2.75 M tetrahedra, 470k nodes),
/// where one allocation per node cost more than the passes that read it.
pub(crate) fn node_elements<const K: usize, I: Copy>(
    n: usize,
    elems: &[[I; K]],
    index: impl Fn(I) -> usize,
) -> (Vec<u32>, Vec<u32>) {
    let mut start = vec![0u32; n + 1];
    for e in elems {
        for &v in e {
            start[index(v) + 1] += 1;
        }
    }
    for k in 0..n {
        start[k + 1] += start[k];
    }
    let mut fill = start.clone();
    let mut inc = vec![0u32; start[n] as usize];
    for (ei, e) in elems.iter().enumerate() {
        for &v in e {
            let v = index(v);
            inc[fill[v] as usize] = ei as u32;
            fill[v] += 1;
        }
    }
    (start, inc)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two triangles sharing an edge: each node lists exactly the
    /// triangles that hold it, in increasing order.
    #[test]
    fn rows_hold_the_elements_of_each_node() {
        let tris: [[usize; 3]; 2] = [[0, 1, 2], [2, 1, 3]];
        let (start, inc) = node_elements(4, &tris, |v| v);
        let row = |v: usize| &inc[start[v] as usize..start[v + 1] as usize];
        assert_eq!(row(0), &[0]);
        assert_eq!(row(1), &[0, 1]);
        assert_eq!(row(2), &[0, 1]);
        assert_eq!(row(3), &[1]);
    }
}
