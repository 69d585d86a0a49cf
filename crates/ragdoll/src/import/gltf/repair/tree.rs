//! The node tree as the repairs query it, built once and without recursion, so a deep or
//! wide hierarchy costs time in proportion to its size, not its depth times its joints.

use serde_json::{Map, Value};

use super::count;

/// Each node's parent and root, and when a depth-first walk enters and leaves it, so that
/// "is `a` above `n`" is two comparisons. A node listed as a child twice keeps its first
/// parent; nodes on a loop (which the importer refuses) are reached from no root, are their
/// own root and lie above or below no other node.
pub(super) struct Tree {
    parent: Vec<Option<usize>>,
    top: Vec<usize>,
    enter: Vec<usize>,
    exit: Vec<usize>,
}

/// `enter` of a node no walk reached.
const UNREACHED: usize = usize::MAX;

impl Tree {
    pub(super) fn new(obj: &Map<String, Value>) -> Tree {
        let n = count(obj, "nodes");
        let mut parent = vec![None; n];
        let mut children = vec![Vec::new(); n];
        let nodes = obj.get("nodes").and_then(Value::as_array);
        for (i, node) in nodes.into_iter().flatten().enumerate() {
            let listed = node.get("children").and_then(Value::as_array);
            for c in listed.into_iter().flatten().filter_map(Value::as_u64) {
                let c = c as usize;
                if c != i && parent.get(c) == Some(&None) {
                    parent[c] = Some(i);
                    children[i].push(c);
                }
            }
        }
        let mut top: Vec<usize> = (0..n).collect();
        let (mut enter, mut exit) = (vec![UNREACHED; n], vec![0; n]);
        let mut clock = 0;
        for root in (0..n).filter(|&i| parent[i].is_none()) {
            enter[root] = clock;
            clock += 1;
            let mut stack = vec![(root, 0)];
            while let Some((node, next)) = stack.last_mut() {
                let node = *node;
                if let Some(&c) = children[node].get(*next) {
                    *next += 1;
                    enter[c] = clock;
                    clock += 1;
                    top[c] = root;
                    stack.push((c, 0));
                } else {
                    exit[node] = clock;
                    clock += 1;
                    stack.pop();
                }
            }
        }
        Tree {
            parent,
            top,
            enter,
            exit,
        }
    }

    /// How many nodes there are.
    pub(super) fn len(&self) -> usize {
        self.parent.len()
    }

    /// The root above `n` (`n` itself for a root).
    pub(super) fn top(&self, n: usize) -> usize {
        self.top[n]
    }

    /// Whether `a` is `n` or one of its ancestors.
    pub(super) fn holds(&self, a: usize, n: usize) -> bool {
        a == n
            || (self.enter[a] != UNREACHED
                && self.enter[n] != UNREACHED
                && self.enter[a] <= self.enter[n]
                && self.exit[n] <= self.exit[a])
    }

    /// The nearest node that holds each of `nodes`, when one does.
    pub(super) fn common_root(&self, nodes: &[usize]) -> Option<usize> {
        let &first = nodes.first()?;
        if nodes.iter().any(|&n| self.enter[n] == UNREACHED) {
            return nodes.iter().all(|&n| n == first).then_some(first);
        }
        if nodes.iter().any(|&n| self.top[n] != self.top[first]) {
            return None;
        }
        // A node above the first and the last entered holds every one entered between.
        let lo = *nodes.iter().min_by_key(|&&n| self.enter[n])?;
        let hi = *nodes.iter().max_by_key(|&&n| self.enter[n])?;
        let mut a = lo;
        while !self.holds(a, hi) {
            a = self.parent[a]?;
        }
        Some(a)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn ancestors_and_common_roots() {
        // 0 ─ 1 ─ 2, 1 ─ 3; 4 alone; 5 and 6 a loop.
        let doc = json!({"nodes": [
            {"children": [1]}, {"children": [2, 3]}, {}, {}, {},
            {"children": [6]}, {"children": [5]}
        ]});
        let t = Tree::new(doc.as_object().unwrap());
        assert!(t.holds(0, 2) && t.holds(1, 3) && t.holds(2, 2));
        assert!(!t.holds(2, 1) && !t.holds(3, 2) && !t.holds(0, 4) && !t.holds(5, 6));
        assert_eq!((t.top(3), t.top(4), t.top(6)), (0, 4, 6));
        assert_eq!(t.common_root(&[2, 3]), Some(1));
        assert_eq!(t.common_root(&[3, 1]), Some(1));
        assert_eq!(t.common_root(&[2, 0]), Some(0));
        assert_eq!(t.common_root(&[2, 4]), None);
        assert_eq!(t.common_root(&[5, 6]), None);
        assert_eq!(t.common_root(&[]), None);
    }

    #[test]
    fn a_deep_chain_is_walked_without_recursion() {
        let n = 200_000;
        let nodes: Vec<Value> = (0..n)
            .map(|i| {
                if i + 1 < n {
                    json!({"children": [i + 1]})
                } else {
                    json!({})
                }
            })
            .collect();
        let doc = json!({ "nodes": nodes });
        let t = Tree::new(doc.as_object().unwrap());
        assert!(t.holds(0, n - 1));
        assert_eq!(t.common_root(&[n - 1, n / 2]), Some(n / 2));
        assert_eq!(t.top(n - 1), 0);
    }
}
