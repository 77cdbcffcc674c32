//! Parameters defined through one another form a graph. [`walk`] visits it once, without
//! recursion, each parameter after those it depends on: validation uses it to find cycles and
//! chains too long ([`crate::model::MAX_PARAMETER_CHAIN`]), binding to evaluate the values in
//! an order where every dependency already has one. One walk, so both report a cycle alike.

/// Why a [`walk`] stopped early.
#[derive(Debug, PartialEq, Eq)]
pub(crate) enum WalkError<E> {
    /// A cycle: the path from the first node met twice to the node reached again, both ends
    /// included (`[a, b, a]`).
    Cycle {
        /// The nodes of the cycle, the repeated one first and last.
        chain: Vec<usize>,
    },
    /// A node with a chain of dependencies longer than the limit below it.
    TooLong {
        /// The node.
        node: usize,
    },
    /// An edge or a finished node reported an error of the caller's own.
    Stopped(E),
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Mark {
    New,
    OnPath,
    Done,
}

struct Frame<E> {
    node: usize,
    dependencies: std::vec::IntoIter<Result<usize, E>>,
    /// The longest chain below the node among the dependencies finished so far.
    height: usize,
}

/// Depth-first walk of `count` nodes, roots in index order: `edges(n)` lists what node `n`
/// depends on, in order (an `Err` among them stops the walk when it is reached, as a recursive
/// evaluation would meet it), and `finish(n)` runs once all of `n`'s dependencies are
/// finished. A chain of more than `limit` dependencies below a node is an error.
///
/// The order of visits, and therefore which of several problems is reported, is the one of
/// the recursive evaluation `eval(n) = { for d in edges(n) { eval(d) }; finish(n) }`.
pub(crate) fn walk<E>(
    count: usize,
    mut edges: impl FnMut(usize) -> Vec<Result<usize, E>>,
    limit: Option<usize>,
    mut finish: impl FnMut(usize) -> Result<(), E>,
) -> Result<(), WalkError<E>> {
    let mut mark = vec![Mark::New; count];
    let mut height = vec![0usize; count];
    let mut stack: Vec<Frame<E>> = Vec::new();
    for root in 0..count {
        if mark[root] != Mark::New {
            continue;
        }
        mark[root] = Mark::OnPath;
        stack.push(Frame {
            node: root,
            dependencies: edges(root).into_iter(),
            height: 0,
        });
        while let Some(top) = stack.last_mut() {
            match top.dependencies.next() {
                Some(Err(e)) => return Err(WalkError::Stopped(e)),
                Some(Ok(dep)) => match mark[dep] {
                    Mark::Done => top.height = top.height.max(height[dep] + 1),
                    Mark::OnPath => {
                        let from = stack.iter().position(|f| f.node == dep).unwrap_or(0);
                        let mut chain: Vec<usize> = stack[from..].iter().map(|f| f.node).collect();
                        chain.push(dep);
                        return Err(WalkError::Cycle { chain });
                    }
                    Mark::New => {
                        mark[dep] = Mark::OnPath;
                        stack.push(Frame {
                            node: dep,
                            dependencies: edges(dep).into_iter(),
                            height: 0,
                        });
                    }
                },
                None => {
                    let Frame {
                        node, height: h, ..
                    } = stack.pop().expect("the loop saw a top");
                    mark[node] = Mark::Done;
                    height[node] = h;
                    if limit.is_some_and(|limit| h > limit) {
                        return Err(WalkError::TooLong { node });
                    }
                    finish(node).map_err(WalkError::Stopped)?;
                    if let Some(parent) = stack.last_mut() {
                        parent.height = parent.height.max(h + 1);
                    }
                }
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn order(deps: &[&[usize]], limit: Option<usize>) -> Result<Vec<usize>, WalkError<()>> {
        let mut out = Vec::new();
        walk(
            deps.len(),
            |n| deps[n].iter().map(|d| Ok(*d)).collect(),
            limit,
            |n| {
                out.push(n);
                Ok(())
            },
        )?;
        Ok(out)
    }

    #[test]
    fn every_node_comes_after_its_dependencies() {
        assert_eq!(order(&[&[2], &[0, 2], &[]], None), Ok(vec![2, 0, 1]));
    }

    #[test]
    fn a_cycle_is_reported_from_the_repeated_node() {
        assert_eq!(
            order(&[&[1], &[2], &[1]], None),
            Err(WalkError::Cycle {
                chain: vec![1, 2, 1]
            })
        );
        assert_eq!(
            order(&[&[0]], None),
            Err(WalkError::Cycle { chain: vec![0, 0] })
        );
    }

    #[test]
    fn chains_longer_than_the_limit_are_refused_without_recursion() {
        let n = 100_000;
        let deps: Vec<Vec<usize>> = (0..n)
            .map(|i| if i + 1 < n { vec![i + 1] } else { vec![] })
            .collect();
        let refs: Vec<&[usize]> = deps.iter().map(Vec::as_slice).collect();
        assert_eq!(order(&refs, None).map(|o| o.len()), Ok(n));
        assert_eq!(
            order(&refs, Some(256)),
            Err(WalkError::TooLong { node: n - 1 - 257 })
        );
    }

    #[test]
    fn an_edge_error_stops_the_walk_where_it_is_met() {
        let mut finished = Vec::new();
        let r = walk(
            2,
            |n| {
                if n == 0 {
                    vec![Ok(1), Err("bad")]
                } else {
                    vec![]
                }
            },
            None,
            |n| {
                finished.push(n);
                Ok(())
            },
        );
        assert_eq!(r, Err(WalkError::Stopped("bad")));
        assert_eq!(finished, vec![1]);
    }
}
