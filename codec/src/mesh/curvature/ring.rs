//! The 1-ring of a vertex as one ordered polygon: what its removal leaves to fill.

/// The neighbours of a vertex in fan order, as its faces wind.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Ring {
    pub vertices: Vec<u32>,
    /// An open fan (the vertex is on a boundary): the polygon's closing edge from the last
    /// vertex back to the first becomes boundary.
    pub open: bool,
}

/// Orders the neighbours of `v` from its incident `faces`; `None` unless they form one
/// closed fan or one open strip (a non-manifold or pinched vertex is not removable).
pub fn ring(v: u32, faces: &[[u32; 3]]) -> Option<Ring> {
    // Each face [v, a, b] gives the fan edge a → b.
    let mut next: Vec<(u32, u32)> = Vec::with_capacity(faces.len());
    for f in faces {
        let k = f.iter().position(|&x| x == v)?;
        let (a, b) = (f[(k + 1) % 3], f[(k + 2) % 3]);
        if next.iter().any(|&(x, _)| x == a) {
            return None;
        }
        next.push((a, b));
    }
    let start = next
        .iter()
        .find(|&&(a, _)| !next.iter().any(|&(_, b)| b == a))
        .map_or(next.first()?.0, |&(a, _)| a);
    let open = next
        .iter()
        .any(|&(a, _)| !next.iter().any(|&(_, b)| b == a));
    let mut vertices = vec![start];
    let mut at = start;
    while let Some(&(_, b)) = next.iter().find(|&&(a, _)| a == at) {
        if b == start {
            break;
        }
        if vertices.len() > next.len() {
            return None;
        }
        vertices.push(b);
        at = b;
    }
    // Every fan edge used once: one fan, not two sharing the vertex.
    let expected = if open { next.len() + 1 } else { next.len() };
    (vertices.len() == expected).then_some(Ring { vertices, open })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closed_open_and_pinched_fans() {
        let closed = [[0, 1, 2], [0, 2, 3], [0, 3, 1]];
        assert_eq!(
            ring(0, &closed),
            Some(Ring {
                vertices: vec![1, 2, 3],
                open: false
            })
        );
        let open = [[0, 2, 3], [0, 1, 2]];
        assert_eq!(
            ring(0, &open),
            Some(Ring {
                vertices: vec![1, 2, 3],
                open: true
            })
        );
        // Two fans through one vertex (a bow tie).
        let pinched = [[0, 1, 2], [0, 2, 1], [0, 3, 4], [0, 4, 3]];
        assert_eq!(ring(0, &pinched), None);
    }
}
