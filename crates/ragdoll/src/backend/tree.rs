//! A ragdoll's bodies as a tree through its joints, for the limit projections of the engines
//! and of the particle backend: joints parents first, and each joint's subtree as one run
//! of a depth-first order, so a long chain (a 2,000-link tail) costs linear memory and
//! time instead of a list per joint and a walk to the root per body.

/// Bodies and joints of one ragdoll as a forest: each body hangs from the first joint that
/// names it as child; bodies no joint reaches (and every cycle, which a spec may hold) start
/// trees of their own.
#[derive(Clone, Debug, Default)]
pub(crate) struct JointTree {
    /// Joint indices, parents before children (by the depth of their child).
    pub order: Vec<usize>,
    /// Bodies in depth-first preorder.
    preorder: Vec<usize>,
    /// Each body's position in `preorder` and the end of its subtree's run there.
    span: Vec<(usize, usize)>,
    /// Each joint's child body.
    child: Vec<usize>,
}

impl JointTree {
    /// The tree of `bodies` bodies linked by `joints` (parent, child), indices within the
    /// ragdoll. Indices out of range are ignored (a spec is validated before this).
    pub(crate) fn new(bodies: usize, joints: &[(usize, usize)]) -> Self {
        let mut parent_joint: Vec<Option<usize>> = vec![None; bodies];
        for (k, &(p, c)) in joints.iter().enumerate() {
            if p < bodies && c < bodies && p != c && parent_joint[c].is_none() {
                parent_joint[c] = Some(k);
            }
        }
        // Children lists in one flat array (counting sort by parent).
        let mut first = vec![0usize; bodies + 1];
        for k in parent_joint.iter().flatten() {
            first[joints[*k].0 + 1] += 1;
        }
        for b in 0..bodies {
            first[b + 1] += first[b];
        }
        let mut fill = first.clone();
        let mut children = vec![0usize; first[bodies]];
        for (c, pj) in parent_joint.iter().enumerate() {
            if let Some(k) = pj {
                let p = joints[*k].0;
                children[fill[p]] = c;
                fill[p] += 1;
            }
        }
        // Depth-first from every root, then from whatever a cycle left unvisited.
        let mut preorder = Vec::with_capacity(bodies);
        let mut span = vec![(usize::MAX, 0usize); bodies];
        let mut depth = vec![0usize; bodies];
        let mut stack: Vec<(usize, usize)> = Vec::new();
        let roots = (0..bodies).filter(|&b| parent_joint[b].is_none());
        for start in roots.chain(0..bodies) {
            if span[start].0 != usize::MAX {
                continue;
            }
            span[start].0 = preorder.len();
            preorder.push(start);
            stack.push((start, first[start]));
            while let Some(top) = stack.last_mut() {
                let (b, next) = *top;
                if next < first[b + 1] {
                    top.1 += 1;
                    let c = children[next];
                    if span[c].0 == usize::MAX {
                        span[c].0 = preorder.len();
                        depth[c] = depth[b] + 1;
                        preorder.push(c);
                        stack.push((c, first[c]));
                    }
                } else {
                    span[b].1 = preorder.len();
                    stack.pop();
                }
            }
        }
        let child: Vec<usize> = joints.iter().map(|&(_, c)| c.min(bodies)).collect();
        let mut order: Vec<usize> = (0..joints.len()).collect();
        order.sort_by_key(|&k| depth.get(child[k]).copied().unwrap_or(0));
        JointTree {
            order,
            preorder,
            span,
            child,
        }
    }

    /// The bodies joint `k` carries: its child and everything below it.
    pub(crate) fn subtree(&self, k: usize) -> &[usize] {
        match self.span.get(self.child[k]) {
            Some(&(s, e)) => &self.preorder[s..e],
            None => &[],
        }
    }

    /// Whether body `b` is in joint `k`'s subtree.
    pub(crate) fn in_subtree(&self, k: usize, b: usize) -> bool {
        match (self.span.get(self.child[k]), self.span.get(b)) {
            (Some(&(s, e)), Some(&(p, _))) => (s..e).contains(&p),
            _ => false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn subtrees_and_order_of_a_small_tree() {
        // 0 ─┬─ 1 ── 2
        //    └─ 3
        let tree = JointTree::new(4, &[(1, 2), (0, 1), (0, 3)]);
        assert_eq!(tree.order, vec![1, 2, 0]);
        let mut sub = tree.subtree(1).to_vec();
        sub.sort_unstable();
        assert_eq!(sub, vec![1, 2]);
        assert_eq!(tree.subtree(0), &[2]);
        assert!(tree.in_subtree(1, 2) && !tree.in_subtree(1, 3) && !tree.in_subtree(2, 0));
    }

    #[test]
    fn a_long_chain_and_a_cycle_cost_linear_memory() {
        let n = 20_000;
        let chain: Vec<(usize, usize)> = (1..n).map(|b| (b - 1, b)).collect();
        let tree = JointTree::new(n, &chain);
        assert_eq!(tree.subtree(0).len(), n - 1);
        assert_eq!(tree.preorder.len(), n);
        assert!(tree.order.windows(2).all(|w| w[0] < w[1]));
        // A cycle has no root: it still gets an order and finite subtrees.
        let tree = JointTree::new(3, &[(0, 1), (1, 2), (2, 0)]);
        assert_eq!(tree.preorder.len(), 3);
        assert!(tree.subtree(2).len() <= 3);
    }
}
