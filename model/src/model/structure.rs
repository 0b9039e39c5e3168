//! Structure the field has, found from its graph: a partitioned field q̇ = a(p), ṗ = b(q)
//! (for Störmer–Verlet and the partitioned Taylor/tape functions).

use super::Model;
use crate::ir::{Input, Node};

impl Model {
    /// Splits the state variables into two groups q, p with q̇ = a(p) and ṗ = b(q), if possible:
    /// a 2-colouring of the graph with an edge between two variables whenever one's rate depends
    /// on the other. The group of the first state variable is q.
    pub fn partition(&self) -> Option<Vec<bool>> {
        let g = &self.graph;
        let block_of = |i: usize| {
            self.state
                .iter()
                .position(|s| (s.offset..s.offset + s.shape.len()).contains(&i))
        };
        let nb = self.state.len();
        let mut edges = vec![Vec::new(); nb];
        for (b, s) in self.state.iter().enumerate() {
            for &rate in &self.field[s.offset..s.offset + s.shape.len()] {
                for id in g.reachable(&[rate]) {
                    if let Node::Input(Input::State(i)) = g.node(id) {
                        let c = block_of(*i as usize)?;
                        if c == b {
                            return None; // a rate that depends on its own group
                        }
                        edges[b].push(c);
                        edges[c].push(b);
                    }
                }
            }
        }
        self.colour_blocks(&edges)
    }

    /// The partition of [`Model::partition`] from its edges between state variables (`edges[b]`
    /// lists the variables whose rates depend on b's, or on which b's rate depends), no
    /// variable's rate reading its own group: a 2-colouring, the first variable's group q.
    pub(crate) fn colour_blocks(&self, edges: &[Vec<usize>]) -> Option<Vec<bool>> {
        let nb = self.state.len();
        if edges.iter().all(Vec::is_empty) {
            return None;
        }
        let mut colour: Vec<Option<bool>> = vec![None; nb];
        for start in 0..nb {
            if colour[start].is_some() {
                continue;
            }
            colour[start] = Some(true);
            let mut stack = vec![start];
            while let Some(b) = stack.pop() {
                let cb = colour[b]?;
                for &c in &edges[b] {
                    match colour[c] {
                        None => {
                            colour[c] = Some(!cb);
                            stack.push(c);
                        }
                        Some(cc) if cc == cb => return None,
                        Some(_) => {}
                    }
                }
            }
        }
        let mut is_q = vec![false; self.dim()];
        for (b, s) in self.state.iter().enumerate() {
            is_q[s.offset..s.offset + s.shape.len()].fill(colour[b] == Some(true));
        }
        Some(is_q)
    }
}
